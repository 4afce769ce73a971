"""HBM benchmark: time per Newton solve, per continuation point and per curve
against the number of harmonics and DOF, and the speed-up over time integration.

Run: ``.venv/bin/python -m benchmarks.bench_hbm [--quick]``.
Writes ``benchmarks/results/hbm.json`` (atomically). Serial, pure NumPy/SciPy.
"""

from __future__ import annotations

import argparse
import logging
import time

import numpy as np
import scipy.linalg as sla
from scipy.integrate import solve_ivp

import hbm
from benchmarks.common import median_time, write_json

log = logging.getLogger("bench_hbm")
RPM = hbm.RPM_TO_RAD_S


def sdof(harmonics: int, fa: float = 0.05, b: float = 1.0) -> hbm.HBMProblem:
    """Kahraman-Singh pair x'' + 0.1 x' + (1 + 0.2 cos w t) f(x) = 0.1 + fa cos w t."""
    system = hbm.LinearSystem([[1.0]], [[0.1]], [[0.0]], [1.0])
    mesh = hbm.GearMesh(1, {0: 1.0, 1: 0.2}, backlash=b)
    exc = hbm.Excitation(1, constant={0: [0.1], 1: [fa]})
    return hbm.HBMProblem(system, mesh, exc, hbm.HarmonicSet.build(1, harmonics))


def multi_dof(n: int, harmonics: int, condensation: str) -> hbm.HBMProblem:
    """Random n-DOF model with the modal damping of eq. (17)-(19), one mesh."""
    rng = np.random.default_rng(0)
    a = rng.standard_normal((n, n))
    m = a @ a.T / n + np.eye(n)
    bb = rng.standard_normal((n, n))
    k = 1e3 * (bb @ bb.T / n + 0.1 * np.eye(n))
    g = np.zeros(n)
    g[: min(12, n)] = rng.standard_normal(min(12, n))
    g /= np.linalg.norm(g)
    w2, phi = sla.eigh(k + 2e3 * np.outer(g, g), m)
    c = m @ phi @ np.diag(0.1 * np.sqrt(w2)) @ phi.T @ m
    mesh = hbm.GearMesh(5, {0: 2e3, 1: 300}, te={1: 1e-2j}, backlash=5e-3)
    exc = hbm.Excitation(n, constant={0: 10 * g})
    return hbm.HBMProblem(hbm.LinearSystem(m, c, k, g), mesh, exc,
                          hbm.HarmonicSet.build(5, harmonics), condensation)


def newton_solve_time(pb: hbm.HBMProblem, rpm: float) -> dict:
    near = pb.solve(rpm * 0.99)
    t, pt = median_time(lambda: pb.solve(rpm, x0=near.unknowns), repeats=20)
    return {"seconds": t, "iterations": pt.iterations, "unknowns": pb.n_unknowns}


def curve_time(pb: hbm.HBMProblem, lo: float, hi: float, stability: bool) -> dict:
    t0 = time.perf_counter()
    br = hbm.trace(pb, lo, hi, stability=stability)
    dt = time.perf_counter() - t0
    return {"seconds": dt, "points": len(br), "per_point": dt / max(len(br), 1),
            "status": br.status}


def time_integration(pb: hbm.HBMProblem, omega: float, rtol: float) -> dict:
    """DOP853 from rest to steady state (|period-to-period change| < 1e-6)."""
    T = 2 * np.pi / omega

    def rhs(t, y):
        x, v = y
        k = 1 + 0.2 * np.cos(omega * t)
        f = k * ((x - 1) if x > 1 else (x + 1) if x < -1 else 0.0)
        return [v, 0.1 + 0.05 * np.cos(omega * t) - 0.1 * v - f]

    t0 = time.perf_counter()
    y = np.array([1.1, 0.0])
    periods = 0
    while periods < 2000:
        y1 = solve_ivp(rhs, (0, 10 * T), y, method="DOP853", rtol=rtol, atol=1e-12).y[:, -1]
        periods += 10
        done = np.max(np.abs(y1 - y)) < 1e-6
        y = y1
        if done:
            break
    return {"seconds": time.perf_counter() - t0, "periods": periods}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    harmonics = [10, 20] if args.quick else [10, 20, 40, 80]
    out: dict = {"sdof_newton": {}, "sdof_curve": {}, "multi_dof": {}}
    for h in harmonics:
        pb = sdof(h)
        out["sdof_newton"][h] = newton_solve_time(pb, 0.9 / RPM)
        out["sdof_curve"][h] = {
            "no_stability": curve_time(pb, 0.3 / RPM, 1.6 / RPM, False),
            "hill": curve_time(pb, 0.3 / RPM, 1.6 / RPM, True)}
        log.info("SDOF H=%d: Newton %.3g ms, curve %s", h,
                 1e3 * out["sdof_newton"][h]["seconds"], out["sdof_curve"][h])
    for n in ([6, 20] if args.quick else [6, 20, 60]):
        out["multi_dof"][n] = {}
        for cond in ("loa", "gear", "none"):
            if cond == "none" and n > 20:
                continue
            pb = multi_dof(n, 8, cond)
            out["multi_dof"][n][cond] = newton_solve_time(pb, 60.0)
            log.info("n=%d %s: %.3g ms", n, cond, 1e3 * out["multi_dof"][n][cond]["seconds"])
    pb = sdof(20)
    hb = out["sdof_newton"][20]["seconds"] if 20 in out["sdof_newton"] else None
    ti = time_integration(pb, 0.9, 1e-8)
    out["time_integration"] = ti
    if hb:
        out["speedup_newton_vs_time_integration"] = ti["seconds"] / hb
    log.info("time integration to steady state: %s", ti)
    print(write_json("hbm", out))


if __name__ == "__main__":
    main()
