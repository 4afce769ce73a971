"""Memory of each component of the pump's reduction at one size (serial): the resident
memory after each step of ``geardyn reduce``'s fe and rom stages, with PETSc's own size of
each matrix and MUMPS's of its factor, so that the memory model of docs/scale.md can
be extrapolated component by component.

Run: ``.venv/bin/python -m benchmarks.bench_memory --size fine --n-cm 100
[--factorization cholesky] [--until fe]``. Writes
``benchmarks/results/memory_<size>_<factorization>.json``; one case per process (the
resident memory is this process's).
"""
from __future__ import annotations

import argparse
import json
import logging
import os
import sys
import tempfile
import time
from pathlib import Path

from benchmarks.bench_scale import SCENE, _overrides, _vm_mib
from benchmarks.common import write_json

log = logging.getLogger("bench_memory")


def _mat_mib(A) -> float:
    """Storage of an AIJ matrix's allocated non-zeros (value + column index) [MiB]."""
    import numpy as np
    from petsc4py import PETSc

    nz = A.getInfo()["nz_allocated"]
    return float(nz) * (8 + np.dtype(PETSc.IntType).itemsize) / 2**20


def _probe(steps: list, name: str, t0: float, **extra) -> None:
    rec = {"step": name, "rss_mib": _vm_mib("VmRSS"), "hwm_mib": _vm_mib("VmHWM"),
           "t_s": time.perf_counter() - t0, **extra}
    steps.append(rec)
    log.info("%-28s RSS %8.0f MiB  peak %8.0f MiB  %s", name, rec["rss_mib"], rec["hwm_mib"],
             {k: round(v, 1) if isinstance(v, float) else v for k, v in extra.items()})


def run(size: str, n_cm: int, factorization: str, until: str) -> dict:
    import gmsh
    import numpy as np

    import study
    from fem import build_pump_model, load_gmsh_mesh
    from fem.elasticity import assemble_elasticity
    from geometry import gmsh_session
    from machines.pump import fe_parameters
    from reduction.craig_bampton import _make_eps
    from study.scene import load_scene

    t0 = time.perf_counter()
    steps: list = []
    _probe(steps, "imports", t0)
    tmp = Path(tempfile.mkdtemp(prefix="bench_memory."))
    ov = _overrides(size, n_cm, factorization)
    study.run(SCENE, tmp / "out", overrides=ov, cache_dir=tmp / "cache", until="mesh")
    mesh_dir = next(p for p in (tmp / "cache" / "mesh").iterdir() if not p.name.startswith("."))
    _probe(steps, "mesh (gmsh, freed)", t0)
    sc = load_scene(SCENE, ov)
    p = fe_parameters(sc.fe, sc.gear)
    info = json.loads((mesh_dir / "mesh.json").read_text())
    groups = {k: (int(v[0]), int(v[1])) for k, v in info["groups"].items()}
    centres = {k: np.asarray(v, dtype=float) for k, v in info["centres"].items()}
    with gmsh_session():
        gmsh.merge(str(mesh_dir / "pump.msh"))
        fe_mesh = load_gmsh_mesh(None, groups=groups, centres=centres)
    _probe(steps, "DOLFINx mesh", t0)
    mats = {k: v for k, v in p.materials.by_volume().items() if k in fe_mesh.groups}
    V, K, M = assemble_elasticity(fe_mesh, mats)
    _probe(steps, "full P2 K, M assembled", t0, K_mib=_mat_mib(K), M_mib=_mat_mib(M),
           n_p2=K.getSize()[0])
    K.destroy()
    M.destroy()
    del V
    _probe(steps, "full K, M freed", t0)
    model = build_pump_model(None, p.materials, p.gears, p.bearings, p.drive, fe_mesh=fe_mesh)
    _probe(steps, "FE model (K̄, M̄, P)", t0, K_mib=_mat_mib(model.K), M_mib=_mat_mib(model.M),
           P_mib=_mat_mib(model.P), n=model.K.getSize()[0])
    import ctypes

    trimmed = ctypes.CDLL("libc.so.6").malloc_trim(0)   # give freed heap back to the OS
    _probe(steps, "after malloc_trim", t0, trimmed=int(trimmed))
    out = {"size": size, "n_cm": n_cm, "factorization": factorization, "steps": steps,
           "n_dof": int(model.K.getSize()[0])}
    if until == "fe":
        return out
    from reduction.interface import interface_eliminated

    n = model.K.getSize()[0]
    n_i = n - model.gear_dofs.size
    with interface_eliminated(model.K, model.M, model.gear_dofs):
        _probe(steps, "interface eliminated in place", t0)
        eps = _make_eps(model.K, model.M, 1e-12, factorization)
        F = eps.getST().getKSP().getPC().getFactorMatrix()
        _probe(steps, "MUMPS factor of K_ii", t0, mumps_mib=float(F.getMumpsInfog(21)),
               entries=int(F.getMumpsInfog(29)))
        nev = n_cm + max(5, n_cm // 10)
        eps.setDimensions(nev)
        eps.solve()
        _, ncv, _ = eps.getDimensions()
        _probe(steps, "eigen-solve", t0, ncv=int(ncv),
               krylov_mib=ncv * n * 8 / 2**20, converged=int(eps.getConverged()))
        F.destroy()  # this reference only: the factor goes with eps
        eps.destroy()
    _probe(steps, "factor and Krylov basis freed", t0, n_i=n_i)
    out["ncv"] = int(ncv)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", default="fine")
    ap.add_argument("--n-cm", type=int, default=100)
    ap.add_argument("--factorization", default="lu", choices=("lu", "cholesky"))
    ap.add_argument("--until", default="rom", choices=("fe", "rom"))
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s: %(message)s",
                        datefmt="%H:%M:%S")
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    rec = run(args.size, args.n_cm, args.factorization, args.until)
    rec["command"] = " ".join([".venv/bin/python -m benchmarks.bench_memory", *sys.argv[1:]])
    rec["tables"] = [{"title": f"resident memory after each step, {args.size}, "
                               f"{rec['n_dof']} DOF, n_CM = {args.n_cm}, {args.factorization} "
                               "(MiB; matrices: allocated non-zeros × 12 B; factor: MUMPS "
                               "INFOG(21))",
                      "columns": ["step", "rss_mib", "hwm_mib", "t_s", "component sizes"],
                      "rows": [[s["step"], s["rss_mib"], s["hwm_mib"], s["t_s"],
                                ", ".join(f"{k} {v:.4g}" for k, v in s.items()
                                          if k not in ("step", "rss_mib", "hwm_mib", "t_s"))]
                               for s in rec["steps"]]}]
    path = write_json(f"memory_{args.size}_{args.factorization}_{args.until}", rec)
    log.info("wrote %s", path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
