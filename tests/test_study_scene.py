"""Scene validation: good scenes load with the right SI values, broken scenes are refused
with a SceneError naming the field (never another exception type)."""
from __future__ import annotations

import math
import tomllib
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from study.scene import (
    SCHEMA,
    SceneError,
    apply_overrides,
    load_scene,
    parse_scene,
    parse_set_values,
    scene_from_dict,
)

ROOT = Path(__file__).resolve().parents[1]
SDOF = ROOT / "scenes" / "gear-pair-sdof.toml"

MINIMAL = {
    "scene": {"name": "t", "kind": "lumped"},
    "gear": {"teeth": 76, "base_radius_mm": 46.984},
    "load": {"torque_Nm": 2.5},
    "mesh_stiffness": {"mean_N_per_um": 200.0, "amplitudes_N_per_um": [40.0, 20.0, 10.0],
                       "phases_deg": [0.0, 90.0, 0.0]},
    "transmission_error": {"amplitudes_um": [1.0, 0.5, 0.2]},
    "continuation": {"speed_rpm": [500.0, 4000.0]},
}


def test_sdof_scene_loads_in_si():
    s = load_scene(SDOF)
    assert s.scene.kind == "lumped"
    assert s.gear.teeth == 76
    assert s.gear.base_radius == pytest.approx(46.984e-3, rel=1e-12)
    assert s.gear.backlash == pytest.approx(40e-6, rel=1e-12)
    # F_s = T / r_b1
    assert s.static_load == pytest.approx(s.load.torque / 46.984e-3, rel=1e-12)
    assert s.damping.modal_ratio == pytest.approx(0.05)
    lo, hi = s.continuation.speed
    assert lo < hi


def test_units_converted():
    s = scene_from_dict(MINIMAL)
    assert s.mesh_stiffness.mean == pytest.approx(200e6)
    assert s.mesh_stiffness.phases[1] == pytest.approx(math.pi / 2)
    assert s.transmission_error.amplitudes[0] == pytest.approx(1e-6)
    assert s.gear.pressure_angle == pytest.approx(math.radians(20))
    # Table 1: pitch radius from r_b and α (docs/architecture.md), centre distance 100 mm
    assert s.gear.centre_distance == pytest.approx(2 * 46.984e-3 / math.cos(math.radians(20)))
    c = s.mesh_stiffness.coefficients()
    assert c[2] == pytest.approx(20e6 * 1j, abs=1e-3)


def test_contact_ratio_against_textbook_formula():
    # standard spur gears, z1 = z2 = 20, m = 5 mm, α = 20°: ε_α = 1.557 (textbook value)
    m, z, a = 5e-3, 20, math.radians(20)
    s = scene_from_dict({**MINIMAL, "gear": {"teeth": z, "base_radius_mm": m * z / 2 * 1e3
                                                    * math.cos(a), "backlash_um": 40}})
    assert s.gear.contact_ratio == pytest.approx(1.557, abs=2e-3)


def test_iso6336_estimate_table1():
    s = scene_from_dict({**MINIMAL, "mesh_stiffness": {"estimate": True}})
    ms = s.mesh_stiffness
    # c'_th = 1/q' for z_n = 76, x = 0: q' = 0.04723 + 0.41342/76
    cth = 1 / (0.04723 + (0.15551 + 0.25791) / 76)
    ft_b = s.static_load * math.cos(s.gear.pressure_angle) / 20.0  # N/mm
    k1 = cth * 0.8 * (ft_b / 100) ** 0.25 * 20 * 1e6  # N/m
    assert ms.mean == pytest.approx(k1 * s.gear.contact_ratio, rel=1e-12)
    assert len(ms.amplitudes) == 3
    # rectangular wave between k1 and 2 k1: the truncated series stays within it
    assert ms.minimum() > 0
    import numpy as np

    from gears.excitation import rectangular_mesh_stiffness
    mean, amplitudes, phases = rectangular_mesh_stiffness(k1, s.gear.contact_ratio, 200)
    t = np.linspace(0, 1, 2001)
    k = mean + sum(a * np.cos(2 * np.pi * (j + 1) * t + p)
                   for j, (a, p) in enumerate(zip(amplitudes, phases, strict=True)))
    d = s.gear.contact_ratio - 1
    inside = np.abs(((t + 0.5) % 1) - 0.5) < d / 2 - 0.02
    outside = np.abs(((t + 0.5) % 1) - 0.5) > d / 2 + 0.02
    assert np.allclose(k[inside], 2 * k1, rtol=0.03)
    assert np.allclose(k[outside], k1, rtol=0.03)


def test_estimates_are_those_of_the_code_before_gears_existed():
    """The ISO 6336 and STE estimates now come from :mod:`gears`: the very same numbers
    as the pre-redesign study/gears.py gave for Table 1 at 2.5 N·m (bitwise for k_m,
    pure floating-point arithmetic; the STE goes through an FFT, whose last bits may
    depend on the NumPy build: bitwise on the reference machine, 1e-13 asked here)."""
    s = scene_from_dict({**MINIMAL, "mesh_stiffness": {"estimate": True},
                         "transmission_error": {"estimate": True}})
    ms, te = s.mesh_stiffness, s.transmission_error
    assert s.gear.contact_ratio == 1.8189846220942514
    assert (ms.mean, ms.amplitudes, ms.phases) == (
        219722393.9190796, (41411899.28223002, 34894262.5327073, 25399244.20546496),
        (0.0, math.pi, 0.0))
    assert (te.mean, *te.amplitudes) == pytest.approx(
        (2.552906613043164e-07, 6.6033098589778e-08, 5.613545966884067e-08,
         4.2268283720798905e-08), rel=1e-13)
    assert te.phases == pytest.approx((math.pi, 0.0, math.pi), abs=1e-13)


def test_estimated_ste_is_static_deflection():
    s = scene_from_dict({**MINIMAL, "mesh_stiffness": {"estimate": True},
                         "transmission_error": {"estimate": True}})
    # mean of F_s/k_m(t) >= F_s/k̄ (Jensen), within the stiffness variation
    assert s.transmission_error.mean >= s.static_load / s.mesh_stiffness.mean
    assert s.transmission_error.kind == "loaded" and s.transmission_error.estimated
    assert len(s.transmission_error.amplitudes) == len(s.mesh_stiffness.amplitudes)


def test_fourier_series_samples_its_coefficients():
    """k_m(t) and the TE are one FourierSeries: sample() equals Re Σ c_k e^{ikθ}."""
    import numpy as np

    s = load_scene(SDOF)
    theta = 2 * np.pi * np.arange(64) / 64
    for series in (s.mesh_stiffness, s.transmission_error):
        c = series.coefficients()
        ref = sum((v * np.exp(1j * k * theta)).real for k, v in c.items())
        assert np.allclose(series.sample(64), ref, rtol=0, atol=1e-12 * abs(c[0]))


def test_estimated_ste_times_mesh_stiffness_is_the_static_load():
    """q_s(t) k_m(t) = F_s pointwise once enough STE harmonics are kept."""
    import numpy as np

    from gears.excitation import perfect_teeth_ste
    from study.scene import MeshStiffness, TransmissionError

    ms = MeshStiffness(2.0e8, (4.0e7, 2.0e7), (0.0, 1.0))
    te = TransmissionError(*perfect_teeth_ste((ms.mean, ms.amplitudes, ms.phases), 1000.0, 40))
    assert np.allclose(te.sample(128) * ms.sample(128), 1000.0, rtol=1e-9)


# ---------------------------------------------------------------- broken scenes

BROKEN = [
    ({"gear": {"backlash_um": -3}}, "gear.backlash_um = -3"),
    ({"gear": {"backlash_um": 0}}, "gear.backlash_um = 0"),
    ({"gear": {"backlsh_um": 40}}, "did you mean 'backlash_um'"),
    ({"gear": {"teeth": 76.5}}, "gear.teeth = 76.5"),
    ({"gear": {"teeth": "76"}}, "gear.teeth = '76'"),
    ({"gear": {"teeth": True}}, "gear.teeth = True"),
    ({"gear": {"module_mm": 1.0}}, "gear.module_mm = 1"),
    ({"gear": {"pressure_angle_deg": 60}}, "gear.pressure_angle_deg = 60"),
    ({"gear": {"dedendum_coef": 0.9}}, "gear.dedendum_coef = 0.9"),
    ({"gear": {"face_width_mm": float("nan")}}, "gear.face_width_mm = nan"),
    ({"gear": {"backlash_um": 5000}}, "gear.backlash_um = 5000"),
    ({"continuation": {"speed_rpm": [4000, 500]}}, "continuation.speed_rpm = [4000, 500]"),
    ({"continuation": {"speed_rpm": [500]}}, "continuation.speed_rpm = [500]"),
    ({"continuation": {"speed_rpm": [500, 4000], "step_rpm": 5000}}, "continuation.step_rpm"),
    ({"hbm": {"harmonics": [1, 2, 3]}}, "hbm.harmonics = [1, 2, 3]: must contain 0"),
    ({"hbm": {"harmonics": [0, 2, 1, 3]}}, "hbm.harmonics"),
    ({"hbm": {"harmonics": [0, 1]}}, "lacks the excited mesh harmonics"),
    ({"hbm": {"harmonics": [0, 76, 152, 228]},
      "external": {"aero": [{"shaft": "in", "order": 2, "torque_Nm": [0, 0, 0.1]}]}},
     "lacks the external shaft orders [2]"),
    ({"hbm": {"condensation": "LOA"}}, "hbm.condensation = 'LOA'"),
    ({"hbm": {"harmonic_set": "band"}},
     "hbm.harmonic_set = 'band': must be one of 'combinations', 'bands', 'contiguous'"),
    ({"hbm": {"harmonic_set": 3}}, "hbm.harmonic_set = 3"),
    ({"mesh_stiffness": {"mean_N_per_um": -5}}, "mesh_stiffness.mean_N_per_um = -5"),
    ({"mesh_stiffness": {"amplitudes_N_per_um": [150, 100]}}, "mesh_stiffness.amplitudes_N_per_um"),
    ({"mesh_stiffness": {"phases_deg": [0, 0]}}, "mesh_stiffness.phases_deg"),
    ({"transmission_error": {"kind": "static"}}, "transmission_error.kind = 'static'"),
    ({"damping": {"modal_ratio": 1.5}}, "damping.modal_ratio = 1.5"),
    ({"load": {"torque_Nm": -1}}, "load.torque_Nm = -1"),
    ({"scene": {"kind": "fem"}}, "scene.kind = 'fem'"),
    ({"scen": {"kind": "fe"}}, "did you mean 'scene'"),
    ({"external": {"unbalance": [{"shaft": "in", "m_unb_kgm": 3e-5}]}}, "external.unbalance[0]"),
    ({"external": {"aero": [{"shaft": "in", "order": 2, "force_N": [1, 0, 0]}]}},
     "external.aero[0].force_N"),
    ({"external": {"aero": [{"shaft": "up", "order": 2}]}}, "external.aero[0].shaft = 'up'"),
    ({"external": {"aero": [{"shaft": "in"}]}}, "external.aero[0].order: missing"),
    ({"external": {"aero": {"shaft": "in"}}}, "external.aero"),
    ({"outputs": {"plots": ["forced_respons"]}}, "did you mean 'forced_response'"),
    ({"outputs": {"time_series_rpm": [9000]}}, "outputs.time_series_rpm"),
    ({"outputs": {"housing_field_rpm": [1000]}}, "outputs.housing_field_rpm"),
    ({"geometry": {"wall_mm": 5}}, "[geometry]: only allowed when scene.kind = 'fe'"),
    ({"lumped": {"inertia_kgm2": [1e-3]}}, "lumped.inertia_kgm2"),
    ({"lumped": {"inertia_kgm2": [1e-3, 1e-3], "equivalent_mass_kg": 0.3}},
     "lumped.equivalent_mass_kg"),
    ({"rom": {"n_cm": 0}}, "rom.n_cm = 0"),
    ({"rom": {"factorization": "ldlt"}},
     "rom.factorization = 'ldlt': must be one of 'lu', 'cholesky'"),
    ({"rom": {"out_of_core": "yes"}}, "rom.out_of_core = 'yes': must be true or false"),
    ({"calibration": {"grazings": "TE"}}, "calibration.grazings: unknown key (did you mean "
     "'grazing'?)"),
    ({"calibration": {"grazing": 5}}, "calibration.grazing = 5: must be a string"),
]


def _merge(base: dict, patch: dict) -> dict:
    out = {k: (dict(v) if isinstance(v, dict) else v) for k, v in base.items()}
    for sec, tab in patch.items():
        if isinstance(tab, dict) and isinstance(out.get(sec), dict):
            out[sec].update(tab)
        else:
            out[sec] = tab
    return out


@pytest.mark.parametrize(("patch", "message"), BROKEN)
def test_broken_scene_names_the_field(patch, message):
    with pytest.raises(SceneError) as err:
        scene_from_dict(_merge(MINIMAL, patch))
    assert message in str(err.value)


def test_invalid_toml_and_missing_file(tmp_path):
    with pytest.raises(SceneError, match="not valid TOML"):
        parse_scene("[gear\nteeth = 3")
    with pytest.raises(SceneError, match="cannot be read"):
        load_scene(tmp_path / "nope.toml")


def test_overrides_and_set_values():
    raw = apply_overrides(MINIMAL, {"load.torque_Nm": 5.0})
    assert scene_from_dict(raw).load.torque == 5.0
    assert MINIMAL["load"] == {"torque_Nm": 2.5}  # original untouched
    assert parse_set_values("1,2.5,3") == [1, 2.5, 3]
    assert parse_set_values("[500,4000],[600,5000]") == [[500, 4000], [600, 5000]]
    assert parse_set_values("loaded,unloaded") == ["loaded", "unloaded"]
    with pytest.raises(SceneError, match="load.torque_Nm = 'abc'"):
        scene_from_dict(apply_overrides(MINIMAL, {"load.torque_Nm": "abc"}))


def test_set_reaches_an_entry_of_an_array_of_tables_by_name_or_index():
    """``--set meshes.stage2.backlash_um`` or ``meshes[1].backlash_um`` changes that mesh
    only (the train's [[meshes]]), deeper keys too; a wrong name, index or a bare array
    is refused naming what the scene has."""
    from study.scene.load import load_scene

    path = Path(__file__).resolve().parents[1] / "scenes" / "two-stage-lumped.toml"
    base = load_scene(path)
    s = load_scene(path, {"meshes.stage2.backlash_um": 25.0, "meshes[0].angle_deg": 10.0,
                          "gears.p1.face_width_mm": 30.0})
    assert s.meshes[1].backlash == pytest.approx(25e-6, rel=1e-12)
    assert s.meshes[0].backlash == base.meshes[0].backlash
    assert s.meshes[0].angle == pytest.approx(math.radians(10.0), rel=1e-12)
    assert s.meshes[1].angle == base.meshes[1].angle
    assert s.gears[0].face_width == pytest.approx(30e-3) and \
        s.gears[1].face_width == base.gears[1].face_width
    raw = apply_overrides({"meshes": [{"name": "a", "x": {"y": 1}}]}, {"meshes.a.x.y": 2})
    assert raw["meshes"][0]["x"]["y"] == 2
    for key, words in (("meshes.stage3.backlash_um", "no entry named 'stage3' (its names: "
                                                     "'stage1', 'stage2'"),
                       ("meshes[2].backlash_um", "index 2 out of range: [[meshes]] has 2 "
                                                 "entries"),
                       ("meshes.backlash_um", "[[meshes]] is an array of tables; name an "
                                              "entry"),
                       ("load[0].torque_Nm", "'load' is not an array of tables")):
        with pytest.raises(SceneError) as err:
            load_scene(path, {key: 20.0})
        assert str(err.value).startswith(f"--set {key}: ") and words in str(err.value), \
            str(err.value)


# ---------------------------------------------------------------- property-based fuzzing

_BAD_VALUES = st.one_of(
    st.text(max_size=5), st.booleans(), st.just(float("nan")), st.just(float("inf")),
    st.just(-1e30), st.just(1e30), st.lists(st.integers(), max_size=3),
    st.dictionaries(st.text(max_size=3), st.integers(), max_size=2), st.just(-1),
)


def _valid_keys():
    keys = []
    for sec, specs in SCHEMA.items():
        if "." in sec:
            continue
        for k, sp in specs.items():
            if sp.kind in ("float", "int", "pair", "vec3", "floats", "ints", "choice", "bool"):
                keys.append((sec, k))
    return keys


KEYS = _valid_keys()


@st.composite
def broken_scenes(draw):
    raw = {k: dict(v) for k, v in tomllib.loads(SDOF.read_text()).items()}
    n = draw(st.integers(1, 3))
    for _ in range(n):
        how = draw(st.sampled_from(["typo", "type", "section", "reverse", "harm", "value"]))
        if how == "typo":
            sec, key = draw(st.sampled_from(KEYS))
            raw.setdefault(sec, {})[key + draw(st.sampled_from(["_", "x", "s"]))] = 1.0
        elif how == "section":
            raw[draw(st.sampled_from(["gears", "Load", "hbmm", "foo"]))] = {}
        elif how == "reverse":
            a = draw(st.floats(10, 1e4))
            raw.setdefault("continuation", {})["speed_rpm"] = [a + draw(st.floats(0, 1e3)), a]
        elif how == "harm":
            raw.setdefault("hbm", {})["harmonics"] = draw(
                st.lists(st.integers(1, 300), min_size=1, max_size=6))
        else:
            sec, key = draw(st.sampled_from(KEYS))
            val = draw(_BAD_VALUES)
            spec = SCHEMA[sec][key]
            # only values that are invalid for sure for this field
            if spec.kind == "bool" and isinstance(val, bool):
                val = "yes"
            if spec.kind == "choice" and val in spec.choices:
                val = val + "_"
            if spec.kind in ("float", "int") and val == -1 and (spec.lo is None or spec.lo < -1):
                val = "x"
            huge_ok = (spec.hi is None or spec.hi >= 1e30) and (spec.lo is None or spec.lo <= -1e30)
            if spec.kind in ("float", "int") and isinstance(val, float) and abs(val) == 1e30 \
                    and huge_ok:
                val = "x"
            if spec.kind in ("floats", "ints") and isinstance(val, list) and \
                    all(isinstance(v, int) and v >= (spec.lo or 0) for v in val):
                val = ["x"]
            if spec.kind == "pair" and isinstance(val, list) and len(val) == 2:
                val = [2, 1]
            raw.setdefault(sec, {})[key] = val
    return raw


@settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(broken_scenes())
def test_fuzz_broken_scenes_always_scene_error(raw):
    with pytest.raises(SceneError):
        scene_from_dict(raw)


def test_docs_list_every_key():
    text = (ROOT / "docs" / "scenes.md").read_text()
    for sec, specs in SCHEMA.items():
        for key in specs:
            assert f"`{key}`" in text, (sec, key)


def test_harmonic_set_option_reaches_the_builder():
    """hbm.harmonic_set picks the builder's kind; the default keeps the combinations."""
    from study.pipeline.model import harmonic_set

    sizes = {}
    for kind in ("combinations", "bands", "contiguous"):
        sc = load_scene(ROOT / "scenes" / "pump.toml",
                        {"hbm.harmonic_set": kind, "hbm.mesh_harmonics": 12,
                         "hbm.sideband_order": 4})
        assert sc.hbm.harmonic_set == kind
        hs = harmonic_set(sc)
        sizes[kind] = hs.n_real
        if kind == "contiguous":
            assert hs.indices == tuple(range(12 * 76 + 16 + 1))
    # Z = 76, orders 1, 2, 4, s = 4: bands 76 +- 16 hold 61 = 76 - 15 (order 5)
    assert sizes == {"combinations": 775, "bands": 825, "contiguous": 1857}
    # the shipped pump uses the converged contiguous 12/3 set; the builder's default kind
    # (a scene that does not say) stays the combinations
    shipped = load_scene(ROOT / "scenes" / "pump.toml").hbm
    assert (shipped.harmonic_set, shipped.mesh_harmonics, shipped.sideband_order) == \
        ("contiguous", 12, 3)
    raw = tomllib.loads((ROOT / "scenes" / "pump.toml").read_text())
    del raw["hbm"]["harmonic_set"]
    assert scene_from_dict(raw, "pump").hbm.harmonic_set == "combinations"


def test_a_scene_extends_another_key_by_key(tmp_path):
    from study.scene import SceneError, load_scene

    base = tmp_path / "base.toml"
    base.write_text(
        '[scene]\nname = "base"\nkind = "lumped"\n[gear]\nteeth = 40\nbacklash_um = 40.0\n'
        "[load]\ntorque_Nm = 10.0\n[mesh_stiffness]\nmean_N_per_um = 200.0\n"
        "[continuation]\nspeed_rpm = [500.0, 900.0]\n"
        '[calibration]\nmesh_mode = "k"\nresonances = "J"\n'
        '[[external.aero]]\nshaft = "in"\norder = 2\ntorque_Nm = [0.0, 0.0, 0.5]\n'
        '[[external.aero]]\nshaft = "out"\norder = 2\ntorque_Nm = [0.0, 0.0, 0.5]\n')
    sub = tmp_path / "sub" / "derived.toml"
    sub.parent.mkdir()
    sub.write_text('[scene]\nextends = "../base.toml"\nname = "derived"\n[gear]\n'
                   'backlash_um = 20.0\n[[external.aero]]\nshaft = "in"\norder = 4\n'
                   'torque_Nm = [0.0, 0.0, 0.1]\n[calibration]\ngrazing = "TE"\n'
                   'mesh_mode = " "\n')
    s = load_scene(sub)
    assert s.name == "derived" and s.gear.teeth == 40          # table merged key by key
    assert s.gear.backlash == pytest.approx(20e-6) and s.load.torque == 10.0
    assert [(a.shaft, a.order) for a in s.external.aero] == [("in", 4)]  # replaced whole
    # the base's fits are inherited, a blank one is taken back, and none enters a result
    assert s.calibration == {"resonances": "J", "grazing": "TE"}
    taken = load_scene(sub, {"calibration.resonances": ""})
    assert taken.calibration == {"grazing": "TE"} and taken == s
    assert 'extends = "../base.toml"' in s.text and "teeth = 40" in s.text
    assert load_scene(sub, {"gear.teeth": 50}).gear.teeth == 50
    base.write_text(base.read_text().replace('name = "base"',
                                             'name = "base"\nextends = "sub/derived.toml"'))
    with pytest.raises(SceneError, match="circular"):
        load_scene(sub)
    sub.write_text('[scene]\nextends = "nothere.toml"\n')
    with pytest.raises(SceneError, match="no such file"):
        load_scene(sub)
