"""Independent checks of a converged HBM point.

* :func:`full_residual` re-evaluates the harmonic balance of the *uncondensed*
  system (eq. 21) with the original ``K`` and the full dead-zone force ``f_LoA``
  (eq. 13), by real FFTs instead of the AFT matrices, from the coordinates
  recovered by :meth:`HBMProblem.recover`. It checks the condensation, the
  modal sums and the Newton solution together.
* :func:`shooting_error` integrates ``M q'' + C q' + K q + G f_LoA(G^T q, t) =
  f_ex(t)`` in time (``scipy.integrate.solve_ivp``) from the HBM state at
  ``t = 0`` over whole fundamental periods and compares ``Delta(t)`` with the
  HBM series: the truncation error of the harmonic set, seen by an
  independent method.
* :func:`quasi_static_delta` solves the Omega -> 0 limit pointwise in time.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from .contact import dead_zone, dead_zone_stiffness, kink_correction
from .problem import HBMProblem, Point

logger = logging.getLogger(__name__)

__all__ = ["ShootingCheck", "full_residual", "quasi_static_delta", "shooting_error"]


def full_residual(problem: HBMProblem, point: Point) -> float:
    """Largest per-DOF relative residual of the uncondensed harmonic balance (eq. 21).

    For each coordinate i the norm over harmonics of
    ``R_ik = [(K - (k w0)^2 M + i k w0 C) q_k]_i + G_i f_LoA,k - F_ik`` is divided
    by the largest norm of the terms of that row (stiffness, inertia, damping,
    mesh force, excitation), so the figure is dimensionless and independent of
    each coordinate's units. Rows whose terms are all zero are skipped.

    Returns
    -------
    float
        max_i ||R_i|| / scale_i (dimensionless).
    """
    hs = problem.harmonics
    s = problem.system
    q = problem.recover(point)                                   # (n, nS)
    n_t = hs.n_time
    k = problem.harmonic_indices
    spec = np.zeros((s.n_dof, n_t // 2 + 1), dtype=complex)
    spec[:, k] = q * np.where(k == 0, 1.0, 0.5) * n_t
    delta = problem.G @ np.fft.irfft(spec, n_t, axis=1)          # Delta(tau_j)
    phase = hs.time_grid() * problem.mesh_step
    p, km = delta - problem.mesh.error_at(phase), problem.mesh.stiffness_at(phase)
    f_t = dead_zone(p, km, problem.mesh.backlash)
    if problem.aft == "corrected":       # the sub-sample kink correction (T.13a)
        f_t = f_t + kink_correction(p, km, problem.mesh.backlash).values
    fk = np.fft.rfft(f_t)[k] / n_t * np.where(k == 0, 1.0, 2.0)  # f_LoA,k
    w = problem.kS * hs.divisor * point.omega
    forcing = (problem.Fc + point.omega ** 2 * problem.Fu).T     # (n, nS)
    terms = [s.K @ q, -(w ** 2) * (s.M @ q), 1j * w * (s.C @ q),
             np.outer(problem.G, fk), -forcing]
    r = np.sum(terms, axis=0)
    scale = np.max([np.linalg.norm(t, axis=1) for t in terms], axis=0)
    live = scale > 0
    if not np.any(live):
        return 0.0
    return float(np.max(np.linalg.norm(r[live], axis=1) / scale[live]))


@dataclass
class ShootingCheck:
    """Time integration started on the HBM orbit.

    Attributes
    ----------
    max_error
        ``max_t |Delta_ode - Delta_hbm|`` over the integrated periods (m).
    relative
        ``max_error`` divided by the half peak-to-peak of ``Delta_hbm`` (floored
        at 1e-6 times the problem's length scale).
    periodicity
        ``|y(T_end) - y(0)| / |y(0)|`` of the integrated state (positions in the
        model's units, velocities times the fundamental period).
    seconds
        Wall time of the integration (s).
    n_rhs
        Right-hand-side evaluations of the integrator.
    """

    max_error: float
    relative: float
    periodicity: float
    seconds: float
    n_rhs: int


def shooting_error(problem: HBMProblem, point: Point, periods: int = 1,
                   method: str = "DOP853", rtol: float = 1e-10,
                   samples_per_period: int = 512) -> ShootingCheck:
    """Integrate the full equations of motion from the HBM state and compare Delta.

    Parameters
    ----------
    problem, point
        The problem and a converged point of it.
    periods
        Fundamental periods ``2 pi / w0`` to integrate (>= 1).
    method
        ``solve_ivp`` method; ``"Radau"`` or ``"BDF"`` use the analytic
        (piecewise-constant) Jacobian, for stiff meshes.
    rtol
        Relative tolerance of the integrator (absolute tolerance scaled by the
        HBM amplitudes of each state).
    samples_per_period
        Comparison samples per period.
    """
    import time

    from scipy.integrate import solve_ivp

    if int(periods) != periods or periods < 1:
        raise ValueError(f"shooting_error.periods = {periods!r}: must be an integer >= 1")
    hs = problem.harmonics
    s = problem.system
    n = s.n_dof
    w0 = hs.fundamental_rad_s(point.omega)
    kw = problem.kS * w0
    q = problem.recover(point)
    forcing = problem.Fc + point.omega ** 2 * problem.Fu              # (nS, n)
    minv = np.linalg.inv(s.M)
    mk, mc, mg = minv @ s.K, minv @ s.C, minv @ problem.G
    mf = forcing @ minv.T                                            # (nS, n)
    g, b, step = problem.G, problem.mesh.backlash, problem.mesh_step

    def rhs(t, y):
        x, v = y[:n], y[n:]
        ph = step * w0 * t
        km = problem.mesh.stiffness_at(np.array([ph]))[0]
        e = problem.mesh.error_at(np.array([ph]))[0]
        f = dead_zone(np.array([g @ x - e]), np.array([km]), b)[0]
        ext = (mf * np.exp(1j * kw * t)[:, None]).real.sum(axis=0)
        return np.concatenate([v, ext - mc @ v - mk @ x - mg * f])

    def jac(t, y):
        x = y[:n]
        ph = step * w0 * t
        km = problem.mesh.stiffness_at(np.array([ph]))[0]
        p = g @ x - problem.mesh.error_at(np.array([ph]))[0]
        kc = dead_zone_stiffness(p, km, b)
        jmat = np.zeros((2 * n, 2 * n))
        jmat[:n, n:] = np.eye(n)
        jmat[n:, :n] = -mk - kc * np.outer(mg, g)
        jmat[n:, n:] = -mc
        return jmat

    x0, v0 = q.real.sum(axis=1), (1j * kw * q).real.sum(axis=1)
    y0 = np.concatenate([x0, v0])
    amp = np.concatenate([np.abs(q).sum(axis=1), (np.abs(q) * kw).sum(axis=1)])
    atol = rtol * np.maximum(amp, 1e-300 + 1e-12 * np.max(amp))
    t_end = periods * 2 * np.pi / w0
    t_eval = np.linspace(0.0, t_end, periods * samples_per_period + 1)
    kwargs = {"jac": jac} if method in ("Radau", "BDF", "LSODA") else {}
    t0 = time.perf_counter()
    sol = solve_ivp(rhs, (0.0, t_end), y0, method=method, t_eval=t_eval, rtol=rtol,
                    atol=atol, **kwargs)
    seconds = time.perf_counter() - t0
    if not sol.success:
        raise RuntimeError(f"shooting_error: time integration failed: {sol.message}")
    d_ode = g @ sol.y[:n]
    d_hbm = (g @ q @ np.exp(1j * np.outer(problem.kS, w0 * t_eval))).real
    err = float(np.max(np.abs(d_ode - d_hbm)))
    half = 0.5 * float(np.ptp(d_hbm))
    denom = max(half, 1e-6 * problem.length_scale)
    yscale = np.concatenate([np.ones(n), np.full(n, 2 * np.pi / w0)])
    per = float(np.linalg.norm((sol.y[:, -1] - y0) * yscale)
                / max(np.linalg.norm(y0 * yscale), 1e-300))
    return ShootingCheck(max_error=err, relative=err / denom, periodicity=per, seconds=seconds,
                         n_rhs=int(sol.nfev))


def quasi_static_delta(problem: HBMProblem) -> np.ndarray:
    """``Delta`` (m) on the AFT grid in the limit Omega -> 0: pointwise statics.

    With the static compliances ``h0 = G^T K'^-1 G`` and ``d0 = G^T K'^-1 F_0``
    (T.6 at k = 0), each sample solves the scalar equation
    ``Delta + h0 (f_LoA(Delta, t) - k_bar Delta) = d0``, strictly increasing in
    Delta (``h0 k_bar < 1``), by bracketing and Brent's method. Only the static
    load may be applied (no shaft-order forcing).
    """
    from scipy.optimize import brentq

    if np.any(problem.Fc[1:] != 0) or np.any(problem.Fu != 0):
        raise ValueError("quasi_static_delta: the excitation must be static (constant[0] only)")
    if np.any(problem.rigid):
        raise ValueError("quasi_static_delta: K + k_bar G G^T must be regular")
    d = problem.dof_eq
    kt = problem.Kp * np.outer(d, d)
    x = d[:, None] * np.linalg.solve(kt, d[:, None] * np.stack([problem.G, problem.Fc[0].real],
                                                               axis=1))
    h0, d0 = problem.G @ x
    b, kbar = problem.b, problem.kbar
    out = np.empty(problem.harmonics.n_time)
    for j, (k, e) in enumerate(zip(problem.k_t, problem.e_t, strict=True)):
        def f(z, k=k, e=e):
            return z + h0 * (dead_zone(np.array([z - e]), np.array([k]), b)[0] - kbar * z) - d0
        scale = max(abs(d0), abs(e) + b)
        lo, hi = -scale, scale
        while f(lo) > 0:
            lo *= 2
        while f(hi) < 0:
            hi *= 2
        out[j] = brentq(f, lo, hi, xtol=1e-15 * scale, rtol=4 * np.finfo(float).eps)
    return out
