"""benchmarks/te_margin.py: the linear contact margin as an affine function of the TE
harmonics, checked against direct solves and the continuation's grazing on the
single-DOF scene (no FE, seconds), and its zero finding on closed-form curves."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from benchmarks import te_margin as tm

ROOT = Path(__file__).resolve().parents[2]
SDOF = ROOT / "scenes" / "gear-pair-sdof.toml"
#: the scene's TE (µm, deg): 20, 2, 0.5 at 0, 90, 0
SDOF_TE = ([20.0, 2.0, 0.5], [0.0, 90.0, 0.0])
OV = {"hbm.mesh_harmonics": 8, "hbm.stability": False}


def _direct_margin(cache: Path, amps_um, phases_deg, rpm: float, n_time: int) -> float:
    """``min_t (p - b)`` of the permanent-contact solution solved with this TE."""
    from hbm.problem.fixed_speed import initial_guess
    from hbm.units import RPM_TO_RAD_S
    from study.pipeline import Pipeline
    from study.scene.load import load_scene

    sc = load_scene(SDOF, {**OV, "transmission_error.amplitudes_um": list(amps_um),
                           "transmission_error.phases_deg": list(phases_deg)})
    prob = Pipeline(sc, cache / "direct", cache_dir=cache, progress=False).problem()[0]
    synth, samples = prob.fine_grid(n_time)
    e = samples[0].e
    u = initial_guess(prob, rpm * RPM_TO_RAD_S)
    return float(np.min((synth @ prob.delta_real(u))[0] - e - prob.elements[0].backlash))


def test_margin_superposes_the_te_harmonics_like_a_direct_solve(tmp_path):
    rpm = np.array([800.0, 1416.0, 2500.0])
    basis = tm.build_basis(SDOF, OV, rpm, tmp_path)
    n = basis.p0.shape[1]
    for amps, phases in ((SDOF_TE[0], SDOF_TE[1]), ([7.0, 4.5, 1.5], [35.0, 200.0, 300.0])):
        m = basis.margin(np.asarray(amps) * 1e-6, np.radians(phases))
        for r, mi in zip(rpm, m, strict=True):
            ref = _direct_margin(tmp_path, amps, phases, float(r), n)
            assert mi == pytest.approx(ref, rel=1e-7, abs=1e-13)


def test_zero_of_the_linear_margin_is_the_continuations_grazing(tmp_path):
    import study

    res = study.run(SDOF, tmp_path / "run", cache_dir=tmp_path,
                    overrides={**OV, "continuation.speed_rpm": [1300.0, 1500.0]}, until="hbm")
    graz = [g.rpm for g in res.branch.grazing]
    assert len(graz) == 1                     # the first grazing of the scene, ~1416 rpm
    rpm = np.arange(1410.0, 1420.0, 0.02)
    basis = tm.build_basis(SDOF, OV, rpm, tmp_path)
    c = tm.crossings(rpm, basis.margin(np.asarray(SDOF_TE[0]) * 1e-6, np.radians(SDOF_TE[1])))
    assert len(c) == 1
    assert c[0] == pytest.approx(graz[0], abs=0.05)


def test_crossings_and_intervals_of_a_cosine():
    rpm = np.linspace(0.0, 10.0, 20001)
    m = np.cos(rpm)                       # zeros at pi/2, 3pi/2, 5pi/2
    c = tm.crossings(rpm, m)
    assert c == pytest.approx([np.pi / 2, 3 * np.pi / 2, 5 * np.pi / 2], abs=1e-6)
    iv = tm.impact_intervals(rpm, m)      # m < 0 between the first two, and after the third
    assert np.ravel(iv) == pytest.approx([np.pi / 2, 3 * np.pi / 2, 5 * np.pi / 2, 10.0],
                                         abs=1e-6)


def test_pattern_score_is_the_grazing_error_for_the_target_pattern():
    target = (1000.0, 1200.0, 1300.0, 2200.0, 2400.0)
    rpm = np.arange(500.0, 7001.0, 1.0)
    found = (1010.0, 1200.0, 1300.0, 2200.0, 2400.0)       # one grazing 1 % high
    m = np.prod([rpm - f for f in found], axis=0) * -1.0    # > 0 at 500, < 0 at 7000
    s, c = tm.pattern_score(rpm, m, target)
    assert c == pytest.approx(found, abs=1e-6)
    assert s == pytest.approx(0.01 + 0.3 * 0.01 / np.sqrt(5), rel=1e-6)
    # impacts at the first speed: not the pattern, whatever the zeros
    s2, _ = tm.pattern_score(rpm, -m, target)
    assert s2 >= 1.5
    # the depth: smallest of the low-speed minimum and the window maxima
    assert tm.depth(rpm, m, c) == pytest.approx(
        min(m[rpm < 1010].min(), m[(rpm > 1200) & (rpm < 1300)].max(),
            m[(rpm > 2200) & (rpm < 2400)].max()))


# --- linear IPP and the H_3Z measures on a hand-built margin -----------------------------

def _three_minima(depth_offsets, eps, per=240):
    """``d_j - cos 3ψ - eps cos ψ`` in mesh period j (ψ = φ - π/6, so the three minima
    sit inside the period and the signal is > 0 at its ends for d_j >= 0.85): minima
    ``d_j - 1 - eps`` (ψ = 0) and ``d_j - 1 + eps/2`` (ψ = ±2π/3)."""
    phi = 2 * np.pi * np.arange(per) / per
    psi = phi - np.pi / 6
    return np.concatenate([d - np.cos(3 * psi) - eps * np.cos(psi) for d in depth_offsets])


def test_linear_ipp_counts_loss_intervals_per_mesh_period():
    # d = 1.3: no loss; 1.1: only the deep minimum (-0.1); 0.85: all three below zero
    d = [1.3, 1.1, 0.85, 0.85, 1.1, 1.3]
    s = _three_minima(d, eps=0.2)
    ipp = tm.linear_ipp(s, len(d))
    assert ipp.tolist() == [0, 1, 3, 3, 1, 0]
    f = tm.ipp_fraction_vector(ipp)
    assert f == pytest.approx([2 / 6, 2 / 6, 0.0, 2 / 6])
    assert tm.cumulative(f) == pytest.approx([4 / 6, 2 / 6, 2 / 6])
    assert tm.ipp_distance(f, [2 / 6, 2 / 6, 2 / 6, 0.0]) == pytest.approx(2 / 6)
    # the minima per period, as built (to first order in eps): d - 1 - eps, then twice
    # d - 1 + eps/2 (their shift by the eps term lowers them by 1.5e-3)
    m = tm.period_minima(s, len(d), 3)
    for j, dj in enumerate(d):
        assert m[j] == pytest.approx([dj - 1.2, dj - 0.9, dj - 0.9], abs=3e-3)
    # contact (d = 1.3: lowest minimum +0.1) and 3 impacts (third minimum
    # -0.05 at d = 0.85) in one turn: the gap is the larger of -0.1 and -0.05
    assert tm.coexistence_gap(s, len(d), 3) == pytest.approx(-0.05, abs=3e-3)
    # the smooth stand-in tends to the step of the counts
    assert tm.soft_ipp(s, len(d), 1e-5) == pytest.approx(tm.cumulative(f), abs=1e-6)
    with pytest.raises(ValueError, match="mesh_step"):
        tm.linear_ipp(s[:-1], len(d))


def test_minima_count_and_h3_ratio_see_which_harmonic_governs():
    s3 = _three_minima([1.0] * 4, eps=0.2)      # H_3Z governs: three deep minima
    s1 = _three_minima([1.0] * 4, eps=3.0)      # H_Z governs: one
    assert tm.minima_count(s3, 4, 0.5).tolist() == [3] * 4
    assert tm.minima_count(s1, 4, 0.5).tolist() == [1] * 4
    # amplitudes 0.2 (H_Z) and 1 (H_3Z), no H_2Z; a slow component does not count
    a = tm.mesh_harmonics(s3 + 0.3 * np.cos(2 * np.pi * np.arange(s3.size) / s3.size), 4)
    assert a == pytest.approx([0.2, 0.0, 1.0], abs=1e-12)
    assert tm.h3_ratio(s3, 4) == pytest.approx(5.0)


def test_fourier_resample_is_exact_for_a_band_limited_signal():
    n, m = 64, 76 * 3
    t0, t1 = np.arange(n) / n, np.arange(m) / m

    def sig(t):
        return 0.3 + np.cos(2 * np.pi * 5 * t + 0.4) - 0.2 * np.sin(2 * np.pi * 31 * t)

    assert tm.fourier_resample(sig(t0), m) == pytest.approx(sig(t1), abs=1e-12)


def test_speed_model_is_the_basis_signal_at_that_speed(tmp_path):
    rpm = np.array([800.0, 1416.0])
    basis = tm.build_basis(SDOF, OV, rpm, tmp_path)
    sm = tm.SpeedModel(basis, 1416.0, oversample=1)
    amps, phases = [7.0, 4.5, 1.5], [35.0, 200.0, 300.0]
    ref = basis.signals(np.asarray(amps) * 1e-6, np.radians(phases))[1]
    got = sm.signals(amps, phases)[0]
    n = len(ref)
    # the same periodic signal, on a grid of a whole number of samples per mesh period
    assert len(got) % basis.mesh_step == 0 and len(got) >= n
    assert tm.fourier_resample(ref, len(got)) == pytest.approx(got, abs=1e-15)
    assert np.min(got) == pytest.approx(np.min(ref), abs=1e-3 * np.ptp(ref))
    with pytest.raises(ValueError, match="rpm = 1000"):
        tm.SpeedModel(basis, 1000.0)


def test_nelder_mead_restarts_reach_the_rosenbrock_minimum():
    def rosen(x):
        return 100.0 * (x[1] - x[0] ** 2) ** 2 + (1.0 - x[0]) ** 2

    def run(restarts):
        return tm.nelder_mead(rosen, np.array([-1.2, 1.0]), [0.5, 0.5], 80, xatol=1e-8,
                              fatol=1e-12, restarts=restarts).x

    # 80 evaluations do not reach the minimum (1, 1) from the classic start; three
    # runs of 80, each from a fresh simplex at the last point, do
    assert np.abs(run(1) - 1.0).max() > 0.1
    assert run(3) == pytest.approx([1.0, 1.0], abs=1e-4)
    with pytest.raises(ValueError, match="restarts = 0"):
        tm.nelder_mead(rosen, np.zeros(2), [0.5, 0.5], 10, 1e-3, 1e-3, restarts=0)
