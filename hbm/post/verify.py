"""Independent checks of a converged HBM point.

* :func:`full_residual` re-evaluates the harmonic balance of the *uncondensed*
  system (eq. 21) with the original ``K`` and every element's full force ``f_e``
  (a gear mesh: the dead zone of eq. 13), by real FFTs instead of the AFT matrices, from
  the coordinates recovered by :meth:`HBMProblem.recover`. It checks the condensation,
  the modal sums and the Newton solution together.
* :func:`shooting_error` integrates ``M q'' + C q' + K q + sum_e g_e f_e(g_e^T q, t) =
  f_ex(t)`` in time (``scipy.integrate.solve_ivp``) from the HBM state at
  ``t = 0`` over whole fundamental periods and compares every ``Delta_e(t)`` with the
  HBM series: the truncation error of the harmonic set, seen by an
  independent method.
* :func:`quasi_static_delta` solves the Omega -> 0 limit pointwise in time.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from ..elements.base import take_samples
from ..problem import HBMProblem, Point

logger = logging.getLogger(__name__)

__all__ = ["ShootingCheck", "full_residual", "quasi_static_delta", "shooting_error"]


def full_residual(problem: HBMProblem, point: Point) -> float:
    """Largest per-DOF relative residual of the uncondensed harmonic balance (eq. 21).

    For each coordinate i the norm over harmonics of
    ``R_ik = [(K - (k w0)^2 M + i k w0 C) q_k]_i + sum_e g_e,i f_e,k - F_ik`` is divided
    by the largest norm of the terms of that row (stiffness, inertia, damping,
    each element's force, excitation), so the figure is dimensionless and independent of
    each coordinate's units. Rows whose terms are all zero are skipped.

    Returns
    -------
    float
        max_i ||R_i|| / scale_i (dimensionless).
    """
    if not problem.periodic:
        return _torus_full_residual(problem, point)
    hs = problem.harmonics
    s = problem.system
    q = problem.recover(point)                                   # (n, nS)
    n_t = hs.n_time
    k = problem.harmonic_indices
    spec = np.zeros((s.n_dof, n_t // 2 + 1), dtype=complex)
    spec[:, k] = q * np.where(k == 0, 1.0, 0.5) * n_t
    coords = np.fft.irfft(spec, n_t, axis=1)                     # q(tau_j)
    corrected = problem.aft == "corrected"   # the sub-sample kink correction (T.13a)
    loads = []
    for el, g, smp in zip(problem.elements, problem.directions, problem.samples,
                          strict=True):
        f_t = el.load(g @ coords, smp, corrected)                # f_e(Delta_e(tau_j))
        fk = np.fft.rfft(f_t)[k] / n_t * np.where(k == 0, 1.0, 2.0)  # f_e,k
        loads.append(np.outer(g, fk))
    return _balance(problem, point, q, loads)


def _torus_full_residual(problem: HBMProblem, point: Point) -> float:
    """:func:`full_residual` on a torus basis: the coordinates synthesised on the torus
    grid, every element's full force analysed there (d-dimensional FFTs), frequencies
    ``(k . r) Omega``."""
    hs = problem.harmonics
    q = problem.recover(point)                                   # (n, nS)
    coords = hs.synthesize(hs.to_real(q))                        # (n, N_1, ..., N_d)
    corrected = problem.aft == "corrected"
    loads = []
    for el, g, smp in zip(problem.elements, problem.directions, problem.samples,
                          strict=True):
        f_t = el.load(np.tensordot(g, coords, axes=1), smp, corrected)
        loads.append(np.outer(g, hs.to_complex(hs.analyse(f_t))))
    return _balance(problem, point, q, loads)


def _balance(problem: HBMProblem, point: Point, q: np.ndarray, loads: list) -> float:
    """Largest relative residual of the harmonic balance over the harmonics: the terms
    K q, -w^2 M q, i w C q, each element's load and the forcing (eq. 21) summed per
    harmonic, against the largest of them."""
    s = problem.system
    w = problem.kS * problem.harmonics.rate * point.omega
    forcing = (problem.Fc + point.omega ** 2 * problem.Fu).T     # (n, nS)
    terms = [s.K @ q, -(w ** 2) * (s.M @ q), 1j * w * (s.C @ q), *loads, -forcing]
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
        ``max_t |Delta_ode - Delta_hbm|`` over the integrated periods and the elements
        (m).
    relative
        The largest over the elements of their error divided by the half peak-to-peak of
        their ``Delta_hbm`` (floored at 1e-6 times their length scale).
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
    problem.require_periodic("shooting_error (one fundamental period)")
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
    mk, mc = minv @ s.K, minv @ s.C
    mf = forcing @ minv.T                                            # (nS, n)
    elements = [(el, g, minv @ g, step) for el, g, step in
                zip(problem.elements, problem.directions, problem.steps, strict=True)]

    def rhs(t, y):
        x, v = y[:n], y[n:]
        ext = (mf * np.exp(1j * kw * t)[:, None]).real.sum(axis=0)
        acc = ext - mc @ v - mk @ x
        for el, g, mg, step in elements:
            smp = el.sample(np.array([step * w0 * t]))
            acc = acc - mg * el.load(np.array([g @ x]), smp)[0]
        return np.concatenate([v, acc])

    def jac(t, y):
        x = y[:n]
        jmat = np.zeros((2 * n, 2 * n))
        jmat[:n, n:] = np.eye(n)
        stiff = -mk
        for el, g, mg, step in elements:
            smp = el.sample(np.array([step * w0 * t]))
            kc = el.load_stiffness(np.array([g @ x]), smp)[0]
            stiff = stiff - kc * np.outer(mg, g)
        jmat[n:, :n] = stiff
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
    errs, rels = [], []
    for g, scale in zip(problem.directions, problem.length_scales, strict=True):
        d_ode = g @ sol.y[:n]
        d_hbm = (g @ q @ np.exp(1j * np.outer(problem.kS, w0 * t_eval))).real
        e = float(np.max(np.abs(d_ode - d_hbm)))
        half = 0.5 * float(np.ptp(d_hbm))
        errs.append(e)
        rels.append(e / max(half, 1e-6 * scale))
    err = max(errs)
    yscale = np.concatenate([np.ones(n), np.full(n, 2 * np.pi / w0)])
    per = float(np.linalg.norm((sol.y[:, -1] - y0) * yscale)
                / max(np.linalg.norm(y0 * yscale), 1e-300))
    return ShootingCheck(max_error=err, relative=max(rels), periodicity=per, seconds=seconds,
                         n_rhs=int(sol.nfev))


def quasi_static_delta(problem: HBMProblem) -> np.ndarray:
    """Every ``Delta_e`` (m) on the AFT grid in the limit Omega -> 0: pointwise statics,
    (E, n_time).

    With the static compliances ``H0 = G^T K'^-1 G`` and ``d0 = G^T K'^-1 F_0``
    (T.6 at k = 0), each sample solves ``Delta + H0 (f(Delta, t) - K_bar Delta) = d0``
    (E equations). One element: a scalar equation strictly increasing in Delta
    (``h0 k_bar < 1``), by bracketing and Brent's method; several: Newton's method from
    the linear solution, with halving steps. Only the static load may be applied (no
    shaft-order forcing).
    """
    problem.require_periodic("quasi_static_delta")
    from scipy.optimize import brentq

    if np.any(problem.Fc[1:] != 0) or np.any(problem.Fu != 0):
        raise ValueError("quasi_static_delta: the excitation must be static (constant[0] only)")
    if np.any(problem.rigid):
        raise ValueError("quasi_static_delta: K + sum k_bar g g^T must be regular")
    d = problem.dof_eq
    kt = problem.Kp * np.outer(d, d)
    ne = problem.n_elements
    x = d[:, None] * np.linalg.solve(kt, d[:, None] * np.stack(
        [*problem.directions, problem.Fc[0].real], axis=1))
    comp = np.stack([g @ x for g in problem.directions])        # (E, E + 1)
    h0, d0 = comp[:, :ne], comp[:, ne]
    n = problem.harmonics.n_time
    out = np.empty((ne, n))
    if ne == 1:
        el, smp, kbar = problem.elements[0], problem.samples[0], problem.kbar[0]
        h, dd = h0[0, 0], d0[0]
        bracket = el.static_scale(smp, n)
        for j in range(n):
            sj = take_samples(smp, slice(j, j + 1))

            def f(z, sj=sj):
                return z + h * (el.load(np.array([z]), sj)[0] - kbar * z) - dd
            scale = max(abs(dd), bracket[j])
            lo, hi = -scale, scale
            while f(lo) > 0:
                lo *= 2
            while f(hi) < 0:
                hi *= 2
            out[0, j] = brentq(f, lo, hi, xtol=1e-15 * scale, rtol=4 * np.finfo(float).eps)
        return out
    for j in range(n):
        sj = [take_samples(smp, slice(j, j + 1)) for smp in problem.samples]
        out[:, j] = _static_newton(problem, h0, d0, sj)
    return out


def _static_newton(problem: HBMProblem, h0: np.ndarray, d0: np.ndarray, samples: list,
                   tol: float = 1e-14, max_iter: int = 50) -> np.ndarray:
    """``z + H0 f'(z) = d0`` (E equations, ``f' = f - K_bar z``): Newton with halving steps
    from the elements' linear laws (law 0, one step) to their own (law 1), through
    intermediate laws when a stage fails (the force is only piecewise linear)."""
    els = problem.elements
    scale = max(float(np.max(np.abs(d0))), float(np.max(problem.length_scales)))

    def evaluate(z, law):
        out = [el.force(np.array([zi]), s, law, False) for el, zi, s in
               zip(els, z, samples, strict=True)]
        r = z + h0 @ np.array([f[0] for f, _ in out]) - d0
        return r, np.eye(z.size) + h0 * np.array([st.samples[0] for _, st in out])[None, :]

    def solve(z, law):
        r, j = evaluate(z, law)
        for _ in range(max_iter):
            if np.linalg.norm(r) <= tol * scale:
                return z
            step = np.linalg.solve(j, -r)
            alpha = 1.0
            while True:
                zn = z + alpha * step
                rn, jn = evaluate(zn, law)
                if np.linalg.norm(rn) < np.linalg.norm(r) or alpha < 1e-6:
                    break
                alpha *= 0.5
            z, r, j = zn, rn, jn
        raise ArithmeticError(f"quasi_static_delta: Newton did not converge at law {law} "
                              f"(residual {np.linalg.norm(r):.3g} m)")

    z = solve(d0.copy(), 0.0)
    laws, done = [1.0], 0.0
    while laws:
        try:
            z, done = solve(z, laws[0]), laws.pop(0)
        except (ArithmeticError, np.linalg.LinAlgError):
            if laws[0] - done < 1e-3:
                raise
            laws.insert(0, 0.5 * (done + laws[0]))
    return z
