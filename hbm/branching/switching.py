"""Period doubling on a traced branch: locate it on the harmonic-balance equations, find
the critical Floquet vector and step onto the period-2 branch (docs/theory.md §15, T.50-T.53).

A multiplier crossing -1 is a zero of Hill's operator at the exponent ``i w0 / 2``: on
the doubled set (:mod:`hbm.branching.doubling`) it is the odd block ``J_odd`` of the
harmonic-balance Jacobian at the embedded period-1 point. With the exact real-root
argument of T.9 (``J_odd -> I`` as a real exponent ``sigma -> +inf``, the mode factor of
the matrix determinant lemma positive), ``det J_odd < 0`` counts an odd number of real
multipliers below -1: its sign change along the branch is the period doubling of the
harmonic-balance equations, the bifurcation of their period-2 branch. It is bracketed by
the branch's Floquet kinds (the monodromy's verdict, T.10) and located by the Illinois
regula falsi on ``det J_odd`` scaled by its magnitude at the bracket's ends (from the LU:
smooth, with a simple zero; a bordered test function as MatCont's would cost a second
factorisation per iterate), each iterate corrected onto the branch on the plane normal to
the bracket's chord; the critical vector by inverse iteration at the located point.

On the doubled problem the period doubling is a symmetry-breaking pitchfork (Seydel,
*Practical Bifurcation and Stability Analysis*, 3rd ed., §7.5: "doubling the period";
Kuznetsov, *Elements of Applied Bifurcation Theory*, §4.4 and §10.3): the period-2
branch leaves the period-1 one along the null vector ``phi`` of ``J_odd`` with no speed
component. Its first point is corrected from ``(x_PD + eps phi, Omega_PD)`` on the plane
``phi . (y - y_pred) = 0``, where the bordered Jacobian is regular, as DDE-BIFTOOL's
``DoublePsol`` deviates by ``radius`` along the period-doubling eigenvector and
BifurcationKit's branch switching by ``ampfactor``.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from ..continuation.corrector import augmented, correct
from ..krylov import is_operator
from ..newton import ConvergenceError
from ..problem import HBMProblem
from ..units import RPM_TO_RAD_S
from .doubling import embed, odd_mask

logger = logging.getLogger(__name__)

__all__ = ["DoublingPoint", "SwitchedPoint", "doubling_brackets", "locate_doubling",
           "odd_jacobian", "switch_branch"]

LOCATE_ITER = 40            # Illinois iterations at most
SWITCH_EPS = (1e-2, 1e-3, 1e-4, 3e-3)   # deviations along phi tried in turn (scaled)


@dataclass
class DoublingPoint:
    """A period doubling located on a branch of ``problem`` (the parent).

    Attributes
    ----------
    rpm, omega
        Its speed (rpm, rad/s) on the harmonic-balance equations (``det J_odd = 0``).
    unknowns
        The parent's unknowns there (physical units).
    vector
        The critical Floquet vector: unit null vector of ``J_odd`` in the child's scaled
        unknowns (zero on the even indices), the half-order harmonics of the Floquet
        eigenfunction of the multiplier -1.
    index
        The bracket: between points ``index`` and ``index + 1`` of the parent branch.
    floquet_rpm
        Where the branch's own verdict (T.10) puts it: the zero of the largest Floquet
        real part interpolated linearly between the two points (NaN if it does not
        change sign there).
    tau
        ``|J_odd v| / |J_odd|_1`` of the critical vector at the located point (near 0).
    """

    rpm: float
    omega: float
    unknowns: np.ndarray
    vector: np.ndarray
    index: int
    floquet_rpm: float
    tau: float


@dataclass
class SwitchedPoint:
    """The first point of the period-2 branch: unknowns of the child problem (physical),
    its speed, the deviation ``eps`` it was corrected from and the sweep direction of the
    branch away from the period doubling (+1 up in speed, -1 down)."""

    unknowns: np.ndarray
    rpm: float
    omega: float
    eps: float
    direction: float


def odd_jacobian(child: HBMProblem, unknowns: np.ndarray, omega: float,
                 mask: np.ndarray | None = None) -> np.ndarray:
    """``J_odd``: the odd block of ``child``'s scaled Jacobian (dense) at its unknowns
    (from the dense Jacobian, or column by column from a matrix-free one)."""
    mask = odd_mask(child) if mask is None else mask
    _, jx, _ = child.scaled(np.asarray(unknowns) / child.x_scale, omega)
    if not is_operator(jx):
        return np.asarray(jx)[np.ix_(mask, mask)]
    # matrix-free: column by column, one product each (O(N log N), the kink blocks of
    # T.13a included), about 8x cheaper than forming the whole doubled matrix with them
    cols = np.flatnonzero(mask)
    out = np.empty((cols.size, cols.size))
    e = np.zeros(mask.size)
    for k, c in enumerate(cols):
        e[c] = 1.0
        out[:, k] = (jx @ e)[mask]
        e[c] = 0.0
    return out


def doubling_brackets(branch) -> list[int]:
    """Indices ``i`` where the branch's leading Floquet kind enters or leaves period
    doubling (kind 2) between points ``i`` and ``i + 1``; points of a closed loop's
    restart (an untraced segment) are skipped."""
    kind = np.asarray(branch.floquet_kind)
    pd = kind == 2
    out = []
    restarts = {int(lp[3]) for lp in getattr(branch, "loops", [])}
    for i in range(len(kind) - 1):
        if pd[i] != pd[i + 1] and kind[i] >= 0 and kind[i + 1] >= 0 and i + 1 not in restarts:
            out.append(i)
    return out


def _null_estimate(a: np.ndarray, iterations: int = 3) -> np.ndarray:
    """Unit vector of the smallest singular value of ``a``, by inverse iteration."""
    lu = sla.lu_factor(a, check_finite=False)
    rng = np.random.default_rng(0)
    v = rng.standard_normal(a.shape[0])
    for _ in range(iterations):
        v = sla.lu_solve(lu, v, check_finite=False)
        v /= np.linalg.norm(v)
    return v


def locate_doubling(parent: HBMProblem, child: HBMProblem, branch, index: int,
                    tol: float = 1e-10, max_iter: int = 12,
                    rpm_tol: float | None = None) -> DoublingPoint | None:
    """Locate the period doubling of ``parent``'s ``branch`` between points ``index`` and
    ``index + 1`` (a bracket of :func:`doubling_brackets`) on the harmonic-balance
    equations; None when ``det J_odd`` keeps its sign there (the leading kind changed
    without a multiplier crossing -1, e.g. a fold taking the lead).

    ``child`` is :func:`hbm.branching.doubled_problem` of ``parent``; ``rpm_tol`` the
    tolerance on the located speed (default 1e-7 of it).
    """
    mask = odd_mask(child)
    wscale = float(branch.omega_scale)
    xs = parent.x_scale
    ya = np.concatenate([branch.unknowns[index] / xs, [branch.omega[index] / wscale]])
    yb = np.concatenate([branch.unknowns[index + 1] / xs,
                         [branch.omega[index + 1] / wscale]])
    chord = yb - ya
    direction = chord / np.linalg.norm(chord)
    evaluate = augmented(parent, wscale)

    def point(s: float) -> np.ndarray:
        if s == 0.0:
            return ya
        if s == 1.0:
            return yb
        y, *_ = correct(evaluate, ya + s * chord, direction, tol, max_iter)
        return y

    def block(y: np.ndarray) -> np.ndarray:
        return odd_jacobian(child, embed(parent, child, y[:-1] * xs), y[-1] * wscale, mask)

    ja, jb = block(ya), block(yb)
    (sga, lga), (sgb, lgb) = np.linalg.slogdet(ja), np.linalg.slogdet(jb)
    if sga == sgb:
        logger.info("period doubling bracket %.6g-%.6g rpm: det J_odd keeps its sign (the "
                    "leading Floquet kind changed without a multiplier crossing -1); "
                    "skipped", branch.rpm[index], branch.rpm[index + 1])
        return None
    ref = max(lga, lgb)

    def test(sign: float, logdet: float) -> float:
        # det J_odd scaled by the larger end's magnitude: smooth, a simple zero
        return float(sign * np.exp(logdet - ref))

    fa, fb = test(sga, lga), test(sgb, lgb)
    span_rpm = abs(branch.rpm[index + 1] - branch.rpm[index])
    rtol = 1e-7 * max(branch.rpm[index], branch.rpm[index + 1]) if rpm_tol is None \
        else rpm_tol
    sa, sb, side = 0.0, 1.0, 0
    y, j = (ya, ja) if abs(fa) < abs(fb) else (yb, jb)
    for _ in range(LOCATE_ITER):
        if abs(sb - sa) * span_rpm < rtol:
            break
        s = (sa * fb - sb * fa) / (fb - fa)          # Illinois regula falsi
        s = min(max(s, sa + 1e-3 * (sb - sa)), sb - 1e-3 * (sb - sa))
        y = point(s)
        j = block(y)
        f = test(*np.linalg.slogdet(j))
        if np.sign(f) == np.sign(fa):
            sa, fa = s, f
            if side == -1:
                fb *= 0.5
            side = -1
        else:
            sb, fb = s, f
            if side == 1:
                fa *= 0.5
            side = 1
    v = _null_estimate(j)
    f = float(np.linalg.norm(j @ v) / max(np.linalg.norm(j, 1), 1e-300))
    floquet = float("nan")
    ra, rb = branch.floquet_max_real[index], branch.floquet_max_real[index + 1]
    if np.isfinite(ra) and np.isfinite(rb) and ra * rb < 0:
        floquet = float(branch.rpm[index] + ra / (ra - rb)
                        * (branch.rpm[index + 1] - branch.rpm[index]))
    phi = np.zeros(child.n_unknowns)
    phi[mask] = v / np.linalg.norm(v)
    omega = float(y[-1] * wscale)
    logger.info("period doubling located at %.9g rpm (tau %.3g; Floquet verdict %.6g rpm)",
                omega / RPM_TO_RAD_S, f, floquet)
    return DoublingPoint(omega / RPM_TO_RAD_S, omega, y[:-1] * xs, phi, index, floquet,
                         float(f))


def switch_branch(parent: HBMProblem, child: HBMProblem, pd: DoublingPoint,
                  omega_scale: float, tol: float = 1e-10, max_iter: int = 12,
                  eps: tuple[float, ...] = SWITCH_EPS) -> SwitchedPoint:
    """The first point of the period-2 branch born at ``pd``: Newton on the child's
    equations bordered by ``phi . (y - y_pred) = 0`` from ``y_pred = (x_PD + e phi,
    Omega_PD)``, ``e = eps_i max(|x_PD|, 1)`` (scaled), the deviations tried in turn.

    Raises :class:`hbm.newton.ConvergenceError` when none converges.
    """
    xs = child.x_scale
    x0 = embed(parent, child, pd.unknowns) / xs
    y0 = np.concatenate([x0, [pd.omega / omega_scale]])
    d = np.concatenate([pd.vector, [0.0]])
    evaluate = augmented(child, omega_scale)
    size = max(float(np.linalg.norm(x0[child.vibration])), 1.0)
    last: Exception = ConvergenceError("switch: no deviation tried")
    for e in eps:
        try:
            y, *_ = correct(evaluate, y0 + e * size * d, d, tol, max_iter)
        except (ConvergenceError, np.linalg.LinAlgError) as exc:
            last = exc
            continue
        omega = float(y[-1] * omega_scale)
        direction = 1.0 if omega >= pd.omega else -1.0
        logger.info("period-2 branch from %.6g rpm: first point at %.9g rpm (eps %.3g)",
                    pd.rpm, omega / RPM_TO_RAD_S, e * size)
        return SwitchedPoint(y[:-1] * xs, omega / RPM_TO_RAD_S, omega, e * size, direction)
    raise ConvergenceError(f"switch at the period doubling {pd.rpm:.6g} rpm: no deviation "
                           f"along the critical vector converged ({last})")
