"""The package layout and the one-way dependency direction (docs/architecture.md)."""
from __future__ import annotations

import ast
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ["core", "gears", "geometry", "fem", "reduction", "machines", "hbm", "study"]
# What each package may import from the project and from the heavy stacks. ``core`` is
# the bottom layer: it imports nothing of the project, and every package but ``hbm``
# (which imports nothing of the project) may import it. ``gears`` (pure NumPy gear
# physics) imports ``core`` only; ``fem`` takes the pair frame and G of eq. (11) from it.
# ``machines`` (the machine contract and the machines) sits on the FE stack and under
# ``study``, which reaches the FE layers through it: ``study`` imports ``fem`` only for
# fem.post's file formats (:data:`STUDY_FEM_MODULES`), never geometry or reduction.
ALLOWED_PROJECT = {
    "core": set(),
    "gears": {"core"},
    "geometry": {"core"},
    "fem": {"core", "gears", "geometry"},
    "reduction": {"core", "fem", "geometry"},
    "machines": {"core", "gears", "geometry", "fem", "reduction"},
    "hbm": set(),
    "study": {"core", "gears", "machines", "hbm", "fem"},
}
#: The fem modules study may import: the XDMF writer and the block size of the housing
#: field files (study.outputs.fields writes the fields from the arrays the rom stage cached).
STUDY_FEM_MODULES = {"fem.post.xdmf", "fem.post.fields"}
FORBIDDEN_THIRD_PARTY = {
    "hbm": {"dolfinx", "gmsh", "petsc4py", "slepc4py", "ufl", "mpi4py", "basix", "h5py"},
    "geometry": {"dolfinx", "petsc4py", "slepc4py", "ufl"},
    # the FE post-processing is fem.post's; study works on the arrays it cached
    "study": {"dolfinx", "ufl", "basix", "petsc4py"},
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


def _imported_modules(path: Path) -> set[str]:
    """Full names of the absolute imports of ``path`` (``from a.b import c`` -> a.b)."""
    names: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module)
    return names


def test_study_reaches_fem_only_for_its_file_formats() -> None:
    """study builds no FE model and reduces nothing: the machines do (machines/); of fem it
    imports only fem.post's file formats, wherever the import stands."""
    for path in sorted((ROOT / "study").rglob("*.py")):
        fem = {m for m in _imported_modules(path) if m.split(".")[0] == "fem"}
        assert fem <= STUDY_FEM_MODULES, f"{path.relative_to(ROOT)} imports {sorted(fem)}"


def test_machines_load_no_fe_stack_at_import() -> None:
    """machines imports the FE stack inside functions only: a lumped scene loads none."""
    code = ("import sys, machines, pkgutil, importlib\n"
            "for m in pkgutil.walk_packages(machines.__path__, 'machines.'):\n"
            "    importlib.import_module(m.name)\n"
            "heavy = {'dolfinx', 'gmsh', 'petsc4py', 'slepc4py', 'mpi4py', 'ufl'} "
            "& set(sys.modules)\n"
            "assert not heavy, heavy\n")
    subprocess.run([sys.executable, "-c", code], check=True, cwd=ROOT)


def test_forbidden_imports_are_found_inside_functions(tmp_path: Path) -> None:
    """study may not import the FE stack lazily either (its FE work is fem.post's)."""
    mod = tmp_path / "m.py"
    mod.write_text("import numpy\n\ndef f():\n    from dolfinx import fem\n"
                   "    import petsc4py.PETSc\n    from . import sibling\n")
    assert _imports(mod) == {"numpy", "dolfinx", "petsc4py"}
    assert _imports(mod) & FORBIDDEN_THIRD_PARTY["study"] == {"dolfinx", "petsc4py"}


def _module_name(root: Path, package: str, path: Path) -> str:
    rel = path.relative_to(root / package).with_suffix("")
    parts = [package, *rel.parts]
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def module_graph(root: Path, package: str) -> dict[str, dict[str, int]]:
    """Imports between the modules of ``package``: module -> {imported module: line}.

    Every import counts, function-local ones included (``ast.walk``). The package's
    ``__init__`` is left out: it is the facade that re-exports the modules, and
    ``from package import __version__`` is no layering edge.
    """
    files = {_module_name(root, package, p): p for p in sorted((root / package).rglob("*.py"))}
    modules = {m for m, p in files.items() if p.name != "__init__.py"}
    graph: dict[str, dict[str, int]] = {}
    for name in sorted(modules):
        path = files[name]
        here = name.rsplit(".", 1)[0]       # the (sub)package holding the module
        edges: dict[str, int] = {}
        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    base = here.split(".")
                    base = base[: len(base) - node.level + 1]
                    stem = ".".join(base + ([node.module] if node.module else []))
                else:
                    stem = node.module or ""
                targets = [stem] + [f"{stem}.{a.name}" for a in node.names]
            else:
                continue
            for target in targets:
                parts = target.split(".")  # the longest prefix that is a module
                for n in range(len(parts), 1, -1):
                    mod = ".".join(parts[:n])
                    if mod in modules:
                        if mod != name:
                            edges.setdefault(mod, node.lineno)
                        break
        graph[name] = edges
    return graph


def find_cycle(graph: dict[str, dict[str, int]]) -> list[str] | None:
    """One import cycle ``[a, b, ..., a]`` of ``graph`` (depth-first search), or None."""
    state: dict[str, int] = {}      # 1 on the current path, 2 done
    path: list[str] = []

    def visit(m: str) -> list[str] | None:
        state[m] = 1
        path.append(m)
        for n in sorted(graph.get(m, {})):
            if state.get(n) == 1:
                return path[path.index(n):] + [n]
            if n not in state:
                found = visit(n)
                if found:
                    return found
        path.pop()
        state[m] = 2
        return None

    for m in sorted(graph):
        if m not in state:
            found = visit(m)
            if found:
                return found
    return None


@pytest.mark.parametrize("package", PACKAGES)
def test_no_import_cycle_between_modules_of_a_package(package: str) -> None:
    graph = module_graph(ROOT, package)
    cycle = find_cycle(graph)
    if cycle:
        steps = [f"{a} (line {graph[a][b]}) -> {b}"
                 for a, b in zip(cycle[:-1], cycle[1:], strict=True)]
        pytest.fail(f"import cycle in {package}/: " + "; ".join(steps))


def test_cycle_finder_sees_function_local_and_relative_imports(tmp_path: Path) -> None:
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("from pkg.a import f\n")
    (pkg / "a.py").write_text("from .b import g\n\ndef f():\n    return g()\n")
    (pkg / "b.py").write_text("def g():\n    from pkg import c\n    return c.h()\n")
    (pkg / "c.py").write_text("import os\n\ndef h():\n    import pkg.a\n    return pkg.a\n")
    graph = module_graph(tmp_path, "pkg")
    assert graph == {"pkg.a": {"pkg.b": 1}, "pkg.b": {"pkg.c": 2}, "pkg.c": {"pkg.a": 4}}
    assert find_cycle(graph) == ["pkg.a", "pkg.b", "pkg.c", "pkg.a"]
    (pkg / "c.py").write_text("def h():\n    from pkg import __version__\n")
    assert find_cycle(module_graph(tmp_path, "pkg")) is None



# ------------------------------------------------------------------ study's subpackages

#: The subpackages of ``study``, bottom first (docs/architecture.md): a module imports
#: modules of its own subpackage or of those before it, never of one after it. ``cli``
#: is study's top: ``cli.py`` and ``__main__.py`` (and the ``__init__`` facade).
STUDY_LAYERS = ("scene", "outputs", "plots", "pipeline", "studies", "cli")
#: Modules at study's top, by the layer they belong to (an entry whose file is gone
#: fails). The FE stages, the FE parameter sections and the lumped model went to
#: ``machines/``, the scene -> hbm problem glue to ``study.pipeline.model``.
STUDY_TOP = {"study.cli": "cli", "study.__main__": "cli"}


def study_layer(module: str) -> str:
    """The layer of a module of ``study``: its subpackage, or its entry of ``STUDY_TOP``."""
    parts = module.split(".")
    if len(parts) > 2 and parts[1] in STUDY_LAYERS:
        return parts[1]
    if module not in STUDY_TOP:
        raise KeyError(f"{module} is in none of study's subpackages {STUDY_LAYERS[:-1]}")
    return STUDY_TOP[module]


def test_study_is_cut_into_its_subpackages() -> None:
    graph = module_graph(ROOT, "study")
    for module in graph:
        study_layer(module)
    assert set(STUDY_TOP) <= set(graph), f"stale STUDY_TOP entries: {set(STUDY_TOP) - set(graph)}"
    folders = {p.parent.name for p in (ROOT / "study").glob("*/__init__.py")}
    assert folders == set(STUDY_LAYERS) - {"cli"}


def upward_imports(graph: dict[str, dict[str, int]], layer) -> list[str]:
    """``a (line n) -> b`` for each import of ``graph`` from a lower layer to a higher one
    (``layer`` gives a module's layer, an index into ``STUDY_LAYERS``)."""
    return [f"{a} (line {line}) -> {b}" for a, edges in sorted(graph.items())
            for b, line in sorted(edges.items()) if layer(b) > layer(a)]


def test_study_subpackages_import_downwards() -> None:
    """scene -> outputs -> plots -> pipeline -> studies -> cli: no module imports one of a
    later subpackage (function-local imports included)."""
    rank = {name: i for i, name in enumerate(STUDY_LAYERS)}
    up = upward_imports(module_graph(ROOT, "study"), lambda m: rank[study_layer(m)])
    assert not up, "imports against the order of study's subpackages: " + "; ".join(up)



def test_upward_import_finder() -> None:
    """report.md's module importing a plot module (as it did) is against the order."""
    rank = {name: i for i, name in enumerate(STUDY_LAYERS)}
    graph = {"study.outputs.report": {"study.plots.common": 14, "study.scene.data": 9},
             "study.plots.common": {"study.outputs.curves": 20}, "study.outputs.curves": {},
             "study.scene.data": {}, "study.cli": {"study.pipeline.stages": 3},
             "study.pipeline.stages": {"study.pipeline.model": 238},
             "study.pipeline.model": {}}
    assert upward_imports(graph, lambda m: rank[study_layer(m)]) == [
        "study.outputs.report (line 14) -> study.plots.common"]

def facade_imports(root: Path, package: str) -> dict[str, list[str]]:
    """Names that a module of ``package`` imports from a (sub)package's ``__init__``
    rather than from the module that holds them: ``from pkg.sub import name`` where
    ``pkg/sub/`` is a package and ``name`` is none of its modules or subpackages (and no
    dunder such as ``__version__``); relative imports resolved, function-local included."""
    def is_package(dotted: str) -> bool:
        return (root.joinpath(*dotted.split(".")) / "__init__.py").is_file()

    def is_module(dotted: str) -> bool:
        path = root.joinpath(*dotted.split("."))
        return path.with_suffix(".py").is_file() or (path / "__init__.py").is_file()

    out: dict[str, list[str]] = {}
    for path in sorted((root / package).rglob("*.py")):
        here = _module_name(root, package, path)
        if path.name != "__init__.py":
            here = here.rsplit(".", 1)[0]
        found = []
        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            if not isinstance(node, ast.ImportFrom):
                continue
            if node.level:
                base = here.split(".")[: len(here.split(".")) - node.level + 1]
                src = ".".join(base + ([node.module] if node.module else []))
            else:
                src = node.module or ""
            if src.split(".")[0] != package or not is_package(src):
                continue
            found += [f"{src}:{a.name}" for a in node.names
                      if not (a.name.startswith("__") and a.name.endswith("__"))
                      and not is_module(f"{src}.{a.name}")]
        if found:
            out[path.relative_to(root).as_posix()] = found
    return out


def test_study_imports_a_name_from_the_module_that_holds_it() -> None:
    """The ``__init__`` of study, study.scene and study.pipeline re-export an API for users
    (tests, benchmarks, scripts); inside study a name comes from its own module, so that
    an import shows the module it depends on (and the order above sees it)."""
    found = facade_imports(ROOT, "study")
    assert not found, f"names imported through a package's __init__: {found}"


def test_facade_import_finder(tmp_path: Path) -> None:
    pkg = tmp_path / "pkg"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("__version__ = '1'\n")
    (pkg / "sub" / "__init__.py").write_text("from pkg.sub.a import f\n")
    (pkg / "sub" / "a.py").write_text("def f():\n    return 1\n")
    (pkg / "b.py").write_text("from pkg.sub import f\nfrom pkg.sub import a\n"
                              "from pkg import __version__, sub\n")
    (pkg / "sub" / "c.py").write_text("def g():\n    from . import f\n    from .a import f\n")
    assert facade_imports(tmp_path, "pkg") == {"pkg/b.py": ["pkg.sub:f"],
                                               "pkg/sub/c.py": ["pkg.sub:f"]}

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


def test_the_continuation_imports_no_problem() -> None:
    """hbm/continuation follows any residual with its tangent (its protocols): it imports
    no problem, element, stability or post-processing module, only linear algebra."""
    graph = module_graph(ROOT, "hbm")
    allowed = {"hbm.newton", "hbm.krylov", "hbm.units", "hbm.records"}
    for mod, edges in graph.items():
        if mod.startswith("hbm.continuation."):
            outside = {m for m in edges if not m.startswith("hbm.continuation.")}
            assert outside <= allowed, f"{mod} imports {sorted(outside - allowed)}"


@pytest.mark.parametrize(("package", "allowed"), [("core", set()),
                                                  ("gears", {"numpy", "core"})])
def test_bottom_packages_use_the_standard_library_and_numpy_only(package: str,
                                                                 allowed: set[str]) -> None:
    for path in sorted((ROOT / package).rglob("*.py")):
        outside = {m for m in _imports(path) - {"__future__"} - allowed
                   if m not in sys.stdlib_module_names}
        assert not outside, f"{path.relative_to(ROOT)} imports {sorted(outside)}"


def test_product_tests_import_no_benchmarks() -> None:
    """The paper calibration and benchmark tools are not the product: their tests live
    in benchmarks/tests/ (``make test`` runs both folders)."""
    for path in sorted((ROOT / "tests").rglob("*.py")):
        assert "benchmarks" not in _imports(path), (
            f"{path.relative_to(ROOT)} imports benchmarks: move the test to benchmarks/tests/")
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert meta["tool"]["pytest"]["ini_options"]["testpaths"] == ["tests", "benchmarks/tests"]
    assert "pytest -q $(XDIST) tests benchmarks/tests" in (ROOT / "Makefile").read_text()


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


# ------------------------------------------------------------------ private names

#: Packages whose modules import no private (``_name``) name of another module: a module
#: cut in pieces along a line count, whose pieces reach into each other, shows as such
#: imports; a cut along concepts needs none.
#: (reduction/rom.py still imports two helpers of reduction/coupled.py.)
PRIVATE_PACKAGES = ["core", "gears", "geometry", "fem", "machines", "hbm", "study"]


def private_imports(root: Path, package: str) -> dict[str, list[str]]:
    """Private names each module of ``package`` imports from another module, by module
    path: ``from x import _y`` (any source, relative or absolute, function-local
    included) and ``import x._y``; dunder names (``__version__``) are public."""
    def private(name: str) -> bool:
        return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))

    out: dict[str, list[str]] = {}
    for path in sorted((root / package).rglob("*.py")):
        found = []
        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            if isinstance(node, ast.ImportFrom):
                src = "." * node.level + (node.module or "")
                found += [f"{src}:{a.name}" for a in node.names if private(a.name)]
                if any(private(part) for part in (node.module or "").split(".")):
                    found.append(src)
            elif isinstance(node, ast.Import):
                found += [a.name for a in node.names
                          if any(private(part) for part in a.name.split("."))]
        if found:
            out[path.relative_to(root).as_posix()] = found
    return out


@pytest.mark.parametrize("package", PRIVATE_PACKAGES)
def test_no_module_imports_private_names(package: str) -> None:
    found = private_imports(ROOT, package)
    assert not found, f"private names imported across modules: {found}"


def test_private_import_finder(tmp_path: Path) -> None:
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "a.py").write_text("from .b import _g, h\nfrom pkg import __version__\n")
    (pkg / "b.py").write_text("def f():\n    from pkg.c import _x\n    import pkg._d\n")
    (pkg / "c.py").write_text("from ._impl import y\nimport os._private_mod\n_x = 1\n")
    assert private_imports(tmp_path, "pkg") == {
        "pkg/a.py": [".b:_g"], "pkg/b.py": ["pkg.c:_x", "pkg._d"],
        "pkg/c.py": ["._impl", "os._private_mod"]}
