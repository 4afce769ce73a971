"""Hill's method for the Floquet exponents of a periodic solution, for comparisons with
the monodromy of :mod:`hbm.stability.monodromy` (:func:`floquet_exponents`,
``method="hill"``).

A perturbation ``y = exp(lambda t) p(t)`` of the periodic solution, p periodic
and expanded on the same harmonic set, satisfies the quadratic eigenproblem

    (lambda^2 M_hat + lambda D1 + D0) p = 0,

with D0 the HBM Jacobian (eq. 21 differentiated with respect to the real
unknowns, here of the uncondensed system: ``real(Z'_k) + sum_ef (g_e g_f^T) (x) J_ef``),
D1 the real form of ``C + 2 i k w0 M`` per harmonic and ``M_hat = I (x) M``.  Of its
2 m n_real eigenvalues, the 2 m Floquet exponents are those whose eigenvectors carry the
largest weight on the mean (index 0) component (eigenvector-weight criterion,
Lazarus & Thomas 2010); the others are copies shifted by i k w0.  For a
contiguous set {0, 1, ..., H} whose band H w0 / 2 covers the natural
frequencies, the cheaper imaginary-part criterion is used (the 2 m eigenvalues
of smallest |Im lambda|, eigenvalues only): a mode above the band has no copy
in the strip |Im| <= w0/2.  Liouville's formula (sum of the real parts =
-tr(M^-1 C)) checks the selection (tests).

For a problem whose damping is modal in the modes of eq. (17) the computation
is done in modal coordinates (M = I, diagonal C and K); rigid-body modes no element
moves are decoupled and left out. The real companion matrix has
size 2 m n_real; beyond ``max_size`` only the modes with the largest dynamic
participation along the elements are kept, and the omitted ones enter through their
compliance along the elements at the harmonic frequencies, ``H_rest,k`` (a residual
flexibility, evaluated at lambda = 0): the coupling ``J_f`` becomes
``J_f (I + H_rest J_f)^-1``. This is exact for the kept exponents in the limit
where the omitted modes are far above the band, and an approximation otherwise.
"""

from __future__ import annotations

import logging

import numpy as np
import scipy.linalg as sla

from ..basis import mul_rows, real_blocks
from ..problem import HBMProblem, Point
from .exponents import positive_real_root
from .verdict import stability

logger = logging.getLogger(__name__)

__all__ = ["floquet_exponents", "hill_coordinates"]


def hill_coordinates(problem: HBMProblem, max_size: int, omega: float):
    """Hill coordinates (M, C, K, g) and the omitted modes' compliance per harmonic.

    ``g`` holds the elements' directions in those coordinates, (E, m). Modal damping: the
    eq. (17) modes, at most ``max_size / (2 n_real)`` of them, those with the largest
    dynamic participation along an element ``max_k |g_ej^2 / (w_j^2 - (k w0)^2 + i k w0
    c_j)|``; the omitted ones enter as a quasi-static residual compliance
    ``H_rest,k`` (E, E, nS) along the elements (exact when their exponents are far from
    the band, see floquet_exponents).
    """
    nr = problem.nr
    ne = problem.n_elements
    if problem.modal:
        keep = np.flatnonzero(~problem.rigid)
        h_rest = np.zeros((ne, ne, problem.nS), dtype=complex)
        rest_max = -np.inf
        if 2 * keep.size * nr > max_size:
            inv, _ = problem.modal_inverse(omega, derivative=False)
            gj = problem.gj
            part = np.max(np.abs(((gj[0] ** 2)[:, None] * inv)[keep]), axis=1)
            for g in gj[1:]:
                part = np.maximum(part, np.max(np.abs(((g ** 2)[:, None] * inv)[keep]),
                                                axis=1))
            nkeep = max(1, max_size // (2 * nr))
            order = np.argsort(part, kind="stable")[::-1]
            rest = keep[order[nkeep:]]
            keep = np.sort(keep[order[:nkeep]])
            for e in range(ne):
                for f in range(ne):
                    g2 = gj[e] ** 2 if e == f else gj[e] * gj[f]
                    h_rest[e, f] = (g2[:, None] * inv)[rest].sum(axis=0)
            # nominal exponents of the omitted modes (largest real part of each)
            c, w2 = problem.cj[rest], problem.w2[rest]
            disc = np.sqrt(np.maximum(c * c - 4 * w2, 0.0))
            rest_max = float(np.max((-c + disc) / 2)) if rest.size else -np.inf
            logger.debug("Hill: %d of %d modes kept (max_size=%d)", keep.size,
                         problem.w2.size, max_size)
        m = keep.size
        return (np.eye(m), np.diag(problem.cj[keep]), np.diag(problem.w2[keep]),
                problem.gj[:, keep], h_rest, rest_max)
    s = problem.system
    if 2 * s.n_dof * nr > max_size:
        raise ValueError(
            f"stability: Hill matrix size {2 * s.n_dof * nr} > max_size {max_size} for a "
            "non-modal damping; disable stability or use modal damping")
    return (s.M, s.C, problem.Kp, np.stack(problem.directions),
            np.zeros((ne, ne, problem.nS), dtype=complex), -np.inf)


def floquet_exponents(problem: HBMProblem, point: Point, max_size: int = 600,
                      criterion: str = "auto", method: str = "monodromy"):
    """Floquet exponents (1/s) of a periodic solution and their largest real part.

    ``method="monodromy"`` (default): :func:`hbm.stability.verdict.stability`'s exponents
    (T.10, with the T.9 fold parity). ``method="hill"``: Hill's method as described in the
    module,
    ``max_size`` and ``criterion`` applying to it only.

    Returns
    -------
    max_real : float
        Largest real part (1/s); the solution is unstable when it is > 0. With
        omitted modes it includes their nominal (uncoupled) exponents.
    exponents : ndarray of complex
        The selected 2 m exponents.
    """
    problem.require_periodic("Floquet exponents (Hill)")
    if method == "monodromy":
        st = stability(problem, point)
        return st.max_real, st.exponents
    if method != "hill":
        raise ValueError(f"floquet_exponents.method = {method!r}: must be 'monodromy' or 'hill'")
    mm, cm, km, g, h_rest, rest_max = hill_coordinates(problem, max_size, point.omega)
    m = g.shape[1]
    nr = problem.nr
    ne = problem.n_elements
    hs = problem.harmonics
    w0 = hs.fundamental_rad_s(point.omega)
    w = problem.kS * w0
    jf = problem.element_jacobian(problem.delta_real(point.unknowns))
    jf_all = jf
    if np.any(h_rest != 0):
        # omitted modes: Delta = Delta_kept - H_rest J_f Delta  =>  J_eff = J_f (I + H_rest J_f)^-1
        hr = np.block([[mul_rows(h_rest[e, f], np.eye(nr)) for f in range(ne)]
                       for e in range(ne)]) if ne > 1 else mul_rows(h_rest[0, 0], np.eye(nr))
        jf = np.linalg.solve((np.eye(ne * nr) + hr @ jf).T, jf.T).T
    z0 = km[None] - (w ** 2)[:, None, None] * mm[None] + 1j * w[:, None, None] * cm[None]
    z1 = cm[None] + 2j * w[:, None, None] * mm[None]
    d0 = real_blocks(z0, nr)
    for e in range(ne):
        for f in range(ne):
            d0 = d0 + np.kron(np.outer(g[e], g[f]), jf[e * nr:(e + 1) * nr, f * nr:(f + 1) * nr])
    d1 = real_blocks(z1, nr)
    mhat = np.kron(mm, np.eye(nr))
    minv = np.linalg.inv(mhat)
    size = m * nr
    a = np.zeros((2 * size, 2 * size))
    a[:size, size:] = np.eye(size)
    a[size:, :size] = -minv @ d0
    a[size:, size:] = -minv @ d1
    if criterion not in ("auto", "imag", "weight"):
        raise ValueError(f"criterion = {criterion!r}: must be 'auto', 'imag' or 'weight'")
    contiguous = hs.contiguous
    w_top = float(np.sqrt(np.max(np.abs(np.diag(km)) / np.abs(np.diag(mm)))))
    in_band = w_top <= 0.5 * w0 * hs.max_index
    if criterion == "imag" or (criterion == "auto" and contiguous and in_band):
        # contiguous set: order by |Im lambda| (eigenvalues only)
        lam = sla.eigvals(a, overwrite_a=True, check_finite=False)
        order = np.argsort(np.abs(lam.imag), kind="stable")
    else:
        lam, vec = sla.eig(a, overwrite_a=True, check_finite=False)
        p = vec[:size]
        weight = np.sum(np.abs(p[0::nr]) ** 2, axis=0) / np.maximum(
            np.sum(np.abs(p) ** 2, axis=0), 1e-300)
        order = np.argsort(-weight, kind="stable")
    exps = lam[order[: 2 * m]]
    # Two exponents with Im = w0/2 (negative multipliers, period doubling) have
    # four tied copies at Im = +-w0/2, and the selection may keep two copies of
    # the same one: the stability verdict takes the largest real part over the
    # 4 m best candidates, all copies of genuine exponents when Hill converged.
    cand = lam[order[: 4 * m]]
    if not problem.modal:
        return max(float(np.max(cand.real)), rest_max), exps
    exps, max_real = exact_exponent(problem, jf_all, w0, exps, cand)
    return max(max_real, rest_max), exps


def exact_exponent(problem: HBMProblem, jf: np.ndarray, w0: float, exps: np.ndarray,
           cand: np.ndarray) -> tuple[np.ndarray, float]:
    """Add the exact real positive exponent that the sign of ``det T(0)`` reveals (T.9).

    ``det T(0) < 0``: an odd number of real exponents in ``(0, inf)`` for the whole
    ROM (every mode, no truncation); one of them is located by bisection on the sign
    of ``det T`` and Newton on ``T(lam) v = 0`` (fold-type instability, the segment
    between two folds). The (possibly mode-truncated) Hill candidates are kept.
    """
    max_real = float(np.max(cand.real))
    real = positive_real_root(problem, jf, w0)         # NaN when det T(0) >= 0
    if np.isnan(real):
        return exps, max_real
    if not np.any((np.abs(cand.imag) <= 1e-9 * w0) & (np.abs(cand.real - real)
                                                       <= 1e-6 * abs(real))):
        exps = np.concatenate([[complex(real, 0.0)], exps[:-1]])
    return exps, max(max_real, real)


