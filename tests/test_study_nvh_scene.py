"""Scene keys of the NVH outputs: [acoustics], field orders, housing time-series sampling
and virtual accelerometers are validated with messages naming the field."""
from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

from study.scene import SceneError, scene_from_dict

ROOT = Path(__file__).resolve().parents[1]
SDOF = ROOT / "scenes" / "gear-pair-sdof.toml"
PUMP = ROOT / "scenes" / "pump.toml"


def _raw(path=SDOF, **sections):
    raw = tomllib.loads(path.read_text())
    for sec, table in sections.items():
        raw.setdefault(sec, {}).update(table)
    return raw


def test_acoustics_defaults_and_values():
    s = scene_from_dict(_raw())
    assert (s.acoustics.air_density, s.acoustics.sound_speed) == (1.2, 343.0)
    s = scene_from_dict(_raw(acoustics={"air_density_kg_per_m3": 1.0,
                                        "sound_speed_m_per_s": 340.0}))
    assert (s.acoustics.air_density, s.acoustics.sound_speed) == (1.0, 340.0)


@pytest.mark.parametrize(("sections", "message"), [
    ({"acoustics": {"air_density_kg_per_m3": 0.0}}, "acoustics.air_density_kg_per_m3 = 0.0"),
    ({"acoustics": {"sound_speed_m_per_s": -343}}, "acoustics.sound_speed_m_per_s = -343"),
    ({"acoustics": {"sound_sped_m_per_s": 343}}, "did you mean 'sound_speed_m_per_s'"),
    ({"outputs": {"housing_mesh_periods": 0}}, "outputs.housing_mesh_periods = 0"),
    ({"outputs": {"housing_frames_per_mesh_period": -1}},
     "outputs.housing_frames_per_mesh_period = -1"),
    ({"outputs": {"field_orders": [76]}}, "outputs.field_orders = [76]: only for"),
    ({"outputs": {"accelerometer": [{"name": "a", "position_mm": [0, 0, 0]}]}},
     "outputs.accelerometer[0]: accelerometers need the housing"),
    ({"outputs": {"plots": ["erp", "order_map"]}}, "did you mean 'order_maps'"),
])
def test_bad_nvh_keys(sections, message):
    with pytest.raises(SceneError) as err:
        scene_from_dict(_raw(**sections))
    assert message in str(err.value)


@pytest.mark.fem
@pytest.mark.parametrize(("accels", "message"), [
    ([{"name": "a"}], "outputs.accelerometer[0].position_mm: missing"),
    ([{"name": "a", "position_mm": [1, 2]}], "must be a list of 3 numbers"),
    ([{"name": "a", "position_mm": [0, 0, 0]}, {"name": "a", "position_mm": [1, 0, 0]}],
     "outputs.accelerometer[1].name = 'a': used twice"),
    ([{"name": "a", "position_mm": [0, 0, 0], "direction": "up"}],
     "outputs.accelerometer[0].direction"),
])
def test_bad_accelerometers(accels, message):
    raw = _raw(PUMP)
    raw["outputs"]["accelerometer"] = accels
    with pytest.raises(SceneError) as err:
        scene_from_dict(raw)
    assert message in str(err.value)


@pytest.mark.fem
def test_check_outputs_against_the_harmonic_set():
    """Orders outside the set and aliasing frame rates are refused before the
    continuation; the automatic rate is 4 frames per period of the top order."""
    from hbm import HarmonicSet
    from study.outputs.fields import check_outputs, field_orders, frames_per_mesh_period

    hs = HarmonicSet([0, 1, 2, 4, 74, 76, 78, 152, 228, 232], ratio=1, fundamental="shaft")
    base = _raw(PUMP)
    s = scene_from_dict(base)
    assert field_orders(s, hs) == [1, 2, 4, 76, 152, 228]
    assert frames_per_mesh_period(s, hs) == 13            # ceil(4 * 232 / 76)
    check_outputs(s, hs)
    raw = _raw(PUMP)
    raw["outputs"]["field_orders"] = [76, 77]
    with pytest.raises(SceneError, match=r"outputs.field_orders = \[76, 77\]: orders \[77\]"):
        check_outputs(scene_from_dict(raw), hs)
    raw = _raw(PUMP)
    raw["outputs"]["housing_frames_per_mesh_period"] = 6   # 6 * 76 < 2 * 232 + 1
    with pytest.raises(SceneError, match="period = 6: aliases .* must be >= 7"):
        check_outputs(scene_from_dict(raw), hs)
    raw["outputs"]["housing_frames_per_mesh_period"] = 7
    check_outputs(scene_from_dict(raw), hs)


@pytest.mark.fem
def test_field_orders_of_a_train_count_its_shaft_orders():
    """A gearbox's default field orders hold its external shaft orders at the drive's
    scale (order 2 of the intermediate shaft: 2 × 23/61 of the drive), beside the meshes'
    harmonics."""
    from fractions import Fraction

    from study.outputs.fields import field_orders
    from study.pipeline.model import harmonic_set

    raw = _raw(ROOT / "scenes" / "two-stage-gearbox-demo.toml")
    plain = field_orders(scene_from_dict(raw), harmonic_set(scene_from_dict(raw)))
    raw["external"] = {"aero": [{"shaft": "intermediate", "order": 2,
                                 "torque_Nm": [0.0, 0.0, 1.0]}]}
    s = scene_from_dict(raw)
    got = field_orders(s, harmonic_set(s))
    assert Fraction(46, 61) in got and Fraction(46, 61) not in plain
    assert 23 in got and 23 in plain                   # stage 1's mesh frequency
