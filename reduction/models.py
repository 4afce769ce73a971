"""Small test/benchmark models with known structure (optional helpers).

``spring_chain`` is pure PETSc; ``elastic_box`` needs DOLFINx (imported lazily)
and assembles a P2 linear-elastic box, optionally clamped at ``x = 0``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from petsc4py import PETSc


@dataclass
class PlainModel:
    """M, K (distributed AIJ) and the chosen interface DOF (global indices)."""

    M: PETSc.Mat
    K: PETSc.Mat
    interface_dofs: np.ndarray


def chain_data(n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Spring stiffnesses (n+1) [N/m] and masses (n) [kg] of a fixed–fixed chain."""
    rng = np.random.default_rng(seed)
    return 1e6 * (1.0 + rng.random(n + 1)), 1.0 + rng.random(n)


def spring_chain(n: int, interface_dofs, seed: int = 0, comm=None) -> PlainModel:
    """Fixed–fixed spring–mass chain (tridiagonal K, diagonal M), distributed."""
    comm = comm or PETSc.COMM_WORLD
    k, m = chain_data(n, seed)
    K = PETSc.Mat().createAIJ((n, n), nnz=3, comm=comm)
    M = PETSc.Mat().createAIJ((n, n), nnz=1, comm=comm)
    r0, r1 = K.getOwnershipRange()
    for i in range(r0, r1):
        K[i, i] = k[i] + k[i + 1]
        if i > 0:
            K[i, i - 1] = -k[i]
        if i < n - 1:
            K[i, i + 1] = -k[i + 1]
        M[i, i] = m[i]
    K.assemble()
    M.assemble()
    return PlainModel(M, K, np.asarray(interface_dofs, dtype=np.int64))


def chain_dense(n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Dense (M, K) of :func:`spring_chain`, for reference solutions."""
    k, m = chain_data(n, seed)
    K = np.diag(k[:-1] + k[1:]) - np.diag(k[1:-1], 1) - np.diag(k[1:-1], -1)
    return np.diag(m), K


def elastic_box(
    size=(0.3, 0.04, 0.04),
    cells=(6, 1, 1),
    clamped: bool = True,
    E: float = 210e9,
    nu: float = 0.3,
    rho: float = 7800.0,
    comm=None,
) -> PlainModel:
    """P2 elasticity box; interface = x, y, z of four corner nodes (12 DOF).

    Clamped: the face ``x = 0`` is removed from the unknowns (like ``fem``'s
    elimination) and the interface is the four corners of ``x = L``. Free: no
    support, interface on four non-coplanar corners, so the interface holds
    every rigid-body motion. The interface order is corner by corner, (x, y, z).
    """
    import ufl
    from dolfinx import fem, mesh
    from dolfinx.fem.petsc import assemble_matrix
    from mpi4py import MPI

    comm = comm or MPI.COMM_WORLD
    L, W, H = size
    msh = mesh.create_box(comm, [np.zeros(3), np.array(size)], list(cells),
                          mesh.CellType.tetrahedron)
    V = fem.VectorFunctionSpace(msh, ("CG", 2))
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    mu, lmbda = E / (2 * (1 + nu)), E * nu / ((1 + nu) * (1 - 2 * nu))

    def strain(w):
        return ufl.sym(ufl.grad(w))

    def stress(w):
        return 2 * mu * strain(w) + lmbda * ufl.tr(strain(w)) * ufl.Identity(3)

    K = assemble_matrix(fem.form(ufl.inner(stress(u), strain(v)) * ufl.dx))
    M = assemble_matrix(fem.form(rho * ufl.inner(u, v) * ufl.dx))
    K.assemble()
    M.assemble()

    imap = V.dofmap.index_map
    n_own = imap.size_local
    b0 = imap.local_range[0]
    x = V.tabulate_dof_coordinates()[:n_own]
    tol = 1e-9 * L
    keep_node = x[:, 0] > tol if clamped else np.ones(n_own, dtype=bool)
    keep = np.repeat(keep_node, 3)
    old = 3 * b0 + np.arange(3 * n_own)
    free = old[keep]
    offset = comm.exscan(free.size)  # collective; None on rank 0
    offset = offset if comm.rank > 0 else 0
    if clamped:
        corners = [(L, 0, 0), (L, W, 0), (L, 0, H), (L, W, H)]
    else:
        corners = [(0, 0, 0), (L, W, 0), (L, 0, H), (0, W, H)]
    found = {}
    for c, target in enumerate(corners):
        hit = np.flatnonzero(np.linalg.norm(x - np.array(target), axis=1) < tol)
        if hit.size:
            pos = int(np.flatnonzero(free == 3 * (b0 + hit[0]))[0])
            found[c] = offset + pos
    allfound = {}
    for d in comm.allgather(found):
        allfound.update(d)
    iface = np.array([allfound[c] + j for c in range(4) for j in range(3)], dtype=np.int64)
    if clamped:
        is_free = PETSc.IS().createGeneral(free.astype(PETSc.IntType), comm=K.getComm())
        K_f = K.createSubMatrix(is_free, is_free)
        M_f = M.createSubMatrix(is_free, is_free)
        K.destroy()
        M.destroy()
        K, M = K_f, M_f
    return PlainModel(M, K, iface)
