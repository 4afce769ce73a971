"""Provenance of results.h5: the scene as run, version and git revision, stage times
(issue 39 item 4; docs/results-format.md)."""
from __future__ import annotations

import json
import math
import subprocess
from pathlib import Path

import h5py
import pytest

import study
from study.outputs.provenance import SOURCE_ROOT, git_revision
from study.scene import load_scene, scene_from_dict
from study.scene.resolved import derived_quantities, resolved_table

ROOT = Path(__file__).resolve().parents[1]
SDOF = ROOT / "scenes" / "gear-pair-sdof.toml"


def test_resolved_table_loads_back_into_the_same_scene():
    s = load_scene(SDOF, {"load.torque_Nm": 120.0, "hbm.mesh_harmonics": 8})
    t = resolved_table(s)
    assert t["load"] == {"torque_Nm": 120.0}                    # the override, not the file
    assert t["hbm"]["mesh_harmonics"] == 8
    assert t["hbm"]["sideband_order"] == 0                      # a default filled in
    assert t["gear"]["module_mm"] == pytest.approx(2 * 46.984 / (76 * math.cos(math.radians(20))))
    assert t["continuation"]["step_rpm"] == pytest.approx((4500 - 600) / 200)   # derived default
    back = scene_from_dict(json.loads(json.dumps(t)))
    assert back == s                                            # every dataclass field equal
    d = derived_quantities(s)
    assert d["static_load_N"] == pytest.approx(120.0 / 46.984e-3)
    assert d["mesh_stiffness_N_per_m"]["mean"] == 220e6


def test_resolved_fe_scene_keeps_its_fe_parameters():
    """The FE sections gain the FE dataclasses' defaults in SI; the machine built from the
    resolved table has the same parameters."""
    from machines import machine_for

    s = load_scene(ROOT / "scenes" / "pump.toml", {"bearings.radial_N_per_um": 150.0})
    t = resolved_table(s, machine_for(s).params)
    assert t["bearings"]["radial_N_per_um"] == 150.0 and t["bearings"]["tilting"] == 0.0
    assert t["drive"]["impeller_mass"] == 0.0
    assert t["mesh"]["preset"] == "coarse" and t["mesh"]["size"] == pytest.approx(0.027)
    back = scene_from_dict(json.loads(json.dumps(t)))
    assert machine_for(back).params == machine_for(s).params


def test_git_revision_of_a_checkout_and_of_a_plain_folder(tmp_path):
    rev, state = git_revision(tmp_path)
    assert rev == "none" and state.startswith("not a git checkout")
    head = subprocess.run(["git", "-C", str(SOURCE_ROOT), "rev-parse", "HEAD"],
                          capture_output=True, text=True)
    if head.returncode == 0:
        assert git_revision(SOURCE_ROOT)[0] == head.stdout.strip()
        assert git_revision(SOURCE_ROOT)[1] in ("clean", "modified")


def test_results_store_the_scene_as_run_and_stage_times(tmp_path):
    ov = {"continuation.speed_rpm": [600.0, 900.0], "load.torque_Nm": 140.0,
          "outputs.plots": []}
    res = study.run(SDOF, tmp_path / "run", overrides=ov)
    with h5py.File(res.results, "r") as f:
        text = f["scene/text"][()].decode()
        table = json.loads(f["scene/resolved"][()].decode())
        prov = dict(f["provenance"].attrs)
        stages = dict(f["provenance/stages"].attrs)
    assert "torque_Nm = 150.0" in text                      # the file as written ...
    assert table["load"]["torque_Nm"] == 140.0              # ... and the scene as run
    assert table["continuation"]["speed_rpm"] == [600.0, 900.0]
    assert scene_from_dict(table) == res.scene
    assert prov["geardyn_version"] == study.__version__
    assert prov["git_revision"] == git_revision()[0]
    assert stages["hbm_state"] == "ran" and stages["hbm_seconds"] > 0
    assert stages["export_state"] == "ran" and stages["export_seconds"] > 0
    assert stages["mesh_state"] == "skipped (lumped scene)" and math.isnan(stages["mesh_seconds"])
    # a second run serves hbm from the cache: no time of its own
    res2 = study.run(SDOF, tmp_path / "run2", overrides=ov)
    with h5py.File(res2.results, "r") as f:
        assert f["provenance/stages"].attrs["hbm_state"] == "cached"
        assert math.isnan(f["provenance/stages"].attrs["hbm_seconds"])


@pytest.mark.parametrize("path", sorted((ROOT / "scenes").glob("*.toml")), ids=lambda p: p.stem)
def test_every_shipped_scene_round_trips(path):
    """The resolved table of each shipped scene (pairs, LTCA source, train, FE) loads back
    into the same scene (FE: the same FE parameters)."""
    from machines import machine_for

    s = load_scene(path)
    fe = machine_for(s).params if s.fe else None
    back = scene_from_dict(json.loads(json.dumps(resolved_table(s, fe))))
    if fe is None:
        assert back == s
    else:
        assert machine_for(back).params == fe
