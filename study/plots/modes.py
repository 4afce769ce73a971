"""Plots of the modes and of the levels per order: the Campbell diagram coloured by
mesh energy (Fig. 8), the ROM frequency error (Fig. 9) and the order/speed maps of a
level in dB. Units: rpm, Hz, dB.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from study.outputs.checks import rom_limit_hz
from study.outputs.nvh import order_label
from study.plots.common import (
    DPI,
    F_STOP,
    ROM_SHADE,
    plt,
    rom_label,
    save_figure,
    shade_beyond_rom,
)
from study.plots.raster import paint_lines

__all__ = ["campbell_modes", "campbell_plot", "order_map_plot", "rom_error_plot", "rom_plots"]


def campbell_modes(frequencies_hz: np.ndarray, mesh_energy: np.ndarray, rpm_range,
                   external_orders, threshold: float = 0.03) -> np.ndarray:
    """Indices of the modes the Campbell plot highlights: mesh energy ≥ ``threshold``,
    or crossed by an external order (1, 2, 4, …) inside the speed range, whatever
    their mesh energy (a low-ρ drivetrain mode can still be excited by unbalance or
    aerodynamic loads)."""
    f = np.asarray(frequencies_hz, dtype=float)
    rho = np.asarray(mesh_energy, dtype=float)
    lo, hi = rpm_range
    keep = (rho >= threshold) & (f > 0)
    for o in external_orders:
        rpm = 60.0 * f / o
        keep |= (f > 0) & (rpm >= lo) & (rpm <= hi)
    return np.flatnonzero(keep)


def campbell_plot(frequencies_hz: np.ndarray, mesh_energy: np.ndarray, rpm_range, n_teeth: int,
                  mesh_harmonics: int, path: Path, threshold: float = 0.03,
                  external_orders=(), rom_valid_hz: float | None = None,
                  f_stop: float = F_STOP) -> Path:
    """Campbell diagram (Fig. 8).

    Every mode is drawn as a horizontal line coloured by its mesh energy on a log
    scale (faint below 0.1 %); modes with ρ ≥ ``threshold`` or crossed by an
    external order inside the speed range (:func:`campbell_modes`) are drawn thick
    and labelled. Mesh orders kZ are solid black lines, the external shaft orders
    dashed; their crossings with the highlighted modes inside the speed range are
    circled. The right panel zooms on the low frequencies the external orders reach.
    The frequency axis stops at ``f_stop`` (:data:`F_STOP`); modes above ``rom_valid_hz``
    (the ROM's checked validity) lie in a shaded band.
    """
    from matplotlib.colors import LogNorm

    f = np.asarray(frequencies_hz, dtype=float)
    e = np.clip(np.asarray(mesh_energy, dtype=float), 1e-6, 1.0)
    lo, hi = rpm_range
    ext = sorted({int(o) for o in external_orders})
    strong = set(campbell_modes(f, e, rpm_range, ext, threshold).tolist())
    norm = LogNorm(1e-4, 1.0)
    cmap = plt.get_cmap("viridis")
    rpm = np.linspace(0, hi * 1.05, 2)
    mesh_orders = [k * n_teeth for k in range(1, mesh_harmonics + 1)]
    fmax_mesh = min(mesh_orders[-1] * rpm[-1] / 60.0, f_stop)
    fmax_ext = 1.3 * max(ext) * rpm[-1] / 60.0 if ext else None
    panels = [(fmax_mesh, mesh_orders + ext)] + ([(fmax_ext, ext + mesh_orders)] if ext else [])
    fig, axes = plt.subplots(1, len(panels), figsize=(8 + 4 * (len(panels) - 1), 4.8),
                             gridspec_kw={"width_ratios": [2, 1.2][:len(panels)]},
                             squeeze=False)
    for pi, (ax, (fmax, orders)) in enumerate(zip(axes[0], panels, strict=True)):
        labelled: list[float] = []
        # every mode a horizontal line across the panel: one collection (one artist per
        # mode drew ~10 times slower), colours with their alpha, thick ones last
        shown = [j for j in np.argsort([j in strong for j in range(f.size)], kind="stable")
                 if 0 < f[j] <= fmax]
        colours = np.array([cmap(norm(e[j])) for j in shown]).reshape(-1, 4)
        colours[:, 3] = [1.0 if j in strong else 0.35 if e[j] < 1e-3 else 0.7 for j in shown]
        ax.hlines(f[shown], 0.0, hi * 1.05, colors=colours, zorder=1,
                  linewidths=[1.8 if j in strong else 0.7 for j in shown])
        for j in sorted(shown):
            if j in strong and all(abs(f[j] - y) > 0.025 * fmax for y in labelled):
                labelled.append(f[j])
                ax.text(rpm[-1], f[j], f" {f[j]:.0f} Hz", fontsize=6, va="center",
                        color=cmap(norm(e[j])))
        circles: list[tuple[float, float]] = []
        for o in orders:
            is_mesh = o in mesh_orders
            fo = o * rpm / 60.0
            ax.plot(rpm, fo, "k", lw=1.0 if is_mesh else 0.9, ls="-" if is_mesh else "--",
                    zorder=2)
            # label where the line leaves the panel
            if fo[-1] <= fmax:
                ax.text(rpm[-1], fo[-1], " " + order_label(o, n_teeth), fontsize=7,
                        va="center")
            elif pi == 0 or not is_mesh:
                r = 60.0 * fmax / o
                ax.text(r, fmax, order_label(o, n_teeth), fontsize=7, ha="center",
                        va="bottom")
            circles += [(60.0 * f[j] / o, f[j]) for j in strong
                        if lo <= 60.0 * f[j] / o <= hi and f[j] <= fmax]
        if circles:                                 # the crossings, one artist
            ax.plot(*np.array(circles).T, "o", ls="none", ms=6, mfc="none", mec="crimson",
                    mew=1.2, zorder=3)
        ax.axvspan(lo, hi, color="grey", alpha=0.08, lw=0)
        shade_beyond_rom(ax, rom_valid_hz, fmax)
        if pi == 0 and rom_valid_hz is not None and rom_valid_hz < fmax:
            ax.legend(loc="upper left", fontsize=7)
        ax.set_xlim(0, hi * 1.05)
        ax.set_ylim(0, fmax)
        ax.set_xlabel("shaft speed Ω (rpm)")
        ax.set_ylabel("frequency (Hz)")
        ax.grid(alpha=0.2)
    sm = plt.cm.ScalarMappable(cmap=cmap, norm=norm)
    fig.colorbar(sm, ax=axes[0].tolist(), label="mesh energy ρ")
    axes[0, 0].set_title("Campbell diagram: mesh orders (solid), external orders (dashed)",
                         fontsize=9)
    if len(panels) > 1:
        axes[0, 1].set_title("zoom: external orders", fontsize=9)
    return save_figure(fig, path)


def _paint_levels(ax, x, level, a, b, norm, cmap, lw_pt: float) -> None:
    """The lines ``y = a[r] + b[r]·x`` coloured by ``level[:, r]`` along the branch ``x``,
    painted at the figure's resolution into one image (:func:`study.plots.raster.paint_lines`;
    lines in column order, the last on top; branch order kept, so folds are drawn as
    they are). The axes' limits and position must be final (after the colour bar).
    One segment per branch step and order as a ``LineCollection`` cost ~40 s of the
    pump's export for its 925 orders; this costs ~1 s."""
    if len(x) < 2:
        for r in range(level.shape[1]):
            ax.scatter(x, a[r] + b[r] * np.asarray(x), c=level[:, r], cmap=cmap, norm=norm,
                       s=lw_pt ** 2, marker="s")
        return
    fig = ax.figure
    pos = ax.get_position()
    shape = (max(1, round(pos.height * fig.get_figheight() * DPI)),
             max(1, round(pos.width * fig.get_figwidth() * DPI)))
    xlim, ylim = ax.get_xlim(), ax.get_ylim()
    img = paint_lines(x, level, a, b, np.arange(level.shape[1]), xlim, ylim, shape,
                      lw_pt * DPI / 72.0)
    ax.imshow(img, origin="lower", extent=(*xlim, *ylim), aspect="auto",
              interpolation="nearest", cmap=cmap, norm=norm, zorder=2)
    ax.set_xlim(xlim)
    ax.set_ylim(ylim)


def _order_ticks(orders, n_teeth: int, most: int = 40) -> list[int]:
    """Rows of the order map to label: every mesh order kZ, then low orders (< Z/2) and
    every few rows, each only if no labelled row is closer than ``len / most`` rows
    (labels of a contiguous set would pile up)."""
    gap = max(1, len(orders) // most)
    ticks = [r for r, o in enumerate(orders) if o % n_teeth == 0]
    rest = [r for r, o in enumerate(orders) if o < n_teeth // 2 or r % gap == 0]
    for r in rest:
        if all(abs(r - t) >= gap for t in ticks):
            ticks.append(r)
    return sorted(ticks)


def order_map_plot(rpm: np.ndarray, orders: np.ndarray, level_db: np.ndarray, n_teeth: int,
                   path: Path, quantity: str, title: str = "",
                   modes_hz: np.ndarray | None = None, dynamic_range_db: float = 60.0,
                   rom_valid_hz: float | None = None, f_stop: float = F_STOP) -> Path:
    """Order/speed colour maps of a level in dB (one column per harmonic order).

    Left: order map, one row per order of the harmonic set (labelled ``Z``, ``Z±e``,
    ``2Z`` …, external orders by number), the level along the branch as colour.
    Right: the same levels at their frequency order·Ω/2π (Campbell/waterfall style),
    with the coupled mode frequencies as thin lines when given, so resonances show
    where an order crosses a mode. Colours span ``dynamic_range_db`` below the maximum.
    Nothing above ``f_stop`` (Hz, :data:`F_STOP`) is drawn (rows whose frequency is above
    it at the lowest speed are left out); levels at frequencies above ``rom_valid_hz``
    (the ROM's checked validity) are shaded in both panels.
    """
    rpm = np.asarray(rpm, dtype=float)
    orders = np.asarray(orders)
    lv = np.asarray(level_db, dtype=float)
    lo_rpm = float(rpm.min()) if rpm.size else 0.0
    keep = (orders > 0) & (orders * lo_rpm / 60.0 <= f_stop)
    orders, lv = orders[keep], lv[:, keep]
    freq = orders[None, :] * rpm[:, None] / 60.0
    lv = np.where(freq <= f_stop, lv, np.nan)
    top = float(np.nanmax(lv)) if lv.size else 0.0
    norm = plt.Normalize(top - dynamic_range_db, top)
    cmap = plt.get_cmap("magma").copy()
    cmap.set_bad((0.0, 0.0, 0.0, 0.0))              # above f_stop: not drawn
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(13, 5),
                                 gridspec_kw={"width_ratios": [1, 1.2], "wspace": 0.25})
    shown = np.maximum(lv, top - dynamic_range_db)
    labels = [order_label(o, n_teeth) for o in orders]
    ticks = _order_ticks(orders, n_teeth)
    ax.set_yticks(ticks)
    ax.set_yticklabels([labels[r] for r in ticks], fontsize=7)
    ax.set_ylim(-0.7, len(orders) - 0.3)
    lo, hi = (float(rpm.min()), float(rpm.max())) if rpm.size else (0.0, 1.0)
    for a in (ax, bx):
        a.set_xlim(lo, hi if hi > lo else lo + 1)
        a.set_xlabel("shaft speed Ω (rpm)")
    ax.set_ylabel("shaft order")
    fmax = min(1.05 * float(orders.max()) * hi / 60.0, f_stop) if orders.size else 1.0
    if modes_hz is not None:
        for fm in np.asarray(modes_hz, dtype=float):
            if 0 < fm <= fmax:
                bx.axhline(fm, color="tab:cyan", lw=0.5, alpha=0.6, zorder=0)
        bx.plot([], [], color="tab:cyan", lw=0.8, label="coupled modes")
    if rom_valid_hz is not None and rom_valid_hz < fmax:
        shade_beyond_rom(bx, rom_valid_hz, fmax, zorder=3)     # the lines fill the panel
        # left panel: the rows whose frequency order·Ω/2π is above the validity
        edge = np.array([np.sum(orders * r / 60.0 <= rom_valid_hz) for r in rpm]) - 0.5
        ax.fill_between(rpm, edge, len(orders) - 0.3, label=rom_label(rom_valid_hz),
                        zorder=3, **ROM_SHADE)
        ax.legend(loc="lower right", fontsize=7)
    if modes_hz is not None or rom_valid_hz is not None:
        bx.legend(loc="upper left", fontsize=7)
    bx.set_ylim(0, fmax)
    bx.set_ylabel("frequency (Hz)")
    bx.set_facecolor("0.93")
    sm = plt.cm.ScalarMappable(cmap=cmap, norm=norm)
    fig.colorbar(sm, ax=[ax, bx], label=f"{quantity} (dB)")
    # loudest row painted last; painted once the limits and the colour bar are set
    rows = np.argsort(np.nanmax(lv, axis=0)) if lv.size else np.arange(0)
    ones = np.ones(rows.size)
    _paint_levels(ax, rpm, shown[:, rows], rows.astype(float), 0.0 * ones, norm, cmap,
                  lw_pt=max(1.0, min(8.0, 200.0 / max(len(orders), 1))))
    _paint_levels(bx, rpm, shown[:, rows], 0.0 * ones, orders[rows] / 60.0, norm, cmap,
                  lw_pt=2.0)
    fig.suptitle((title or f"{quantity} per order against speed")
                 + f" (drawn up to {f_stop / 1e3:g} kHz)", fontsize=10)
    return save_figure(fig, path)



def rom_error_plot(full_hz: np.ndarray, rom_hz: np.ndarray, path: Path,
                   relative_error: np.ndarray | None = None) -> Path:
    """Relative error of the ROM frequencies against the full model (Fig. 9)."""
    full_hz, rom_hz = np.asarray(full_hz), np.asarray(rom_hz)
    n = min(full_hz.size, rom_hz.size)
    if relative_error is not None:
        err = np.asarray(relative_error)[:n]
    else:
        err = np.abs(rom_hz[:n] - full_hz[:n]) / np.maximum(np.abs(full_hz[:n]), 1e-30)
    fig, ax = plt.subplots(figsize=(8, 3.5))
    ax.semilogy(full_hz[:n], np.maximum(err, 1e-16), "o", ms=4)
    ax.set_xlabel("frequency of the full model (Hz)")
    ax.set_ylabel("relative frequency error")
    ax.grid(alpha=0.3, which="both")
    ax.set_title("ROM frequency error (coupled modes, eq. 17)")
    return save_figure(fig, path)


def rom_plots(result, want: set) -> list[Path]:
    """Campbell diagram (Fig. 8) and ROM frequency error (Fig. 9)."""
    rd, out, sc = result.rom, Path(result.out), result.scene
    paths = []
    if "campbell" in want:
        paths.append(campbell_plot(rd.frequencies_hz, rd.mesh_energy, sc.continuation.speed,
                                   sc.gear.teeth, max(3, sc.hbm.mesh_harmonics),
                                   out / "campbell.png", external_orders=sc.external.orders,
                                   rom_valid_hz=rom_limit_hz(rd)))
    if "rom_error" in want and rd.validation is not None:
        paths.append(rom_error_plot(rd.validation.full_hz, rd.validation.rom_hz,
                                    out / "rom_error.png", rd.validation.relative_error))
    return paths

