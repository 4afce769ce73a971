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
``geardyn excitations`` (their overrides, :func:`study.studies.excitations.case_scenes`) with
the cheap 3/1 set on that ROM. Everything else — k̄, TE, loads, the harmonic set — is
the scene's (``--set`` overrides apply first; ``--te-scale`` then multiplies the loaded
STE amplitudes). Output: one JSON line per case with the curve summary, the primary
peak as ``geardyn excitations`` takes it and, against the internal-only case of the
same call, its std change and the span change (``--json`` to keep them).

The linear measures logged first (``--linear``: only these, kept as "screens") are the
modes with ρ > 3 % below 7 kHz, the mesh mode (most ρ above 1 kHz) and the flywheel
mode (most ρ below, the flywheels against each other through the mesh) with the speeds
where H_Z…H_3Z hit them, the drivetrain mode (motor spring against the flywheels) with
the speeds where the shaft orders 1, 2 and 4 cross it, and the D peak with f½/f (T.33).

Run (one heavy run at a time; ~1–3 min per case)::

    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 nice .venv/bin/python -m benchmarks.grounded_gears \\
        --dI 3 --Ir 110 --kt 2.4e6 --dm 2.5 --ky 2e9 --set mesh_stiffness.mean_N_per_um=235.3 \\
        --set "mesh_stiffness.amplitudes_N_per_um=[44.35,37.37,27.2]" \\
        --set drive.motor_torsional_stiffness=1e3 --label NAME [--te-scale S] [--linear]

Not a timing benchmark (not picked up by ``run_all``).
"""
from __future__ import annotations

import argparse
import json
import logging
import time
from pathlib import Path

import numpy as np

from benchmarks.common import scene_overrides, write_json

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
    return Me, Ke, np.concatenate([G, np.zeros((2, *np.shape(G)[1:]))])


def rim_on_web(M: np.ndarray, K: np.ndarray, G: np.ndarray, blanks: tuple, rim: np.ndarray,
               web: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``M``, ``K``, ``G`` with each gear's teeth moved onto a rim on a web: the 6x6
    ``blanks`` masses (gear 1, gear 2) are taken off the gear DOF (which become the gear
    body), a rim node of 6x6 mass ``rim`` is appended per gear (12 new DOF, gear 1 then
    gear 2), joined to the body by the 6x6 spring ``web``, and the mesh (``G``) acts on
    the rims. Masses in kg and kg·m², stiffness in N/m and N·m/rad (SI, as the ROM); all
    6x6 matrices in the gear-pair frame (for the disk, ring and web of
    ``fem.pump``, which are symmetric about the axis, the same as in the global frame)."""
    n = M.shape[0]
    Me, Ke = np.zeros((n + 12, n + 12)), np.zeros((n + 12, n + 12))
    Me[:n, :n], Ke[:n, :n] = M, K
    for g in range(2):
        body, ring = slice(6 * g, 6 * g + 6), slice(n + 6 * g, n + 6 * g + 6)
        Me[body, body] -= blanks[g]
        Me[ring, ring] += rim
        Ke[body, body] += web
        Ke[ring, ring] += web
        Ke[body, ring] -= web
        Ke[ring, body] -= web
    Ge = np.zeros((n + 12, *np.shape(G)[1:]))
    Ge[n:] = G[:12]
    return Me, Ke, Ge


#: Shaft orders of the external excitation (unbalance 1, aerodynamic 2 and 4, eq. 1–3).
ORDERS = (1, 2, 4)
#: A mode below this [Hz] is a flywheel (gear–rotor) mode, above it a mesh mode.
LOW_HZ = 1000.0


def drivetrain_mode(f: np.ndarray, phi: np.ndarray, M: np.ndarray, rho: np.ndarray,
                    n: int, kt: float) -> int:
    """Index of the drivetrain mode (motor spring against the rotating inertias): the
    elastic mode with most kinetic energy in the two flywheels (DOF ``n``, ``n + 1``) and
    least mesh energy; without flywheel springs (``kt = 0``), the first elastic mode."""
    elastic = ~np.isclose(f, 0.0)
    if kt == 0.0:
        return int(np.flatnonzero(elastic)[0])
    ke = np.array([phi[n:, j] @ M[n:, n:] @ phi[n:, j] / (phi[:, j] @ M @ phi[:, j])
                   for j in range(len(f))])
    return int(np.argmax(np.where(elastic, ke * (1.0 - rho), -1.0)))


def linear_measures(M: np.ndarray, K: np.ndarray, G: np.ndarray, km: float, n: int,
                    kt: float, teeth: int) -> dict:
    """Linear measures of the grounded ROM (``n``: the ROM's size, flywheels after it):
    modes with ρ > 3 % below 7 kHz, the mesh mode (most ρ above :data:`LOW_HZ`) and the
    flywheel mode (most ρ below it) with the speeds of H_Z…H_3Z on them, the drivetrain
    mode with the speeds where the external orders cross it, and the dynamic-factor peak
    with its shift under k̄/2 (T.32–33)."""
    from benchmarks.pump_structure import F_GRID, dynamic_factor_peak
    from reduction import coupled_modes, mesh_energy

    cm = coupled_modes(M, K, G, km)
    f = cm.frequencies_hz
    rho = mesh_energy(M, K, G, km)
    hi = f >= LOW_HZ
    j = int(np.flatnonzero(hi)[np.argmax(rho[hi])])
    lo = ~hi & (rho > 0.03)
    jl = int(np.flatnonzero(lo)[np.argmax(rho[lo])]) if lo.any() else None
    jd = drivetrain_mode(f, cm.phi, M, rho, n, kt)
    fp, _ = dynamic_factor_peak(M, K, G, km, F_GRID)
    fh, _ = dynamic_factor_peak(M, K, G, 0.5 * km, F_GRID)
    out = {"drivetrain_hz": float(f[jd]), "drivetrain_rho": float(rho[jd]),
           "drivetrain_cross_rpm": {f"order {o}": 60.0 * float(f[jd]) / o for o in ORDERS},
           "mesh_mode_hz": float(f[j]), "mesh_energy": float(rho[j]),
           "mesh_mode_rpm": [60.0 * float(f[j]) / (k * teeth) for k in (1, 2, 3)],
           "low_mode_hz": None if jl is None else float(f[jl]),
           "low_mode_rho": None if jl is None else float(rho[jl]),
           "low_mode_rpm": None if jl is None else
           [60.0 * float(f[jl]) / (k * teeth) for k in (1, 2, 3)],
           "peak_hz": fp, "half_ratio": fh / fp,
           "modes": [[round(float(a), 1), round(float(b), 3)]
                     for a, b in zip(f, rho, strict=True) if b > 0.03 and a < 7000.0],
           "modes_below_500_hz": [[round(float(a), 1), round(float(b), 4)]
                                  for a, b in zip(f, rho, strict=True) if 0.0 < a < 500.0]}
    log.info("grounded ROM: mesh mode %.0f Hz ρ %.3f; low mode %s; D peak %.0f Hz, f½/f "
             "%.3f; drivetrain %.1f Hz (orders 1, 2, 4 at %s rpm)", f[j], rho[j],
             "none" if jl is None else f"{f[jl]:.0f} Hz ρ {rho[jl]:.3f} "
             f"(H_Z at {out['low_mode_rpm'][0]:.0f} rpm)", fp, fh / fp, f[jd],
             ", ".join(f"{v:.0f}" for v in out["drivetrain_cross_rpm"].values()))
    return out


def scaled_te(overrides: dict, scale: float) -> dict:
    """``overrides`` with the TE amplitudes (the override's or the scene's) × ``scale``."""
    if scale == 1.0:
        return overrides
    if not scale > 0.0:
        raise ValueError(f"te_scale = {scale}: must be > 0")
    import tomllib

    key = "transmission_error.amplitudes_um"
    base = overrides.get(key)
    if base is None:
        base = tomllib.loads(SCENE.read_text())["transmission_error"]["amplitudes_um"]
    return {**overrides, key: [round(scale * float(a), 6) for a in base]}


def run(overrides: dict, dI_f: float, Ir_f: float, kt: float, dm_f: float, ky: float,
        out: Path, cache: Path, converged: bool = False, te_scale: float = 1.0,
        cases: tuple[str, ...] = ("internal", "external", "all"), linear: bool = False,
        label: str = "") -> list[dict]:
    """The excitation cases (``cases`` of the three) on the grounded ROM (the cheap 3/1
    set, or the scene's own converged set); their curve summaries. ``linear``: only the
    linear measures (one row, no forced response)."""
    from fem.lumped import disk_mass
    from fem.pump import GearParams
    from hbm import trace
    from machines import LinearModel, machine_for
    from reduction import modal_damping
    from study.outputs.curves import primary_peak, summarize_branch
    from study.pipeline import Pipeline
    from study.pipeline.model import build_problem
    from study.scene.load import load_scene
    from study.studies.excitations import case_scenes

    g = GearParams()
    blank = disk_mass(g.blank_outer_radius(1), g.bore_radius, g.face_width, g.density)
    m_g, j_g = blank[0, 0], blank[5, 5]  # the blank the pump model carries (pump_spec)
    overrides = scaled_te(overrides, te_scale)
    scene = load_scene(SCENE, overrides if converged else {**CHEAP, **overrides})
    rom_dir = Pipeline(scene, out, cache_dir=cache).run_rom()
    rd = machine_for(scene).load_rom(rom_dir)
    n = rd.M.shape[0]
    M, K, G = ground_gears(rd.M, rd.K, rd.G, dI_f * j_g, Ir_f * j_g, kt, dm_f * m_g, ky)
    km, xi = scene.mesh_stiffness.mean, scene.damping.modal_ratio
    head = {"label": label, "harmonic_set": "scene" if converged else "3/1",
            "dI_over_J": dI_f, "Ir_over_J": Ir_f, "kt_Nm_per_rad": kt, "dm_over_m": dm_f,
            "ky_N_per_m": ky, "te_scale": te_scale, "J_g_kgm2": j_g, "m_g_kg": m_g,
            "overrides": overrides,
            **linear_measures(M, K, G, km, n, kt, scene.gear.teeth)}
    if linear:
        return [{**head, "case": "linear"}]
    C = modal_damping(M, K, G, km, xi)
    rows, summaries = [], {}
    for case, sc in case_scenes(scene).items():
        if case not in cases:
            continue
        machine = machine_for(sc)
        const, om2 = machine.rom_forcing(rd.node_rows, n)
        const = {k: np.concatenate([v, np.zeros(2)]) for k, v in const.items()}
        om2 = {k: np.concatenate([v, np.zeros(2)]) for k, v in om2.items()}
        # the case scenes differ in k_m harmonics, TE and loads, not in k̄ or ξ
        problem = build_problem(sc, machine, LinearModel(M, C, K, G, const, om2))
        c = sc.continuation
        lo, hi = c.speed
        t0 = time.perf_counter()
        br = trace(problem, lo, hi, step=c.step / (hi - lo), min_step=c.min_step / (hi - lo),
                   max_step=c.max_step / (hi - lo), tol=c.tolerance, max_points=c.max_points,
                   stability=sc.hbm.stability)
        s = summaries[case] = summarize_branch(br)
        best = s.strongest(3)
        # the primary peak as geardyn excitations takes it (study.studies.excitations): the
        # largest of the internal-only curve, on the others the largest within ±15 %
        pi = primary_peak(summaries["internal"]) if "internal" in summaries else None
        pk = primary_peak(s) if case == "internal" or pi is None else \
            primary_peak(s, near=pi.rpm)
        row = {**head, "case": case, "status": br.status,
               "seconds": round(time.perf_counter() - t0, 1),
               "resonances_rpm": [p.rpm for p in best],
               "resonances_N": [p.std for p in best], "grazing_rpm": s.grazing,
               "windows_rpm": s.windows, "impacts_rpm": s.impacts, "span_rpm": s.span,
               "max_std_N": s.max_std, "max_std_rpm": s.max_std_rpm,
               "primary_rpm": None if pk is None else pk.rpm,
               "primary_N": None if pk is None else pk.std}
        if case != "internal" and "internal" in summaries and pi is not None:
            si = summaries["internal"]
            row["primary_change"] = None if pk is None else (pk.std - pi.std) / pi.std
            row["span_change"] = (s.span - si.span) / si.span if si.span > 0 else None
        rows.append(row)
        log.info("%s: %s, peaks %s rpm, grazing %s, windows %s, span %.0f rpm, primary "
                 "%s", case, br.status, ", ".join(f"{p.rpm:.0f}" for p in best),
                 ", ".join(f"{v:.0f}" for v in s.grazing),
                 ", ".join(f"{a:.0f}–{b:.0f}" for a, b in s.windows) or "none", s.span,
                 "none" if pk is None else f"{pk.std:.1f} N at {pk.rpm:.0f} rpm")
    return rows


COLUMNS = ["label", "set", "dI/J, Ir/J, kt (N·m/rad), dm/m, ky (N/m)", "overrides",
           "modes ρ > 3 % (Hz: ρ)", "drivetrain (Hz; orders 2, 4 at rpm)",
           "D peak (Hz), f½/f", "case", "peaks (rpm)", "grazing (rpm)", "windows (rpm)",
           "span (rpm)", "primary (N at rpm; change)", "span change"]


def _pct(x: float | None) -> str:
    return "–" if x is None else f"{100.0 * x:+.1f} %"


def _drive(r: dict) -> str:
    if "drivetrain_cross_rpm" not in r:
        return f"{r['drivetrain_hz']:.0f}" if "drivetrain_hz" in r else "–"
    c = r["drivetrain_cross_rpm"]
    return f"{r['drivetrain_hz']:.1f}; {c['order 2']:.0f}, {c['order 4']:.0f}"


def _row(r: dict) -> list[str]:
    modes = ", ".join(f"{a:.0f}: {b:.2f}" for a, b in r["modes"]) if "modes" in r \
        else f"{r['mesh_mode_hz']:.0f}, {r['mesh_energy']:.2f}"
    forced = r["case"] != "linear"
    prim = "–" if r.get("primary_N") is None else \
        f"{r['primary_N']:.1f} at {r['primary_rpm']:.0f}" + \
        ("" if r.get("primary_change") is None else f"; {_pct(r['primary_change'])}")
    return [r.get("label", ""), r.get("harmonic_set", "3/1"),
            f"{r['dI_over_J']:g}, {r.get('Ir_over_J', 0):g}, {r['kt_Nm_per_rad']:.3g}, "
            f"{r['dm_over_m']:g}, {r['ky_N_per_m']:.3g}",
            ", ".join(f"{k}={v}" for k, v in r["overrides"].items()) or "–", modes,
            _drive(r), f"{r['peak_hz']:.0f}, {r['half_ratio']:.3f}", r["case"],
            ", ".join(f"{v:.0f}" for v in r["resonances_rpm"]) if forced else "–",
            ", ".join(f"{v:.0f}" for v in r["grazing_rpm"]) if forced else "–",
            (", ".join(f"{lo:.0f}–{hi:.0f}" for lo, hi in r["windows_rpm"]) or "none")
            if forced else "–",
            f"{r['span_rpm']:.0f}" if forced else "–", prim, _pct(r.get("span_change"))]


def save(path: Path, runs: list[dict], screens: list[dict]) -> None:
    """Write the runs and the linear screens with a table of each for BENCHMARKS.md
    (benchmarks.report)."""
    write_json("grounded_gears", {
        "command": ".venv/bin/python -m benchmarks.grounded_gears --dI .. --Ir .. --kt .. "
                   "--dm .. --ky .. [--set ..] [--te-scale ..] [--linear] "
                   "--json benchmarks/results/grounded_gears.json",
        "summary": "Three excitation cases (3/1 set) on the pump ROM with its gears tied to "
                   "flywheels and a lateral ground (docs/theory.md §13.4, an idealisation).",
        "runs": runs, "screens": screens,
        "tables": [{"title": "runs", "columns": COLUMNS, "rows": [_row(r) for r in runs]},
                   {"title": "linear screens", "columns": COLUMNS,
                    "rows": [_row(r) for r in screens]}]}, path)


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
    p.add_argument("--te-scale", type=float, default=1.0,
                   help="scale of the TE amplitudes (the scene's or --set's)")
    p.add_argument("--cases", default="internal,external,all",
                   help="comma-separated subset of internal, external, all")
    p.add_argument("--linear", action="store_true",
                   help="only the linear measures (modes, D peak, drivetrain), no forced run")
    p.add_argument("--label", default="", help="name of the candidate in the JSON")
    p.add_argument("--json", type=Path, default=None, help="append the rows to this file")
    p.add_argument("--work", type=Path, default=ROOT / "out" / "grounded")
    p.add_argument("--cache", type=Path, default=ROOT / "out" / "cache")
    a = p.parse_args(argv)
    logging.basicConfig(level=logging.WARNING, format="%(asctime)s %(levelname)-7s "
                        "%(name)s: %(message)s", datefmt="%H:%M:%S")
    log.setLevel(logging.INFO)
    ov = scene_overrides(a.set)
    cases = tuple(c.strip() for c in a.cases.split(","))
    bad = [c for c in cases if c not in ("internal", "external", "all")]
    if bad:
        p.error(f"--cases {a.cases}: {bad} not among internal, external, all")
    rows = run(ov, a.dI, a.Ir, a.kt, a.dm, a.ky, a.work, a.cache, a.converged, a.te_scale,
               cases, a.linear, a.label)
    if a.json is not None:
        old = json.loads(a.json.read_text()) if a.json.exists() else {}
        if a.linear:
            save(a.json, old.get("runs", []), old.get("screens", []) + rows)
        else:
            save(a.json, old.get("runs", []) + rows, old.get("screens", []))
    print("\n".join(json.dumps(r) for r in rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
