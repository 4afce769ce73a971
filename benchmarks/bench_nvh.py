"""Cost of the housing's equivalent radiated power (ERP) on the coarse pump.

Measured in one run (medians of repeats): the one-time construction of the radiation
data with the ROM (outer facets, W = (PT)ᵀ A (PT), facet rows), the per-point ERP of
every harmonic from the ROM coordinates (n_r × n_r products), the per-point recovery
of those coordinates (``HBMProblem.recover``) and, as the reference the reduced form
replaces, the ERP of the same point from full P2 fields (reconstruction through
DOLFINx and ``uᵀ A u`` per harmonic).

Run: ``.venv/bin/python -m benchmarks.bench_nvh [--quick]``.
"""
from __future__ import annotations

import argparse
import logging
import time
from pathlib import Path

import numpy as np

from benchmarks.common import median_time, peak_rss_mb, write_json

ROOT = Path(__file__).resolve().parents[1]
log = logging.getLogger("bench_nvh")


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="n_CM = 40 instead of the scene's")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--work", type=Path, default=Path("/tmp/geardyn-bench-nvh"))
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(name)s: %(message)s")
    import h5py

    import study
    from fem import post
    from machines import machine_for
    from reduction import load_basis, reconstruct
    from study.outputs.acoustics import erp_harmonics
    from study.outputs.points import point_at
    from study.pipeline import Pipeline

    t0 = time.perf_counter()
    ov = {"continuation.speed_rpm": [2000.0, 2100.0], "hbm.stability": False,
          "outputs.plots": [], "outputs.housing_field_rpm": [2050.0], "outputs.report": False,
          "rom.n_check": 0}
    if args.quick:
        ov["rom.n_cm"] = 40
    r = study.run(ROOT / "scenes" / "pump.toml", args.work / "run", cache_dir=args.work / "cache",
                  overrides=ov)
    mesh_dir = Pipeline(r.scene, r.out, cache_dir=args.work / "cache").run_mesh()  # cached
    model = machine_for(r.scene).build_fe_model(mesh_dir)
    with h5py.File(r.rom.folder / "rom.h5", "r") as f:
        T = f["rom/basis"][()]
    n_r = T.shape[1]

    def build():
        PT = post.field_operator(model, T)
        post.radiation_data(model, PT, args.work / "radiation.h5")
        PT.destroy()
    t_build, _ = median_time(build, repeats=max(1, args.repeats // 2), warmup=0)
    W = r.rom.radiation["W"]
    pt = point_at(r, len(r.branch) // 2)
    hs = r.problem.harmonics
    idx = np.asarray(hs.indices)
    w0 = hs.fundamental_rad_s(pt.omega)
    qk = r.problem.recover(pt)
    t_recover, _ = median_time(lambda: r.problem.recover(pt), repeats=args.repeats)
    t_erp, erp = median_time(lambda: erp_harmonics(W, qk, idx * w0), repeats=args.repeats)
    Tp = load_basis(r.rom.folder / "rom.h5", row_range=model.K.getOwnershipRange())
    facets = post.outer_surface_facets(model.fe_mesh)
    A = post.normal_gram(model.V, facets)

    def full():
        out = np.zeros(idx.size)
        for j in range(1, idx.size):
            val = 0.0
            for part in reconstruct(Tp, qk[:, j]):
                uf = model.displacement(part)
                u = uf.vector
                y = A.createVecLeft()
                A.mult(u, y)
                val += u.dot(y)
            out[j] = 0.5 * 1.2 * 343.0 * (idx[j] * w0) ** 2 * val
        return out
    t_full, erp_full = median_time(full, repeats=max(1, args.repeats // 2))
    err = float(np.max(np.abs(erp - erp_full)) / np.max(erp_full))
    n_f = int(r.rom.radiation["n_facets"])
    rows = [[r.scene.name, n_r, idx.size, n_f, t_build, t_recover * 1e3, t_erp * 1e6,
             t_full, t_full / t_erp, err]]
    summary = (f"Coarse pump, n_r = {n_r}, {idx.size} harmonics, {n_f} outer facets: the "
               f"radiation data take {t_build:.2f} s once per ROM; the ERP of all harmonics of "
               f"a point takes {t_erp * 1e6:.0f} µs from the ROM coordinates (their recovery "
               f"{t_recover * 1e3:.2f} ms), {t_full / t_erp:.0f}x less than from full P2 fields "
               f"({t_full:.2f} s), agreeing to {err:.1e}.")
    payload = {"command": ".venv/bin/python -m benchmarks.bench_nvh"
                          + (" --quick" if args.quick else ""),
               "summary": summary,
               "tables": [{"title": "ERP cost per continuation point (medians, same run)",
                           "columns": ["scene", "n_r", "harmonics", "outer facets",
                                       "build W once s", "recover q ms", "ERP from W µs",
                                       "ERP from full fields s", "ratio full/W",
                                       "max rel. difference"],
                           "rows": rows}],
               "seconds": time.perf_counter() - t0, "peak_rss_mb": peak_rss_mb()}
    path = write_json("nvh", payload)
    log.info("%s", summary)
    log.info("wrote %s", path)
    return payload


if __name__ == "__main__":
    main()
