"""Craig–Bampton benchmark: time and peak memory vs DOF count and n_CM, and the
fixed-interface eigensolve against ``scipy.sparse.linalg.eigsh`` (shift-invert σ=0)
and CalculiX; the pump presets (coarse, fine) serial and under ``mpirun -n 2``.

Run: ``.venv/bin/python -m benchmarks.bench_reduction [--quick] [--repeats N]
[--presets coarse,fine] [--n-cm 100]``.
Writes ``benchmarks/results/reduction.json`` (atomically). Each pump case runs in
its own process (``--pump-case PRESET --case-out FILE``; serial or under mpirun),
so its peak memory (sum over ranks of the peak RSS) is its own.
"""

from __future__ import annotations

import argparse
import json
import logging
import math
import os
import platform
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from benchmarks.common import reset_peak, status_kib
from core.files import atomic_write

log = logging.getLogger("bench_reduction")
OUT = Path(__file__).resolve().parent / "results" / "reduction.json"

SIZES = [(8, 2, 2), (16, 3, 3), (24, 4, 4), (32, 5, 5)]
SIZES_QUICK = [(8, 2, 2), (16, 3, 3)]
N_CMS = [10, 40, 100]
EIGSH_MAX_DOF = 15000  # eigsh comparison on small/medium sizes only


def _interior_scipy(M, K, iface):
    import scipy.sparse as sp
    from petsc4py import PETSc

    n = K.getSize()[0]
    keep = np.setdiff1d(np.arange(n), iface).astype(PETSc.IntType)
    is_i = PETSc.IS().createGeneral(keep)
    out = []
    for A in (K, M):
        S = A.createSubMatrix(is_i, is_i)
        ia, ja, a = S.getValuesCSR()
        out.append(sp.csr_matrix((a.copy(), ja.copy(), ia.copy()), shape=S.getSize()))
    return out


def bench_case(cells, n_cm, repeats):
    from reduction import craig_bampton
    from reduction.models import elastic_box

    model = elastic_box(size=(0.3, 0.04, 0.04), cells=cells, clamped=True)
    n = model.K.getSize()[0]
    if n_cm > n // 4:
        return None, model
    times, peaks, phases = [], [], []
    for _ in range(repeats):
        ok = reset_peak()
        base = status_kib("VmRSS")
        t0 = time.perf_counter()
        cb = craig_bampton(model.M, model.K, model.interface_dofs, n_modes=n_cm)
        times.append(time.perf_counter() - t0)
        peaks.append((status_kib("VmHWM") - base) / 1024.0 if ok else float("nan"))
        phases.append(cb.timings)
        cb.T.destroy()
    rec = {
        "cells": list(cells), "n_dof": n, "n_cm": n_cm, "repeats": repeats,
        "time_median_s": statistics.median(times),
        "eigensolve_median_s": statistics.median(p["eigensolve"] for p in phases),
        "static_modes_median_s": statistics.median(p["static_modes"] for p in phases),
        "projection_median_s": statistics.median(p["projection"] for p in phases),
        "peak_extra_rss_mib": statistics.median(peaks) if all(
            math.isfinite(p) for p in peaks) else None,
        "highest_fixed_interface_hz": float(cb.fixed_interface_hz[-1]),
    }
    log.info("n=%d n_cm=%d: %.3f s, peak +%s MiB", n, n_cm, rec["time_median_s"],
             rec["peak_extra_rss_mib"])
    return rec, model


def bench_eigsh(model, n_cm, repeats):
    """SLEPc (this package's settings) vs eigsh on the same K_ii, M_ii."""
    import scipy.sparse.linalg as spla
    from petsc4py import PETSc

    from reduction.craig_bampton import _make_eps

    n = model.K.getSize()[0]
    keep = np.setdiff1d(np.arange(n), model.interface_dofs).astype(PETSc.IntType)
    is_i = PETSc.IS().createGeneral(keep)
    K_ii = model.K.createSubMatrix(is_i, is_i)
    M_ii = model.M.createSubMatrix(is_i, is_i)
    Ks, Ms = _interior_scipy(model.M, model.K, model.interface_dofs)
    t_slepc, t_eigsh = [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        eps = _make_eps(K_ii, M_ii, 1e-10)
        eps.setDimensions(n_cm)
        eps.solve()
        lam_s = np.sort([eps.getEigenvalue(j).real for j in range(eps.getConverged())])[:n_cm]
        t_slepc.append(time.perf_counter() - t0)
        assert eps.getConvergedReason() > 0 or eps.getConverged() >= n_cm
        eps.destroy()
        t0 = time.perf_counter()
        lam_e = spla.eigsh(Ks, k=n_cm, M=Ms, sigma=0.0, which="LM", tol=1e-10,
                           return_eigenvectors=False)
        t_eigsh.append(time.perf_counter() - t0)
    lam_e = np.sort(lam_e)
    diff = float(np.max(np.abs(np.sqrt(lam_s) - np.sqrt(lam_e)) / np.sqrt(lam_e)))
    ts, te = statistics.median(t_slepc), statistics.median(t_eigsh)
    log.info("eigsh n=%d n_cm=%d: slepc %.3f s, eigsh %.3f s", n, n_cm, ts, te)
    return {"n_dof": n, "n_interior": int(keep.size), "n_cm": n_cm, "repeats": repeats,
            "slepc_s": ts, "eigsh_s": te, "eigsh_over_slepc": te / ts,
            "max_rel_freq_diff": diff}


def _gmsh_box(size, h):
    """Live gmsh model: box (volume ``box``), clamp face ``clamp`` at x = 0, tet10."""
    import gmsh

    gmsh.model.add("bench_box")
    gmsh.model.occ.addBox(0, 0, 0, *size)
    gmsh.model.occ.synchronize()
    vol = gmsh.model.getEntities(3)[0][1]
    face = [t for d, t in gmsh.model.getEntities(2)
            if abs(gmsh.model.occ.getCenterOfMass(d, t)[0]) < 1e-9]
    gmsh.model.setPhysicalName(3, gmsh.model.addPhysicalGroup(3, [vol]), "box")  # gmsh 4.8
    gmsh.model.setPhysicalName(2, gmsh.model.addPhysicalGroup(2, face), "clamp")
    gmsh.option.setNumber("Mesh.MeshSizeMax", h)
    gmsh.option.setNumber("Mesh.MeshSizeMin", h)
    gmsh.model.mesh.generate(3)
    gmsh.model.mesh.setOrder(2)
    return gmsh.model


def bench_calculix(h, n_modes, repeats, size=(0.3, 0.04, 0.04)):
    """CalculiX *FREQUENCY vs SLEPc (and eigsh) on the same clamped tet10 mesh
    (:func:`benchmarks.ccx_compare.compare`)."""
    import shutil

    import gmsh

    import fem
    from benchmarks.ccx_compare import compare

    if shutil.which("ccx") is None:
        return None
    steel = fem.Material(210e9, 0.3, 7800.0)
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    try:
        _gmsh_box(size, h)
        rec = compare({"box": steel}, ["clamp"], n_modes, repeats, scipy_eigsh=True)
    finally:
        gmsh.finalize()
    return {"mesh_size_m": h, **rec}


PRESETS = ("coarse", "fine")
MPIRUN = ["mpirun", "--allow-run-as-root", "--oversubscribe", "-n", "2"]


def pump_case(preset_name: str, n_cm: int, out: Path) -> dict:
    """One pump reduction in this process (serial or one rank of mpirun): mesh on
    rank 0, distribute, assemble, Craig–Bampton with ``n_cm`` modes, coupled ROM.

    Writes the record as JSON to ``out`` (rank 0) and returns it. Peak memory is
    the peak RSS of each rank (``ru_maxrss``), summed and max over ranks (MiB).
    """
    import resource

    from mpi4py import MPI

    import fem
    import geometry
    from reduction import build_rom, craig_bampton

    comm = MPI.COMM_WORLD
    t = {}
    t0 = time.perf_counter()
    with geometry.gmsh_session():
        meshed = (geometry.build_pump(geometry.PumpParams(), geometry.preset(preset_name))
                  if comm.rank == 0 else None)
        t["mesh_s"] = time.perf_counter() - t0
        t1 = time.perf_counter()
        fe_mesh = fem.load_meshed_model(meshed, comm)
        t["distribute_s"] = time.perf_counter() - t1
    comm.Barrier()
    t1 = time.perf_counter()
    model = fem.build_pump_model(None, fe_mesh=fe_mesh, comm=comm)
    comm.Barrier()
    t["assembly_s"] = time.perf_counter() - t1
    t1 = time.perf_counter()
    cb = craig_bampton(model.M, model.K, model.gear_dofs, n_modes=n_cm)
    rom = build_rom(cb, model.G, 185e6, 0.05)
    comm.Barrier()
    t["reduction_s"] = time.perf_counter() - t1
    phases = {f"{k}_s": float(v) for k, v in cb.timings.items()}
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    peaks = comm.allgather(peak)
    rec = {"preset": preset_name, "ranks": comm.size, "n_dof": int(model.K.getSize()[0]),
           "n_cm": n_cm, "n_r": int(rom.n_r), **t, **phases,
           "peak_rss_sum_mib": float(sum(peaks)), "peak_rss_max_rank_mib": float(max(peaks)),
           "highest_fixed_interface_hz": float(cb.fixed_interface_hz[-1]),
           "first_coupled_hz": [float(f) for f in rom.frequencies_hz[:4]]}
    if comm.rank == 0:
        with atomic_write(out, "w") as f:
            json.dump(rec, f, indent=2)
    return rec


def run_pump_case(preset_name: str, n_cm: int, ranks: int, timeout: float) -> dict | None:
    """Run :func:`pump_case` in a subprocess (``mpirun -n 2`` when ranks == 2)."""
    import subprocess
    import sys

    with tempfile.TemporaryDirectory() as d:
        out = Path(d) / "case.json"
        cmd = [sys.executable, "-m", "benchmarks.bench_reduction", "--pump-case",
               preset_name, "--n-cm", str(n_cm), "--case-out", str(out)]
        if ranks == 2:
            cmd = MPIRUN + cmd
        env = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
        t0 = time.perf_counter()
        try:
            proc = subprocess.run(cmd, cwd=Path(__file__).resolve().parents[1], env=env,
                                  capture_output=True, text=True, timeout=timeout)
        except subprocess.TimeoutExpired:
            log.warning("pump %s on %d rank(s): timed out after %.0f s", preset_name, ranks,
                        timeout)
            return None
        if proc.returncode != 0 or not out.exists():
            log.warning("pump %s on %d rank(s) failed (%d): %s", preset_name, ranks,
                        proc.returncode, proc.stderr[-2000:])
            return None
        rec = json.loads(out.read_text())
    rec["wall_s"] = time.perf_counter() - t0
    log.info("pump %s, %d rank(s): %d DOF, reduction %.1f s, total %.1f s, peak %.0f MiB",
             preset_name, ranks, rec["n_dof"], rec["reduction_s"], rec["wall_s"],
             rec["peak_rss_sum_mib"])
    return rec


def pump_tables(pump: list[dict]) -> list[dict]:
    """Markdown tables of the pump cases: time/memory vs DOF, serial vs mpirun -n 2."""
    cols = ["preset", "ranks", "n_dof", "n_cm", "mesh_s", "assembly_s", "reduction_s",
            "eigensolve_s", "static_modes_s", "projection_s", "peak_rss_sum_mib",
            "peak_rss_max_rank_mib", "wall_s"]
    rows = [[r.get(c, "") for c in cols] for r in pump]
    ratio = []
    for name in PRESETS:
        s = [r for r in pump if r["preset"] == name and r["ranks"] == 1]
        m = [r for r in pump if r["preset"] == name and r["ranks"] == 2]
        if s and m:
            ratio.append([name, s[0]["n_dof"], s[0]["assembly_s"], m[0]["assembly_s"],
                          s[0]["reduction_s"], m[0]["reduction_s"],
                          s[0]["reduction_s"] / m[0]["reduction_s"],
                          s[0]["peak_rss_sum_mib"], m[0]["peak_rss_sum_mib"]])
    return [{"title": "pump Craig–Bampton: time and peak memory against DOF (one run each)",
             "columns": cols, "rows": rows},
            {"title": "pump: serial against mpirun -n 2 (same model, side by side)",
             "columns": ["preset", "n_dof", "assembly serial s", "assembly np2 s",
                         "reduction serial s", "reduction np2 s", "serial/np2 (reduction)",
                         "peak MiB serial", "peak MiB np2 (sum)"],
             "rows": ratio}]


def box_tables(cases: list[dict], eig: list[dict], ccx: list[dict]) -> list[dict]:
    """Tables of the box benchmarks (the records are also kept as lists)."""
    def tab(title, recs, cols):
        return {"title": title, "columns": cols, "rows": [[r.get(c, "") for c in cols]
                                                          for r in recs]}
    return [
        tab("clamped box: Craig–Bampton time and memory against DOF and n_CM", cases,
            ["n_dof", "n_cm", "time_median_s", "eigensolve_median_s",
             "static_modes_median_s", "projection_median_s", "peak_extra_rss_mib"]),
        tab("fixed-interface eigensolve: SLEPc against scipy eigsh", eig,
            ["n_dof", "n_cm", "slepc_s", "eigsh_s", "eigsh_over_slepc", "max_rel_freq_diff"]),
        tab("free vibration: SLEPc against CalculiX on the same mesh", ccx,
            ["n_dof", "n_modes", "slepc_s", "ccx_s", "eigsh_s", "ccx_over_slepc",
             "max_rel_freq_diff_ccx"]),
    ]


def main(argv=None) -> dict:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true",
                   help="two small box sizes, pump coarse only")
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--out", type=Path, default=OUT)
    p.add_argument("--only", choices=("all", "box", "pump"), default="all",
                   help="run only one part; the other part's records are kept from --out")
    p.add_argument("--presets", default=None,
                   help="comma-separated pump presets (default coarse,fine; --quick coarse)")
    p.add_argument("--n-cm", type=int, default=100, help="fixed-interface modes of the pump")
    p.add_argument("--timeout", type=float, default=1800.0, help="per pump case (s)")
    p.add_argument("--pump-case", default=None, help=argparse.SUPPRESS)
    p.add_argument("--case-out", type=Path, default=None, help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.repeats < 1:
        raise ValueError(f"--repeats = {args.repeats}: must be >= 1")
    if args.n_cm < 1:
        raise ValueError(f"--n-cm = {args.n_cm}: must be >= 1")
    logging.basicConfig(level=logging.INFO, format="%(name)s: %(message)s")
    if args.pump_case is not None:
        return pump_case(args.pump_case, args.n_cm, args.case_out)
    presets = (args.presets.split(",") if args.presets else
               ["coarse"] if args.quick else list(PRESETS))
    for name in presets:
        if name not in PRESETS:
            raise ValueError(f"--presets: {name!r} must be one of {PRESETS}")
    old = json.loads(args.out.read_text()) if args.out.exists() else {}
    cases, eig, ccx = (old.get("reduction", []), old.get("eigensolve_vs_eigsh", []),
                       old.get("eigensolve_vs_calculix", []))
    if args.only in ("all", "box"):
        cases, eig, ccx = [], [], []
        for cells in SIZES_QUICK if args.quick else SIZES:
            model = None
            for n_cm in N_CMS:
                rec, model = bench_case(cells, n_cm, args.repeats)
                if rec is not None:
                    cases.append(rec)
            n = model.K.getSize()[0]
            if n <= EIGSH_MAX_DOF:
                eig.append(bench_eigsh(model, 40, args.repeats))
        for h in ([0.012] if args.quick else [0.012, 0.008]):
            rec = bench_calculix(h, 40, args.repeats)
            if rec is not None:
                ccx.append(rec)
    pump = old.get("pump", [])
    if args.only in ("all", "pump"):
        pump = [r for r in pump if r["preset"] not in presets]
        for name in presets:
            for ranks in (1, 2):
                rec = run_pump_case(name, args.n_cm, ranks, args.timeout)
                if rec is not None:
                    pump.append(rec)
        pump.sort(key=lambda r: (PRESETS.index(r["preset"]), r["ranks"]))
    cmd = ".venv/bin/python -m benchmarks.bench_reduction" + (" --quick" if args.quick else "")
    biggest = max(pump, key=lambda r: r["n_dof"], default=None)
    summary = ("Craig–Bampton reduction (SLEPc shift-invert + MUMPS) of a clamped box and of "
               "the pump presets; one run per pump case (mesh, assembly, reduction in one "
               "process; peak memory = sum over ranks of the peak RSS).")
    if biggest is not None:
        summary += (f" Largest model run: pump '{biggest['preset']}', {biggest['n_dof']} DOF, "
                    f"n_CM = {biggest['n_cm']}, reduction {biggest['reduction_s']:.1f} s, "
                    f"peak {biggest['peak_rss_sum_mib']:.0f} MiB on {biggest['ranks']} rank(s).")
    result = {
        "benchmark": "reduction",
        "command": cmd,
        "summary": summary,
        "date_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        "machine": {"node": platform.node(), "cpus": os.cpu_count(),
                    "python": platform.python_version()},
        "model": "clamped P2 steel box 0.3x0.04x0.04 m, interface = 12 DOF at 4 corners; "
                 "pump = geometry.build_pump(PumpParams(), preset) with fem defaults",
        "notes": "box: median of repeats; peak_extra_rss_mib = VmHWM after minus VmRSS before "
                 "the reduction (VmHWM reset with /proc/self/clear_refs); serial. "
                 "pump: one run per case, serial and mpirun -n 2 side by side.",
        "tables": pump_tables(pump) + box_tables(cases, eig, ccx),
        "reduction": cases,
        "eigensolve_vs_eigsh": eig,
        "eigensolve_vs_calculix": ccx,
        "pump": pump,
    }
    with atomic_write(args.out, "w") as f:
        json.dump(result, f, indent=2)
    log.info("written %s", args.out)
    return result


if __name__ == "__main__":
    main()
