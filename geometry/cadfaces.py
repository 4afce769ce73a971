"""Bearing seats and mounts on the OpenCASCADE faces of an imported part.

Each boundary face of the part becomes a :class:`geometry.locate.Candidate`: points on
its boundary curves (exact, they bound the trimmed face) and on a grid of its surface
parameters, with gmsh's outward normals there (``gmsh.model.getNormal`` follows the
face's orientation in the solid: on a bore it points to the axis). The surface type
(``Cylinder``, ``Plane``, ``BSpline surface``, ...) only labels the faces: a bore
exported as a B-spline is found as well, by its points.
"""

from __future__ import annotations

import logging

import gmsh
import numpy as np

from core.errors import InputError

from .locate import (
    BearingSeat,
    Candidate,
    Mount,
    MountReport,
    SeatReport,
    check_seat_fit,
    nearest_text,
    plane_match,
    seat_match,
    seat_miss,
    seat_misses,
    seat_report,
)

log = logging.getLogger(__name__)

#: Parameter grid per face direction, and points per boundary curve.
N_GRID = 7
N_CURVE = 12


def part_faces(volumes: list[int]) -> list[int]:
    """Boundary faces of the given volumes, sorted."""
    return sorted({abs(t) for _, t in gmsh.model.getBoundary([(3, v) for v in volumes],
                                                             combined=False, oriented=False)})


def face_candidate(face: int) -> Candidate:
    """Sample one OCC face (see the module docstring)."""
    (u0, v0), (u1, v1) = (np.asarray(b, dtype=float)
                          for b in gmsh.model.getParametrizationBounds(2, face))
    g = (np.arange(N_GRID) + 0.5) / N_GRID
    uu, vv = np.meshgrid(u0 + g * (u1 - u0), v0 + g * (v1 - v0))
    uv = np.column_stack([uu.ravel(), vv.ravel()]).ravel()
    grid = np.asarray(gmsh.model.getValue(2, face, uv)).reshape(-1, 3)
    normals = np.asarray(gmsh.model.getNormal(face, uv)).reshape(-1, 3)
    rim = []
    for _, c in gmsh.model.getBoundary([(2, face)], combined=False, oriented=False):
        (t0,), (t1,) = gmsh.model.getParametrizationBounds(1, abs(c))
        t = np.linspace(t0, t1, N_CURVE)
        rim.append(np.asarray(gmsh.model.getValue(1, abs(c), t)).reshape(-1, 3))
    rim_pts = np.vstack(rim) if rim else grid
    return Candidate(label=f"face {face} ({gmsh.model.getType(2, face)})",
                     points=np.vstack([rim_pts, grid]), normals=normals,
                     normal_points=grid, area=float(gmsh.model.occ.getMass(2, face)),
                     rim=rim_pts)


def face_candidates(volumes: list[int]) -> dict[int, Candidate]:
    """Candidates of every boundary face of the volumes, by face tag."""
    return {f: face_candidate(f) for f in part_faces(volumes)}


def _named(cands: dict[int, Candidate], group: str) -> list[int]:
    out = []
    for f in cands:
        name = gmsh.model.getEntityName(2, f)
        if name and (name == group or name.endswith("/" + group)):
            out.append(f)
    return out


def _names(cands: dict[int, Candidate]) -> list[str]:
    return sorted({gmsh.model.getEntityName(2, f) for f in cands} - {""})


def _by_group(group: str, cands: dict[int, Candidate], fld: str) -> list[int]:
    faces = _named(cands, group)
    if not faces:
        names = _names(cands)
        raise InputError.of(fld, group, "no face of the part carries this name; "
                            + (f"named faces: {', '.join(map(repr, names[:20]))}" if names
                               else "the file names no face (use the seat's axis, or a "
                               "box or plane for a mount)"))
    return faces


def find_seat(seat: BearingSeat, cands: dict[int, Candidate], bbox: np.ndarray,
              where: str) -> tuple[list[int], SeatReport]:
    """The faces of one bearing seat, and the report.

    Parameters
    ----------
    seat : BearingSeat
    cands : dict[int, Candidate]
        The part's faces (:func:`face_candidates`).
    bbox : numpy.ndarray, shape (2, 3)
        The part's bounding box [m].
    where : str
        How messages name the seat (``"seats[2]"``).

    Raises
    ------
    core.errors.InputError
        The seat misses the part, or no face fits (the nearest are named), or a group
        does not exist or does not fit the radius or point given.
    """
    if seat.by_axis:
        seat_misses(seat, bbox[0], bbox[1], where)
        faces = [f for f, c in cands.items() if seat_match(c, seat)]
        if not faces:
            scored = [(score, c.label, shape) for c in cands.values()
                      for score, shape in [seat_miss(c, seat)]]
            p, a = seat.axis()
            raise InputError(
                f"{where} ({seat.name!r}): no {seat.surface} face of radius "
                f"{seat.radius:.6g} m (tolerance {seat.tol():.3g} m) around the axis through "
                f"{np.round(p, 6).tolist()} m along {np.round(a, 6).tolist()} within "
                f"{seat.width / 2:.4g} m of the point" + nearest_text(scored),
                field=f"{where}.point", value=seat.point)
    else:
        faces = _by_group(seat.group, cands, f"{where}.group")
    sel = [cands[f] for f in faces]
    report = seat_report(seat, [c.label for c in sel], sum(c.area for c in sel),
                         np.vstack([c.points for c in sel]),
                         np.vstack([c.normals for c in sel]),
                         np.vstack([c.rim for c in sel]))
    if not seat.by_axis:
        check_seat_fit(report, seat, where)
    return faces, report


def face_patches(faces: list[int]) -> list[list[int]]:
    """Connected groups of faces (sharing a boundary curve), each sorted."""
    parent = {f: f for f in faces}

    def root(f: int) -> int:
        while parent[f] != f:
            parent[f] = parent[parent[f]]
            f = parent[f]
        return f

    owner: dict[int, int] = {}
    for f in faces:
        for _, c in gmsh.model.getBoundary([(2, f)], combined=False, oriented=False):
            other = owner.setdefault(abs(c), f)
            if other != f:
                parent[root(f)] = root(other)
    groups: dict[int, list[int]] = {}
    for f in faces:
        groups.setdefault(root(f), []).append(f)
    return [sorted(g) for g in groups.values()]


def find_mount(mount: Mount, cands: dict[int, Candidate], where: str
               ) -> tuple[list[list[int]], MountReport]:
    """The faces of one mount, grouped per patch when ``mount.per_patch``, and the report.

    Returns
    -------
    (list of face lists, MountReport)
        One face list (the whole mount) or one per connected patch, in the order of
        the patch centroids (x, then y, then z).
    """
    if mount.group is not None:
        faces = _by_group(mount.group, cands, f"{where}.group")
    else:
        faces, scored = [], []
        for f, c in cands.items():
            ok, score, shape = plane_match(c, mount)
            if ok:
                faces.append(f)
            else:
                scored.append((score, c.label, shape))
        if not faces:
            what = " and ".join(k for k in ("plane", "box") if getattr(mount, k) is not None)
            raise InputError(f"{where} ({mount.name!r}): no face of part '{mount.part}' "
                             f"lies in the {what} given (tolerance {mount.tolerance:g} m)"
                             + nearest_text(scored), field=f"{where}.{what.split()[0]}")
    groups = face_patches(faces) if mount.per_patch else [sorted(faces)]
    centres, areas = [], []
    for g in groups:
        a = np.array([gmsh.model.occ.getMass(2, f) for f in g])
        c = np.array([gmsh.model.occ.getCenterOfMass(2, f) for f in g])
        areas.append(float(a.sum()))
        centres.append((a[:, None] * c).sum(axis=0) / a.sum())
    order = sorted(range(len(groups)), key=lambda i: tuple(np.round(centres[i], 9)))
    groups = [groups[i] for i in order]
    names = ([f"{mount.group_name}_{k + 1}" for k in range(len(groups))] if mount.per_patch
             else [mount.group_name])
    report = MountReport(name=mount.name, groups=names,
                         found=[cands[f].label for g in groups for f in g],
                         area=float(sum(areas)), centres=[centres[i] for i in order],
                         areas=[areas[i] for i in order])
    return groups, report
