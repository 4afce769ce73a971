"""Outputs of a gear train run (issue 36 item 4): results.h5 with one element per mesh,
the basis chosen, per-mesh /nvh and curves.csv columns, report.md's Meshes section, the
per-mesh plots with every order named; the names of a train's orders."""
from __future__ import annotations

import csv
from fractions import Fraction
from pathlib import Path

import h5py
import numpy as np

from study.outputs.train import order_name, order_names
from study.pipeline.stages import run_scene
from study.scene.load import load_scene

ROOT = Path(__file__).resolve().parents[1]


def test_order_names_of_a_two_stage_train():
    """Mesh combinations by their smallest total order, a positive term first; shaft
    orders where no mesh combination falls; anything else as a number."""
    meshes = [("stage1", Fraction(23)), ("stage2", Fraction(437, 61))]
    shafts = [("input", Fraction(1)), ("output", Fraction(437, 4087))]
    names = order_names(meshes, shafts, max_harmonic=6)
    assert names[Fraction(23)] == "stage1"
    assert names[Fraction(2 * 437, 61)] == "2 stage2"
    assert names[Fraction(23) - Fraction(437, 61)] == "stage1 − stage2"
    assert names[6 * Fraction(437, 61) - 23] == "6 stage2 − stage1"
    assert names[Fraction(1)] == "input ×1"
    assert order_name(float(Fraction(23) - Fraction(437, 61)), names) == "stage1 − stage2"
    assert order_name(Fraction(1, 3), names) == "×0.33333"


def test_two_stage_run_writes_every_mesh(tmp_path):
    """The shipped scene over 8000-9000 rpm (4 harmonics per mesh): results.h5, curves.csv,
    report.md and the plots carry both meshes."""
    sc = load_scene(ROOT / "scenes" / "two-stage-lumped.toml",
                    {"continuation.speed_rpm": [8000.0, 9000.0], "hbm.mesh_harmonics": 4,
                     "outputs.time_series_rpm": [8800.0]})
    res = run_scene(sc, tmp_path / "run", cache_dir=tmp_path / "cache", progress=False)
    n = len(res.branch)
    with h5py.File(res.results, "r") as f:
        assert [f[f"elements/{i}"].attrs["name"] for i in range(2)] == ["stage1", "stage2"]
        loads = [float(f[f"elements/{i}/static_load"][()]) for i in range(2)]
        assert loads == [m.static_load for m in res.problem.elements]
        c = f["continuation"]
        assert c.attrs["basis"] == "periodic" and c.attrs["hunting_fundamental"] == "23/61"
        assert (c.attrs["periodic_harmonics"], c.attrs["torus_harmonics"]) == (41, 41)
        assert c["mesh_load_std"].shape == (n, 2)
        assert f["nvh/mesh_load_amplitude"].shape == (n, 2, 41)
        assert f["nvh/mesh_load_ptp"].shape == (n, 2)
        assert list(f["nvh"].attrs["elements"]) == ["stage1", "stage2"]
        orders = f["nvh/orders"][()]
        assert orders.dtype == np.float64
        assert np.allclose(orders, f["nvh/harmonics"][()] * 23 / 61, rtol=1e-15)
        assert f["excitation/harmonics"].attrs["ratio"] == "23/61"
    rows = list(csv.DictReader(open(res.out / "curves.csv")))
    assert len(rows) == n and {"stage1_std_N", "stage2_contact_class"} <= set(rows[0])
    report = (res.out / "report.md").read_text()
    for text in ("## Meshes", "| stage1 | p1:w1 (23:61) | 23 = 23 |",
                 "437/61 = 7.1639", "### Grazing bifurcations per mesh",
                 "### Impacts per mesh period (IPP)", "hunting fundamental 23/61"):
        assert text in report, text
    for name in ("forced_response.png", "campbell.png", "order_map_stage1.png",
                 "order_map_stage2.png"):
        assert (res.out / name).is_file(), name
    assert len(list(res.out.glob("spectrum_stage2_*rpm.png"))) == 1


def test_torus_run_says_stability_is_not_computed(tmp_path):
    """basis = 'torus' over a short range: no stability verdict, said in report.md."""
    sc = load_scene(ROOT / "scenes" / "two-stage-lumped.toml",
                    {"continuation.speed_rpm": [4000.0, 4600.0], "hbm.mesh_harmonics": 3,
                     "hbm.basis": "torus", "outputs.plots": ["forced_response"]})
    res = run_scene(sc, tmp_path / "run", cache_dir=tmp_path / "cache", progress=False)
    with h5py.File(res.results, "r") as f:
        assert f["continuation"].attrs["basis"] == "torus"
        assert np.all(f["continuation/floquet_kind"][()] == -1)
    assert "not computed on a torus" in (res.out / "report.md").read_text()
