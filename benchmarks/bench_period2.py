"""What a point of a period-2 branch costs against a point of its period-1 parent of the
same harmonic reach (docs/hbm.md "Period doubling"; issue 40 items 2 and 5).

Model: the Kahraman-Singh pair of tests/hbm_models.py (``fa = 0.1``, ``b = 0.2``; one
tooth, w_n = 1 rad/s), whose branch over 0.45-0.62 rad/s has period doublings at 0.4902
and 0.5658 rad/s joined by a period-2 branch. Per harmonic count ``H`` of the period-1
set ``{0..H}`` the doubled set is ``{0..2H+1}`` of ``w0/2``: the same highest frequency.

Per point, same run, medians: the fixed-speed Newton solve from the solution of the same
branch at 0.99 x the speed (``solve``; and per Newton iteration, since the period-2
branch bends more over 1 % of speed and takes more of them), one residual with its
Jacobian (``evaluate``), the stability verdict (``stability``: the monodromy over the
branch's own period, T.10), and the whole continuation per point (the main trace against
the traces of its period-2 branches, the location and switch included). Ratios period-2 / period-1.

Run: ``.venv/bin/python -m benchmarks.bench_period2 [--quick]``; writes
``benchmarks/results/period2.json``.
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
from hbm.branching import period_doubling_branches
from hbm.stability import stability

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from hbm_models import RPM, sdof_problem  # noqa: E402  (the tests' own model)

log = logging.getLogger("bench_period2")
LO, HI = 0.45 / RPM, 0.62 / RPM


def _costs(pb, branch, i: int, repeats: int) -> dict[str, float]:
    """Median seconds of solve / evaluate / stability at point ``i`` of ``branch``."""
    rpm, u = branch.rpm[i], branch.unknowns[i]
    prev = pb.solve(0.99 * rpm, x0=u, tol=1e-10)
    t_solve, pt = median_time(lambda: pb.solve(rpm, x0=prev.unknowns, tol=1e-10),
                              repeats=repeats)
    its = max(int(pt.iterations), 1)
    t_eval, _ = median_time(lambda: pb.evaluate(u, branch.omega[i]), repeats=repeats)
    pt = pb.point(u, branch.omega[i])
    t_stab, _ = median_time(lambda: stability(pb, pt), repeats=max(3, repeats // 2))
    return {"solve_s": t_solve, "iterations": its, "iteration_s": t_solve / its,
            "evaluate_s": t_eval, "stability_s": t_stab,
            "unknowns": pb.n_unknowns, "aft_samples": pb.harmonics.n_time}


def run(quick: bool) -> dict[str, Any]:
    rows = []
    repeats = 5 if quick else 11
    for h in ((20, 40) if quick else (20, 40, 80)):
        pb = sdof_problem(harmonics=h, fa=0.1, b=0.2)
        t0 = time.perf_counter()
        main = hbm.trace(pb, HI, LO, step=0.02, max_step=0.05)
        t_main = time.perf_counter() - t0
        span = HI - LO
        t0 = time.perf_counter()
        secs = period_doubling_branches(pb, main, (LO, HI), depth=1,
                                        step_rpm=(0.02 * span, 1e-6 * span, 0.05 * span))
        t_sec = time.perf_counter() - t0
        s = max(secs, key=lambda x: np.sum(x.branch.stable))
        br2 = s.branch
        j = int(np.flatnonzero(br2.stable)[np.sum(br2.stable) // 2])
        # the period-1 point nearest in speed on the main branch (a stable one if any)
        k = int(np.argmin(np.abs(main.rpm - br2.rpm[j]) + 1e9 * (~main.stable)))
        c1 = _costs(pb, main, k, repeats)
        c2 = _costs(s.problem, br2, j, repeats)
        n2 = sum(len(x.branch) for x in secs)
        row = {"H": h, "rpm": float(br2.rpm[j]), "period1": c1, "period2": c2,
               "ratio": {key: c2[key] / c1[key] for key in ("solve_s", "iteration_s",
                                                             "evaluate_s", "stability_s")},
               "trace": {"main_points": len(main), "main_s": t_main,
                         "main_s_per_point": t_main / len(main),
                         "secondary_branches": len(secs), "secondary_points": n2,
                         "secondary_s": t_sec, "secondary_s_per_point": t_sec / max(n2, 1),
                         "ratio_per_point": (t_sec / max(n2, 1)) / (t_main / len(main))}}
        log.info("H = %d: solve %.2f ms / %.2f ms (x%.2f; %d / %d iterations, x%.2f per "
                 "iteration), evaluate x%.2f, stability x%.2f; "
                 "trace per point %.2f / %.2f ms (x%.2f, switching included)", h,
                 1e3 * c2["solve_s"], 1e3 * c1["solve_s"], row["ratio"]["solve_s"],
                 c2["iterations"], c1["iterations"], row["ratio"]["iteration_s"],
                 row["ratio"]["evaluate_s"], row["ratio"]["stability_s"],
                 1e3 * row["trace"]["secondary_s_per_point"],
                 1e3 * row["trace"]["main_s_per_point"], row["trace"]["ratio_per_point"])
        rows.append(row)
    cols = ["H", "unknowns p1 / p2", "solve ms p1 / p2", "iterations p1 / p2",
            "per iteration x", "evaluate x", "stability x", "trace ms/point p1 / p2",
            "trace per point x"]
    table = [[r["H"], f"{r['period1']['unknowns']} / {r['period2']['unknowns']}",
              f"{1e3 * r['period1']['solve_s']:.3g} / {1e3 * r['period2']['solve_s']:.3g}",
              f"{r['period1']['iterations']} / {r['period2']['iterations']}",
              r["ratio"]["iteration_s"], r["ratio"]["evaluate_s"], r["ratio"]["stability_s"],
              f"{1e3 * r['trace']['main_s_per_point']:.3g} / "
              f"{1e3 * r['trace']['secondary_s_per_point']:.3g}",
              r["trace"]["ratio_per_point"]] for r in rows]
    return {"command": "python -m benchmarks.bench_period2",
            "summary": "A point of the period-2 branch of the Kahraman-Singh pair against "
                       "one of its period-1 parent of the same harmonic reach, same run "
                       "(x: period-2 / period-1; trace per point includes locating the "
                       "doublings and switching).",
            "tables": [{"title": "period-2 against period-1 point", "columns": cols,
                        "rows": table}],
            "headline": {f"period-2 / period-1 continuation per point, H = {r['H']}":
                         r["trace"]["ratio_per_point"] for r in rows},
            "rows": rows, "peak_rss_mb": peak_rss_mb()}


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="H = 20, 40 only, fewer repeats")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(name)s: %(message)s")
    logging.getLogger("hbm").setLevel(logging.WARNING)
    path = write_json("period2", run(args.quick))
    log.info("wrote %s", path)


if __name__ == "__main__":
    main()
