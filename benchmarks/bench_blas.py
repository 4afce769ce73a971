"""BLAS benchmark: Debian's reference BLAS/LAPACK against the system default
(OpenBLAS once ``libopenblas0-pthread`` is installed), 1 and 2 threads, measured
side by side in the same run on dense kernels and on the project's workloads.

NumPy, SciPy and PETSc come from Debian and link ``libblas.so.3`` /
``liblapack.so.3``, which ``update-alternatives`` resolves to the provider with
the highest priority. Every workload runs in its own subprocess
(``--worker NAME``) under three environments:

* ``reference``: ``LD_LIBRARY_PATH`` puts Debian's reference
  ``/usr/lib/x86_64-linux-gnu/{blas,lapack}`` first, whatever the alternative;
* ``default 1t`` / ``default 2t``: the alternative as installed, with
  ``OPENBLAS_NUM_THREADS`` (and ``OMP_NUM_THREADS``) = 1 and 2.

The worker reports which BLAS/LAPACK it actually loaded (``/proc/self/maps``) and
the thread count OpenBLAS runs with, so the labels are checked, not assumed.
Variants are interleaved in rounds (the machine is shared); each figure is the
median over every repeat of every round. A scalar of each result is compared
between variants (the answers agree to rounding, not bit for bit).

Workloads: dense ``A @ B`` n=1000; LU solve (``numpy.linalg.solve``) n=575 (the
pump HBM Newton matrix at 12 mesh harmonics) and n=2000; ``scipy.linalg.eig``
n=500; one HBM Newton point (from the 0.99 x speed solution, as a continuation
step) on the SDOF scene and on the coarse pump ROM (n_CM=100) with 3 and 12 mesh
harmonics; ``hbm.stability.stability`` (monodromy, T.10) at three pump speeds;
a small Craig-Bampton reduction (PETSc/SLEPc, elastic box).

Run: ``.venv/bin/python -m benchmarks.bench_blas [--quick] [--rounds 3] [--repeats 5]``.
Writes ``benchmarks/results/blas.json`` (atomically). The pump ROMs come from the
pipeline's stage cache (built on first use, about a minute).
"""
from __future__ import annotations

import argparse
import ctypes
import json
import logging
import os
import statistics
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.common import peak_rss_mb, write_json

log = logging.getLogger("bench_blas")
ROOT = Path(__file__).resolve().parents[1]
LIBDIR = Path("/usr/lib/x86_64-linux-gnu")
REFERENCE_PATH = f"{LIBDIR / 'blas'}:{LIBDIR / 'lapack'}"
WORK = Path("/tmp/geardyn-bench-blas")
PUMP_SPEEDS = (852.0, 1200.0, 2218.0)  # rpm; issue 13's check speeds


def variants() -> dict[str, dict[str, str]]:
    """Environment overrides of each BLAS variant (``LD_LIBRARY_PATH`` '' = unset)."""
    return {
        "reference": {"LD_LIBRARY_PATH": REFERENCE_PATH, "OPENBLAS_NUM_THREADS": "1",
                      "OMP_NUM_THREADS": "1"},
        "default 1t": {"LD_LIBRARY_PATH": "", "OPENBLAS_NUM_THREADS": "1",
                       "OMP_NUM_THREADS": "1"},
        "default 2t": {"LD_LIBRARY_PATH": "", "OPENBLAS_NUM_THREADS": "2",
                       "OMP_NUM_THREADS": "2"},
    }


# --------------------------------------------------------------------- worker side


def loaded_blas() -> dict[str, Any]:
    """BLAS/LAPACK shared objects mapped into this process, and OpenBLAS's thread count."""
    libs = set()
    with open("/proc/self/maps") as fh:
        for line in fh:
            path = line.split()[-1]
            name = os.path.basename(path)
            if path.startswith("/") and name.startswith(("libblas", "liblapack", "libopenblas")):
                libs.add(os.path.realpath(path))
    threads = None
    for lib in sorted(libs):
        if "openblas" in lib:
            try:
                threads = int(ctypes.CDLL(lib).openblas_get_num_threads())
            except (OSError, AttributeError):
                pass
    return {"libraries": sorted(libs), "openblas_threads": threads}


def _rng() -> np.random.Generator:
    return np.random.default_rng(20240613)


def _matmul(n: int):
    a, b = _rng().standard_normal((2, n, n))
    return lambda: float(np.linalg.norm(a @ b)), 2.0 * n ** 3


def _solve(n: int):
    rng = _rng()
    a = rng.standard_normal((n, n)) + n ** 0.5 * np.eye(n)
    b = rng.standard_normal(n)
    return lambda: float(np.linalg.norm(np.linalg.solve(a, b))), 2.0 / 3.0 * n ** 3


def _eig(n: int):
    import scipy.linalg as sla

    a = _rng().standard_normal((n, n))
    return lambda: float(np.max(np.abs(sla.eig(a, right=True)[0]))), None


def _hbm_point(pb, rpm: float):
    prev = pb.solve(0.99 * rpm, tol=1e-8)
    prev = pb.solve(0.99 * rpm, x0=prev.unknowns, tol=1e-8)

    def run() -> float:
        pt = pb.solve(rpm, x0=prev.unknowns, tol=1e-8)
        return float(np.linalg.norm(pt.unknowns))
    return run, None


def _sdof():
    from benchmarks.bench_hbm import sdof_problem

    pb, _ = sdof_problem(12)
    return _hbm_point(pb, 1650.0)


def _pump(h: int):
    from benchmarks.bench_hbm import pump_problem
    from benchmarks.bench_verify import DEFAULT_CACHE

    pb, _ = pump_problem(100, h, DEFAULT_CACHE, WORK)
    return pb


def _stability():
    from hbm.stability import stability

    pb = _pump(3)
    points = []
    x0 = None
    for rpm in PUMP_SPEEDS:
        pt = pb.solve(0.99 * rpm, x0=x0, tol=1e-8)
        pt = pb.solve(rpm, x0=pt.unknowns, tol=1e-8)
        points.append(pt)
        x0 = pt.unknowns

    def run() -> float:
        return float(sum(stability(pb, pt).max_real for pt in points))
    return run, None


def _craig_bampton():
    from reduction import craig_bampton
    from reduction.models import elastic_box

    model = elastic_box(size=(0.3, 0.04, 0.04), cells=(16, 3, 3), clamped=True)

    def run() -> float:
        cb = craig_bampton(model.M, model.K, model.interface_dofs, n_modes=40)
        hz = float(cb.fixed_interface_hz[-1])
        cb.T.destroy()
        return hz
    return run, None


# name -> (description, builder returning (callable -> checksum, flop count or None))
WORKLOADS: dict[str, tuple[str, Callable[[], tuple[Callable[[], float], float | None]]]] = {
    "matmul 1000": ("A @ B, n=1000", lambda: _matmul(1000)),
    "solve 575": ("numpy.linalg.solve (LU), n=575", lambda: _solve(575)),
    "solve 2000": ("numpy.linalg.solve (LU), n=2000", lambda: _solve(2000)),
    "eig 500": ("scipy.linalg.eig (nonsymmetric, vectors), n=500", lambda: _eig(500)),
    "HBM SDOF H=12": ("Newton point 1650 rpm, SDOF scene, 12 mesh harmonics", _sdof),
    "HBM pump H=3": ("Newton point 1200 rpm, pump ROM n_CM=100, 3 mesh harmonics",
                     lambda: _hbm_point(_pump(3), 1200.0)),
    "HBM pump H=12": ("Newton point 1200 rpm, pump ROM n_CM=100, 12 mesh harmonics",
                      lambda: _hbm_point(_pump(12), 1200.0)),
    "stability pump x3": ("hbm.stability.stability at 852, 1200, 2218 rpm (pump H=3)",
                          _stability),
    "Craig-Bampton": ("craig_bampton, elastic box 16x3x3 cells, 40 modes", _craig_bampton),
}
QUICK = ["matmul 1000", "solve 575", "eig 500", "HBM SDOF H=12", "HBM pump H=3"]


def worker(name: str, repeats: int) -> dict[str, Any]:
    """Time one workload in this process: warm-up, then ``repeats`` timed runs."""
    build = WORKLOADS[name][1]
    logging.disable(logging.INFO)  # the workloads' own progress logs
    func, flops = build()
    check = func()  # warm-up
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        check = func()
        times.append(time.perf_counter() - t0)
    return {"times": times, "check": check, "flops": flops, **loaded_blas()}


# --------------------------------------------------------------------- driver side


def run_worker(name: str, variant: str, repeats: int) -> dict[str, Any]:
    """Run one workload in a subprocess under ``variant``'s environment."""
    env = dict(os.environ)
    for key, value in variants()[variant].items():
        if value:
            env[key] = value
        else:
            env.pop(key, None)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))
    cmd = [sys.executable, "-m", "benchmarks.bench_blas", "--worker", name,
           "--repeats", str(repeats)]
    out = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True, check=False)
    if out.returncode != 0:
        raise RuntimeError(f"worker {name!r} ({variant}) failed:\n{out.stderr[-3000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def _kind(libs: list[str]) -> str:
    """Short name of the BLAS a worker loaded."""
    if any("openblas" in lib for lib in libs):
        return "OpenBLAS"
    if any(lib.startswith(str(LIBDIR / "blas")) for lib in libs):
        return "reference"
    return "other"


def measure(names: list[str], rounds: int, repeats: int) -> list[dict[str, Any]]:
    """Every workload under every variant, variants interleaved in ``rounds``."""
    vs = list(variants())
    recs = []
    for name in names:
        runs: dict[str, list[dict]] = {v: [] for v in vs}
        for r in range(rounds):
            order = vs[r % len(vs):] + vs[:r % len(vs)]  # rotate who goes first
            for v in order:
                runs[v].append(run_worker(name, v, repeats))
        rec: dict[str, Any] = {"workload": name, "description": WORKLOADS[name][0]}
        checks = []
        for v in vs:
            times = [t for run in runs[v] for t in run["times"]]
            med = statistics.median(times)
            first = runs[v][0]
            rec[v] = {"median_s": med, "min_s": min(times), "n": len(times),
                      "blas": _kind(first["libraries"]), "libraries": first["libraries"],
                      "openblas_threads": first["openblas_threads"]}
            if first["flops"]:
                rec[v]["gflops"] = first["flops"] / med / 1e9
            checks.append(first["check"])
        ref = rec["reference"]["median_s"]
        for v in vs[1:]:
            rec[v]["speedup"] = ref / rec[v]["median_s"]
        scale = max(abs(c) for c in checks) or 1.0
        rec["check_rel_diff"] = max(abs(c - checks[0]) for c in checks) / scale
        log.info("%-18s %s", name, "  ".join(
            f"{v}: {rec[v]['median_s'] * 1e3:.1f} ms ({rec[v]['blas']})" for v in vs)
            + f"  check diff {rec['check_rel_diff']:.1e}")
        recs.append(rec)
    return recs


def table(recs: list[dict]) -> dict[str, Any]:
    cols = ["workload", "reference ms", "default BLAS", "1 thread ms", "speed-up 1t",
            "2 threads ms", "speed-up 2t", "GFLOP/s ref / 1t / 2t", "result rel. diff"]
    rows = []
    for r in recs:
        ref, d1, d2 = r["reference"], r["default 1t"], r["default 2t"]
        gf = ("-" if "gflops" not in ref else
              f"{ref['gflops']:.1f} / {d1['gflops']:.1f} / {d2['gflops']:.1f}")
        rows.append([r["workload"], ref["median_s"] * 1e3, d1["blas"], d1["median_s"] * 1e3,
                     f"{d1['speedup']:.2f}x", d2["median_s"] * 1e3,
                     f"{d2['speedup']:.2f}x", gf, f"{r['check_rel_diff']:.1e}"])
    return {"title": "reference BLAS/LAPACK against the default alternative, 1 and 2 threads "
                     "(median ms; speed-up = reference / variant, same run)",
            "columns": cols, "rows": rows}


def alternatives() -> dict[str, str]:
    """Where ``libblas.so.3`` / ``liblapack.so.3`` point (update-alternatives)."""
    return {name: os.path.realpath(LIBDIR / name) for name in ("libblas.so.3", "liblapack.so.3")}


def main(argv: list[str] | None = None) -> dict | None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help=f"only {', '.join(QUICK)}; 1 round")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--only", default="", help="comma-separated workload names")
    ap.add_argument("--worker", default=None, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.repeats < 1 or args.rounds < 1:
        raise ValueError(f"--repeats = {args.repeats}, --rounds = {args.rounds}: must be >= 1")
    if args.worker is not None:
        if args.worker not in WORKLOADS:
            raise ValueError(f"--worker = {args.worker!r}: not in {list(WORKLOADS)}")
        print(json.dumps(worker(args.worker, args.repeats)))
        return None
    logging.basicConfig(level=logging.INFO, format="%(name)s: %(message)s")
    names = QUICK if args.quick else list(WORKLOADS)
    if args.only:
        names = [n.strip() for n in args.only.split(",")]
        unknown = set(names) - set(WORKLOADS)
        if unknown:
            raise ValueError(f"--only: {sorted(unknown)} not in {list(WORKLOADS)}")
    rounds = 1 if args.quick else args.rounds
    t0 = time.perf_counter()
    load0 = os.getloadavg()
    # build the pump ROMs once (stage cache) before anything is timed
    if any("pump" in n for n in names):
        for h in (3, 12):
            _pump(h)
    recs = measure(names, rounds, args.repeats)
    load1 = os.getloadavg()
    cmd = (".venv/bin/python -m benchmarks.bench_blas" + (" --quick" if args.quick else "")
           + f" --rounds {rounds} --repeats {args.repeats}")
    d1 = [r["default 1t"]["speedup"] for r in recs]
    d2 = [r["default 2t"]["speedup"] for r in recs]
    summary = (f"Debian's reference BLAS/LAPACK (forced with LD_LIBRARY_PATH) against the "
               f"default alternative ({', '.join(sorted(alternatives().values()))}), "
               f"OPENBLAS_NUM_THREADS=1 and 2, each workload in its own subprocess, "
               f"{rounds} interleaved rounds of {args.repeats} repeats after a warm-up. "
               f"Speed-up with 1 thread {min(d1):.2f}x to {max(d1):.2f}x, with 2 threads "
               f"{min(d2):.2f}x to {max(d2):.2f}x. Shared 2-core machine, load average "
               f"{load0[0]:.1f} at the start and {load1[0]:.1f} at the end: 2-thread figures "
               f"depend on what else runs.")
    payload = {"command": cmd, "summary": summary, "tables": [table(recs)], "records": recs,
               "alternatives": alternatives(), "load_average": [load0[0], load1[0]],
               "seconds": time.perf_counter() - t0, "peak_rss_mb": peak_rss_mb()}
    path = write_json("blas", payload)
    log.info("wrote %s", path)
    return payload


if __name__ == "__main__":
    main()
