"""A train mesh whose k_m and TE come from the LTCA: its arrays in results.h5
``/elements/<i>/mesh_excitation``, cached by the ltca stage, its plots (file names ending
with the mesh's name) and its lines in report.md; the other mesh has none."""
from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest
from train_scenes import two_stage_with_stage2

import gears
from study.pipeline.replay import report_from_results
from study.pipeline.stages import run_scene
from study.scene.load import load_scene

ROOT = Path(__file__).resolve().parents[1]
QUICK = {"continuation.speed_rpm": [8000.0, 9000.0], "hbm.mesh_harmonics": 4,
         "outputs.plots": ["forced_response"]}


@pytest.fixture(scope="module")
def ltca_train(tmp_path_factory):
    """The lumped two-stage train with stage 2 from the LTCA of its own pair (tip relief
    on the wheel), run twice on one cache."""
    tmp = tmp_path_factory.mktemp("ltca_train")
    ltca = ('[meshes.mesh_stiffness]\nsource = "ltca"\n[meshes.transmission_error]\n'
            'source = "ltca"\nkind = "loaded"\n[meshes.micro_geometry.gear2]\n'
            'tip_relief_um = 8.0\ntip_relief_start_diameter_mm = 135.5\n')
    path = tmp / "ltca-train.toml"
    path.write_text(two_stage_with_stage2(ltca))
    scene = load_scene(path, QUICK)
    first = run_scene(scene, tmp / "a", cache_dir=tmp / "cache", progress=False)
    second = run_scene(scene, tmp / "b", cache_dir=tmp / "cache", progress=False)
    return path, scene, first, second


def test_the_ltca_mesh_is_solved_once_then_cached(ltca_train):
    _, scene, first, second = ltca_train
    assert first.stages["ltca"] == "ran" and second.stages["ltca"] == "cached"
    assert list(first.train_excitations) == ["stage2"]
    assert first.keys["ltca stage2"] == second.keys["ltca stage2"]
    a, b = first.train_excitations["stage2"], second.train_excitations["stage2"]
    for k in a.arrays:
        np.testing.assert_array_equal(a.arrays[k], b.arrays[k])


def test_results_h5_holds_the_arrays_of_the_ltca_mesh(ltca_train):
    """The arrays are the LTCA of the mesh's case; the series the dynamics took (the
    element's stiffness and TE coefficients, ``Re sum c_m exp(i m phase)``) are the
    Fourier coefficients of their mesh cycle, computed here by FFT: the mean, and each
    harmonic's amplitude (its phase carries the mesh's phase at t = 0)."""
    _, scene, first, _ = ltca_train
    case = scene.meshes[1].source.case
    res = gears.solve_ltca(case)
    with h5py.File(first.results, "r") as f:
        assert "mesh_excitation" not in f["elements/0"]
        g = f["elements/1/mesh_excitation"]
        assert f["elements/1"].attrs["name"] == "stage2"
        assert (g.attrs["stiffness_source"], g.attrs["te_source"]) == ("ltca", "ltca")
        assert g.attrs["harmonics"] == 4 and g.attrs["periods"] == 1
        assert g.attrs["torque"] == pytest.approx(case.torque, rel=1e-14)
        np.testing.assert_array_equal(g["ste"][()], res.ste)
        np.testing.assert_array_equal(g["stiffness"][()], res.stiffness)
        np.testing.assert_allclose(g["pair_load"][()].sum(axis=1), case.load, rtol=1e-10)
        for name, dyn in (("stiffness", "stiffness"), ("ste", "te")):
            cycle = g[name][()]
            n = cycle.size
            spec = np.fft.rfft(cycle) / n
            idx = f[f"elements/1/{dyn}_harmonics"][()]
            c = f[f"elements/1/{dyn}"][()]
            assert list(idx) == [0, 1, 2, 3, 4]
            assert c[0].real == pytest.approx(cycle.mean(), rel=1e-12)
            np.testing.assert_allclose(np.abs(c[1:]), 2 * np.abs(spec[1:5]), rtol=1e-9,
                                       atol=1e-12 * np.abs(c).max())


def test_plots_and_report_name_the_mesh(ltca_train):
    path, _, first, _ = ltca_train
    for stem in ("mesh_ste_tvms", "mesh_load_sharing", "mesh_harris"):  # one slice
        assert (first.out / f"{stem}_stage2.png").is_file(), stem
        assert not (first.out / f"{stem}_stage1.png").exists()
    report = (first.out / "report.md").read_text()
    assert "- mesh excitation of stage2: k_m from `ltca`, TE from `ltca`" in report
    assert "arrays in results.h5 `/elements/1/mesh_excitation`" in report
    assert "- LTCA of stage2 at " in report and "of stage1:" not in report
    # the Meshes table says where each k̄ comes from
    assert "| 464.3 (ISO 6336) |" in report and "| 574.1 (LTCA) |" in report
    # `geardyn report` from results.h5 draws them again from the cached arrays
    (first.out / "mesh_harris_stage2.png").unlink()
    report_from_results(path, first.out, QUICK, cache=str(first.out.parent / "cache"))
    assert (first.out / "mesh_harris_stage2.png").is_file()
