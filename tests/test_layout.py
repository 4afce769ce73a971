"""The package layout and the one-way dependency direction (docs/architecture.md)."""
from __future__ import annotations

import ast
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ["geometry", "fem", "reduction", "hbm", "study"]
# What each package may import from the project and from the heavy stacks.
ALLOWED_PROJECT = {
    "geometry": set(),
    "fem": {"geometry"},
    "reduction": {"fem", "geometry"},
    "hbm": set(),
    "study": {"geometry", "fem", "reduction", "hbm"},
}
FORBIDDEN_THIRD_PARTY = {
    "hbm": {"dolfinx", "gmsh", "petsc4py", "slepc4py", "ufl", "mpi4py", "basix", "h5py"},
    "geometry": {"dolfinx", "petsc4py", "slepc4py", "ufl"},
}


def _imports(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(), filename=str(path))
    names: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module.split(".")[0])
    return names


@pytest.mark.parametrize("package", PACKAGES)
def test_dependencies_point_one_way(package: str) -> None:
    files = sorted((ROOT / package).rglob("*.py"))
    assert files, f"{package}/ has no modules"
    for path in files:
        imported = _imports(path)
        project = imported & set(PACKAGES) - {package}
        assert project <= ALLOWED_PROJECT[package], (
            f"{path.relative_to(ROOT)} imports {sorted(project - ALLOWED_PROJECT[package])}"
        )
        bad = imported & FORBIDDEN_THIRD_PARTY.get(package, set())
        assert not bad, f"{path.relative_to(ROOT)} imports {sorted(bad)}"


def test_pyproject_declares_packages_and_entry_point() -> None:
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text())
    include = meta["tool"]["setuptools"]["packages"]["find"]["include"]
    for package in PACKAGES:
        assert f"{package}*" in include
        assert (ROOT / package / "__init__.py").is_file()
    assert meta["project"]["scripts"]["geardyn"] == "study.cli:main"
    for folder in ["scenes", "benchmarks", "docs", "tests"]:
        assert (ROOT / folder).is_dir()
    assert (ROOT / "docs" / "theory.md").is_file()


def test_hbm_imports_without_the_fe_stack() -> None:
    code = (
        "import sys, hbm\n"
        "import pkgutil, importlib\n"
        "for m in pkgutil.walk_packages(hbm.__path__, 'hbm.'):\n"
        "    importlib.import_module(m.name)\n"
        "heavy = {'dolfinx', 'gmsh', 'petsc4py', 'slepc4py'} & set(sys.modules)\n"
        "assert not heavy, heavy\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True, cwd=ROOT)
