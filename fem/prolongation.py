"""Rigid links and clamps by exact elimination: the prolongation P (reduced -> full).

Full unknowns: the P2 displacement DOF of V in DOLFINx's global numbering
(``3*block + component``, rank-contiguous) followed by 6 DOF per extra node
(global frame), owned by the last rank: ``n_fe + 6*k + i``.
Reduced unknowns: on each rank its free owned FE DOF (neither linked nor clamped)
in increasing order; the last rank then appends the non-fixed DOF of the extra
nodes, in node order, expressed in each node's local frame.

A linked FE DOF of a surface tied rigidly to node c takes the row of
u_s = u_c + theta_c x (x_s - x_c), with u_c = R u'_c, theta_c = R theta'_c.
A distributing link eliminates 6 DOF of its surface instead (the UM set), whose rows
are dense over the surface's other DOF (:mod:`fem.distributing`). Its other free DOF
are measured from the node's rigid motion: u_r = A_r q'_c + w_r, w_r reduced unknowns;
then u_m = A_m q'_c - G_m^{-1} G_r w_r, every coefficient O(1) (u_m = G_m^{-1} (q'_c -
G_r u_r) in physical u_r has node coefficients ~ the number of surface DOF, which
spoils the conditioning of K_bar).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from mpi4py import MPI

from .distributing import SurfaceFit, choose_um, rigid_motion_matrix, surface_fit, um_rows
from .mesh import FEMesh
from .spec import ModelSpec

log = logging.getLogger(__name__)

FREE, CLAMPED = -1, -2


@dataclass
class Prolongation:
    """Result of :func:`build_prolongation`.

    Attributes
    ----------
    P : PETSc.Mat
        (n_fe + 6 n_nodes) x n_red, rows FE owned ranges then nodes on the last rank.
    P_fe : PETSc.Mat or None
        The first n_fe rows of P (same row layout as the FE matrices); ``build_model``
        frees it after the projection.
    node_red : dict[str, numpy.ndarray]
        Reduced global index of each node's 6 local DOF (-1 where fixed).
    n_fe, n_red : int
        Global FE DOF count and reduced DOF count.
    red_range : tuple[int, int]
        This rank's ownership range of reduced DOF.
    free_coords : numpy.ndarray, shape (n_free_local, 3)
        Coordinates (m) of this rank's free FE DOF in reduced order.
    free_comp : numpy.ndarray, shape (n_free_local,)
        Their component (0, 1, 2).
    free_blocks : numpy.ndarray
        Local (owned) block indices of V holding a free FE DOF, increasing (all 3
        components free, except at the UM DOF of distributing links).
    free_dofs : numpy.ndarray of int64, shape (n_free_local,)
        Local (owned) FE DOF ``3 * block + comp`` of the free DOF, in reduced order.
    counts : dict[str, int]
        Global numbers of FE DOF: ``free``, ``linked`` (eliminated by links: every DOF
        of a rigid link's surface, the 6 UM DOF of a distributing link), ``clamped``;
        ``node``: free node DOF; with distributing links also ``distributed``: the FE
        DOF on their surfaces (each weighted in a fit).
    node_links : dict[str, int]
        FE DOF eliminated towards each node (see ``counts["linked"]``).
    um : dict[str, numpy.ndarray]
        Global FE indices of the 6 eliminated DOF of each distributing link's surface.
    free_relative : numpy.ndarray of bool, shape (n_free_local,)
        Free DOF on a distributing surface: their reduced unknown is the deviation
        w = u - A q'_c from the rigid motion of the link's node, not u itself.
    """

    P: Any
    P_fe: Any
    node_red: dict[str, np.ndarray]
    n_fe: int
    n_red: int
    red_range: tuple[int, int]
    free_coords: np.ndarray
    free_comp: np.ndarray
    counts: dict[str, int]
    node_links: dict[str, int]
    free_blocks: np.ndarray | None = None
    free_dofs: np.ndarray | None = None
    um: dict[str, np.ndarray] = field(default_factory=dict)
    free_relative: np.ndarray | None = None


def _surface_blocks(V: Any, fe_mesh: FEMesh, name: str) -> np.ndarray:
    """Owned DOF blocks (local indices) on surface group ``name``."""
    from dolfinx import fem

    tag = fe_mesh.tag(name, 2)
    facets = fe_mesh.facet_tags.find(tag)
    blocks = fem.locate_dofs_topological(V, 2, facets)  # remote=True: all ranks' facets
    n_own = V.dofmap.index_map.size_local
    blocks = blocks[blocks < n_own]
    n_glob = fe_mesh.comm.allreduce(blocks.size, op=MPI.SUM)
    if n_glob == 0:
        raise ValueError(f"surface {name!r}: holds no DOF of the mesh")
    return blocks


def classify_blocks(V: Any, fe_mesh: FEMesh, spec: ModelSpec) -> np.ndarray:
    """Owner of each owned DOF block: FREE, CLAMPED, or the index of its rigidly linked
    node (distributing links leave their surface's blocks FREE)."""
    comm = fe_mesh.comm
    owner = np.full(V.dofmap.index_map.size_local, FREE, dtype=np.int64)
    first_surface: dict[int, str] = {}
    n_shared = 0
    for link in spec.links:
        if link.kind != "rigid":
            continue
        k = spec.node_index(link.node)
        blocks = _surface_blocks(V, fe_mesh, link.surface)
        prev = owner[blocks]
        clash = (prev >= 0) & (prev != k)
        n_clash = comm.allreduce(int(np.count_nonzero(clash)), op=MPI.SUM)
        if n_clash:
            others = sorted({first_surface.get(int(p), "?") for p in np.unique(prev[clash])})
            msg = (f"surface {link.surface!r} (node {link.node!r}) shares {n_clash} DOF "
                   f"nodes with links of surfaces {others} to other nodes")  # fmt: skip
            if spec.shared == "error":
                raise ValueError(msg + "; spec.shared = 'error'")
            log.warning("%s: they stay with the link added first", msg)
            n_shared += n_clash
        owner[blocks[prev < 0]] = k
        first_surface.setdefault(k, link.surface)
    for surface in spec.clamps:
        blocks = _surface_blocks(V, fe_mesh, surface)
        n_over = comm.allreduce(int(np.count_nonzero(owner[blocks] >= 0)), op=MPI.SUM)
        if n_over:
            log.warning("clamp %r overrides %d linked DOF nodes", surface, n_over)
        owner[blocks] = CLAMPED
    return owner


def _csr(rows: np.ndarray, cols: np.ndarray, vals: np.ndarray, n_rows: int) -> tuple:
    order = np.lexsort((cols, rows))
    rows, cols, vals = rows[order], cols[order], vals[order]
    indptr = np.zeros(n_rows + 1, dtype=np.int64)
    np.cumsum(np.bincount(rows, minlength=n_rows), out=indptr[1:])
    return indptr, cols, vals


def _petsc_aij(comm: MPI.Comm, n_rows_local: int, n_cols_local: int, csr: tuple) -> Any:
    from petsc4py import PETSc

    it = PETSc.IntType
    indptr, cols, vals = csr
    A = PETSc.Mat().createAIJ(
        size=((n_rows_local, PETSc.DETERMINE), (n_cols_local, PETSc.DETERMINE)),
        csr=(indptr.astype(it), cols.astype(it), vals.astype(PETSc.ScalarType)),
        comm=comm,
    )
    A.assemble()
    return A


def _distributing_fits(V: Any, fe_mesh: FEMesh, spec: ModelSpec, owner: np.ndarray
                       ) -> list[tuple[SurfaceFit, np.ndarray, np.ndarray]]:
    """Fit and UM set of each distributing link, in link order (collective).

    A UM DOF is chosen among the surface's DOF that are free (not rigidly linked or
    clamped), on no other distributing surface and not already chosen.

    Returns
    -------
    list of (fit, um, Gm)
        See :func:`fem.distributing.choose_um`.
    """
    comm = fe_mesh.comm
    links = [link for link in spec.links if link.kind == "distributing"]
    if not links:
        return []
    offset = 3 * V.dofmap.index_map.local_range[0]
    surf_blocks = [_surface_blocks(V, fe_mesh, link.surface) for link in links]
    n_dist = np.zeros(owner.size, dtype=np.int64)
    for blocks in surf_blocks:
        n_dist[np.unique(blocks)] += 1
    taken: set[int] = set()
    out = []
    for link, blocks in zip(links, surf_blocks, strict=True):
        blocks = np.unique(blocks)
        dofs = (3 * blocks[:, None] + np.arange(3)).reshape(-1).astype(np.int64)
        node = spec.nodes[spec.node_index(link.node)]
        fit = surface_fit(V, fe_mesh, link.surface, node, dofs)
        eligible = np.repeat((owner[blocks] == FREE) & (n_dist[blocks] == 1), 3)
        eligible &= ~np.isin(dofs + offset, np.fromiter(taken, dtype=np.int64))
        um, Gm = choose_um(fit, eligible, offset, comm)
        taken.update(int(i) for i in um)
        out.append((fit, um, Gm))
    return out


def build_prolongation(V: Any, fe_mesh: FEMesh, spec: ModelSpec) -> Prolongation:
    """Build P from reduced to full unknowns (links and clamps eliminated).

    Parameters
    ----------
    V : dolfinx.fem.FunctionSpace
        Vector displacement space (block size 3).
    fe_mesh : FEMesh
    spec : ModelSpec
        Nodes (centres in m), links, clamps.

    Returns
    -------
    Prolongation
    """
    if spec.shared not in ("first", "error"):
        raise ValueError(f"spec.shared = {spec.shared!r}: must be 'first' or 'error'")
    comm = fe_mesh.comm
    rank, last = comm.rank, comm.size - 1
    im = V.dofmap.index_map
    bs = V.dofmap.index_map_bs
    if bs != 3:
        raise ValueError(f"V block size = {bs}: must be 3 (vector displacement)")
    n_own = im.size_local
    n_fe = im.size_global * bs
    coords = V.tabulate_dof_coordinates()[:n_own]
    owner = classify_blocks(V, fe_mesh, spec)
    dist = _distributing_fits(V, fe_mesh, spec, owner)
    offset = 3 * im.local_range[0]

    # Reduced numbering.
    free_mask = np.repeat(owner == FREE, 3)
    for _, um, _ in dist:
        local = um - offset
        free_mask[local[(local >= 0) & (local < 3 * n_own)]] = False
    free_dofs = np.flatnonzero(free_mask).astype(np.int64)
    free_blocks = np.unique(free_dofs // 3)
    n_free_local = free_dofs.size
    n_node_free = int(sum(np.count_nonzero(~n.fixed) for n in spec.nodes))
    n_red_local = n_free_local + (n_node_free if rank == last else 0)
    red_start = comm.exscan(n_red_local, op=MPI.SUM)  # collective; None on rank 0
    red_start = int(red_start) if rank > 0 else 0
    n_red = comm.allreduce(n_red_local, op=MPI.SUM)
    node_red: dict[str, np.ndarray] = {}
    nxt = n_red - n_node_free
    for node in spec.nodes:
        idx = np.full(6, -1, dtype=np.int64)
        for i in range(6):
            if not node.fixed[i]:
                idx[i] = nxt
                nxt += 1
        node_red[node.name] = idx

    # FE rows: free -> identity; linked -> rigid-body row; clamped -> empty;
    # UM DOF of distributing links -> their fit's row (added below).
    rows = [free_dofs]
    cols = [red_start + np.arange(n_free_local)]
    vals = [np.ones(n_free_local)]
    rel_node = _relative_nodes(dist, spec, free_mask)
    for k, node in enumerate(spec.nodes):
        blocks = np.flatnonzero(owner == k)
        linked = (3 * blocks[:, None] + np.arange(3)).reshape(-1)
        # per node column: its relative rows, then its rigidly linked ones
        for dofs in (np.flatnonzero(rel_node == k), linked):
            r, c, v = _rigid_rows(dofs, coords, node, node_red[node.name])
            rows.append(r)
            cols.append(c)
            vals.append(v)
    rows_fe = np.concatenate([a.reshape(-1) for a in rows]).astype(np.int64)
    cols_fe = np.concatenate([a.reshape(-1) for a in cols]).astype(np.int64)
    vals_fe = np.concatenate([a.reshape(-1) for a in vals])
    n_rows_fe = 3 * n_own
    if dist:
        rows_fe, cols_fe, vals_fe = _add_um_rows(dist, spec, node_red, (rows_fe, cols_fe, vals_fe),
                                                 n_rows_fe, offset, comm)
    P_fe = _petsc_aij(comm, n_rows_fe, n_red_local, _csr(rows_fe, cols_fe, vals_fe, n_rows_fe))

    # Node rows (global frame) of the full P, on the last rank.
    n_rows = n_rows_fe
    if rank == last:
        n_rows += 6 * len(spec.nodes)
        nr, nc, nv = [], [], []
        for k, node in enumerate(spec.nodes):
            red = node_red[node.name]
            for blk in (0, 3):
                for i in range(3):
                    for m in range(3):
                        if red[blk + m] >= 0 and node.frame[i, m] != 0.0:
                            nr.append(n_rows_fe + 6 * k + blk + i)
                            nc.append(red[blk + m])
                            nv.append(node.frame[i, m])
        rows_fe = np.concatenate([rows_fe, np.asarray(nr, dtype=np.int64)])
        cols_fe = np.concatenate([cols_fe, np.asarray(nc, dtype=np.int64)])
        vals_fe = np.concatenate([vals_fe, np.asarray(nv, dtype=float)])
    P = _petsc_aij(comm, n_rows, n_red_local, _csr(rows_fe, cols_fe, vals_fe, n_rows))

    counts = {
        "free": comm.allreduce(n_free_local, op=MPI.SUM),
        "linked": comm.allreduce(3 * int(np.count_nonzero(owner >= 0)), op=MPI.SUM)
        + 6 * len(dist),
        "clamped": comm.allreduce(3 * int(np.count_nonzero(owner == CLAMPED)), op=MPI.SUM),
        "node": n_node_free,
    }
    if dist:
        counts["distributed"] = comm.allreduce(sum(f.dofs.size for f, _, _ in dist),
                                               op=MPI.SUM)
    per_node = 3 * np.bincount(owner[owner >= 0], minlength=len(spec.nodes))
    per_node = comm.allreduce(per_node, op=MPI.SUM)
    for fit, _, _ in dist:
        per_node[spec.node_index(fit.node)] += 6
    node_links = {n.name: int(c) for n, c in zip(spec.nodes, per_node, strict=True)}
    log.info("prolongation: %d FE DOF -> %d reduced (%s)", n_fe, n_red, counts)
    return Prolongation(
        P=P,
        P_fe=P_fe,
        node_red=node_red,
        n_fe=n_fe,
        n_red=n_red,
        red_range=(red_start, red_start + n_red_local),
        free_coords=coords[free_dofs // 3],
        free_comp=free_dofs % 3,
        counts=counts,
        node_links=node_links,
        free_blocks=free_blocks,
        free_dofs=free_dofs,
        um={fit.surface: um for fit, um, _ in dist},
        free_relative=rel_node[free_dofs] >= 0,
    )


def _relative_nodes(dist: list[tuple[SurfaceFit, np.ndarray, np.ndarray]], spec: ModelSpec,
                    free_mask: np.ndarray) -> np.ndarray:
    """Node index whose rigid motion each free owned FE DOF is measured from (-1: none).

    A free DOF on a distributing surface is the deviation w = u - A q'_c from the rigid
    motion of that link's node (of the first such link when on several).
    """
    rel = np.full(free_mask.size, -1, dtype=np.int64)
    for fit, _, _ in dist:
        d = fit.dofs[free_mask[fit.dofs] & (rel[fit.dofs] < 0)]
        rel[d] = spec.node_index(fit.node)
    return rel


def _rigid_rows(dofs: np.ndarray, coords: np.ndarray, node: Any, red: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Entries A q'_c of P for owned FE DOF ``dofs`` on ``node``'s rigid motion: the
    whole row of a rigidly linked DOF (u = A q'_c), the node part of a free DOF measured
    from it (u = A q'_c + w). Local DOF m on component j: translations R[j, m],
    rotations (R[:, m] x d)[j], since theta x d = sum_m theta'_m (R[:, m] x d).

    Parameters
    ----------
    dofs : numpy.ndarray of int64
        Local owned FE DOF (``3 * block + comp``).
    coords : numpy.ndarray, shape (n_own, 3)
        Coordinates (m) of the owned blocks.
    node : fem.Node
    red : numpy.ndarray of int64, shape (6,)
        Reduced indices of the node's DOF (-1 where fixed).

    Returns
    -------
    (rows, cols, vals)
    """
    A = rigid_motion_matrix(coords[dofs // 3], node.centre, node.frame)
    A = A[np.arange(dofs.size), dofs % 3]  # (n, 6): the row of each DOF's component
    keep = (red[None, :] >= 0) & (A != 0.0)
    r = np.broadcast_to(dofs[:, None], A.shape)[keep]
    c = np.broadcast_to(red[None, :], A.shape)[keep]
    return r, c, A[keep]


def _add_um_rows(dist: list[tuple[SurfaceFit, np.ndarray, np.ndarray]], spec: ModelSpec,
                 node_red: dict[str, np.ndarray], triplets: tuple, n_local: int, offset: int,
                 comm: MPI.Comm) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Append the rows of the UM DOF of each distributing link to the FE triplets.

    Each is computed from the free and rigid rows only: a UM DOF lies on no other
    distributing surface, so no fit's other DOF is another fit's UM DOF.
    """
    parts: list[list[np.ndarray]] = [[a] for a in triplets]
    for fit, um, Gm in dist:
        new = um_rows(fit, um, Gm, node_red[fit.node], triplets, n_local, offset, comm)
        for lst, a in zip(parts, new, strict=True):
            lst.append(a)
    rows, cols, vals = (np.concatenate(lst) for lst in parts)
    return rows, cols, vals
