"""Plots of the mesh excitation of an ``ltca`` or ``table`` source (issue 38): STE and
TVMS over a mesh period with the Fourier series the dynamics use, over the hunting
period with pitch deviations, the load sharing between teeth, the contact pattern over
the face width and the Harris map; the samples of a table. Units: µm, N/µm, N, N·m, mm.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from gears.excitation import fourier_sample
from study.outputs.mesh_excitation import MeshExcitation
from study.plots.common import plt, save_figure

__all__ = ["mesh_excitation_plots", "parameter_study_plot", "train_excitation_plots"]

_FINE = 512    # samples of a Fourier series over one mesh period


def _series(ax, series, scale: float, label: str) -> None:
    x = np.arange(_FINE + 1) / _FINE
    y = fourier_sample(series.mean, series.amplitudes, series.phases, _FINE)
    ax.plot(x, np.append(y, y[0]) * scale, "k-", lw=1.0, label=label)


def _period_plot(data: MeshExcitation, stiffness, te, path: Path, title: str) -> Path:
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(7.5, 6), sharex=True)
    n = data.n_positions
    x = np.arange(n) / n
    kept = f"Fourier series kept ({data.harmonics} harmonics)"
    if data.has_ltca:
        a1.plot(x, data.mesh_cycle("ste") * 1e6, "o", ms=3, color="tab:blue",
                label=f"LTCA at {data.torque:g} N·m" + (" (synchronous average)"
                                                         if data.periods > 1 else ""))
        a1.plot(x, data.mesh_cycle("no_load_te") * 1e6, "s", ms=2.5, color="tab:gray",
                label="no-load TE")
        a2.plot(x, data.mesh_cycle("stiffness") * 1e-6, "o", ms=3, color="tab:blue",
                label="LTCA")
    for name, ax, scale in (("te", a1, 1e6), ("stiffness", a2, 1e-6)):
        pos = data.arrays.get(f"table_{name}_position")
        if pos is not None:
            ax.plot(pos % 1.0, data.arrays[f"table_{name}"] * scale, "^", ms=3,
                    color="tab:green", label="table samples")
    _series(a1, te, 1e6, kept)
    _series(a2, stiffness, 1e-6, kept)
    a1.set_ylabel("transmission error (µm)")
    a2.set_ylabel("mesh stiffness k_m (N/µm)")
    a2.set_xlabel("mesh position (mesh periods)")
    for ax in (a1, a2):
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="best")
    a1.set_title(title)
    return save_figure(fig, path)


def _hunting_plot(data: MeshExcitation, teeth: tuple[int, int], path: Path,
                  title: str) -> Path:
    t, ste, k = data.arrays["t"], data.arrays["ste"], data.arrays["stiffness"]
    fig, (a1, a2, a3) = plt.subplots(3, 1, figsize=(7.5, 7.5))
    a1.plot(t, ste * 1e6, lw=0.7)
    a1.set_ylabel("q_s (µm)")
    a2.plot(t, k * 1e-6, lw=0.7)
    a2.set_ylabel("k_m (N/µm)")
    a2.set_xlabel(f"mesh periods (hunting period {data.periods})")
    c = np.abs(np.fft.rfft(ste - ste.mean())) * 2.0 / ste.size
    z1 = teeth[0]
    order = np.arange(c.size) * z1 / data.periods       # shaft orders of gear 1
    keep = order <= 3.5 * z1
    a3.vlines(order[keep], 0, c[keep] * 1e6, lw=1.0)
    a3.set_xlabel(f"order of gear 1's shaft (mesh orders at multiples of {z1})")
    a3.set_ylabel("q_s amplitude (µm)")
    for ax in (a1, a2, a3):
        ax.grid(alpha=0.3)
    a1.set_title(title)
    fig.tight_layout()
    return save_figure(fig, path)


def _sharing_plot(data: MeshExcitation, load: float, path: Path, title: str) -> Path:
    n = data.n_positions
    share = data.arrays["pair_load"][:n] / load          # the first mesh period
    x = np.arange(n) / n
    tooth = data.arrays["teeth"][:n, :, 0]                 # gear 1's tooth in each slot
    fig, ax = plt.subplots(figsize=(7.5, 3.8))
    for k in np.unique(tooth):          # one curve per tooth pair, across the slot change
        curve = np.where(tooth == k, share, 0.0).sum(axis=1)
        if np.any(curve > 0):
            ax.plot(x, np.where((tooth == k).any(axis=1), curve, np.nan), lw=1.3,
                    label=f"gear 1 tooth {k}")
    ax.plot(x, share.sum(axis=1), "k:", lw=1.0, label="sum")
    ax.set_xlabel("mesh position (mesh periods, first period)")
    ax.set_ylabel("share of the static load F_s")
    ax.set_ylim(-0.02, 1.08)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="best")
    ax.set_title(title)
    return save_figure(fig, path)


def _pattern_plot(data: MeshExcitation, path: Path, title: str) -> Path:
    z = data.arrays["pattern_z"] * 1e3
    fig, axes = plt.subplots(1, 2, figsize=(10, 4), gridspec_kw={"wspace": 0.35})
    load = data.arrays["pattern_line_load"] * 1e-3            # N/mm
    top = max(float(load.max()), 1e-12)
    for g, ax in enumerate(axes):
        d = data.arrays["pattern_diameter"][g] * 1e3
        im = ax.pcolormesh(z, d, load[g], shading="nearest", cmap="viridis", vmin=0, vmax=top)
        ax.set_xlabel("face width position z (mm)")
        ax.set_ylabel(f"gear {g + 1} diameter (mm)")
        ax.set_title(f"gear {g + 1}", fontsize=9)
    fig.colorbar(im, ax=axes, label="largest line load (N/mm)")
    fig.suptitle(title)
    return save_figure(fig, path)


def _harris_plot(data: MeshExcitation, path: Path, title: str) -> Path:
    a = data.arrays
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.plot(a["harris_torque"], a["harris_ste_peak_to_peak"] * 1e6, "o-", ms=3)
    ax.axvline(data.torque, color="tab:red", ls="--", lw=1,
               label=f"scene torque {data.torque:g} N·m")
    ax.set_xlabel("torque T (N·m)")
    ax.set_ylabel("peak-to-peak loaded STE (µm)")
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(title)
    return save_figure(fig, path)


def mesh_excitation_plots(data: MeshExcitation, scene, out: Path) -> list[Path]:
    """The PNGs of a one-pair run's ``ltca``/``table`` mesh excitation in ``out``:
    ``mesh_ste_tvms`` (one mesh period, with the series kept), and with the LTCA
    ``mesh_load_sharing``, ``mesh_harris``, ``mesh_hunting`` (pitch deviations: the
    hunting period and its shaft orders) and ``mesh_contact_pattern`` (slices across the
    face)."""
    return _plots(data, scene.mesh_source, scene.mesh_stiffness, scene.transmission_error,
                  Path(out), scene.name, "")


def train_excitation_plots(per_mesh: dict[str, MeshExcitation], scene,
                           out: Path) -> list[Path]:
    """The same PNGs (:func:`mesh_excitation_plots`) for every mesh of a train in
    ``per_mesh`` (mesh name -> arrays), each file name ending with ``_<mesh>``."""
    meshes = {m.name: m for m in scene.meshes}
    paths = []
    for name, data in per_mesh.items():
        m = meshes[name]
        paths += _plots(data, m.source, m.mesh_stiffness, m.transmission_error, Path(out),
                        f"{scene.name}, {name}", f"_{name}")
    return paths


def _plots(data: MeshExcitation, src, stiffness, te, out: Path, name: str,
           suffix: str) -> list[Path]:
    """:func:`mesh_excitation_plots` of one mesh: its source ``src``, the series ``stiffness``
    and ``te`` the dynamics take, titles starting with ``name``, file names ending with
    ``suffix``."""
    paths = [_period_plot(data, stiffness, te, out / f"mesh_ste_tvms{suffix}.png",
                          f"{name}: STE and TVMS over a mesh period "
                          f"(k_m: {data.stiffness_source}, TE: {data.te_source})")]
    if not data.has_ltca:
        return paths
    paths.append(_sharing_plot(data, src.case.load, out / f"mesh_load_sharing{suffix}.png",
                               f"{name}: load sharing between tooth pairs"))
    paths.append(_harris_plot(data, out / f"mesh_harris{suffix}.png", f"{name}: Harris map"))
    if data.periods > 1:
        paths.append(_hunting_plot(data, src.case.pair.teeth, out / f"mesh_hunting{suffix}.png",
                                   f"{name}: over the hunting period"))
    if data.n_slices > 1:
        paths.append(_pattern_plot(data, out / f"mesh_contact_pattern{suffix}.png",
                                   f"{name}: contact pattern at {data.torque:g} N·m"))
    return paths


def parameter_study_plot(values: list, branches: list, meshes: list, nvhs: list, key: str,
                         path: Path, element: int = 0) -> Path:
    """A micro-geometry study (:mod:`study.studies.microgeometry`): the mesh-load std of
    element ``element`` (the studied mesh) against speed for each value (its grazing
    points as diamonds), the LTCA's STE peak-to-peak and the largest mesh-load std against
    the value, and (FE scenes) the housing's total ERP against speed."""
    erp = [n is not None and n.erp is not None for n in nvhs]
    n_panels = 3 if any(erp) else 2
    fig, axes = plt.subplots(n_panels, 1, figsize=(8, 3.3 * n_panels))
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    label = key.split(".")[-1]
    ax = axes[0]
    for j, (v, br) in enumerate(zip(values, branches, strict=True)):
        col = colours[j % len(colours)]
        cur = br.element(element)
        std = cur.mesh_load_std
        ax.plot(br.rpm, std, color=col, lw=1.2, label=f"{label} = {v}")
        g = sorted(cur.grazing, key=lambda p: p.rpm)
        if g:
            ax.plot([p.rpm for p in g], np.interp([p.rpm for p in g], br.rpm, std), "D",
                    ms=5, mfc="white", mec=col)
    ax.set_xlabel("shaft speed Ω (rpm)")
    ax.set_ylabel("std of dynamic mesh load (N)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    ax.set_title(f"micro-geometry study: {key} (diamonds: grazing)")
    ax = axes[1]
    x = np.arange(len(values))
    ste = [np.ptp(m.mesh_cycle("ste")) * 1e6 if (m is not None and m.has_ltca) else np.nan
           for m in meshes]
    ax.plot(x, ste, "o-", color="tab:blue", label="LTCA STE peak-to-peak (µm)")
    ax.set_ylabel("STE peak-to-peak (µm)", color="tab:blue")
    ax.set_ylim(bottom=0)
    ax2 = ax.twinx()
    ax2.plot(x, [br.element(element).mesh_load_std.max() for br in branches], "s--",
             color="tab:red", label="largest mesh-load std (N)")
    ax2.set_ylabel("largest mesh-load std (N)", color="tab:red")
    ax2.set_ylim(bottom=0)
    ax.set_xticks(x, [str(v) for v in values])
    ax.set_xlabel(key)
    ax.grid(alpha=0.3)
    if n_panels == 3:
        ax = axes[2]
        for j, (v, br, n) in enumerate(zip(values, branches, nvhs, strict=True)):
            if n is not None and n.erp is not None:
                ax.plot(br.rpm, n.erp_total_db, color=colours[j % len(colours)], lw=1.2,
                        label=f"{label} = {v}")
        ax.set_xlabel("shaft speed Ω (rpm)")
        ax.set_ylabel("total ERP (dB re 1 pW)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    return save_figure(fig, path)
