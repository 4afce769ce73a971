"""``geardyn microgeometry`` (issue 38 item 4): one micro-geometry key varied on an LTCA
scene, its table and plot."""
from __future__ import annotations

from pathlib import Path

import pytest
from train_scenes import LTCA_RELIEVED, two_stage_with_stage2

from study.cli import EXIT_INPUT, EXIT_OK, main

ROOT = Path(__file__).resolve().parent.parent
LTCA = str(ROOT / "scenes" / "gear-pair-ltca.toml")
QUICK = ["--set", "continuation.speed_rpm=[1800.0,2600.0]", "--set",
         "outputs.plots=[\"forced_response\"]", "--no-progress", "-q"]


def test_tip_relief_amount_against_the_vibro_impact_map(tmp_path):
    out = tmp_path / "study"
    code = main(["microgeometry", LTCA, "--out", str(out), "--set",
                 "micro_geometry.both.tip_relief_um=0,12", *QUICK])
    assert code == EXIT_OK
    text = (out / "microgeometry.md").read_text()
    rows = [ln for ln in text.splitlines() if ln.startswith("| 0 |") or ln.startswith("| 12 |")]
    assert len(rows) == 2
    cells = {r.split("|")[1].strip(): [c.strip() for c in r.split("|")[2:-1]] for r in rows}
    # unmodified teeth: 5.6 µm STE fluctuation and impacts near 2000-2300 rpm; the
    # relief designed for the scene's torque: < 1 µm and no impacts in this range
    assert float(cells["0"][0]) == pytest.approx(5.634, abs=0.01)
    assert float(cells["12"][0]) < 1.0
    assert "SS" in cells["0"][6] and cells["12"][6] == "none"
    assert float(cells["12"][2]) < 0.5 * float(cells["0"][2])     # largest mesh-load std
    assert (out / "microgeometry.png").stat().st_size > 10_000
    assert (out / "microgeometry.csv").read_text().startswith("value,ste_peak_to_peak_um")
    assert (out / "tip_relief_um=12" / "mesh_harris.png").exists()


def test_the_study_refuses_what_it_cannot_compare(tmp_path, capsys):
    out = str(tmp_path / "x")
    assert main(["microgeometry", LTCA, "--out", out, "--set",
                 "micro_geometry.both.tip_relief_um=8", *QUICK]) == EXIT_INPUT
    assert "give exactly one --set SECTION.KEY=V1,V2" in capsys.readouterr().err
    sdof = str(ROOT / "scenes" / "gear-pair-sdof.toml")
    assert main(["microgeometry", sdof, "--out", out, "--set",
                 "load.torque_Nm=100,150", *QUICK]) == EXIT_INPUT
    assert "do not come from the LTCA" in capsys.readouterr().err
    assert main(["microgeometry", LTCA, "--out", out, "--set",
                 "micro_geometry.both.tip_relief_um=0,3000", *QUICK]) == EXIT_INPUT
    assert "micro_geometry.gear1.tip_relief_um" in capsys.readouterr().err


def test_a_train_mesh_named_in_the_key(tmp_path, capsys):
    """On a train the key names the mesh (``meshes.stage2.…``): the table gives that mesh's
    LTCA (STE peak-to-peak 8.30 µm without relief, 3.10 µm with 20 µm) and its own
    mesh-load std (element 1 of results.h5); a key of no mesh, or of a mesh without the
    LTCA, is refused."""
    import h5py
    import numpy as np

    scene = tmp_path / "reducer.toml"
    scene.write_text(two_stage_with_stage2(LTCA_RELIEVED))
    scene = str(scene)
    quick = ["--set", "continuation.speed_rpm=[8000.0,9000.0]", "--set",
             "hbm.mesh_harmonics=4", "--set", "outputs.plots=[\"forced_response\"]",
             "--no-progress", "-q"]
    out = tmp_path / "study"
    assert main(["microgeometry", scene, "--out", str(out), "--set",
                 "meshes.stage2.micro_geometry.both.tip_relief_um=0,20", *quick]) == EXIT_OK
    rows = {r.split("|")[1].strip(): [c.strip() for c in r.split("|")[2:-1]]
            for r in (out / "microgeometry.md").read_text().splitlines()
            if r.startswith(("| 0 |", "| 20 |"))}
    assert float(rows["0"][0]) == pytest.approx(8.303, abs=0.01)
    assert float(rows["20"][0]) == pytest.approx(3.104, abs=0.01)
    with h5py.File(out / "tip_relief_um=20" / "results.h5", "r") as f:
        std = f["continuation/mesh_load_std"][()][:, 1]
    assert float(rows["20"][2]) == pytest.approx(float(np.max(std)), rel=1e-3)
    assert (out / "tip_relief_um=20" / "mesh_harris_stage2.png").exists()
    assert main(["microgeometry", scene, "--out", str(tmp_path / "y"), "--set",
                 "hbm.mesh_harmonics=3,4", "-q"]) == EXIT_INPUT
    assert "varies a key of one mesh: meshes.<name>" in capsys.readouterr().err
    assert main(["microgeometry", scene, "--out", str(tmp_path / "z"), "--set",
                 "meshes.stage1.backlash_um=30,40", "-q"]) == EXIT_INPUT
    assert "mesh 'stage1''s mesh_stiffness and transmission_error do not come from the " \
        "LTCA" in capsys.readouterr().err
