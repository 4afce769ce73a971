"""OpenCASCADE solid of the pump housing with its tagged surfaces."""

from __future__ import annotations

import logging

import gmsh
import numpy as np

from .model import PartEntities
from .params import DEFAULT_CENTRE_DISTANCE, SHAFT_NAMES, HousingParams

log = logging.getLogger(__name__)

_TOL = 1e-6  # m, matching tolerance on OCC bounding boxes


def bore_axes(centre_distance: float) -> dict[str, float]:
    """``x`` of the bore axis of each shaft (``y = 0``) [m]."""
    return {"in": 0.0, "out": float(centre_distance)}


def build_housing(params: HousingParams,
                  centre_distance: float = DEFAULT_CENTRE_DISTANCE) -> PartEntities:
    """Add the housing solid to the current gmsh OCC model and find its surfaces.

    Box ``x ∈ a/2 ± length_x/2``, ``y ∈ ±height_y/2``, ``z ∈ [0, length_z]``,
    hollowed to ``wall_thickness``; one boss with a through bore per shaft on
    each end wall (bore axes at ``x = 0`` and ``x = a``, ``y = 0``); four corner
    feet under the bottom face; ``rib_count`` plates on the top face.

    Parameters
    ----------
    params : HousingParams
        Housing dimensions [m]; validated here.
    centre_distance : float
        Centre distance ``a`` between the two bore axes [m].

    Returns
    -------
    PartEntities
        Volume tag, surfaces ``housing/bore_{s}_{a|b}`` and ``housing/feet``,
        and the bore centres. The OCC model is synchronised on return.
    """
    params.validate(centre_distance)
    p = params
    occ = gmsh.model.occ
    t = p.wall_thickness
    x0, x1 = p.x_range(centre_distance)
    lx, hy, lz = p.length_x, p.height_y, p.length_z
    y0 = -0.5 * hy
    axes = bore_axes(centre_distance)

    box = occ.addBox(x0, y0, 0.0, lx, hy, lz)
    adds: list[tuple[int, int]] = []
    for xc in axes.values():
        adds.append((3, occ.addCylinder(xc, 0.0, -p.boss_length, 0, 0, p.boss_length,
                                        p.boss_radius)))
        adds.append((3, occ.addCylinder(xc, 0.0, lz, 0, 0, p.boss_length, p.boss_radius)))
    yf = y0 - p.foot_height
    fx = (x0 - p.foot_overhang, x1 + p.foot_overhang - p.foot_width)
    fz = (0.0, lz - p.foot_depth)
    for xa in fx:
        for za in fz:
            adds.append((3, occ.addBox(xa, yf, za, p.foot_width, p.foot_height, p.foot_depth)))
    for zc in p.rib_centres():
        adds.append((3, occ.addBox(x0, -y0, zc - 0.5 * p.rib_thickness, lx, p.rib_height,
                                   p.rib_thickness)))
    solid, _ = occ.fuse([(3, box)], adds)
    cuts = [(3, occ.addBox(x0 + t, y0 + t, t, lx - 2 * t, hy - 2 * t, lz - 2 * t))]
    eps = 0.5 * t
    for xc in axes.values():
        za0, za1 = p.bore_a_z
        zb0, zb1 = p.bore_b_z
        cuts.append((3, occ.addCylinder(xc, 0.0, za0 - eps, 0, 0, za1 - za0 + 2 * eps,
                                        p.bore_radius)))
        cuts.append((3, occ.addCylinder(xc, 0.0, zb0 - eps, 0, 0, zb1 - zb0 + 2 * eps,
                                        p.bore_radius)))
    result, _ = occ.cut(solid, cuts)
    vols = [tag for d, tag in result if d == 3]
    if len(vols) != 1:
        raise RuntimeError(f"housing: boolean operations gave {len(vols)} volumes, expected "
                           "one connected solid")
    vol = vols[0]
    occ.synchronize()

    faces = [tag for d, tag in gmsh.model.getBoundary([(3, vol)], oriented=False) if d == 2]
    bboxes = {tag: gmsh.model.getBoundingBox(2, tag) for tag in faces}
    part = PartEntities(volume=vol)
    rb = p.bore_radius
    for s in SHAFT_NAMES:
        xc = axes[s]
        for end, (za, zb) in (("a", p.bore_a_z), ("b", p.bore_b_z)):
            hit = [tag for tag, b in bboxes.items()
                   if abs(b[0] - (xc - rb)) < _TOL and abs(b[3] - (xc + rb)) < _TOL
                   and abs(b[1] + rb) < _TOL and abs(b[4] - rb) < _TOL
                   and abs(b[2] - za) < _TOL and abs(b[5] - zb) < _TOL]
            if not hit:
                raise RuntimeError(f"housing: no surface found for bore {s}_{end}")
            key = f"housing/bore_{s}_{end}"
            part.surfaces[key] = hit
            part.centres[key] = np.array([xc, 0.0, 0.5 * (za + zb)])
    feet = [tag for tag, b in bboxes.items()
            if abs(b[1] - yf) < _TOL and abs(b[4] - yf) < _TOL]
    if len(feet) != 4:
        raise RuntimeError(f"housing: found {len(feet)} foot faces, expected 4")
    part.surfaces["housing/feet"] = sorted(feet)
    log.debug("housing: volume %d, %d faces", vol, len(faces))
    return part
