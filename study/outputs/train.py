"""Outputs of a gear train (several meshes): the names of its orders (every shaft's speed
and every mesh's harmonics and their combinations, in the drive shaft's orders), and the
per-mesh sections of report.md.

An order of a train's response is a rational multiple of the drive speed Ω: a mesh
frequency ``Z_1 ρ_1`` (exact), its harmonics and the combinations the meshes' products
create, or a shaft's speed ρ_s. :func:`order_names` names each order of a set by its
simplest combination (``stage1``, ``2 stage2``, ``stage1 − stage2``; a shaft's
``input ×1``); :func:`mesh_report_lines` writes the per-mesh tables of report.md.
"""
from __future__ import annotations

import itertools
from fractions import Fraction

import numpy as np

__all__ = ["train_frequencies", "order_names", "order_name", "mesh_report_lines"]

_CLASS = ("permanent contact", "single-sided impacts", "double-sided impacts")


def train_frequencies(result) -> tuple[list[tuple[str, Fraction]], list[tuple[str, Fraction]]]:
    """(meshes, shafts): ``(name, frequency over Ω)`` of every gear mesh of the problem
    (``Z ρ``, exact) and every shaft of the scene's machine (ρ_s)."""
    from machines import machine_for

    meshes = [(el.name, el.n_teeth * Fraction(el.speed_ratio))
              for el in result.problem.elements if hasattr(el, "n_teeth")]
    shafts = [(s.name, Fraction(s.speed_ratio)) for s in machine_for(result.scene).shafts]
    return meshes, shafts


def _term(k: int, name: str) -> str:
    return name if k == 1 else f"{k} {name}"


def order_names(meshes, shafts, max_harmonic: int = 8, max_shaft_order: int = 4
                ) -> dict[Fraction, str]:
    """``{order: name}`` for every combination ``Σ m_e f_e`` of the distinct mesh
    frequencies with ``|m_e| <= max_harmonic`` (the simplest, smallest ``Σ|m_e|``, kept),
    and the shaft orders ``k ρ_s`` (``input ×k``, ``k <= max_shaft_order``) where no mesh
    combination has that order."""
    distinct: dict[Fraction, str] = {}
    for name, f in meshes:
        distinct.setdefault(Fraction(f), name)
    freqs = list(distinct.items())
    best: dict[Fraction, tuple[int, str]] = {}
    for ms in itertools.product(range(-max_harmonic, max_harmonic + 1), repeat=len(freqs)):
        o = sum((m * f for m, (f, _) in zip(ms, freqs, strict=True)), Fraction(0))
        if o <= 0:
            continue
        cost = sum(abs(m) for m in ms)
        parts = [("− " if m < 0 else "+ ") + _term(abs(m), name)
                 for m, (_, name) in sorted(zip(ms, freqs, strict=True),
                                            key=lambda t: t[0] < 0) if m]
        label = " ".join(parts).removeprefix("+ ")
        if o not in best or cost < best[o][0]:
            best[o] = (cost, label)
    out = {o: label for o, (_, label) in best.items()}
    for name, rho in shafts:
        for k in range(1, max_shaft_order + 1):
            out.setdefault(k * Fraction(rho), f"{name} ×{k}")
    return out


def order_name(order, names: dict[Fraction, str]) -> str:
    """The name of ``order`` (a Fraction, or a float matched to 1e-9) in ``names``, else
    the order as a number (``×1.2345``)."""
    if isinstance(order, Fraction) and order in names:
        return names[order]
    x = float(order)
    for o, label in names.items():
        if abs(float(o) - x) <= 1e-9 * max(1.0, abs(x)):
            return label
    return f"×{x:.5g}"


def _speed_ranges(rpm: np.ndarray, mask: np.ndarray) -> str:
    """``a–b, c–d`` rpm of the runs of ``mask``."""
    runs, start = [], None
    for i, m in enumerate(mask):
        if m and start is None:
            start = i
        if (not m or i == len(mask) - 1) and start is not None:
            end = i if m else i - 1
            runs.append(f"{rpm[start]:.0f}–{rpm[end]:.0f}")
            start = None
    return ", ".join(runs) or "none"


def mesh_report_lines(result) -> list[str]:
    """report.md's sections of a train: the meshes (gears, ratio, frequency, static load,
    stiffness, backlash, phase) and, per mesh along the branch, the mesh-load std, max and
    peak-to-peak, the contact classes, the grazing bifurcations (onset/disappearance,
    flank) and the impacts per mesh period (IPP) at the time-series speeds."""
    from machines import machine_for

    sc, br, pb = result.scene, result.branch, result.problem
    layout = machine_for(sc).layout
    nvh = getattr(result, "nvh", None)
    lines = ["## Meshes", "",
             "| mesh | gears (Z₁:Z₂) | mesh order (of the drive) | F_s (N) | k̄ (N/µm) | "
             "b (µm) | ε_α | phase at t = 0 |", "|---|---|---:|---:|---:|---:|---:|---|"]
    for m, sm in zip(layout.meshes, sc.meshes, strict=True):
        src = sm.source.stiffness if sm.source is not None else "fourier"
        iso = {"ltca": " (LTCA)", "table": " (table)"}.get(
            src, " (ISO 6336)" if sm.mesh_stiffness.estimated else "")
        lines.append(
            f"| {m.name} | {m.gears[0]}:{m.gears[1]} ({m.teeth[0]}:{m.teeth[1]}) | "
            f"{m.frequency_ratio} = {float(m.frequency_ratio):.5g} | {m.static_load:.1f} | "
            f"{sm.mesh_stiffness.mean / 1e6:.1f}{iso}"
            f" | {m.backlash * 1e6:g} | {m.pair.transverse_contact_ratio:.3f} | "
            f"{np.degrees(m.phase):.2f}° ({m.phase_source}) |")
    lines += ["", "- shafts: " + ", ".join(
        f"{s.name} at ({s.centre[0] * 1e3:.2f}, {s.centre[1] * 1e3:.2f}) mm, speed ×"
        f"{s.speed_ratio} ({'+' if s.sense > 0 else '−'}z)" for s in layout.shafts),
        f"- hunting fundamental {layout.hunting_fundamental()} of the drive speed; basis "
        f"{'periodic' if pb.harmonics.periodic else 'torus'}: {pb.harmonics.n_harmonics} "
        f"harmonics, {np.prod(pb.harmonics.n_time)} AFT samples"]
    if not pb.harmonics.periodic:
        lines.append("- stability: not computed on a torus (docs/theory.md §14.2)")
    lines += _source_lines(result)
    if not len(br):
        return lines
    lines += ["", "### Per mesh along the branch", "",
              "| mesh | max mesh-load std (N) at rpm | max mesh load (N) | max peak-to-peak "
              "(N) | points per contact class |", "|---|---:|---:|---:|---|"]
    for e, m in enumerate(layout.meshes):
        cur = br.element(e)
        i = int(np.argmax(cur.mesh_load_std))
        ptp = "–" if nvh is None or nvh.ptp_per_mesh is None else \
            f"{float(np.max(nvh.ptp_per_mesh[:, e])):.1f}"
        classes = ", ".join(f"{_CLASS[int(c)]} {int(np.sum(cur.contact == c))}"
                            for c in np.unique(cur.contact))
        lines.append(f"| {m.name} | {cur.mesh_load_std[i]:.1f} at {br.rpm[i]:.0f} | "
                     f"{float(np.max(cur.mesh_load_max)):.1f} | {ptp} | {classes} |")
    lines += ["", "### Contact per mesh (rpm)", ""]
    for e, m in enumerate(layout.meshes):
        cur = br.element(e)
        for c in (1, 2):
            lines.append(f"- {m.name}, {_CLASS[c]}: "
                         f"{_speed_ranges(br.rpm, np.asarray(cur.contact) == c)}")
    lines += ["", "### Grazing bifurcations per mesh", "", "| mesh | rpm | kind | flank |",
              "|---|---:|---|---|"]
    rows = [f"| {layout.meshes[g.element].name} | {g.rpm:.2f} | "
            f"{'onset' if g.kind == 'onset' else 'disappearance'} | {g.side} |"
            for g in sorted(br.grazing, key=lambda g: (g.element, g.rpm))]
    lines += rows or ["| – | – | – | – |"]
    ipp = br.stats.get("ipp")
    if ipp is not None:
        from study.outputs.points import nearest_point, time_series_speeds

        lines += ["", "### Impacts per mesh period (IPP) at the time-series speeds", "",
                  "| rpm | " + " | ".join(m.name for m in layout.meshes) + " |",
                  "|---:|" + "---|" * len(layout.meshes)]
        for rpm in time_series_speeds(result):
            i, pt = nearest_point(result, rpm)
            cells = []
            for e in range(len(layout.meshes)):
                seq = np.asarray(br.element(e).ipp[i]).ravel()
                seq = seq[seq >= 0] if seq.dtype.kind in "iu" else seq[np.isfinite(seq)]
                cells.append(" ".join(str(int(v)) for v in seq[:24]) or "–")
            lines.append(f"| {pt.rpm:.1f} | " + " | ".join(cells) + " |")
    return lines


def _source_lines(result) -> list[str]:
    """The ``ltca``/``table`` sources of the meshes that have one
    (:func:`study.outputs.mesh_excitation.source_lines`, arrays in
    ``/elements/<i>/mesh_excitation``)."""
    from study.outputs.mesh_excitation import source_lines

    names = [el.name for el in result.problem.elements]
    per_mesh = getattr(result, "train_excitations", None) or {}
    out = []
    for m in result.scene.meshes:
        if m.source is not None:
            out += source_lines(m.source, per_mesh.get(m.name),
                                f"/elements/{names.index(m.name)}/mesh_excitation", m.name)
    return out
