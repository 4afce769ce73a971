"""Dense products of distributed PETSc matrices that every rank needs whole.

``Tᵀ A T`` with a tall distributed dense ``T`` (a reduction basis, or ``P T`` on the
P2 DOF) and a sparse ``A`` gives a small dense matrix: the Craig–Bampton ``M_r``,
``K_r`` (eq. 9, :mod:`reduction.craig_bampton`) and the radiation matrix ``W``
(:mod:`fem.post.radiation`). It lives in the FE layer so that both can use it.
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["dense_projection"]


def dense_projection(A: Any, T: Any) -> np.ndarray:
    """Dense ``Tᵀ A T`` (symmetrised) on every rank: ``A·T`` by PETSc, then each rank's
    rows ``T_locᵀ (AT)_loc`` summed with an allreduce (eq. 9).

    Parameters
    ----------
    A : PETSc.Mat
        Square AIJ matrix on ``T``'s row layout.
    T : PETSc.Mat
        Distributed dense matrix (n × m).
    """
    from mpi4py import MPI

    AT = A.matMult(T)
    local = T.getDenseArray().T @ AT.getDenseArray()
    AT.destroy()
    out = np.empty_like(local)
    T.getComm().tompi4py().Allreduce(np.ascontiguousarray(local), out, op=MPI.SUM)
    return 0.5 * (out + out.T)
