"""The time responses of a run's unstable segments against a refined integration.

A run with ``[outputs] attractor_transient_turns`` wrote ``attractors.csv`` (one row per
integrated speed: its std, largest load, Poincaré verdict; docs/theory.md §16). For each
row this integrates again from the same orbit (Newton from the branch point of that
speed in ``results.h5``) with another tolerance, another start disturbance and another
transient (defaults: rtol 1e-10, disturbance 1e-4, 1.5 × the turns left out, the same
window) and records both summaries and their relative differences: the response is the
attractor's, not the run's, when they agree (issue 40 item 5 asks 1 % for std and
spectra). Results in ``benchmarks/results/attractor_check_<scene>.json``.

Run (minutes per speed on the pump's ROM; the stage cache of the run is reused)::

    OMP_NUM_THREADS=1 nice .venv/bin/python -m benchmarks.attractor_check \\
        --scene scenes/pump.toml --run OUT --cache CACHE
"""
from __future__ import annotations

import argparse
import csv
import json
import logging
from pathlib import Path

import h5py
import numpy as np

from benchmarks.common import RESULTS
from core.files import atomic_write

log = logging.getLogger("attractor_check")


def rows(run: Path, speeds: list[float] | None = None) -> list[dict]:
    """The integrated rows of ``run/attractors.csv``, one per speed (a branch that winds
    repeats points), only those within 1e-3 rpm of ``speeds`` when given."""
    with open(run / "attractors.csv") as fh:
        out, seen = [], set()
        for r in csv.DictReader(fh):
            rpm = float(r["speed_rpm"])
            if not r["response_std_N"] or rpm in seen:
                continue
            if speeds and min(abs(rpm - s) for s in speeds) > 1e-3:
                continue
            seen.add(rpm)
            out.append(r)
        return out


def check(problem, unknowns: np.ndarray, branch_rpm: np.ndarray, row: dict, transient: int,
          window: int, rtol: float, eps: float) -> dict:
    """One row against a refined integration from the same orbit."""
    from hbm.post.time_response import integrate

    rpm = float(row["speed_rpm"])
    i = int(np.argmin(np.abs(branch_rpm - rpm)))
    pt = problem.solve(rpm, x0=unknowns[i], tol=1e-10)
    tr = integrate(problem, rpm, pt, transient=transient, window=window, rtol=rtol,
                   perturbation=eps)
    sec = tr.poincare
    ref_std, ref_max = float(row["response_std_N"]), float(row["max_load_N"])
    return {"rpm": rpm, "kind": row["kind"], "run": {
                "std": ref_std, "max_load": ref_max, "section": row["section"],
                "rotation": float(row["rotation"] or "nan"), "outcome": row["outcome"],
                "turns": [int(row["turns_left_out"]), int(row["turns_analysed"])]},
            "refined": {"std": tr.std, "max_load": tr.max_load,
                        "section": None if sec is None else sec.label,
                        "rotation": None if sec is None else sec.rotation,
                        "turns": [transient, window], "rtol": rtol, "perturbation": eps,
                        "seconds": round(tr.seconds, 1),
                        "windowed_lines": [[round(o, 5), round(a, 4)]
                                           for o, a in tr.windowed_lines(6)]},
            "std_rel_diff": tr.std / ref_std - 1.0, "max_rel_diff": tr.max_load / ref_max - 1.0}


def main(argv: list[str] | None = None) -> dict:
    import study
    from study.pipeline import Pipeline

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", type=Path, required=True)
    ap.add_argument("--run", type=Path, required=True, help="output folder of the run")
    ap.add_argument("--cache", type=Path, required=True, help="the run's stage cache")
    ap.add_argument("--rtol", type=float, default=1e-10)
    ap.add_argument("--perturbation", type=float, default=1e-4)
    ap.add_argument("--transient-factor", type=float, default=1.5)
    ap.add_argument("--max-rows", type=int, default=3)
    ap.add_argument("--rpm", type=float, nargs="+", help="only these speeds of the CSV")
    ap.add_argument("--out", type=Path)
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s: %(message)s")
    scene = study.load_scene(args.scene)
    problem, _ = Pipeline(scene, args.cache.parent / "attractor-check", cache_dir=args.cache,
                          progress=False).problem()
    with h5py.File(args.run / "results.h5", "r") as f:
        unknowns = f["continuation/unknowns"][()]
        branch_rpm = f["continuation/rpm"][()]
    out = args.out or RESULTS / f"attractor_check_{args.scene.stem}.json"
    records = []
    for row in rows(args.run, args.rpm)[:args.max_rows]:
        transient = int(round(args.transient_factor * int(row["turns_left_out"])))
        rec = check(problem, unknowns, branch_rpm, row, transient,
                    int(row["turns_analysed"]), args.rtol, args.perturbation)
        log.info("%.3f rpm: std %.4g against %.4g N (%+.2e), max %+.2e, section %s / %s",
                 rec["rpm"], rec["refined"]["std"], rec["run"]["std"], rec["std_rel_diff"],
                 rec["max_rel_diff"], rec["refined"]["section"], rec["run"]["section"])
        records.append(rec)
        with atomic_write(out, "w") as fh:
            json.dump({"scene": str(args.scene), "records": records}, fh, indent=1)
            fh.write("\n")
    return {"records": records}


if __name__ == "__main__":
    main()
