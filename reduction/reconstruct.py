"""Recover the FE unknowns from reduced coordinates: ``u = T q`` (eq. 8)."""

from __future__ import annotations

import numpy as np
from petsc4py import PETSc


def reconstruct(T: PETSc.Mat, q) -> PETSc.Vec | tuple[PETSc.Vec, PETSc.Vec]:
    """Distributed FE vector ``u = T q`` of the unknowns after links/clamping.

    Parameters
    ----------
    T : PETSc.Mat
        Distributed dense basis ``n × n_r`` (``ROM.T`` or ``load_basis``).
    q : array (n_r,)
        Reduced coordinates (same on every rank), real or complex (a complex
        Fourier amplitude: real and imaginary parts are two real products).

    Returns
    -------
    PETSc.Vec, or (PETSc.Vec, PETSc.Vec) for complex ``q``
        ``T q`` with the row layout of ``T`` (of the FE matrices); for complex
        ``q`` the pair ``(T Re q, T Im q)``.
    """
    q = np.asarray(q)
    n_r = T.getSize()[1]
    if q.shape != (n_r,):
        raise ValueError(f"q.shape = {q.shape}: must be ({n_r},)")
    if not np.all(np.isfinite(q)):
        raise ValueError("q: contains non-finite entries")
    if np.iscomplexobj(q):
        return _product(T, q.real.copy()), _product(T, q.imag.copy())
    return _product(T, q.astype(float))


def _product(T: PETSc.Mat, q: np.ndarray) -> PETSc.Vec:
    x, u = T.createVecs()
    c0, c1 = x.getOwnershipRange()
    x.setArray(q[c0:c1])
    T.mult(x, u)
    x.destroy()
    return u
