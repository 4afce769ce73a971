"""Physical plausibility of scene inputs (study.scene.plausibility, issue 39 item 3)."""
from __future__ import annotations

import logging
from pathlib import Path

import pytest

from study.scene import SceneError, load_scene, scene_from_dict
from study.scene.plausibility import (
    BOUNDS,
    DYNAMIC_RATIO_USUAL,
    bounds_markdown,
    dynamic_ratio_warning,
    plausibility_warnings,
)

ROOT = Path(__file__).resolve().parents[1]
SDOF = ROOT / "scenes" / "gear-pair-sdof.toml"
PUMP = ROOT / "scenes" / "pump.toml"


@pytest.mark.parametrize("name", ["gear-pair-sdof", "pump", "pump-paper"])
def test_shipped_scenes_load_without_warning(name, caplog):
    with caplog.at_level(logging.WARNING, logger="study.scene.plausibility"):
        s = load_scene(ROOT / "scenes" / f"{name}.toml")
    assert plausibility_warnings(s) == []
    assert not caplog.records


@pytest.mark.parametrize(("override", "field", "unit", "shown"), [
    # the examples: a modulus in Pa, a density in g/cm³ mistaken for kg/m³,
    # bearings in N/m, a backlash in mm mistaken for µm
    ({"materials.shaft_E": 210.0}, "materials.shaft_E", "GPa", "210 (2.1e-07 GPa)"),
    ({"materials.housing_E_GPa": 2e-7}, "materials.housing_E_GPa", "GPa", "2e-07 GPa"),
    ({"materials.shaft_rho": 7.2}, "materials.shaft_rho", "kg/m³", "7.2 kg/m³"),
    ({"bearings.radial": 100.0}, "bearings.radial", "N/µm", "100 (0.0001 N/µm)"),
    ({"bearings.axial_N_per_um": 2e7}, "bearings.axial_N_per_um", "N/µm", "2e+07 N/µm"),
    ({"gear.backlash_um": 0.04}, "gear.backlash_um", "µm", "0.04 µm"),
    ({"drive.motor_torsional_stiffness": 0.2}, "drive.motor_torsional_stiffness", "N·m/rad",
     "0.2 N·m/rad"),
    ({"drive.impeller_inertia": 2e4}, "drive.impeller_inertia", "kg·m²", "2e+04 kg·m²"),
    # 20 mm on module 1.316 mm is 15.2; 0.5 mm (a face width in cm mistaken for mm) is 0.38
    ({"gear.face_width_mm": 0.5}, "gear.face_width_mm / gear.module_mm", "-", "0.38 -"),
])
def test_implausible_fe_and_gear_inputs_are_refused(override, field, unit, shown):
    with pytest.raises(SceneError) as err:
        load_scene(PUMP, override)
    e = err.value
    assert e.field == field and e.unit == unit
    assert str(e).startswith(f"{field} = {shown}: outside the plausible range")


def test_lumped_mesh_stiffness_and_density_bounds():
    # 0.22 N/µm: the stiffness given in the wrong unit
    with pytest.raises(SceneError, match=r"^mesh_stiffness\.mean_N_per_um = 0\.22 N/µm: outside"
                       r" the plausible range \[1, 100000\] N/µm"):
        load_scene(SDOF, {"mesh_stiffness.mean_N_per_um": 0.22,
                          "mesh_stiffness.amplitudes_N_per_um": [0.041, 0.035, 0.025]})
    # 3 N/µm on a 20 mm face: 0.15 N/(mm·µm), beyond the per-face-width bound 0.2
    with pytest.raises(SceneError, match=r"^mesh_stiffness\.mean_N_per_um / gear\.face_width_mm"
                       r" = 0\.15 N/\(mm·µm\): outside the plausible range \[0\.2, 300\]"):
        load_scene(SDOF, {"mesh_stiffness.mean_N_per_um": 3.0,
                          "mesh_stiffness.amplitudes_N_per_um": [0.41, 0.35, 0.25]})
    with pytest.raises(SceneError, match=r"^lumped\.density_kg_per_m3 = 7\.8 kg/m³"):
        load_scene(SDOF, {"lumped.density_kg_per_m3": 7.8})
    # the static deflection F_s/k̄ = (11000 N·m / 46.984 mm) / 220 N/µm = 1064 µm > 1000 µm
    with pytest.raises(SceneError, match=r"load\.torque_Nm / mesh_stiffness\.mean_N_per_um = "
                       r"1064 µm: outside the plausible range <= 1000 µm"):
        load_scene(SDOF, {"load.torque_Nm": 11000.0})


def test_zero_torque_with_a_loaded_te_is_refused_unloaded_is_not():
    with pytest.raises(SceneError, match=r"^load\.torque_Nm = 0 \(N·m\) with "
                       r"transmission_error\.kind = 'loaded'") as err:
        load_scene(SDOF, {"load.torque_Nm": 0.0})
    assert err.value.field == "load.torque_Nm" and err.value.unit == "N·m"
    s = load_scene(SDOF, {"load.torque_Nm": 0.0, "transmission_error.kind": "unloaded",
                          "transmission_error.mean_um": 0.0})
    assert s.static_load == 0.0


def test_unusual_values_warn_in_the_log_and_the_list(caplog):
    with caplog.at_level(logging.WARNING, logger="study.scene.plausibility"):
        s = load_scene(SDOF, {"gear.backlash_um": 3.0, "damping.modal_ratio": 0.3})
    w = plausibility_warnings(s)
    assert w[0] == ("gear.backlash_um = 3 µm: unusual: outside [5, 500] µm (half backlash b; "
                    "0.03–0.1 module in practice (b = 40 µm on module 1.3 mm))")
    assert w[1].startswith("damping.modal_ratio = 0.3 -: unusual: outside [0.002, 0.15] -")
    assert [r.getMessage() for r in caplog.records] == w
    # a loaded STE far from the static deflection F_s/k̄ = 14.51 µm
    w = plausibility_warnings(load_scene(SDOF, {"transmission_error.mean_um": 100.0}))
    assert w == ["transmission_error.mean_um = 100 µm: unusual for a loaded STE whose static "
                 "deflection F_s/k̄_m is 14.51 µm (outside a factor 3 of it)"]


@pytest.mark.parametrize("section", ["gear", "mesh_stiffness", "load", "continuation"])
def test_absent_required_section_is_an_error(section):
    import tomllib

    raw = tomllib.loads(SDOF.read_text())
    del raw[section]
    with pytest.raises(SceneError, match=rf"^\[{section}\]: missing \(required for "
                       r"scene\.kind = 'lumped'"):
        scene_from_dict(raw)


def test_fe_scene_needs_materials_and_bearings():
    import tomllib

    raw = tomllib.loads(PUMP.read_text())
    del raw["bearings"]
    with pytest.raises(SceneError, match=r"^\[bearings\]: missing"):
        scene_from_dict(raw)


def test_dynamic_ratio_post_check():
    # the sdof demo's numbers: 121 kN peak on 3.19 kN static -> ratio 37.9
    w = dynamic_ratio_warning(121088.4, 3192.58, 2990.8)
    assert w.startswith("dynamic-to-static deflection ratio 37.9 (peak mesh load 1.211e+05 N "
                        "at 2990.8 rpm on a static load of 3193 N): above 10")
    assert dynamic_ratio_warning(DYNAMIC_RATIO_USUAL * 100.0, 100.0, 1.0) is None
    assert dynamic_ratio_warning(5.0, 0.0, 1.0) is None       # no static load: not judged


def test_docs_table_matches_the_code():
    text = (ROOT / "docs" / "scenes.md").read_text()
    assert bounds_markdown() in text
    assert len(BOUNDS) == bounds_markdown().count("\n") - 1


def test_train_meshes_are_judged_one_by_one():
    train = ROOT / "scenes" / "two-stage-lumped.toml"
    assert plausibility_warnings(load_scene(train)) == []
    import tomllib

    raw = tomllib.loads(train.read_text())
    raw["meshes"][1]["backlash_um"] = 0.04
    with pytest.raises(SceneError, match=r"^meshes\[1\]\.backlash_um = 0\.04 µm: outside the "
                       r"plausible range >= 1 µm") as err:
        scene_from_dict(raw)
    assert err.value.unit == "µm"
