"""Draw the package layers of geardyn and the imports between them (docs/layers.png).

The arrows are read from the code (every ``import`` and ``from ... import`` of the
project's packages, function-local ones included), not drawn by hand: an arrow that
points upward would show a broken layer. Three panels: the top-level packages, the
subpackages of ``study`` and those of ``hbm``.

Run: ``.venv/bin/python scripts/draw_layers.py [OUT.png]``
"""
from __future__ import annotations

import ast
import sys
import textwrap
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.patches import FancyArrowPatch, FancyBboxPatch  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]

#: The layers, bottom first; names on one row may not import each other.
TOP = [["core"], ["gears", "geometry", "hbm"], ["fem"], ["reduction"], ["machines"],
       ["study"]]
STUDY = [["scene"], ["outputs"], ["plots"], ["pipeline"], ["studies"], ["cli"]]
#: hbm has no designed order beyond "imports nothing of the project": its panel is laid
#: out by the longest import path below each unit (an arrow up would be a cycle).
HBM_UNITS = ["units", "records", "newton", "basis", "system", "elements", "modes", "torus",
             "condensation", "krylov", "problem", "stability", "post", "continuation",
             "sweep", "examples"]
NOTES = {
    "core": "atomic writes, units, errors",
    "gears": "pair geometry, eq. 11, ISO 6336, LTCA, trains",
    "geometry": "gmsh: parametric, CAD import, meshing",
    "hbm": "harmonic balance engine (NumPy/SciPy only)",
    "fem": "DOLFINx assembly, links; fem.post",
    "reduction": "Craig-Bampton, 6 DOF per gear body",
    "machines": "contract + registry: pump, lumped pair",
    "study": "scene, pipeline, outputs, studies, CLI",
}


def module_imports(path: Path) -> set[str]:
    """Dotted names imported by one file (absolute; relative ones resolved)."""
    pkg = path.relative_to(ROOT).with_suffix("").parts
    here = pkg[:-1] if pkg[-1] != "__init__" else pkg[:-1]
    names = set()
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            names.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = list(here)[: len(here) - node.level + 1]
                stem = ".".join(base + ([node.module] if node.module else []))
            else:
                stem = node.module or ""
            names.add(stem)
            names.update(f"{stem}.{a.name}" for a in node.names)
    return names


def edges(unit_of) -> set[tuple[str, str]]:
    """(importer, imported) pairs between the units that ``unit_of(dotted)`` names."""
    out = set()
    for path in ROOT.rglob("*.py"):
        rel = path.relative_to(ROOT)
        if rel.parts[0] in ("tests", "benchmarks", "scripts", ".venv") or rel.name == "__init__.py":
            continue
        src = unit_of(".".join(rel.with_suffix("").parts))
        if src is None:
            continue
        for name in module_imports(path):
            dst = unit_of(name)
            if dst is not None and dst != src:
                out.add((src, dst))
    return out


def top_unit(dotted: str) -> str | None:
    head = dotted.split(".")[0]
    return head if any(head in row for row in TOP) else None


def sub_unit(package: str, layers):
    names = {n for row in layers for n in row}

    def unit(dotted: str) -> str | None:
        parts = dotted.split(".")
        if parts[0] != package or len(parts) < 2:
            return None
        return parts[1] if parts[1] in names else None
    return unit


def levels(units: list[str], arrows: set[tuple[str, str]]) -> list[list[str]]:
    """Rows by the longest import path below each unit (bottom first)."""
    depth: dict[str, int] = {}

    def d(u: str, seen: tuple[str, ...] = ()) -> int:
        if u not in depth:
            below = [b for a, b in arrows if a == u and b not in seen]
            depth[u] = 1 + max((d(b, (*seen, u)) for b in below), default=-1)
        return depth[u]
    rows: dict[int, list[str]] = {}
    for u in units:
        rows.setdefault(d(u), []).append(u)
    return [rows[k] for k in sorted(rows)]


def panel(ax, layers, arrows, title, notes=None) -> None:
    pos = {}
    for y, row in enumerate(layers):
        for i, name in enumerate(row):
            pos[name] = ((i + 0.5) / len(row), y)
    w, h = (0.3 if notes else 0.2), 0.5
    for name, (x, y) in pos.items():
        ax.add_patch(FancyBboxPatch((x - w / 2, y - h / 2), w, h,
                                    boxstyle="round,pad=0.02", fc="#e8eef7", ec="#2f4b7c"))
        ax.text(x, y + (0.08 if notes else 0), name, ha="center", va="center",
                fontsize=10, weight="bold")
        if notes and name in notes:
            ax.text(x, y - 0.12, textwrap.fill(notes[name], 30), ha="center", va="center",
                    fontsize=6.5)
    up = 0
    for a, b in sorted(arrows):
        (xa, ya), (xb, yb) = pos[a], pos[b]
        bad = yb >= ya and a != b
        up += bad
        ax.add_patch(FancyArrowPatch((xa, ya - h / 2), (xb, yb + h / 2),
                                     arrowstyle="-|>", mutation_scale=9, lw=0.7,
                                     color="#c0392b" if bad else "#7f8c8d",
                                     connectionstyle="arc3,rad=0.08", alpha=0.8))
    ax.set_xlim(-0.05, 1.05)
    ax.set_ylim(-0.6, len(layers) - 0.4)
    ax.set_title(f"{title}\n{len(arrows)} import arrows, {up} pointing up", fontsize=10)
    ax.axis("off")


def main(out: str = str(ROOT / "docs" / "layers.png")) -> None:
    fig, axes = plt.subplots(1, 3, figsize=(15, 7.5), gridspec_kw={"width_ratios": [1.4, 1, 1.2]})
    panel(axes[0], TOP, edges(top_unit), "packages (data flows upward)", NOTES)
    panel(axes[1], STUDY, edges(sub_unit("study", STUDY)), "study's subpackages")
    hbm_arrows = edges(sub_unit("hbm", [HBM_UNITS]))
    panel(axes[2], levels(HBM_UNITS, hbm_arrows), hbm_arrows, "hbm's modules and subpackages")
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print(out)


if __name__ == "__main__":
    main(*sys.argv[1:])
