"""A small generalized eigen-solver (SLEPc Krylov-Schur, shift-and-invert, MUMPS)."""

from __future__ import annotations

import logging
import math
from typing import Any

import numpy as np

log = logging.getLogger(__name__)


def shift_invert_eps(K: Any, M: Any, sigma: float, tol: float, max_it: int = 500) -> Any:
    """A SLEPc generalized eigensolver for K x = w^2 M x, configured, not solved.

    Krylov-Schur, eigenvalues nearest ``sigma`` (rad^2/s^2), shift-and-invert with
    a direct MUMPS LU of ``K - sigma M`` (the factor is reachable through
    ``eps.getST().getKSP().getPC().getFactorMatrix()`` once solved). Callers set
    the number of pairs (``setDimensions``) and an options prefix as they need.
    """
    from petsc4py import PETSc
    from slepc4py import SLEPc

    eps = SLEPc.EPS().create(K.getComm())
    eps.setOperators(K, M)
    eps.setProblemType(SLEPc.EPS.ProblemType.GHEP)
    eps.setType(SLEPc.EPS.Type.KRYLOVSCHUR)
    eps.setTarget(sigma)
    eps.setWhichEigenpairs(SLEPc.EPS.Which.TARGET_MAGNITUDE)
    eps.setTolerances(tol, max_it)
    st = eps.getST()
    st.setType(SLEPc.ST.Type.SINVERT)
    st.setShift(sigma)
    ksp = st.getKSP()
    ksp.setType(PETSc.KSP.Type.PREONLY)
    pc = ksp.getPC()
    pc.setType(PETSc.PC.Type.LU)
    pc.setFactorSolverType("mumps")
    return eps


def eigenfrequencies(
    K: Any,
    M: Any,
    n: int,
    sigma: float = 0.0,
    tol: float = 1e-12,
    max_it: int = 500,
    return_vectors: bool = False,
) -> np.ndarray | tuple[np.ndarray, list]:
    """The ``n`` eigenfrequencies of K x = w^2 M x nearest to the shift ``sigma``.

    Parameters
    ----------
    K, M : PETSc.Mat
        Symmetric stiffness (N/m) and positive semi-definite mass (kg).
    n : int
        Number of modes, >= 1.
    sigma : float
        Shift in w^2 units (rad^2/s^2). Must not be an eigenvalue: use a negative
        value (e.g. -1e2) for a structure with rigid-body modes.
    tol : float
        SLEPc relative residual tolerance.
    max_it : int
    return_vectors : bool
        Also return the eigenvectors (PETSc Vec, M-normalised by SLEPc).

    Returns
    -------
    numpy.ndarray, shape (n,)
        Frequencies f = sign(w^2) sqrt(|w^2|) / (2 pi) (Hz), ascending; a slightly
        negative w^2 (rigid-body mode) gives a slightly negative f.
    """
    from petsc4py import PETSc

    if int(n) < 1:
        raise ValueError(f"n = {n}: must be >= 1")
    if not math.isfinite(sigma):
        raise ValueError(f"sigma = {sigma}: must be finite")
    eps = shift_invert_eps(K, M, sigma, tol, max_it)
    eps.setDimensions(int(n), PETSc.DECIDE)
    eps.solve()
    nconv = eps.getConverged()
    if nconv < n:
        eps.destroy()
        raise RuntimeError(f"eigenfrequencies: {nconv} of {n} eigenpairs converged")
    # Rayleigh quotients x^T K x / x^T M x of the converged vectors: their error is
    # quadratic in the vector error, so rigid-body modes come out far below
    # eps * lambda_max, the accuracy of sigma + 1/theta.
    lam = np.empty(nconv)
    vecs_all = []
    kx, mx = K.createVecLeft(), M.createVecLeft()
    for i in range(nconv):
        x = K.createVecRight()
        eps.getEigenvector(i, x)
        K.mult(x, kx)
        M.mult(x, mx)
        lam[i] = x.dot(kx) / x.dot(mx)
        vecs_all.append(x)
    order = np.argsort(np.abs(lam - sigma))[: int(n)]
    order = order[np.argsort(lam[order])]
    lam = lam[order]
    f = np.sign(lam) * np.sqrt(np.abs(lam)) / (2.0 * math.pi)
    vecs = [vecs_all[i] for i in order] if return_vectors else []
    eps.destroy()
    log.info("eigenfrequencies (Hz): %s", np.array2string(f, precision=4))
    return (f, vecs) if return_vectors else f
