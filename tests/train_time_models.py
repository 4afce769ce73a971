"""Own time integration of a lumped gear train (scene.kind = "train") for the checks of
issue 36 item 5(a): the machine's ``M θ'' + C θ' + K θ + Σ_e g_e f_e(g_eᵀ θ, t) = T`` with
each mesh's dead-zone law of eq. (13) written out here from the scene's data (its stiffness
and transmission-error Fourier series, the layout's phase and static load, the backlash),
not from hbm's elements, and integrated by ``scipy.integrate.solve_ivp`` (DOP853). The
mean and the mean square of each mesh load (less its static load, against cancellation)
are integrated as extra states over whole periods of the fundamental, so the standard
deviation over the window is exact up to the integrator's tolerance.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp


@dataclass
class Integrated:
    """Mesh-load standard deviations and means (N) per mesh over the window; cost."""

    std: np.ndarray
    mean: np.ndarray
    seconds: float
    n_rhs: int


def _series(coeffs: dict) -> list[tuple[int, float, float]]:
    """(m, Re c_m, Im c_m) of a one-sided series Re Σ c_m e^{i m φ}."""
    return [(int(m), complex(c).real, complex(c).imag) for m, c in coeffs.items()]


def _value(series, phi: float) -> float:
    """Re Σ c_m e^{i m φ} = Σ (Re c_m cos mφ − Im c_m sin mφ)."""
    out = 0.0
    for m, re, im in series:
        out += re * math.cos(m * phi) - im * math.sin(m * phi)
    return out


def shaft_order_torques(scene, machine, rpm: float) -> list[tuple[int, float, float, float]]:
    """``(coordinate, amplitude, rate, phase)`` of each gear's share of each
    ``[[external.aero]]`` torque, written out from the scene: ``A cos(k ρ_s Ω t + φ)``
    about z on shaft s, split evenly on its gears (docs/scenes.md)."""
    big_omega = rpm * 2.0 * math.pi / 60.0
    names = list(machine.dof_names)
    out = []
    for a in scene.external.aero:
        shaft = machine.layout.shaft(a.shaft)
        gears = [g for g in machine.layout.gears if g.shaft == a.shaft]
        rate = a.order * float(shaft.speed_ratio) * big_omega
        for g in gears:
            out.append((names.index(g.name), a.torque[2] / len(gears), rate, a.phase))
    return out


def integrate_train(scene, machine, rpm: float, theta0: np.ndarray, omega0: np.ndarray,
                    period: float, transient_periods: int, window_periods: int,
                    rtol: float = 1e-11) -> Integrated:
    """Integrate the lumped train ``machine`` of ``scene`` at ``rpm`` (of the drive shaft)
    from ``(theta0, omega0)`` for ``transient_periods`` fundamental periods ``period`` (s),
    then average each mesh load over ``window_periods`` periods. The static torques are
    the machine's (order 0); the shaft-order torques :func:`shaft_order_torques`'s."""
    lm = machine.linear_model()
    torques = shaft_order_torques(scene, machine, rpm)
    M, C, K, G = (np.asarray(a, dtype=float) for a in (lm.M, lm.C, lm.K, lm.G))
    f0 = np.asarray(lm.constant[0]).real
    minv = np.linalg.inv(M)
    n, n_e = M.shape[0], G.shape[1]
    big_omega = rpm * 2.0 * math.pi / 60.0
    meshes = []
    for e, (spec, data, lay) in enumerate(zip(machine.gear_meshes, scene.meshes,
                                                machine.layout.meshes, strict=True)):
        te = data.transmission_error
        meshes.append((G[:, e].copy(), float(spec.frequency_ratio) * big_omega, lay.phase,
                       _series(data.mesh_stiffness.coefficients()), _series(te.coefficients()),
                       te.kind == "loaded", lay.static_load, data.backlash))
    t0, t1 = transient_periods * period, (transient_periods + window_periods) * period
    count = [0]

    def loads(theta, t):
        out = []
        for g, rate, phase, ks, es, loaded, fs, b in meshes:
            phi = rate * t + phase
            k = _value(ks, phi)
            e = _value(es, phi)
            if loaded:
                e -= fs / k                                       # eq. (12)
            p = float(g @ theta) - e
            out.append(k * (p - b) if p > b else k * (p + b) if p < -b else 0.0)
        return out

    def rhs(t, y):
        count[0] += 1
        theta, vel = y[:n], y[n:2 * n]
        f = loads(theta, t)
        force = f0 - C @ vel - K @ theta - G @ np.asarray(f)
        for j, amp, rate, phase in torques:
            force[j] += amp * math.cos(rate * t + phase)
        acc = minv @ force
        w = 1.0 / (t1 - t0) if t >= t0 else 0.0
        dev = [fe - m[6] for fe, m in zip(f, meshes, strict=True)]
        return np.concatenate([vel, acc, [w * d for d in dev], [w * d * d for d in dev]])

    y0 = np.concatenate([theta0, omega0, np.zeros(2 * n_e)])
    start = time.perf_counter()
    atol = np.concatenate([np.full(n, 1e-15), np.full(n, 1e-11), np.full(2 * n_e, 1e-12)])
    sol = solve_ivp(rhs, (0.0, t0), y0, method="DOP853", rtol=rtol, atol=atol)
    sol = solve_ivp(rhs, (t0, t1), sol.y[:, -1], method="DOP853", rtol=rtol,
                    atol=atol)
    y = sol.y[:, -1]
    m1 = y[2 * n:2 * n + n_e]
    m2 = y[2 * n + n_e:]
    statics = np.array([m[6] for m in meshes])
    return Integrated(np.sqrt(np.maximum(m2 - m1 * m1, 0.0)), statics + m1,
                      time.perf_counter() - start, count[0])


def hbm_state(problem, point) -> tuple[np.ndarray, np.ndarray]:
    """Coordinates and velocities of a periodic HBM solution at t = 0."""
    q = problem.recover(point)
    w0 = problem.harmonics.fundamental_rad_s(point.omega)
    k = np.asarray(problem.harmonics.indices, dtype=float)
    return q.sum(axis=1).real, (q * (1j * k * w0)[None, :]).sum(axis=1).real
