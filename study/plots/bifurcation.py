"""The bifurcation diagram (:mod:`study.outputs.bifurcation`): Poincaré samples of the
mesh deflection and the mesh load against shaft speed — the periodic branch (stable
solid, unstable marked), secondary (period-k) branches, and the time-integrated
attractors of the unstable segments as dots. Units: rpm, µm, N."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from study.outputs.bifurcation import SOURCES, Diagram
from study.plots.common import plt, save_figure

__all__ = ["bifurcation_plot"]

#: Colours of the secondary branches (cycled) and of the attractor samples.
SECONDARY_COLOURS = ("tab:blue", "tab:green", "tab:purple", "tab:brown")
ATTRACTOR_COLOUR = "tab:red"


def _runs(mask: np.ndarray) -> list[slice]:
    """Slices of consecutive True entries of ``mask``."""
    out, start = [], None
    for i, m in enumerate(np.append(mask, False)):
        if m and start is None:
            start = i
        elif not m and start is not None:
            out.append(slice(start, i))
            start = None
    return out


def _branch(ax, rpm, y, stable, k: int, colour: str, label: str) -> None:
    """One branch's samples: each of its ``k`` sample rows a curve along the branch,
    solid where stable; unstable points as small crosses."""
    first = True
    for row in range(k):
        r, v, s = rpm[row::k], y[row::k], stable[row::k]
        for sl in _runs(s):
            ax.plot(r[sl], v[sl], color=colour, lw=1.1,
                    label=f"{label}, stable" if first else None)
            first = False
        ax.plot(r[~s], v[~s], "x", color=colour, ms=3, mew=0.8,
                label=f"{label}, unstable" if row == 0 and (~s).any() else None)


def _panel(ax, d: Diagram, y: np.ndarray, legend: bool) -> None:
    """The branches and attractors of ``d`` with ordinate ``y`` (one value per row)."""
    groups = [(d.of(SOURCES[0]), "k", "periodic branch")]
    sec = d.of(SOURCES[1])
    for n, j in enumerate(np.unique(d.branch[sec])):
        m = sec & (d.branch == j)
        groups.append((m, SECONDARY_COLOURS[n % len(SECONDARY_COLOURS)],
                       f"period-{int(d.periods[m][0])} branch"))
    for m, colour, label in groups:
        if m.any():
            _branch(ax, d.rpm[m], y[m], d.stable[m].astype(bool), int(d.periods[m][0]),
                    colour, label)
    ti = d.of(SOURCES[2])
    if ti.any():
        ax.plot(d.rpm[ti], y[ti], ".", color=ATTRACTOR_COLOUR, ms=2.5, alpha=0.6,
                label="time integration (attractor)")
    ax.grid(alpha=0.3)
    if legend:
        ax.legend(loc="best", fontsize=7)


def bifurcation_plot(d: Diagram, path: Path, title: str = "",
                     xlim: tuple[float, float] | None = None) -> Path:
    """Poincaré samples against speed (rpm), once per fundamental period: the mesh
    deflection Delta (µm, top: smooth, it separates the branches where the load is zero
    for lost contact) and the mesh load (N, bottom); branches as curves (solid stable,
    crosses unstable), time integrations as dots (the attractor the machine reaches)."""
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(8, 6.4), sharex=True)
    _panel(top, d, d.delta * 1e6, legend=True)
    _panel(bottom, d, d.load, legend=False)
    top.set_ylabel("Δ at t = 0 mod T (µm)")
    bottom.set_ylabel("mesh load at t = 0 mod T (N)")
    bottom.set_xlabel("shaft speed Ω (rpm)")
    if xlim is not None:
        bottom.set_xlim(*xlim)
    top.set_title(title or "bifurcation diagram (Poincaré samples, once per fundamental "
                  "period)")
    return save_figure(fig, path)
