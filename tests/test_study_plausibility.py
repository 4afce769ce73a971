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


# ------------------------------------------------ geometry, inertias, unbalance, gearbox

def _scene(name: str):
    return load_scene(ROOT / "scenes" / f"{name}.toml")


def _fe(scene, section: str, table: dict):
    """``scene`` with one free FE table replaced (judged as the loader judges it, after
    the machine's own check)."""
    import dataclasses

    return dataclasses.replace(scene, fe={**scene.fe, section: table})


def _entry(scene, table: str, i: int, **values):
    """``scene`` with entry ``i`` of a train table (``shafts``, ``gears``, ``loads``) or of
    ``external.unbalance`` changed."""
    import dataclasses

    if table == "unbalance":
        ub = list(scene.external.unbalance)
        ub[i] = dataclasses.replace(ub[i], **values)
        return dataclasses.replace(scene, external=dataclasses.replace(
            scene.external, unbalance=tuple(ub)))
    rows = list(getattr(scene, table))
    rows[i] = dataclasses.replace(rows[i], **values)
    return dataclasses.replace(scene, **{table: tuple(rows)})


def _bearing(scene, i: int, j: int, **values):
    import dataclasses

    b = list(scene.shafts[i].bearings)
    b[j] = dataclasses.replace(b[j], **values)
    return _entry(scene, "shafts", i, bearings=tuple(b))


def _replace(scene, section: str, **values):
    import dataclasses

    return dataclasses.replace(scene, **{section: dataclasses.replace(
        getattr(scene, section), **values)})


GEARBOX = "two-stage-gearbox-demo"
TRAIN = "two-stage-lumped"

#: (row of BOUNDS, scene, change, key named, shown value, error?) — one refusal or
#: warning per row family; each fails if its row is taken out of BOUNDS
FAMILY_CASES = [
    # geometry lengths: 8 under a plain key is 8 m; 0.3 mm a very thin station ring
    ("geometry.*", "pump", lambda s: _fe(s, "geometry", {"housing": {"wall_thickness": 8.0}}),
     "geometry.housing.wall_thickness", "8 (8000 mm)", True),
    ("geometry.*", "pump", lambda s: _fe(s, "geometry", {"shaft_in": {"station_width_mm": 0.3}}),
     "geometry.shaft_in.station_width_mm", "0.3 mm", False),
    ("geometry.*", "pump", lambda s: _fe(s, "geometry", {"centre_distance": 100.0}),
     "geometry.centre_distance", "100 (1e+05 mm)", True),
    # the gearbox's housing: 0.008 under a _mm key (metres), a 2.5 m clearance
    ("housing.*", GEARBOX, lambda s: _fe(s, "housing", {"wall_thickness_mm": 0.008}),
     "housing.wall_thickness_mm", "0.008 mm", True),
    ("housing.*", GEARBOX, lambda s: _fe(s, "housing", {"clearance_mm": 2500.0}),
     "housing.clearance_mm", "2500 mm", False),
    ("housing.*", GEARBOX, lambda s: _fe(s, "housing", {"bearing_width": 15.0}),
     "housing.bearing_width", "15 (1.5e+04 mm)", True),
    # shafts, gears and bearings of a gearbox or train
    ("shafts.diameter", GEARBOX, lambda s: _entry(s, "shafts", 1, diameter=3e-5),
     "shafts[1].diameter_mm", "0.03 mm", True),
    ("shafts.diameter", TRAIN, lambda s: _entry(s, "shafts", 2, diameter=2.0),
     "shafts[2].diameter_mm", "2000 mm", False),
    ("shafts.length", GEARBOX, lambda s: _entry(s, "shafts", 0, length=25.0),
     "shafts[0].length_mm", "2.5e+04 mm", True),
    ("gears.module", GEARBOX, lambda s: _entry(s, "gears", 2, module=2e-6),
     "gears[2].module_mm", "0.002 mm", True),
    ("gears.face_width / gears.module", TRAIN, lambda s: _entry(s, "gears", 3, face_width=5e-4),
     "gears[3].face_width_mm / gears[3].module_mm", "0.25 -", True),
    ("shafts.bearings.radial", GEARBOX, lambda s: _bearing(s, 2, 1, radial=300.0),
     "shafts[2].bearings[1].radial_N_per_um", "0.0003 N/µm", True),
    ("shafts.bearings.axial", GEARBOX, lambda s: _bearing(s, 0, 0, axial=5e5),
     "shafts[0].bearings[0].axial_N_per_um", "0.5 N/µm", False),
    # inertias: kg·mm² read as kg·m² (2e5), or far too small
    ("lumped.inertia", "gear-pair-sdof", lambda s: _replace(s, "lumped", inertia=(2e5, 1e-3)),
     "lumped.inertia_kgm2[0]", "2e+05 kg·m²", True),
    ("rotors.inertia", "pump",
     lambda s: _fe(s, "rotors", {"inertia_kgm2": 2e5, "torsional_stiffness": 1e6}),
     "rotors.inertia_kgm2", "2e+05 kg·m²", True),
    ("rotors.gear_inertia", "pump", lambda s: _fe(s, "rotors", {"gear_inertia": 1e-9}),
     "rotors.gear_inertia", "1e-09 kg·m²", False),
    ("rotors.rim_inertia", "pump", lambda s: _fe(s, "rotors", {"rim_inertia_kgm2": 3e4}),
     "rotors.rim_inertia_kgm2", "3e+04 kg·m²", True),
    ("shafts.inertia", TRAIN, lambda s: _entry(s, "shafts", 0, inertia=2e5),
     "shafts[0].inertia_kgm2", "2e+05 kg·m²", True),
    ("gears.inertia", TRAIN, lambda s: _entry(s, "gears", 1, inertia=500.0),
     "gears[1].inertia_kgm2", "500 kg·m²", False),
    ("drive.motor_inertia", GEARBOX, lambda s: _replace(s, "drive", motor_inertia=1e5),
     "drive.motor_inertia_kgm2", "1e+05 kg·m²", True),
    ("loads.inertia", TRAIN, lambda s: _entry(s, "loads", 0, inertia=1e-8),
     "loads[0].inertia_kgm2", "1e-08 kg·m²", False),
    # lumped masses
    ("lumped.equivalent_mass", "gear-pair-sdof",
     lambda s: _replace(s, "lumped", equivalent_mass=2e6), "lumped.equivalent_mass_kg",
     "2e+06 kg", True),
    ("rotors.gear_mass", "pump", lambda s: _fe(s, "rotors", {"gear_mass_kg": 5000.0}),
     "rotors.gear_mass_kg", "5000 kg", False),
    ("rotors.rim_mass", "pump", lambda s: _fe(s, "rotors", {"rim_mass": 2e5}),
     "rotors.rim_mass", "2e+05 kg", True),
    ("drive.impeller_mass", "pump", lambda s: _fe(s, "drive", {"impeller_mass_kg": 1e-4}),
     "drive.impeller_mass_kg", "0.0001 kg", False),
    ("gears.mass", GEARBOX, lambda s: _entry(s, "gears", 0, mass=3e5),
     "gears[0].mass_kg", "3e+05 kg", True),
    # unbalance: 3 kg·m (30 g·mm read as kg·m would be refused by the schema's 10 kg·m)
    ("external.unbalance.m_unb", "pump", lambda s: _entry(s, "unbalance", 1, m_unb=3.0),
     "external.unbalance[1].m_unb_kgm", "3 kg·m", True),
    ("external.unbalance.m_unb", "pump", lambda s: _entry(s, "unbalance", 0, m_unb=1e-9),
     "external.unbalance[0].m_unb_kgm", "1e-09 kg·m", False),
    # a gearbox's [materials] are judged as the pump's
    ("materials.shaft_E", GEARBOX, lambda s: _fe(s, "materials", {"shaft_E": 210.0}),
     "materials.shaft_E", "210 (2.1e-07 GPa)", True),
]


@pytest.mark.parametrize(("row", "name", "change", "key", "shown", "fatal"), FAMILY_CASES,
                         ids=[f"{c[0]}:{c[3]}" for c in FAMILY_CASES])
def test_row_families_refuse_or_warn(row, name, change, key, shown, fatal):
    from study.scene.plausibility import check_plausibility

    scene = change(_scene(name))
    unit = next(b.unit for b in BOUNDS if b.field == row)
    if fatal:
        with pytest.raises(SceneError) as err:
            check_plausibility(scene)
        e = err.value
        assert e.field == key and e.unit == unit
        assert str(e).startswith(f"{key} = {shown}: outside the plausible range")
    else:
        w = plausibility_warnings(scene)
        assert [t for t in w if t.startswith(f"{key} = {shown}: unusual: outside")], w


def test_every_new_row_has_a_case():
    """Each row family added for issue 39's leftovers is exercised above (a row taken out
    of BOUNDS makes its case fail)."""
    old = {"gear.", "mesh_stiffness.", "load.", "damping.", "lumped.density", "bearings.",
           "drive.motor_torsional", "drive.impeller_inertia", "rotors.lateral",
           "rotors.torsional", "materials."}
    new = {b.field for b in BOUNDS if not b.field.startswith(tuple(old))}
    assert new <= {c[0] for c in FAMILY_CASES}, new - {c[0] for c in FAMILY_CASES}


def test_zero_means_none_for_lengths_and_rotor_parts():
    """tail_length = 0 (the shaft ends at journal b), rotor_radius = 0 (no rotor), an
    absent rotor (inertia 0) are not judged."""
    from study.scene.plausibility import check_plausibility

    s = _fe(_scene("pump"), "geometry", {"shaft_out": {"tail_length": 0.0,
                                                       "rotor_radius_mm": 0.0}})
    assert check_plausibility(s) is s and plausibility_warnings(s) == []
    s = _fe(_scene("pump"), "rotors", {"inertia": 0.0, "torsional_stiffness": 0.0,
                                       "gear_mass": 0.0})
    assert plausibility_warnings(s) == []


def test_length_fields_are_the_geometry_dataclasses():
    """The lengths the geometry.* and housing.* rows judge are every float field of the
    geometry's dataclasses (a new field of them must be added to LENGTH_FIELDS)."""
    import dataclasses

    geometry = pytest.importorskip("geometry")
    from machines.gearbox.params import HousingOptions
    from study.scene.plausibility import LENGTH_FIELDS

    def floats(cls, skip=()):
        return {f.name for f in dataclasses.fields(cls)
                if f.type in ("float", "float | None") and f.name not in skip}

    assert set(LENGTH_FIELDS["geometry"]) == floats(geometry.PumpParams)
    assert set(LENGTH_FIELDS["geometry.housing"]) == floats(geometry.HousingParams)
    assert set(LENGTH_FIELDS["geometry.shaft_in"]) == floats(geometry.ShaftParams)
    assert set(LENGTH_FIELDS["geometry.shaft_out"]) == floats(geometry.ShaftParams)
    assert set(LENGTH_FIELDS["housing"]) == (floats(geometry.GearboxHousingParams)
                                             | {"bearing_width"})
    assert "bearing_width" in floats(HousingOptions, skip=("feet_y",))


@pytest.mark.parametrize("name", ["gear-pair-helical", "gear-pair-ltca", "two-stage-lumped",
                                  GEARBOX, "two-stage-gearbox", "two-stage-gearbox-cad"])
def test_other_shipped_scenes_load_without_warning(name, caplog):
    with caplog.at_level(logging.WARNING, logger="study.scene.plausibility"):
        s = _scene(name)
    assert plausibility_warnings(s) == []
    assert not caplog.records
