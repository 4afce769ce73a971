"""``scenes/pump-paper.toml`` (docs/theory.md §13.5): the pump with its gears on lumped
rotors calibrated against Fig. 8 only. The resonance speeds are then a prediction, and
they must come out within issue 14's 3 % of the paper's Fig. 14 (1070, 1570, 3000 rpm),
as the converged run of §13.5 found (1056, 1574, 2920 rpm). Cheap 3/1 set over the
three resonances (it moves them by < 0.3 % against 12/3, §13.5)."""
from __future__ import annotations

from pathlib import Path

import pytest

pytestmark = pytest.mark.fem

SCENE = Path(__file__).resolve().parents[1] / "scenes" / "pump-paper.toml"
CHEAP = {"hbm.harmonic_set": "combinations", "hbm.mesh_harmonics": 3,
         "hbm.sideband_order": 1, "hbm.stability": False,
         "continuation.speed_rpm": [900.0, 3300.0], "outputs.plots": [],
         "outputs.housing_field_rpm": [], "outputs.report": False}


def test_pump_paper_resonances_are_the_papers_within_3_percent(tmp_path):
    import study
    from study.curves import summarize_branch
    from study.paper import PAPER, TOLERANCE

    r = study.run(SCENE, tmp_path / "run", cache_dir=tmp_path / "cache", overrides=CHEAP)
    assert r.branch.status == "completed"
    s = summarize_branch(r.branch)
    peaks = [p.rpm for p in s.strongest(3)]
    assert peaks == pytest.approx(PAPER["resonances"].value, rel=TOLERANCE)
    # and the H_Z peak is softened by contact loss, but by the paper's few per cent, not
    # the shipped pump's 20 %: 60 f/Z of the 4004 Hz mesh mode is 3161 rpm
    assert 0.05 < 1.0 - peaks[2] / 3161.0 < 0.10
