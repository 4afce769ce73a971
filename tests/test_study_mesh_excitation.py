"""A run with ``source = "ltca"`` / ``"table"`` (issue 38): the ltca stage and its cache,
results.h5 ``/mesh_excitation`` and the plots."""
from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest

import gears
import study
from study.scene import load_scene

ROOT = Path(__file__).resolve().parent.parent
QUICK = {"continuation.speed_rpm": [600.0, 1500.0], "outputs.plots": ["forced_response"]}


@pytest.fixture(scope="module")
def ltca_runs(tmp_path_factory):
    base = tmp_path_factory.mktemp("ltca")
    cache = base / "cache"
    scene = load_scene(ROOT / "scenes" / "gear-pair-ltca.toml", QUICK)
    first = study.run(scene, base / "a", cache_dir=cache, progress=False)
    second = study.run(scene, base / "b", cache_dir=cache, progress=False)
    return scene, first, second


def test_the_ltca_stage_runs_once_then_comes_from_the_cache(ltca_runs):
    _, first, second = ltca_runs
    assert first.stages["ltca"] == "ran" and second.stages["ltca"] == "cached"
    a, b = first.mesh_excitation, second.mesh_excitation
    assert a.arrays.keys() == b.arrays.keys()
    for k in a.arrays:
        np.testing.assert_array_equal(a.arrays[k], b.arrays[k])
    assert first.keys["ltca"] == second.keys["ltca"]


def test_results_h5_holds_the_ltca_arrays(ltca_runs):
    scene, first, _ = ltca_runs
    case = scene.mesh_source.case
    res = gears.solve_ltca(case)
    with h5py.File(first.results, "r") as f:
        g = f["mesh_excitation"]
        assert (g.attrs["stiffness_source"], g.attrs["te_source"]) == ("ltca", "ltca")
        assert g.attrs["harmonics"] == 16 and g.attrs["periods"] == 1
        assert g.attrs["torque"] == 150.0 and g.attrs["n_slices"] == 100
        np.testing.assert_array_equal(g["ste"][()], res.ste)
        np.testing.assert_array_equal(g["stiffness"][()], res.stiffness)
        assert g["ste"].attrs["unit"] == "m" and g["stiffness"].attrs["unit"] == "N/m"
        # load sharing: every load >= 0, summing to F_s at every position
        load = g["pair_load"][()]
        assert load.min() >= 0.0
        np.testing.assert_allclose(load.sum(axis=1), case.load, rtol=1e-10)
        # contact pattern of the crowned teeth: loaded at mid-face, symmetric
        pattern = g["pattern_line_load"][()]
        assert pattern.shape == (2, 40, 100)
        across = pattern[0].max(axis=0)
        assert np.argmax(across) in (49, 50)
        np.testing.assert_allclose(across, across[::-1], rtol=1e-6, atol=1e-6 * across.max())
        # Harris map: the tip relief was designed for the scene's torque
        torque, ptp = g["harris_torque"][()], g["harris_ste_peak_to_peak"][()]
        assert torque[0] == pytest.approx(30.0) and torque[-1] == pytest.approx(300.0)
        assert abs(torque[np.argmin(ptp)] - 150.0) <= 15.0
        assert ptp[np.argmin(ptp)] < 0.2 * ptp[-1]
        # the dynamics' series are those of the same solve
        k = f["gear_mesh/stiffness"][()]
        assert k[0].real == scene.mesh_stiffness.mean


def test_the_plots_of_an_ltca_run(ltca_runs):
    _, first, _ = ltca_runs
    names = {Path(p).name for p in first.figures}
    assert {"mesh_ste_tvms.png", "mesh_load_sharing.png", "mesh_harris.png",
            "mesh_contact_pattern.png"} <= names
    assert "mesh_hunting.png" not in names                 # no pitch deviation
    text = (first.out / "report.md").read_text()
    assert "mesh excitation: k_m from `ltca`, TE from `ltca`" in text
    assert "Harris map: smallest STE fluctuation" in text


def test_a_table_run_draws_its_samples(tmp_path):
    n = 40
    x = np.arange(n) / n
    te = 14.0 + 3.0 * np.cos(2 * np.pi * x) + 0.5 * np.cos(4 * np.pi * x + 1.0)
    (tmp_path / "te.csv").write_text("mesh_position,te_um\n" + "".join(
        f"{a!r},{b!r}\n" for a, b in zip(x, te, strict=True)))
    text = (ROOT / "scenes" / "gear-pair-sdof.toml").read_text().replace(
        'kind = "loaded"\nmean_um = 14.0\namplitudes_um = [20.0, 2.0, 0.5]\n'
        'phases_deg = [0.0, 90.0, 0.0]', 'source = "table"\nfile = "te.csv"').replace(
        "mesh_harmonics = 16", "mesh_harmonics = 6")
    (tmp_path / "s.toml").write_text(text)
    scene = load_scene(tmp_path / "s.toml", QUICK)
    r = study.run(scene, tmp_path / "out", progress=False)
    assert "ltca" not in r.stages
    with h5py.File(r.results, "r") as f:
        g = f["mesh_excitation"]
        assert (g.attrs["stiffness_source"], g.attrs["te_source"]) == ("fourier", "table")
        np.testing.assert_allclose(g["table_te"][()], te * 1e-6, rtol=1e-15)
        assert "ste" not in g
    assert {Path(p).name for p in r.figures} >= {"mesh_ste_tvms.png"}
    assert scene.transmission_error.amplitudes[0] == pytest.approx(3e-6, rel=1e-12)


def test_a_fourier_run_writes_no_mesh_excitation(tmp_path):
    scene = load_scene(ROOT / "scenes" / "gear-pair-sdof.toml", QUICK)
    r = study.run(scene, tmp_path / "out", progress=False)
    assert r.mesh_excitation is None and "ltca" not in r.stages
    with h5py.File(r.results, "r") as f:
        assert "mesh_excitation" not in f


def test_a_helical_run_with_pitch_deviations_shows_the_hunting_period(tmp_path):
    scene = load_scene(ROOT / "scenes" / "gear-pair-helical.toml",
                       {"continuation.speed_rpm": [2000.0, 4000.0],
                        "outputs.plots": ["forced_response"]})
    r = study.run(scene, tmp_path / "out", progress=False)
    data = r.mesh_excitation
    assert data.periods == 40 and data.arrays["ste"].shape == (40 * 64,)
    assert "mesh_hunting.png" in {Path(p).name for p in r.figures}
    # shaft order 1 of gear 1 from the eccentricity: A cos α_t (A = 4 µm) within 1 %
    ste = data.arrays["ste"]
    c = np.fft.rfft(ste) / ste.size
    alpha_t = scene.mesh_source.case.pair.transverse_pressure_angle
    assert 2 * abs(c[1]) == pytest.approx(4e-6 * np.cos(alpha_t), rel=1e-2)
    # the Harris map is of the mesh-periodic part: its STE fluctuation is far below
    # the 7.5 µm of the eccentricity
    assert data.arrays["harris_ste_peak_to_peak"].max() < 2e-6
    # ideal helical teeth at ε_β ≈ 1: k_m nearly constant (the crowning adds little)
    k = data.mesh_cycle("stiffness")
    assert np.ptp(k) / k.mean() < 0.01


def test_geardyn_report_redraws_the_mesh_excitation(ltca_runs, tmp_path):
    from study.pipeline.replay import report_from_results

    _, first, _ = ltca_runs
    for p in first.out.glob("mesh_*.png"):
        p.unlink()
    res = report_from_results(ROOT / "scenes" / "gear-pair-ltca.toml", first.out, QUICK,
                              cache=str(first.out.parent / "cache"))
    assert res.keys["ltca"] == first.keys["ltca"]          # served from the stage cache
    assert (first.out / "mesh_harris.png").exists()
    assert "mesh excitation: k_m from `ltca`" in (first.out / "report.md").read_text()
