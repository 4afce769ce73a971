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

logger = logging.getLogger(__name__)

__all__ = ["forced_response", "forced_response_overlay", "time_series_plot", "spectrum_plot",
           "campbell_plot", "rom_error_plot", "draw_all", "contact_intervals", "grazing_values"]

CLASS_COLOURS = {1: ("tab:orange", "single-sided impacts"), 2: ("tab:red", "double-sided impacts")}


def _save(fig, path: Path) -> Path:
    import os
    import tempfile

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=".png", dir=path.parent)
    os.close(fd)
    fig.savefig(tmp, dpi=130, bbox_inches="tight")
    plt.close(fig)
    from study.results import replace_file
    replace_file(tmp, path)
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


def spectrum_plot(problem, point, path: Path, title: str = "") -> Path:
    """Amplitude spectrum of the mesh load against the shaft order (Fig. 15c)."""
    from hbm import spectrum

    sp = spectrum(problem, point)
    order, amp = sp["shaft_order"], sp["amplitude"]
    top = max(float(np.max(amp[1:])) if amp.size > 1 else 1.0, 1e-30)
    keep = (order > 0) & (amp > 1e-6 * top)
    fig, ax = plt.subplots(figsize=(8, 3.2))
    ax.vlines(order[keep], 1e-6 * top, amp[keep], color="tab:blue", lw=1.2)
    ax.set_yscale("log")
    ax.set_ylim(1e-6 * top, 2 * top)
    ax.set_xlabel("shaft order (harmonic of Ω)")
    ax.set_ylabel("mesh-load amplitude (N)")
    ax.grid(alpha=0.3)
    ax.set_title(title or f"mesh-load spectrum at {point.rpm:.0f} rpm")
    return _save(fig, path)


def campbell_plot(frequencies_hz: np.ndarray, mesh_energy: np.ndarray, rpm_range, n_teeth: int,
                  mesh_harmonics: int, path: Path, threshold: float = 0.03) -> Path:
    """Campbell diagram (Fig. 8): modes as horizontal lines coloured by mesh energy
    (only those above ``threshold``), excitation orders kZ as black lines."""
    fig, ax = plt.subplots(figsize=(8, 4.5))
    lo, hi = rpm_range
    rpm = np.linspace(0, hi * 1.05, 2)
    fmax = 0.0
    for k in range(1, mesh_harmonics + 1):
        f = k * n_teeth * rpm / 60.0
        ax.plot(rpm, f, "k", lw=1)
        ax.text(rpm[-1], f[-1], f" H{k}Z" if k > 1 else " HZ", fontsize=7, va="center")
        fmax = max(fmax, f[-1])
    cmap = plt.get_cmap("viridis")
    e = np.asarray(mesh_energy, dtype=float)
    emax = max(float(np.max(e)) if e.size else 1.0, 1e-12)
    for f, rho in zip(frequencies_hz, e, strict=True):
        if rho >= threshold and f <= 1.1 * fmax:
            ax.axhline(f, color=cmap(rho / emax), lw=1.5)
    sm = plt.cm.ScalarMappable(cmap=cmap, norm=plt.Normalize(0, emax * 100))
    fig.colorbar(sm, ax=ax, label="mesh energy ρ (%)")
    ax.axvspan(lo, hi, color="grey", alpha=0.1, lw=0)
    ax.set_xlim(0, hi * 1.05)
    ax.set_ylim(0, fmax)
    ax.set_xlabel("shaft speed Ω (rpm)")
    ax.set_ylabel("frequency (Hz)")
    ax.set_title(f"Campbell diagram (modes with ρ ≥ {threshold:.0%})")
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


def draw_all(result) -> list[Path]:
    """All plots the scene's ``[outputs] plots`` asks for; returns the PNG paths."""
    from study.export import nearest_point, time_series_speeds

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
    if result.rom is not None:
        from study import fe_stages
        paths += fe_stages.rom_plots(result, want)
    return paths
