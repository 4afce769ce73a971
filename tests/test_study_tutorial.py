"""docs/tutorial.md stays true: its scene loads without warning and gives the numbers the
text quotes (issue 39 item 6); section 8's LTCA tables, put in the shipped two-stage
scene as the text says, give the LTCA it quotes."""
from __future__ import annotations

import logging
import math
import re
from pathlib import Path

import numpy as np
import pytest
from train_scenes import LTCA_RELIEVED, two_stage_with_stage2

from study.scene import SceneError, parse_scene

ROOT = Path(__file__).resolve().parents[1]
TEXT = (ROOT / "docs" / "tutorial.md").read_text()


def _blocks() -> list[str]:
    return re.findall(r"```toml\n(.*?)```", TEXT, flags=re.S)


def _scene_text() -> str:
    """Section 2's scene (the first of the two TOML blocks)."""
    blocks = _blocks()
    assert len(blocks) == 2
    return blocks[0]


def test_tutorial_scene_loads_with_the_quoted_numbers(caplog):
    with caplog.at_level(logging.WARNING):
        s = parse_scene(_scene_text(), "my-gearbox")
    assert not [r for r in caplog.records if r.name.startswith("study")]
    assert s.static_load == pytest.approx(1064.18, abs=0.01)                 # "1064 N"
    assert s.mesh_stiffness.estimated and round(s.mesh_stiffness.mean / 1e6) == 473
    assert round(s.mesh_stiffness.mean / 1e6 / 25.0, 1) == 18.9             # N/(mm·µm)
    assert round(s.static_load / s.mesh_stiffness.mean * 1e6, 2) == 2.25     # µm
    assert round(s.gear.contact_ratio, 2) == 1.71
    assert s.gear.module == pytest.approx(2e-3, rel=1e-5)
    assert 2 * s.gear.base_radius / (40 * math.cos(math.radians(20))) == pytest.approx(2e-3,
                                                                                    rel=1e-5)
    assert "1064 N, 4.73e8 N/m, 1.71" in TEXT and "k̄ = 473 N/µm" in TEXT


def test_tutorial_unit_slip_is_refused_as_quoted():
    bad = _scene_text().replace("housing_E_GPa = 70.0", "housing_E_GPa = 0.07")
    with pytest.raises(SceneError) as err:
        parse_scene(bad, "my-gearbox")
    quoted = "materials.housing_E_GPa = 0.07 GPa: outside the plausible range [0.1, 1500] GPa"
    assert str(err.value).startswith(quoted) and quoted in TEXT


def test_section_8_ltca_tables_give_the_quoted_ltca():
    """Section 8: stage 2 of scenes/two-stage-lumped.toml from the LTCA with tip relief and
    crowning: its torque, k̄, STE peak-to-peak (and without the relief) as quoted."""
    import gears

    snippet = _blocks()[1]
    s = parse_scene(two_stage_with_stage2(snippet), "my-reducer")
    # the tests' copy of the snippet (train_scenes.LTCA_RELIEVED) is the same case
    assert parse_scene(two_stage_with_stage2(LTCA_RELIEVED), "copy").meshes[1].source == \
        s.meshes[1].source
    m = s.meshes[1]
    ste = gears.solve_ltca(m.source.case).ste
    plain = parse_scene(two_stage_with_stage2(snippet.replace("tip_relief_um = 20.0",
                                                              "tip_relief_um = 0.0")),
                        "no-relief")
    no_relief = gears.solve_ltca(plain.meshes[1].source.case).ste
    quoted = (f"LTCA of stage2 at {m.source.case.torque:.3f} N·m", f"{np.ptp(ste) * 1e6:.3f} µm",
              f"`{m.mesh_stiffness.mean / 1e6:.1f} (LTCA)`",
              f"({np.ptp(no_relief) * 1e6:.2f} µm peak-to-peak without the relief")
    assert quoted == ("LTCA of stage2 at 132.609 N·m", "3.104 µm", "`548.3 (LTCA)`",
                      "(8.30 µm peak-to-peak without the relief")
    flat = " ".join(TEXT.split())
    for q in quoted:
        assert q in flat, q
