"""The reduced-to-field operator ``P T`` and its rows at points of the mesh.

A ROM coordinate vector ``q`` gives the P2 displacement ``u = P T q`` (eq. 8: ``T`` the
reduction basis on the reduced unknowns, ``P`` the prolongation of links and clamps).
``P T`` stays a distributed dense PETSc matrix; the rows wanted at given nodes or points
are taken by multiplying it with a sparse AIJ matrix whose rows hold the shape-function
weights and whose columns are global P2 DOF numbers, so DOF owned by another rank come
through PETSc (as ``dolfinx.fem.Function.eval`` would need them on the owning rank).
"""
from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["field_operator", "aij_on_rows", "on_p_layout", "point_rows"]


def field_operator(model: Any, T: Any) -> Any:
    """``P T``: the reduction basis on the P2 DOF of ``model.V`` (collective).

    Parameters
    ----------
    model : fem.FEModel
    T : PETSc dense Mat (rows on ``model.K``'s layout), or (n_red, n_r) float (one process)
        Reduction basis (``rom/basis``).

    Returns
    -------
    PETSc dense Mat
        Rows on ``model.P``'s row layout (the P2 DOF of V, then the 6-DOF node rows on the
        last rank); the caller destroys it.
    """
    return model.P.matMult(_dense_mat(T, model.comm))


def _dense_mat(T: Any, comm: Any) -> Any:
    """``T`` as a PETSc dense matrix: a PETSc Mat is returned as is, a NumPy array (the
    whole basis, one process only) is copied into a sequential dense matrix."""
    from petsc4py import PETSc

    if isinstance(T, PETSc.Mat):
        return T
    if comm.size != 1:
        raise RuntimeError("a NumPy basis is serial only: give the distributed PETSc basis")
    T = np.asarray(T, dtype=float)
    out = PETSc.Mat().createDense(T.shape, comm=PETSc.COMM_SELF)
    out.setUp()
    out.getDenseArray()[:] = T
    out.assemble()
    return out


def aij_on_rows(P: Any, n_rows_local: int, csr: tuple) -> Any:
    """AIJ matrix with ``n_rows_local`` rows here and the columns of ``P``'s row layout
    (the P2 DOF of V, then the 6-DOF node rows on the last rank); ``csr`` = (row
    pointers, global column numbers, values) of the local rows."""
    from petsc4py import PETSc

    it = PETSc.IntType
    ip, ix, vals = csr
    A = PETSc.Mat().createAIJ(
        size=((n_rows_local, PETSc.DETERMINE), (P.getLocalSize()[0], P.getSize()[0])),
        csr=(np.asarray(ip, dtype=it), np.asarray(ix, dtype=it),
             np.asarray(vals, dtype=PETSc.ScalarType)), comm=P.getComm())
    A.assemble()
    return A


def on_p_layout(A: Any, P: Any) -> Any:
    """The V-layout matrix ``A`` (n_V × n_V) on ``P``'s row layout (square): the V DOF
    keep their global numbers, the node rows of P get empty rows and columns."""
    ip, ix, vals = A.getValuesCSR()
    n_pad = P.getLocalSize()[0] - (ip.size - 1)
    ip = np.concatenate([ip, np.full(n_pad, ip[-1], dtype=ip.dtype)])
    return aij_on_rows(P, P.getLocalSize()[0], (ip, ix, vals))


def point_rows(model: Any, PT: Any, blocks: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """``u`` per unit ROM coordinate at points given as weighted sums of DOF blocks
    (n × 3 × n_r; m per unit of the ROM coordinate, the basis' own units), from the
    distributed ``P T``: one AIJ row per point and component (global P2 DOF numbers as
    columns) times ``P T`` (collective on ``model.comm``; ``n`` may differ per rank).

    Parameters
    ----------
    model : fem.FEModel
    PT : PETSc dense Mat
        :func:`field_operator`.
    blocks : (n, k) int
        Local DOF blocks of ``model.V`` (ghosts allowed) of each point's nodes.
    weights : (k,) float
        Weight of each node (the shape-function values at the point).
    """
    V = model.V
    n, k = blocks.shape
    if np.any(blocks < 0):
        raise RuntimeError("basis rows: a node without a DOF block")
    gblocks = np.asarray(V.dofmap.index_map.local_to_global(
        np.ascontiguousarray(blocks.ravel(), dtype=np.int32)), dtype=np.int64).reshape(n, k)
    order = np.argsort(gblocks, axis=1)                            # sorted columns per row
    cols = np.take_along_axis(gblocks, order, axis=1)
    w = np.asarray(weights, dtype=float)[order]
    ip = np.arange(0, k * n + 1, k, dtype=np.int64)
    out = np.empty((n, 3, PT.getSize()[1]))
    for i in range(3):
        R = aij_on_rows(model.P, n, (ip, (3 * cols + i).ravel(), w.ravel()))
        X = R.matMult(PT)
        out[:, i, :] = X.getDenseArray()
        X.destroy()
        R.destroy()
    return out
