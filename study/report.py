"""``report.md``: the figures and key numbers of a run."""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from geometry.files import atomic_write
from hbm.stability import KINDS
from study.attractors import attractor_line
from study.curves import UnstableSegment, unstable_segments
from study.fields import velocity_level_db
from study.plot_common import contact_intervals, order_label

__all__ = ["summary", "write_report"]

_CLASS = ("permanent contact", "single-sided impacts", "double-sided impacts")


def summary(result) -> dict:
    """Key numbers of a run (SI / rpm)."""
    br = result.branch
    i = int(np.argmax(br.mesh_load_std))
    return {
        "points": len(br), "status": br.status, "max_residual": float(np.max(br.residual)),
        "max_mesh_load_std": float(br.mesh_load_std[i]), "at_rpm": float(br.rpm[i]),
        "grazing": [(g.rpm, g.kind, g.side) for g in br.grazing],
        "folds": [float(f) for f in br.folds],
        "classes": {int(c): int(np.sum(br.contact == c)) for c in np.unique(br.contact)},
        "unstable_points": int(np.sum(~br.stable.astype(bool))),
        "unstable_kinds": {KINDS[k]: int(np.sum(br.floquet_kind == k))
                           for k in range(1, len(KINDS)) if np.any(br.floquet_kind == k)},
        "unresolved_rpm": [float(r) for r in br.rpm[~br.stability_consistent.astype(bool)]],
        "unstable_segments": unstable_segments(br.rpm, br.mesh_load_std, br.stable,
                                               br.floquet_kind),
        "intervals": contact_intervals(br.rpm, br.contact),
    }


def _unresolved(rpm: list[float]) -> list[str]:
    """Report lines for points whose stability the harmonic set does not resolve."""
    if not rpm:
        return []
    return [f"- **stability not resolved at {len(rpm)} points** ({min(rpm):.1f}–{max(rpm):.1f} "
            "rpm): the branch lies between two folds of the harmonic balance there (reported "
            "unstable) but the variational equation finds the orbit stable, so the harmonic "
            "set does not resolve the orbit; raise `hbm.mesh_harmonics` / `sideband_order` "
            "(docs/convergence.md)"]


#: what the machine does where the periodic orbit is unstable, per leading kind
_MEANING = {
    "fold": "the middle part of an amplitude jump",
    "period_doubling": "a response at half the fundamental frequency takes over (not "
                       "computed: the harmonic set holds multiples of the fundamental only)",
    "neimark_sacker": "a quasi-periodic response or another, coexisting periodic one takes "
                      "over (not computed)",
    "unclassified": "unstable, kind not recorded",
}


def unstable_lines(segments: list[UnstableSegment], found: list | None = None) -> list[str]:
    """Report lines for the unstable segments of a branch and what each kind means, with
    the time response at each where computed (``found``: :class:`study.attractors.Attractor`
    per segment)."""
    if not segments:
        return []
    how = ("below each, the time response from its most unstable orbit" if found else
           "to see its response, integrate in time from the orbit: `[outputs] "
           "attractor_transient_turns`")
    out = ["- unstable segments (branch order; the curve shows the periodic orbit, which the "
           f"machine leaves there; {how}; docs/theory.md §11 and §13.5):"]
    at = {a.segment: a for a in found or []}         # segments are frozen: equal by value
    for u in segments:
        out.append(f"  - {u.rpm[0]:.1f}–{u.rpm[1]:.1f} rpm, {u.points} points, std up to "
                   f"{u.peak_std:.4g} N: {u.label}, {_MEANING[u.kind]}")
        if u in at:
            out.append(attractor_line(at[u]))
    return out


def _loops(br) -> list[str]:
    """Report lines for the closed loops of the branch (kept, marked in results.h5)."""
    out = []
    for j, (first, last, entry, _) in enumerate(getattr(br, "loops", [])):
        rpm = br.rpm[int(first):int(last) + 1]
        out.append(f"- closed loop {j + 1}: {int(last) - int(first) + 1} points, "
                   f"{rpm.min():.2f}–{rpm.max():.2f} rpm (the branch went round it and came "
                   f"back onto its own path; kept, `continuation/loop` = {j + 1}); the curve "
                   f"goes on from its entry point at {br.rpm[int(entry)]:.2f} rpm")
    return out


def write_report(result) -> Path:
    """Write ``<out>/report.md`` atomically and return its path."""
    s, sc = summary(result), result.scene
    g = sc.gear
    lines = [f"# {sc.name}", "", sc.scene.description or "", "",
             "## Model", "",
             f"- kind: {sc.scene.kind}; {result.problem.system.n_dof} DOF, condensation "
             f"`{result.problem.condensation}`",
             f"- gears: Z = {g.teeth}, r_b = {g.base_radius * 1e3:.3f} mm, α = "
             f"{np.degrees(g.pressure_angle):.1f}°, b_f = {g.face_width * 1e3:.1f} mm, "
             f"ε_α = {g.contact_ratio:.3f}",
             f"- torque T = {sc.load.torque:g} N·m, static load F_s = {sc.static_load:.2f} N, "
             f"half backlash b = {g.backlash * 1e6:g} µm",
             f"- mean mesh stiffness {sc.mesh_stiffness.mean / 1e6:.1f} N/µm, "
             f"{len(sc.mesh_stiffness.amplitudes)} harmonics; TE ({sc.transmission_error.kind}) "
             f"{len(sc.transmission_error.amplitudes)} harmonics",
             f"- damping ξ = {sc.damping.modal_ratio:g}; harmonic set: "
             f"{result.problem.harmonics.n_harmonics} indices of the "
             f"{result.problem.harmonics.fundamental} frequency, "
             f"{result.problem.harmonics.n_time} AFT samples",
             "", "## Continuation", "",
             f"- {s['points']} points from {sc.continuation.speed[0]:g} to "
             f"{sc.continuation.speed[1]:g} rpm, status `{s['status']}`",
             *([] if s["status"] == "completed" else [
                 f"- **incomplete curve**: the continuation stopped at "
                 f"{result.branch.rpm[-1]:.1f} rpm before {sc.continuation.speed[1]:g} rpm: "
                 f"{result.branch.message}"]),
             *_loops(result.branch),
             f"- largest relative residual {s['max_residual']:.2e} "
             f"(tolerance {sc.continuation.tolerance:g})",
             f"- largest std of the dynamic mesh load {s['max_mesh_load_std']:.4g} N at "
             f"{s['at_rpm']:.1f} rpm",
             "- points per class: " + ", ".join(f"{_CLASS[c]} {n}" for c, n in
                                                 s["classes"].items()),
             f"- unstable points: {s['unstable_points']}"
             + (" (" + ", ".join(f"{k.replace('_', ' ')} {n}" for k, n in
                                 s["unstable_kinds"].items()) + ")" if s["unstable_kinds"] else "")
             + " — Floquet exponents of the variational equation, every mode",
             *unstable_lines(s["unstable_segments"], result.attractors),
             *_unresolved(s["unresolved_rpm"]),
             "- folds (jumps) near: " + (", ".join(f"{f:.1f}" for f in s["folds"]) or "none")
             + " rpm", "", "### Grazing bifurcations", "",
             "| rpm | kind | flank |", "|---:|---|---|"]
    lines += [f"| {r:.2f} | {k} | {sd} |" for r, k, sd in s["grazing"]] or ["| – | – | – |"]
    lines += ["", "### Speed ranges with impacts (rpm)", ""]
    for c, iv in s["intervals"].items():
        txt = ", ".join(f"{a:.1f}–{b:.1f}" for a, b in iv) or "none"
        lines.append(f"- {_CLASS[c]}: {txt}")
    nvh = getattr(result, "nvh", None)
    if nvh is not None and nvh.erp is not None and len(result.branch):

        br = result.branch
        tot = nvh.erp_total_db
        i = int(np.argmax(tot))
        j = int(np.argmax(nvh.erp[i]))
        lines += ["", "## Noise (equivalent radiated power of the housing)", "",
                  f"- ERP from {tot.min():.1f} to {tot.max():.1f} dB re 1 pW (ρ = "
                  f"{nvh.rho:g} kg/m³, c = {nvh.c:g} m/s, radiation efficiency 1); loudest at "
                  f"{br.rpm[i]:.1f} rpm, dominated by order "
                  f"{order_label(nvh.orders[j], sc.gear.teeth)} ({nvh.erp_db[i, j]:.1f} dB)",
                  "- curves per point: `curves.csv`; per order: `/nvh` in results.h5"]
        if nvh.accel_velocity is not None:
            lv = velocity_level_db(nvh.accel_velocity)
            lines += [f"- accelerometer `{n}`: velocity level up to {lv[a].max():.1f} dB re "
                      f"1 nm/s (at {br.rpm[int(np.argmax(lv[a]))]:.1f} rpm)"
                      for a, n in enumerate(nvh.accel_names)]
    lines += ["", "## Stages", ""]
    lines += [f"- {k}: {v}" for k, v in result.stages.items()]
    lines += ["", "## Figures", ""]
    out = Path(result.out)
    for p in result.figures:
        p = Path(p)
        if p.suffix == ".png":
            lines += [f"![{p.stem}]({os.path.relpath(p, out)})", ""]
        else:
            lines += [f"- [{p.name}]({os.path.relpath(p, out)})"]
    path = out / "report.md"
    with atomic_write(path, "w") as f:
        f.write("\n".join(lines) + "\n")
    return path
