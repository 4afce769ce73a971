"""Where the machine goes from the unstable parts of a run's curve: time integration.

report.md says what takes over on each unstable run of the curve (the middle of a jump:
a coexisting stable orbit; a period doubling or Neimark-Sacker: another response). This
integrates the ROM in time (:func:`hbm.post.time_response.integrate`: DOP853, all coupled
modes) from three orbits of each run of consecutive unstable points (its first, middle
and last point; the ``--max-runs`` longest runs), started with a relative disturbance of
1e-6, over ``--turns`` shaft turns, and compares the mesh-load std of its last turns with
every *stable* orbit the run has at that speed (the stable pieces of its main branch and
of its period-k branches, ``/branches``, through that speed, interpolated linearly; the std
of a period-k orbit is over its own period): where the integration settles on one of them, the
run's curve holds what the machine does there; where it settles on none, it shows a
response the periodic curve does not hold (period-k, quasi-periodic, or a stable orbit of
another branch). Results in ``benchmarks/results/unstable_ti_<scene>.json``.

Run (10-60 s per speed on the pump's ROM; the run's stage cache is reused)::

    OMP_NUM_THREADS=1 nice .venv/bin/python -m benchmarks.unstable_ti \\
        --scene scenes/pump.toml --run OUT --cache CACHE
"""
from __future__ import annotations

import argparse
import logging
import time
from pathlib import Path

import numpy as np

from benchmarks.common import finished_run, records_table, write_json

log = logging.getLogger("unstable_ti")


def unstable_runs(stable: np.ndarray, min_points: int = 3) -> list[tuple[int, int]]:
    """(first, last) indices of the runs of consecutive unstable points, longest first."""
    bad = ~np.asarray(stable, dtype=bool)
    edges = np.diff(np.concatenate([[0], bad.astype(int), [0]]))
    runs = [(int(a), int(b) - 1) for a, b in zip(np.flatnonzero(edges == 1),
                                                  np.flatnonzero(edges == -1), strict=True)]
    runs = [r for r in runs if r[1] - r[0] + 1 >= min_points]
    return sorted(runs, key=lambda r: r[0] - r[1])


def stable_orbits_at(rpm: np.ndarray, std: np.ndarray, stable: np.ndarray,
                     speed: float) -> list[float]:
    """Mesh-load std of every stable orbit of the branch at ``speed``: each segment between
    two consecutive stable points that brackets it, interpolated linearly."""
    out = []
    for j in range(rpm.size - 1):
        a, b = rpm[j], rpm[j + 1]
        if stable[j] and stable[j + 1] and a != b and (a - speed) * (b - speed) <= 0:
            t = (speed - a) / (b - a)
            out.append(float((1 - t) * std[j] + t * std[j + 1]))
    return out


def main(argv: list[str] | None = None) -> dict:
    from hbm.post.time_response import integrate
    from study.outputs.points import point_at

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", type=Path, required=True)
    ap.add_argument("--set", dest="sets", action="append", default=[],
                    metavar="SECTION.KEY=VALUE", help="the run's --set overrides")
    ap.add_argument("--run", type=Path, required=True, help="output folder of the run")
    ap.add_argument("--cache", type=Path, required=True, help="the run's stage cache")
    ap.add_argument("--turns", type=int, default=8)
    ap.add_argument("--settled", type=int, default=3, help="last turns averaged")
    ap.add_argument("--max-runs", type=int, default=8)
    ap.add_argument("--match", type=float, default=1e-3,
                    help="relative std difference that counts as the same orbit")
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    if args.turns < 2 or not 1 <= args.settled < args.turns or args.max_runs < 1:
        raise ValueError("--turns >= 2, 1 <= --settled < --turns, --max-runs >= 1")
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s: %(message)s")
    res = finished_run(args.scene, args.sets, args.run, args.cache)
    br, problem, path = res.branch, res.problem, res.results
    std = br.element(0).mesh_load_std
    stable = np.asarray(br.stable, dtype=bool)
    # the period-k branches of the run (/branches): their stable orbits count too
    import h5py

    from study.outputs.branches import read_branches
    with h5py.File(path, "r") as f:
        secondary = read_branches(f, problem)[0]
    records = []
    for first, last in unstable_runs(stable)[:args.max_runs]:
        for i in sorted({first, (first + last) // 2, last}):
            t0 = time.perf_counter()
            r = integrate(problem, float(br.rpm[i]), point_at(res, i), transient=0,
                          window=args.turns, perturbation=1e-6)
            per_turn = np.asarray(r.std_per_turn, dtype=float)
            settled = float(per_turn[-args.settled:].mean())
            spread = float(np.ptp(per_turn[-args.settled:]) / settled)
            cands = stable_orbits_at(br.rpm, std, stable, float(br.rpm[i]))
            others = {sb.name: stable_orbits_at(sb.branch.rpm,
                                                sb.branch.element(0).mesh_load_std,
                                                np.asarray(sb.branch.stable, dtype=bool),
                                                float(br.rpm[i])) for sb in secondary}
            every = cands + [x for v in others.values() for x in v]
            near = min(every, key=lambda s: abs(s - settled)) if every else float("nan")
            diff = abs(near - settled) / settled if every else float("nan")
            on = next((n for n, v in others.items() if near in v), "main") if every else ""
            rec = {"rpm": float(br.rpm[i]), "run": [int(first), int(last)],
                   "run_rpm": [float(br.rpm[first:last + 1].min()),
                               float(br.rpm[first:last + 1].max())],
                   "kind": int(br.floquet_kind[i]), "orbit_std": float(std[i]),
                   "ti_std": settled, "ti_spread": spread,
                   "left_orbit": bool(abs(settled - std[i]) / std[i] > args.match),
                   "stable_orbits": cands, "stable_secondary_orbits": others,
                   "nearest_stable_std": near, "nearest_branch": on,
                   "nearest_rel_diff": diff,
                   "on_a_stable_orbit": bool(every) and diff <= args.match
                   and spread <= args.match,
                   "seconds": time.perf_counter() - t0}
            log.info("%.4f rpm (run %d-%d): orbit %.3f N, integration %.3f N (spread %.1e); "
                     "stable orbits there %s -> %s (%.0f s)", rec["rpm"], first, last,
                     std[i], settled, spread, [round(c, 3) for c in every],
                     "on one" if rec["on_a_stable_orbit"] else "on none", rec["seconds"])
            records.append(rec)
    n_on = sum(r["on_a_stable_orbit"] for r in records)
    summary = (f"{len(records)} speeds on {len({tuple(r['run']) for r in records})} unstable "
               f"runs of {args.run}: the integration from the unstable orbit leaves it at "
               f"{sum(r['left_orbit'] for r in records)} and settles on a stable orbit of the "
               f"branch at the same speed (std within {args.match:g}) at {n_on}")
    cols = ["rpm", "run_rpm", "kind", "orbit_std", "ti_std", "ti_spread", "left_orbit",
            "nearest_stable_std", "nearest_branch", "nearest_rel_diff", "on_a_stable_orbit",
            "seconds"]
    payload = {"command": f"python -m benchmarks.unstable_ti --scene {args.scene} --run OUT "
                          f"--cache CACHE --turns {args.turns}",
               "summary": summary,
               "headline": {"unstable speeds integrated": len(records),
                            "of them settling on a stable orbit of the curve": n_on},
               "tables": [records_table("unstable speeds", cols, records)],
               "records": records}
    write_json(f"unstable_ti_{Path(args.scene).stem}", payload, args.out)
    log.info("%s", summary)
    return payload


if __name__ == "__main__":
    main()
