"""Exterior P2 facets of a part: its outer skin, the facets' geometry nodes in
``triangle6`` order, their frames (area, centroid, outward normal) and the map from
geometry nodes to DOF blocks; plus the two MPI helpers the post-processing shares
(input-mesh node numbers, gathering rows on rank 0).

Used by :mod:`fem.post.radiation` (radiation matrix and facet rows) and
:mod:`fem.post.fields` (housing nodes and cells). The numbering that does not depend
on the partition is the input mesh's (``mesh.geometry.input_global_indices``, the gmsh
node numbers), as DOLFINx's own I/O does for its checkpoints.
"""
from __future__ import annotations

import logging
from typing import Any

import numpy as np

logger = logging.getLogger(__name__)

__all__ = ["CENTROID_WEIGHTS", "cell_geometry_nodes", "facet_centroid_rows", "facet_frames",
           "facet_geometry_nodes", "facet_normal_velocity_rows", "gather_on_root", "input_ids",
           "node_blocks", "outer_surface_facets", "part_boundary_facets"]


#: Edges of the reference tetrahedron (DOLFINx/basix P2 layout: geometry node 4 + e
#: sits on edge e).
_TET_EDGES = ((2, 3), (1, 3), (1, 2), (0, 3), (0, 2), (0, 1))
#: Weights of the P2 triangle's nodes at its centroid (vertices, then edge nodes).
CENTROID_WEIGHTS = np.array([-1 / 9] * 3 + [4 / 9] * 3)


def input_ids(mesh: Any, geometry_nodes: np.ndarray) -> np.ndarray:
    """Input-mesh (gmsh) node numbers of local geometry nodes: the same on any partition."""
    ids = np.asarray(mesh.geometry.input_global_indices, dtype=np.int64)
    return ids[geometry_nodes]


def gather_on_root(comm: Any, a: np.ndarray) -> np.ndarray | None:
    """The ranks' arrays stacked along axis 0 on rank 0 (None elsewhere)."""
    parts = comm.gather(np.ascontiguousarray(a), root=0)
    return np.concatenate(parts, axis=0) if comm.rank == 0 else None


def _cell_rows(adjacency: Any, n_cells: int) -> np.ndarray:
    """A uniform adjacency list (a DOLFINx dofmap) as an (n_cells, k) array."""
    return np.asarray(adjacency.array, dtype=np.int64).reshape(n_cells, -1)


def _n_cells(mesh: Any) -> int:
    cmap = mesh.topology.index_map(3)
    return cmap.size_local + cmap.num_ghosts


def cell_geometry_nodes(mesh: Any, cells: np.ndarray) -> np.ndarray:
    """The 10 geometry nodes of each cell (DOLFINx/basix P2 order), (n, 10) int64."""
    return _cell_rows(mesh.geometry.dofmap, _n_cells(mesh))[np.asarray(cells, dtype=np.int64)]


def node_blocks(mesh: Any, V: Any, cells: np.ndarray) -> np.ndarray:
    """Geometry node -> DOF block of the P2 vector space ``V`` (−1 off ``cells``).

    The P2 geometry and the P2 Lagrange space share the reference layout cell by
    cell, so the node at local position j of a cell carries the cell's j-th block.
    """
    n = _n_cells(mesh)
    cells = np.asarray(cells, dtype=np.int64)
    out = np.full(mesh.geometry.x.shape[0], -1, dtype=np.int64)
    out[_cell_rows(mesh.geometry.dofmap, n)[cells]] = _cell_rows(V.dofmap.list, n)[cells]
    return out


def facet_geometry_nodes(mesh: Any, facets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The 6 geometry nodes of each exterior P2 facet in VTK/XDMF ``triangle6`` order
    (vertices a, b, c, then the edge nodes of ab, bc, ca) and the cell of each facet.

    Facet ``i`` of a tetrahedron is opposite its vertex ``i``; the edge node of the
    cell's edge ``e`` (``_TET_EDGES``) is its geometry node ``4 + e``.
    """
    top = mesh.topology
    top.create_connectivity(2, 3)
    top.create_connectivity(3, 2)
    f2c, c2f = top.connectivity(2, 3), top.connectivity(3, 2)
    cg = mesh.geometry.dofmap
    cells = f2c.array[f2c.offsets[facets]]
    edge_of = {frozenset(p): 4 + e for e, p in enumerate(_TET_EDGES)}
    out = np.empty((len(facets), 6), dtype=np.int64)
    for j, (f, c) in enumerate(zip(facets, cells, strict=True)):
        i = int(np.flatnonzero(c2f.links(c) == f)[0])
        nodes = cg.links(c)
        a, b, d = (v for v in range(4) if v != i)
        out[j] = nodes[[a, b, d, edge_of[frozenset((a, b))], edge_of[frozenset((b, d))],
                        edge_of[frozenset((d, a))]]]
    return out, cells


def facet_frames(mesh: Any, facets: np.ndarray):
    """Geometry nodes (n_f × 6, ``triangle6``), cells, flat areas [m²], centroids [m]
    and outward unit normals of the facets."""
    x = mesh.geometry.x
    g, cells = facet_geometry_nodes(mesh, facets)                  # (n_f, 6)
    p = x[g]
    nrm = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    area = 0.5 * np.linalg.norm(nrm, axis=1)
    nrm /= np.linalg.norm(nrm, axis=1)[:, None]
    cen = p[:, :3].mean(axis=1)
    # orient outwards: away from the centroid of the (single) adjacent cell
    cg = mesh.geometry.dofmap
    cell_cen = np.stack([x[cg.links(c)[:4]].mean(axis=0) for c in cells]).reshape(-1, 3)
    flip = np.einsum("ij,ij->i", nrm, cen - cell_cen) < 0
    nrm[flip] *= -1
    return g, cells, area, cen, nrm


def facet_centroid_rows(mesh: Any, V: Any, facets: np.ndarray):
    """Sparse rows giving u and ``n·u`` at the centroid of each facet from the P2 DOF of V
    (local DOF numbers, serial use).

    Returns ``(Rc, Rn, area, centroid, normal)``: ``Rc`` a list of 3 scipy CSR
    (n_f × n_V), ``(Rc[i] u)_f = u_i(centroid_f)`` (P2 triangle: vertex weights
    −1/9, edge weights 4/9), ``Rn = Σ_i n_i Rc[i]`` (``n·u``); flat facet areas
    [m²], centroids [m] and unit normals (flat facet, pointing out of the cell).
    """
    import scipy.sparse as sp

    g, cells, area, cen, nrm = facet_frames(mesh, facets)
    blocks = node_blocks(mesh, V, cells)[g]
    if np.any(blocks < 0):
        raise RuntimeError("facet_centroid_rows: facet node without a DOF block")
    n_v = 3 * (V.dofmap.index_map.size_local + V.dofmap.index_map.num_ghosts)
    rows = np.repeat(np.arange(facets.size), 6)
    Rc = [sp.csr_matrix((np.tile(CENTROID_WEIGHTS, facets.size),
                         (rows, (3 * blocks + i).ravel())), shape=(facets.size, n_v))
          for i in range(3)]
    Rn = sum(sp.diags(nrm[:, i]) @ Rc[i] for i in range(3)).tocsr()
    return Rc, Rn, area, cen, nrm


def facet_normal_velocity_rows(mesh: Any, V: Any, facets: np.ndarray):
    """``(Rn, area, centroid, normal)`` of :func:`facet_centroid_rows` (``n·u`` rows)."""
    _, Rn, area, cen, nrm = facet_centroid_rows(mesh, V, facets)
    return Rn, area, cen, nrm


def part_boundary_facets(fe_mesh: Any, part: str) -> np.ndarray:
    """This rank's exterior facets of volume ``part`` minus its named surface groups."""
    from dolfinx import mesh as dmesh

    top = fe_mesh.mesh.topology
    top.create_connectivity(2, 3)
    top.create_connectivity(2, 0)
    # owned facets with one cell in the whole mesh (no inter-process facets)
    ext = np.asarray(dmesh.exterior_facet_indices(top), dtype=np.int32)
    f2c = top.connectivity(2, 3)
    cells = f2c.array[f2c.offsets[ext]]
    is_part = np.zeros(top.index_map(3).size_local + top.index_map(3).num_ghosts, dtype=bool)
    is_part[fe_mesh.cell_tags.find(fe_mesh.tag(part, 3))] = True
    facets = ext[is_part[cells]]
    named = [fe_mesh.facet_tags.find(t) for name, (d, t) in fe_mesh.groups.items()
             if d == 2 and name.startswith(part + "/")]
    if named:
        facets = np.setdiff1d(facets, np.concatenate(named))
    return facets.astype(np.int32)


def outer_surface_facets(fe_mesh: Any, part: str = "housing") -> np.ndarray:
    """Local indices of this rank's facets of the outer skin of volume ``part``
    (collective on the mesh communicator).

    The boundary facets of the part's cells, minus its named surface groups
    (bearing seats ``housing/bore_*`` and the bolted ``housing/feet``, which face a
    bearing or the foundation, not the air), split into connected pieces (shared
    vertices); the outer skin is the piece with the largest bounding box (the
    inner skin of a closed casing lies strictly inside it). Under MPI the facets'
    vertex numbers (input mesh) and positions are gathered on rank 0, which finds the
    pieces and sends each rank its selection.
    """
    import scipy.sparse as sp
    from scipy.sparse.csgraph import connected_components

    m = fe_mesh.mesh
    comm = m.comm
    facets = part_boundary_facets(fe_mesh, part)
    n_total = comm.allreduce(int(facets.size))
    if n_total == 0:
        raise ValueError(f"part = {part!r}: has no free boundary facets")
    g, _ = facet_geometry_nodes(m, facets)
    verts = input_ids(m, g[:, :3])                                 # (n_f, 3)
    pts = m.geometry.x[g[:, :3]]                                   # (n_f, 3, 3)
    all_v, all_p = gather_on_root(comm, verts), gather_on_root(comm, pts)
    counts = comm.gather(int(facets.size), root=0)
    keep_parts = None
    if comm.rank == 0:
        _, vidx = np.unique(all_v, return_inverse=True)
        vidx = vidx.reshape(all_v.shape)
        n_f = all_v.shape[0]
        inc = sp.csr_matrix((np.ones(vidx.size), (np.repeat(np.arange(n_f), 3), vidx.ravel())),
                            shape=(n_f, int(vidx.max()) + 1))
        n_comp, lab = connected_components(inc @ inc.T, directed=False)
        best, size = -1, -1.0
        for c in range(n_comp):
            p = all_p[lab == c].reshape(-1, 3)
            s = float(np.prod(np.ptp(p, axis=0) + 1e-12))
            if s > size:
                best, size = c, s
        keep = lab == best
        logger.info("outer surface of %r: %d of %d free boundary facets (%d connected pieces)",
                    part, int(keep.sum()), n_f, n_comp)
        keep_parts = np.split(keep, np.cumsum(counts)[:-1])
    keep_local = comm.scatter(keep_parts, root=0)
    return np.sort(facets[keep_local]).astype(np.int32)
