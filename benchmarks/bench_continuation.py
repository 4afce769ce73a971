"""The continuation's per-point bookkeeping and the modal recovery, before and after
(issue 39 item 5), in one run.

1. **A long lumped branch, old code against new** (``--baseline``, a git revision
   exported to a temporary folder): ``hbm.examples.Geared3`` (12 harmonics, 5 µm TE)
   traced over 0.7-1.3 of its mesh resonance in steps of 1e-4 up to ``--points`` points
   (a fold and a grazing point among them), each version in its own process, the
   versions alternating; the time of every accepted point is stamped, the per-point time
   is the median over windows of 200 points at given indices. Without an ``on_point``
   callback (the old code would take minutes with one: see 2). The branches must be the
   same bit for bit (checked).
2. **The bookkeeping of one point at point k, replayed** on that branch in this process:
   the walk-back / closed-loop distance test (every segment measured, as the old code
   did, against the segment index) and the branch handed to ``on_point`` (every list
   stacked again, as the old code did, against the stacked rows grown point by point);
   interleaved repeats, medians.
3. **HBMProblem.recover** on a ROM of the pump's size (``synthetic_rom(100)``: 112 DOF,
   the contiguous set of 925 indices, one mesh): the former two complex products with
   the modes against the new recovery, interleaved repeats, and their largest
   difference relative to the largest coordinate.

Run (one heavy run at a time; ~5 min)::

    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 .venv/bin/python -m benchmarks.bench_continuation \\
        --baseline <revision> [--points 12000] [--repeats 2]

Writes ``benchmarks/results/continuation.json`` (rendered into BENCHMARKS.md by
``benchmarks.report``); the headline figures are same-run ratios old / new.
"""
from __future__ import annotations

import argparse
import logging
import os
import statistics
import subprocess
import sys
import tempfile
import time
from functools import partial
from pathlib import Path

import numpy as np

LOG = logging.getLogger(__name__)
ROOT = Path(__file__).resolve().parents[1]
#: point indices at which the per-point times are reported
AT = (1000, 2000, 5000, 10000, 12000)
WINDOW = 200


# ------------------------------------------------------------------ the child process
def _long_branch(points: int):
    """The long lumped branch (hbm API common to both versions)."""
    import hbm
    from hbm.examples import Geared3

    g = Geared3(harmonics=12, te=5e-6)
    pb = g.problem()
    r = g.mesh_rpm()
    return pb, (0.7 * r, 1.3 * r), dict(step=1e-4, max_step=1e-4, min_step=1e-8,
                                        stability=False, max_points=points), hbm


def child(out: str, points: int) -> None:
    """Trace the long branch, stamping the time of every point added; save to ``out``."""
    from hbm.continuation import branch as branch_module

    stamps: list[float] = []
    add = branch_module.Recorder.add

    def stamped(self, *args, **kwargs):
        add(self, *args, **kwargs)
        stamps.append(time.perf_counter())

    branch_module.Recorder.add = stamped
    pb, (lo, hi), opts, hbm = _long_branch(points)
    t0 = time.perf_counter()
    br = hbm.trace(pb, lo, hi, **opts)
    wall = time.perf_counter() - t0
    np.savez(out, rpm=br.rpm, unknowns=br.unknowns, tangents=br.tangents,
             folds=np.array(br.folds), grazing=np.array([g.rpm for g in br.grazing]),
             iterations=br.newton_iterations, stamps=np.array(stamps), wall=wall,
             reversals=br.reversals, loops=np.array(br.loops, dtype=np.int64).reshape(-1, 4))


def _run_child(tree: Path, out: Path, points: int) -> dict:
    env = dict(os.environ, PYTHONPATH=str(tree), OMP_NUM_THREADS="1",
               OPENBLAS_NUM_THREADS="1")
    subprocess.run([sys.executable, str(Path(__file__).resolve()), "--child", str(out),
                    "--points", str(points)], cwd=tree, env=env, check=True,
                   capture_output=True)
    with np.load(out) as f:
        return {k: f[k] for k in f.files}


def _per_point(stamps: np.ndarray, at: int) -> float | None:
    """Median time per point (ms) over the WINDOW points before index ``at``."""
    if at > stamps.size:
        return None
    dt = np.diff(stamps[max(at - WINDOW, 0):at])
    return float(np.median(dt)) * 1e3


# ------------------------------------------------------------------ replayed bookkeeping
class _States:
    """What the distance test reads of a trace context: the recorder's states."""

    @staticmethod
    def states(rec):
        return rec.states()


def _whole_scan(rec, y: np.ndarray):
    """The old test's distances: every segment but the last measured."""
    from hbm.continuation.revisits import REVISIT_RATIO, segment_gaps, untraced

    ys = rec.states()
    n = len(rec)
    d, foot = segment_gaps(ys[:n - 1], y, untraced(rec))
    i = int(np.argmin(d))
    return i, float(d[i]) < REVISIT_RATIO * float(np.linalg.norm(y - ys[-1]))


def _old_branch_arrays(rec) -> dict:
    """The old Recorder.branch: every list stacked again."""
    from hbm.continuation.branch import POINT_FIELDS

    out = {k: np.array(rec.lists[k]) for k in POINT_FIELDS}
    for k in rec.stat_names:
        v = rec.lists[k]
        shapes = {np.shape(x) for x in v}
        out[k] = np.array(v) if len(shapes) == 1 else None
    return out


def replay(branch_file: Path, repeats: int) -> list[dict]:
    """Per-point bookkeeping at the points AT, old algorithms against new."""
    from hbm.continuation import revisits
    from hbm.continuation.branch import Recorder
    from hbm.sweep import PointMonitor

    pb, (lo, hi), opts, hbm = _long_branch(10)
    with np.load(branch_file) as f:
        n_total = int(f["rpm"].size)
    br = hbm.trace(pb, lo, hi, **{**opts, "max_points": n_total})
    meta = PointMonitor(pb, False).branch_meta()
    rows = []
    for at in AT:
        if at > len(br):
            continue
        rec = Recorder(meta, pb.x_scale, lo, hi, br.omega_scale, br)
        rec.truncate(at - 1)
        rec.branch("running", "", 0.1)               # rows stacked up to here
        i = at - 1
        rec.add(stats={k: v[i] for k, v in br.stats.items()},
                **{k: getattr(br, k)[i] for k in ("rpm", "omega", "unknowns", "residual",
                                                  "newton_iterations", "stable",
                                                  "floquet_max_real", "tangents",
                                                  "floquet_kind", "stability_consistent",
                                                  "loop")})
        y = rec.states()[-1] + 1e-3 * (rec.states()[-1] - rec.states()[-2])
        ctx = _States()
        new_hit = revisits.branch_gaps(ctx, rec, y).nearest(len(rec) - 2)
        old_i, old_near = _whole_scan(rec, y)
        assert (new_hit is not None) == old_near and (new_hit is None or new_hit[0] == old_i)
        t = {"scan old": [], "scan new": [], "branch old": [], "branch new": []}
        for _ in range(repeats):
            for name, f in (("scan old", partial(_whole_scan, rec, y)),
                            ("scan new", partial(revisits.branch_gaps, ctx, rec, y)),
                            ("branch old", partial(_old_branch_arrays, rec)),
                            ("branch new", partial(rec.branch, "running", "", 0.1))):
                t0 = time.perf_counter()
                f()
                t[name].append(time.perf_counter() - t0)
        med = {k: statistics.median(v) * 1e3 for k, v in t.items()}
        rows.append({"point": at, **med,
                     "old total": med["scan old"] + med["branch old"],
                     "new total": med["scan new"] + med["branch new"]})
        LOG.info("replay at %d: %s", at, {k: round(v, 4) for k, v in rows[-1].items()})
    return rows


# ------------------------------------------------------------------ recovery
def recovery(repeats: int) -> dict:
    """HBMProblem.recover against the former products with the modes, pump-sized ROM."""
    import hbm
    from hbm.examples import synthetic_rom

    rom = synthetic_rom(100, clustered=False)
    hs = hbm.HarmonicSet(tuple(range(925)), ratio=1)
    pb = hbm.HBMProblem(rom.system, rom.elements, hbm.Excitation(
        rom.n_dof, constant={0: rom.Fc[0]}), hs, "loa")
    pts = [pb.solve(rpm) for rpm in (40.0, 55.0, 70.0)]

    def old(pt):
        ft, _ = pb.forces(pb.scheme.delta_real(pt.unknowns), jacobian=False)
        fc = pb.harmonics.to_complex(ft)
        f, _ = pb.forcing(pt.omega)
        acc = fc[0][:, None] * pb.directions[0][None, :]
        for e in range(1, len(pb.directions)):
            acc = acc + fc[e][:, None] * pb.directions[e][None, :]
        inv, _ = pb.modal_inverse(pt.omega)
        return pb.phi @ (inv * (pb.phi.T @ (f - acc).T))

    diff = max(float(np.max(np.abs(old(p) - pb.recover(p))) / np.max(np.abs(old(p))))
               for p in pts)
    t = {"old": [], "new": []}
    for _ in range(repeats):
        for name, f in (("old", old), ("new", pb.recover)):
            t0 = time.perf_counter()
            for p in pts:
                f(p)
            t[name].append((time.perf_counter() - t0) / len(pts))
    return {"n_dof": pb.n_dof, "harmonics": pb.nS,
            "old ms": statistics.median(t["old"]) * 1e3,
            "new ms": statistics.median(t["new"]) * 1e3, "max_rel_diff": diff}


# ------------------------------------------------------------------ main
def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--baseline", help="git revision of the old code")
    ap.add_argument("--points", type=int, default=12000)
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--child", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        child(args.child, args.points)
        return 0
    if not args.baseline:
        ap.error("--baseline is required")
    from benchmarks.common import write_json

    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    work = Path(tempfile.mkdtemp(prefix="bench_continuation_"))
    old_tree = work / "old"
    old_tree.mkdir()
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", args.baseline],
                             check=True, capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(old_tree)], input=archive, check=True)
    rev = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short=12", "HEAD"],
                         capture_output=True, text=True, check=True).stdout.strip()
    trees = {"old": old_tree, "new": ROOT}
    load = [os.getloadavg()[0]]
    runs: dict[str, list[dict]] = {"old": [], "new": []}
    for r in range(args.repeats):
        for k in (("old", "new") if r % 2 == 0 else ("new", "old")):
            runs[k].append(_run_child(trees[k], work / f"{k}_{r}.npz", args.points))
            LOG.info("round %d %s: %d points in %.1f s", r, k, runs[k][-1]["rpm"].size,
                     float(runs[k][-1]["wall"]))
            load.append(os.getloadavg()[0])
    a, b = runs["old"][0], runs["new"][0]
    same = all(np.array_equal(a[k], b[k]) for k in ("rpm", "unknowns", "tangents", "folds",
                                                   "grazing", "iterations", "loops"))
    wall = {k: statistics.median(float(x["wall"]) for x in v) for k, v in runs.items()}
    per_point = []
    for at in AT:
        old = [_per_point(x["stamps"], at) for x in runs["old"]]
        new = [_per_point(x["stamps"], at) for x in runs["new"]]
        if None in old or None in new:
            continue
        o, n = statistics.median(old), statistics.median(new)
        its = float(np.mean(b["iterations"][max(at - WINDOW, 0):at]))
        per_point.append([at, f"{o:.3f}", f"{n:.3f}", f"{o / n:.2f}", f"{its:.2f}"])
    rows = replay(work / "new_0.npz", 5)
    rec = recovery(5)
    load.append(os.getloadavg()[0])
    at10k = next((r for r in rows if r["point"] == 10000), rows[-1])
    summary = (
        f"{int(a['rpm'].size)}-point lumped branch (Geared3, 12 harmonics, a fold and a "
        f"grazing point), old {args.baseline} against new {rev}, {args.repeats} "
        f"interleaved runs each: trace {wall['old']:.1f} s old, {wall['new']:.1f} s new "
        f"({wall['old'] / wall['new']:.2f}x), branches bitwise the same: {same}. "
        f"Bookkeeping of point {at10k['point']} (distance test + the branch handed to "
        f"on_point): {at10k['old total']:.2f} ms old, {at10k['new total']:.3f} ms new. "
        f"recover on a {rec['n_dof']}-DOF ROM with {rec['harmonics']} harmonics: "
        f"{rec['old ms']:.2f} ms old, {rec['new ms']:.2f} ms new "
        f"({rec['old ms'] / rec['new ms']:.2f}x, coordinates within "
        f"{rec['max_rel_diff']:.1e} of their largest). 1-minute load "
        f"{min(load):.1f}-{max(load):.1f} on the shared 2-core machine.")
    LOG.info(summary)
    write_json("continuation", {
        "command": f"python -m benchmarks.bench_continuation --baseline {args.baseline} "
                   f"--points {args.points} --repeats {args.repeats}",
        "summary": summary,
        "headline": {
            f"bookkeeping per point at point {at10k['point']}, old/new":
                at10k["old total"] / at10k["new total"],
            f"{int(a['rpm'].size)}-point lumped branch, trace time old/new":
                wall["old"] / wall["new"],
            "recover per point (pump-sized ROM), old/new": rec["old ms"] / rec["new ms"]},
        "revisions": {"old": args.baseline, "new": rev}, "branches_identical": same,
        "load": load, "recover": rec,
        "tables": [
            {"title": "time per point of the long branch at point k (ms, median of the "
                      f"{WINDOW} points before k, no on_point)",
             "columns": ["k", "old", "new", "old/new", "corrector iterations (mean)"],
             "rows": per_point},
            {"title": "bookkeeping of point k, replayed (ms, medians): distance test and "
                      "branch handed to on_point",
             "columns": ["k", "scan old", "scan new", "branch old", "branch new",
                         "old total", "new total"],
             "rows": [[r["point"], *(f"{r[c]:.3f}" for c in ("scan old", "scan new",
                                                              "branch old", "branch new",
                                                              "old total", "new total"))]
                      for r in rows]},
            {"title": "HBMProblem.recover per point (ms, medians)",
             "columns": ["DOF", "harmonics", "old", "new", "old/new", "max rel. diff"],
             "rows": [[rec["n_dof"], rec["harmonics"], f"{rec['old ms']:.2f}",
                       f"{rec['new ms']:.2f}", f"{rec['old ms'] / rec['new ms']:.2f}",
                       f"{rec['max_rel_diff']:.1e}"]]}]})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
