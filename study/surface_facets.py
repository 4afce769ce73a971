"""Exterior P2 facets of the housing: their geometry nodes, DOF blocks and the rows
that give ``u`` and ``n·u`` at their centroids (used by :mod:`study.acoustics` for the
radiation data and by :mod:`study.fields` for the surface fields)."""
from __future__ import annotations

import numpy as np

__all__ = ["CENTROID_WEIGHTS", "facet_centroid_rows", "facet_frames", "facet_geometry_nodes",
           "facet_normal_velocity_rows", "node_blocks"]


#: Edges of the reference tetrahedron (DOLFINx/basix P2 layout: geometry node 4 + e
#: sits on edge e).
_TET_EDGES = ((2, 3), (1, 3), (1, 2), (0, 3), (0, 2), (0, 1))


def facet_geometry_nodes(mesh, facets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
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


def node_blocks(mesh, V, cells: np.ndarray) -> np.ndarray:
    """Geometry node -> DOF block of the P2 vector space ``V`` (−1 off ``cells``).

    The P2 geometry and the P2 Lagrange space share the reference layout cell by
    cell, so the node at local position j of a cell carries the cell's j-th block.
    """
    cg = mesh.geometry.dofmap
    out = np.full(mesh.geometry.x.shape[0], -1, dtype=np.int64)
    for c in np.unique(cells):
        out[cg.links(c)] = V.dofmap.cell_dofs(c)
    return out


def facet_frames(mesh, facets: np.ndarray):
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


#: Weights of the P2 triangle's nodes at its centroid (vertices, then edge nodes).
CENTROID_WEIGHTS = np.array([-1 / 9] * 3 + [4 / 9] * 3)


def facet_centroid_rows(mesh, V, facets: np.ndarray):
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


def facet_normal_velocity_rows(mesh, V, facets: np.ndarray):
    """``(Rn, area, centroid, normal)`` of :func:`facet_centroid_rows` (``n·u`` rows)."""
    _, Rn, area, cen, nrm = facet_centroid_rows(mesh, V, facets)
    return Rn, area, cen, nrm
