"""Scaling of the FE pipeline (``geardyn reduce``: mesh → fe → rom) with the model size
and the number of MPI ranks: time per stage, peak memory per rank, fitted exponent.

Run: ``.venv/bin/python -m benchmarks.bench_scale [--sizes coarse,0.0115] [--ranks 1,2]
[--n-cm 100] [--repeats 1] [--petsc-options OPTS]``. A size is a mesh preset name or a
``mesh.size`` in m (fine preset otherwise). Each case runs in its own process
(``mpirun -n R`` for R > 1) through the same pipeline as ``geardyn reduce`` with a fresh
cache, so every stage runs and the peak resident memory of each rank (VmHWM) is that
case's own. The ROM validation against the full eigen-solve is switched off
(``rom.n_check = 0``): the table is about the reduction. ``--petsc-options`` passes
PETSc/SLEPc/MUMPS options to the cases through ``PETSC_OPTIONS`` (Craig–Bampton prefix
``cb_``, e.g. ``-cb_st_mat_mumps_icntl_35 1``); such a case is kept apart from the
default one and compared with it (largest relative difference of the fixed-interface
frequencies). ``--calculix`` adds, per size, CalculiX ``*FREQUENCY`` (C3D10, n_CM modes)
against the project's eigen-solve on the same pump mesh, each in its own process
(:mod:`benchmarks.ccx_compare`; housing feet and the two gear hubs clamped: the fixed
interface, without the bearing springs and rigid links the deck writer cannot express).
Writes ``benchmarks/results/scale.json`` (atomically); cases already in the file and
not rerun are kept.
"""
from __future__ import annotations

import argparse
import json
import logging
import math
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from benchmarks.common import RESULTS, write_json

log = logging.getLogger("bench_scale")
ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "scenes" / "pump.toml"


def _vm_mib(field: str = "VmHWM") -> float:
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(field + ":"):
                return int(line.split()[1]) / 1024.0
    return float("nan")


def _vm_hwm_mib() -> float:
    return _vm_mib("VmHWM")


def _overrides(size: str, n_cm: int, factorization: str = "lu",
               out_of_core: bool = False) -> dict:
    ov = {"rom.n_cm": n_cm, "rom.n_check": 0, "rom.factorization": factorization,
          "rom.out_of_core": out_of_core}
    if size in ("coarse", "fine", "million"):
        ov["mesh.preset"] = size
    else:
        ov["mesh.preset"] = "fine"
        ov["mesh.size"] = float(size)
    return ov


class _StageTimes(logging.Handler):
    """Collects ``stage NAME ran in X s`` records of study.pipeline."""

    def __init__(self) -> None:
        super().__init__(logging.INFO)
        self.seconds: dict[str, float] = {}

    def emit(self, record: logging.LogRecord) -> None:
        if record.msg.startswith("stage ") and record.args and len(record.args) >= 3:
            name, how, extra = record.args[:3]
            if how == "ran" and extra.startswith(" in "):
                self.seconds[name] = float(extra.split()[1])


def case(size: str, n_cm: int, out: Path, factorization: str = "lu",
         out_of_core: bool = False) -> None:
    """One ``reduce`` in this process (one rank of mpirun, or serial)."""
    import reduction
    import study
    from study.pipeline.parallel import world

    comm = world()
    times = _StageTimes()
    logging.getLogger("study.pipeline").addHandler(times)
    logging.getLogger("study.pipeline").setLevel(logging.INFO)
    phases: dict = {}
    cb0 = reduction.craig_bampton

    def cb(*a, **k):
        # memory of this rank (MiB): resident before the reduction (mesh + FE model),
        # peak up to its end (VmHWM), resident after it (+ T, M_r, K_r)
        phases["memory_mib"] = {"rss_before_rom": _vm_mib("VmRSS"),
                                "hwm_before_rom": _vm_mib("VmHWM")}
        r = cb0(*a, **k)
        phases["memory_mib"].update(hwm_after_cb=_vm_mib("VmHWM"),
                                    rss_after_cb=_vm_mib("VmRSS"))
        phases.update(r.timings)
        phases["factor"] = r.factor_stats
        return r
    reduction.craig_bampton = cb                 # machines.rom imports it at call time
    tmp = Path(tempfile.mkdtemp(prefix="bench_scale.")) if comm.rank == 0 else None
    tmp = comm.bcast(tmp)
    load_start = os.getloadavg()[0]
    t0 = time.perf_counter()
    study.run(SCENE, tmp / "out", overrides=_overrides(size, n_cm, factorization, out_of_core),
              cache_dir=tmp / "cache",
              refresh=True, until="rom")
    wall = time.perf_counter() - t0
    peaks = [_vm_hwm_mib()] if comm.size == 1 else comm.mpi.allgather(_vm_hwm_mib())
    ru = resource.getrusage(resource.RUSAGE_SELF)
    cpu = [ru.ru_utime + ru.ru_stime]
    cpu = cpu if comm.size == 1 else comm.mpi.allgather(cpu[0])
    if comm.rank == 0:
        import h5py
        with h5py.File(tmp / "out" / "rom.h5", "r") as f:
            n_dof = int(f["rom/basis"].shape[0])
            f_hz = [float(v) for v in f["rom/fixed_interface_hz"][:]]
            rom_hz = [float(v) for v in f["rom/frequencies_hz"][:20]]
        rec = {"size": size, "ranks": comm.size, "n_dof": n_dof, "n_cm": n_cm,
               "mesh_s": times.seconds.get("mesh"), "fe_s": times.seconds.get("fe"),
               "rom_s": times.seconds.get("rom"),
               "eigensolve_s": phases.get("eigensolve"),
               "eigenvectors_s": phases.get("eigenvectors"),
               "static_modes_s": phases.get("static_modes"),
               "projection_s": phases.get("projection"), "wall_s": wall,
               "mumps_factor": phases.get("factor", {}),
               "memory_rank0_mib": phases.get("memory_mib", {}),
               "peak_rss_per_rank_mib": peaks, "peak_rss_max_rank_mib": max(peaks),
               "highest_fixed_interface_hz": f_hz[-1], "fixed_interface_hz": f_hz,
               "rom_frequencies_hz": rom_hz,
               "petsc_options": os.environ.get("PETSC_OPTIONS", ""),
               "factorization": factorization, "out_of_core": out_of_core,
               "load_avg_1min": [load_start, os.getloadavg()[0]],
               "cpu_s_per_rank": cpu}
        out.write_text(json.dumps(rec))
        shutil.rmtree(tmp, ignore_errors=True)


#: Surfaces clamped in the CalculiX comparison: the foundation and the fixed interface.
CCX_CLAMPS = ["housing/feet", "in/hub", "out/hub"]


def ccx_case(size: str, n_cm: int, out: Path) -> None:
    """CalculiX against the project's eigen-solve on the pump mesh of ``size`` (serial)."""
    import gmsh

    import geometry
    from benchmarks.ccx_compare import compare
    from machines.pump import fe_parameters
    from study.scene import load_scene

    sc = load_scene(SCENE, _overrides(size, n_cm))
    p = fe_parameters(sc.fe, sc.gear)
    load_start = os.getloadavg()[0]
    with geometry.gmsh_session():
        geometry.build_pump(p.pump, p.mesh)
        names = {gmsh.model.getPhysicalName(d, t) for d, t in gmsh.model.getPhysicalGroups(3)}
        mats = {k: v for k, v in p.materials.by_volume().items() if k in names}
        rec = compare(mats, CCX_CLAMPS, n_cm, factors=("lu", "cholesky"))
    rec.update({"size": size, "n_cm": n_cm, "clamps": CCX_CLAMPS,
                "load_avg_1min": [load_start, os.getloadavg()[0]]})
    out.write_text(json.dumps(rec))


def run_case(size: str, n_cm: int, ranks: int, timeout: float,
             petsc_options: str = "", kind: str = "--case",
             factorization: str = "lu", out_of_core: bool = False) -> dict | None:
    with tempfile.TemporaryDirectory() as d:
        out = Path(d) / "case.json"
        cmd = [sys.executable, "-m", "benchmarks.bench_scale", kind, size,
               "--n-cm", str(n_cm), "--case-out", str(out), "--factorization", factorization]
        cmd += ["--out-of-core"] if out_of_core else []
        if ranks > 1:
            cmd = ["mpirun", "--allow-run-as-root", "--oversubscribe", "-n", str(ranks)] + cmd
        env = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1",
               "OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
               "PYTHONPATH": str(ROOT), "PETSC_OPTIONS": petsc_options}
        try:
            p = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True,
                               timeout=timeout)
        except subprocess.TimeoutExpired:
            log.warning("size %s on %d rank(s): timed out after %.0f s", size, ranks, timeout)
            return None
        if p.returncode != 0 or not out.exists():
            log.warning("size %s on %d rank(s) failed (%d): %s", size, ranks, p.returncode,
                        p.stderr[-1500:])
            return None
        return json.loads(out.read_text())


def _median_record(recs: list[dict]) -> dict:
    rec = dict(recs[0])
    rec["repeats"] = len(recs)
    for k in ("mesh_s", "fe_s", "rom_s", "eigensolve_s", "static_modes_s", "wall_s",
              "peak_rss_max_rank_mib"):
        vals = [r[k] for r in recs if r.get(k) is not None]
        rec[k] = statistics.median(vals) if vals else None
    rec["peak_rss_per_rank_mib"] = [statistics.median(v) for v in
                                    zip(*(r["peak_rss_per_rank_mib"] for r in recs),
                                        strict=True)]
    return rec


def _key(c: dict) -> tuple:
    return c["size"], c["ranks"], c["n_cm"], variant(c)


def variant(c: dict) -> str:
    """How a case differs from the default eigen-solver ('' for the default)."""
    fac = c.get("factorization", "lu")
    return " ".join(x for x in (f"rom.factorization={fac}" if fac != "lu" else "",
                                "rom.out_of_core=true" if c.get("out_of_core") else "",
                                c.get("petsc_options", "")) if x)


def freq_diff(case: dict, cases: list[dict]) -> float | None:
    """Largest relative difference of ``case``'s fixed-interface frequencies from those of
    the default-options case of the same size and n_CM (same rank count first)."""
    if not variant(case) or "fixed_interface_hz" not in case:
        return None
    refs = [c for c in cases if not variant(c) and "fixed_interface_hz" in c
            and c["size"] == case["size"] and c["n_cm"] == case["n_cm"]]
    refs.sort(key=lambda c: c["ranks"] != case["ranks"])
    if not refs:
        return None
    return max(abs(a - b) / b for a, b in zip(case["fixed_interface_hz"],
                                               refs[0]["fixed_interface_hz"], strict=True))


def exponents(cases: list[dict]) -> list[dict]:
    """Least-squares exponent p of ``t ∝ n^p`` (rom stage and peak memory) per rank count,
    n_CM and variant (factorisation, out of core, PETSc options), over the sizes measured."""
    out = []
    groups = sorted({(c["ranks"], c["n_cm"], variant(c)) for c in cases})
    for ranks, n_cm, var in groups:
        cs = sorted((c for c in cases if c["ranks"] == ranks and c["n_cm"] == n_cm
                     and variant(c) == var and c.get("rom_s")),
                    key=lambda c: c["n_dof"])
        if len(cs) < 2:
            continue
        row = {"ranks": ranks, "n_cm": n_cm, "variant": var, "sizes": len(cs),
               "n_dof_min": cs[0]["n_dof"], "n_dof_max": cs[-1]["n_dof"]}
        for key in ("rom_s", "eigensolve_s", "wall_s", "peak_rss_max_rank_mib"):
            xs = [math.log(c["n_dof"]) for c in cs]
            ys = [math.log(c[key]) for c in cs]
            mx, my = statistics.fmean(xs), statistics.fmean(ys)
            row[f"exponent_{key}"] = sum((x - mx) * (y - my) for x, y in zip(xs, ys, strict=True)) \
                / sum((x - mx) ** 2 for x in xs)
        out.append(row)
    return out


def _factor_cells(c: dict, factor: str) -> list:
    """CPU time and its ratio to CalculiX of the project's eigen-solve with ``factor``
    (blank when not measured)."""
    b = c.get("by_factor", {}).get(factor)
    return [b["cpu_s"], b["cpu_s"] / c["ccx_cpu_s"]] if b else ["", ""]


def ccx_rows(ccx: list[dict], cases: list[dict]) -> list[list]:
    """Rows of the CalculiX table, with the serial ``geardyn reduce`` of the same size and
    n_CM (rom stage) beside it."""
    rows = []
    for c in ccx:
        red = [r for r in cases if r["size"] == c["size"] and r["n_cm"] == c["n_cm"]
               and r["ranks"] == 1 and not variant(r)]
        rom = red[0]["rom_s"] if red else None
        rows.append([c["size"], c["n_dof"], c["n_modes"], c["ccx_s"], c["ccx_peak_rss_mib"],
                     c["slepc_s"], c["slepc_peak_extra_rss_mib"], c["slepc_s"] / c["ccx_s"],
                     c.get("slepc_cpu_s", ""), c.get("ccx_cpu_s", ""),
                     "" if "ccx_cpu_s" not in c else c["slepc_cpu_s"] / c["ccx_cpu_s"],
                     *_factor_cells(c, "cholesky"),
                     "" if rom is None else rom, "" if rom is None else rom / c["ccx_s"],
                     f"{c['max_rel_freq_diff_ccx']:.1e}",
                     ", ".join(f"{v:.1f}" for v in c.get("load_avg_1min", []))])
    return rows


def tables(cases: list[dict], fits: list[dict], ccx: list[dict] | None = None) -> list[dict]:
    cols = ["size", "ranks", "n_dof", "n_cm", "repeats", "mesh_s", "fe_s", "rom_s",
            "eigensolve_s", "static_modes_s", "wall_s", "peak_rss_max_rank_mib"]
    rows = [[c.get(k, "") for k in cols] + [
        ", ".join(f"{p:.0f}" for p in c["peak_rss_per_rank_mib"]),
        ", ".join(f"{p:.0f}" for p in c.get("cpu_s_per_rank", [])),
        ", ".join(f"{p:.1f}" for p in c.get("load_avg_1min", [])),
        variant(c), _fmt_diff(freq_diff(c, cases))] for c in cases]
    fcols = ["ranks", "n_cm", "variant", "sizes", "n_dof_min", "n_dof_max", "exponent_rom_s",
             "exponent_eigensolve_s", "exponent_wall_s", "exponent_peak_rss_max_rank_mib"]
    return [{"title": "geardyn reduce (mesh → fe → rom) against DOF and MPI ranks "
                      "(times in s, memory in MiB; rom.n_check = 0)",
             "columns": cols + ["peak_rss_per_rank_mib", "cpu_s_per_rank",
                                "load_avg_1min_start_end", "variant",
                                "max_rel_freq_diff_vs_default"], "rows": rows},
            {"title": "fitted exponents p of t ∝ n^p (least squares over the sizes run)",
             "columns": fcols, "rows": [[f.get(k, "") for k in fcols] for f in fits]},
            {"title": "CalculiX *FREQUENCY against the project on the same pump mesh and modes "
                      "(serial, 1 thread; clamps " + ", ".join(CCX_CLAMPS) + "; project = "
                      "SLEPc shift-invert + MUMPS on the same model; rom_s = the reduce row "
                      "of the same size and n_CM)",
             "columns": ["size", "n_dof", "n_modes", "ccx_s", "ccx_peak_rss_mib", "project_s",
                         "project_peak_extra_rss_mib", "project_over_ccx", "project_cpu_s",
                         "ccx_cpu_s", "project_over_ccx_cpu", "cholesky_cpu_s",
                         "cholesky_over_ccx_cpu", "rom_s",
                         "rom_over_ccx", "max_rel_freq_diff", "load_avg_1min_start_end"],
             "rows": ccx_rows(ccx or [], cases)}]


def _fmt_diff(d: float | None) -> str:
    return "" if d is None else f"{d:.1e}"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--sizes", default="coarse,0.0115")
    p.add_argument("--ranks", default="1,2")
    p.add_argument("--n-cm", type=int, default=100)
    p.add_argument("--repeats", type=int, default=1)
    p.add_argument("--petsc-options", default="",
                   help="PETSC_OPTIONS for every case, e.g. '-cb_st_mat_mumps_icntl_35 1'")
    p.add_argument("--timeout", type=float, default=900.0, help="per case (s)")
    p.add_argument("--factorization", default="lu", choices=("lu", "cholesky"),
                   help="rom.factorization of the reduce cases")
    p.add_argument("--out-of-core", action="store_true",
                   help="rom.out_of_core = true (MUMPS factor on disk in $MUMPS_OOC_TMPDIR)")
    p.add_argument("--calculix", action="store_true",
                   help="also CalculiX against the project's eigen-solve per size (serial)")
    p.add_argument("--no-reduce", action="store_true",
                   help="run no geardyn reduce case (e.g. only --calculix)")
    p.add_argument("--add-case", type=Path, default=None,
                   help="merge a case record written by '--case SIZE --case-out FILE' (e.g. a "
                        "size run once by hand under a memory watchdog) into scale.json")
    p.add_argument("--verbose", action="store_true", help="INFO logging in a --case run")
    p.add_argument("--case", default=None, help=argparse.SUPPRESS)
    p.add_argument("--ccx-case", default=None, help=argparse.SUPPRESS)
    p.add_argument("--case-out", type=Path, default=None, help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    quiet = args.case is not None and not args.verbose
    logging.basicConfig(level=logging.WARNING if quiet else logging.INFO,
                        format="%(asctime)s %(name)s: %(message)s", datefmt="%H:%M:%S")
    if args.case is not None:
        case(args.case, args.n_cm, args.case_out, args.factorization, args.out_of_core)
        return 0
    if args.ccx_case is not None:
        ccx_case(args.ccx_case, args.n_cm, args.case_out)
        return 0
    old_path = RESULTS / "scale.json"
    old_all = json.loads(old_path.read_text()) if old_path.exists() else {}
    old, old_ccx = old_all.get("cases", []), old_all.get("calculix", [])
    cases, ccx = [], []
    if args.add_case is not None:
        rec = json.loads(args.add_case.read_text())
        rec.setdefault("repeats", 1)
        cases.append(rec)
    for size in [] if args.add_case is not None else args.sizes.split(","):
        if args.calculix:
            rec = run_case(size, args.n_cm, 1, args.timeout * 4, kind="--ccx-case")
            if rec:
                log.info("%s: CalculiX %.1f s / %.0f MiB, project %.1f s (+%s MiB), %d DOF",
                         size, rec["ccx_s"], rec["ccx_peak_rss_mib"], rec["slepc_s"],
                         rec["slepc_peak_extra_rss_mib"], rec["n_dof"])
                ccx.append(rec)
        for ranks in [] if args.no_reduce else [int(r) for r in args.ranks.split(",")]:
            recs = [r for r in (run_case(size, args.n_cm, ranks, args.timeout,
                                         args.petsc_options,
                                         factorization=args.factorization,
                                         out_of_core=args.out_of_core)
                                for _ in range(args.repeats)) if r]
            if recs:
                rec = _median_record(recs)
                log.info("%s, %d rank(s): %d DOF, rom %.1f s, wall %.1f s, peak/rank %s MiB",
                         size, ranks, rec["n_dof"], rec["rom_s"], rec["wall_s"],
                         rec["peak_rss_per_rank_mib"])
                cases.append(rec)
    keep = [c for c in old if not any(_key(c) == _key(n) for n in cases)]
    cases = sorted(keep + cases, key=lambda c: (c["n_dof"], c["n_cm"],
                                                variant(c), c["ranks"]))
    ccx = sorted([c for c in old_ccx if not any((c["size"], c["n_cm"]) == (n["size"], n["n_cm"])
                                                for n in ccx)] + ccx,
                 key=lambda c: (c["n_dof"], c["n_cm"]))
    fits = exponents(cases)
    cmd = (".venv/bin/python -m benchmarks.bench_scale --sizes SIZES --ranks 1,2 "
           "--n-cm N_CM --repeats R [--petsc-options OPTS] (per row)")
    path = write_json("scale", {"command": cmd, "cases": cases, "fits": fits,
                                "calculix": ccx, "tables": tables(cases, fits, ccx),
                                "notes": "repeats = 1: a single run (the million "
                                         "preset, ~30 min per run, was not repeated; added "
                                         "with --add-case from a "
                                         "'--case million --out-of-core' run under a memory "
                                         "watchdog, docs/scale.md); load 1.4-4 from other "
                                         "engineers' jobs on the 2 cores"})
    log.info("wrote %s", path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
