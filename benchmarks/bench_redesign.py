"""The pump's curve and export before and after a change of the code, in the same run.

Each version of the code (a git revision, checked out in a temporary worktree, and the
working tree) runs ``python -m study run SCENE`` in its own process with its own stage
cache. The mesh and ROM stages are computed once per version (a warm-up run); before each
counted run the version's hbm cache entries are removed, so every counted run traces the
whole curve with stability (hbm stage) and writes every output (export stage). The two
versions alternate (A B A B ...), and the ratio new / old is taken pair by pair, so a
comparison holds while the shared machine's speed drifts. Stage times are read from the
``stage <name> ran in <s> s`` lines the pipeline logs.

Run (one heavy run at a time; ~4 min per pair on the pump)::

    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 .venv/bin/python -m benchmarks.bench_redesign \\
        --baseline <revision> [--repeats 3] [--scene scenes/pump.toml] [--name redesign]

``--cache-from DIR`` links the mesh and ROM entries of an existing stage cache into both
versions' caches instead of the warm-up runs (the first counted run of each version
then also compiles its bytecode). ``--export-only`` keeps each version's hbm cache:
every counted run is then the export stage alone (a finer ratio of the export, a few
minutes; no hbm time).

Writes ``benchmarks/results/<name>.json`` (rendered into BENCHMARKS.md by
``benchmarks.report``). Also checks that both versions wrote the same ``results.h5``
numbers (largest relative difference over the datasets both files hold).
"""
from __future__ import annotations

import argparse
import logging
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from benchmarks.common import write_json

LOG = logging.getLogger(__name__)
ROOT = Path(__file__).resolve().parents[1]
STAGE_LINE = re.compile(r"stage (\w+)\s+(ran|resumed) in ([0-9.]+) s")


def revision(tree: Path) -> str:
    """The commit of a checkout (with ``+dirty`` when its tracked files changed)."""
    rev = subprocess.run(["git", "-C", str(tree), "rev-parse", "--short=12", "HEAD"],
                         capture_output=True, text=True, check=True).stdout.strip()
    dirty = subprocess.run(["git", "-C", str(tree), "status", "--porcelain",
                            "--untracked-files=no"], capture_output=True, text=True,
                           check=True).stdout.strip()
    return rev + ("+dirty" if dirty else "")


def run_scene(tree: Path, scene: str, out: Path, cache: Path) -> dict[str, float]:
    """``python -m study run`` of ``tree``'s code; the stage times it logged (s) and the
    wall time of the whole process (``total``)."""
    env = dict(os.environ, PYTHONPATH=str(tree), OMP_NUM_THREADS="1",
               OPENBLAS_NUM_THREADS="1")
    cmd = [sys.executable, "-m", "study", "run", str(tree / scene), "--out", str(out),
           "--cache", str(cache), "--no-progress"]
    t = time.perf_counter()
    proc = subprocess.run(cmd, cwd=tree, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} (in {tree}) exited {proc.returncode}:\n"
                           f"{proc.stderr[-3000:]}")
    times = {m.group(1): float(m.group(3)) for m in STAGE_LINE.finditer(proc.stderr)}
    times["total"] = wall
    return times


def link_stages(source: Path, cache: Path, stages: tuple[str, ...]) -> None:
    """Hard-link the entries of ``stages`` of the cache ``source`` into ``cache`` (no
    copy of the ROM's gigabytes; the entries are only read)."""
    for stage in stages:
        if (source / stage).is_dir() and not (cache / stage).exists():
            cache.mkdir(parents=True, exist_ok=True)
            subprocess.run(["cp", "-al", str(source / stage), str(cache / stage)],
                           check=True)


def drop_hbm(cache: Path) -> None:
    """Remove the hbm stage's entries of a cache (the ROM stays)."""
    shutil.rmtree(cache / "hbm", ignore_errors=True)


def largest_difference(old: Path, new: Path) -> float:
    """Largest relative difference over the numeric datasets both results.h5 hold."""
    import h5py

    worst = 0.0
    with h5py.File(old, "r") as fo, h5py.File(new, "r") as fn:
        names: list[str] = []
        fo.visititems(lambda n, o: names.append(n) if isinstance(o, h5py.Dataset) else None)
        for n in names:
            if n not in fn:
                continue
            a, b = np.asarray(fo[n][()]), np.asarray(fn[n][()])
            if a.dtype.kind not in "biufc" or a.shape != b.shape or a.size == 0:
                continue
            scale = max(float(np.max(np.abs(a))), 1e-300)
            worst = max(worst, float(np.max(np.abs(a.astype(complex) - b.astype(complex))))
                        / scale)
    return worst


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--baseline", required=True, help="git revision of the old code")
    ap.add_argument("--new", default=None, help="git revision of the new code (default: "
                    "this working tree; a revision is checked out apart, so that editing "
                    "the tree during the run changes nothing)")
    ap.add_argument("--scene", default="scenes/pump.toml")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--name", default="redesign")
    ap.add_argument("--export-only", action="store_true",
                    help="keep each version's hbm cache: every counted run is the export "
                         "stage alone (a finer ratio of the export; no hbm time)")
    ap.add_argument("--work", default=None, help="folder for worktree, caches, outputs")
    ap.add_argument("--cache-from", default=None,
                    help="a stage cache holding this scene's mesh and ROM (both versions "
                         "must build the same ROM key): linked into each version's cache "
                         "instead of the warm-up runs (the pump's converged ROM takes "
                         "minutes)")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    work = Path(args.work or tempfile.mkdtemp(prefix="bench_redesign_"))
    old_tree = work / "old"
    if not old_tree.exists():
        subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(old_tree),
                        args.baseline], check=True, capture_output=True)
    new_tree = ROOT if args.new is None else work / "new"
    if args.new is not None and not new_tree.exists():
        subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(new_tree),
                        args.new], check=True, capture_output=True)
    trees = {"old": old_tree, "new": new_tree}
    revs = {k: revision(t) for k, t in trees.items()}
    load_start = os.getloadavg()[0]
    caches = {k: work / f"cache_{k}" for k in trees}
    for k, tree in trees.items():                 # mesh and ROM once per version
        if args.cache_from:
            link_stages(Path(args.cache_from), caches[k], ("mesh", "rom"))
            if not args.export_only:              # (export-only needs the hbm entry)
                continue
        LOG.info("warm-up %s (%s)", k, revs[k])
        run_scene(tree, args.scene, work / f"warm_{k}", caches[k])
    stages = ("export", "total") if args.export_only else ("hbm", "export", "total")
    rows, ratios = [], {s: [] for s in stages}
    share: dict[str, list[float]] = {"old": [], "new": []}     # export / hbm, same process
    for r in range(args.repeats):
        pair = {}
        for k in (("old", "new") if r % 2 == 0 else ("new", "old")):
            if not args.export_only:
                drop_hbm(caches[k])
            out = work / f"run_{k}_{r}"
            shutil.rmtree(out, ignore_errors=True)
            pair[k] = run_scene(trees[k], args.scene, out, caches[k])
            LOG.info("round %d %s: %s", r, k, pair[k])
        for s in ratios:
            ratios[s].append(pair["new"][s] / pair["old"][s])
        if not args.export_only:
            for k in share:
                share[k].append(pair[k]["export"] / pair[k]["hbm"])
        rows.append([r, *(f"{pair[k][s]:.1f}" for s in stages for k in ("old", "new"))])
    diff = largest_difference(work / "run_old_0" / "results.h5",
                              work / "run_new_0" / "results.h5")
    med = {s: statistics.median(v) for s, v in ratios.items()}
    load_end = os.getloadavg()[0]
    what = ("the export stage alone (hbm cached per version)" if args.export_only else
            "the whole curve with stability (hbm stage) and the export")
    summary = (f"{args.scene}: {what}, old {revs['old']} against new {revs['new']}, "
               f"{args.repeats} interleaved pairs "
               + ("(mesh and ROM linked from one cache)" if args.cache_from else
                  "after a warm-up (mesh and ROM cached per version)")
               + ". Median ratio new/old: "
               + ", ".join(f"{'whole run' if s == 'total' else s} {med[s]:.2f}"
                           for s in stages))
    headline = {f"{s} new/old" + (" (export only)" if args.export_only else ""): med[s]
                for s in stages if s != "total"}
    extra_cols, extra = [], []
    if not args.export_only:
        med_share = {k: statistics.median(v) for k, v in share.items()}
        summary += (f"; export / hbm of the same run: old {med_share['old']:.2f}, new "
                    f"{med_share['new']:.2f}")
        headline.update({"export/hbm old": med_share["old"],
                         "export/hbm new": med_share["new"]})
        extra_cols = ["export/hbm old", "export/hbm new"]
        extra = [f"{med_share['old']:.3f}", f"{med_share['new']:.3f}"]
    summary += (f". results.h5 largest relative difference {diff:.1e}. Load average (1 min) "
                f"{load_start:.1f} at the start, {load_end:.1f} at the end on "
                f"{os.cpu_count()} cores.")
    LOG.info(summary)
    names = {"hbm": "hbm", "export": "export", "total": "run"}
    write_json(args.name, {
        "command": f"python -m benchmarks.bench_redesign --baseline {args.baseline} "
                   + (f"--new {args.new} " if args.new else "")
                   + f"--repeats {args.repeats} --scene {args.scene}"
                   + (" --export-only" if args.export_only else "")
                   + (" --cache-from CACHE" if args.cache_from else ""),
        "summary": summary,
        "headline": headline,
        "revisions": revs, "ratios": ratios, "export_over_hbm": share,
        "results_max_rel_diff": diff, "load_average_start": load_start,
        "load_average_end": load_end,
        "tables": [{"title": "stage wall times per round (s)",
                    "columns": ["round", *(f"{names[s]} {k}" for s in stages
                                           for k in ("old", "new"))],
                    "rows": rows},
                   {"title": "median ratio new / old (pair by pair)"
                             + ("" if args.export_only else
                                " and export / hbm of each version (same run)"),
                    "columns": [("whole run" if s == "total" else s) for s in stages]
                    + extra_cols,
                    "rows": [[f"{med[s]:.3f}" for s in stages] + extra]}]})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
