"""Fixtures shared by the benchmark tests."""
from __future__ import annotations

from pathlib import Path

import pytest

SDOF = Path(__file__).resolve().parents[2] / "scenes" / "gear-pair-sdof.toml"


@pytest.fixture(scope="session")
def sdof3_run(tmp_path_factory):
    """The SDOF pair run with 3 mesh harmonics over 1700-2200 rpm (it checks its verdicts
    in and next to its tangles on 4, and has unstable runs): (scene, its --set items, the
    output folder, the stage cache)."""
    from study.pipeline import Pipeline
    from study.scene.load import load_scene

    root = tmp_path_factory.mktemp("sdof3")
    over = {"hbm.mesh_harmonics": 3, "continuation.speed_rpm": [1700.0, 2200.0],
            "outputs.plots": []}
    Pipeline(load_scene(SDOF, over), root / "out", cache_dir=root / "cache",
             progress=False).run()
    return SDOF, ["hbm.mesh_harmonics=3"], root / "out", root / "cache"
