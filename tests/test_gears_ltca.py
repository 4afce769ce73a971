"""Loaded tooth contact analysis (gears.ltca and the modules it uses) against theory and
ISO values."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import gears as tc
from gears.iso6336 import approximate_virtual_teeth, pair_stiffness, single_stiffness
from study.scene import load_scene

PUMP = "scenes/pump.toml"


@pytest.fixture(scope="module")
def gear():
    return load_scene(PUMP).gear


@pytest.fixture(scope="module")
def pair(gear):
    return tc.SpurPair.from_pair(gear.pair())


def test_pair_geometry_matches_the_scene(gear, pair):
    # Table 1 via the scene: module from r_b = 46.984 mm at 20°, ε_α from the same formula
    assert pair.module == pytest.approx(2 * 46.984e-3 / (76 * math.cos(math.radians(20))))
    assert pair.base_radius == pytest.approx(gear.base_radius, rel=1e-12)
    assert pair.contact_ratio == pytest.approx(gear.contact_ratio, rel=1e-12)
    s_a, s_e = pair.path
    assert (s_e - s_a) / pair.base_pitch == pytest.approx(1.8190, abs=1e-4)


def test_beam_terms_of_a_uniform_cantilever():
    # constant section 2h, length L, unit load at the free end at angle a to the section,
    # lever h: closed-form integrals of (T.23–T.24)
    e, g, h, length = 200e9, 80e9, 1e-3, 3e-3
    x, w = np.polynomial.legendre.leggauss(20)
    y = (0.5 * (x + 1) * length)[None, :]
    dy = (0.5 * length * w)[None, :]
    hh = np.full_like(y, h)
    inertia, area = (2 * h) ** 3 / 12, 2 * h
    for a in (0.0, 0.3):
        ca, sa = math.cos(a), math.sin(a)
        expected = ((ca**2 * length**3 / 3 - ca * sa * h * length**2 + sa**2 * h**2 * length)
                    / (e * inertia) + 1.2 * ca**2 * length / (g * area)
                    + sa**2 * length / (e * area))
        got = tc.beam_compliance(y, hh, dy, np.array([length]), np.array([h]), np.array([a]),
                                 e, g)
        assert got[0] == pytest.approx(expected, rel=1e-12)


def test_single_pair_stiffness_against_iso6336(gear, pair):
    # (a) ISO 6336-1 method B c' (C_M = 0.8, no low-load correction) against the
    # potential-energy single-pair stiffness at the pitch point: the methods differ by
    # 10-30 % (docs/theory.md §13.3); band ±30 %.
    zn = approximate_virtual_teeth(gear.teeth, gear.helix_angle)
    c_iso = single_stiffness((zn, zn), (0.0, 0.0), gear.helix_angle, gear.pressure_angle,
                             gear.face_width, static_load=1e5)   # line load > 100 N/mm
    assert pair_stiffness(pair.geometry)[0] == pytest.approx(c_iso, rel=1e-12)
    k_pe = tc.pitch_point_stiffness(pair)
    assert 0.7 < k_pe / c_iso < 1.3
    # the pair stiffness of a 1:1 pair is symmetric about the pitch point, maximal there
    s_p = pair.pitch_radius * math.sin(pair.pressure_angle)
    d = np.linspace(0.1, 3.0, 5) * 1e-3
    c_plus = tc.pair_compliance(pair, s_p + d)
    c_minus = tc.pair_compliance(pair, s_p - d)
    np.testing.assert_allclose(c_plus, c_minus, rtol=1e-12)
    assert np.all(pair.face_width / c_plus < k_pe)


def test_mean_mesh_stiffness_against_iso_and_path_integral(pair):
    # (b) perfect teeth: every pair in the path carries load, so k̄ = (1/p_b) ∫ k_pair ds
    # over the path of contact (independent quadrature), and ISO's c_γα b within ±30 %.
    res = tc.solve_ltca(pair, 70.0, n_positions=2000, n_slices=1)
    k_mean = res.stiffness.mean()
    s_a, s_e = pair.path
    x, w = np.polynomial.legendre.leggauss(40)
    s = s_a + 0.5 * (x + 1) * (s_e - s_a)
    integral = 0.5 * (s_e - s_a) * np.sum(w * pair.face_width / tc.pair_compliance(pair, s))
    assert k_mean == pytest.approx(integral / pair.base_pitch, rel=2e-3)
    c_gamma = pair_stiffness(pair.geometry)[1]
    assert 0.7 < k_mean / c_gamma < 1.3


def test_perfect_teeth_ste_is_load_over_stiffness(pair):
    # (c) no deviations: q_s = F_s / k_m(θ) pointwise, STE ∝ load, k_m independent of it
    for load in (53.2, 70.0):
        res = tc.solve_ltca(pair, load, n_positions=400, n_slices=8)
        np.testing.assert_allclose(res.ste, load / res.stiffness, rtol=1e-12)
    r1 = tc.solve_ltca(pair, 10.0, n_positions=400)
    r2 = tc.solve_ltca(pair, 20.0, n_positions=400)
    np.testing.assert_allclose(r2.stiffness, r1.stiffness, rtol=1e-12)
    # double contact centred on t = 0 (phase convention of the scene's MeshStiffness)
    k0, amp, ph = tc.fourier_harmonics(r1.stiffness, 3)
    assert np.degrees(ph[0]) == pytest.approx(0.0, abs=1e-6)
    assert abs(abs(np.degrees(ph[1])) - 180.0) < 1e-6


def test_load_sharing_with_class6_deviations(pair):
    # (d) with ISO 1328 class-6 deviations: pair loads ≥ 0 summing to F_s, out-of-path
    # slots unloaded, and some in-path pair left out of contact by the deviations
    dev, _ = tc.class_deviations(pair, 6, slope_signs=(1, 0), form_signs=(1, 0))
    for load in (53.2, 70.0):
        res = tc.solve_ltca(pair, load, dev, n_positions=360, n_slices=40)
        np.testing.assert_allclose(res.pair_load.sum(axis=1), load, rtol=1e-10)
        assert np.all(res.pair_load >= 0.0)
        assert np.all(res.pair_load[np.isnan(res.pair_s)] == 0.0)
        in_path_unloaded = (~np.isnan(res.pair_s)) & (res.pair_load == 0.0)
        assert in_path_unloaded.any()
        assert np.all(res.stiffness > 0)


def test_partial_face_contact_matches_closed_form(pair):
    # one pair whose separation varies linearly by f across the face: with F < K f / 2
    # only part of the face touches and F = K (δ + f/2)² / (2 f), so the tangent
    # stiffness is √(2 F K / f) (K = full-face pair stiffness)
    f = 8e-6
    dev = tc.Deviations(helix_slope=f)
    res = tc.solve_ltca(pair, 5.0, dev, n_positions=400, n_slices=2000)
    s_p = pair.pitch_radius * math.sin(pair.pressure_angle)
    # the position whose single pair is nearest the pitch point (single-contact zone)
    single = np.sum(~np.isnan(res.pair_s), axis=1) == 1
    idx = np.flatnonzero(single)[np.argmin(np.nanmin(np.abs(res.pair_s[single] - s_p),
                                                     axis=1))]
    j = np.flatnonzero(~np.isnan(res.pair_s[idx]))[0]
    k_full = pair.face_width / tc.pair_compliance(pair, np.array([res.pair_s[idx, j]]))[0]
    assert 5.0 < k_full * f / 2
    # approach from the first touching fibre, and the tangent stiffness (quantised to the
    # ~140 engaged slices of 2000)
    assert res.ste[idx] + f / 2 == pytest.approx(math.sqrt(2 * 5.0 * f / k_full), rel=1e-3)
    assert res.stiffness[idx] == pytest.approx(math.sqrt(2 * 5.0 * k_full / f), rel=1e-2)


def test_iso1328_tolerances_by_hand():
    # ISO 1328-1:2013 formulas, class 6 (×√2), d = 100 mm, m = 1.3158 mm, b = 20 mm,
    # evaluated by hand and rounded (>10 µm: 1 µm, 5-10 µm: 0.5 µm, <5 µm: 0.1 µm)
    tol = tc.iso1328_tolerances(1.3158, 100.0, 20.0, 6)
    assert tol == {"f_pT": 8.0, "f_HaT": 6.5, "f_faT": 8.0, "F_aT": 10.0, "f_HbT": 8.5,
                   "f_fbT": 9.5, "F_bT": 13.0}
    # class 5, m = 2, d = 50, b = 10: f_HαT = 4.85 -> 4.9 (half up), f_fαT = 6.1 -> 6.0
    tol5 = tc.iso1328_tolerances(2.0, 50.0, 10.0, 5)
    assert tol5["f_HaT"] == pytest.approx(4.9)
    assert tol5["f_faT"] == pytest.approx(6.0)
    assert tol5["f_pT"] == pytest.approx(6.0)   # 0.05 + 0.8 + 5 = 5.85 -> 6.0


def test_harmonics_of_a_known_signal():
    t = np.arange(64) / 64
    x = 3.0 + 0.5 * np.cos(2 * np.pi * t + 0.4) + 0.2 * np.cos(6 * np.pi * t - 1.0)
    mean, amp, ph = tc.fourier_harmonics(x, 3)
    assert mean == pytest.approx(3.0)
    np.testing.assert_allclose(amp, [0.5, 0.0, 0.2], atol=1e-12)
    assert ph[0] == pytest.approx(0.4)
    assert ph[2] == pytest.approx(-1.0)


def test_scene_coefficients_load_in_the_scene(pair):
    dev, _ = tc.class_deviations(pair, 6, slope_signs=(1, 0), form_signs=(1, 0))
    res = tc.solve_ltca(pair, 70.0, dev, n_positions=360, n_slices=20)
    coef = tc.scene_coefficients(res, 3)
    overrides = {f"{sec}.{k}": v for sec, d in coef.items() for k, v in d.items()}
    scene = load_scene(PUMP, overrides)
    assert scene.mesh_stiffness.mean == pytest.approx(res.stiffness.mean(), rel=1e-4)
    assert scene.transmission_error.amplitudes[0] == pytest.approx(
        coef["transmission_error"]["amplitudes_um"][0] * 1e-6)


def test_bad_input_is_refused(gear, pair):
    with pytest.raises(ValueError, match="load"):
        tc.solve_ltca(pair, 0.0)
    geometry = gear.pair()
    with pytest.raises(ValueError, match="helix_angle"):
        tc.SpurPair.from_pair(dataclasses.replace(geometry, helix_angle=0.2))
    with pytest.raises(ValueError, match="profile_shift"):
        tc.SpurPair.from_pair(dataclasses.replace(geometry, profile_shift=(0.1, 0.0)))
    with pytest.raises(ValueError, match="teeth"):
        tc.SpurPair.from_pair(dataclasses.replace(geometry, teeth=(76, 77)))
    with pytest.raises(ValueError, match="grade"):
        tc.iso1328_tolerances(1.0, 50.0, 10.0, 12)
    with pytest.raises(ValueError, match="bore_radius"):
        tc.solve_ltca(dataclasses.replace(pair, bore_radius=0.06), 70.0)
