"""Plots of one periodic solution: the dynamic transmission error and mesh load over
time (Fig. 15–18) and the mesh-load spectrum against the shaft order (Fig. 15c).
Units: µm, N, Hz.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from study.outputs.nvh import order_label
from study.plots.common import F_STOP, plt, save_figure, shade_beyond_rom

__all__ = ["time_series_plot", "spectrum_lines", "spectrum_plot"]


def time_series_plot(problem, point, path: Path, title: str = "") -> Path:
    """Dynamic transmission error with the gap limits, and mesh load (Fig. 15–18)."""
    from hbm import time_series

    hs = problem.harmonics
    mesh_fund = hs.fundamental == "mesh"
    ts = time_series(problem, point, n_periods=3 if mesh_fund else 1)
    z = problem.elements[0].n_teeth
    mesh_period = 2 * np.pi / (z * point.omega)
    t = ts.t / mesh_period  # in mesh periods
    nrows = 2 if mesh_fund else 3
    fig, axes = plt.subplots(nrows, 1, figsize=(8, 2.4 * nrows), sharex=False)
    d = ts.delta * 1e6
    ga, gr = ts.signals["gap_active"] * 1e6, ts.signals["gap_reverse"] * 1e6
    reverse = bool(np.any(d < gr + 0.25 * (ga - gr).mean()))  # near the back flank

    def limits(ax, sel):
        lo = min(d[sel].min(), ga[sel].min())
        hi = max(d[sel].max(), ga[sel].max())
        if reverse:
            lo = min(lo, gr[sel].min())
        pad = 0.08 * max(hi - lo, 1e-3)
        ax.set_ylim(lo - pad, hi + pad)

    ax = axes[0]
    ax.plot(t, d, "b", lw=1, label="DTE Δ")
    ax.plot(t, ga, "k--", lw=0.8, label="gap limits e ± b" if reverse else "gap limit e + b")
    if reverse:
        ax.plot(t, gr, "k--", lw=0.8)
    limits(ax, slice(None))
    ax.set_ylabel("Δ (µm)")
    ax.legend(fontsize=8, loc="upper right")
    ax.set_title(title or f"{point.rpm:.0f} rpm")
    ax = axes[1]
    ax.plot(t, ts.load, "r", lw=1)
    ax.set_ylabel("mesh load (N)")
    if not mesh_fund:  # zoom on 3 mesh periods around the largest mesh load
        tc = t[int(np.argmax(ts.load))]
        t0 = min(max(tc - 1.5, t[0]), max(t[-1] - 3.0, t[0]))
        m = (t >= t0) & (t <= t0 + 3.0)
        ax = axes[2]
        ax.plot(t[m], d[m], "b", lw=1)
        ax.plot(t[m], ga[m], "k--", lw=0.8)
        if reverse:
            ax.plot(t[m], gr[m], "k--", lw=0.8)
        limits(ax, m)
        ax.set_ylabel("Δ (µm), zoom")
    for a in axes:
        a.grid(alpha=0.3)
    axes[-1].set_xlabel("time (mesh periods)")
    return save_figure(fig, path)



def spectrum_lines(order: np.ndarray, amp: np.ndarray, max_order: float,
                   dynamic_range_db: float = 60.0) -> tuple[np.ndarray, np.ndarray, float]:
    """Orders and amplitudes drawn by :func:`spectrum_plot`: 0 < order ≤ ``max_order``
    and within ``dynamic_range_db`` of the largest line; returns them and the floor."""
    order, amp = np.asarray(order), np.asarray(amp, dtype=float)
    sel = (order > 0) & (order <= max_order)
    top = max(float(np.max(amp[sel])) if np.any(sel) else 0.0, 1e-30)
    floor = top * 10 ** (-dynamic_range_db / 20)
    keep = sel & (amp >= floor)
    return order[keep], amp[keep], floor


def spectrum_plot(problem, point, path: Path, title: str = "", n_labels: int = 10,
                  rom_valid_hz: float | None = None) -> Path:
    """Mesh-load spectrum (Fig. 15c) against the shaft order, with a frequency axis.

    Orders are drawn up to a little above the highest harmonic of the HBM set (the AFT
    grid's upper orders hold no solved content) and at most to :data:`F_STOP` (20 kHz),
    within 60 dB of the largest line; the largest lines are labelled as mesh harmonics
    and sidebands (``Z``, ``2Z``, ``Z±e``) or external orders. Frequencies above
    ``rom_valid_hz`` (the ROM's checked validity, FE scenes) are shaded.
    """
    from hbm import spectrum

    sp = spectrum(problem, point)
    hs = problem.harmonics
    z = problem.elements[0].n_teeth
    f1 = point.rpm / 60.0
    max_order = min(1.1 * hs.max_index * hs.integer_ratio + 1, F_STOP / f1)
    order, amp, floor = spectrum_lines(sp["shaft_order"], sp["amplitude"], max_order)
    fig, ax = plt.subplots(figsize=(9, 3.8))
    ax.vlines(order, floor, amp, color="tab:blue", lw=1.4)
    ax.plot(order, amp, "o", ms=2.5, color="tab:blue")
    done: list[int] = []
    for o, a in sorted(zip(order, amp, strict=True), key=lambda t: -t[1]):
        if len(done) >= n_labels:
            break
        if all(abs(o - d) >= 3 for d in done) or o % z == 0:
            done.append(int(o))
            ax.annotate(order_label(o, z), (o, a), xytext=(0, 4), textcoords="offset points",
                        ha="center", fontsize=7)
    for k in range(1, int(max_order // z) + 1):
        ax.axvline(k * z, color="grey", lw=0.6, ls=":", zorder=0)
    ax.set_yscale("log")
    ax.set_ylim(floor, 3 * max(float(amp.max()) if amp.size else floor, floor))
    ax.set_xlim(0, max_order)
    ax.set_xlabel("shaft order (harmonic of Ω)")
    ax.set_ylabel("mesh-load amplitude (N)")
    if rom_valid_hz is not None and rom_valid_hz < max_order * f1:
        shade_beyond_rom(ax, rom_valid_hz, max_order * f1, vertical=True, hz_per_unit=f1)
        ax.legend(loc="upper right", fontsize=7)
    sec = ax.secondary_xaxis("top", functions=(lambda o: o * f1, lambda f: f / f1))
    sec.set_xlabel("frequency (Hz)")
    ax.grid(alpha=0.3)
    ax.set_title(title or f"mesh-load spectrum at {point.rpm:.0f} rpm "
                 f"(mesh frequency {z * f1:.0f} Hz)", fontsize=10)
    return save_figure(fig, path)

