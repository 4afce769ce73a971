"""Bearing seats and mounts on the boundary facets of an imported volume mesh.

A mesh file has no CAD faces: its boundary is the set of tetrahedron faces used once,
each a 6-node triangle with its outward normal (away from the tetrahedron's fourth
vertex). A seat is made of the boundary facets whose three corners lie on the seat's
cylinder (radius and axis within the tolerance), facing the axis (a bore): each connected
piece of them that lies mostly in the axial window is taken whole, as a whole CAD face
is. A mount is the facets in its plane and box. Corner nodes only are tested: the
mid-edge nodes of a mesh upgraded from 4-node tetrahedra sit on the chords.

When nothing fits, the boundary is cut into smooth patches (neighbour facets whose
normals differ by less than :data:`PATCH_ANGLE_DEG`, the way a feature-angle
classification finds CAD faces again) and the nearest patches are named, as CAD faces
would be. Pure NumPy/SciPy: no gmsh.
"""

from __future__ import annotations

import math

import numpy as np

from core.errors import InputError

from .locate import (
    SEAT_NORMAL_DEG,
    BearingSeat,
    Candidate,
    Mount,
    MountReport,
    SeatReport,
    axis_coordinates,
    check_seat_fit,
    nearest_text,
    plane_match,
    radial_directions,
    seat_miss,
    seat_misses,
    seat_report,
)

#: Feature angle between neighbour facets that separates two patches [deg].
PATCH_ANGLE_DEG = 40.0
MOUNT_NORMAL_COS = math.cos(math.radians(5.0))
# gmsh 10-node tetrahedron: its four faces as 6-node triangles (corners, then the mid
# nodes of edges 01, 12, 20 of the triangle); tet mid node 4 + k is on edge
# (0,1), (1,2), (2,0), (3,0), (3,2), (3,1) for k = 0..5
TET10_FACES = np.array([[0, 1, 2, 4, 5, 6], [0, 1, 3, 4, 9, 7],
                        [0, 2, 3, 6, 8, 7], [1, 2, 3, 5, 8, 9]])
TET10_OPPOSITE = np.array([3, 2, 1, 0])
# degree-4 rule on the reference triangle (Dunavant, 6 points): (xi, eta), weight
_A, _B = 0.445948490915965, 0.091576213509771
_W1, _W2 = 0.223381589678011 / 2, 0.109951743655322 / 2
TRI_RULE = (np.array([[_A, _A], [1 - 2 * _A, _A], [_A, 1 - 2 * _A],
                      [_B, _B], [1 - 2 * _B, _B], [_B, 1 - 2 * _B]]),
            np.array([_W1, _W1, _W1, _W2, _W2, _W2]))


def _row_keys(rows: np.ndarray) -> np.ndarray:
    """Sorted rows as a 1-D array of void keys (for unique / isin on row sets)."""
    s = np.ascontiguousarray(np.sort(rows, axis=1))
    return s.view(np.dtype((np.void, s.dtype.itemsize * s.shape[1]))).ravel()


def boundary_facets(tets: np.ndarray, nodes: np.ndarray) -> np.ndarray:
    """The boundary of a 10-node tetrahedral mesh as outward 6-node triangles.

    Parameters
    ----------
    tets : numpy.ndarray of int, shape (m, 10)
        0-based node indices, gmsh order.
    nodes : numpy.ndarray, shape (n, 3)

    Returns
    -------
    numpy.ndarray of int64, shape (k, 6)
        Faces used by one tetrahedron only, corners ordered so that the normal
        ``(x1 - x0) x (x2 - x0)`` points out of the mesh; sorted by corner indices.
    """
    faces = tets[:, TET10_FACES].reshape(-1, 6)
    opposite = tets[:, TET10_OPPOSITE].reshape(-1)
    keys = _row_keys(faces[:, :3])
    _, first, counts = np.unique(keys, return_index=True, return_counts=True)
    once = np.sort(first[counts == 1])
    f, o = faces[once].astype(np.int64), opposite[once]
    x0, x1, x2 = (nodes[f[:, i]] for i in range(3))
    inward = np.einsum("ij,ij->i", np.cross(x1 - x0, x2 - x0), nodes[o] - x0) > 0
    f[inward] = f[inward][:, [0, 2, 1, 5, 4, 3]]
    return f[np.lexsort(np.sort(f[:, :3], axis=1).T[::-1])]


def facet_normals(nodes: np.ndarray, facets: np.ndarray) -> np.ndarray:
    """Unit normals of the facets' corner triangles (outward for :func:`boundary_facets`)."""
    x0, x1, x2 = (nodes[facets[:, i]] for i in range(3))
    n = np.cross(x1 - x0, x2 - x0)
    return n / np.linalg.norm(n, axis=1, keepdims=True)


def facet_areas(nodes: np.ndarray, facets: np.ndarray) -> np.ndarray:
    """Areas [m^2] of 6-node triangles (curved; degree-4 rule on the quadratic map)."""
    pts, wts = TRI_RULE
    x = nodes[facets]  # (k, 6, 3)
    area = np.zeros(len(facets))
    for (xi, eta), w in zip(pts, wts, strict=True):
        l0 = 1.0 - xi - eta
        # derivatives of the 6 shape functions (corners, then mid 01, 12, 20)
        d_xi = np.array([-(4 * l0 - 1), 4 * xi - 1, 0.0, 4 * (l0 - xi), 4 * eta, -4 * eta])
        d_eta = np.array([-(4 * l0 - 1), 0.0, 4 * eta - 1, -4 * xi, 4 * xi, 4 * (l0 - eta)])
        t1 = np.einsum("a,kai->ki", d_xi, x)
        t2 = np.einsum("a,kai->ki", d_eta, x)
        area += w * np.linalg.norm(np.cross(t1, t2), axis=1)
    return area


def patches(facets: np.ndarray, normals: np.ndarray,
            angle_deg: float | None = PATCH_ANGLE_DEG) -> np.ndarray:
    """Label of the connected patch of each facet.

    Facets are neighbours when they share an edge and, if ``angle_deg`` is given, their
    normals differ by less than it. Labels are numbered in the order of each patch's
    first facet.
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    k = len(facets)
    edges = np.concatenate([facets[:, [0, 1]], facets[:, [1, 2]], facets[:, [2, 0]]])
    owner = np.tile(np.arange(k), 3)
    keys = _row_keys(edges)
    order = np.argsort(keys, kind="stable")
    ks, ow = keys[order], owner[order]
    same = ks[1:] == ks[:-1]
    a, b = ow[:-1][same], ow[1:][same]
    if angle_deg is not None:
        keep = np.einsum("ij,ij->i", normals[a], normals[b]) >= math.cos(
            math.radians(angle_deg))
        a, b = a[keep], b[keep]
    graph = coo_matrix((np.ones(a.size), (a, b)), shape=(k, k))
    _, labels = connected_components(graph, directed=False)
    _, first = np.unique(labels, return_index=True)
    rank = np.empty(first.size, dtype=np.int64)
    rank[np.argsort(np.argsort(first))] = np.arange(first.size)
    return rank[labels]


class MeshBoundary:
    """The boundary facets of one imported mesh part, with what the searches need.

    Parameters
    ----------
    nodes : numpy.ndarray, shape (n, 3)
        [m]
    tets : numpy.ndarray of int, shape (m, 10)
    face_sets : dict[str, numpy.ndarray]
        Named facet sets of the file, (k, >=3) node indices (corners first).
    node_sets : dict[str, numpy.ndarray]
        Named node sets of the file.
    """

    def __init__(self, nodes: np.ndarray, tets: np.ndarray,
                 face_sets: dict[str, np.ndarray] | None = None,
                 node_sets: dict[str, np.ndarray] | None = None) -> None:
        self.nodes = np.asarray(nodes, dtype=float)
        self.facets = boundary_facets(np.asarray(tets), self.nodes)
        self.normals = facet_normals(self.nodes, self.facets)
        self.areas = facet_areas(self.nodes, self.facets)
        self.centroids = self.nodes[self.facets[:, :3]].mean(axis=1)
        self.face_sets = dict(face_sets or {})
        self.node_sets = dict(node_sets or {})
        self.bbox = np.array([self.nodes.min(axis=0), self.nodes.max(axis=0)])
        self._patches: np.ndarray | None = None

    def patch_labels(self) -> np.ndarray:
        """Smooth-patch label of every facet (computed once)."""
        if self._patches is None:
            self._patches = patches(self.facets, self.normals)
        return self._patches

    def candidates(self) -> list[Candidate]:
        """One candidate per smooth patch."""
        labels = self.patch_labels()
        out = []
        for p in range(int(labels.max()) + 1 if labels.size else 0):
            sel = np.flatnonzero(labels == p)
            corners = self.nodes[np.unique(self.facets[sel, :3])]
            out.append(Candidate(label=f"patch {p + 1} ({sel.size} facets)", points=corners,
                                 normals=self.normals[sel],
                                 normal_points=self.centroids[sel],
                                 area=float(self.areas[sel].sum()), rim=corners))
        return out

    def group(self, name: str, fld: str) -> np.ndarray:
        """Boundary facets of a named set of the file (face set, else node set)."""
        keys = _row_keys(self.facets[:, :3])
        if name in self.face_sets:
            wanted = _row_keys(np.asarray(self.face_sets[name])[:, :3])
            hit = np.isin(keys, wanted)
            if int(hit.sum()) < len(wanted):
                raise InputError.of(fld, name, f"{len(wanted) - int(hit.sum())} of its "
                                    f"{len(wanted)} faces are not on the mesh boundary")
        elif name in self.node_sets:
            inside = np.zeros(len(self.nodes), dtype=bool)
            inside[np.asarray(self.node_sets[name], dtype=np.int64)] = True
            hit = inside[self.facets[:, :3]].all(axis=1)
        else:
            known = sorted(self.face_sets) + sorted(self.node_sets)
            raise InputError.of(fld, name, "no face set or node set of the file has this "
                                "name; " + (f"the file has: {', '.join(map(repr, known[:30]))}"
                                            if known else "the file names none"))
        sel = np.flatnonzero(hit)
        if not sel.size:
            raise InputError.of(fld, name, "the set holds no face of the mesh boundary")
        return sel

    def find_seat(self, seat: BearingSeat, where: str) -> tuple[np.ndarray, SeatReport]:
        """Boundary facets of one bearing seat (indices into ``facets``) and the report."""
        if seat.by_axis:
            seat_misses(seat, self.bbox[0], self.bbox[1], where)
            p, a = seat.axis()
            tol, r, w = seat.tol(), float(seat.radius), float(seat.width)
            corners = self.nodes[self.facets[:, :3]].reshape(-1, 3)
            s, rho = axis_coordinates(corners, p, a)
            s, rho = s.reshape(-1, 3), rho.reshape(-1, 3)
            radial = radial_directions(self.centroids, p, a)
            cos = np.einsum("ij,ij->i", self.normals, radial)
            sign = -1.0 if seat.surface == "bore" else 1.0
            on = np.flatnonzero((np.abs(rho - r) <= tol).all(axis=1)
                                & (sign * cos >= math.cos(math.radians(SEAT_NORMAL_DEG))))
            # whole connected pieces of the cylinder lying mostly in the window, as
            # whole CAD faces are
            labels = patches(self.facets[on], self.normals[on], angle_deg=None)
            keep = []
            for k in range(int(labels.max()) + 1 if on.size else 0):
                piece = labels == k
                lo, hi = float(s[on[piece]].min()), float(s[on[piece]].max())
                overlap = min(hi, 0.5 * w) - max(lo, -0.5 * w)
                if overlap >= 0.5 * min(hi - lo, w) - tol:
                    keep.append(on[piece])
            sel = np.sort(np.concatenate(keep)) if keep else np.zeros(0, dtype=np.int64)
            if not sel.size:
                scored = [(sc, c.label, shape) for c in self.candidates()
                          for sc, shape in [seat_miss(c, seat)]]
                raise InputError(
                    f"{where} ({seat.name!r}): no {seat.surface} facets of radius {r:.6g} m "
                    f"(tolerance {tol:.3g} m) around the axis through "
                    f"{np.round(p, 6).tolist()} m along {np.round(a, 6).tolist()} within "
                    f"{w / 2:.4g} m of the point" + nearest_text(scored),
                    field=f"{where}.point", value=seat.point)
        else:
            sel = self.group(seat.group, f"{where}.group")
        pts = self.nodes[np.unique(self.facets[sel])]
        corners = self.nodes[np.unique(self.facets[sel, :3])]
        report = seat_report(seat, [f"{sel.size} facets"], float(self.areas[sel].sum()),
                             corners, self.normals[sel], pts)
        if not seat.by_axis:
            check_seat_fit(report, seat, where)
        return sel, report

    def find_mount(self, mount: Mount, where: str) -> tuple[list[np.ndarray], MountReport]:
        """Boundary facets of one mount (one array, or one per patch) and the report."""
        if mount.group is not None:
            sel = self.group(mount.group, f"{where}.group")
        else:
            hit = np.ones(len(self.facets), dtype=bool)
            corners = self.nodes[self.facets[:, :3]]
            tol = mount.tolerance
            if mount.plane is not None:
                p = np.asarray(mount.plane[0], dtype=float)
                n = np.asarray(mount.plane[1], dtype=float)
                n = n / np.linalg.norm(n)
                hit &= (np.abs((corners - p) @ n) <= tol).all(axis=1)
                hit &= np.abs(self.normals @ n) >= MOUNT_NORMAL_COS
            if mount.box is not None:
                lo, hi = (np.asarray(v, dtype=float) for v in mount.box)
                hit &= ((corners >= lo - tol) & (corners <= hi + tol)).all(axis=(1, 2))
            sel = np.flatnonzero(hit)
            if not sel.size:
                what = " and ".join(k for k in ("plane", "box")
                                    if getattr(mount, k) is not None)
                scored = [(sc, c.label, shape) for c in self.candidates()
                          for _, sc, shape in [plane_match(c, mount)]]
                raise InputError(f"{where} ({mount.name!r}): no boundary facet of part "
                                 f"'{mount.part}' lies in the {what} given (tolerance "
                                 f"{tol:g} m)" + nearest_text(scored),
                                 field=f"{where}.{what.split()[0]}")
        if mount.per_patch:
            labels = patches(self.facets[sel], self.normals[sel], angle_deg=None)
            groups = [sel[labels == k] for k in range(int(labels.max()) + 1)]
        else:
            groups = [sel]
        areas = [float(self.areas[g].sum()) for g in groups]
        centres = [(self.areas[g, None] * self.centroids[g]).sum(axis=0) / a
                   for g, a in zip(groups, areas, strict=True)]
        order = sorted(range(len(groups)), key=lambda i: tuple(np.round(centres[i], 9)))
        groups = [groups[i] for i in order]
        names = ([f"{mount.group_name}_{k + 1}" for k in range(len(groups))]
                 if mount.per_patch else [mount.group_name])
        report = MountReport(name=mount.name, groups=names,
                             found=[f"{g.size} facets" for g in groups],
                             area=float(sum(areas)), centres=[centres[i] for i in order],
                             areas=[areas[i] for i in order])
        return groups, report
