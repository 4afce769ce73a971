"""Run every benchmark module, each in its own process, then regenerate BENCHMARKS.md.

Each ``benchmarks/bench_*.py`` runs as ``python -m benchmarks.<name>`` in a fresh
subprocess (so peak-memory figures and MPI/gmsh state do not leak between them),
with ``--quick`` passed through to the modules that accept it. A failing module
is reported and the others still run; ``benchmarks.report`` then renders
``benchmarks/results/*.json`` (the failed module keeps its previous JSON, if any).

Run: ``.venv/bin/python -m benchmarks.run_all [--quick] [--only hbm,verify] [--skip fem]``
(``make bench`` runs it without options). Exit code 1 if any module failed.
"""
from __future__ import annotations

import argparse
import logging
import os
import subprocess
import sys
import time
from pathlib import Path

log = logging.getLogger("run_all")
HERE = Path(__file__).resolve().parent
ROOT = HERE.parent


def modules() -> list[str]:
    """Benchmark module names (``bench_*.py``), sorted."""
    return sorted(p.stem for p in HERE.glob("bench_*.py"))


def accepts_quick(name: str) -> bool:
    """True if the module declares a ``--quick`` option."""
    return '"--quick"' in (HERE / f"{name}.py").read_text()


def run_module(name: str, quick: bool, timeout: float | None) -> dict:
    """Run one benchmark module in a subprocess; return its name, status and wall time."""
    cmd = [sys.executable, "-m", f"benchmarks.{name}"]
    if quick and accepts_quick(name):
        cmd.append("--quick")
    env = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1",
           "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT),
                                                       os.environ.get("PYTHONPATH")]))}
    log.info("running %s", " ".join(cmd[1:]))
    t0 = time.perf_counter()
    try:
        rc = subprocess.run(cmd, cwd=ROOT, env=env, timeout=timeout).returncode
    except subprocess.TimeoutExpired:
        rc = "timeout"
    dt = time.perf_counter() - t0
    log.info("%s: %s in %.0f s", name, "ok" if rc == 0 else f"FAILED ({rc})", dt)
    return {"module": name, "returncode": rc, "seconds": dt}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="pass --quick where supported")
    ap.add_argument("--only", default="", help="comma-separated module names (bench_ optional)")
    ap.add_argument("--skip", default="", help="comma-separated module names to skip")
    ap.add_argument("--timeout", type=float, default=None, help="per module (s)")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(name)s: %(message)s")
    names = modules()

    def norm(s: str) -> set[str]:
        return {n if n.startswith("bench_") else f"bench_{n}" for n in s.split(",") if n}
    only, skip = norm(args.only), norm(args.skip)
    unknown = (only | skip) - set(names)
    if unknown:
        raise ValueError(f"--only/--skip: {sorted(unknown)} not in {names}")
    chosen = [n for n in names if (not only or n in only) and n not in skip]
    results = [run_module(n, args.quick, args.timeout) for n in chosen]
    from benchmarks import report
    report.main()
    failed = [r["module"] for r in results if r["returncode"] != 0]
    for r in results:
        log.info("%-16s %-8s %6.0f s", r["module"],
                 "ok" if r["returncode"] == 0 else "FAILED", r["seconds"])
    if failed:
        log.error("failed: %s", ", ".join(failed))
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
