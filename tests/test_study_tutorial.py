"""docs/tutorial.md stays true: its scene loads without warning and gives the numbers the
text quotes (issue 39 item 6)."""
from __future__ import annotations

import logging
import math
import re
from pathlib import Path

import pytest

from study.scene import SceneError, parse_scene

ROOT = Path(__file__).resolve().parents[1]
TEXT = (ROOT / "docs" / "tutorial.md").read_text()


def _scene_text() -> str:
    blocks = re.findall(r"```toml\n(.*?)```", TEXT, flags=re.S)
    assert len(blocks) == 1
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
