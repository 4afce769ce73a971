"""Plots of a gear train: each mesh's load spectrum, the order map of each mesh's load and
the Campbell diagram of the linearised train, every order labelled by the shaft or mesh
combination it is (:func:`study.outputs.train.order_names`), in the drive shaft's orders
and in Hz.
"""
from __future__ import annotations

from fractions import Fraction
from pathlib import Path

import numpy as np

from study.outputs.train import order_name, order_names, train_frequencies
from study.plots.common import plt, save_figure

_CLASS = ("permanent contact", "single-sided impacts", "double-sided impacts")

__all__ = ["train_forced_response", "train_spectrum_plot", "train_order_map",
           "train_campbell", "train_time_series_plot", "train_plots"]


def train_forced_response(branch, path: Path, title: str, periodic: bool = True) -> Path:
    """Std of each mesh's dynamic load against the drive speed, one colour per mesh, its
    grazing points as diamonds; unstable orbits dashed (periodic basis; on a torus the
    stability is not computed and every curve is drawn solid)."""
    fig, ax = plt.subplots(figsize=(8, 4.2))
    rpm = np.asarray(branch.rpm)
    stable = np.asarray(branch.stable, dtype=bool) if periodic else np.ones(rpm.size, bool)
    for e in range(max(branch.n_elements, 1)):
        cur = branch.element(e)
        std = np.asarray(cur.mesh_load_std)
        colour = f"C{e}"
        start = 0
        for i in range(1, rpm.size + 1):
            if i == rpm.size or stable[i] != stable[start]:
                sl = slice(start, min(i + 1, rpm.size))
                ax.plot(rpm[sl], std[sl], color=colour, lw=1.3,
                        ls="-" if stable[start] else "--",
                        label=cur.name if start == 0 else None)
                start = i
        for g in cur.grazing:
            ax.plot([g.rpm], [np.interp(g.rpm, rpm, std) if np.all(np.diff(rpm) > 0)
                              else std[int(np.argmin(np.abs(rpm - g.rpm)))]],
                    "D", ms=5, mfc="white", mec=colour, mew=1.2, zorder=5)
    ax.plot([], [], "D", ms=5, mfc="white", mec="k", ls="", label="grazing")
    if periodic:
        ax.plot([], [], "k--", label="unstable")
    ax.set_xlabel("drive speed Ω (rpm)")
    ax.set_ylabel("std of dynamic mesh load (N)")
    ax.grid(alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    ax.set_title(title + ("" if periodic else " (torus: stability not computed)"), fontsize=10)
    return save_figure(fig, path)


def train_spectrum_plot(problem, point, e: int, names: dict, path: Path,
                        n_labels: int = 10) -> Path:
    """Mesh ``e``'s load spectrum at one point against the drive shaft's order (frequency
    on the top axis), its largest lines named."""
    from hbm import spectrum

    sp = spectrum(problem, point, element=e)
    hs = problem.harmonics
    idx = np.asarray(sp["index"])
    order, amp = np.asarray(sp["shaft_order"], dtype=float), np.asarray(sp["amplitude"])
    keep = (idx > 0) & (idx <= 1.1 * max(hs.indices))
    top = max(float(np.max(amp[keep])) if np.any(keep) else 0.0, 1e-30)
    floor = top * 1e-3
    keep &= amp >= floor
    fig, ax = plt.subplots(figsize=(9, 3.8))
    ax.vlines(order[keep], floor, amp[keep], color="tab:blue", lw=1.4)
    for j in sorted(np.flatnonzero(keep), key=lambda j: -amp[j])[:n_labels]:
        ax.annotate(order_name(Fraction(int(idx[j])) * hs.ratio, names), (order[j], amp[j]),
                    xytext=(0, 4), textcoords="offset points", ha="center", fontsize=7)
    ax.set_yscale("log")
    ax.set_ylim(floor, 3 * top)
    ax.set_xlabel("order of the drive shaft (harmonic of Ω)")
    ax.set_ylabel("mesh-load amplitude (N)")
    f1 = point.rpm / 60.0
    sec = ax.secondary_xaxis("top", functions=(lambda o: o * f1, lambda f: f / f1))
    sec.set_xlabel("frequency (Hz)")
    ax.grid(alpha=0.3)
    el = problem.elements[e]
    ax.set_title(f"{el.name}: mesh-load spectrum at {point.rpm:.0f} rpm (mesh frequency "
                 f"{float(el.n_teeth * el.speed_ratio) * f1:.0f} Hz)", fontsize=10)
    return save_figure(fig, path)


def train_order_map(rpm, orders, amplitude, names: dict, path: Path, title: str,
                    dynamic_range_db: float = 60.0, max_rows: int = 24,
                    levels_db: np.ndarray | None = None,
                    label: str = "mesh-load amplitude (dB re 1 N)") -> Path:
    """Order map of one mesh's load (or of any level per order, ``levels_db`` with its
    colour-bar ``label``, e.g. the housing's ERP): a row per order of the set (the loudest
    ``max_rows``), named by :func:`order_name`, level in dB along the branch (the
    amplitude's in dB re 1 N); right, the same at its frequency (Campbell style)."""
    rpm = np.asarray(rpm, dtype=float)
    lv = (np.asarray(levels_db, dtype=float) if levels_db is not None else
          20 * np.log10(np.maximum(np.asarray(amplitude, dtype=float), 1e-30)))
    orders = [o for o in orders]
    keep = [j for j, o in enumerate(orders) if o > 0]
    keep = sorted(keep, key=lambda j: -np.max(lv[:, j]))[:max_rows]
    keep.sort(key=lambda j: orders[j])
    lv = lv[:, keep]
    top = float(np.max(lv)) if lv.size else 0.0
    norm = plt.Normalize(top - dynamic_range_db, top)
    cmap = plt.get_cmap("magma")
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(13, 5),
                                 gridspec_kw={"width_ratios": [1, 1.2], "wspace": 0.3})
    for r, j in enumerate(keep):
        o = float(orders[j])
        c = cmap(norm(np.maximum(lv[:, r], top - dynamic_range_db)))
        ax.scatter(rpm, np.full(rpm.size, r), c=c, s=6, marker="s", lw=0)
        bx.scatter(rpm, o * rpm / 60.0, c=c, s=4, lw=0)
    ax.set_yticks(range(len(keep)))
    ax.set_yticklabels([f"{order_name(orders[j], names)} (×{float(orders[j]):.4g})"
                        for j in keep], fontsize=6)
    for a in (ax, bx):
        a.set_xlabel("drive speed Ω (rpm)")
    ax.set_ylabel("order of the drive shaft")
    bx.set_ylabel("frequency (Hz)")
    fig.colorbar(plt.cm.ScalarMappable(cmap=cmap, norm=norm), ax=[ax, bx], label=label)
    fig.suptitle(title, fontsize=10)
    return save_figure(fig, path)


def train_campbell(result, path: Path, mesh_harmonics: int = 3) -> Path:
    """Campbell diagram of the linearised train (mean mesh stiffnesses): its natural
    frequencies against the drive speed, with every mesh's harmonics ``k Z ρ Ω`` and every
    shaft's speed ``ρ_s Ω`` as labelled lines (orders of the drive shaft and Hz)."""
    import scipy.linalg as sla

    pb, sc = result.problem, result.scene
    K = pb.system.K + sum(float(np.real(el.stiffness[0])) * np.outer(el.direction,
                                                                     el.direction)
                          for el in pb.elements)
    w2 = sla.eigh(K, pb.system.M, eigvals_only=True)
    fn = np.sqrt(np.clip(w2, 0.0, None)) / (2 * np.pi)
    fn = fn[fn > 1e-3 * max(fn.max(), 1.0)]
    lo, hi = sc.continuation.speed
    rpm = np.linspace(0.0, hi * 1.05, 2)
    meshes, shafts = train_frequencies(result)
    fig, ax = plt.subplots(figsize=(9, 5.5))
    fmax = 1.1 * max(float(f) for _, f in meshes) * mesh_harmonics * hi / 60.0
    for f in fn:
        if f <= fmax:
            ax.axhline(f, color="tab:cyan", lw=0.8)
            ax.annotate(f"{f:.0f} Hz", (0.01 * hi, f), fontsize=7, color="tab:cyan",
                        va="bottom")
    for name, f in meshes:
        for k in range(1, mesh_harmonics + 1):
            y = k * float(f) * rpm / 60.0
            ax.plot(rpm, y, lw=1.4 if k == 1 else 0.8)
            ax.annotate(f"{f'{k} ' if k > 1 else ''}{name} (×{k * float(f):.4g})",
                        (rpm[-1], y[-1]), fontsize=7, ha="right", va="bottom")
    for name, rho in shafts:
        y = float(rho) * rpm / 60.0
        ax.plot(rpm, y, color="grey", lw=0.6, ls="--")
        ax.annotate(f"{name} ×1 (×{float(rho):.4g})", (rpm[-1], y[-1]), fontsize=6,
                    ha="right", color="grey")
    ax.axvspan(lo, hi, color="0.92", zorder=0, label="speed range")
    ax.set_xlim(0, rpm[-1])
    ax.set_ylim(0, fmax)
    ax.set_xlabel("drive speed Ω (rpm)")
    ax.set_ylabel("frequency (Hz)")
    ax.set_title(f"{sc.name}: Campbell diagram of the linearised train (mean mesh "
                 "stiffnesses); orders of the drive shaft in brackets", fontsize=9)
    ax.grid(alpha=0.3)
    return save_figure(fig, path)


def train_time_series_plot(problem, point, path: Path, title: str = "") -> Path:
    """One panel per mesh over one period of the response (the hunting period): its
    dynamic transmission error Δ with the gap limits e ± b (left, µm) and its mesh load
    (right, N), against time in periods of the first mesh."""
    from hbm import time_series

    n_el = len(problem.elements)
    e0 = problem.elements[0]
    mesh_period = 2 * np.pi / (float(e0.n_teeth * e0.speed_ratio) * point.omega)
    fig, axes = plt.subplots(n_el, 1, figsize=(9, 2.6 * n_el), sharex=True, squeeze=False)
    for e, (ax, el) in enumerate(zip(axes[:, 0], problem.elements, strict=True)):
        ts = time_series(problem, point, element=e)
        t = ts.t / mesh_period
        d = ts.delta * 1e6
        ga, gr = ts.signals["gap_active"] * 1e6, ts.signals["gap_reverse"] * 1e6
        ax.plot(t, d, "b", lw=0.9, label="DTE Δ")
        ax.plot(t, ga, "k--", lw=0.7, label="gap limit e + b")
        if np.any(d < gr + 0.25 * (ga - gr).mean()):      # near the back flank
            ax.plot(t, gr, "k:", lw=0.7, label="e − b")
        ax.set_ylabel(f"{el.name}: Δ (µm)", color="b")
        bx = ax.twinx()
        bx.plot(t, ts.load, "r", lw=0.8)
        bx.set_ylabel("mesh load (N)", color="r")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="upper right")
    axes[-1, 0].set_xlabel(f"time (periods of {e0.name})")
    axes[0, 0].set_title(title or f"{point.rpm:.0f} rpm", fontsize=10)
    return save_figure(fig, path)


def train_plots(result, want: set, speeds) -> list[Path]:
    """The train's plots the scene asks for: ``time_series`` (one panel per mesh) and
    ``spectrum`` per mesh at the time-series speeds (periodic basis), ``order_maps`` per
    mesh (and of the housing's ERP), ``campbell``, ``rom_error`` (an FE train's Fig. 9
    check), and for a machine with a radiating housing ``erp`` and ``accelerometers``
    with the train's order names."""
    from study.outputs.points import nearest_point

    out = Path(result.out)
    pb, br = result.problem, result.branch
    meshes, shafts = train_frequencies(result)
    h = result.scene.hbm.mesh_harmonics
    names = order_names(meshes, shafts, max_harmonic=max(h, 1))
    paths: list[Path] = []
    if "forced_response" in want and len(br):
        paths.append(train_forced_response(br, out / "forced_response.png",
                                           f"{result.scene.name}: forced response per mesh",
                                           pb.harmonics.periodic))
    if "time_series" in want and pb.harmonics.periodic:
        from hbm import point_stats
        from study.outputs.points import point_at_speed

        for rpm in speeds:    # at exactly the asked speed (as the pair's, study.plots.figures)
            if result.scene.outputs.time_series:
                i, pt, use = point_at_speed(result, rpm, "time series")
                solved = use.how == "solved"
            else:
                (i, pt), solved = nearest_point(result, rpm), False
            contact = ([int(s["contact"]) for s in point_stats(pb, pt)] if solved else
                       [int(br.element(e).contact[i]) for e in range(len(pb.elements))])
            cls = ", ".join(f"{el.name} {_CLASS[c]}"
                            for el, c in zip(pb.elements, contact, strict=True))
            paths.append(train_time_series_plot(pb, pt, out / f"time_series_{pt.rpm:.0f}rpm.png",
                                                f"{result.scene.name}: {pt.rpm:.1f} rpm "
                                                f"({cls})"))
    if "spectrum" in want and pb.harmonics.periodic:
        for rpm in speeds:
            _, pt = nearest_point(result, rpm)
            for e, el in enumerate(pb.elements):
                paths.append(train_spectrum_plot(pb, pt, e, names,
                                                 out / f"spectrum_{el.name}_{pt.rpm:.0f}rpm.png"))
    nvh = getattr(result, "nvh", None)
    if "order_maps" in want and nvh is not None and nvh.amplitude_per_mesh is not None \
            and pb.harmonics.periodic and len(br):
        orders = [Fraction(int(i)) * pb.harmonics.ratio for i in pb.harmonics.indices]
        for e, el in enumerate(pb.elements):
            paths.append(train_order_map(br.rpm, orders, nvh.amplitude_per_mesh[:, e], names,
                                         out / f"order_map_{el.name}.png",
                                         f"{result.scene.name}: {el.name} mesh load per order"))
    if nvh is not None and nvh.erp is not None and len(br):
        paths += _housing_plots(result, want, names)
    if "campbell" in want:
        paths.append(train_campbell(result, out / "campbell.png"))
    rd = result.rom
    if "rom_error" in want and rd is not None and rd.validation is not None:
        from study.plots.modes import rom_error_plot

        paths.append(rom_error_plot(rd.validation.full_hz, rd.validation.rom_hz,
                                    out / "rom_error.png", rd.validation.relative_error))
    return paths


def _housing_plots(result, want: set, names: dict) -> list[Path]:
    """The housing's ERP order map (``order_maps``), ERP curves (``erp``) and virtual
    accelerometers (``accelerometers``) of a train, orders named by shaft and mesh."""
    from study.outputs.checks import rom_limit_hz
    from study.plots.speed import accelerometer_plot, erp_plot

    out, br, nvh, pb = Path(result.out), result.branch, result.nvh, result.problem
    name, z = result.scene.name, result.scene.gear.teeth
    paths: list[Path] = []
    if "order_maps" in want and pb.harmonics.periodic:
        orders = [Fraction(int(i)) * pb.harmonics.ratio for i in pb.harmonics.indices]
        paths.append(train_order_map(br.rpm, orders, None, names, out / "order_map_erp.png",
                                     f"{name}: housing ERP per order (all meshes)",
                                     levels_db=nvh.erp_db, label="ERP (dB re 1 pW)"))
    if "erp" in want:
        paths.append(erp_plot(br, nvh.erp_total_db, nvh.erp_db, nvh.orders, z,
                              out / "erp.png", f"{name}: equivalent radiated power",
                              rom_valid_hz=rom_limit_hz(result.rom), names=nvh.order_names))
    if "accelerometers" in want and nvh.accel_velocity is not None:
        paths.append(accelerometer_plot(br, nvh.accel_names, nvh.accel_velocity, nvh.orders,
                                        z, out / "accelerometers.png",
                                        f"{name}: virtual accelerometers",
                                        order_names=nvh.order_names))
    return paths
