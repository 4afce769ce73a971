"""The FE gearbox's ROM as an HBM problem over the hunting period, and the same ROM's
equations integrated in time from the HBM orbit (tests of issue 36 item 5b; not
collected by pytest)."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
from scipy.integrate import quad, solve_ivp

import hbm
from hbm.post.time_response import equations, initial_state, modal_model, state_atol

_BUMP_MASS = quad(lambda s: math.exp(-1.0 / (s * (1.0 - s))), 0.0, 1.0,
                  epsabs=1e-15, epsrel=1e-14)[0]


def problem(machine, rom, mesh_harmonics: int, variation: float, te: tuple,
            backlash: float = 40e-6) -> hbm.HBMProblem:
    """One dead-zone mesh per machine mesh on the ROM (k̄ (1 + a cos), TE te_e cos, phases
    of the layout) on the one-dimensional set over the hunting period."""
    lm = machine.linear_model(rom)
    layout = machine.layout
    km = machine.mean_mesh_stiffness()
    elements = [hbm.GearMesh(direction=lm.G[:, e], n_teeth=m.teeth,
                             stiffness={0: km[e], 1: km[e] * variation}, te={1: te[e]},
                             backlash=backlash, speed_ratio=m.speed_ratio, name=m.name,
                             phase=layout.meshes[e].phase)
               for e, m in enumerate(machine.gear_meshes)]
    r = layout.hunting_fundamental()
    hs = hbm.HarmonicSet(layout.periodic_indices(mesh_harmonics), ratio=r)
    ex = hbm.Excitation(lm.n_dof, constant={0: lm.constant[0].real})
    return hbm.HBMProblem(hbm.LinearSystem(lm.M, lm.C, lm.K), elements, ex, hs)


def hbm_window_std(pb: hbm.HBMProblem, point, t0: float, window: float,
                   samples: int) -> np.ndarray:
    """Bump-weighted mesh-load std of the HBM orbit over ``[t0, t0 + window]``."""
    hs = pb.harmonics
    dc = hs.to_complex(pb.delta_real(point.unknowns))
    w = pb.kS * hs.rate * point.omega
    t = t0 + (np.arange(samples) + 0.5) * window / samples
    wt = _bump(t, t0, window) * window / samples
    d = (dc @ np.exp(1j * np.outer(w, t))).real
    out = []
    for e, el in enumerate(pb.elements):
        f = el.load(d[e], el.sample(float(el.base_ratio) * point.omega * t))
        mean = wt @ f
        out.append(math.sqrt(max(wt @ (f * f) - mean * mean, 0.0)))
    return np.array(out)


def _bump(t: np.ndarray, t0: float, window: float) -> np.ndarray:
    s = (np.asarray(t) - t0) / window
    w = np.zeros_like(s)
    inside = (s > 0.0) & (s < 1.0)
    si = s[inside]
    w[inside] = np.exp(-1.0 / (si * (1.0 - si))) / (_BUMP_MASS * window)
    return w


@dataclass
class Integrated:
    std: np.ndarray
    seconds: float
    n_rhs: int
    contact_loss: np.ndarray


def integrate_window(pb: hbm.HBMProblem, point, rpm: float, t0: float, window: float,
                     rtol: float = 1e-9) -> Integrated:
    """The ROM's equations (every mode, :func:`hbm.post.time_response.equations`)
    integrated by DOP853 from the HBM orbit at t = 0; the bump-weighted mean and mean
    square of each mesh load over ``[t0, t0 + window]`` integrated as extra states."""
    mm = modal_model(pb, rpm)
    fun = equations(mm)
    m = mm.n_modes
    E = len(pb.elements)
    forces = [el.time_force() for el in pb.elements]
    counter = [0]
    loss = np.zeros(E)

    def rhs(t, y, averaging):
        counter[0] += 1
        dy = fun(t, y[:2 * m])
        out = np.zeros(2 * E + E)
        if averaging:
            w = _bump(np.array([t]), t0, window)[0]
            eta = y[:m]
            for e in range(E):
                f = forces[e](mm.gamma[e] @ eta, mm.rates[e] * t)
                out[2 * e] = w * f
                out[2 * e + 1] = w * f * f
                out[2 * E + e] = w * (f == 0.0)
        return np.concatenate([dy, out])

    y0 = initial_state(pb, point, mm)
    atol = state_atol(mm, y0, rtol)
    tic = time.perf_counter()
    y = np.concatenate([y0, np.zeros(3 * E)])
    sol = solve_ivp(rhs, (0.0, t0), y, method="DOP853", rtol=rtol,
                    atol=np.concatenate([atol, np.ones(3 * E)]), args=(False,))
    y = sol.y[:, -1]
    sol = solve_ivp(rhs, (t0, t0 + window), y, method="DOP853", rtol=rtol,
                    atol=np.concatenate([atol, np.full(3 * E, 1e-3)]) , args=(True,))
    y = sol.y[:, -1]
    acc = y[2 * m:]
    mean, sq = acc[0:2 * E:2], acc[1:2 * E:2]
    loss = acc[2 * E:]
    return Integrated(np.sqrt(np.maximum(sq - mean ** 2, 0.0)), time.perf_counter() - tic,
                      counter[0], loss)
