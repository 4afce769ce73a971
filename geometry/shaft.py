"""OpenCASCADE solid of a stepped shaft with its tagged surfaces."""

from __future__ import annotations

import logging
import math

import gmsh
import numpy as np

from .model import PartEntities
from .params import ShaftParams

log = logging.getLogger(__name__)

_TOL = 1e-6  # m, matching tolerance on OCC bounding boxes


Segment = tuple[float, float, float, str]
"""An axial segment ``(z0, z1, radius, label)`` of a solid of revolution, local z [m]."""


def _profile_points(segments: list[Segment], length: float) -> list[tuple[float, float]]:
    """Closed ``(r, z)`` half-profile of consecutive segments in local coordinates [m]."""
    pts: list[tuple[float, float]] = [(0.0, 0.0)]
    r_prev = 0.0
    for z0, z1, r, _ in segments:
        if not math.isclose(r, r_prev, abs_tol=1e-12):
            pts.append((r, z0))
        pts.append((r, z1))
        r_prev = r
    pts.append((0.0, length))
    return pts


def build_revolved(segments: list[Segment], name: str, origin: tuple[float, float, float],
                   inset: float, untagged: tuple[str, ...]) -> tuple[PartEntities, dict]:
    """Add a solid of revolution about ``z`` through ``origin`` made of ``segments`` (from
    local ``z = 0`` towards ``+z``) and tag the lateral face of each segment.

    The face of a segment labelled ``label`` becomes the surface ``{name}/{label}`` with
    its centreline point, except the labels in ``untagged``. A line along the axis, from
    ``inset`` to ``length - inset``, is embedded in the volume: it gives the thin shaft
    interior nodes, which avoids "cap" tets with all four vertices on the lateral surface
    (these become flat once their edges are curved onto the cylinder).

    Returns
    -------
    (PartEntities, dict)
        The part (volume, surfaces, centres) and the bounding box of each boundary face
        (face tag -> box), for the caller's own faces. The OCC model is synchronised.
    """
    x0, y0, z0 = (float(c) for c in origin)
    length = segments[-1][1]
    occ = gmsh.model.occ
    pts = _profile_points(segments, length)
    ptags = [occ.addPoint(x0 + r, y0, z0 + z) for r, z in pts]
    n = len(ptags)
    lines = [occ.addLine(ptags[i], ptags[(i + 1) % n]) for i in range(n)]
    loop = occ.addCurveLoop(lines)
    face = occ.addPlaneSurface([loop])
    out = occ.revolve([(2, face)], x0, y0, z0, 0.0, 0.0, 1.0, 2.0 * math.pi)
    vols = [t for d, t in out if d == 3]
    if len(vols) != 1:
        raise RuntimeError(f"shaft '{name}': revolve produced {len(vols)} volumes, expected 1")
    vol = vols[0]
    occ.remove([(2, face)], recursive=True)
    occ.synchronize()

    faces = [t for d, t in gmsh.model.getBoundary([(3, vol)], oriented=False) if d == 2]
    bboxes = {t: gmsh.model.getBoundingBox(2, t) for t in faces}

    def lateral(za: float, zb: float, r: float) -> list[int]:
        hit = [t for t, b in bboxes.items()
               if abs(b[2] - za) < _TOL and abs(b[5] - zb) < _TOL
               and abs(b[3] - (x0 + r)) < _TOL and abs(b[0] - (x0 - r)) < _TOL]
        return hit

    pa = occ.addPoint(x0, y0, z0 + inset)
    pb = occ.addPoint(x0, y0, z0 + length - inset)
    axis = occ.addLine(pa, pb)
    occ.synchronize()
    gmsh.model.mesh.embed(1, [axis], 3, vol)

    part = PartEntities(volume=vol)
    for za, zb, r, label in segments:
        if label in untagged:
            continue
        tags = lateral(z0 + za, z0 + zb, r)
        if len(tags) != 1:
            raise RuntimeError(f"shaft '{name}': found {len(tags)} lateral faces for "
                               f"segment '{label}' at z = [{z0 + za:g}, {z0 + zb:g}] m")
        key = f"{name}/{label}"
        part.surfaces[key] = tags
        part.centres[key] = np.array([x0, y0, z0 + 0.5 * (za + zb)])
    return part, bboxes


def end_face(bboxes: dict, name: str, z: float, radius: float, x0: float) -> list[int]:
    """The flat end face of a shaft at global ``z`` with outer ``radius`` (axis at ``x0``);
    RuntimeError unless exactly one."""
    end = [t for t, b in bboxes.items()
           if abs(b[2] - z) < _TOL and abs(b[5] - z) < _TOL and abs(b[3] - (x0 + radius)) < _TOL]
    if len(end) != 1:
        raise RuntimeError(f"shaft '{name}': found {len(end)} end faces at z = {z:g} m")
    return end


def build_shaft(params: ShaftParams, name: str,
                origin: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> PartEntities:
    """Add a shaft solid to the current gmsh OCC model and find its surfaces.

    The shaft axis is parallel to ``z`` through ``origin``; ``origin`` is the
    centre of the coupling end face and the shaft extends towards ``+z``.

    Parameters
    ----------
    params : ShaftParams
        Shaft dimensions [m]; validated here.
    name : str
        Shaft name used as group prefix (``"in"``/``"out"``).
    origin : tuple of 3 floats
        Global position of the coupling end centre [m].

    Returns
    -------
    PartEntities
        Volume tag, surfaces ``{name}/coupling``, ``{name}/bearing_a``,
        ``{name}/bearing_b``, ``{name}/hub``, ``{name}/station_1..6`` and their
        centreline points (plus ``{name}/gear`` = hub centre). The OCC model is
        synchronised on return.
    """
    params.validate(f"shaft_{name}")
    x0, y0, z0 = (float(c) for c in origin)
    inset = 0.5 * min(params.coupling_length, params.journal_length)
    # coupling: its end face, below
    part, bboxes = build_revolved(params.segments(), name, (x0, y0, z0), inset,
                                  ("body", "rotor", "tail", "coupling"))
    part.surfaces[f"{name}/coupling"] = end_face(bboxes, name, z0, params.coupling_radius, x0)
    part.centres[f"{name}/coupling"] = np.array([x0, y0, z0])
    part.centres[f"{name}/gear"] = part.centres[f"{name}/hub"].copy()
    log.debug("shaft %s: volume %d, %d faces", name, part.volume, len(bboxes))
    return part
