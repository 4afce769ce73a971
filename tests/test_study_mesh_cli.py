"""``geardyn mesh SCENE --out DIR`` writes DIR/mesh.msh with named groups and reports quality."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

pytestmark = pytest.mark.fem


def test_mesh_command_writes_msh(tmp_path: Path) -> None:
    out = tmp_path / "mesh"
    proc = subprocess.run(
        [sys.executable, "-m", "study", "mesh", str(ROOT / "scenes" / "pump.toml"),
         "--out", str(out), "--no-progress", "--cache", str(tmp_path / "cache")],
        capture_output=True, text=True, cwd=ROOT, timeout=600,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "min SICN" in proc.stderr + proc.stdout
    code = (
        "import gmsh, sys\n"
        "gmsh.initialize(); gmsh.option.setNumber('General.Terminal', 0)\n"
        f"gmsh.merge({str(out / 'mesh.msh')!r})\n"
        "types, tags, _ = gmsh.model.mesh.getElements(3)\n"
        "names = {gmsh.model.getPhysicalName(d, t) for d, t in gmsh.model.getPhysicalGroups()}\n"
        "print(*types)\n"
        "print(sum(len(t) for t in tags))\n"
        "print(len(names))\n"
        "print({'shaft_in', 'shaft_out', 'housing', 'housing/feet'} <= names)\n"
    )
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    types, n_tets, n_groups, has_parts = res.stdout.strip().splitlines()
    assert types == "11"  # 10-node tetrahedra only
    assert int(n_tets) > 1000
    assert int(n_groups) == 28
    assert has_parts == "True"
