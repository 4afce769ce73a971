"""The stage ``branches`` of a run (issue 40 item 2): period-2 branches of the SDOF gear
pair written to results.h5 ``/branches``, listed in report.md and drawn on the forced
response; skipped at once without a period doubling or at depth 0."""
from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest

import study

ROOT = Path(__file__).resolve().parents[1]
SDOF = ROOT / "scenes" / "gear-pair-sdof.toml"
#: the period doubling of the shipped scene near 4055 rpm (docs/hbm.md "Period doubling")
RANGE = {"continuation.speed_rpm": [3700.0, 4500.0], "outputs.plots": ["forced_response"],
         "hbm.mesh_harmonics": 8}


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    return study.run(SDOF, tmp_path_factory.mktemp("branches") / "pd", overrides=RANGE)


def test_period2_branch_is_written_reported_and_drawn(run):
    assert run.stages["branches"] == "ran"
    assert run.secondary and run.secondary[0].period == 2
    s = run.secondary[0]
    with h5py.File(run.results, "r") as f:
        assert list(f["branches"].attrs["names"]) == [x.name for x in run.secondary]
        g = f["branches"][s.name]
        assert g.attrs["parent"] == "main" and g.attrs["period"] == 2
        assert g.attrs["ratio"] == "38"                      # Z/2: the mesh fundamental halved
        np.testing.assert_array_equal(g["continuation/rpm"][()], s.branch.rpm)
        np.testing.assert_array_equal(g["continuation/mesh_load_std"][()],
                                      s.branch.element(0).mesh_load_std)
        assert g["continuation/harmonics"].shape == (2 * 8 + 2,)
        assert abs(g.attrs["doubling_rpm"] - s.doubling.rpm) == 0
        # the main curve is where it was
        assert f["continuation/rpm"].shape == (len(run.branch),)
    text = (run.out / "report.md").read_text()
    assert "## Period doubling" in text and f"| {s.name} | main |" in text
    assert (run.out / "forced_response.png").exists()


def test_stage_skips_without_period_doubling(tmp_path):
    r = study.run(SDOF, tmp_path / "low", overrides={
        "continuation.speed_rpm": [600.0, 900.0], "outputs.plots": [],
        "hbm.mesh_harmonics": 6})
    assert r.stages["branches"].startswith("skipped") and r.secondary == []
    r0 = study.run(SDOF, tmp_path / "off", overrides={
        **RANGE, "outputs.plots": [], "continuation.period_doubling_depth": 0})
    assert r0.stages["branches"].startswith("skipped") and r0.secondary == []
    with h5py.File(r0.results, "r") as f:
        assert "branches" not in f


@pytest.mark.parametrize("order, name", [(38, "Z/2"), (114, "3Z/2"), (75.5, "Z−1/2"),
                                         (76.5, "Z+1/2"), (0.5, "1/2"), (76, "Z"),
                                         (77, "Z+1"), (152, "2Z")])
def test_half_order_labels(order, name):
    from study.outputs.nvh import order_label

    assert order_label(order, 76) == name
