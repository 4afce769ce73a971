"""PNG plots (matplotlib, Agg): forced response (Fig. 12/14), time series of the DTE
and mesh load (Fig. 15–18), mesh-load spectrum (Fig. 15c), Campbell diagram coloured
by mesh energy (Fig. 8) and ROM frequency error (Fig. 9).

Units on the plots: rpm, µm, N, Hz.
"""
from __future__ import annotations

import logging
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from geometry.files import atomic_write
from study.fields import V_REF, velocity_level_db
from study.points import nearest_point, time_series_speeds

logger = logging.getLogger(__name__)

__all__ = ["forced_response", "forced_response_overlay", "time_series_plot", "spectrum_plot",
           "campbell_plot", "campbell_modes", "rom_error_plot", "rom_plots", "draw_all",
           "contact_intervals", "grazing_values", "order_label", "spectrum_lines",
           "order_map_plot", "erp_plot", "accelerometer_plot"]

CLASS_COLOURS = {1: ("tab:orange", "single-sided impacts"), 2: ("tab:red", "double-sided impacts")}


def _save(fig, path: Path) -> Path:
    path = Path(path)
    try:
        with atomic_write(path) as tmp:
            fig.savefig(tmp, dpi=130, bbox_inches="tight")
    finally:
        plt.close(fig)
    logger.info("wrote %s", path)
    return path


def contact_intervals(rpm: np.ndarray, contact: np.ndarray) -> dict[int, list[tuple[float, float]]]:
    """Merged speed intervals (rpm) covered by branch segments with impacts, per class.

    A segment between consecutive points counts for the larger class of its ends.
    """
    out: dict[int, list[tuple[float, float]]] = {1: [], 2: []}
    for i in range(len(rpm) - 1):
        c = int(max(contact[i], contact[i + 1]))
        if c in out:
            out[c].append((float(min(rpm[i], rpm[i + 1])), float(max(rpm[i], rpm[i + 1]))))
    for c, iv in out.items():
        iv.sort()
        merged: list[list[float]] = []
        for a, b in iv:
            if merged and a <= merged[-1][1] + 1e-9:
                merged[-1][1] = max(merged[-1][1], b)
            else:
                merged.append([a, b])
        out[c] = [(a, b) for a, b in merged]
    return out


def grazing_values(branch) -> list[tuple[float, float, str, str]]:
    """(rpm, mesh-load std, kind, side) of each grazing point, std interpolated on the
    branch segment where the corresponding contact margin changes sign."""
    out = []
    for g in branch.grazing:
        m = branch.margin_active if g.side == "active" else branch.margin_reverse
        best = None
        for i in range(len(branch) - 1):
            if (m[i] > 0) != (m[i + 1] > 0):
                a, b = branch.rpm[i], branch.rpm[i + 1]
                if min(a, b) - 1e-6 <= g.rpm <= max(a, b) + 1e-6:
                    w = 0.0 if a == b else (g.rpm - a) / (b - a)
                    val = (1 - w) * branch.mesh_load_std[i] + w * branch.mesh_load_std[i + 1]
                    d = 0.0
                else:
                    d = min(abs(a - g.rpm), abs(b - g.rpm))
                    val = branch.mesh_load_std[i]
                if best is None or d < best[0]:
                    best = (d, val)
        if best is None:
            i = int(np.argmin(np.abs(branch.rpm - g.rpm)))
            best = (0.0, branch.mesh_load_std[i])
        out.append((g.rpm, float(best[1]), g.kind, g.side))
    return out


def _curve(ax, branch, colour="k", label=None, shade=True):
    rpm, std, stable = branch.rpm, branch.mesh_load_std, branch.stable.astype(bool)
    if shade:
        for c, iv in contact_intervals(rpm, branch.contact).items():
            col, name = CLASS_COLOURS[c]
            for j, (a, b) in enumerate(iv):
                ax.axvspan(a, b, color=col, alpha=0.18 if c == 1 else 0.25, lw=0,
                           label=name if j == 0 else None)
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


def forced_response(branch, path: Path, title: str = "") -> Path:
    """Std of the dynamic mesh load vs shaft speed (Fig. 12/14): grazing points as
    diamonds, impact ranges shaded, unstable solutions dashed."""
    fig, ax = plt.subplots(figsize=(8, 4.2))
    _curve(ax, branch)
    ax.plot([], [], "k--", label="unstable")
    ax.set_xlabel("shaft speed Ω (rpm)")
    ax.set_ylabel("std of dynamic mesh load (N)")
    ax.set_yscale("log" if np.ptp(np.log10(np.maximum(branch.mesh_load_std, 1e-12))) > 2
                  else "linear")
    ax.set_xlim(branch.rpm_start, branch.rpm_end)
    ax.grid(alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    ax.set_title(title or "forced response")
    return _save(fig, path)


def forced_response_overlay(branches: list, labels: list[str], path: Path,
                            title: str = "") -> Path:
    """Forced response curves of several variants in one plot, grazing points marked."""
    fig, ax = plt.subplots(figsize=(8, 4.2))
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    logy = False
    for j, (br, lab) in enumerate(zip(branches, labels, strict=True)):
        col = colours[j % len(colours)]
        _curve(ax, br, colour=col, label=lab, shade=False)
        for c, iv in contact_intervals(br.rpm, br.contact).items():
            y = 0.02 + 0.025 * j
            for a, b in iv:
                ax.plot([a, b], [y, y], transform=ax.get_xaxis_transform(), color=col,
                        lw=3 if c == 1 else 6, solid_capstyle="butt")
        logy |= np.ptp(np.log10(np.maximum(br.mesh_load_std, 1e-12))) > 2
    ax.plot([], [], "kD", mfc="white", label="grazing")
    ax.plot([], [], "k--", label="unstable")
    ax.set_yscale("log" if logy else "linear")
    ax.set_xlabel("shaft speed Ω (rpm)")
    ax.set_ylabel("std of dynamic mesh load (N)")
    ax.grid(alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    ax.set_title(title or "parameter study (bars: impact ranges, thick = double-sided)")
    return _save(fig, path)


def time_series_plot(problem, point, path: Path, title: str = "") -> Path:
    """Dynamic transmission error with the gap limits, and mesh load (Fig. 15–18)."""
    from hbm import time_series

    hs = problem.harmonics
    mesh_fund = hs.fundamental == "mesh"
    ts = time_series(problem, point, n_periods=3 if mesh_fund else 1)
    z = problem.mesh.n_teeth
    mesh_period = 2 * np.pi / (z * point.omega)
    t = ts.t / mesh_period  # in mesh periods
    nrows = 2 if mesh_fund else 3
    fig, axes = plt.subplots(nrows, 1, figsize=(8, 2.4 * nrows), sharex=False)
    d, ga, gr = ts.delta * 1e6, ts.gap_active * 1e6, ts.gap_reverse * 1e6
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
    ax.plot(t, ts.mesh_load, "r", lw=1)
    ax.set_ylabel("mesh load (N)")
    if not mesh_fund:  # zoom on 3 mesh periods around the largest mesh load
        tc = t[int(np.argmax(ts.mesh_load))]
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
    return _save(fig, path)


def order_label(order: int, n_teeth: int) -> str:
    """Name of a shaft order: ``"Z"``, ``"2Z"``, sidebands ``"Z+2"``, ``"2Z−1"``, and the
    plain number for orders far below the mesh frequency (external orders)."""
    order = int(order)
    k = int(round(order / n_teeth))
    e = order - k * n_teeth
    if k == 0:
        return str(order)
    base = "Z" if k == 1 else f"{k}Z"
    return base if e == 0 else f"{base}{'+' if e > 0 else '−'}{abs(e)}"


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


def spectrum_plot(problem, point, path: Path, title: str = "", n_labels: int = 10) -> Path:
    """Mesh-load spectrum (Fig. 15c) against the shaft order, with a frequency axis.

    Only orders up to a little above the highest harmonic of the HBM set are drawn
    (the AFT grid's upper orders hold no solved content), within 60 dB of the
    largest line; the largest lines are labelled as mesh harmonics and sidebands
    (``Z``, ``2Z``, ``Z±e``) or external orders.
    """
    from hbm import spectrum

    sp = spectrum(problem, point)
    hs = problem.harmonics
    z = problem.mesh.n_teeth
    max_order = 1.1 * hs.max_index * hs.divisor + 1
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
    f1 = point.rpm / 60.0
    sec = ax.secondary_xaxis("top", functions=(lambda o: o * f1, lambda f: f / f1))
    sec.set_xlabel("frequency (Hz)")
    ax.grid(alpha=0.3)
    ax.set_title(title or f"mesh-load spectrum at {point.rpm:.0f} rpm "
                 f"(mesh frequency {z * f1:.0f} Hz)", fontsize=10)
    return _save(fig, path)


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
                  external_orders=()) -> Path:
    """Campbell diagram (Fig. 8).

    Every mode is drawn as a horizontal line coloured by its mesh energy on a log
    scale (faint below 0.1 %); modes with ρ ≥ ``threshold`` or crossed by an
    external order inside the speed range (:func:`campbell_modes`) are drawn thick
    and labelled. Mesh orders kZ are solid black lines, the external shaft orders
    dashed; their crossings with the highlighted modes inside the speed range are
    circled. The right panel zooms on the low frequencies the external orders reach.
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
    fmax_mesh = mesh_orders[-1] * rpm[-1] / 60.0
    fmax_ext = 1.3 * max(ext) * rpm[-1] / 60.0 if ext else None
    panels = [(fmax_mesh, mesh_orders + ext)] + ([(fmax_ext, ext + mesh_orders)] if ext else [])
    fig, axes = plt.subplots(1, len(panels), figsize=(8 + 4 * (len(panels) - 1), 4.8),
                             gridspec_kw={"width_ratios": [2, 1.2][:len(panels)]},
                             squeeze=False)
    for pi, (ax, (fmax, orders)) in enumerate(zip(axes[0], panels, strict=True)):
        labelled: list[float] = []
        for j, (fj, rho) in enumerate(zip(f, e, strict=True)):
            if fj <= 0 or fj > fmax:
                continue
            thick = j in strong
            ax.axhline(fj, color=cmap(norm(rho)), lw=1.8 if thick else 0.7,
                       alpha=1.0 if thick else 0.35 if rho < 1e-3 else 0.7, zorder=1)
            if thick and all(abs(fj - y) > 0.025 * fmax for y in labelled):
                labelled.append(fj)
                ax.text(rpm[-1], fj, f" {fj:.0f} Hz", fontsize=6, va="center",
                        color=cmap(norm(rho)))
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
            for j in strong:
                r = 60.0 * f[j] / o
                if lo <= r <= hi and f[j] <= fmax:
                    ax.plot(r, f[j], "o", ms=6, mfc="none", mec="crimson", mew=1.2, zorder=3)
        ax.axvspan(lo, hi, color="grey", alpha=0.08, lw=0)
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
    return _save(fig, path)


def _level_lines(ax, x, y, level, norm, cmap, lw=4.0):
    """A line through (x, y) coloured by ``level`` point by point (branch order kept,
    so folds are drawn as they are)."""
    from matplotlib.collections import LineCollection

    pts = np.column_stack([x, y])
    if len(pts) < 2:
        ax.scatter(x, y, c=level, cmap=cmap, norm=norm, s=lw ** 2, marker="s")
        return
    seg = np.stack([pts[:-1], pts[1:]], axis=1)
    lc = LineCollection(seg, cmap=cmap, norm=norm, linewidths=lw, capstyle="butt")
    lc.set_array(0.5 * (level[:-1] + level[1:]))
    ax.add_collection(lc)


def order_map_plot(rpm: np.ndarray, orders: np.ndarray, level_db: np.ndarray, n_teeth: int,
                   path: Path, quantity: str, title: str = "",
                   modes_hz: np.ndarray | None = None, dynamic_range_db: float = 60.0) -> Path:
    """Order/speed colour maps of a level in dB (one column per harmonic order).

    Left: order map, one row per order of the harmonic set (labelled ``Z``, ``Z±e``,
    ``2Z`` …, external orders by number), the level along the branch as colour.
    Right: the same levels at their frequency order·Ω/2π (Campbell/waterfall style),
    with the coupled mode frequencies as thin lines when given, so resonances show
    where an order crosses a mode. Colours span ``dynamic_range_db`` below the maximum.
    """
    rpm = np.asarray(rpm, dtype=float)
    orders = np.asarray(orders)
    lv = np.asarray(level_db, dtype=float)
    keep = orders > 0
    orders, lv = orders[keep], lv[:, keep]
    top = float(np.max(lv)) if lv.size else 0.0
    norm = plt.Normalize(top - dynamic_range_db, top)
    cmap = plt.get_cmap("magma")
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(13, 5),
                                 gridspec_kw={"width_ratios": [1, 1.2], "wspace": 0.25})
    for r in np.argsort(np.max(lv, axis=0)) if lv.size else []:  # loudest drawn last
        o = orders[r]
        _level_lines(ax, rpm, np.full(rpm.size, r), np.maximum(lv[:, r], top - dynamic_range_db),
                     norm, cmap, lw=max(1.0, min(8.0, 200.0 / max(len(orders), 1))))
        _level_lines(bx, rpm, o * rpm / 60.0, np.maximum(lv[:, r], top - dynamic_range_db),
                     norm, cmap, lw=2.0)
    labels = [order_label(o, n_teeth) for o in orders]
    step = max(1, len(orders) // 40)
    ticks = [r for r, o in enumerate(orders)
             if r % step == 0 or o % n_teeth == 0 or o < n_teeth // 2]
    ax.set_yticks(ticks)
    ax.set_yticklabels([labels[r] for r in ticks], fontsize=7)
    ax.set_ylim(-0.7, len(orders) - 0.3)
    lo, hi = (float(rpm.min()), float(rpm.max())) if rpm.size else (0.0, 1.0)
    for a in (ax, bx):
        a.set_xlim(lo, hi if hi > lo else lo + 1)
        a.set_xlabel("shaft speed Ω (rpm)")
    ax.set_ylabel("shaft order")
    fmax = 1.05 * float(orders.max()) * hi / 60.0 if orders.size else 1.0
    if modes_hz is not None:
        for fm in np.asarray(modes_hz, dtype=float):
            if 0 < fm <= fmax:
                bx.axhline(fm, color="tab:cyan", lw=0.5, alpha=0.6, zorder=0)
        bx.plot([], [], color="tab:cyan", lw=0.8, label="coupled modes")
        bx.legend(loc="upper left", fontsize=7)
    bx.set_ylim(0, fmax)
    bx.set_ylabel("frequency (Hz)")
    bx.set_facecolor("0.93")
    sm = plt.cm.ScalarMappable(cmap=cmap, norm=norm)
    fig.colorbar(sm, ax=[ax, bx], label=f"{quantity} (dB)")
    fig.suptitle(title or f"{quantity} per order against speed", fontsize=10)
    return _save(fig, path)


def erp_plot(branch, erp_total_db: np.ndarray, erp_db: np.ndarray, orders: np.ndarray,
             n_teeth: int, path: Path, title: str = "", n_orders: int = 6) -> Path:
    """Equivalent radiated power of the housing against speed: total (thick) and the
    ``n_orders`` orders with the highest peak level; impact ranges shaded."""
    rpm = branch.rpm
    fig, ax = plt.subplots(figsize=(8, 4.2))
    for c, iv in contact_intervals(rpm, branch.contact).items():
        col, name = CLASS_COLOURS[c]
        for j, (a, b) in enumerate(iv):
            ax.axvspan(a, b, color=col, alpha=0.15, lw=0, label=name if j == 0 else None)
    ax.plot(rpm, erp_total_db, "k", lw=1.8, label="total")
    orders = np.asarray(orders)
    cand = np.flatnonzero(orders > 0)
    best = cand[np.argsort(-np.max(erp_db[:, cand], axis=0))][:n_orders]
    for j in sorted(best, key=lambda j: orders[j]):
        ax.plot(rpm, erp_db[:, j], lw=1.0, label=f"order {order_label(orders[j], n_teeth)}")
    top = float(np.max(erp_total_db))
    ax.set_ylim(max(float(np.min(erp_total_db)) - 30, top - 80), top + 5)
    ax.set_xlim(branch.rpm_start, branch.rpm_end)
    ax.set_xlabel("shaft speed Ω (rpm)")
    ax.set_ylabel("ERP (dB re 1 pW)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="best", ncol=2)
    ax.set_title(title or "equivalent radiated power of the housing (radiation efficiency 1)",
                 fontsize=10)
    return _save(fig, path)


def accelerometer_plot(branch, names, velocity: np.ndarray, orders: np.ndarray, n_teeth: int,
                       path: Path, title: str = "") -> Path:
    """Virtual accelerometers: velocity level (dB re 1 nm/s, rms over all orders) against
    speed, and the velocity spectrum per order at each accelerometer's loudest point."""

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
            bx.annotate(order_label(orders[j], n_teeth), (orders[j], db[j]), xytext=(0, 3),
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
    return _save(fig, path)


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
    return _save(fig, path)


def rom_plots(result, want: set) -> list[Path]:
    """Campbell diagram (Fig. 8) and ROM frequency error (Fig. 9)."""
    rd, out, sc = result.rom, Path(result.out), result.scene
    paths = []
    if "campbell" in want:
        paths.append(campbell_plot(rd.frequencies_hz, rd.mesh_energy, sc.continuation.speed,
                                  sc.gear.teeth, max(3, sc.hbm.mesh_harmonics),
                                  out / "campbell.png", external_orders=sc.external.orders))
    if "rom_error" in want and rd.validation is not None:
        paths.append(rom_error_plot(rd.validation.full_hz, rd.validation.rom_hz,
                                    out / "rom_error.png", rd.validation.relative_error))
    return paths


def draw_all(result) -> list[Path]:
    """All plots the scene's ``[outputs] plots`` asks for; returns the PNG paths."""
    want = set(result.scene.outputs.plots)
    out = Path(result.out)
    br, pb = result.branch, result.problem
    paths: list[Path] = []
    name = result.scene.name
    if "forced_response" in want:
        paths.append(forced_response(br, out / "forced_response.png", f"{name}: forced response"))
    speeds = time_series_speeds(result) if {"time_series", "spectrum"} & want else []
    for rpm in speeds:
        i, pt = nearest_point(result, rpm)
        tag = f"{pt.rpm:.0f}rpm"
        cls = ("permanent contact", "single-sided impacts", "double-sided impacts")[
            int(br.contact[i])]
        if "time_series" in want:
            paths.append(time_series_plot(pb, pt, out / f"time_series_{tag}.png",
                                          f"{name}: {pt.rpm:.1f} rpm, {cls}"))
        if "spectrum" in want:
            paths.append(spectrum_plot(pb, pt, out / f"spectrum_{tag}.png"))
    nvh = getattr(result, "nvh", None)
    z = result.scene.gear.teeth
    if nvh is not None and "order_maps" in want and len(br) > 0:
        ml = 20 * np.log10(np.maximum(nvh.mesh_load_amplitude, 1e-30) / 1.0)
        modes = result.rom.frequencies_hz if result.rom is not None else None
        paths.append(order_map_plot(br.rpm, nvh.orders, ml, z, out / "order_map_mesh_load.png",
                                    "mesh-load amplitude, dB re 1 N",
                                    f"{name}: mesh load per order", modes))
        if nvh.erp is not None:
            paths.append(order_map_plot(br.rpm, nvh.orders, nvh.erp_db, z,
                                        out / "order_map_erp.png", "ERP, dB re 1 pW",
                                        f"{name}: housing ERP per order", modes))
    if nvh is not None and nvh.erp is not None and "erp" in want and len(br) > 0:
        paths.append(erp_plot(br, nvh.erp_total_db, nvh.erp_db, nvh.orders, z,
                              out / "erp.png", f"{name}: equivalent radiated power"))
    if nvh is not None and nvh.accel_velocity is not None and "accelerometers" in want \
            and len(br) > 0:
        paths.append(accelerometer_plot(br, nvh.accel_names, nvh.accel_velocity, nvh.orders, z,
                                        out / "accelerometers.png",
                                        f"{name}: virtual accelerometers"))
    if result.rom is not None:
        paths += rom_plots(result, want)
    return paths
