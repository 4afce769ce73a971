"""Stability of periodic solutions: the verdict, and Hill's method for reference.

:func:`stability` is what the continuation calls: the Floquet exponents of the
variational equation (T.10, :mod:`hbm.monodromy`, every mode, no harmonic
truncation of the perturbation), checked against the exact parity of the real
positive exponents of the harmonic balance itself (T.9, :mod:`hbm.exponents`):
a point between two folds of the HBM branch has ``det T(0) < 0``. When the two
disagree the harmonic set does not resolve the orbit there (the flag is kept
per point); the verdict then follows the branch (unstable, with the exact real
root of T.9 as its exponent), so a segment between two folds is never reported
stable.

Hill's method (:func:`floquet_exponents` with ``method="hill"``) stays for
comparisons:

A perturbation ``y = exp(lambda t) p(t)`` of the periodic solution, p periodic
and expanded on the same harmonic set, satisfies the quadratic eigenproblem

    (lambda^2 M_hat + lambda D1 + D0) p = 0,

with D0 the HBM Jacobian (eq. 21 differentiated with respect to the real
unknowns, here of the uncondensed system), D1 the real form of
``C + 2 i k w0 M`` per harmonic and ``M_hat = I (x) M``.  Of its 2 m n_real
eigenvalues, the 2 m Floquet exponents are those whose eigenvectors carry the
largest weight on the mean (index 0) component (eigenvector-weight criterion,
Lazarus & Thomas 2010); the others are copies shifted by i k w0.  For a
contiguous set {0, 1, ..., H} whose band H w0 / 2 covers the natural
frequencies, the cheaper imaginary-part criterion is used (the 2 m eigenvalues
of smallest |Im lambda|, eigenvalues only): a mode above the band has no copy
in the strip |Im| <= w0/2.  Liouville's formula (sum of the real parts =
-tr(M^-1 C)) checks the selection (tests).

For a problem whose damping is modal in the modes of eq. (17) the computation
is done in modal coordinates (M = I, diagonal C and K); rigid-body modes the
mesh does not move are decoupled and left out. The real companion matrix has
size 2 m n_real; beyond ``max_size`` only the modes with the largest dynamic
mesh participation are kept, and the omitted ones enter through their
compliance along the mesh at the harmonic frequencies, ``h_rest,k`` (a residual
flexibility, evaluated at lambda = 0): the mesh coupling ``J_f`` becomes
``J_f (I + H_rest J_f)^-1``. This is exact for the kept exponents in the limit
where the omitted modes are far above the band, and an approximation otherwise.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from .exponents import classify_exponent, det_sign, line_of_action_operator, positive_real_root
from .harmonics import mul_rows, real_blocks
from .monodromy import monodromy_exponents
from .problem import HBMProblem, Point

logger = logging.getLogger(__name__)

__all__ = ["KINDS", "Stability", "stability", "floquet_exponents", "real_blocks",
           "loss_of_stability"]

#: Kinds of a point's stability, in the order of the codes stored per point.
KINDS = ("stable", "fold", "period_doubling", "neimark_sacker")


@dataclass(frozen=True)
class Stability:
    """Stability of one periodic solution.

    Attributes
    ----------
    max_real
        Largest real part of the Floquet exponents (1/s); > 0 is unstable.
    exponents
        Exponents (1/s) by decreasing real part, ``|Im| <= w0 / 2``.
    kind
        One of :data:`KINDS`: ``"stable"``, or how the leading exponent leaves the
        unit circle (multiplier +1: ``"fold"``, -1: ``"period_doubling"``, complex:
        ``"neimark_sacker"``).
    fold_parity
        ``det T(0) < 0`` (T.9): an odd number of real positive exponents of the
        harmonic balance, i.e. the point lies between two folds of the branch
        (modal damping only; False otherwise).
    consistent
        False when ``fold_parity`` holds but the variational equation finds no
        exponent with a positive real part: the harmonic set does not resolve the
        orbit there.
    error
        Estimated error of ``max_real`` from the time step (1/s).
    basis
        Dominant subspace of the monodromy (see :class:`hbm.monodromy.MonodromyResult`).
    """

    max_real: float
    exponents: np.ndarray
    kind: str
    fold_parity: bool
    consistent: bool
    error: float
    basis: np.ndarray | None = None

    @property
    def code(self) -> int:
        """Index of ``kind`` in :data:`KINDS`."""
        return KINDS.index(self.kind)


def stability(problem: HBMProblem, point: Point, start: np.ndarray | None = None,
              parity: bool | None = None) -> Stability:
    """Floquet exponents (T.10) and the fold parity (T.9) of a solution; see the module.

    ``start``: :attr:`Stability.basis` of a neighbouring point (faster, same result).
    ``parity``: ``det T(0) < 0`` when the caller knows it (the continuation does, from
    the sign of its tangent's speed component, T.9a in docs/theory.md); else it is
    computed from the dense ``T(0)`` (an LU of the harmonic-balance size).
    """
    res = monodromy_exponents(problem, point, start=start)
    w0 = problem.harmonics.fundamental_rad_s(point.omega)
    exps, max_real = res.exponents, res.max_real
    jf = None
    if not problem.modal:
        parity = False
    elif parity is None:
        _, jf = problem.mesh_force(problem.delta_real(point.unknowns))
        parity = det_sign(line_of_action_operator(problem, jf, 0.0, w0).real) < 0
    consistent = not parity or max_real > 0
    if not consistent:
        if jf is None:
            _, jf = problem.mesh_force(problem.delta_real(point.unknowns))
        root = positive_real_root(problem, jf, w0)
        if np.isnan(root):
            # the branch puts the point between two folds (the tangent, T.9a) but the
            # computed det T(0) >= 0: the point lies within round-off of a fold, whose
            # real exponent is below what T(0) resolves; reported as that fold, 0 1/s
            logger.debug("%.2f rpm: between two folds by the tangent but det T(0) >= 0; "
                         "real exponent taken as 0 (variational equation: max Re %.4g "
                         "1/s)", point.rpm, max_real)
            root = 0.0
        else:
            logger.debug("%.2f rpm: between two folds (T.9 root %.4g 1/s) but the "
                         "variational equation has max Re %.4g 1/s", point.rpm, root,
                         max_real)
        exps = np.concatenate([[complex(root, 0.0)], exps])
        max_real = float(root)
    # round-off of the multipliers (|mu| = 1 +- 1e-15 for a rigid mode) is not growth
    w_top = float(np.sqrt(np.max(np.abs(problem.w2))))
    tiny = 1e-9 * (w0 + w_top)
    stable = max_real <= tiny and consistent          # between two folds: never stable
    kind = "stable" if stable else classify_exponent(complex(exps[0]), w0)
    return Stability(max_real, exps, kind, bool(parity), bool(consistent), res.error, res.basis)


def _coordinates(problem: HBMProblem, max_size: int, omega: float):
    """Hill coordinates (M, C, K, g) and the omitted modes' compliance per harmonic.

    Modal damping: the eq. (17) modes, at most ``max_size / (2 n_real)`` of them,
    those with the largest dynamic mesh participation
    ``max_k |g_j^2 / (w_j^2 - (k w0)^2 + i k w0 c_j)|``; the omitted ones enter
    as a quasi-static residual compliance ``h_rest,k`` along the mesh (exact
    when their exponents are far from the band, see floquet_exponents).
    """
    nr = problem.nr
    if problem.modal:
        keep = np.flatnonzero(~problem.rigid)
        h_rest = np.zeros(problem.nS, dtype=complex)
        rest_max = -np.inf
        if 2 * keep.size * nr > max_size:
            inv, _ = problem.modal_inverse(omega)
            contrib = (problem.gj ** 2)[:, None] * inv                 # (n_modes, nS)
            part = np.max(np.abs(contrib[keep]), axis=1)
            nkeep = max(1, max_size // (2 * nr))
            order = np.argsort(part, kind="stable")[::-1]
            rest = keep[order[nkeep:]]
            keep = np.sort(keep[order[:nkeep]])
            h_rest = contrib[rest].sum(axis=0)
            # nominal exponents of the omitted modes (largest real part of each)
            c, w2 = problem.cj[rest], problem.w2[rest]
            disc = np.sqrt(np.maximum(c * c - 4 * w2, 0.0))
            rest_max = float(np.max((-c + disc) / 2)) if rest.size else -np.inf
            logger.debug("Hill: %d of %d modes kept (max_size=%d)", keep.size,
                         problem.w2.size, max_size)
        m = keep.size
        return (np.eye(m), np.diag(problem.cj[keep]), np.diag(problem.w2[keep]),
                problem.gj[keep], h_rest, rest_max)
    s = problem.system
    if 2 * s.n_dof * nr > max_size:
        raise ValueError(
            f"stability: Hill matrix size {2 * s.n_dof * nr} > max_size {max_size} for a "
            "non-modal damping; disable stability or use modal damping")
    return s.M, s.C, problem.Kp, problem.G, np.zeros(problem.nS, dtype=complex), -np.inf


def floquet_exponents(problem: HBMProblem, point: Point, max_size: int = 600,
                      criterion: str = "auto", method: str = "monodromy"):
    """Floquet exponents (1/s) of a periodic solution and their largest real part.

    ``method="monodromy"`` (default): :func:`stability`'s exponents (T.10, with the
    T.9 fold parity). ``method="hill"``: Hill's method as described in the module,
    ``max_size`` and ``criterion`` applying to it only.

    Returns
    -------
    max_real : float
        Largest real part (1/s); the solution is unstable when it is > 0. With
        omitted modes it includes their nominal (uncoupled) exponents.
    exponents : ndarray of complex
        The selected 2 m exponents.
    """
    if method == "monodromy":
        st = stability(problem, point)
        return st.max_real, st.exponents
    if method != "hill":
        raise ValueError(f"floquet_exponents.method = {method!r}: must be 'monodromy' or 'hill'")
    mm, cm, km, g, h_rest, rest_max = _coordinates(problem, max_size, point.omega)
    m = g.size
    nr = problem.nr
    hs = problem.harmonics
    w0 = hs.fundamental_rad_s(point.omega)
    w = problem.kS * w0
    _, jf = problem.mesh_force(problem.delta_real(point.unknowns))
    jf_all = jf
    if np.any(h_rest != 0):
        # omitted modes: Delta = Delta_kept - H_rest J_f Delta  =>  J_eff = J_f (I + H_rest J_f)^-1
        hr = mul_rows(h_rest, np.eye(nr))
        jf = np.linalg.solve((np.eye(nr) + hr @ jf).T, jf.T).T
    z0 = km[None] - (w ** 2)[:, None, None] * mm[None] + 1j * w[:, None, None] * cm[None]
    z1 = cm[None] + 2j * w[:, None, None] * mm[None]
    d0 = real_blocks(z0, nr) + np.kron(np.outer(g, g), jf)
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
    contiguous = hs.indices == tuple(range(hs.n_harmonics))
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
    exps, max_real = _exact(problem, jf_all, w0, exps, cand)
    return max(max_real, rest_max), exps


def _exact(problem: HBMProblem, jf: np.ndarray, w0: float, exps: np.ndarray,
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


def loss_of_stability(problem: HBMProblem, point: Point) -> str:
    """``"stable"`` or the kind of the exponent of largest real part:
    ``"fold"``, ``"period_doubling"`` or ``"neimark_sacker"`` (see classify_exponent)."""
    return stability(problem, point).kind
