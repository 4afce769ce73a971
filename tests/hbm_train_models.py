"""The lumped two-stage reducer of tests/test_hbm_torus.py integrated in time, written out
here independently of hbm's AFT and condensation: ``M theta'' + C theta' + g_1 f_1 + g_2 f_2
= T(t)`` with the dead-zone meshes of eq. (13) evaluated at each instant, by
``scipy.integrate.solve_ivp`` (DOP853). The mesh-load mean and mean square are integrated
as extra states (exact quadrature to the integrator's tolerance) with a flat weight over
whole common periods (a periodic response) or a smooth bump weight (the weighted Birkhoff
average of Das and Yorke, "Super convergence of ergodic averages for quasiperiodic
orbits", Nonlinearity 31, 2018: faster than any power of the window for a quasi-periodic
signal), so that the standard deviation of each mesh load over the window is exact up to
the window's own error."""
from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
from scipy.integrate import quad, solve_ivp

from hbm.examples import TwoStage

RPM = 2.0 * math.pi / 60.0

_BUMP_MASS = quad(lambda s: math.exp(-1.0 / (s * (1.0 - s))), 0.0, 1.0,
                  epsabs=1e-15, epsrel=1e-14)[0]


@dataclass
class Integrated:
    """Mesh-load standard deviations (N) over the analysed window, per mesh, with the cost
    (s of wall time, right-hand-side evaluations)."""

    std: np.ndarray
    mean: np.ndarray
    seconds: float
    n_rhs: int
    state: np.ndarray


def integrate(model: TwoStage, rpm: float, theta0: np.ndarray, omega0: np.ndarray,
              transient: float, window: float, weight: str = "flat", rtol: float = 1e-10,
              max_step: float | None = None) -> Integrated:
    """Integrate ``model`` at ``rpm`` from ``(theta0, omega0)`` (rad, rad/s) for
    ``transient`` s, then average over ``window`` s (``weight`` ``"flat"`` or ``"bump"``)."""
    m = np.diag(model.system().M).copy()
    c = model.system().C
    g1, g2 = model.directions
    k = model.stiffness
    a = model.variation
    te = model.te
    b = model.backlash
    big_omega = rpm * RPM
    rates = [float(r) * big_omega for r in model.mesh_ratios]
    phases = model.phases
    rb = model.base_radii
    load = model.torque * rb[1] * rb[3] / (rb[0] * rb[2])
    static = np.array([model.torque, 0.0, -load])
    ripple = [(shaft, float(order * model.speeds[shaft]) * big_omega, amp)
              for shaft, order, amp in model.shaft_forcing]
    t0, t1 = transient, transient + window
    counter = [0]

    def mesh_force(delta, e, t):
        ph = rates[e] * t + phases[e]
        cs = math.cos(ph)
        km = k[e] * (1.0 + a[e] * cs)
        p = delta - te[e] * cs
        if p > b[e]:
            return km * (p - b[e])
        if p < -b[e]:
            return km * (p + b[e])
        return 0.0

    def weight_at(t):
        if weight == "flat":
            return 1.0 / window
        s = (t - t0) / window
        if s <= 0.0 or s >= 1.0:
            return 0.0
        return math.exp(-1.0 / (s * (1.0 - s))) / (_BUMP_MASS * window)

    (c00, c01, c02), (c10, c11, c12), (c20, c21, c22) = (tuple(float(v) for v in row)
                                                         for row in c)
    (a10, a11, a12), (a20, a21, a22) = (tuple(float(v) for v in gg) for gg in (g1, g2))
    m0, m1, m2 = (float(v) for v in m)
    s0, s1, s2 = (float(v) for v in static)
    ripple = [(int(shaft), float(w), float(amp)) for shaft, w, amp in ripple]
    cos = math.cos

    def rhs(t, y, averaging=True):
        # plain floats: the three-DOF right-hand side costs a few microseconds
        counter[0] += 1
        x0, x1, x2, v0, v1, v2 = y[0], y[1], y[2], y[3], y[4], y[5]
        f1 = mesh_force(a10 * x0 + a11 * x1 + a12 * x2, 0, t)
        f2 = mesh_force(a20 * x0 + a21 * x1 + a22 * x2, 1, t)
        tq = [s0, s1, s2]
        for shaft, w, amp in ripple:
            tq[shaft] += amp * cos(w * t)
        r0 = tq[0] - (c00 * v0 + c01 * v1 + c02 * v2) - a10 * f1 - a20 * f2
        r1 = tq[1] - (c10 * v0 + c11 * v1 + c12 * v2) - a11 * f1 - a21 * f2
        r2 = tq[2] - (c20 * v0 + c21 * v1 + c22 * v2) - a12 * f1 - a22 * f2
        w = weight_at(t) if averaging else 0.0
        return np.array([v0, v1, v2, r0 / m0, r1 / m1, r2 / m2,
                         w * f1, w * f1 * f1, w * f2, w * f2 * f2])

    y0 = np.concatenate([theta0, omega0, np.zeros(4)])
    scale = np.concatenate([np.full(3, max(np.max(np.abs(theta0)), 1e-9) * 1e-3),
                            np.full(3, max(np.max(np.abs(omega0)), 1e-9) * 1e-3),
                            np.full(4, 1e-6)])
    tic = time.perf_counter()
    kw = {} if max_step is None else {"max_step": max_step}
    sol = solve_ivp(rhs, (0.0, t0), y0, method="DOP853", rtol=rtol, atol=scale * rtol,
                    args=(False,), **kw)
    y = sol.y[:, -1]
    # the weighted window by itself (the weight is smooth inside, 0 at its ends)
    sol = solve_ivp(rhs, (t0, t1), y, method="DOP853", rtol=rtol,
                    atol=np.concatenate([scale[:6], np.abs(y[6:]) + 1.0]) * rtol, **kw)
    y = sol.y[:, -1]
    secs = time.perf_counter() - tic
    mean = np.array([y[6], y[8]])
    sq = np.array([y[7], y[9]])
    return Integrated(std=np.sqrt(np.maximum(sq - mean ** 2, 0.0)), mean=mean, seconds=secs,
                      n_rhs=counter[0], state=y[:6])


def bump_weights(t: np.ndarray, t0: float, window: float) -> np.ndarray:
    """The normalised bump weight of :func:`integrate` at the instants ``t`` (1/s)."""
    s = (np.asarray(t) - t0) / window
    inside = (s > 0.0) & (s < 1.0)
    w = np.zeros_like(s)
    si = s[inside]
    w[inside] = np.exp(-1.0 / (si * (1.0 - si))) / (_BUMP_MASS * window)
    return w


def torus_line_std(problem, point, t0: float, window: float, samples: int,
                   chunk: int = 4096) -> np.ndarray:
    """The mesh-load standard deviation of a torus solution along its time line over
    ``[t0, t0 + window]`` with the bump weight of :func:`integrate` (midpoint rule on
    ``samples`` instants): what the time integration sees over the same window."""
    hs = problem.harmonics
    dc = hs.to_complex(problem.delta_real(point.unknowns))           # (E, nS)
    w = problem.kS * hs.rate * point.omega
    t = t0 + (np.arange(samples) + 0.5) * window / samples
    wt = bump_weights(t, t0, window) * window / samples
    acc = np.zeros((problem.n_elements, 2))
    for i in range(0, samples, chunk):
        tt = t[i:i + chunk]
        d = (dc @ np.exp(1j * np.outer(w, tt))).real
        for e, el in enumerate(problem.elements):
            f = el.load(d[e], el.sample(float(el.base_ratio) * point.omega * tt))
            acc[e, 0] += wt[i:i + chunk] @ f
            acc[e, 1] += wt[i:i + chunk] @ (f * f)
    return np.sqrt(acc[:, 1] - acc[:, 0] ** 2)
