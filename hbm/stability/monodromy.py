"""Floquet multipliers of a periodic solution from the variational equation (T.10).

A perturbation ``y`` of an HBM solution obeys, with every mode of the problem,

    M y'' + C y' + K' y + G S'(t) G^T y = 0,     S'(t) = diag_e d f'_e/d Delta_e (t),  (T.10)

``K' = K + sum_e k_bar_e g_e g_e^T`` the operator of eq. (17) and ``s'_e`` the derivative
of element e's force minus ``k_bar_e`` along the solution (a gear mesh, eq. 13:
``k_m(t) - k_bar`` in contact, ``-k_bar`` when the teeth separate).  The coupling has
rank E (one per element: the line of action of a mesh), and the dead-zone force is
continuous in ``Delta``, so (T.10) holds almost everywhere and no saltation is needed at
contact switches.

One period is integrated by Strang splitting: an exact half step of the
uncoupled part (2x2 exponential per mode for a modal damping, ``expm`` of the
first-order matrix otherwise), the element kick ``v <- v - dt M^-1 G S'_n G^T q``
(exact: the kick is nilpotent) and another exact half step.  ``S'_n`` is the mean
of ``S'`` over step n (each element's :meth:`~hbm.elements.Element.step_stiffness`; a
gear mesh takes the fraction of the step in contact from the linear interpolation of the
gap, so a contact switch inside a step costs no order of accuracy beyond the
interpolation).  The kick has determinant 1, so ``det Phi = exp(-T tr M^-1 C)`` exactly
(Liouville).

The multipliers are the eigenvalues of the monodromy ``Phi``; the exponents
``lam = log(mu) / T`` with ``|Im lam| <= w0 / 2``.  For many modes only the
dominant multipliers matter (every mode but a few is contracted by orders of
magnitude over one period): they are found by subspace iteration with Rayleigh-Ritz
on a block of ``p`` columns, ``p`` doubled until the Ritz pairs converge, the full
matrix when ``p`` reaches its size.  The time step is refined until the largest real
part, compared with half the steps (second order: error ~ difference / 3), is
resolved well enough to decide its sign.

Why not Hill's method: on a sparse harmonic set (mesh harmonics and their
sidebands) a Floquet eigenfunction needs harmonics outside the set, and Hill's
matrix, even with every mode (T.9), has spurious exponents; see docs/theory.md §11.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from ..problem import HBMProblem, Point

logger = logging.getLogger(__name__)

#: Fewest monodromy steps per period of the fastest element's base frequency (measured on
#: a train over its hunting period of 4087 mesh periods at 3238 rpm: 2048 steps in all
#: overflow; 16 per mesh period give the largest real part -18.882 1/s with an estimated
#: error of 2e-3 1/s in 0.24 s, 32 per mesh period 3e-5 1/s).
MIN_STEPS_PER_BASE_PERIOD = 16
#: Doublings of the step count when the period map overflows (steps too long for the
#: fastest dynamics: a long period at low speed), before giving up.
MAX_OVERFLOW_DOUBLINGS = 4
#: Largest state size (2 x kept modes) whose whole monodromy is formed for the transient
#: amplification (:func:`period_amplification`); beyond, a lower bound on the dominant
#: subspace.
FULL_AMPLIFICATION_STATES = 600

__all__ = ["DensePeriod", "ModalPeriod", "MonodromyResult", "dominant_multipliers",
           "energy_weights", "exponents_along", "monodromy_exponents", "orbit_deltas",
           "period_amplification", "period_map", "step_stiffness"]


@dataclass(frozen=True)
class MonodromyResult:
    """Floquet exponents of one solution from the monodromy (T.10).

    Attributes
    ----------
    exponents
        Exponents (1/s), ``|Im| <= w0 / 2``, sorted by decreasing real part: all
        ``2 m`` of them, or the ``p`` dominant ones of a subspace iteration.
    max_real
        Largest real part (1/s), extrapolated in the time step.
    error
        Estimated error of ``max_real`` (1/s), from the half-step solution.
    n_steps
        Time steps per period of the accepted solution.
    columns
        Block size of the subspace iteration (``2 m``: full monodromy).
    basis
        Orthonormal basis (2 m x columns) of the dominant subspace, to start the
        next point from; None for the full monodromy.
    amplification
        Transient amplification over one period: the largest singular value of the
        monodromy in the energy norm (:func:`energy_weights`), the largest growth of a
        disturbance's ``sqrt(energy)`` over one period whatever the multipliers (a
        non-normal ``Phi`` grows disturbances although every ``|mu| < 1``). Exact up to
        :data:`FULL_AMPLIFICATION_STATES` states; beyond, on the dominant subspace of the
        subspace iteration, a lower bound (``amplification_exact`` False).
    amplification_exact
        True when ``amplification`` is that of the whole monodromy.
    """

    exponents: np.ndarray
    max_real: float
    error: float
    n_steps: int
    columns: int
    basis: np.ndarray | None = None
    amplification: float = float("nan")
    amplification_exact: bool = False


def orbit_deltas(problem: HBMProblem, unknowns: np.ndarray, n_steps: int) -> np.ndarray:
    """Every element's ``Delta_e`` (m) of an HBM solution at ``n_steps`` instants
    ``t_i = i T / n_steps`` of one fundamental period, (E, n_steps)."""
    synth, _ = problem.fine_grid(n_steps)
    return synth @ problem.delta_real(unknowns)


def step_stiffness(problem: HBMProblem, deltas: np.ndarray) -> np.ndarray:
    """Mean of ``s'_e(t) = d f'_e/d Delta_e`` over each step between the samples of every
    element's deflection (N/m), (E, n).

    ``deltas``: ``Delta_e`` at the ``n`` instants ``i T / n`` of one period
    (:func:`orbit_deltas`, or samples of a time integration), (E, n); each element's
    :meth:`~hbm.elements.Element.step_stiffness` (a gear mesh: eq. 13 differentiated,
    ``k_m`` where a flank is loaded, 0 in the backlash, minus ``k_bar``, with the
    fraction of each step in contact from the linear interpolation of the gap).
    """
    _, samples = problem.fine_grid(deltas.shape[-1])
    return np.stack([el.step_stiffness(d, smp) for el, d, smp in
                     zip(problem.elements, deltas, samples, strict=True)])


class ModalPeriod:
    """One period of the (T.10) splitting in the eq. (17) modes, in chunks of steps.

    With ``x_i`` the state before kick ``i``, ``y_i = G^T q_i`` (one entry per element)
    and ``E`` the exact modal step, ``x_{i+1} = E (x_i - b K_i y_i)`` (``b = (0, G)``: the
    kick acts on the velocities, ``K_i`` diagonal over the elements). Over a chunk of
    ``L`` steps from ``x_s`` this unrolls into

        y_{s+i} + sum_{l<i} H_{i-l} K_{s+l} y_{s+l} = G^T E^i x_s,
        x_{s+L} = E^L x_s - sum_{l<L} E^{L-l} b K_{s+l} y_{s+l},

    ``H_k = G^T E_qv^k G`` (E x E) the impulse response along the elements: a small
    unit lower-triangular system per chunk (block lower-triangular with E x E blocks) and
    matrix products, the same numbers as stepping but ``L`` times fewer NumPy calls. The
    product of the ``E K_i`` is similar to the Strang product ``E^(1/2) ... E^(1/2)``
    (conjugate by ``E^(1/2)``): same multipliers.
    """

    chunk = 64

    def __init__(self, problem: HBMProblem, jbar: np.ndarray, period: float) -> None:
        keep = ~problem.rigid
        self.g = problem.gj[:, keep]                              # (E, m)
        self.c, self.w2 = problem.cj[keep], problem.w2[keep]
        self.n = jbar.shape[-1]
        self.dt = period / self.n
        self.kappa = self.dt * jbar                               # (E, n)
        self.size = 2 * self.g.shape[1]
        self.ops = {}
        for length in {min(self.chunk, self.n), self.n % min(self.chunk, self.n)} - {0}:
            self.ops[length] = self._chunk_operators(length)

    def _chunk_operators(self, length: int):
        """(P, H, Q, E^L) of a chunk of ``length`` steps (see the class), rows and columns
        ordered (step, element)."""
        g = self.g
        ne, m = g.shape
        k = np.arange(length + 1)[:, None] * self.dt
        e = self._blocks(self.c, self.w2, k)                     # E^k, k = 0..L, (L+1, m)
        # rows G^T E^i, (L E, 2m)
        p = np.hstack([(e[0][:length, None, :] * g[None]).reshape(length * ne, m),
                       (e[1][:length, None, :] * g[None]).reshape(length * ne, m)])
        h = np.empty((length, ne, ne))                           # H_0 = 0
        for a in range(ne):
            for b in range(ne):
                h[:, a, b] = e[1][:length] @ (g[a] * g[b])
        idx = np.arange(length)
        below = (idx[:, None] > idx[None, :])[:, :, None, None]
        lower = np.where(below, h[np.abs(idx[:, None] - idx[None, :])], 0.0)
        lower = lower.transpose(0, 2, 1, 3).reshape(length * ne, length * ne)
        rev = slice(length, 0, -1)                               # E^{L-l}, l = 0..L-1
        q = np.vstack([(e[1][rev][:, None, :] * g[None]).reshape(length * ne, m).T,
                       (e[3][rev][:, None, :] * g[None]).reshape(length * ne, m).T])
        whole = [b[-1][:, None] for b in e]
        return p, lower, q, whole

    @staticmethod
    def _blocks(c: np.ndarray, w2: np.ndarray, h) -> tuple[np.ndarray, ...]:
        """exp(h [[0, 1], [-w2, -c]]) per mode as its four entries (exact, any damping).

        With ``s = -c/2``, ``d^2 = s^2 - w2``: ``e^{sh} (cosh dh - s S, S, -w2 S,
        cosh dh + s S)``, ``S = sinh(dh)/d``, in real arithmetic (cos and sin for an
        underdamped mode).
        """
        s = -0.5 * c
        d2 = s * s - w2
        wd = np.sqrt(np.abs(d2))
        under = d2 < 0
        x = wd * h
        ch = np.where(under, np.cos(x), np.cosh(np.where(under, 0.0, x)))
        sn = np.where(under, np.sin(x), np.sinh(np.where(under, 0.0, x)))
        sinc = np.where(wd > 0, sn / np.where(wd > 0, wd, 1.0), h)
        ex = np.exp(s * h)
        es = ex * sinc
        return ex * ch - s * es, es, -w2 * es, ex * ch + s * es

    def __call__(self, x: np.ndarray) -> np.ndarray:
        m = self.g.shape[1]
        q, v = x[:m], x[m:]
        start = 0
        while start < self.n:
            length = min(self.chunk, self.n - start)
            p, lower, qm, e = self.ops[length]
            kap = self.kappa[:, start:start + length].T.ravel()  # (step, element)
            y = sla.solve_triangular(np.eye(kap.size) + lower * kap, p @ np.vstack([q, v]),
                                     lower=True, unit_diagonal=True, check_finite=False)
            kick = qm @ (kap[:, None] * y)                        # (T.10) mesh kicks
            q, v = e[0] * q + e[1] * v - kick[:m], e[2] * q + e[3] * v - kick[m:]
            start += length
        return np.vstack([q, v])


class DensePeriod:
    """One period of (T.10) in physical coordinates: ``expm`` of the first-order matrix."""

    def __init__(self, problem: HBMProblem, jbar: np.ndarray, period: float) -> None:
        s = problem.system
        n = s.n_dof
        minv = np.linalg.inv(s.M)
        a = np.zeros((2 * n, 2 * n))
        a[:n, n:] = np.eye(n)
        a[n:, :n] = -minv @ problem.Kp
        a[n:, n:] = -minv @ s.C
        self.n = jbar.shape[-1]
        self.dt = period / self.n
        self.full = sla.expm(a * self.dt)
        self.half = sla.expm(a * 0.5 * self.dt)
        self.mg = [minv @ g for g in problem.directions]
        self.g = problem.directions
        self.kick = self.dt * jbar                               # (E, n)
        self.size = 2 * n

    def __call__(self, x: np.ndarray) -> np.ndarray:
        n = self.size // 2
        x = self.half @ x
        last = self.n - 1
        for i in range(self.n):
            for kick, mg, g in zip(self.kick, self.mg, self.g, strict=True):
                x[n:] -= np.outer(kick[i] * mg, g @ x[:n])           # (T.10) element kick
            x = (self.full if i < last else self.half) @ x
        return x


def period_map(problem: HBMProblem, deltas: np.ndarray, period: float):
    """The one-period map of (T.10) along the elements' deflections ``deltas`` (E, n)."""
    cls = ModalPeriod if problem.modal else DensePeriod
    return cls(problem, step_stiffness(problem, deltas), period)


def _ritz(step, x: np.ndarray, tol: float, max_sweeps: int, last: list | None = None):
    """Dominant eigenvalues of ``step`` by subspace iteration from the columns of x.

    Returns (dominant half of the Ritz values, converged?, next orthonormal basis);
    ``last`` (a list) receives the orthonormal block and its image of the last sweep.
    """
    x, _ = np.linalg.qr(x)
    top = max(1, x.shape[1] // 2)
    mu = np.zeros(top, dtype=complex)
    for _ in range(max_sweeps):
        y = step(x)
        if last is not None:
            last[:] = [x, y]
        mu, w = np.linalg.eig(x.T @ y)
        order = np.argsort(-np.abs(mu))[:top]
        mu, w = mu[order], w[:, order]
        # residual of the dominant half of the Ritz pairs, relative to the largest
        res = np.linalg.norm(y @ w - (x @ w) * mu, axis=0) / max(abs(mu[0]), 1e-300)
        x, _ = np.linalg.qr(y)
        if np.all(res <= tol):
            return mu, True, x
    return mu, False, x


def dominant_multipliers(step, size: int, columns: int, tol: float, start, rng, full=None,
                         last=None):
    """Dominant multipliers of one period map: subspace iteration (from ``start`` when
    it has the right shape, else random), the full eig when the block reaches ``size``
    (the monodromy then put in ``full[0]`` when a list is given; ``last``, a list,
    receives the block and its image of the last sweep, see :func:`_ritz`).

    Returns (multipliers, block size, basis of the dominant subspace or None).
    """
    p = columns
    while p < size:
        x0 = start if start is not None and start.shape == (size, p) else \
            rng.standard_normal((size, p))
        mu, ok, basis = _ritz(step, x0, tol, max_sweeps=6, last=last)
        if ok:
            return mu, p, basis
        p, start = 2 * p, None
    phi = step(np.eye(size))
    if full is not None:
        full[:] = [phi]
    return np.linalg.eigvals(phi), size, None


def energy_weights(problem: HBMProblem) -> tuple[np.ndarray, np.ndarray | None]:
    """Weights of the energy norm on the states of the period map.

    Modal damping (the kept eq. (17) modes, mass-normalised): ``w = (omega_j, 1)`` on
    ``(q_j, v_j)``, so ``|w x|^2`` is twice the energy of the state in ``K'`` and ``M``.
    Otherwise, physical ``(q, v)``: returns ``(w, T)`` with ``T`` the modal transform
    (the eigenvectors of ``(K', M)``, a rigid mode weighted with 1e-3 of the largest
    frequency); for the modal case ``T`` is None.
    """
    if problem.modal:
        w = np.sqrt(np.abs(problem.w2[~problem.rigid]))
        return np.concatenate([w, np.ones(w.size)]), None
    s = problem.system
    w2, phi = sla.eigh(problem.Kp, s.M)
    w = np.sqrt(np.maximum(w2, (1e-3 ** 2) * np.max(np.abs(w2))))
    tinv = np.linalg.inv(phi)
    n = s.n_dof
    t = np.zeros((2 * n, 2 * n))
    t[:n, :n] = tinv
    t[n:, n:] = tinv
    return np.concatenate([w, np.ones(n)]), t


def period_amplification(problem: HBMProblem, step, phi: np.ndarray | None = None,
                         basis: np.ndarray | None = None,
                         image: tuple[np.ndarray, np.ndarray] | None = None
                         ) -> tuple[float, bool]:
    """Largest singular value of the period map in the energy norm (:func:`energy_weights`).

    ``phi``: the whole monodromy (exact); else, up to :data:`FULL_AMPLIFICATION_STATES`
    states, the whole monodromy is formed (one application of the period map to the
    identity: 0.1-0.2 s on the shipped 112-mode pump, against 0.7-0.9 s for its
    exponents); beyond, ``basis``: the dominant subspace, on which the map is applied once
    (a lower bound of the whole map's: 0.50 against 3.22 on the pump at 1384.67 rpm), or
    ``image``: an orthonormal block ``x`` and ``step(x)`` already computed (the last
    sweep of the subspace iteration, whose span is the dominant subspace to its
    tolerance), which spares that application of the period map.
    Returns (value, exact).
    """
    w, t = energy_weights(problem)
    if phi is None and w.size <= FULL_AMPLIFICATION_STATES:
        phi = step(np.eye(w.size))
    if phi is None and basis is None and image is None:
        return float("nan"), False
    if phi is not None:
        a = phi if t is None else t @ phi @ np.linalg.inv(t)
        a = w[:, None] * a / w[None, :]
        return float(np.linalg.svd(a, compute_uv=False)[0]), True
    x, y = image if image is not None else (basis, step(basis))
    bx = w[:, None] * (x if t is None else t @ x)
    by = w[:, None] * (y if t is None else t @ y)
    q, r = np.linalg.qr(bx)
    # the map on span(x) in the energy norm: by = A bx, A restricted = by r^-1 q^T
    a = np.linalg.solve(r.T, by.T).T
    return float(np.linalg.svd(a, compute_uv=False)[0]), False


def _leading(problem: HBMProblem, point: Point, n: int, period: float, size: int,
             basis: np.ndarray | None) -> float:
    """Largest real part (1/s) of the exponents of the period map with ``n`` steps: every
    multiplier (``basis`` None) or the Ritz values on ``basis``."""
    step = period_map(problem, orbit_deltas(problem, point.unknowns, n), period)
    mu = np.linalg.eigvals(step(np.eye(size))) if basis is None else _projected(step, basis)
    return float(floquet_from_multipliers(mu, period)[0].real)


def _asymptotic(values: list[float], rtol: float) -> bool:
    """Whether the largest real parts with ``n/8, n/4, n/2, n`` steps (``values``, in that
    order) converge like a second-order scheme: each difference smaller than the one before
    by 2 to 8 (4 in the limit), or negligible against ``rtol`` of the value. Before that
    regime the difference with ``n/2`` is not an error estimate: on the shipped pump at
    2508.95 rpm 2048 and 4096 steps give 15.85 and 10.74 1/s (estimated error 1.7) against
    5.98 converged; at 1384.67 rpm 1024, 2048, 4096, 8192 steps give -59.9, -18.4, -3.2,
    -8.3 against -10.5 (three levels can pass by chance, four did not there)."""
    d = np.diff(np.asarray(values, dtype=float))[::-1]          # newest difference first
    small = 0.1 * rtol * (abs(values[-1]) + 1.0)
    if np.all(np.abs(d) <= small):
        return True
    for newer, older in zip(d[:-1], d[1:], strict=True):
        if abs(newer) <= small and abs(older) <= 8.0 * small:
            continue
        if not (newer * older > 0 and 2.0 <= older / newer <= 8.0):
            return False
    return True


def _projected(step, basis: np.ndarray) -> np.ndarray:
    """Ritz values of ``step`` on a fixed basis (one sweep)."""
    mu = np.linalg.eigvals(basis.T @ step(basis))
    return mu[np.argsort(-np.abs(mu))[: max(1, basis.shape[1] // 2)]]


def exponents_along(problem: HBMProblem, deltas: np.ndarray, period: float,
                    columns: int = 16, ritz_tol: float = 1e-8) -> np.ndarray:
    """Dominant Floquet exponents (1/s) of (T.10) along any periodic deflections.

    ``deltas``: every element's ``Delta_e`` (m) at ``n`` equally spaced instants of one
    period ``period`` (s) starting at the phase origin of the elements' parameters,
    (E, n) (or (n,) with one element) — e.g. the last period of a time integration, to
    check the exponents of an HBM orbit against those of the orbit the equations of
    motion settle on.
    """
    size = 2 * (int(np.sum(~problem.rigid)) if problem.modal else problem.n_dof)
    cols = size if size <= 2 * columns else columns
    deltas = np.asarray(deltas, dtype=float).reshape(problem.n_elements, -1)
    mu, _, _ = dominant_multipliers(period_map(problem, deltas, period), size,
                            cols, ritz_tol, None, np.random.default_rng(12345))
    return floquet_from_multipliers(mu, period)


def floquet_from_multipliers(mu: np.ndarray, period: float) -> np.ndarray:
    """Floquet exponents log(mu) / T by decreasing real part; a multiplier 0 (a direction
    the period annihilates, e.g. a rank-deficient Ritz basis) gives -inf, not a warning."""
    mu = np.asarray(mu, dtype=complex)
    lam = np.full(mu.shape, complex(-np.inf, 0.0))
    nz = mu != 0
    lam[nz] = np.log(mu[nz]) / period
    return lam[np.argsort(-lam.real, kind="stable")]


def monodromy_exponents(problem: HBMProblem, point: Point, n_steps: int | None = None,
                        columns: int = 16, rtol: float = 1e-2, sign_margin: float = 4.0,
                        max_refine: int = 4, ritz_tol: float = 1e-8,
                        start: np.ndarray | None = None) -> MonodromyResult:
    """Floquet exponents of a periodic solution by the monodromy of (T.10), every mode.

    Parameters
    ----------
    problem, point
        The HBM problem and a converged solution.
    n_steps
        Time steps per period to start from (default: the AFT grid, within 256-2048,
        and at least :data:`MIN_STEPS_PER_BASE_PERIOD` per period of the fastest
        element's base frequency).
    columns
        Initial block size of the subspace iteration; the full monodromy is formed
        when ``2 m <= 2 * columns``.
    rtol, sign_margin
        The step count is doubled (at most ``max_refine`` times) until the estimated error
        of the largest real part is below ``rtol * |max_real|`` or, since the verdict only
        needs its sign, below ``|max_real| / sign_margin`` (pass ``sign_margin=inf`` for
        the accuracy alone); at an unstable point (its exponent is reported) also until the
        largest real parts with ``n/8 ... n`` steps converge at second order
        (:func:`_asymptotic`: the error estimate is only valid there).
    ritz_tol
        Relative residual of the accepted Ritz pairs.
    start
        A basis to start the subspace iteration from (``MonodromyResult.basis`` of a
        neighbouring point on the branch: the iteration then converges in a sweep or
        two), with its block size when wider than ``columns``; ignored when its shape
        does not fit.

    Returns
    -------
    MonodromyResult
    """
    problem.require_periodic("the monodromy (Floquet exponents)")
    period = 2 * np.pi / problem.harmonics.fundamental_rad_s(point.omega)
    # the monodromy's resolution follows the dynamics, not the harmonic count: the
    # AFT grid up to 2048 steps per period, refined below when the sign needs it; and at
    # least MIN_STEPS_PER_BASE_PERIOD per period of the fastest element (a train's
    # hunting period with shaft orders holds thousands of mesh periods: 2048 steps over
    # 4087 of them overflow)
    fastest = max((int(s) for s in problem.steps), default=0)
    n = int(n_steps or max(min(max(256, problem.harmonics.n_time), 2048),
                           MIN_STEPS_PER_BASE_PERIOD * fastest))
    n = 2 * int(np.ceil(n / 2))
    rng = np.random.default_rng(12345)
    size = 2 * (int(np.sum(~problem.rigid)) if problem.modal else problem.n_dof)
    cols = size if size <= 2 * columns else columns
    if start is not None and start.ndim == 2 and start.shape[0] == size and \
            cols < start.shape[1] < size:
        # the neighbour needed a wider block (clustered multipliers, e.g. at high speed):
        # start there, from its basis, rather than fail with the narrow one first
        cols = start.shape[1]
    prev = None
    levels: list[float] = []          # largest real parts with n/8, n/4 (then n/2, ...)
    overflowed = 0
    refine = 0
    while refine <= max_refine:
        full: list = []
        last: list = []
        try:
            with np.errstate(over="ignore", invalid="ignore"):
                step = period_map(problem, orbit_deltas(problem, point.unknowns, n), period)
                mu, cols_n, basis = dominant_multipliers(step, size, cols, ritz_tol, start,
                                                         rng, full, last)
                lam = floquet_from_multipliers(mu, period)
                if prev is None:
                    prev = _leading(problem, point, n // 2, period, size, basis)
                if lam[0].real > 0 and len(levels) < 2:
                    # an unstable point: its exponent is reported, the step count must be
                    # in the second-order regime (:func:`_asymptotic`)
                    levels = [_leading(problem, point, n // m, period, size, basis)
                              for m in (8, 4)]
            overflow = False
        except np.linalg.LinAlgError:       # the period map overflowed to inf/NaN
            overflow = True
        if overflow:
            # steps too long for the fastest dynamics over a long period (a train's
            # hunting period): the map overflows; halve the step, not counted as a
            # refinement of the error (at most MAX_OVERFLOW_DOUBLINGS times)
            overflowed += 1
            if overflowed > MAX_OVERFLOW_DOUBLINGS:
                raise np.linalg.LinAlgError(
                    f"monodromy at {point.rpm:.2f} rpm: the period map overflows with "
                    f"{n} steps per period, after {overflowed - 1} doublings")
            prev, levels, start, n = None, [], None, 2 * n
            continue
        cols = cols_n
        mx = float(lam[0].real)
        err = abs(mx - prev) / 3.0                       # second order in the step
        asymptotic = mx <= 0 or _asymptotic([*levels[-2:], prev, mx], rtol)
        resolved = asymptotic and (err <= rtol * abs(mx) or err * sign_margin < abs(mx))
        if resolved or refine == max_refine:
            if not resolved:
                # the sign undecided: a warning; only the magnitude's error unknown: info
                sign = err * sign_margin < abs(mx) or err <= rtol * abs(mx)
                (logger.info if sign else logger.warning)(
                    "monodromy at %.2f rpm: largest real part %.4g 1/s, estimated error %.2g "
                    "after %d steps per period%s", point.rpm, mx, err, n,
                    "" if asymptotic else " (steps not yet in the second-order regime: the "
                    "estimate is not reliable)")
            with np.errstate(over="ignore", invalid="ignore"):
                amp, exact = period_amplification(problem, step, full[0] if full else None,
                                                  basis, tuple(last) if last else None)
            return MonodromyResult(lam, mx, err, n, cols, basis, amp, exact)
        levels.append(prev)
        prev, start = mx, basis
        n *= 2
        refine += 1
    raise AssertionError("unreachable")
