"""Torus (multi-frequency) HBM against the one-dimensional HBM over the common period and
against time integration: unknowns, AFT samples, time per point, agreement (docs/hbm.md,
"Several base frequencies"; issue 36 item 3).

Models (:class:`hbm.examples.TwoStage`, lumped torsional two-stage reducer):

* ``short``: 20:30 then 15:45 (mesh frequencies 20 and 10 Omega, common period one mesh-2
  period) at 3000 rpm (permanent contact) and 3631 rpm (mesh 2 loses contact 13 % of the
  time): periodic sets of 40/160 harmonics of 10 Omega against tori of 12/20 harmonics per
  mesh; the time integration over 10 common periods after 20.
* ``hunting``: 23:61 then 19:67 with torque ripples at input and output shaft order 1
  (common period 4087 input turns, 94001 mesh-1 periods) at 2500 rpm: the torus of the two
  meshes and the two shafts (6 harmonics per mesh, sideband order 1; on the default grid
  and on the coarse one that suffices in permanent contact) against the same
  harmonics as a sparse periodic set over the hunting period (AFT of 2**21 samples, the
  smallest power of two above twice the largest index) and against the time integration
  (bump-weighted average over four output turns).
* ``mesh-only``: 23:61 then 19:67 without shaft ripples (common period 61 mesh-1 periods):
  the torus of the two meshes against the contiguous periodic set over 61 mesh-1 periods.

Time per point: median Newton solve at the speed from the solution at 0.99 x the speed.
Run: ``.venv/bin/python -m benchmarks.bench_torus [--quick]``; writes
``benchmarks/results/torus.json``. The time integration is the tests' own
(tests/hbm_train_models.py), independent of hbm's AFT.
"""
from __future__ import annotations

import argparse
import logging
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

import hbm
from benchmarks.common import median_time, peak_rss_mb, write_json
from hbm.examples import TwoStage
from hbm.post.torus import line_state, line_statistics, torus_statistics
from hbm.torus import train_basis

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from hbm_train_models import integrate  # noqa: E402  (the tests' own integrator)

log = logging.getLogger("bench_torus")


def _point(pb, rpm: float, repeats: int) -> tuple[float, Any]:
    prev = pb.solve(0.99 * rpm)
    return median_time(lambda: pb.solve(rpm, x0=prev.unknowns), repeats=repeats, warmup=0)


def _row(kind: str, pb, seconds: float, std, extra: dict | None = None) -> dict[str, Any]:
    hs = pb.harmonics
    samples = hs.n_time if hs.periodic else hs.n_samples
    row = {"method": kind, "harmonics": hs.n_harmonics, "unknowns": pb.n_unknowns,
           "aft_samples": int(samples), "point_s": seconds,
           "mesh_load_std": [float(v) for v in std]}
    row.update(extra or {})
    log.info("%-34s %5d harmonics %6d unknowns %9d samples %8.3f s  std %s", kind,
             row["harmonics"], row["unknowns"], row["aft_samples"], seconds,
             ", ".join(f"{v:.10g}" for v in std))
    return row


def short_model(repeats: int) -> list[dict[str, Any]]:
    model = TwoStage(te=(8e-6, 8e-6))
    r1, r2 = model.mesh_ratios
    r0 = hbm.common_fundamental(r1, r2)
    rows = []
    for rpm in (3000.0, 3631.0):
        for h in (40, 160):
            pb = model.problem(hbm.HarmonicSet(range(h + 1), ratio=r0))
            t, pt = _point(pb, rpm, repeats)
            std = [s.mesh_load_std for s in hbm.point_stats(pb, pt, n_time=8192)]
            rows.append(_row(f"short {rpm:.0f} rpm periodic H={h}", pb, t, std,
                             {"rpm": rpm}))
        ref = np.array(rows[-1]["mesh_load_std"])
        q = pb.recover(pt)
        w = pb.kS * pb.harmonics.rate * pt.omega
        period = 2 * np.pi / (pb.harmonics.rate * pt.omega)
        ti = integrate(model, rpm, q.sum(axis=1).real, (q * (1j * w)).sum(axis=1).real,
                       20 * period, 10 * period)
        rows.append({"method": f"short {rpm:.0f} rpm time integration", "point_s": ti.seconds,
                     "n_rhs": ti.n_rhs, "mesh_load_std": ti.std.tolist(),
                     "relative_to_periodic": (ti.std / ref - 1.0).tolist(), "rpm": rpm})
        log.info("time integration %.2f s (%d rhs): %s", ti.seconds, ti.n_rhs,
                 (ti.std / ref - 1.0))
        for k in (12, 20):
            pb = model.problem(train_basis({"mesh 1": r1, "mesh 2": r2}, k))
            t, pt = _point(pb, rpm, max(1, repeats // 2))
            std = [s["mesh_load_std"] for s in line_statistics(pb, pt, 2048)]
            erg = [s["mesh_load_std"] for s in torus_statistics(pb, pt)]
            rows.append(_row(f"short {rpm:.0f} rpm torus K={k}", pb, t, std, {
                "rpm": rpm, "grid": list(pb.harmonics.grid), "torus_std": erg,
                "relative_to_periodic": (np.array(std) / ref - 1.0).tolist()}))
    return rows


def hunting_model(repeats: int, quick: bool) -> list[dict[str, Any]]:
    model = TwoStage(teeth=(23, 61, 19, 67), te=(4e-6, 4e-6),
                     shaft_forcing=((0, 1, 5.0), (2, 1, 50.0)))
    r1, r2 = model.mesh_ratios
    s = model.speeds
    rpm = 2500.0
    rows = []
    for grid in (None, (32, 32, 8, 8)):
        tb = train_basis({"mesh 1": r1, "mesh 2": r2}, 6,
                         shafts={"input": (s[0], (1,)), "output": (s[2], (1,))}, grid=grid)
        tic = time.perf_counter()
        pb = model.problem(tb)
        setup = time.perf_counter() - tic
        t, pt = _point(pb, rpm, repeats)
        tic = time.perf_counter()
        std = [v["mesh_load_std"] for v in torus_statistics(pb, pt)]
        stats = time.perf_counter() - tic
        rows.append(_row(f"hunting torus K=6 (4 bases) {tb.grid}", pb, t, std,
                         {"rpm": rpm, "grid": list(tb.grid), "setup_s": setup,
                          "statistics_s": stats}))
    ref = np.array(std)
    th0, om0 = line_state(pb, pt, 0.0)
    turn = 2 * np.pi / (float(s[2]) * pt.omega)
    ti = integrate(model, rpm, th0[:, 0], om0[:, 0], 0.02, (2 if quick else 4) * turn,
                   weight="bump")
    rows.append({"method": "hunting time integration", "point_s": ti.seconds,
                 "n_rhs": ti.n_rhs, "mesh_load_std": ti.std.tolist(),
                 "output_turns": 2 if quick else 4,
                 "relative_to_torus": (ti.std / ref - 1.0).tolist()})
    log.info("time integration %.2f s (%d rhs): %s", ti.seconds, ti.n_rhs, ti.std / ref - 1)
    if not quick:
        rss0 = peak_rss_mb()
        tic = time.perf_counter()
        p1 = model.problem(tb.line_set(n_time=2 ** 21))
        setup = time.perf_counter() - tic
        t1, pt1 = _point(p1, rpm, 1)
        tic = time.perf_counter()
        std1 = [v.mesh_load_std for v in hbm.point_stats(p1, pt1, n_time=2 ** 21)]
        stats = time.perf_counter() - tic
        rows.append(_row("hunting periodic over 4087 turns", p1, t1, std1, {
            "rpm": rpm, "peak_rss_mb": peak_rss_mb(), "peak_rss_before_mb": rss0,
            "setup_s": setup, "statistics_s": stats,
            "relative_to_torus": (np.array(std1) / ref - 1.0).tolist()}))
    return rows


def mesh_only_model(repeats: int) -> list[dict[str, Any]]:
    model = TwoStage(teeth=(23, 61, 19, 67), te=(4e-6, 4e-6))
    r1, r2 = model.mesh_ratios
    rpm = 2500.0
    rows = []
    tb = train_basis({"mesh 1": r1, "mesh 2": r2}, 6)
    pb = model.problem(tb)
    t, pt = _point(pb, rpm, repeats)
    std = [v["mesh_load_std"] for v in line_statistics(pb, pt)]
    rows.append(_row("mesh-only torus K=6", pb, t, std, {"rpm": rpm, "grid": list(tb.grid)}))
    ref = np.array(std)
    sparse = tb.line_set()
    for hs in (sparse, hbm.HarmonicSet(range(sparse.max_index + 1), ratio=tb.ratio)):
        p1 = model.problem(hs)
        t1, pt1 = _point(p1, rpm, repeats)
        std1 = [v.mesh_load_std for v in hbm.point_stats(p1, pt1)]
        kind = "sparse" if len(hs.indices) < hs.max_index + 1 else "contiguous"
        rows.append(_row(f"mesh-only periodic {kind} over 61 periods", p1, t1, std1, {
            "rpm": rpm, "relative_to_torus": (np.array(std1) / ref - 1.0).tolist()}))
    return rows


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="fewer repeats, no hunting 1-D run")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    repeats = 1 if args.quick else 3
    rows = short_model(repeats) + mesh_only_model(repeats) + hunting_model(repeats, args.quick)
    path = write_json("torus", {"rows": rows, "peak_rss_mb": peak_rss_mb()})
    log.info("wrote %s", path)


if __name__ == "__main__":
    main()
