"""``scenes/pump-paper.toml`` (docs/theory.md §13.5): the pump with its gears on lumped
rotors calibrated against Fig. 8 and its TE calibrated against the paper's five grazing
speeds. The resonance speeds are a prediction and must come out within issue 14's 3 % of
Fig. 14 (1070, 1570, 3000 rpm); the grazings and the two permanent-contact windows are
the calibration's, checked here so that a change of the model that moves them is seen.
All excitations, the scene's converged 12/3 set, 900–3300 rpm (the five grazings and the
three resonances), no stability."""
from __future__ import annotations

from pathlib import Path

import pytest

pytestmark = pytest.mark.fem

SCENE = Path(__file__).resolve().parents[1] / "scenes" / "pump-paper.toml"
RANGE = {"hbm.stability": False, "continuation.speed_rpm": [900.0, 3300.0],
         "outputs.plots": [], "outputs.housing_field_rpm": [], "outputs.report": False}


@pytest.fixture(scope="module")
def summary(tmp_path_factory):
    import study
    from study.curves import summarize_branch

    tmp = tmp_path_factory.mktemp("pump-paper")
    r = study.run(SCENE, tmp / "run", cache_dir=tmp / "cache", overrides=RANGE)
    assert r.branch.status == "completed"
    return summarize_branch(r.branch)


def test_resonances_are_the_papers_within_3_percent(summary):
    from study.paper import PAPER, TOLERANCE

    peaks = [p.rpm for p in summary.strongest(3)]
    assert peaks == pytest.approx(PAPER["resonances"].value, rel=TOLERANCE)
    # the H_Z peak is softened by contact loss by the paper's few per cent (5 %: 3000
    # against 60 f/Z = 3158 rpm), not the shipped pump's 21 %: 60 f/Z of the 4004 Hz
    # mesh mode is 3161 rpm
    assert 0.02 < 1.0 - peaks[2] / 3161.0 < 0.08


def test_grazings_and_windows_are_the_calibrated_ones(summary):
    from study.paper import PAPER, TOLERANCE

    assert summary.grazing == pytest.approx(PAPER["grazing"].value, rel=TOLERANCE)
    assert len(summary.windows) == 2
    for (lo, hi), (p_lo, p_hi) in zip(summary.windows, PAPER["windows"].value, strict=True):
        assert lo < p_hi and hi > p_lo  # each window overlaps the paper's
