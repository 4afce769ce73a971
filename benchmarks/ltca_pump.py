"""Mesh stiffness and STE of the pump's gear pair from the loaded tooth contact analysis.

Prints the comparison table of docs/theory.md §13.3 (the calibrated and invented values
of scenes/pump.toml and scenes/pump-paper.toml beside gears.ltca's for perfect teeth and
for ISO 1328-1:2013 class-6 deviations, at T = 2.5 and 3.29 N·m) and, with
``--json FILE``, writes the numbers atomically. Not a timing benchmark (not picked up
by ``run_all``).

Run: ``.venv/bin/python -m benchmarks.ltca_pump [--json FILE] [--positions N] [--slices N]
[--sets] [--docs]`` (``--sets`` prints each case's ``--set`` options for ``geardyn``;
``--docs`` rewrites the table of docs/gears.md, "Table 1's pair at class 6, beside the
shipped scenes", with a last row of pump.toml switched to ``source = "ltca"`` through the
scene loader; benchmarks/tests/test_ltca_pump.py checks the file holds what this
produces).
"""
from __future__ import annotations

import argparse
import json
import logging
import math
from pathlib import Path

import gears as tc
from core.files import atomic_write
from gears.iso6336 import pair_stiffness
from study.scene import load_scene

log = logging.getLogger("ltca_pump")
ROOT = Path(__file__).resolve().parent.parent
BORE = 0.016   # r_int of both gear bodies (m), docs/theory.md §13.3
# the shipped scenes whose calibrated values the table shows beside the LTCA's
SCENES = {"pump.toml": "k̄ calibrated, TE invented", "pump-paper.toml": "k̄ ISO 6336, TE "
          "calibrated against the grazings"}

# name -> keyword arguments of gears.class_deviations (None: perfect teeth)
CASES: dict[str, dict | None] = {
    "perfect teeth": None,
    "class 6, profile only (gear 1)": {"slope_signs": (1, 0), "form_signs": (1, 0),
                                       "helix": False},
    "class 6, profile + helix (gear 1)": {"slope_signs": (1, 0), "form_signs": (1, 0)},
    "class 6 at half tolerance": {"slope_signs": (1, 0), "form_signs": (1, 0),
                                  "fraction": 0.5},
    "class 6, slopes opposite (both gears) + helix": {"slope_signs": (1, -1), "form_signs": (1, 1)},
}


def scene_values(scene) -> dict:
    """A scene's mesh stiffness and TE series in N/µm, µm and degrees."""
    ms, te = scene.mesh_stiffness, scene.transmission_error
    return {"mesh_stiffness": {"mean_N_per_um": ms.mean * 1e-6,
                               "amplitudes_N_per_um": [a * 1e-6 for a in ms.amplitudes],
                               "phases_deg": [math.degrees(p) for p in ms.phases]},
            "transmission_error": {"mean_um": te.mean * 1e6,
                                   "amplitudes_um": [a * 1e6 for a in te.amplitudes],
                                   "phases_deg": [math.degrees(p) for p in te.phases]},
            "torque_Nm": scene.load.torque}


def measure(torques: tuple[float, ...], positions: int, slices: int) -> dict:
    """Scene values and LTCA coefficients per case and torque."""
    scenes = {name: load_scene(ROOT / "scenes" / name) for name in SCENES}
    pair = scenes["pump.toml"].gear.pair()
    bores = (BORE, BORE)
    c_prime, c_gamma = pair_stiffness(pair)
    s_p = pair.pitch_radii[0] * math.sin(pair.working_pressure_angle)
    k_pitch = pair.face_width / tc.pair_compliance(pair, [s_p], bores)[0]
    out: dict = {
        "scenes": {name: scene_values(scene) for name, scene in scenes.items()},
        "pitch_point_pair_N_per_um": k_pitch * 1e-6,
        "iso6336_c_prime_N_per_um": c_prime * 1e-6,
        "iso6336_c_gamma_N_per_um": c_gamma * 1e-6,
        "iso1328_class6_um": tc.class_deviations(pair, 6)[1],
        "contact_ratio": pair.transverse_contact_ratio,
        "cases": {},
    }
    for name, kw in CASES.items():
        flanks = (tc.Flank(), tc.Flank()) if kw is None else tc.class_deviations(pair, 6, **kw)[0]
        for torque in torques:
            case = tc.LtcaCase(pair, torque, bores, flanks=flanks, n_positions=positions,
                               n_slices=slices)
            res = tc.solve_ltca(case)
            coef = tc.scene_coefficients(res, 3)
            coef["load_N"] = case.load
            coef["F_s_over_kbar_um"] = case.load / res.stiffness.mean() * 1e6
            out["cases"][f"{name} @ {torque} N·m"] = coef
    return out


def table(data: dict) -> str:
    """Markdown table of the measured values."""
    def fmt(v: list[float], p: list[float]) -> str:
        return ", ".join(f"{a:.3g} ∠{q:.0f}°" for a, q in zip(v, p, strict=True))

    rows = ["| case | k̄ (N/µm) | k_m harmonics (N/µm ∠φ) | q_s harmonics (µm ∠φ) | "
            "F_s/k̄ (µm) |", "|---|---|---|---|---|"]
    for name, s in data["scenes"].items():
        sm, st = s["mesh_stiffness"], s["transmission_error"]
        rows.append(f"| scenes/{name} ({SCENES[name]}), {s['torque_Nm']} N·m | "
                    f"{sm['mean_N_per_um']:.1f} | "
                    f"{fmt(sm['amplitudes_N_per_um'], sm['phases_deg'])} | "
                    f"{fmt(st['amplitudes_um'], st['phases_deg'])} | – |")
    for name, c in data["cases"].items():
        ms, te = c["mesh_stiffness"], c["transmission_error"]
        rows.append(f"| {name} | {ms['mean_N_per_um']:.1f} | "
                    f"{fmt(ms['amplitudes_N_per_um'], ms['phases_deg'])} | "
                    f"{fmt(te['amplitudes_um'], te['phases_deg'])} | "
                    f"{c['F_s_over_kbar_um']:.3f} |")
    return "\n".join(rows)


#: Torque of the docs/gears.md table (N·m): the pump scenes'.
DOCS_TORQUE = 3.29
DOCS = ROOT / "docs" / "gears.md"
BEGIN = ("<!-- table generated by `python -m benchmarks.ltca_pump --docs` (checked by "
         "benchmarks/tests/test_ltca_pump.py); do not edit -->")
END = "<!-- end of the generated table -->"


def scene_ltca(positions: int, slices: int, kw: dict) -> dict:
    """pump.toml with ``source = "ltca"`` in both tables and the class-6 deviations of
    ``kw`` written as its ``[micro_geometry]`` (µm), through the scene loader: the
    series the dynamics would get (3 harmonics)."""
    from study.scene.load import resolved_table, scene_from_dict

    raw = resolved_table(ROOT / "scenes" / "pump.toml")
    pair = load_scene(ROOT / "scenes" / "pump.toml").gear.pair()
    flanks, _ = tc.class_deviations(pair, 6, **kw)
    raw["mesh_stiffness"] = {"source": "ltca"}
    raw["transmission_error"] = {"source": "ltca"}
    raw["hbm"] = {**raw.get("hbm", {}), "mesh_harmonics": 3}
    raw["hbm"].pop("harmonics", None)
    raw["micro_geometry"] = {
        f"gear{i}": {"profile_slope_um": f.profile_slope * 1e6,
                     "profile_form_um": f.profile_form * 1e6,
                     "lead_slope_um": f.lead_slope * 1e6}
        for i, f in enumerate(flanks, start=1)}
    raw["ltca"] = {"n_positions": positions, "n_slices": slices,
                   "bore_diameter_mm": [2e3 * BORE, 2e3 * BORE]}
    scene = scene_from_dict(raw, "pump-ltca", base=ROOT / "scenes")
    return scene_values(scene)


def docs_table(data: dict) -> str:
    """The table of docs/gears.md ("Table 1's pair at class 6, beside the shipped
    scenes") from :func:`measure`'s numbers at :data:`DOCS_TORQUE`, between its markers."""
    def harm(v: list[float], p: list[float]) -> str:
        return ", ".join(f"{a:.3g} ∠{q % 360.0:.0f}°" for a, q in zip(v, p, strict=True))

    rows = [BEGIN, "",
            "| case | T (N·m) | k̄ (N/µm) | k_m H_Z, H_2Z, H_3Z (N/µm) | q_s H_Z, H_2Z, H_3Z "
            "(µm) |", "|---|---|---|---|---|"]

    def row(name: str, torque: float, ms: dict, te: dict) -> str:
        return (f"| {name} | {torque:g} | {ms['mean_N_per_um']:.1f} | "
                f"{harm(ms['amplitudes_N_per_um'][:3], ms['phases_deg'][:3])} | "
                f"{harm(te['amplitudes_um'][:3], te['phases_deg'][:3])} |")
    for name, s in data["scenes"].items():
        rows.append(row(f"`scenes/{name}` ({SCENES[name]})", s["torque_Nm"],
                        s["mesh_stiffness"], s["transmission_error"]))
    for name in CASES:
        c = data["cases"][f"{name} @ {DOCS_TORQUE} N·m"]
        rows.append(row(f"LTCA, {name}", DOCS_TORQUE, c["mesh_stiffness"],
                        c["transmission_error"]))
    if "scene_ltca" in data:
        s = data["scene_ltca"]
        rows.append(row("`scenes/pump.toml` with `source = \"ltca\"`, class 6 profile + helix "
                        "in `[micro_geometry]`", s["torque_Nm"], s["mesh_stiffness"],
                        s["transmission_error"]))
    return "\n".join([*rows, "", END])


def write_docs(data: dict, path: Path = DOCS) -> None:
    """Replace the generated table of docs/gears.md (between its markers)."""
    text = path.read_text()
    a, b = text.index(BEGIN), text.index(END) + len(END)
    with atomic_write(path, "w") as fh:
        fh.write(text[:a] + docs_table(data) + text[b:])


def set_args(coef: dict) -> str:
    """The ``--set`` options that put one case's coefficients into a scene."""
    out = []
    for sec in ("mesh_stiffness", "transmission_error"):
        for key, v in coef[sec].items():
            if key == "kind":
                continue
            val = "[" + ",".join(f"{x:g}" for x in v) + "]" if isinstance(v, list) else f"{v:g}"
            out.append(f"--set '{sec}.{key}={val}'")
    return " ".join(out)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", type=Path, default=None, help="write the numbers here")
    ap.add_argument("--positions", type=int, default=1440, help="positions per mesh period")
    ap.add_argument("--slices", type=int, default=1280, help="slices across the face width")
    ap.add_argument("--sets", action="store_true",
                    help="also print each case's --set options for geardyn")
    ap.add_argument("--docs", action="store_true",
                    help="rewrite the generated table of docs/gears.md")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    data = measure((2.5, DOCS_TORQUE), args.positions, args.slices)
    data["scene_ltca"] = scene_ltca(args.positions, args.slices,
                                    CASES["class 6, profile + helix (gear 1)"])
    log.info("pitch-point pair stiffness %.1f N/µm, ISO 6336 c' %.1f, c_γα %.1f N/µm, "
             "ε_α %.4f", data["pitch_point_pair_N_per_um"], data["iso6336_c_prime_N_per_um"],
             data["iso6336_c_gamma_N_per_um"], data["contact_ratio"])
    log.info("ISO 1328-1:2013 class 6 tolerances (µm): %s", data["iso1328_class6_um"])
    log.info("\n%s", table(data))
    if args.sets:
        for name, coef in data["cases"].items():
            log.info("%s:\n  %s", name, set_args(coef))
    if args.docs:
        write_docs(data)
        log.info("rewrote the table of %s", DOCS)
    if args.json is not None:
        with atomic_write(args.json, "w") as fh:
            json.dump(data, fh, indent=2)
            fh.write("\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
