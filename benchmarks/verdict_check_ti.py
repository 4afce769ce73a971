"""The verdicts a run checked on a richer harmonic set, against time integration.

A run writes ``/verdict_checks`` (docs/theory.md §11, "Verdicts on a richer set"): the
points in doubt, their verdict on the run's own set and the one written (the richer
set's, or not stable where it has no orbit near). For each of them (or ``--max-points``
of them, every changed one first) this integrates the ROM in time from the run's own
orbit (:func:`hbm.post.time_response.integrate`: DOP853, all coupled modes, a relative
disturbance of 1e-6, ``--turns`` shaft turns) and records whether the response stays on
that orbit (every turn's mesh-load std within ``--stay`` of the orbit's) or leaves it;
then which verdict the integration agrees with. Results in
``benchmarks/results/verdict_check_<scene>.json``.

Run (15-25 s per point on the pump's ROM; the run's stage cache is reused)::

    OMP_NUM_THREADS=1 nice .venv/bin/python -m benchmarks.verdict_check_ti \\
        --scene scenes/pump.toml --run OUT --cache CACHE
"""
from __future__ import annotations

import argparse
import logging
import time
from pathlib import Path

import h5py
import numpy as np

from benchmarks.common import finished_run, records_table, write_json

log = logging.getLogger("verdict_check_ti")


def main(argv: list[str] | None = None) -> dict:
    from hbm.post.time_response import integrate
    from study.outputs.points import point_at

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", type=Path, required=True)
    ap.add_argument("--run", type=Path, required=True, help="output folder of the run")
    ap.add_argument("--cache", type=Path, required=True, help="the run's stage cache")
    ap.add_argument("--turns", type=int, default=5)
    ap.add_argument("--stay", type=float, default=5e-3,
                    help="largest relative std change of a turn that still 'stays'")
    ap.add_argument("--max-points", type=int, default=40)
    ap.add_argument("--set", dest="sets", action="append", default=[],
                    metavar="SECTION.KEY=VALUE", help="the run's --set overrides")
    ap.add_argument("--out", type=Path, default=None,
                    help="JSON file (default benchmarks/results/verdict_check_<scene>.json)")
    args = ap.parse_args(argv)
    if args.turns < 1 or not 0 < args.stay < 1 or args.max_points < 1:
        raise ValueError("--turns >= 1, 0 < --stay < 1 and --max-points >= 1")
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s: %(message)s")
    # the run's own orbits: /continuation holds the checked verdicts, /verdict_checks both
    res = finished_run(args.scene, args.sets, args.run, args.cache)
    br, problem = res.branch, res.problem
    with h5py.File(res.results, "r") as f:
        g = f["verdict_checks"]
        rows = {k: g[k][:] for k in ("index", "rpm", "stable_before", "stable", "same_orbit",
                                      "max_real_before", "max_real", "change")}
        richer = int(g.attrs["mesh_harmonics"])
    changed = rows["stable_before"] != rows["stable"]
    order = np.concatenate([np.flatnonzero(changed), np.flatnonzero(~changed)])[:args.max_points]
    std = br.element(0).mesh_load_std
    records = []
    for j in order:
        i = int(rows["index"][j])
        t0 = time.perf_counter()
        r = integrate(problem, float(br.rpm[i]), point_at(res, i), transient=0,
                      window=args.turns, perturbation=1e-6)
        rel = (np.asarray(r.std_per_turn) - std[i]) / std[i]
        stays = bool(np.all(np.abs(rel) < args.stay))
        before, after = bool(rows["stable_before"][j]), bool(rows["stable"][j])
        rec = {"rpm": float(rows["rpm"][j]), "before": before, "after": after,
               "same_orbit": bool(rows["same_orbit"][j]),
               "max_real_before": float(rows["max_real_before"][j]),
               "max_real_after": float(rows["max_real"][j]),
               "orbit_change": float(rows["change"][j]), "ti_stays": stays,
               "ti_std_change_per_turn": [float(x) for x in rel],
               "agrees_before": stays == before, "agrees_after": stays == after,
               "seconds": time.perf_counter() - t0}
        log.info("%.4f rpm: %s -> %s, integration %s (%.0f s)", rec["rpm"],
                 "stable" if before else "unstable", "stable" if after else "unstable",
                 "stays" if stays else "leaves", rec["seconds"])
        records.append(rec)
    n = len(records)
    summary = (f"{n} checked verdicts of {args.run} ({richer} mesh harmonics), integrated "
               f"{args.turns} turns from the run's own orbit: the integration agrees with "
               f"{sum(r['agrees_before'] for r in records)} verdicts before the check and "
               f"{sum(r['agrees_after'] for r in records)} after it")
    cols = ["rpm", "before", "after", "same_orbit", "max_real_before", "max_real_after",
            "orbit_change", "ti_stays", "agrees_before", "agrees_after", "seconds"]
    payload = {"command": "python -m benchmarks.verdict_check_ti --scene "
                          f"{args.scene} --run OUT --cache CACHE --turns {args.turns}",
               "summary": summary,
               "headline": {"verdicts agreeing with time integration, before the check":
                            sum(r["agrees_before"] for r in records),
                            "verdicts agreeing with time integration, after the check":
                            sum(r["agrees_after"] for r in records),
                            "verdicts checked against time integration": n},
               "tables": [records_table("verdicts", cols, records)],
               "records": records}
    write_json(f"verdict_check_{Path(args.scene).stem}", payload, args.out)
    log.info("%s", summary)
    return payload


if __name__ == "__main__":
    main()
