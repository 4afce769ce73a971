"""results.h5 of a branch with one gear mesh (the documented 1-D datasets) and with two
elements (the (n_points, n_elements) layout, docs/results-format.md): written and read
back, the branch is the one traced."""
from __future__ import annotations

from types import SimpleNamespace

import h5py
import numpy as np
from hbm_models import RPM, sdof_problem

import hbm
from study.outputs.results import read_branch, write_results


def _scene():
    return SimpleNamespace(name="test", text="", scene=SimpleNamespace(kind="lumped"),
                           load=SimpleNamespace(torque=1.0),
                           gear=SimpleNamespace(base_radius=0.05, pressure_angle=0.35,
                                                helix_angle=0.0))


def _two_halves():
    els = [hbm.GearMesh([1.0], 1, {0: 0.5, 1: 0.1}, te={1: 0.3j}, backlash=1.0,
                        name=f"half {i}") for i in range(2)]
    return hbm.HBMProblem(hbm.LinearSystem([[1.0]], [[0.1]], [[0.0]]), els,
                          hbm.Excitation(1, constant={0: [0.1], 1: [0.05]}),
                          hbm.HarmonicSet.build(1, 12))


def _same(a, b) -> None:
    assert len(a) == len(b) and a.n_elements == b.n_elements
    for k in ("rpm", "unknowns", "stable", "floquet_kind", "tangents"):
        np.testing.assert_array_equal(getattr(a, k), getattr(b, k))
    assert set(a.stats) == set(b.stats)
    for k, v in a.stats.items():
        np.testing.assert_array_equal(v, b.stats[k])
    assert [(g.rpm, g.kind, g.side, g.element) for g in a.grazing] == \
        [(g.rpm, g.kind, g.side, g.element) for g in b.grazing]


def test_one_mesh_keeps_the_one_dimensional_datasets(tmp_path):
    pb = sdof_problem(harmonics=12, fa=0.1, b=0.2)
    br = hbm.trace(pb, 0.3 / RPM, 1.2 / RPM, stability=False)
    assert br.grazing
    path = tmp_path / "results.h5"
    write_results(path, _scene(), pb, br)
    with h5py.File(path) as f:
        c = f["continuation"]
        assert c["mesh_load_std"].shape == (len(br),)
        assert c["ipp"].shape == (len(br), 1) and c["coefficients"].shape == (len(br), 13)
        assert "elements" not in c.attrs and "element" not in f["grazing"]
        assert "gear_mesh" in f and f["system/G"].shape == (1,)
        assert f["excitation/harmonics"].attrs["divisor"] == 1
    _same(br, read_branch(path, pb))


def test_two_elements_have_an_element_axis(tmp_path):
    pb = _two_halves()
    br = hbm.trace(pb, 0.3 / RPM, 0.6 / RPM, stability=False)
    assert {g.element for g in br.grazing} == {0, 1}
    path = tmp_path / "results.h5"
    write_results(path, _scene(), pb, br)
    with h5py.File(path) as f:
        c = f["continuation"]
        assert c["mesh_load_std"].shape == (len(br), 2)
        assert c["ipp"].shape == (len(br), 2, 1) and c["coefficients"].shape == (len(br), 2, 13)
        assert list(c.attrs["elements"]) == ["half 0", "half 1"]
        assert sorted(f["grazing/element"][()]) == sorted(g.element for g in br.grazing)
        assert f["elements/1"].attrs["kind"] == "gear_mesh"
        assert f["system/G"].shape == (1, 2)
    back = read_branch(path, pb)
    _same(br, back)
    assert back.element(1).name == "half 1"
    assert back.element_statistics == br.element_statistics
