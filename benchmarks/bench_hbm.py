"""HBM benchmark: time per point and per curve against the number of harmonics and
the number of DOF, with the speed-up over time integration measured side by side.

Models: the SDOF scene (scenes/gear-pair-sdof.toml, 1 DOF) with 5-60 mesh
harmonics, and the coarse pump ROM (scenes/pump.toml) with n_CM = 50/100/200
fixed-interface modes (62-212 DOF, ROMs from the pipeline's stage cache; built
on first use) with 3 and 6 mesh harmonics plus the scene's sidebands.

* per point: Newton solve at one speed started from the solution at 0.99 x the
  speed (what a continuation step costs), median of repeats;
* per curve: ``hbm.trace`` over the scene's speed range with the scene's
  continuation settings (the pipeline's call), without and with stability (T.10);
* time integration: ``solve_ivp`` DOP853 (rtol 1e-7, all coupled modes, see
  benchmarks/bench_verify.py) from the orbit at 0.99 x the speed until the
  period-to-period change of the state is < 1e-5 — what one point of a time-integration sweep
  costs; the equal-accuracy comparison is in verify.json.

Run: ``.venv/bin/python -m benchmarks.bench_hbm [--quick]``.
Writes ``benchmarks/results/hbm.json`` (atomically). Serial, pure NumPy/SciPy.
"""
from __future__ import annotations

import argparse
import logging
import time
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks import bench_verify as bv
from benchmarks.common import median_time, peak_rss_mb, write_json

log = logging.getLogger("bench_hbm")


def sdof_problem(h: int):
    """HBM problem of the SDOF scene with ``h`` mesh harmonics."""
    import study
    from study.pipeline.model import scene_problem

    return scene_problem(study.load_scene(bv.SDOF_SCENE, {"hbm.mesh_harmonics": h}))[0], \
        study.load_scene(bv.SDOF_SCENE)


def pump_problem(n_cm: int, h: int, cache: Path, work: Path):
    """HBM problem of the coarse pump with ``n_cm`` modes and ``h`` mesh harmonics."""
    import study
    from study.pipeline import Pipeline

    scene = study.load_scene(bv.PUMP_SCENE, {"rom.n_cm": n_cm, "hbm.mesh_harmonics": h})
    pb, _ = Pipeline(scene, work / f"pump{n_cm}", cache_dir=cache, progress=False).problem()
    return pb, scene


def point_time(pb, rpm: float, repeats: int) -> dict[str, Any]:
    """Median Newton time at ``rpm`` from the solution at 0.99 rpm."""
    prev = pb.solve(0.99 * rpm, tol=1e-8)
    prev = pb.solve(0.99 * rpm, x0=prev.unknowns, tol=1e-8)
    t, pt = median_time(lambda: pb.solve(rpm, x0=prev.unknowns, tol=1e-8), repeats=repeats)
    return {"seconds": t, "iterations": pt.iterations, "point": pt, "prev": prev}


def curve_time(pb, scene, stability: bool) -> dict[str, Any]:
    """One ``hbm.trace`` over the scene's range with its continuation settings."""
    import hbm

    c = scene.continuation
    lo, hi = c.speed
    span = hi - lo
    t0 = time.perf_counter()
    br = hbm.trace(pb, lo, hi, step=c.step / span, min_step=c.min_step / span,
                   max_step=c.max_step / span, tol=c.tolerance, max_points=c.max_points,
                   stability=stability)
    dt = time.perf_counter() - t0
    return {"seconds": dt, "points": len(br), "per_point": dt / max(len(br), 1),
            "status": br.status}


def ti_point_time(pb, rpm: float, prev, repeats: int) -> dict[str, Any]:
    """Time integration from the orbit at 0.99 rpm to steady state at ``rpm``."""
    mm = bv.modal_model(pb, rpm)
    y0 = bv.initial_state(pb, prev, bv.modal_model(pb, prev.rpm))
    t, ss = median_time(lambda: bv.steady_state(mm, y0, rtol=1e-7, tol_periodic=1e-5,
                                                tol_state=1e-5, samples=256 * pb.steps[0]),
                        repeats=repeats, warmup=0)
    return {"seconds": t, "periods": ss.periods, "n_rhs": ss.n_rhs, "modes": mm.n_modes,
            "top_mode_hz": float(np.sqrt(mm.w2[-1]) / (2 * np.pi))}


def bench_model(label: str, pb, scene, rpm: float, repeats: int, curves: bool,
                stability: bool, ti: bool) -> dict[str, Any]:
    pt = point_time(pb, rpm, repeats)
    rec: dict[str, Any] = {"model": label, "dof": pb.system.n_dof,
                           "harmonic_indices": pb.harmonics.n_harmonics,
                           "max_index": pb.harmonics.max_index,
                           "n_time": pb.harmonics.n_time, "unknowns": pb.n_unknowns,
                           "rpm": rpm, "point_s": pt["seconds"],
                           "newton_iterations": pt["iterations"]}
    if curves:
        cv = curve_time(pb, scene, False)
        rec.update(curve_s=cv["seconds"], curve_points=cv["points"],
                   curve_per_point_s=cv["per_point"], curve_status=cv["status"])
        if stability:
            ch = curve_time(pb, scene, True)
            rec.update(curve_stability_s=ch["seconds"],
                       curve_stability_per_point_s=ch["per_point"])
    if ti:
        tr = ti_point_time(pb, rpm, pt["prev"], 1 if pb.system.n_dof > 1 else repeats)
        rec.update(ti_point_s=tr["seconds"], ti_periods=tr["periods"], ti_n_rhs=tr["n_rhs"],
                   top_mode_hz=tr["top_mode_hz"], speedup_point=tr["seconds"] / pt["seconds"])
    log.info("%s: %s", label, {k: v for k, v in rec.items() if k != "model"})
    return rec


def tables(recs: list[dict]) -> list[dict]:
    cols = ["model", "dof", "harmonic_indices", "unknowns", "n_time", "rpm", "point_s",
            "newton_iterations", "curve_points", "curve_s", "curve_per_point_s",
            "curve_stability_per_point_s", "ti_point_s", "ti_periods", "speedup_point"]
    sd = [r for r in recs if r["dof"] == 1]
    pu = [r for r in recs if r["dof"] > 1]

    def rows(rs):
        return [[r.get(c, "-") for c in cols] for r in rs]
    return [{"title": "SDOF scene: time per point and per curve against the harmonic count",
             "columns": cols, "rows": rows(sd)},
            {"title": "coarse pump ROM: time per point and per curve against DOF (n_CM) and "
                      "harmonics", "columns": cols, "rows": rows(pu)}]


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true",
                    help="SDOF 5-20 harmonics, pump n_CM 50/100 with 3 harmonics")
    ap.add_argument("--no-pump", action="store_true")
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--cache", type=Path, default=bv.DEFAULT_CACHE)
    ap.add_argument("--work", type=Path, default=Path("/tmp/geardyn-bench-hbm"))
    args = ap.parse_args(argv)
    if args.repeats < 1:
        raise ValueError(f"--repeats = {args.repeats}: must be >= 1")
    logging.basicConfig(level=logging.INFO, format="%(name)s: %(message)s")
    t0 = time.perf_counter()
    recs = []
    for h in ([5, 10, 20] if args.quick else [5, 10, 20, 40, 60]):
        pb, scene = sdof_problem(h)
        recs.append(bench_model(f"SDOF H={h}", pb, scene, 1650.0, args.repeats, True, True,
                                True))
    if not args.no_pump:
        n_cms = [50, 100] if args.quick else [50, 100, 200]
        hs = [3] if args.quick else [3, 6]
        for n_cm in n_cms:
            for h in hs:
                pb, scene = pump_problem(n_cm, h, args.cache, args.work)
                recs.append(bench_model(f"pump n_CM={n_cm} H={h}", pb, scene, 1200.0,
                                        args.repeats, True, h == 3 and n_cm == 100,
                                        h == hs[0]))
    sp = [r["speedup_point"] for r in recs if "speedup_point" in r]
    cmd = ".venv/bin/python -m benchmarks.bench_hbm" + (" --quick" if args.quick else "")
    summary = ("HBM (condensation 'loa') time per Newton point (from the 0.99 x speed "
               "solution, median) and per continuation curve (scene settings; without "
               "stability, and with it where a column is filled) against harmonics and DOF; "
               "time integration of the same point from the 0.99 x speed orbit (DOP853 rtol 1e-7 "
               "to a period-to-period state change < 1e-5, all coupled modes) measured in the "
               "same run. Timings on a shared 2-core machine under load: compare ratios.")
    if sp:
        summary += f" Speed-up per point: {min(sp):.0f}x to {max(sp):.0f}x."
    payload = {"command": cmd, "summary": summary, "tables": tables(recs), "records": recs,
               "seconds": time.perf_counter() - t0, "peak_rss_mb": peak_rss_mb()}
    path = write_json("hbm", payload)
    log.info("wrote %s", path)
    return payload


if __name__ == "__main__":
    main()
