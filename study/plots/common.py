"""What the plots of :mod:`study` share: the Agg backend, atomic PNG writing, the
impact-class colours and shading, and the grazing points on a forced-response curve.

The impact intervals of a branch (:func:`study.outputs.curves.contact_intervals`) and
the names of shaft orders (:func:`study.outputs.nvh.order_label`) are the outputs'
(``report.md`` uses them too).
"""
from __future__ import annotations

import logging
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from core.files import atomic_write  # noqa: E402
from study.outputs.curves import contact_intervals  # noqa: E402

logger = logging.getLogger("study.plots")  # one logger for every plot module

__all__ = ["CLASS_COLOURS", "DPI", "F_STOP", "save_figure", "shade_impacts", "grazing_values",
           "ROM_SHADE", "rom_label", "shade_beyond_rom"]

CLASS_COLOURS = {1: ("tab:orange", "single-sided impacts"), 2: ("tab:red", "double-sided impacts")}

#: Upper frequency of the order maps, spectra and Campbell diagram (Hz): the upper limit
#: of hearing, which the levels and the ERP are for (docs/results-format.md, "Plots");
#: they stop lower where the harmonic set (or the mesh orders drawn) stops lower.
F_STOP = 20_000.0
#: Resolution of the PNG files (dots per inch).
DPI = 130
#: How a frequency range outside the ROM's validity is shaded.
ROM_SHADE = {"facecolor": "0.6", "alpha": 0.3, "hatch": "///", "edgecolor": "0.35", "lw": 0}


def rom_label(valid_hz: float) -> str:
    """Legend text of the shading above the ROM's validity."""
    return "ROM not checked" if valid_hz <= 0 else f"ROM not validated above {valid_hz:.0f} Hz"


def shade_beyond_rom(ax, valid_hz: float | None, top_hz: float, vertical: bool = False,
                     hz_per_unit: float = 1.0, zorder: float = 0.5) -> None:
    """Shade the band from ``valid_hz`` to ``top_hz`` of a frequency axis (y, or x with
    ``vertical``; the axis is in units of ``hz_per_unit`` Hz, e.g. shaft orders):
    where the ROM was not checked against the full FE model
    (:func:`study.outputs.checks.rom_limit_hz`); nothing when ``valid_hz`` is None or
    above ``top_hz``. ``zorder`` 0.5 puts it under the data; above 2, over it (a plot
    whose background is data)."""
    if valid_hz is None or valid_hz >= top_hz:
        return
    span = ax.axvspan if vertical else ax.axhspan
    span(valid_hz / hz_per_unit, top_hz / hz_per_unit, label=rom_label(valid_hz),
         zorder=zorder, **ROM_SHADE)


def save_figure(fig, path: Path) -> Path:
    """Write ``fig`` as a PNG (atomically), close it and return ``path``."""
    path = Path(path)
    try:
        with atomic_write(path) as tmp:
            fig.savefig(tmp, dpi=DPI, bbox_inches="tight")
    finally:
        plt.close(fig)
    logger.info("wrote %s", path)
    return path


def shade_impacts(ax, branch, alpha: tuple[float, float] = (0.18, 0.25)) -> None:
    """Shade the speed ranges of a branch with single- and double-sided impacts
    (``alpha`` of each class), each class labelled once."""
    for c, iv in contact_intervals(branch).items():
        col, name = CLASS_COLOURS[c]
        for j, (a, b) in enumerate(iv):
            ax.axvspan(a, b, color=col, alpha=alpha[c - 1], lw=0,
                       label=name if j == 0 else None)


def grazing_values(branch) -> list[tuple[float, float, str, str]]:
    """(rpm, mesh-load std, kind, side) of each grazing point, std interpolated on the
    branch segment where the corresponding contact margin changes sign."""
    out = []
    mesh = branch.element(0)
    std = mesh.mesh_load_std
    for g in mesh.grazing:
        m = mesh.margin_active if g.side == "active" else mesh.margin_reverse
        best = None
        for i in range(len(branch) - 1):
            if (m[i] > 0) != (m[i + 1] > 0):
                a, b = branch.rpm[i], branch.rpm[i + 1]
                if min(a, b) - 1e-6 <= g.rpm <= max(a, b) + 1e-6:
                    w = 0.0 if a == b else (g.rpm - a) / (b - a)
                    val = (1 - w) * std[i] + w * std[i + 1]
                    d = 0.0
                else:
                    d = min(abs(a - g.rpm), abs(b - g.rpm))
                    val = std[i]
                if best is None or d < best[0]:
                    best = (d, val)
        if best is None:
            i = int(np.argmin(np.abs(branch.rpm - g.rpm)))
            best = (0.0, std[i])
        out.append((g.rpm, float(best[1]), g.kind, g.side))
    return out
