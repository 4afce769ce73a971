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


@pytest.mark.parametrize("size, words", [
    ("10.0", ["mesh.size = 10 m", "part 'housing'", "thinnest plate 0.006 m", "(0, 0.048] m"]),
    ("1e-6", ["mesh.size = 1e-06 m", "tetrahedra estimated", "3e+06 allowed",
              "mesh.size >= "]),
])
def test_bad_mesh_size_is_refused_before_meshing(tmp_path: Path, size, words) -> None:
    """Too coarse for the thinnest wall, or too many elements: exit 2 naming the field,
    within seconds (no gmsh meshing, no traceback)."""
    proc = subprocess.run(
        [sys.executable, "-m", "study", "mesh", str(ROOT / "scenes" / "pump.toml"),
         "--out", str(tmp_path / "m"), "--no-progress", "--cache", str(tmp_path / "c"),
         "--set", f"mesh.size={size}"],
        capture_output=True, text=True, cwd=ROOT, timeout=120,
    )
    assert proc.returncode == 2, proc.stderr[-2000:]
    assert "Traceback" not in proc.stderr and "meshed" not in proc.stderr
    for w in words:
        assert w in proc.stderr, (w, proc.stderr[-1500:])


def test_element_estimate_is_volume_over_regular_tet() -> None:
    """check_sizes: V/h^3 times 6 sqrt(2) (regular tetrahedra of edge h fill V), and the
    bounds name the field."""
    from geometry.meshing import check_sizes

    n = check_sizes({"cube": (1.0, 0.1, 1.0, "mesh.size", "test")})
    assert n == round(6 * 2 ** 0.5 * 1000)
    with pytest.raises(ValueError, match=r"mesh.size = 2 m .*part 'cube'.*\(0, 1\] m"):
        check_sizes({"cube": (1.0, 2.0, 1.0, "mesh.size", "its thinnest wall")})
    with pytest.raises(ValueError, match=r"mesh.size = 0.001 m: about 8.49e\+09 tetrahedra"):
        check_sizes({"cube": (1.0, 1e-3, 1.0, "mesh.size", "x")})
