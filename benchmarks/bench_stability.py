"""Stability on the coarse pump: cost per point, and the verdicts against time integration.

1. The shipped pump curve is traced without stability (Newton cost per point), then
   the stability of every point is computed in branch order as the continuation
   does (:func:`hbm.stability.stability`, warm-started): ms/point of each, and the
   ratio. The mode-truncated Hill of earlier versions (``method="hill"``, 4 of 112
   modes at ``max_size`` 400) is timed on a sample of the same points.
2. At four speeds — 1084 rpm (where the truncated Hill said unstable), the middle of
   a speed-decreasing segment between two folds, the largest mesh load and one
   permanent-contact point — the ROM is integrated in time (DOP853, modal form of
   benchmarks.bench_verify) from the HBM state, one period at a time. The
   period-to-period change of the state decays (stable) or grows (unstable) by the
   leading multiplier: its slope in log over the last periods, divided by the
   period, is the measured largest real part, compared with the Floquet exponent.
   A period-doubling point is added when the branch has one.

Run: ``.venv/bin/python -m benchmarks.bench_stability [--periods 8]``. Writes
``benchmarks/results/stability.json``.
"""
from __future__ import annotations

import argparse
import logging
import time
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

from benchmarks.bench_verify import PUMP_SCENE, _state_norm, steady_state
from benchmarks.common import machine, write_json
from hbm.post.time_response import equations, initial_state, modal_model, state_atol

logger = logging.getLogger("bench_stability")
ROOT = Path(__file__).resolve().parents[1]


def measured_rate(problem, point, periods: int, rtol: float = 1e-10) -> dict:
    """Largest real part (1/s) seen by time integration from the HBM state."""
    mm = modal_model(problem, point.rpm)
    y = initial_state(problem, point, mm)
    fun = equations(mm)
    T = mm.period
    atol = state_atol(mm, y, rtol)
    norm0 = np.linalg.norm(_state_norm(mm, y))
    changes = []
    t0 = time.perf_counter()
    for _ in range(periods):
        sol = solve_ivp(fun, (0.0, T), y, method="DOP853", rtol=rtol, atol=atol)
        if not sol.success:
            raise RuntimeError(sol.message)
        yn = sol.y[:, -1]
        changes.append(float(np.linalg.norm(_state_norm(mm, yn - y)) / norm0))
        y = yn
    # the linear regime: after the first period (the HBM error decays through every
    # mode), above the integration noise (~1e3 rtol); a growing sequence is kept whole
    ch = np.array(changes)
    k = np.flatnonzero((np.arange(ch.size) >= 1) & (ch > 1e3 * rtol))
    if k.size < 2:
        k = np.arange(min(2, ch.size))
    slope = np.polyfit(k, np.log(ch[k]), 1)[0]
    return {"changes": changes, "rate": float(slope / T), "fit_periods": k.tolist(),
            "seconds": time.perf_counter() - t0}


def orbit_exponent(problem, point, n_steps: int | None = None) -> dict:
    """Largest real part (1/s) of (T.10) along the orbit the ROM settles on in time,
    from the HBM state (DOP853 to a periodic state), and how far that orbit is from
    the HBM one (max |gap difference| / half peak-to-peak of the HBM gap)."""
    from hbm.stability.monodromy import exponents_along, orbit_deltas

    n = int(n_steps or problem.harmonics.n_time)
    mm = modal_model(problem, point.rpm)
    ss = steady_state(mm, initial_state(problem, point, mm), rtol=1e-9, tol_periodic=1e-7,
                      max_periods=200, samples=n)
    _, samples = problem.fine_grid(n)
    e = samples[0].e
    gap = ss.delta - e
    hbm_gap = orbit_deltas(problem, point.unknowns, n)[0] - e
    lam = exponents_along(problem, ss.delta, mm.period)
    return {"max_real": float(lam[0].real), "periods": ss.periods,
            "orbit_difference": float(np.max(np.abs(gap - hbm_gap)) / (0.5 * np.ptp(hbm_gap)))}


def main(argv: list[str] | None = None) -> dict:
    import hbm
    import study
    from hbm.stability import KINDS, stability
    from study.pipeline import Pipeline

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--periods", type=int, default=8)
    ap.add_argument("--work", type=Path, default=ROOT / ".cache" / "bench-stability")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    scene = study.load_scene(PUMP_SCENE)
    pl = Pipeline(scene, args.work, progress=False)
    problem, _ = pl.problem()
    c = scene.continuation
    span = c.speed[1] - c.speed[0]
    t0 = time.perf_counter()
    br = hbm.trace(problem, c.speed[0], c.speed[1], step=c.step / span,
                   min_step=c.min_step / span, max_step=c.max_step / span, tol=c.tolerance,
                   max_points=c.max_points, stability=False)
    t_newton = time.perf_counter() - t0
    logger.info("curve without stability: %d points, %.1f s", len(br), t_newton)
    pts = [problem.point(br.unknowns[i], br.omega[i]) for i in range(len(br))]
    t0 = time.perf_counter()
    basis, stab = None, []
    for p in pts:
        s = stability(problem, p, start=basis)
        basis = s.basis
        stab.append(s)
    t_stab = time.perf_counter() - t0
    sample = pts[:: max(1, len(pts) // 20)]
    t0 = time.perf_counter()
    for p in sample:
        hbm.floquet_exponents(problem, p, 400, method="hill")
    t_hill = (time.perf_counter() - t0) / len(sample)
    max_real = np.array([s.max_real for s in stab])
    kinds = np.array([s.code for s in stab])
    consistent = np.array([s.consistent for s in stab])
    logger.info("stability: %.1f ms/point (Newton %.1f ms/point), truncated Hill %.1f ms/point",
                1e3 * t_stab / len(pts), 1e3 * t_newton / len(pts), 1e3 * t_hill)

    d = np.diff(br.rpm)
    down = np.flatnonzero(np.r_[False, (d[:-1] < 0) & (d[1:] < 0), False])
    picks = {"1084 rpm": int(np.argmin(np.abs(br.rpm - 1084.0))),
             "between two folds": int(down[0]) if down.size else None,
             "largest mesh load": int(np.argmax(br.element(0).mesh_load_std)),
             "permanent contact": int(np.flatnonzero(br.element(0).contact == 0)[-1])
             if np.any(br.element(0).contact == 0) else None}
    pd = np.flatnonzero(kinds == KINDS.index("period_doubling"))
    if pd.size:
        picks["period doubling"] = int(pd[0])
    checks = []
    for label, i in picks.items():
        if i is None:
            continue
        meas = measured_rate(problem, pts[i], args.periods)
        along = orbit_exponent(problem, pts[i])
        s = stab[i]
        checks.append({"case": label, "rpm": float(br.rpm[i]),
                       "contact": int(br.element(0).contact[i]),
                       "floquet_max_real": s.max_real, "kind": s.kind,
                       "fold_parity": s.fold_parity, "consistent": s.consistent,
                       "variational_max_real": float(s.exponents[0].real) if s.consistent
                       else float(s.exponents[1].real),
                       "time_integration_rate": meas["rate"], "changes": meas["changes"],
                       "ti_orbit_max_real": along["max_real"],
                       "ti_orbit_vs_hbm_orbit": along["orbit_difference"],
                       "ti_seconds": meas["seconds"]})
        logger.info("%s %.1f rpm: exponent %.3f (%s, consistent %s); time integration: decay "
                    "%.3f 1/s, exponent along its orbit %.3f 1/s (orbits differ by %.2g)",
                    label, br.rpm[i], s.max_real, s.kind, s.consistent, meas["rate"],
                    along["max_real"], along["orbit_difference"])
    payload = {"machine": machine(), "points": len(br),
               "newton_ms_per_point": 1e3 * t_newton / len(pts),
               "stability_ms_per_point": 1e3 * t_stab / len(pts),
               "stability_over_newton": t_stab / t_newton,
               "truncated_hill_ms_per_point": 1e3 * t_hill,
               "curve_newton_s": t_newton, "curve_stability_s": t_stab,
               "unstable": int(np.sum(max_real > 0)),
               "unresolved": int(np.sum(~consistent)),
               "kinds": {k: int(np.sum(kinds == j)) for j, k in enumerate(KINDS)},
               "checks": checks}
    payload["command"] = ".venv/bin/python -m benchmarks.bench_stability --periods " \
        f"{args.periods}"
    payload["summary"] = (
        f"Coarse pump, shipped harmonic set, {len(br)} points: Newton "
        f"{payload['newton_ms_per_point']:.1f} ms/point, stability (T.10, every mode) "
        f"{payload['stability_ms_per_point']:.0f} ms/point "
        f"({payload['stability_over_newton']:.1f}x), the former mode-truncated Hill "
        f"{payload['truncated_hill_ms_per_point']:.0f} ms/point; {payload['unresolved']} points "
        "between folds of the HBM branch where the variational equation finds the orbit "
        "stable (harmonic set not converged). Averages over the curve, one run.")
    payload["tables"] = [
        {"title": "cost per point (average over the curve)",
         "columns": ["Newton ms", "stability ms", "ratio", "truncated Hill ms",
                     "curve without stability s", "stability of the curve s"],
         "rows": [[payload["newton_ms_per_point"], payload["stability_ms_per_point"],
                   payload["stability_over_newton"], payload["truncated_hill_ms_per_point"],
                   payload["curve_newton_s"], payload["curve_stability_s"]]]},
        {"title": "largest real part (1/s): HBM orbit, time integration",
         "columns": ["case", "rpm", "verdict", "T.9 parity", "consistent",
                     "T.10 on HBM orbit", "decay seen in time", "T.10 on settled orbit",
                     "orbit difference"],
         "rows": [[c["case"], c["rpm"], c["kind"], c["fold_parity"], c["consistent"],
                   c["variational_max_real"], c["time_integration_rate"],
                   c["ti_orbit_max_real"], c["ti_orbit_vs_hbm_orbit"]] for c in checks]}]
    write_json("stability", payload)
    return payload


if __name__ == "__main__":
    main()
