"""An imported CAD housing at scale: the gearbox housing of
``scripts/gearbox_housing_step.py`` read from STEP, meshed with quadratic tetrahedra at
≥ 1 M DOF, its six bearing seats linked to seat nodes, its feet clamped, and reduced by
Craig–Bampton onto the seat nodes under ``mpirun -n R`` (issue 37, "Scale").

Each case runs in its own ``mpirun`` process so that its peak resident memory per rank
(VmHWM) is its own. The import and the face searches run on rank 0 (the gmsh model lives
there; :func:`fem.load_meshed_model` distributes the mesh), everything after is parallel.
The seats are rigid (RBE2): a distributing seat holds a dense block over its surface's
DOF (docs/cad-import.md §9), which is what one avoids at this size. Each seat node
carries 2 kg (a bearing and its share of a shaft) so that the interface is a machine's.

Run: ``.venv/bin/python -m benchmarks.bench_cad_scale [--sizes 0.012,0.0052]
[--ranks 2] [--n-cm 100]`` (about 15 min and 12 GB at 5.2 mm on 2 cores). Writes
``benchmarks/results/cad_scale.json`` (cases already in the file and not rerun are kept).
"""
from __future__ import annotations

import argparse
import json
import logging
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from benchmarks.common import RESULTS, write_json

log = logging.getLogger("bench_cad_scale")
ROOT = Path(__file__).resolve().parents[1]
OUT = RESULTS / "cad_scale.json"
SEAT_MASS = 2.0  # kg on each seat node


def _vm_mib(field: str) -> float:
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(field + ":"):
                return int(line.split()[1]) / 1024.0
    return float("nan")


def _gearbox_script():
    import importlib.util

    name = "gearbox_housing_step"
    spec = importlib.util.spec_from_file_location(name, ROOT / "scripts" / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    spec.loader.exec_module(mod)
    return mod


def case(size: float, n_cm: int, out: Path) -> None:
    """One case in this process (one rank of mpirun)."""
    from mpi4py import MPI

    import fem
    from geometry import CadPart, gmsh_session, import_cad, preset
    from reduction import craig_bampton

    comm = MPI.COMM_WORLD
    gb = _gearbox_script()
    p = gb.GearboxHousing()
    t: dict[str, float] = {}
    tmp = Path(tempfile.mkdtemp(prefix="cad_scale.")) if comm.rank == 0 else None
    tmp = comm.bcast(tmp)
    t0 = time.perf_counter()
    if comm.rank == 0:
        gb.write(tmp / "gearbox.step", p)
    comm.barrier()
    t["step_write_s"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    quality = None
    with gmsh_session():
        model = None
        if comm.rank == 0:
            model = import_cad([CadPart("housing", tmp / "gearbox.step", unit="mm")],
                               gb.seats(p), [gb.feet_mount(p)],
                               preset("coarse", size=size, curvature_points=10),
                               max_elements=5_000_000)
            quality = model.quality.summary()
        t["import_mesh_s"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        fe_mesh = fem.load_meshed_model(model, comm)
    t["distribute_s"] = time.perf_counter() - t0
    quality = comm.bcast(quality)
    seats = sorted(g for g in fe_mesh.groups if "/bore_" in g)
    t0 = time.perf_counter()
    spec = fem.housing_spec(fe_mesh, dict.fromkeys(seats, "rigid"),
                            {"housing/feet": fem.MountSupport()})
    for s in seats:
        spec.add_mass(s, fem.rigid_body_mass(SEAT_MASS, [0.0, 0.0, 0.0]))
    fe_model = fem.build_model(fe_mesh, {"housing": fem.CAST_IRON}, spec,
                               quadrature_degree=2, gear_nodes=seats)
    t["assemble_s"] = time.perf_counter() - t0
    n_dof = fe_model.K.getSize()[0]
    hwm_before = _vm_mib("VmHWM")
    t0 = time.perf_counter()
    cb = craig_bampton(fe_model.M, fe_model.K, fe_model.gear_dofs, n_modes=n_cm)
    t["craig_bampton_s"] = time.perf_counter() - t0
    peaks = comm.allgather(_vm_mib("VmHWM"))
    before = comm.allgather(hwm_before)
    if comm.rank == 0:
        rec = {"size_mm": size * 1e3, "ranks": comm.size, "n_dof": int(n_dof),
               "mesh": quality, "n_interface": int(len(fe_model.gear_dofs)),
               "n_cm": n_cm, **{k: round(v, 2) for k, v in t.items()},
               "cb_phases_s": {k: round(float(v), 2) for k, v in cb.timings.items()},
               "peak_rss_per_rank_mib": [round(x) for x in peaks],
               "peak_before_cb_per_rank_mib": [round(x) for x in before],
               "peak_rss_total_gib": round(sum(peaks) / 1024.0, 2),
               "fixed_interface_hz_first": [round(float(f), 2) for f in
                                            cb.fixed_interface_hz[:6]],
               "fixed_interface_hz_last": round(float(cb.fixed_interface_hz[-1]), 1),
               "load_avg_1min": os.getloadavg()[0]}
        out.write_text(json.dumps(rec))


def run(sizes: list[float], ranks: list[int], n_cm: int) -> list[dict]:
    """Each (size, ranks) case in its own mpirun process; their records."""
    records = []
    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1",
               OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
               PYTHONPATH=str(ROOT))
    for size in sizes:
        for r in ranks:
            with tempfile.TemporaryDirectory() as tmp:
                out = Path(tmp) / "case.json"
                cmd = ["mpirun", "--allow-run-as-root", "--oversubscribe", "-n", str(r),
                       sys.executable, "-m", "benchmarks.bench_cad_scale",
                       "--case", str(size), "--n-cm", str(n_cm), "--case-out", str(out)]
                log.info("case size %.4g m, %d rank(s)", size, r)
                t0 = time.perf_counter()
                subprocess.run(cmd, check=True, env=env, cwd=ROOT)
                rec = json.loads(out.read_text())
                rec["wall_s"] = round(time.perf_counter() - t0, 1)
                log.info("%s", rec)
                records.append(rec)
    return records


def _key(rec: dict) -> tuple:
    return (rec["size_mm"], rec["ranks"], rec["n_cm"])


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", default="0.012,0.0052", help="element sizes in m")
    ap.add_argument("--ranks", default="2")
    ap.add_argument("--n-cm", type=int, default=100)
    ap.add_argument("--case", type=float, help=argparse.SUPPRESS)
    ap.add_argument("--case-out", type=Path, help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.case is not None:
        case(a.case, a.n_cm, a.case_out)
        return
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    records = run([float(s) for s in a.sizes.split(",")],
                  [int(r) for r in a.ranks.split(",")], a.n_cm)
    old = json.loads(OUT.read_text()).get("cases", []) if OUT.exists() else []
    new = {_key(r) for r in records}
    cases = sorted([r for r in old if _key(r) not in new] + records, key=_key)
    big = [r for r in cases if r["n_dof"] >= 1_000_000]
    headline = {}
    if big:
        b = max(big, key=lambda r: r["n_dof"])
        headline = {
            f"CAD housing {b['n_dof'] / 1e6:.2f} M DOF, CB n_cm={b['n_cm']}, "
            f"{b['ranks']} ranks: wall [s]": b["wall_s"],
            f"CAD housing {b['n_dof'] / 1e6:.2f} M DOF: peak memory, all ranks [GiB]":
                b["peak_rss_total_gib"]}
    write_json("cad_scale", {
        "command": "python -m benchmarks.bench_cad_scale " + " ".join(argv or sys.argv[1:]),
        "summary": ("The gearbox housing of scripts/gearbox_housing_step.py imported from "
                    "STEP (gmsh OCC), P2 tetrahedra, six rigid seats with 2 kg each, feet "
                    "clamped, Craig-Bampton onto the 36 seat DOF under mpirun: time per "
                    "phase and peak resident memory per rank (VmHWM)."),
        "headline": headline,
        "cases": cases,
    })


if __name__ == "__main__":
    main()
