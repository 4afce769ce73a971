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

3. ``--lumped`` (issue 40 item 1, seconds): exponent accuracy and verdicts near grazing on
   the SDOF gear pair (scenes/gear-pair-sdof.toml, 8 and 16 mesh harmonics), against our
   own time integration: Newton shooting on the integrated periodic orbit from the HBM
   state and a finite-difference monodromy of it (DOP853, rtol 1e-12, central
   differences), at the unstable, stable and flagged points of the branch around the fold
   at grazing (1791 rpm) and the fold at 1452 rpm: the largest real part on the HBM orbit
   (T.10) and on the integrated orbit, the transient amplification against the largest
   singular value of the finite-difference monodromy (energy norm), and whether the
   integration started on a "stable" point stays there.
   (On the pump the exponent's convergence in the step is checked by the slow test of
   tests/test_hbm_grazing_verdicts.py, docs/theory.md §11 "Exponent accuracy".)

Run: ``.venv/bin/python -m benchmarks.bench_stability [--periods 8]``, ``--lumped``.
Writes ``benchmarks/results/stability.json`` (``stability_lumped.json``).
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


def _energy(mm) -> np.ndarray:
    """Weights of the energy norm on the modal state (eta, eta')."""
    return np.concatenate([np.sqrt(mm.w2), np.ones(mm.n_modes)])


def fd_monodromy(problem, rpm: float, y0: np.ndarray, eps: float = 1e-8,
                 rtol: float = 1e-12) -> tuple[float, float, np.ndarray]:
    """Monodromy of the integrated equations about the state ``y0`` by central
    differences (DOP853): (largest real part 1/s, largest singular value in the energy
    norm, the matrix)."""
    mm = modal_model(problem, rpm)
    fun, w = equations(mm), _energy(mm)
    scale = np.linalg.norm(y0 * w)
    cols = []
    for j in range(y0.size):
        d = np.zeros(y0.size)
        d[j] = eps * scale / w[j]
        ends = [solve_ivp(fun, (0.0, mm.period), y0 + s * d, method="DOP853", rtol=rtol,
                          atol=1e-15 * scale / w).y[:, -1] for s in (1, -1)]
        cols.append((ends[0] - ends[1]) / (2 * d[j]))
    phi = np.array(cols).T
    lam = float(np.log(np.max(np.abs(np.linalg.eigvals(phi)))) / mm.period)
    sv = float(np.linalg.svd(w[:, None] * phi / w[None, :], compute_uv=False)[0])
    return lam, sv, phi


def shooting_orbit(problem, point, tol: float = 1e-12, iters: int = 20
                   ) -> tuple[np.ndarray, float, float]:
    """The integrated periodic orbit nearest the HBM state: Newton on ``y(T) - y(0)`` with
    the finite-difference monodromy. Returns (state at t = 0, relative periodicity
    residual, relative distance from the HBM state), energy norm."""
    mm = modal_model(problem, point.rpm)
    fun, w = equations(mm), _energy(mm)
    y0 = initial_state(problem, point, mm)
    scale = np.linalg.norm(y0 * w)
    y, res = y0.copy(), np.inf
    for _ in range(iters):
        yt = solve_ivp(fun, (0.0, mm.period), y, method="DOP853", rtol=1e-12,
                       atol=1e-15 * scale / w).y[:, -1]
        res = float(np.linalg.norm((yt - y) * w) / scale)
        if res < tol:
            break
        _, _, phi = fd_monodromy(problem, point.rpm, y)
        y = y - np.linalg.solve(phi - np.eye(y.size), yt - y)
    return y, res, float(np.linalg.norm((y - y0) * w) / scale)


def stays(problem, point, periods: int = 40) -> float:
    """Relative distance (energy norm) from the HBM state after ``periods`` periods of the
    integration started on it."""
    mm = modal_model(problem, point.rpm)
    fun, w = equations(mm), _energy(mm)
    y0 = initial_state(problem, point, mm)
    scale = np.linalg.norm(y0 * w)
    y = solve_ivp(fun, (0.0, periods * mm.period), y0, method="DOP853", rtol=1e-10,
                  atol=1e-14 * scale / w).y[:, -1]
    return float(np.linalg.norm((y - y0) * w) / scale)


def lumped(harmonics: tuple[int, ...] = (8, 16)) -> dict:
    """Exponent accuracy and verdicts near grazing on the SDOF gear pair (module doc, 3)."""
    import hbm
    import study
    from benchmarks.bench_verify import SDOF_SCENE
    from study.pipeline.model import scene_problem

    rows, summary = [], []
    for h in harmonics:
        pb, _ = scene_problem(study.load_scene(SDOF_SCENE, {"hbm.mesh_harmonics": h}))
        t0 = time.perf_counter()
        br = hbm.trace(pb, 1300.0, 2300.0, stability=True, stability_process=False, tol=1e-10)
        t_trace = time.perf_counter() - t0
        mesh = br.element(0)
        near_fold = ((br.rpm > 1790.5) & (br.rpm < 1796.0)) | \
            ((br.rpm > 1450.0) & (br.rpm < 1453.0))
        picks = np.flatnonzero(near_fold | br.stability_grazing)
        left = flagged_left = 0
        for i in picks:
            pt = pb.point(br.unknowns[i], br.omega[i])
            y, res, dist = shooting_orbit(pb, pt)
            lam_ti, sv_ti, _ = fd_monodromy(pb, pt.rpm, y)
            _, sv_hbm_state, _ = fd_monodromy(pb, pt.rpm, initial_state(
                pb, pt, modal_model(pb, pt.rpm)))
            away = stays(pb, pt) if br.stable[i] else float("nan")
            if br.stable[i] and away > 0.1:
                left += 1
                flagged_left += int(br.stability_grazing[i])
            rows.append([h, float(br.rpm[i]), bool(br.stable[i]),
                         bool(br.stability_grazing[i]), float(br.floquet_max_real[i]),
                         lam_ti, dist, res, float(br.floquet_amplification[i]),
                         sv_hbm_state, away,
                         float(min(abs(mesh.margin_active[i]), abs(mesh.margin_reverse[i])))])
            logger.info("H=%d %.4f rpm %s%s: T.10 %.2f, integrated orbit %.2f 1/s (%.2g away, "
                        "residual %.1g); amplification %.3g, FD %.3g; TI from the point: %s",
                        h, br.rpm[i], "stable" if br.stable[i] else "unstable",
                        " [near grazing]" if br.stability_grazing[i] else "",
                        br.floquet_max_real[i], lam_ti, dist, res,
                        br.floquet_amplification[i], sv_hbm_state, away)
        summary.append({"mesh_harmonics": h, "points": len(br), "trace_s": t_trace,
                        "flagged": int(np.sum(br.stability_grazing)),
                        "stable_points_the_integration_leaves": left,
                        "of_them_flagged": flagged_left})
    return {"command": ".venv/bin/python -m benchmarks.bench_stability --lumped",
            "summary": "SDOF gear pair, 1300-2300 rpm: "
                       + "; ".join(f"{s['mesh_harmonics']} harmonics: {s['points']} points, "
                                   f"{s['flagged']} flagged near grazing, "
                                   f"{s['stable_points_the_integration_leaves']} 'stable' "
                                   f"points the integration leaves, "
                                   f"{s['of_them_flagged']} of them flagged"
                                   for s in summary),
            "cases": summary,
            "tables": [{"title": "largest real part (1/s) and transient amplification: HBM "
                                 "orbit (T.10) against the integrated orbit's "
                                 "finite-difference monodromy",
                        "columns": ["H", "rpm", "stable", "near grazing", "T.10 HBM orbit",
                                    "FD monodromy TI orbit", "TI orbit distance",
                                    "shooting residual", "amplification",
                                    "FD sigma_max at HBM state", "TI leaves (stable pts)",
                                    "closest margin m"],
                        "rows": rows}]}


def main(argv: list[str] | None = None) -> dict:
    import hbm
    import study
    from hbm.stability import KINDS, stability
    from study.pipeline import Pipeline

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--periods", type=int, default=8)
    ap.add_argument("--work", type=Path, default=ROOT / ".cache" / "bench-stability")
    ap.add_argument("--lumped", action="store_true", help="the SDOF part only (seconds)")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    if args.lumped:
        payload = lumped()
        write_json("stability_lumped", payload)
        return payload
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
                       # the T.9 root is put first when one was located (not when NaN)
                       "variational_max_real": float(s.exponents[0].real)
                       if s.consistent or np.isnan(s.max_real)
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
