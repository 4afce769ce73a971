"""What a paper-like mesh-energy share does to the forced response: the pump's ROM with
its gears tied to heavy flywheels and a stiff lateral ground (an idealisation, not a pump).

docs/theory.md §13.4: the mesh mode of every pump structure tried keeps an effective
mesh-energy share ρ_½ ≈ 0.6–1.1 (the dynamic-factor peak moves by f½/f = 0.67–0.84
when k̄ is halved), where the paper's ρ = 0.32 would give 0.92. The last session's
hypothesis is that this share, not the TE, makes the resonances soften by 10–30 % when
the teeth separate. This script tests the hypothesis directly, on the cached ROM of the
shipped scene: it adds, on both gears' DOF (which Craig–Bampton keeps as physical
DOF, so this is exact for lumped parts),

* a rotational inertia ``dI`` (× the blank's J_z) on the gear axis (θ3 of the Fig. 1
  frame), and a flywheel of inertia ``Ir`` (× J_z) joined to it by a torsional spring
  ``kt`` — one new DOF per gear. The flywheel is not grounded: a torsional spring to
  ground would carry part of the static load torque and unload the mesh (F_s ≠ T/r_b);
  the free flywheel passes no static torque and, heavy enough, is a ground at the mesh
  frequencies (``Ir ω² ≫ kt``). It also lowers the drivetrain mode (motor spring
  against all inertias), which the external excitation sees;
* a mass ``dm`` (× the blank's mass) and a spring ``ky`` to ground on the two in-plane
  translations (u1, u2),

recomputes the 5 % modal damping (eq. 17–19) and runs the three excitation cases of
``geardyn excitations`` (their overrides, :func:`study.excitations.case_scenes`) with
the cheap 3/1 set on that ROM. Everything else — k̄, TE, loads, the harmonic set — is
the scene's (``--set`` overrides apply first). Output: one JSON line per case with the
curve summary (``--json`` to keep them).

Run (one heavy run at a time; ~1–3 min per case)::

    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 nice .venv/bin/python -m benchmarks.grounded_gears \\
        --dI 3 --Ir 30 --kt 2.6e6 --dm 2.5 --ky 2e9 --set mesh_stiffness.mean_N_per_um=235.3 ...

Not a timing benchmark (not picked up by ``run_all``).
"""
from __future__ import annotations

import argparse
import json
import logging
import math
import time
from pathlib import Path

import numpy as np

from benchmarks.common import write_json

log = logging.getLogger("grounded_gears")
ROOT = Path(__file__).resolve().parent.parent
SCENE = ROOT / "scenes" / "pump.toml"
CHEAP = {"hbm.harmonic_set": "combinations", "hbm.mesh_harmonics": 3,
         "hbm.sideband_order": 1}
#: Gear DOF in the ROM (Fig. 1 frame, gear 1 then gear 2): in-plane translations, axis rotation.
TRANSLATIONS = (0, 1, 6, 7)
ROTATIONS = (5, 11)


def ground_gears(M: np.ndarray, K: np.ndarray, G: np.ndarray, dI: float, Ir: float,
                 kt: float, dm: float, ky: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``M``, ``K``, ``G`` with inertia ``dI`` [kg·m²] on each gear's rotation, a flywheel
    ``Ir`` [kg·m²] joined to it by ``kt`` [N·m/rad] (two new DOF, appended), and mass
    ``dm`` [kg] and a spring ``ky`` [N/m] to ground on each in-plane translation."""
    n = M.shape[0]
    Me, Ke = np.zeros((n + 2, n + 2)), np.zeros((n + 2, n + 2))
    Me[:n, :n], Ke[:n, :n] = M, K
    for j, i in enumerate(ROTATIONS):
        r = n + j
        Me[i, i] += dI
        Me[r, r] = Ir
        Ke[i, i] += kt
        Ke[r, r] += kt
        Ke[i, r] -= kt
        Ke[r, i] -= kt
    for i in TRANSLATIONS:
        Me[i, i] += dm
        Ke[i, i] += ky
    return Me, Ke, np.concatenate([G, np.zeros(2)])


def run(overrides: dict, dI_f: float, Ir_f: float, kt: float, dm_f: float, ky: float,
        out: Path, cache: Path, converged: bool = False) -> list[dict]:
    """The three excitation cases on the grounded ROM (the cheap 3/1 set, or the scene's
    own converged set); their curve summaries."""
    from benchmarks.pump_structure import F_GRID, dynamic_factor_peak
    from fem.pump import GearParams
    from hbm import trace
    from reduction import coupled_modes, mesh_energy, modal_damping
    from study import fe_stages
    from study.curves import summarize_branch
    from study.excitations import case_scenes
    from study.model import build_problem
    from study.pipeline import Pipeline
    from study.scene_load import load_scene

    g = GearParams()
    ro, ri = g.blank_outer_radius(1), g.bore_radius
    m_g = g.density * math.pi * (ro**2 - ri**2) * g.face_width
    j_g = 0.5 * m_g * (ro**2 + ri**2)
    scene = load_scene(SCENE, overrides if converged else {**CHEAP, **overrides})
    rom_dir = Pipeline(scene, out, cache_dir=cache).run_rom()
    rd = fe_stages.load_rom_data(scene, rom_dir)
    M, K, G = ground_gears(rd.M, rd.K, rd.G, dI_f * j_g, Ir_f * j_g, kt, dm_f * m_g, ky)
    km, xi = scene.mesh_stiffness.mean, scene.damping.modal_ratio
    f = coupled_modes(M, K, G, km).frequencies_hz
    rho = mesh_energy(M, K, G, km)
    j = int(np.argmax(rho))
    fp, _ = dynamic_factor_peak(M, K, G, km, F_GRID)
    fh, _ = dynamic_factor_peak(M, K, G, 0.5 * km, F_GRID)
    head = {"harmonic_set": "scene" if converged else "3/1", "dI_over_J": dI_f,
            "Ir_over_J": Ir_f, "kt_Nm_per_rad": kt, "dm_over_m": dm_f,
            "ky_N_per_m": ky, "drivetrain_hz": float(f[~np.isclose(f, 0.0)][0]),
            "overrides": overrides, "mesh_mode_hz": float(f[j]), "mesh_energy": float(rho[j]),
            "peak_hz": fp, "half_ratio": fh / fp,
            "modes": [[round(float(a), 1), round(float(b), 3)]
                      for a, b in zip(f, rho, strict=True) if b > 0.03 and a < 7000.0]}
    log.info("grounded ROM: mode %.0f Hz ρ %.2f, D peak %.0f Hz, f½/f %.3f, first mode "
             "%.0f Hz", f[j], rho[j], fp, fh / fp, head["drivetrain_hz"])
    C = modal_damping(M, K, G, km, xi)
    rows = []
    for case, sc in case_scenes(scene).items():
        const, om2 = fe_stages.rom_forcing(sc, rd.node_rows, rd.M.shape[0])
        const = {k: np.concatenate([v, np.zeros(2)]) for k, v in const.items()}
        om2 = {k: np.concatenate([v, np.zeros(2)]) for k, v in om2.items()}
        # the case scenes differ in k_m harmonics, TE and loads, not in k̄ or ξ
        problem = build_problem(sc, M, C, K, G, const, om2)
        c = sc.continuation
        lo, hi = c.speed
        t0 = time.perf_counter()
        br = trace(problem, lo, hi, step=c.step / (hi - lo), min_step=c.min_step / (hi - lo),
                   max_step=c.max_step / (hi - lo), tol=c.tolerance, max_points=c.max_points,
                   stability=sc.hbm.stability)
        s = summarize_branch(br)
        best = s.strongest(3)
        rows.append({**head, "case": case, "status": br.status,
                     "seconds": round(time.perf_counter() - t0, 1),
                     "resonances_rpm": [p.rpm for p in best],
                     "resonances_N": [p.std for p in best], "grazing_rpm": s.grazing,
                     "windows_rpm": s.windows, "impacts_rpm": s.impacts, "span_rpm": s.span,
                     "max_std_N": s.max_std, "max_std_rpm": s.max_std_rpm})
        log.info("%s: %s, peaks %s rpm, grazing %s, windows %s, span %.0f rpm", case,
                 br.status, ", ".join(f"{p.rpm:.0f}" for p in best),
                 ", ".join(f"{v:.0f}" for v in s.grazing),
                 ", ".join(f"{a:.0f}–{b:.0f}" for a, b in s.windows) or "none", s.span)
    return rows


COLUMNS = ["set", "dI/J, Ir/J, kt (N·m/rad), dm/m, ky (N/m)", "overrides",
           "modes ρ > 3 % (Hz: ρ)",
           "D peak (Hz), f½/f", "case", "peaks (rpm)", "grazing (rpm)", "windows (rpm)",
           "span (rpm)"]


def save(path: Path, runs: list[dict]) -> None:
    """Write the runs with a table of them for BENCHMARKS.md (benchmarks.report)."""
    rows = [[r.get("harmonic_set", "3/1"),
             f"{r['dI_over_J']:g}, {r.get('Ir_over_J', 0):g}, {r['kt_Nm_per_rad']:.3g}, "
             f"{r['dm_over_m']:g}, {r['ky_N_per_m']:.3g}",
             ", ".join(f"{k}={v}" for k, v in r["overrides"].items()) or "–",
             ", ".join(f"{a:.0f}: {b:.2f}" for a, b in r["modes"]) if "modes" in r
             else f"{r['mesh_mode_hz']:.0f}, {r['mesh_energy']:.2f}",
             f"{r['peak_hz']:.0f}, {r['half_ratio']:.3f}", r["case"],
             ", ".join(f"{v:.0f}" for v in r["resonances_rpm"]),
             ", ".join(f"{v:.0f}" for v in r["grazing_rpm"]),
             ", ".join(f"{lo:.0f}–{hi:.0f}" for lo, hi in r["windows_rpm"]) or "none",
             f"{r['span_rpm']:.0f}"] for r in runs]
    write_json("grounded_gears", {
        "command": ".venv/bin/python -m benchmarks.grounded_gears --dI .. --Ir .. --kt .. "
                   "--dm .. --ky .. [--set ..] --json benchmarks/results/grounded_gears.json",
        "summary": "Three excitation cases (3/1 set) on the pump ROM with its gears tied to "
                   "flywheels and a lateral ground (docs/theory.md §13.4, an idealisation).",
        "runs": runs, "tables": [{"title": "runs", "columns": COLUMNS, "rows": rows}]}, path)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--dI", type=float, default=0.0, help="added inertia / blank J_z")
    p.add_argument("--Ir", type=float, default=1.0, help="flywheel inertia / blank J_z")
    p.add_argument("--kt", type=float, default=0.0, help="gear-flywheel spring [N·m/rad]")
    p.add_argument("--dm", type=float, default=0.0, help="added mass / blank mass")
    p.add_argument("--ky", type=float, default=0.0, help="lateral spring to ground [N/m]")
    p.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=VALUE")
    p.add_argument("--converged", action="store_true",
                   help="the scene's own (converged 12/3) harmonic set instead of the cheap one")
    p.add_argument("--json", type=Path, default=None, help="append the rows to this file")
    p.add_argument("--work", type=Path, default=ROOT / "out" / "grounded")
    p.add_argument("--cache", type=Path, default=ROOT / "out" / "cache")
    a = p.parse_args(argv)
    logging.basicConfig(level=logging.WARNING, format="%(asctime)s %(levelname)-7s "
                        "%(name)s: %(message)s", datefmt="%H:%M:%S")
    log.setLevel(logging.INFO)
    from study.scene_overrides import parse_set_values

    ov: dict = {}
    for item in a.set:
        k, v = item.split("=", 1)
        (val,) = parse_set_values(v)
        ov[k.strip()] = val
    rows = run(ov, a.dI, a.Ir, a.kt, a.dm, a.ky, a.work, a.cache, a.converged)
    if a.json is not None:
        old = json.loads(a.json.read_text()) if a.json.exists() else {}
        save(a.json, old.get("runs", []) + rows)
    print("\n".join(json.dumps(r) for r in rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
