"""Distributing (RBE3-type) links: the node follows the mass-weighted rigid fit of a surface.

For a surface S with FE displacement DOF u_S (3n values, global components) and a node c
of local frame R, the rigid motion of local node DOF q'_c = (u', theta') is
u_S = A q'_c with, at a DOF point x, the 3x6 block A(x) = [R, (R e_m) x (x - x_c)].
The node's motion is the weighted least-squares rigid fit of u_S, weighted with the
surface's consistent mass matrix M_S (P2, ``inner(u, v) * ds``):

    q'_c = G u_S,   G = N^{-1} A^T M_S,   N = A^T M_S A   (6 x 6, m^2, m^3, m^4),

so G A = I. The node's 6 DOF stay reduced unknowns; 6 surface DOF m (the "UM set" of
Nastran's RBE3) are eliminated instead: u_m = G_m^{-1} (q'_c - G_r u_r), with G_m (6x6)
chosen well conditioned by column-pivoted QR and maxvol swaps. :mod:`fem.prolongation`
writes the other free surface DOF as deviations from the node's rigid motion
(u_r = A_r q'_c + w_r), so that u_m = A_m q'_c - G_m^{-1} G_r w_r has O(1) coefficients.
The force side is G^T F_c (through P^T).

Cost: a UM row is dense over the surface, so K_bar = P^T K P (and M_bar) holds a dense
block over each distributing surface's n_S DOF (rank-6 in K_mm, stored as n_S^2
entries): 7e7 for the pump's hub seat on 1.9 mm shaft elements (n_S = 8 340).

These equations are this project's; the idea is Nastran's RBE3 element with its UM set
(MSC Nastran Quick Reference Guide, "RBE3"). The paper uses rigid links only.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Any

import numpy as np
from mpi4py import MPI

from .mesh import FEMesh
from .spec import Node

log = logging.getLogger(__name__)

#: Largest accepted condition number of the length-scaled N and G_m.
MAX_COND = 1e10


@dataclass
class SurfaceFit:
    """The rigid fit of one distributing link, this rank's part.

    Attributes
    ----------
    surface, node : str
        The linked surface group and node names.
    dofs : numpy.ndarray of int64, shape (n,)
        This rank's owned FE DOF of the surface, local row index ``3 * block + comp``.
    G : numpy.ndarray, shape (6, n)
        Columns of G at ``dofs`` (translations -, rotations 1/m), node local frame.
    N : numpy.ndarray, shape (6, 6)
        A^T M_S A (same on every rank; m^2 translations, m^3, m^4 with rotations).
    length : float
        RMS distance (m) of the surface from the node centre, the scale of rotations.
    x : numpy.ndarray, shape (n, 3)
        Coordinates (m) of ``dofs``.
    """

    surface: str
    node: str
    dofs: np.ndarray
    G: np.ndarray
    N: np.ndarray
    length: float
    x: np.ndarray


def rigid_motion_matrix(x: np.ndarray, centre: np.ndarray, frame: np.ndarray) -> np.ndarray:
    """Rigid-motion blocks A(x) of points ``x`` about ``centre`` in the local ``frame``.

    Parameters
    ----------
    x : numpy.ndarray, shape (n, 3)
        Points (m), global frame.
    centre : numpy.ndarray, shape (3,)
        Node centre (m).
    frame : numpy.ndarray, shape (3, 3)
        Columns = the node's local axes in global components.

    Returns
    -------
    numpy.ndarray, shape (n, 3, 6)
        ``A[i, j, m]``: global component j at point i per unit local node DOF m
        (translations -, rotations m/rad).
    """
    d = np.asarray(x, dtype=float) - centre
    A = np.empty((d.shape[0], 3, 6))
    A[:, :, :3] = frame[None, :, :]
    for m in range(3):
        A[:, :, 3 + m] = np.cross(frame[:, m][None, :], d)
    return A


def _scaling(length: float) -> np.ndarray:
    """Diagonal that makes the node DOF dimensionless (rotations times ``length``)."""
    return np.array([1.0, 1.0, 1.0, length, length, length])


def fit_operator(A: np.ndarray, B: np.ndarray, comm: MPI.Comm, label: str
                 ) -> tuple[np.ndarray, np.ndarray, float]:
    """G = N^{-1} B^T with N = A^T B summed over ranks, checked for a unique fit.

    Parameters
    ----------
    A : numpy.ndarray, shape (k, 6)
        Rigid-motion rows of this rank's surface DOF.
    B : numpy.ndarray, shape (k, 6)
        M_S A at the same DOF (m^2 per unit node DOF).
    comm : MPI.Comm
    label : str
        Names the link in errors.

    Returns
    -------
    G : numpy.ndarray, shape (6, k)
    N : numpy.ndarray, shape (6, 6)
    length : float
        sqrt(trace(N_rot) / (2 trace(N_trans))) (m), the surface's RMS radius about
        the node.

    Raises
    ------
    ValueError
        When the scaled N has a condition number above :data:`MAX_COND`: the surface
        does not fix a rigid motion (fewer than 3 non-collinear points, or no
        exterior facet: ``ds`` integrates exterior facets only).
    """
    N = comm.allreduce(A.T @ B, op=MPI.SUM)
    N = 0.5 * (N + N.T)
    tr_t = float(np.trace(N[:3, :3]))
    if not (np.isfinite(tr_t) and tr_t > 0):
        raise ValueError(f"{label}: surface area = {tr_t / 3:.3g} m^2 on exterior facets; "
                         "must be > 0 (a distributing link needs boundary facets)")
    length = float(np.sqrt(max(np.trace(N[3:, 3:]), 0.0) / (2.0 * tr_t)))
    s = _scaling(length) if length > 0 else np.ones(6)
    Ns = N / s[:, None] / s[None, :]
    cond = np.linalg.cond(Ns)
    if not np.isfinite(cond) or cond > MAX_COND:
        raise ValueError(f"{label}: the surface does not fix a rigid motion (scaled A^T M_S A "
                         f"has condition number {cond:.3g} > {MAX_COND:.0e}); it needs at "
                         "least 3 non-collinear points")
    return np.linalg.solve(N, B.T), N, length


def surface_fit(V: Any, fe_mesh: FEMesh, surface: str, node: Node,
                dofs: np.ndarray) -> SurfaceFit:
    """Rigid fit of ``surface`` about ``node`` (collective).

    Parameters
    ----------
    V : dolfinx.fem.FunctionSpace
        P2 vector displacement space (block size 3).
    fe_mesh : FEMesh
    surface : str
        Surface group name.
    node : Node
    dofs : numpy.ndarray of int64
        This rank's owned DOF on the surface (``3 * block + comp``).

    Returns
    -------
    SurfaceFit
    """
    import ufl
    from dolfinx import fem
    from dolfinx.fem.petsc import assemble_vector
    from petsc4py import PETSc

    msh = fe_mesh.mesh
    ds = ufl.Measure("ds", domain=msh, subdomain_data=fe_mesh.facet_tags)
    w = fem.Function(V)
    form = fem.form(ufl.inner(w, ufl.TestFunction(V)) * ds(fe_mesh.tag(surface, 2)))
    x_all = V.tabulate_dof_coordinates()
    A_all = rigid_motion_matrix(x_all, node.centre, node.frame)
    B = np.empty((dofs.size, 6))
    for m in range(6):
        w.x.array[:] = A_all[:, :, m].reshape(-1)
        b = assemble_vector(form)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        B[:, m] = b.array_r[dofs]
        b.destroy()
    A = A_all.reshape(-1, 6)[dofs]
    G, N, length = fit_operator(A, B, fe_mesh.comm, f"distributing link {surface!r} -> "
                                f"{node.name!r}")
    return SurfaceFit(surface, node.name, dofs, G, N, length, x_all[dofs // 3])


def choose_um(fit: SurfaceFit, eligible: np.ndarray, dof_offset: int,
              comm: MPI.Comm) -> tuple[np.ndarray, np.ndarray]:
    """The 6 eliminated DOF (UM set) of a fit: column-pivoted QR on the scaled G.

    The candidates are ordered by coordinates and component, and the pivots found on
    G rounded to 12 digits, so that the choice does not depend on the partition.

    Parameters
    ----------
    fit : SurfaceFit
    eligible : numpy.ndarray of bool, shape (len(fit.dofs),)
        DOF that may be eliminated (free, on no other distributing surface).
    dof_offset : int
        Global FE index of this rank's first owned DOF.
    comm : MPI.Comm

    Returns
    -------
    um : numpy.ndarray of int64, shape (6,)
        Global FE DOF indices (same on every rank).
    Gm : numpy.ndarray, shape (6, 6)
        Columns of G at ``um``.

    Raises
    ------
    ValueError
        Fewer than 6 eligible DOF, or G_m with condition number above :data:`MAX_COND`.
    """
    from scipy.linalg import qr

    label = f"distributing link {fit.surface!r} -> {fit.node!r}"
    ids_all = np.concatenate(comm.allgather(fit.dofs[eligible].astype(np.int64) + dof_offset))
    G_all = np.concatenate(comm.allgather(fit.G[:, eligible]), axis=1)
    x_all = np.concatenate(comm.allgather(fit.x[eligible]), axis=0)
    order = np.lexsort((ids_all % 3, x_all[:, 2], x_all[:, 1], x_all[:, 0]))
    ids_all, G_all = ids_all[order], G_all[:, order]
    if ids_all.size < 6:
        raise ValueError(f"{label}: {ids_all.size} surface DOF free to eliminate; needs >= 6 "
                         "(the others are clamped, rigidly linked or on another "
                         "distributing surface)")
    Gs = _scaling(fit.length)[:, None] * G_all
    scale = float(np.abs(Gs).max()) if Gs.size else 1.0
    _, piv = qr(np.round(Gs / scale, 12), mode="r", pivoting=True)
    pick = piv[:6].copy()
    cond = np.linalg.cond(Gs[:, pick])
    if not np.isfinite(cond) or cond > MAX_COND:
        raise ValueError(f"{label}: no well-conditioned set of 6 DOF to eliminate "
                         f"(condition number {cond:.3g} > {MAX_COND:.0e})")
    pick, c_max = _maxvol(np.round(Gs / scale, 12), pick)
    log.info("%s: %d surface DOF, UM set: condition number %.3g, largest |G_m^-1 G_r| "
             "%.3g", label, ids_all.size, np.linalg.cond(Gs[:, pick]), c_max)
    return ids_all[pick], G_all[:, pick]


def _maxvol(G: np.ndarray, pick: np.ndarray, bound: float = 1.05, max_swaps: int = 200
            ) -> tuple[np.ndarray, float]:
    """Swap columns into ``pick`` until every |G_pick^{-1} G| <= ``bound``.

    Each swap multiplies |det G_pick| by the entry swapped in (> ``bound``), so this
    ends; afterwards the UM rows' coefficients on the other surface DOF are at most
    ``bound`` (a "maximal volume" submatrix, up to the bound).

    Returns
    -------
    pick : numpy.ndarray of int, shape (6,)
    c_max : float
        The largest |G_pick^{-1} G| reached.
    """
    for _ in range(max_swaps):
        C = np.linalg.solve(G[:, pick], G)
        i, j = np.unravel_index(int(np.argmax(np.abs(C))), C.shape)
        c_max = float(abs(C[i, j]))
        if c_max <= bound:
            break
        pick[i] = j
    return pick, c_max


def um_rows(fit: SurfaceFit, um: np.ndarray, Gm: np.ndarray, node_red: np.ndarray,
            triplets: tuple[np.ndarray, np.ndarray, np.ndarray], n_local: int,
            dof_offset: int, comm: MPI.Comm) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rows of P of the eliminated DOF: u_m = G_m^{-1} (q'_c - G_r P_r q) (collective).

    Parameters
    ----------
    fit : SurfaceFit
    um : numpy.ndarray of int64, shape (6,)
        Global FE indices of the eliminated DOF; ``Gm`` their columns of G.
    Gm : numpy.ndarray, shape (6, 6)
    node_red : numpy.ndarray of int64, shape (6,)
        Reduced indices of the node's local DOF (-1 where fixed: that q'_c is 0).
    triplets : (rows, cols, vals)
        This rank's entries of P for its owned FE rows (local row index), without the
        rows of any eliminated DOF.
    n_local : int
        Number of this rank's owned FE DOF (3 x owned blocks).
    dof_offset : int
        Global FE index of this rank's first owned DOF.
    comm : MPI.Comm

    Returns
    -------
    (rows, cols, vals)
        Entries of the eliminated DOF's rows owned by this rank (local row index,
        global reduced column).
    """
    rows, cols, vals = triplets
    g = np.zeros((n_local, 6))
    g[fit.dofs] = fit.G.T
    local_um = um - dof_offset
    own = (local_um >= 0) & (local_um < n_local)
    g[local_um[own]] = 0.0
    on = np.zeros(n_local, dtype=bool)
    on[fit.dofs] = True
    sel = on[rows]
    contrib = g[rows[sel]] * vals[sel, None]
    uc, inv = np.unique(cols[sel], return_inverse=True)
    W = np.zeros((uc.size, 6))
    np.add.at(W, inv, contrib)
    all_c = np.concatenate(comm.allgather(uc))
    all_w = np.concatenate(comm.allgather(W), axis=0)
    uc, inv = np.unique(all_c, return_inverse=True)
    W = np.zeros((uc.size, 6))
    np.add.at(W, inv, all_w)
    # T (6 x columns) = E - W^T, E the node's own columns
    free = node_red >= 0
    cols_t, inv = np.unique(np.concatenate([node_red[free], uc]), return_inverse=True)
    T = np.zeros((6, cols_t.size))
    np.add.at(T.T, inv, np.concatenate([np.eye(6)[:, free], -W.T], axis=1).T)
    R = np.linalg.solve(Gm, T)  # row j: coefficients of u_m[j]
    n_own = int(np.count_nonzero(own))
    out_r = np.repeat(local_um[own], cols_t.size)
    out_c = np.tile(cols_t, n_own)
    out_v = R[own].reshape(-1)
    keep = out_v != 0.0
    return out_r[keep].astype(np.int64), out_c[keep].astype(np.int64), out_v[keep]
