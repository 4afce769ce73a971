"""What the machine does where the HBM orbit is unstable: time integration from it.

For a scene, an excitation case (``all`` as the scene is; ``internal``: ``[external]``
removed, as ``geardyn excitations`` does) and a list of speeds, the HBM point at each
speed is solved by Newton from the nearest point of a saved run (``--from
OUT/<case>/results.h5``), then the ROM is integrated in time from it
(:func:`hbm.time_response.integrate`, DOP853, rtol 1e-9) over ``--transient``
shaft turns and ``--window`` more. Per speed the record keeps the HBM orbit's mesh-load
std, its stability, the std of each integrated turn of the window, and the strongest
lines of the mesh-load spectrum over the window (resolution 1/window shaft orders),
its Poincaré section's verdict and the Hann-windowed lines (docs/theory.md §16.3):
an attractor is the HBM orbit when its std and lines are those of the orbit; a
periodic attractor has lines at integer orders only and the same std every turn; a
quasi-periodic one has lines between them (docs/theory.md §13.5, "Stability along the
curves"). With ``--sweep`` each speed after the first starts from the state the
previous one ended in: a slow run-up (or run-down) as on a test rig. (One time response
per unstable segment is in every run's report.md with ``[outputs]
attractor_transient_turns``; this script is for chosen speeds, run-ups and ``--trace``.)

Run (a few minutes per speed on the pump-paper ROM)::

    OMP_NUM_THREADS=1 nice .venv/bin/python -m benchmarks.ti_attractor \\
        --scene scenes/pump-paper.toml --case internal --rpm 2922 5900 \\
        --from OUT/internal/results.h5 --cache CACHE
"""
from __future__ import annotations

import argparse
import json
import logging
from pathlib import Path

import numpy as np

from benchmarks.bench_verify import hbm_load, map_unknowns
from benchmarks.common import RESULTS
from core.files import atomic_write
from hbm.post.time_response import SAMPLES_PER_MESH_PERIOD, fundamentals_per_turn
from hbm.post.time_response import integrate as time_integrate

log = logging.getLogger("ti_attractor")
ROOT = Path(__file__).resolve().parents[1]
DEFAULT_OUT = RESULTS / "ti_attractor_pump_paper.json"


def case_scene(path: Path, case: str):
    """The scene of an excitation case: ``all`` as it is, ``internal`` as
    :func:`study.studies.excitations.case_scenes` makes it (``[external]`` removed; its HBM
    fundamental is then the mesh frequency)."""
    import study
    from study.studies.excitations import case_scenes

    scene = study.load_scene(path)
    if case == "all":
        return scene
    if case != "internal":
        raise ValueError(f"--case = {case!r}: must be 'all' or 'internal'")
    return case_scenes(scene)["internal"]


def nearest_branch_point(run: Path, rpm: float) -> dict:
    """The saved branch's point nearest to ``rpm``: its speed, std, stability, leading
    kind and unknowns."""
    import h5py

    with h5py.File(run, "r") as f:
        c = f["continuation"]
        i = int(np.argmin(np.abs(c["rpm"][()] - rpm)))
        return {"rpm": round(float(c["rpm"][i]), 2),
                "std": round(float(c["mesh_load_std"][i]), 4),
                "stable": bool(c["stable"][i]), "kind": int(c["floquet_kind"][i]),
                "unknowns": c["unknowns"][i]}


def start_point(problem, near: dict, rpm: float):
    """Newton solution at ``rpm`` from a branch point (:func:`nearest_branch_point`)."""
    x0 = near["unknowns"]
    if x0.size != problem.n_unknowns:
        raise ValueError(f"--from: {x0.size} unknowns per point, the case's problem has "
                         f"{problem.n_unknowns} (another case or harmonic set?)")
    return problem.solve(rpm, x0=x0, tol=1e-10)


def orbit_std(problem, point) -> float:
    """Mesh-load std (N) of an HBM orbit, ``SAMPLES_PER_MESH_PERIOD`` per mesh period."""
    return float(hbm_load(problem, point, problem.steps[0] * SAMPLES_PER_MESH_PERIOD).std())


def integrate(problem, rpm: float, y0, turns: int, window: int
              ) -> tuple[dict, np.ndarray, np.ndarray]:
    """:func:`hbm.time_response.integrate` from ``y0`` (a point or a modal state) as a
    record: the window's std per turn and spectrum; with the state at the end and Delta
    (m) over the last turn."""
    tr = time_integrate(problem, rpm, y0, transient=turns, window=window)
    rec = {"turns": turns, "window": window, "seconds": round(tr.seconds, 1),
           "std_per_turn": [round(float(s), 4) for s in tr.std_per_turn],
           "std_window": round(tr.std, 4), "max_load": round(tr.max_load, 3),
           "lines": [{"order": round(o, 4), "hz": round(o * rpm / 60, 1), "N": round(a, 3)}
                     for o, a in tr.lines]}
    sec = tr.poincare
    if sec is not None:                 # docs/theory.md §16.3
        rec["section"] = {"kind": sec.label, "samples": sec.samples,
                          "rotation": round(sec.rotation, 6),
                          "concentration": round(sec.concentration, 6)}
        rec["windowed_lines"] = [{"order": round(o, 5), "N": round(a, 4)}
                                 for o, a in tr.windowed_lines(6)]
    return rec, tr.state, tr.delta


def attractor_point(problem, rpm: float, delta: np.ndarray):
    """Newton solution at ``rpm`` from the Fourier coefficients of ``Delta`` over one
    shaft turn (a time-integrated attractor): the harmonic-balance orbit it is, if it
    is periodic and the harmonic set holds it."""
    per_turn = fundamentals_per_turn(problem)
    spec = np.fft.rfft(delta) / delta.size
    coeffs = {int(k): complex(spec[k * per_turn] * (1.0 if k == 0 else 2.0))
              for k in problem.harmonics.indices if k * per_turn < spec.size}
    return problem.solve(rpm, x0=map_unknowns(problem, coeffs), tol=1e-10)


def trace_attractor(problem, scene, point, ends: tuple[float, float]) -> dict:
    """Continue the branch of ``point`` (:func:`attractor_point`) down to ``ends[0]`` and
    up to ``ends[1]`` rpm with the scene's continuation settings and stability; per
    direction its reach, largest std, unstable segments and arrays."""
    import hbm
    from study.outputs.curves import unstable_segments

    c = scene.continuation
    out = {}
    for name, end in zip(("down", "up"), ends, strict=True):
        span = abs(end - point.rpm)
        br = hbm.trace(problem, point.rpm, end, step=c.step / span,
                       min_step=c.min_step / span, max_step=c.max_step / span,
                       tol=c.tolerance, max_points=c.max_points, start=point.unknowns)
        i = int(np.argmax(br.element(0).mesh_load_std))
        out[name] = {
            "status": br.status, "points": len(br),
            "rpm_range": [round(float(br.rpm.min()), 2), round(float(br.rpm.max()), 2)],
            "max_std": round(float(br.element(0).mesh_load_std[i]), 4),
            "max_std_rpm": round(float(br.rpm[i]), 2), "stable_max_std": round(float(
                np.max(br.element(0).mesh_load_std[br.stable.astype(bool)], initial=0.0)), 4),
            "folds": [round(float(f), 2) for f in br.folds],
            "unstable": [{"kind": u.kind, "rpm": [round(u.rpm[0], 2), round(u.rpm[1], 2)],
                          "points": u.points} for u in unstable_segments(
                              br.rpm, br.element(0).mesh_load_std, br.stable, br.floquet_kind)],
            "rpm": [round(float(r), 3) for r in br.rpm],
            "std": [round(float(v), 4) for v in br.element(0).mesh_load_std],
            "stable": [bool(v) for v in br.stable]}
        log.info("attractor branch %s from %.1f rpm: %s, %d points, %.1f-%.1f rpm, largest "
                 "std %.2f N at %.1f rpm (stable points: %.2f N), unstable %s", name,
                 point.rpm, br.status, len(br), *out[name]["rpm_range"], out[name]["max_std"],
                 out[name]["max_std_rpm"], out[name]["stable_max_std"], out[name]["unstable"])
    return out


def main(argv: list[str] | None = None) -> dict:
    from study.pipeline import Pipeline

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", type=Path, default=ROOT / "scenes" / "pump-paper.toml")
    ap.add_argument("--case", default="all", choices=("all", "internal"))
    ap.add_argument("--rpm", type=float, nargs="+", required=True)
    ap.add_argument("--from", dest="run", type=Path, required=True,
                    help="results.h5 of a run of that case (start points)")
    ap.add_argument("--cache", type=Path, required=True, help="stage cache holding the ROM")
    ap.add_argument("--transient", type=int, default=30, help="shaft turns left out")
    ap.add_argument("--window", type=int, default=16, help="shaft turns analysed")
    ap.add_argument("--sweep", action="store_true",
                    help="each speed starts from the state the previous one ended in (a "
                         "run-up or run-down, in the order given) instead of its HBM point")
    ap.add_argument("--trace", type=float, nargs=2, metavar=("LO", "HI"),
                    help="if the attractor at a speed is a periodic orbit of the harmonic "
                         "set, continue its branch down to LO and up to HI rpm")
    ap.add_argument("--out", type=Path, default=DEFAULT_OUT)
    args = ap.parse_args(argv)
    if args.transient < 0 or args.window < 1:
        raise ValueError(f"--transient = {args.transient}, --window = {args.window}: must be "
                         ">= 0 and >= 1")
    if any(not r > 0 for r in args.rpm):
        raise ValueError(f"--rpm = {args.rpm}: must be > 0")
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s: %(message)s")
    scene = case_scene(args.scene, args.case)
    problem, _ = Pipeline(scene, args.cache.parent / "ti-attractor", cache_dir=args.cache,
                          progress=False).problem()
    old = json.loads(args.out.read_text()) if args.out.exists() else {"records": []}
    sweep = (("up" if args.rpm[-1] >= args.rpm[0] else "down") if args.sweep else False)
    records = [r for r in old["records"]
               if not (r["case"] == args.case and r["rpm"] in args.rpm
                       and r.get("sweep", False) == sweep)]
    y = None
    for rpm in args.rpm:
        near = nearest_branch_point(args.run, rpm)
        rec = {"scene": str(args.scene), "case": args.case, "rpm": rpm, "sweep": sweep,
               "hbm_nearest": {k: v for k, v in near.items() if k != "unknowns"}}
        if y is None or not args.sweep:
            pt = start_point(problem, near, rpm)
            rec.update(hbm_std=round(orbit_std(problem, pt), 4), hbm_stable=near["stable"],
                       hbm_kind=near["kind"])
            y = pt
        out, y, delta = integrate(problem, rpm, y, args.transient, args.window)
        rec.update(out)
        if args.trace:
            try:
                ap_pt = attractor_point(problem, rpm, delta)
            except Exception as exc:             # noqa: BLE001 - recorded, not fatal
                rec["attractor_orbit"] = f"no orbit of the harmonic set: {exc}"
            else:
                hstd = orbit_std(problem, ap_pt)
                off = hstd / rec["std_window"] - 1.0
                rec["attractor_orbit"] = {"std": round(hstd, 4),
                                          "vs_time_integration": round(off, 6)}
                if abs(off) < 1e-3:
                    rec["attractor_branch"] = trace_attractor(problem, scene, ap_pt,
                                                              tuple(args.trace))
        log.info("%s %.0f rpm: HBM std %.2f N near (stable %s); attractor std %.2f N, "
                 "lines %s", args.case, rpm, rec["hbm_nearest"]["std"],
                 rec["hbm_nearest"]["stable"], rec["std_window"],
                 ", ".join(f"{ln['order']:g}: {ln['N']:.1f} N" for ln in rec["lines"][:5]))
        records.append(rec)
        with atomic_write(args.out, "w") as fh:
            json.dump({"records": records}, fh, indent=1)
            fh.write("\n")
    return {"records": records}


if __name__ == "__main__":
    main()
