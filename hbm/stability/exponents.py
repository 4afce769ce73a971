"""Floquet exponents on the elements' deflections, exact for every mode of a modal ROM
(T.9).

With the modal damping of eq. (17)-(19) the Hill operator of (T.8), in the eq. (17)
modes, is block-diagonal but for the coupling through the elements:

    Q(lam) = B(lam) + (G (x) I) J_f (G^T (x) I),

``B`` holding one 2x2 real block per mode j and harmonic k (the real form of
``w_j^2 + c_j mu + mu^2`` at ``mu = lam +- i k w0``), ``G`` the elements' modal
directions and ``J_f`` the AFT linearisation of the elements' forces (block-diagonal,
E n_real square).  By the matrix determinant lemma

    det Q(lam) = det B(lam) * det T(lam),   T(lam) = I + R(lam) J_f,          (T.9)

with ``R(lam)`` E x E blocks ``R_ef = sum_j g_ej g_fj B_j(lam)^-1``, each one block
``x_k I + y_k J`` per harmonic (``J = [[0, -1], [1, 0]]``).  ``det B`` has no zero with
``Re lam >= 0`` (damped modes), so the exponents in the right half-plane are exactly the
zeros of the E n_real-sized ``det T``.  At ``lam = 0``, ``T`` is the Newton matrix of
the "loa" condensation; for real ``lam -> +inf``, ``T -> I``.  Hence:

* the sign of ``det T(0)`` gives the parity of the number of real positive
  exponents (an odd number: the point lies between two folds) at no cost beyond
  the Newton factorisation;
* a real positive exponent is then located by bisection on the sign of ``det T``
  and refined to machine precision by Newton's method on ``T(lam) v = 0``
  (bordered system), with every mode of the ROM.

With one element (a gear mesh) ``T`` is n_real square, the line of action of the paper.
"""

from __future__ import annotations

import logging

import numpy as np
import scipy.linalg as sla

from ..problem import HBMProblem

logger = logging.getLogger(__name__)

__all__ = ["line_of_action_operator", "det_sign", "refine_exponent", "positive_real_root",
           "real_root_bound", "classify_exponent"]


def _blocks_times(x: np.ndarray, y: np.ndarray, j: np.ndarray) -> np.ndarray:
    """Rows of a real-layout matrix ``j`` times the per-harmonic blocks ``x_k I + y_k J``."""
    out = np.empty(j.shape, dtype=np.result_type(x, y, j))
    jr, ji = j[1::2], j[2::2]
    xr, yr = x[1:, None], y[1:, None]
    out[0] = x[0] * j[0]
    out[1::2] = xr * jr - yr * ji
    out[2::2] = yr * jr + xr * ji
    return out


def _receptance_blocks(problem: HBMProblem, lam: complex, w0: float,
                       derivative: bool = False):
    """``(x_k, y_k)`` of R(lam) per element pair and harmonic, (E, E, nS) (m/N), and, if
    asked, of dR/dlam (m s/N)."""
    keep = ~problem.rigid
    gj = [g[keep] for g in problem.gj]
    c = problem.cj[keep][:, None]
    w2 = problem.w2[keep][:, None]
    kw = problem.kS[None, :] * w0
    u = lam * lam + lam * c + w2 - kw * kw              # real part of w^2 + c mu + mu^2
    v = kw * (c + 2.0 * lam)                             # its J part
    den = u * u + v * v
    ne = len(gj)
    ud, vd = u / den, v / den
    if derivative:
        du = 2.0 * lam + c
        dv = 2.0 * kw
        s = u * u - v * v
        dxa = (du * s + 2.0 * u * v * dv) / den ** 2
        dya = (dv * s - 2.0 * u * v * du) / den ** 2
    out = [np.empty((ne, ne, kw.size), dtype=np.result_type(lam, float))
           for _ in range(4 if derivative else 2)]
    for e in range(ne):
        for f in range(ne):
            g2 = gj[e] ** 2 if e == f else gj[e] * gj[f]
            out[0][e, f] = g2 @ ud
            out[1][e, f] = -(g2 @ vd)
            if derivative:
                out[2][e, f] = -(g2 @ dxa)
                out[3][e, f] = -(g2 @ dya)
    return tuple(out)


def line_of_action_operator(problem: HBMProblem, jf: np.ndarray, lam: complex, w0: float,
                            derivative: bool = False):
    """``T(lam) = I + R(lam) J_f`` of (T.9) and, if asked, ``dT/dlam``.

    Parameters
    ----------
    problem
        A problem with modal damping (``problem.modal``).
    jf
        ``J_f`` from :meth:`HBMProblem.element_jacobian` (block-diagonal over the
        elements, E n_real square, N/m).
    lam
        Exponent (1/s), real or complex.
    w0
        Fundamental angular frequency (rad/s).
    """
    if not problem.modal:
        raise ValueError("line_of_action_operator: needs a modal damping (eq. 17-19)")
    blocks = _receptance_blocks(problem, lam, w0, derivative)
    ne = blocks[0].shape[0]
    if ne == 1:
        t = _blocks_times(blocks[0][0, 0], blocks[1][0, 0], jf)
        t[np.diag_indices_from(t)] += 1.0
        if not derivative:
            return t
        return t, _blocks_times(blocks[2][0, 0], blocks[3][0, 0], jf)
    nr = jf.shape[0] // ne
    out = []
    for x, y in zip(blocks[0::2], blocks[1::2], strict=True):
        t = np.zeros(jf.shape, dtype=np.result_type(x, y, jf))
        for e in range(ne):
            for f in range(ne):
                jff = jf[f * nr:(f + 1) * nr, f * nr:(f + 1) * nr]
                t[e * nr:(e + 1) * nr, f * nr:(f + 1) * nr] = _blocks_times(x[e, f], y[e, f],
                                                                             jff)
        out.append(t)
    out[0][np.diag_indices_from(out[0])] += 1.0
    return out[0] if not derivative else (out[0], out[1])


def det_sign(t: np.ndarray) -> float:
    """Sign of the determinant of a real square matrix from its LU factors."""
    lu, piv = sla.lu_factor(t, check_finite=False)
    swaps = int(np.sum(piv != np.arange(piv.size)))
    d = np.diag(lu)
    if np.any(d == 0.0):
        return 0.0
    return float((-1) ** swaps * np.prod(np.sign(d)))


def real_root_bound(problem: HBMProblem, jf: np.ndarray) -> float:
    """A real ``lam_b`` above which ``det T(lam) > 0`` for every ``lam`` with ``Re lam >= lam_b``.

    ``|w^2 + c mu + mu^2| >= (Re mu)^2`` for a damped mode, so ``||R(lam)||_2 <=
    sum_j |g_j|^2 / (Re lam)^2`` (``g_j`` the mode's components along the elements); with
    ``||J_f||_2 <= ||J_f||_F``, ``||R J_f|| < 1`` above ``sqrt(sum |g_j|^2 ||J_f||_F)``
    (1/s).
    """
    g2 = sum(float(np.sum(g[~problem.rigid] ** 2)) for g in problem.gj)
    return 1.01 * float(np.sqrt(g2 * np.linalg.norm(jf))) + 1e-300


def positive_real_root(problem: HBMProblem, jf: np.ndarray, w0: float,
                       hi: float | None = None, rtol: float = 1e-12) -> float:
    """A real root (1/s) of ``det T`` in ``(0, hi)`` when ``det T(0) < 0`` (an odd count of
    real positive exponents), by bisection on the sign of ``det T`` then Newton on
    ``T(lam) v = 0``; NaN when ``det T(0) >= 0``. ``hi`` defaults to
    :func:`real_root_bound`. With three or more real roots, any one of them."""
    def sign(lam):
        return det_sign(line_of_action_operator(problem, jf, lam, w0).real)

    lo = 0.0
    if sign(lo) >= 0:
        return float("nan")
    hi = real_root_bound(problem, jf) if hi is None else float(hi)
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if hi - lo <= rtol * hi:
            break
        if sign(mid) < 0:
            lo = mid
        else:
            hi = mid
        if hi - lo < 1e-3 * hi:
            # close enough for Newton on the eigenproblem
            lam, res = refine_exponent(problem, jf, w0, 0.5 * (lo + hi))
            if lo <= lam.real <= hi and abs(lam.imag) <= rtol * max(hi, 1.0):
                return float(lam.real)
    return 0.5 * (lo + hi)


def refine_exponent(problem: HBMProblem, jf: np.ndarray, w0: float, lam0: complex,
                    tol: float = 1e-13, max_iter: int = 30) -> tuple[complex, float]:
    """Newton's method on ``T(lam) v = 0`` from ``lam0`` (bordered system, v normalised).

    Returns the exponent (1/s) and the relative residual ``||T v|| / ||v||``; raises
    ``ArithmeticError`` when Newton does not reach ``tol`` (no exponent near ``lam0``).
    """
    n = jf.shape[0]
    lam = complex(lam0)
    t = line_of_action_operator(problem, jf, lam, w0)
    lu = sla.lu_factor(t, check_finite=False)
    v = sla.lu_solve(lu, np.ones(n, dtype=complex), check_finite=False)
    v = sla.lu_solve(lu, v / np.linalg.norm(v), check_finite=False)   # inverse iteration
    v /= np.linalg.norm(v)
    u = v.conj()
    res = np.inf
    for _ in range(max_iter):
        t, dt = line_of_action_operator(problem, jf, lam, w0, derivative=True)
        r = t @ v
        res = float(np.linalg.norm(r) / np.linalg.norm(v))
        if res < tol:
            return lam, res
        a = np.zeros((n + 1, n + 1), dtype=complex)
        a[:n, :n] = t
        a[:n, n] = dt @ v
        a[n, :n] = u
        rhs = -np.concatenate([r, [u @ v - 1.0]])
        step = np.linalg.solve(a, rhs)
        v = v + step[:n]
        lam = lam + step[n]
        if not np.isfinite(lam):
            break
    if res < 1e3 * tol:
        return lam, res
    raise ArithmeticError(f"no exponent converged near {lam0:.6g} (residual {res:.2g})")


def classify_exponent(lam: complex, w0: float, rtol: float = 1e-6) -> str:
    """Kind of loss of stability an unstable exponent stands for.

    ``"fold"`` (real multiplier +1: Im lam = 0 mod w0), ``"period_doubling"``
    (multiplier -1: Im lam = w0/2 mod w0) or ``"neimark_sacker"`` (complex pair).
    """
    frac = (lam.imag / w0) % 1.0
    d = min(frac, 1.0 - frac)
    if d <= rtol:
        return "fold"
    if abs(frac - 0.5) <= rtol:
        return "period_doubling"
    return "neimark_sacker"
