"""Parameter validation and analytic volumes of geometry/ (no meshing)."""

from __future__ import annotations

import dataclasses
import math

import pytest

from geometry import HousingParams, MeshOptions, PumpParams, ShaftParams, preset
from geometry.volumes import housing_volume, shaft_volume


def test_defaults_are_valid_and_match_the_architecture_frame():
    p = PumpParams()
    p.validate()
    assert p.centre_distance == pytest.approx(0.100)
    assert p.shaft_axis("in") == (0.0, 0.0)
    assert p.shaft_axis("out") == (0.100, 0.0)
    # gear tip = pitch radius (rb / cos 20deg = 50 mm) + one effective module (100/76 mm)
    assert p.gear_tip_radius == pytest.approx(46.984e-3 / math.cos(math.radians(20))
                                              + 0.1 / 76, rel=1e-4)
    # hub centre of both shafts at the gear plane
    for s in ("in", "out"):
        sp = p.shaft(s)
        z_hub = p.shaft_origin(s)[2] + 0.5 * sum(sp.hub_z)
        assert z_hub == pytest.approx(p.gear_plane_z)


def test_shaft_segments_tile_the_length_and_stations_are_six_rings():
    sp = ShaftParams()
    segs = sp.segments()
    assert segs[0][0] == 0.0
    assert segs[-1][1] == pytest.approx(sp.length)
    for (_, z1, _, _), (z0, _, _, _) in zip(segs[:-1], segs[1:], strict=True):
        assert z0 == pytest.approx(z1)
    stations = [s for s in segs if s[3].startswith("station_")]
    assert sorted(s[3] for s in stations) == [f"station_{k}" for k in range(1, 7)]
    for z0, z1, _, _ in stations:
        assert z1 - z0 == pytest.approx(sp.station_width)


def test_shaft_volume_is_sum_of_cylinders():
    sp = ShaftParams(coupling_radius=0.01, coupling_length=0.05, journal_radius=0.012,
                     journal_length=0.02, body_radius=0.015, span_a=0.06, hub_radius=0.017,
                     hub_length=0.02, span_b=0.06, tail_radius=0.01, tail_length=0.03)
    expected = math.pi * (0.01**2 * 0.05 + 2 * 0.012**2 * 0.02 + 0.015**2 * 0.12
                          + 0.017**2 * 0.02 + 0.01**2 * 0.03)
    assert shaft_volume(sp) == pytest.approx(expected, rel=1e-12)


def test_rotor_sections_default_off_and_volume_hand_computed():
    base = ShaftParams()
    # rotor_radius = 0 (default): the rotor gap is ignored, the segments are the plain shaft's
    assert ShaftParams(rotor_gap=0.01).segments() == base.segments()
    assert "rotor" not in {s[3] for s in base.segments()}
    R, g = 0.030, 0.008
    sp = dataclasses.replace(base, rotor_radius=R, rotor_gap=g)
    sp.validate()
    segs = sp.segments()
    for (_, z1, _, _), (z0, _, _, _) in zip(segs[:-1], segs[1:], strict=True):
        assert z0 == pytest.approx(z1)
    # the default stations (quarter points of the spans) all lie on the rotors
    assert all(r == R for _, _, r, lab in segs if lab.startswith("station_"))
    assert sp.max_radius == R
    # volume: the plain shaft plus the rotor annuli over span - 2 gaps on both spans
    extra = math.pi * (R**2 - base.body_radius**2) * (base.span_a + base.span_b - 4 * g)
    assert shaft_volume(sp) == pytest.approx(shaft_volume(base) + extra, rel=1e-12)


@pytest.mark.parametrize(
    ("shaft", "field"),
    [
        (ShaftParams(rotor_radius=-0.02), "rotor_radius"),
        (ShaftParams(rotor_radius=0.03, rotor_gap=-0.001), "rotor_gap"),
        (ShaftParams(rotor_radius=0.03, rotor_gap=0.033), "rotor_gap"),  # >= span/2
        (ShaftParams(rotor_radius=0.03, rotor_gap=0.015), "straddles a rotor end"),
    ],
)
def test_bad_rotor_is_refused_naming_the_field(shaft, field):
    with pytest.raises(ValueError, match=field):
        shaft.validate()


def test_housing_volume_hand_computed():
    h = HousingParams(rib_count=0)
    t = h.wall_thickness
    shell = h.length_x * h.height_y * h.length_z - \
        (h.length_x - 2 * t) * (h.height_y - 2 * t) * (h.length_z - 2 * t)
    bosses = 4 * math.pi * (h.boss_radius**2 * h.boss_length
                            - h.bore_radius**2 * (h.boss_length + t))
    feet = 4 * h.foot_width * h.foot_height * h.foot_depth
    assert housing_volume(h) == pytest.approx(shell + bosses + feet, rel=1e-12)
    h2 = dataclasses.replace(h, rib_count=3)
    assert housing_volume(h2) - housing_volume(h) == pytest.approx(
        3 * h.length_x * h.rib_height * h.rib_thickness, rel=1e-9)


@pytest.mark.parametrize(
    ("params", "field"),
    [
        (PumpParams(shaft_in=ShaftParams(journal_radius=-0.01)), "journal_radius"),
        (PumpParams(shaft_out=ShaftParams(hub_length=0.0)), "hub_length"),
        (PumpParams(housing=HousingParams(wall_thickness=0.0)), "wall_thickness"),
        (PumpParams(housing=HousingParams(bore_radius=0.040)), "bore_radius"),  # > boss
        (PumpParams(housing=HousingParams(wall_thickness=0.07)), "wall_thickness"),
        (PumpParams(shaft_in=ShaftParams(journal_radius=0.0255)), "journal_radius"),
        (PumpParams(centre_distance=0.030), "centre_distance"),  # shafts collide
        (PumpParams(centre_distance=0.070), "boss_radius"),  # bosses overlap
        (PumpParams(gear_tip_radius=0.065), "gear_tip_radius"),  # gear hits housing
        (PumpParams(housing=HousingParams(length_x=0.20)), "gear_tip_radius"),
        (PumpParams(shaft_in=ShaftParams(span_a=0.05)), "journal"),  # journal out of bore
        (PumpParams(gear_z=0.005), "gear_z"),
        (PumpParams(shaft_out=ShaftParams(body_radius=0.030)), "shaft_out"),  # hits wall
        (PumpParams(shaft_in=ShaftParams(station_z=(0.1, 0.1, 0.2, 0.2, 0.15, 0.12))),
         "station_z"),
        (PumpParams(shaft_in=ShaftParams(station_z=(0.08, 0.09))), "station_z"),
        (PumpParams(housing=HousingParams(rib_count=-1)), "rib_count"),
        (PumpParams(centre_distance=float("nan")), "centre_distance"),
    ],
)
def test_bad_geometry_is_refused_naming_the_field(params, field):
    with pytest.raises(ValueError, match=field):
        params.validate()


def test_bad_mesh_options_and_presets():
    with pytest.raises(ValueError, match="size"):
        MeshOptions(size=-1.0).validate()
    with pytest.raises(ValueError, match="order"):
        MeshOptions(order=1).validate()
    with pytest.raises(ValueError, match="preset"):
        preset("medium")
    assert preset("coarse").size > preset("fine").size
    assert preset("coarse", size=0.03).size == 0.03
