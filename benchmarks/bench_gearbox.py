"""The FE two-stage gearbox (issue 36 item 6): per-point cost against one mesh, harmonic
balance against time integration of the same ROM at equal accuracy, and the whole curve
with stability.

* **per point**: the scene's problem (two meshes, one-dimensional set over the hunting
  period, ``[hbm] mesh_harmonics``) against the same ROM with its first mesh as the
  only dead-zone element (its harmonics 0..H) and the second as its mean spring ``k̄ g
  gᵀ``: median Newton solve at a speed from the solution at
  0.99 x the speed.
* **against time integration**: at one speed in permanent contact, the HBM point (at
  ``--harmonics`` per mesh, converged; the scene's set's error against it is reported)
  against
  DOP853 on the ROM's equations (every coupled mode, :func:`hbm.post.time_response.
  equations`) started from the static deflection, run hunting period by hunting period
  (61 mesh-1 periods) until the mesh-load std of the last period agrees with the HBM's to
  ``--tol`` (both meshes): the wall time each method needs for that accuracy.
* **whole curve**: the scene through the pipeline (mesh, fe, rom cached after the first
  run), the hbm stage's wall time for the continuation with Floquet stability.

Run: ``.venv/bin/python -m benchmarks.bench_gearbox [--scene scenes/two-stage-gearbox.toml]
[--rpm 2000] [--tol 1e-4]``; writes ``benchmarks/results/gearbox.json`` for the demo
scene (``scenes/two-stage-gearbox-demo.toml``, the default), ``gearbox_full.json`` for
another.
"""
from __future__ import annotations

import argparse
import logging
import math
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp

import hbm
from benchmarks.common import median_time, peak_rss_mb, write_json
from hbm.post.time_response import equations, modal_model

log = logging.getLogger("bench_gearbox")


def _point_time(pb: hbm.HBMProblem, rpm: float, repeats: int) -> tuple[float, Any]:
    prev = pb.solve(0.99 * rpm)
    return median_time(lambda: pb.solve(rpm, x0=prev.unknowns), repeats=repeats, warmup=0)


def _one_mesh(pb: hbm.HBMProblem, harmonics: int) -> hbm.HBMProblem:
    """The same ROM and forcing with the first mesh as the only nonlinear element (its
    harmonics 0..H) and the others as their mean springs ``k̄ g gᵀ`` in K."""
    el = pb.elements[0]
    s = pb.system
    K = s.K + sum(o.mean_stiffness * np.outer(o.direction, o.direction)
                  for o in pb.elements[1:])
    hs = hbm.HarmonicSet(range(harmonics + 1), ratio=el.base_ratio)
    const = {0: pb.excitation.constant[0]}
    return hbm.HBMProblem(hbm.LinearSystem(s.M, s.C, K), [el],
                          hbm.Excitation(s.M.shape[0], const), hs)


def _integrate_to(pb: hbm.HBMProblem, rpm: float, target: np.ndarray, tol: float,
                  max_periods: int, rtol: float) -> dict[str, Any]:
    """DOP853 from the static deflection, one hunting period at a time, until the std of
    each mesh load over the last period is within ``tol`` of ``target``."""
    mm = modal_model(pb, rpm)
    fun = equations(mm)
    m = mm.n_modes
    f0 = np.real(mm.forcing[np.argmin(np.abs(mm.kw))])        # static modal forcing
    y = np.concatenate([f0 / mm.w2, np.zeros(m)])
    T = mm.period                                              # the hunting period
    n = 61 * 64                                                # 64 samples per mesh-1 period
    te = T * np.arange(n) / n
    atol = np.concatenate([np.full(m, rtol * np.abs(y[:m]).max()),
                           np.full(m, rtol * np.abs(y[:m]).max() * 2 * math.pi / T)])
    tic = time.perf_counter()
    errs = []
    for k in range(max_periods):
        sol = solve_ivp(fun, (0.0, T), y, method="DOP853", rtol=rtol, atol=atol,
                        t_eval=np.append(te, T))
        y = sol.y[:, -1]
        std = []
        for e, el in enumerate(pb.elements):
            d = mm.gamma[e] @ sol.y[:m, :-1]
            std.append(float(el.load(d, el.sample(mm.rates[e] * te)).std()))
        err = float(np.max(np.abs(np.array(std) / target - 1.0)))
        errs.append(err)
        log.info("time integration: hunting period %d, max rel. error %.3g", k + 1, err)
        if err < tol:
            break
    return {"periods": len(errs), "seconds": time.perf_counter() - tic,
            "error_per_period": errs, "reached": errs[-1] < tol}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default="scenes/two-stage-gearbox-demo.toml")
    ap.add_argument("--rpm", type=float, default=2000.0)
    ap.add_argument("--tol", type=float, default=1e-4)
    ap.add_argument("--harmonics", type=int, default=8,
                    help="harmonics per mesh of the converged HBM point the time "
                         "integration is measured against")
    ap.add_argument("--max-periods", type=int, default=60)
    ap.add_argument("--out", default=None, help="folder for the run's temporary output "
                    "and cache (default: the system's temp folder)")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s: %(message)s")
    from study import load_scene
    from study.pipeline import Pipeline

    scene = load_scene(args.scene)
    out = Path(tempfile.mkdtemp(prefix="bench_gearbox_", dir=args.out))
    tic = time.perf_counter()
    pipe = Pipeline(scene, out, cache_dir=out / "cache")  # every stage runs (fresh cache)
    res = pipe.run()
    total = time.perf_counter() - tic
    status = {k: {"state": v.state, "seconds": v.seconds} for k, v in pipe.status.items()}
    pb = res.problem
    h = scene.hbm.mesh_harmonics
    t2, p2 = _point_time(pb, args.rpm, 5)
    one = _one_mesh(pb, h)
    t1, _ = _point_time(one, args.rpm, 5)
    from study.pipeline.model import scene_problem

    ref_scene = load_scene(args.scene, {"hbm.mesh_harmonics": args.harmonics})
    ref, _ = scene_problem(ref_scene, pipe.cache.entry("rom", pipe.keys["rom"]))
    t_ref, p_ref = _point_time(ref, args.rpm, 3)
    target = np.array([s.mesh_load_std for s in hbm.point_stats(ref, p_ref)])
    scene_std = np.array([s.mesh_load_std for s in hbm.point_stats(pb, p2)])
    loss = [s.contact_loss_fraction for s in hbm.point_stats(ref, p_ref)]
    ti = _integrate_to(ref, args.rpm, target, args.tol, args.max_periods, rtol=1e-9)
    payload = {
        "scene": args.scene, "rpm": args.rpm, "n_dof": int(pb.system.M.shape[0]),
        "per_point": {"two_meshes": {"seconds": t2, "unknowns": pb.n_unknowns,
                                     "harmonics": len(pb.harmonics.indices),
                                     "aft_samples": int(pb.harmonics.n_time)},
                      "one_mesh": {"seconds": t1, "unknowns": one.n_unknowns,
                                   "harmonics": len(one.harmonics.indices),
                                   "aft_samples": int(one.harmonics.n_time)},
                      "ratio": t2 / t1},
        "hbm_vs_time_integration": {"tol": args.tol, "harmonics": args.harmonics,
                                    "hbm_point_s": t_ref, "unknowns": ref.n_unknowns,
                                    "mesh_load_std": target.tolist(),
                                    "scene_set_error": float(np.max(np.abs(
                                        scene_std / target - 1.0))),
                                    "contact_loss": loss, **ti,
                                    "speedup": ti["seconds"] / t_ref},
        "whole_curve": {"run_s": total, "stages": status,
                        "points": len(res.branch), "stability": True},
        "peak_rss_mb": peak_rss_mb(),
    }
    name = "gearbox" if args.scene.endswith("demo.toml") else "gearbox_full"
    path = write_json(name, payload)
    log.info("wrote %s", path)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
