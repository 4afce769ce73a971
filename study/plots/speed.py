"""Plots against shaft speed along the branch: the forced response (Fig. 12/14), its
overlay for a parameter study, the housing's equivalent radiated power and the
virtual accelerometers. Units: rpm, N, dB.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from study.outputs.acoustics import V_REF, velocity_level_db
from study.outputs.curves import contact_intervals
from study.outputs.nvh import order_label
from study.plots.common import ROM_SHADE, grazing_values, plt, save_figure, shade_impacts

__all__ = ["forced_response", "forced_response_overlay", "erp_plot", "accelerometer_plot"]


def _curve(ax, branch, colour="k", label=None, shade=True):
    rpm, std, stable = branch.rpm, branch.element(0).mesh_load_std, branch.stable.astype(bool)
    if shade:
        shade_impacts(ax, branch)
    # split into runs of equal stability; consecutive runs share their end point
    start = 0
    first = True
    for i in range(1, len(rpm) + 1):
        if i == len(rpm) or stable[i] != stable[start]:
            sl = slice(start, min(i + 1, len(rpm)))
            ax.plot(rpm[sl], std[sl], color=colour, lw=1.3,
                    ls="-" if stable[start] else "--",
                    label=label if (first and label) else None)
            first = False
            start = i
    gv = grazing_values(branch)
    if gv:
        ax.plot([g[0] for g in gv], [g[1] for g in gv], "D", ms=6, mfc="white", mec=colour,
                mew=1.4, label="grazing" if label is None else None, zorder=5)


def forced_response(branch, path: Path, title: str = "", secondary=()) -> Path:
    """Std of the dynamic mesh load vs shaft speed (Fig. 12/14): grazing points as
    diamonds, impact ranges shaded, unstable solutions dashed; the branches of period 2
    and more born at its period doublings (``secondary``:
    :class:`hbm.branching.SecondaryBranch`, std over their own period) in colour, their
    switch points as triangles."""
    fig, ax = plt.subplots(figsize=(8, 4.2))
    _curve(ax, branch)
    periods = sorted({s.period for s in secondary})
    for s in secondary:
        colour = f"C{periods.index(s.period) % 9 + 1}"
        _curve(ax, s.branch, colour=colour, shade=False,
               label=f"period {s.period}" if s is next(t for t in secondary
                                                        if t.period == s.period) else "")
        ax.plot([s.doubling.rpm], [s.branch.element(0).mesh_load_std[0]], "v", ms=5,
                color=colour, zorder=5)
    ax.plot([], [], "k--", label="unstable")
    ax.set_xlabel("shaft speed Ω (rpm)")
    ax.set_ylabel("std of dynamic mesh load (N)")
    std = branch.element(0).mesh_load_std
    ax.set_yscale("log" if np.ptp(np.log10(np.maximum(std, 1e-12))) > 2 else "linear")
    ax.set_xlim(branch.rpm_start, branch.rpm_end)
    ax.grid(alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    ax.set_title(title or "forced response")
    return save_figure(fig, path)


def forced_response_overlay(branches: list, labels: list[str], path: Path,
                            title: str = "") -> Path:
    """Forced response curves of several variants in one plot, grazing points marked."""
    fig, ax = plt.subplots(figsize=(8, 4.2))
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    logy = False
    for j, (br, lab) in enumerate(zip(branches, labels, strict=True)):
        col = colours[j % len(colours)]
        _curve(ax, br, colour=col, label=lab, shade=False)
        for c, iv in contact_intervals(br).items():
            y = 0.02 + 0.025 * j
            for a, b in iv:
                ax.plot([a, b], [y, y], transform=ax.get_xaxis_transform(), color=col,
                        lw=3 if c == 1 else 6, solid_capstyle="butt")
        logy |= np.ptp(np.log10(np.maximum(br.element(0).mesh_load_std, 1e-12))) > 2
    ax.plot([], [], "kD", mfc="white", label="grazing")
    ax.plot([], [], "k--", label="unstable")
    ax.set_yscale("log" if logy else "linear")
    ax.set_xlabel("shaft speed Ω (rpm)")
    ax.set_ylabel("std of dynamic mesh load (N)")
    ax.grid(alpha=0.3)
    # below the axes: inside, the legend hides the impact bars along the bottom
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=2, fontsize=8,
              frameon=False)
    ax.set_title(title or "parameter study (bars: impact ranges, thick = double-sided)")
    return save_figure(fig, path)



def erp_plot(branch, erp_total_db: np.ndarray, erp_db: np.ndarray, orders: np.ndarray,
             n_teeth: int, path: Path, title: str = "", n_orders: int = 6,
             rom_valid_hz: float | None = None, names: tuple = ()) -> Path:
    """Equivalent radiated power of the housing against speed: total (thick) and the
    ``n_orders`` orders with the highest peak level (named by ``names``, one per order, a
    train's; else by :func:`order_label`); impact ranges shaded.

    With ``rom_valid_hz`` (the ROM's checked validity): each order's line is solid where
    its frequency is below it and dotted above; the total of the orders below it is drawn
    dashed beside the total; the speeds where the mesh frequency Z·Ω is above it are
    shaded."""
    rpm = branch.rpm
    fig, ax = plt.subplots(figsize=(8, 4.2))
    shade_impacts(ax, branch, alpha=(0.15, 0.15))
    ax.plot(rpm, erp_total_db, "k", lw=1.8, label="total")
    orders = np.asarray(orders)
    valid = None
    if rom_valid_hz is not None:
        valid = orders[None, :] * np.asarray(rpm)[:, None] / 60.0 <= rom_valid_hz
        inside = np.where(valid & (orders > 0)[None, :], 10.0 ** (erp_db / 10.0), 0.0)
        ax.plot(rpm, 10.0 * np.log10(np.maximum(inside.sum(axis=1), 1e-30)), "k--", lw=1.2,
                label=f"total of orders below {rom_valid_hz:.0f} Hz")
        r_mesh = 60.0 * rom_valid_hz / n_teeth
        if r_mesh < branch.rpm_end:
            ax.axvspan(max(r_mesh, branch.rpm_start), branch.rpm_end,
                       label=f"Z·Ω above the ROM's validity ({rom_valid_hz:.0f} Hz)",
                       zorder=0.5, **ROM_SHADE)
    cand = np.flatnonzero(orders > 0)
    best = cand[np.argsort(-np.max(erp_db[:, cand], axis=0))][:n_orders]
    for j in sorted(best, key=lambda j: orders[j]):
        label = f"order {names[j] if names else order_label(orders[j], n_teeth)}"
        if valid is None:
            ax.plot(rpm, erp_db[:, j], lw=1.0, label=label)
            continue
        line, = ax.plot(rpm, np.where(valid[:, j], erp_db[:, j], np.nan), lw=1.0, label=label)
        ax.plot(rpm, np.where(valid[:, j], np.nan, erp_db[:, j]), lw=0.8, ls=":",
                color=line.get_color())
    top = float(np.max(erp_total_db))
    ax.set_ylim(max(float(np.min(erp_total_db)) - 30, top - 80), top + 5)
    ax.set_xlim(branch.rpm_start, branch.rpm_end)
    ax.set_xlabel("shaft speed Ω (rpm)")
    ax.set_ylabel("ERP (dB re 1 pW)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="best", ncol=2)
    ax.set_title(title or "equivalent radiated power of the housing (radiation efficiency 1)",
                 fontsize=10)
    return save_figure(fig, path)


def accelerometer_plot(branch, names, velocity: np.ndarray, orders: np.ndarray, n_teeth: int,
                       path: Path, title: str = "", order_names: tuple = ()) -> Path:
    """Virtual accelerometers: velocity level (dB re 1 nm/s, rms over all orders) against
    speed, and the velocity spectrum per order at each accelerometer's loudest point
    (orders named by ``order_names`` when given, a train's)."""

    lv = velocity_level_db(velocity)                               # (n_acc, n)
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(13, 4.2), gridspec_kw={"width_ratios": [1.2, 1]})
    orders = np.asarray(orders)
    for a, name in enumerate(names):
        line, = ax.plot(branch.rpm, lv[a], lw=1.3, label=name)
        i = int(np.argmax(lv[a]))
        amp = np.abs(velocity[a, i]) / np.sqrt(2)
        db = 20 * np.log10(np.maximum(amp, V_REF * 1e-5) / V_REF)
        sel = orders > 0
        bx.plot(orders[sel], db[sel], "o", ms=3, color=line.get_color(),
                label=f"{name} at {branch.rpm[i]:.0f} rpm")
        bx.vlines(orders[sel], -20, db[sel], color=line.get_color(), lw=0.8, alpha=0.6)
        for j in np.argsort(-db * sel)[:4]:
            bx.annotate(order_names[j] if order_names else order_label(orders[j], n_teeth),
                        (orders[j], db[j]), xytext=(0, 3),
                        textcoords="offset points", ha="center", fontsize=7)
    ax.set_xlabel("shaft speed Ω (rpm)")
    ax.set_ylabel("velocity level (dB re 1 nm/s)")
    ax.set_xlim(branch.rpm_start, branch.rpm_end)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    bx.set_xlabel("shaft order")
    bx.set_ylabel("velocity per order (dB re 1 nm/s rms)")
    bx.set_ylim(bottom=max(-20.0, bx.get_ylim()[0]))
    bx.grid(alpha=0.3)
    bx.legend(fontsize=7)
    fig.suptitle(title or "virtual accelerometers", fontsize=10)
    return save_figure(fig, path)

