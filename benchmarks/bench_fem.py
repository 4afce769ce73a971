"""fem assembly cost against DOF count: P2 K and M, prolongation + PtAP, and 10
eigenfrequencies, on a housing-like block (bore linked to a node, feet clamped).

Run: ``.venv/bin/python -m benchmarks.bench_fem [--sizes 0.02 0.012 0.008]``
Writes ``benchmarks/results/fem.json`` (atomically). Each mesh size runs in its own
process so that the peak resident memory (getrusage) belongs to that size alone.
"""

from __future__ import annotations

import argparse
import json
import logging
import subprocess
import sys
import time
from pathlib import Path

from benchmarks.common import peak_rss_mb, write_json

LOG = logging.getLogger(__name__)
ROOT = Path(__file__).resolve().parents[1]


def one_case(h: float) -> dict:
    """Build and time the block model with target element size ``h`` (m)."""
    sys.path.insert(0, str(ROOT / "tests"))
    import fem_support as fs
    from mpi4py import MPI

    import fem

    rss0 = peak_rss_mb()
    t0 = time.perf_counter()
    with fs.gmsh_session() as model:
        centres = fs.build_housing_block((0.16, 0.12, 0.08), 0.03, h, MPI.COMM_WORLD.rank)
        t1 = time.perf_counter()
        fe_mesh = fem.load_gmsh_mesh(model, centres=centres)
    t2 = time.perf_counter()
    V, K, M = fem.elasticity.assemble_elasticity(fe_mesh, {"housing": fem.CAST_IRON})
    t3 = time.perf_counter()
    nnz_full = int(K.getInfo()["nz_used"])
    rss_assembled = peak_rss_mb()
    spec = fem.ModelSpec()
    spec.add_node("bore", centres["bore"])
    spec.add_link("bore", "bore")
    spec.add_clamp("housing/feet")
    pro = fem.build_prolongation(V, fe_mesh, spec)
    t3b = time.perf_counter()
    Kr, Mr = fem.model.project(K, pro.P_fe), fem.model.project(M, pro.P_fe)
    t4 = time.perf_counter()
    nnz_red = int(Kr.getInfo()["nz_used"])
    f = fem.eigenfrequencies(Kr, Mr, 10, sigma=0.0)
    t5 = time.perf_counter()
    return {
        "h_m": h,
        "n_cells": fe_mesh.mesh.topology.index_map(3).size_global,
        "n_fe_dofs": pro.n_fe,
        "n_reduced_dofs": pro.n_red,
        "nnz_K": nnz_full,
        "nnz_K_reduced": nnz_red,
        "t_gmsh_s": t1 - t0,
        "t_to_dolfinx_s": t2 - t1,
        "t_assemble_KM_s": t3 - t2,
        "t_prolongation_s": t3b - t3,
        "t_ptap_KM_s": t4 - t3b,
        "t_prolongation_ptap_s": t4 - t3,
        "t_eigen10_s": t5 - t4,
        "f1_hz": float(f[0]),
        "peak_rss_start_mb": rss0,
        "peak_rss_assembled_mb": rss_assembled,
        "peak_rss_end_mb": peak_rss_mb(),
    }


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=float, nargs="+", default=[0.02, 0.012, 0.008])
    ap.add_argument("--case", type=float, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.case is not None:
        print(json.dumps(one_case(args.case)))
        return
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    cases = []
    for h in args.sizes:
        out = subprocess.run([sys.executable, "-m", "benchmarks.bench_fem", "--case", str(h)],
                             cwd=ROOT, capture_output=True, text=True, check=True)  # fmt: skip
        case = json.loads(out.stdout.strip().splitlines()[-1])
        LOG.info("h = %.4g m: %d DOF, assembly %.2f s, PtAP %.2f s, peak %.0f MiB",
                 h, case["n_fe_dofs"], case["t_assemble_KM_s"], case["t_prolongation_ptap_s"],
                 case["peak_rss_end_mb"])  # fmt: skip
        cases.append(case)
    path = write_json("fem", {"description": __doc__.splitlines()[0], "cases": cases})
    LOG.info("wrote %s", path)


if __name__ == "__main__":
    main()
