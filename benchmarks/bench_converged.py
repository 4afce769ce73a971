"""Error of the pump's HBM curve against the reference time integrations.

For a harmonic set (``--set hbm.KEY=VALUE`` overrides of the pump scene's
``[hbm]``; none: the shipped set) the pump curve is traced over the scene's range
with its continuation settings and stability on (``hbm.trace``, as
benchmarks/bench_stability.py), timed. Then at each speed of the reference
(``benchmarks/results/ti_reference_pump.json``, :mod:`benchmarks.ti_reference`) the
HBM mesh-load std is taken on the attractor the integration settled on: Newton at
that speed from the nearest point of every monotone piece of the branch through
it, and of those solutions the one whose Delta is nearest to the integrated Delta
(relative L2 over the shaft harmonics) is compared. The std is sampled on the
reference's own time grid of one period.

Reported per speed: the relative std error; over the speeds: the largest, and
whether it is <= ``--eps`` (1e-3, issue 13 item 4). A reference computed for another
ROM, scene or physics is refused. Speeds where the reference did not settle are
listed but not counted.

Run: ``.venv/bin/python -m benchmarks.bench_converged [--set hbm.mesh_harmonics=12 ...]
[--cache DIR]``. Writes ``benchmarks/results/converged.json`` (one record per harmonic
set, records of other sets kept).
"""
from __future__ import annotations

import argparse
import json
import logging
import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.bench_verify import hbm_load, load_metrics
from benchmarks.common import RESULTS, peak_rss_mb, write_json
from benchmarks.ti_reference import (
    DEFAULT_OUT,
    PUMP_SCENE,
    crossing_starts,
    delta_distance,
    harmonic_vector,
    load_reference,
    reference_key,
)

log = logging.getLogger("bench_converged")
ROOT = Path(__file__).resolve().parents[1]
EPS = 1e-3


# --------------------------------------------------------------------------- metric

def branch_solutions(branch_rpm: np.ndarray, rpm: float,
                     solve_from: Callable[[int], dict | None]) -> list[dict]:
    """Solutions at ``rpm`` started from the nearest point of every monotone piece of the
    branch through it; ``solve_from(i)`` returns ``{"std", "vector", ...}`` or None
    (no convergence)."""
    out = []
    for i in crossing_starts(branch_rpm, rpm):
        sol = solve_from(i)
        if sol is not None:
            out.append({**sol, "branch_index": i})
    return out


def attractor_error(ref: dict, solutions: list[dict]) -> dict:
    """Relative mesh-load std error of the solution nearest to the reference orbit.

    Parameters
    ----------
    ref
        ``{"rpm", "std", "coefficients"}``: reference std (N) and complex Delta
        coefficients by shaft harmonic.
    solutions
        ``{"std", "vector"}`` per candidate: HBM std and Delta coefficients by shaft
        harmonic.

    Raises
    ------
    ValueError
        If ``solutions`` is empty or the reference std is not > 0.
    """
    if not solutions:
        raise ValueError(f"{ref['rpm']} rpm: no HBM solution on the branch")
    if not ref["std"] > 0:
        raise ValueError(f"reference std at {ref['rpm']} rpm = {ref['std']!r}: must be > 0")
    dist = [delta_distance(s["vector"], ref["coefficients"]) for s in solutions]
    k = int(np.argmin(dist))
    s = solutions[k]
    return {"rpm": float(ref["rpm"]), "ref_std": float(ref["std"]), "std": float(s["std"]),
            "err_std": abs(s["std"] - ref["std"]) / ref["std"], "distance": dist[k],
            "solutions": len(solutions), "branch_index": s.get("branch_index")}


def summarize(rows: list[dict], eps: float = EPS) -> dict:
    """Largest relative std error over ``rows`` and whether it is <= ``eps``."""
    if not rows:
        raise ValueError("no speed to summarize")
    worst = max(rows, key=lambda r: r["err_std"])
    return {"max_err_std": worst["err_std"], "worst_rpm": worst["rpm"],
            "within_eps": bool(worst["err_std"] <= eps), "eps": eps}


# --------------------------------------------------------------------------- run

def trace_curve(problem, scene, stability: bool = True) -> tuple[Any, dict]:
    """The scene's curve (with stability unless told), and its timing: ``wall_s``,
    ``cpu_s`` (this process and its finished children: the stability worker),
    ``cpu_main_s`` (this process) and the load average before and after (the machine
    is shared)."""
    import hbm

    c = scene.continuation
    span = c.speed[1] - c.speed[0]
    load0 = os.getloadavg()[0]
    c0 = _cpu_seconds()
    m0 = time.process_time()
    t0 = time.perf_counter()
    br = hbm.trace(problem, c.speed[0], c.speed[1], step=c.step / span,
                   min_step=c.min_step / span, max_step=c.max_step / span, tol=c.tolerance,
                   max_points=c.max_points, stability=stability)
    wall = time.perf_counter() - t0
    return br, {"wall_s": wall, "cpu_s": _cpu_seconds() - c0,
                "cpu_main_s": time.process_time() - m0,
                "load_before": load0, "load_after": os.getloadavg()[0]}


def _cpu_seconds() -> float:
    """User + system CPU time of this process and its waited-for children (s)."""
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


def speed_error(problem, branch, ref: dict) -> dict:
    """:func:`attractor_error` at one reference speed on a traced branch."""
    from hbm import ConvergenceError, point_stats

    rpm = ref["rpm"]

    def solve_from(i: int) -> dict | None:
        try:
            pt = problem.solve(rpm, x0=branch.unknowns[i], tol=1e-10)
        except ConvergenceError as exc:
            log.warning("%.0f rpm: Newton from branch point %d failed (%s)", rpm, i, exc)
            return None
        return {"std": load_metrics(hbm_load(problem, pt, ref["samples"]))["std"],
                "vector": harmonic_vector(problem, pt),
                "contact": int(point_stats(problem, pt)[0].contact)}
    sols = branch_solutions(branch.rpm, rpm, solve_from)
    row = attractor_error(ref, sols)
    row["contact"] = next(s["contact"] for s in sols if s["branch_index"] == row["branch_index"])
    row["ref_contact"] = ref["contact"]
    return row


def label_of(scene, overrides: dict) -> str:
    """Name of the harmonic set, e.g. ``contiguous 12/3 (shipped)``, with the AFT samples
    when the scene fixes them."""
    h = scene.hbm
    name = f"{h.harmonic_set} {h.mesh_harmonics}/{h.sideband_order}"
    if h.aft_samples:
        name += f", {h.aft_samples} AFT samples"
    return name + (" (shipped)" if not overrides else "")


def main(argv: list[str] | None = None) -> dict:
    import study
    from study.cli import parse_sets
    from study.pipeline import Pipeline

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--set", action="append", default=[], metavar="hbm.KEY=VALUE",
                    help="override of the scene's [hbm] (repeatable)")
    ap.add_argument("--reference", type=Path, default=DEFAULT_OUT)
    ap.add_argument("--cache", type=Path, default=ROOT / "out" / ".geardyn-cache",
                    help="pipeline stage cache holding the ROM")
    ap.add_argument("--eps", type=float, default=EPS)
    ap.add_argument("--without-stability", action="store_true",
                    help="also trace the curve without stability (ms/point without it)")
    ap.add_argument("--tag", default="",
                    help="appended to the set's label (e.g. which code ran it)")
    args = ap.parse_args(argv)
    variants = parse_sets(args.set)
    if len(variants) != 1:
        raise ValueError(f"--set {args.set}: one value per key")
    overrides = variants[0]
    bad = [k for k in overrides if not k.startswith("hbm.")]
    if bad:
        raise ValueError(f"--set {bad}: only [hbm] keys (the reference is for the scene's "
                         "physics)")
    if not 0 < args.eps < 1:
        raise ValueError(f"--eps = {args.eps}: must be in (0, 1)")
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s: %(message)s")
    ref = load_reference(args.reference, reference_key(PUMP_SCENE, args.cache))
    scene = study.load_scene(PUMP_SCENE, overrides)
    problem, _ = Pipeline(scene, args.cache.parent / "bench-converged", cache_dir=args.cache,
                          progress=False).problem()
    label = label_of(scene, overrides) + (f" [{args.tag}]" if args.tag else "")
    log.info("%s: %d unknowns, tracing %g-%g rpm with stability", label, problem.n_unknowns,
             *scene.continuation.speed)
    br, timing = trace_curve(problem, scene)
    log.info("%s: %d points in %.1f s wall, %.1f s CPU, load %.2f -> %.2f (%s)", label,
             len(br), timing["wall_s"], timing["cpu_s"], timing["load_before"],
             timing["load_after"], br.status)
    plain = {}
    if args.without_stability:
        br0, t_plain = trace_curve(problem, scene, stability=False)
        plain = {"points_no_stability": len(br0), "wall_s_no_stability": t_plain["wall_s"],
                 "cpu_s_no_stability": t_plain["cpu_s"],
                 "ms_per_point_no_stability": 1e3 * t_plain["wall_s"] / max(len(br0), 1),
                 "load_no_stability": t_plain["load_before"]}
        log.info("%s without stability: %d points in %.1f s wall, %.1f s CPU", label,
                 len(br0), t_plain["wall_s"], t_plain["cpu_s"])
    rows, skipped = [], []
    for r in ref["speeds"]:
        if not r["accepted"]:
            skipped.append(r["rpm"])
            continue
        row = speed_error(problem, br, r)
        log.info("  %.0f rpm: std %.6g N vs %.6g N, err %.2e (%d solution(s), distance %.2g)",
                 row["rpm"], row["std"], row["ref_std"], row["err_std"], row["solutions"],
                 row["distance"])
        rows.append(row)
    record = {"set": label, "overrides": overrides, "unknowns": problem.n_unknowns,
              "harmonics": len(problem.harmonics.indices),
              "n_time": int(problem.harmonics.n_time), "points": len(br),
              "status": br.status, **timing,
              "ms_per_point": 1e3 * timing["wall_s"] / max(len(br), 1),
              "folds": len(br.folds), "grazing": len(br.grazing),
              "unstable": int(np.sum(~br.stable)), **plain, "speeds": rows,
              "not_settled": skipped,
              **summarize(rows, args.eps)}
    log.info("%s: max err %.2e at %.0f rpm (<= %g: %s)", label, record["max_err_std"],
             record["worst_rpm"], args.eps, record["within_eps"])
    return write(record, args.eps)


def write(record: dict, eps: float) -> dict:
    """Merge ``record`` into ``converged.json`` (other sets kept) and write it."""
    old = RESULTS / "converged.json"
    records = [record]
    if old.exists():
        records += [r for r in json.loads(old.read_text()).get("records", [])
                    if r["set"] != record["set"]]
    records.sort(key=lambda r: r["unknowns"])
    summary_rows = [[r["set"], r["unknowns"], r.get("n_time"), r["points"], r["status"],
                     r["wall_s"], r.get("cpu_s"), r.get("cpu_main_s", "-"),
                     r.get("load_before"), r["ms_per_point"],
                     r.get("ms_per_point_no_stability"), r["folds"], r["max_err_std"],
                     r["worst_rpm"], r["within_eps"]] for r in records]
    speed_rows = [[r["set"], s["rpm"], s["ref_std"], s["std"], s["err_std"], s["ref_contact"],
                   s["contact"], s["solutions"], s["distance"]]
                  for r in records for s in r["speeds"]]
    payload = {
        "command": ".venv/bin/python -m benchmarks.bench_converged [--set hbm.KEY=VALUE ...]",
        "summary": (f"Pump curve 500-7000 rpm with stability per harmonic set, and the "
                    f"relative error of its mesh-load std against the reference time "
                    f"integrations (benchmarks/results/ti_reference_pump.json) on the attractor "
                    f"the integration settled on; target <= {eps:g} at every speed. One run "
                    "per set on the shared machine: wall and CPU time of the trace, load "
                    "average (1 min) when it started."),
        "tables": [{"title": "whole curve and largest error per harmonic set",
                    "columns": ["set", "unknowns", "AFT samples", "points", "status",
                                "wall s", "CPU s", "CPU s main process", "load",
                                "ms/point",
                                "ms/point without stability", "folds", "max err std",
                                "at rpm", f"<= {eps:g}"],
                    "rows": summary_rows},
                   {"title": "mesh-load std against time integration per speed",
                    "columns": ["set", "rpm", "TI std N", "HBM std N", "err std",
                                "TI contact", "HBM contact", "HBM solutions", "Delta distance"],
                    "rows": speed_rows}],
        "records": records, "peak_rss_mb": peak_rss_mb()}
    shipped = [r for r in records if "(shipped)" in r["set"]]
    if shipped:
        r = shipped[0]
        payload["headline"] = {"shipped set: curve with stability, wall [s]": r["wall_s"],
                               "shipped set: largest std error against TI": r["max_err_std"]}
    path = write_json("converged", payload)
    log.info("wrote %s", path)
    return payload


if __name__ == "__main__":
    main()
