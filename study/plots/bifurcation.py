"""The bifurcation diagram (:mod:`study.outputs.bifurcation`): Poincaré samples of the
mesh load against shaft speed — the periodic branch (stable solid, unstable marked),
secondary (period-k) branches, and the time-integrated attractors of the unstable
segments as dots. Units: rpm, N."""
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


def _branch(ax, d: Diagram, sel: np.ndarray, colour: str, label: str) -> None:
    """One branch's samples: each of its ``k`` sample rows a curve along the branch,
    solid where stable; unstable points as small crosses."""
    rpm, load, stable = d.rpm[sel], d.load[sel], d.stable[sel].astype(bool)
    k = int(d.periods[sel][0]) if sel.any() else 1
    first = True
    for row in range(k):
        r, y, s = rpm[row::k], load[row::k], stable[row::k]
        for sl in _runs(s):
            ax.plot(r[sl], y[sl], color=colour, lw=1.1,
                    label=f"{label}, stable" if first else None)
            first = False
        ax.plot(r[~s], y[~s], "x", color=colour, ms=3, mew=0.8,
                label=f"{label}, unstable" if row == 0 and (~s).any() else None)


def bifurcation_plot(d: Diagram, path: Path, title: str = "",
                     xlim: tuple[float, float] | None = None) -> Path:
    """Poincaré samples of the mesh load (N, once per fundamental period) against speed
    (rpm): branches as curves (solid stable, crosses unstable), time integrations as
    dots (the attractor the machine reaches)."""
    fig, ax = plt.subplots(figsize=(8, 4.6))
    main = d.of(SOURCES[0])
    if main.any():
        _branch(ax, d, main, "k", "periodic branch")
    sec = d.of(SOURCES[1])
    for n, j in enumerate(np.unique(d.branch[sec])):
        k = int(d.periods[sec & (d.branch == j)][0])
        _branch(ax, d, sec & (d.branch == j), SECONDARY_COLOURS[n % len(SECONDARY_COLOURS)],
                f"period-{k} branch")
    ti = d.of(SOURCES[2])
    if ti.any():
        ax.plot(d.rpm[ti], d.load[ti], ".", color=ATTRACTOR_COLOUR, ms=2.5, alpha=0.6,
                label="time integration (attractor)")
    ax.set_xlabel("shaft speed Ω (rpm)")
    ax.set_ylabel("mesh load at t = 0 mod T (N)")
    if xlim is not None:
        ax.set_xlim(*xlim)
    ax.grid(alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    ax.set_title(title or "bifurcation diagram (Poincaré samples, once per fundamental "
                 "period)")
    return save_figure(fig, path)
