"""``report.md``: the figures and key numbers of a run."""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from core.files import atomic_write
from hbm.post.tangles import Tangle, branch_tangles
from hbm.stability import KINDS
from study.outputs.acoustics import velocity_level_db
from study.outputs.attractors import attractor_line
from study.outputs.checks import banner_lines, check_lines
from study.outputs.curves import (
    UnstableSegment,
    contact_intervals,
    kind_label,
    kind_name,
    unstable_segments,
)
from study.outputs.verdict_checks import verdict_check_lines

__all__ = ["summary", "write_report"]

_CLASS = ("permanent contact", "single-sided impacts", "double-sided impacts")


def summary(result) -> dict:
    """Key numbers of a run (SI / rpm)."""
    br = result.branch
    mesh = br.element(0)
    i = int(np.argmax(mesh.mesh_load_std))
    return {
        "points": len(br), "status": br.status, "max_residual": float(np.max(br.residual)),
        "max_mesh_load_std": float(mesh.mesh_load_std[i]), "at_rpm": float(br.rpm[i]),
        "grazing": [(g.rpm, g.kind, g.side) for g in mesh.grazing],
        "folds": [float(f) for f in br.folds],
        "classes": {int(c): int(np.sum(mesh.contact == c)) for c in np.unique(mesh.contact)},
        "unstable_points": int(np.sum(~br.stable.astype(bool))),
        "unstable_kinds": {KINDS[k]: int(np.sum(br.floquet_kind == k))
                           for k in range(1, len(KINDS)) if np.any(br.floquet_kind == k)},
        "unresolved_rpm": [float(r) for r in br.rpm[~br.stability_consistent.astype(bool)]],
        "grazing_rpm": [float(r) for r in br.rpm[np.asarray(br.stability_grazing, dtype=bool)]],
        "nan_exponent_rpm": [float(r) for r in br.rpm[np.isnan(br.floquet_max_real)
                                                       & (br.floquet_kind > 0)]],
        "amplification": _largest_amplification(br),
        "tangles": branch_tangles(br),
        "unstable_segments": unstable_segments(br.rpm, mesh.mesh_load_std, br.stable,
                                               br.floquet_kind),
        "intervals": contact_intervals(br),
        "max_std_kind": "" if br.stable[i] else kind_label(kind_name(int(br.floquet_kind[i]))),
        "max_stable": _largest_stable(br),
    }


#: Transient amplification over one period above which report.md names it.
AMPLIFICATION_REPORTED = 10.0


def _largest_amplification(br) -> tuple[float, float, bool] | None:
    """(amplification, rpm, True) of the stable point with the largest transient
    amplification over one period (on an unstable orbit it is mostly the growing
    multiplier, ``e^{lambda T}``, up to 1e13 on the shipped pump), None when none was
    computed."""
    amp = np.where(np.asarray(br.stable, dtype=bool),
                   np.asarray(br.floquet_amplification, dtype=float), np.nan)
    if not np.isfinite(amp).any():
        return None
    j = int(np.nanargmax(amp))
    return float(amp[j]), float(br.rpm[j]), True


def _largest_stable(br) -> tuple[float, float] | None:
    """(std N, rpm) of the branch's largest stable orbit, None if none is stable."""
    ok = np.flatnonzero(br.stable.astype(bool))
    if not ok.size:
        return None
    std = br.element(0).mesh_load_std
    j = ok[int(np.argmax(std[ok]))]
    return float(std[j]), float(br.rpm[j])


def _largest_line(s: dict, stability: bool) -> str:
    """The curve's largest std, and when that orbit is unstable, the largest stable one."""
    line = f"- largest std of the dynamic mesh load {s['max_mesh_load_std']:.4g} N at " \
           f"{s['at_rpm']:.1f} rpm"
    if not stability or not s["max_std_kind"]:
        return line
    best = s["max_stable"]
    other = "no orbit of the curve is stable" if best is None else \
        f"the largest stable one is {best[0]:.4g} N at {best[1]:.1f} rpm"
    return f"{line}, **an unstable orbit** ({s['max_std_kind']}): {other}"


def _stability_lines(s: dict, stability: bool, attractors, periodic: bool = True,
                     secondary=None, checks=None, mesh_harmonics: int = 0) -> list[str]:
    """Report lines on the Floquet verdicts, or that none were computed."""
    if not periodic:
        return ["- stability: **not computed on a torus** (a quasi-periodic response has no "
                "monodromy matrix; docs/theory.md §14.2): no verdict on any point"]
    if not stability:
        return ["- stability: **not computed** (`[hbm] stability = false`): every point is "
                "listed as stable without a check"]
    kinds = ", ".join(f"{kind_label(k)} {n}" for k, n in s["unstable_kinds"].items())
    return [f"- unstable points: {s['unstable_points']}" + (f" ({kinds})" if kinds else "")
            + " — Floquet exponents of the variational equation, every mode",
            *unstable_lines(s["unstable_segments"], attractors, secondary),
            *_unresolved(s["unresolved_rpm"]), *_near_grazing(s["grazing_rpm"]),
            *_not_computed(s["nan_exponent_rpm"]), *_amplification(s["amplification"]),
            *tangle_lines(s.get("tangles", [])), *verdict_check_lines(checks, mesh_harmonics)]


def tangle_lines(tangles: list[Tangle]) -> list[str]:
    """Report lines for the near-grazing tangles of a branch."""
    if not tangles:
        return []
    out = [f"- **{len(tangles)} near-grazing tangle{'' if len(tangles) == 1 else 's'}**: "
           "the branch folds three times or more within 0.1 % of the speed, on the steep "
           "flank or at the top of a resonance where the contact pattern changes (on a flank "
           "one mesh cycle at a time). Its pieces are solutions of the harmonic balance, "
           "each with its verdict, and the stable points in and next to it are checked on a "
           "richer harmonic set (below); the machine crosses a tangle as one jump "
           "(docs/theory.md §11, near-grazing tangles):"]
    for t in tangles:
        change = (f", contact-loss intervals per period change by {t.contact_changes}"
                  if t.contact_changes else ", no change of the contact-loss count")
        out.append(f"  - {t.rpm_min:.3f}–{t.rpm_max:.3f} rpm: {t.n_folds} folds over "
                   f"{t.last - t.first + 1} points, {t.n_stable} of them stable{change}")
    return out


def _rpm_list(rpm: list[float]) -> str:
    n = f"{len(rpm)} point{'' if len(rpm) == 1 else 's'}"
    return f"{n} ({min(rpm):.2f}–{max(rpm):.2f} rpm)"


def _near_grazing(rpm: list[float]) -> list[str]:
    """Report lines for verdicts unresolved near grazing."""
    if not rpm:
        return []
    return [f"- **verdict unresolved near grazing at {_rpm_list(rpm)}**: the orbit comes "
            "within its own error estimate of a flank, and shifting it by that much opens or "
            "closes a contact interval and changes the sign of the leading Floquet exponent "
            "(or the branch's fold parity contradicts it): the verdict written there may be "
            "wrong; check with a time integration (docs/theory.md §11, near grazing)"]


def _not_computed(rpm: list[float]) -> list[str]:
    """Report lines for unstable points whose exponent was not computed (NaN)."""
    if not rpm:
        return []
    return [f"- exponent **not computed** (NaN in `floquet_max_real`) at {_rpm_list(rpm)}: "
            "the branch puts these points between two folds (unstable, a fold) within "
            "round-off of a turn, where no positive real exponent can be located"]


def _amplification(amp) -> list[str]:
    """Report line for a large transient amplification over one period of a stable orbit."""
    if amp is None or amp[0] < AMPLIFICATION_REPORTED:
        return []
    return [f"- largest transient amplification over one period of a stable orbit "
            f"{amp[0]:.3g}× at {amp[1]:.1f} rpm: a disturbance can grow that much in energy "
            "norm within one period although every Floquet multiplier is inside the unit "
            "circle (largest singular value of the monodromy; `floquet_amplification`)"]


def _unresolved(rpm: list[float]) -> list[str]:
    """Report lines for points whose stability the harmonic set does not resolve."""
    if not rpm:
        return []
    n = f"{len(rpm)} point{'' if len(rpm) == 1 else 's'}"
    return [f"- **stability not resolved at {n}** ({min(rpm):.1f}–{max(rpm):.1f} "
            "rpm): the branch lies between two folds of the harmonic balance there (reported "
            "unstable) but the variational equation finds the orbit stable, so the harmonic "
            "set does not resolve the orbit; raise `hbm.mesh_harmonics` / `sideband_order` "
            "(where the branch winds this may not help: docs/convergence.md)"]


#: what the machine does where the periodic orbit is unstable, per leading kind
_MEANING = {
    "fold": "the middle part of an amplitude jump",
    "period_doubling": "a response at half the fundamental frequency takes over",
    "neimark_sacker": "a quasi-periodic response or another, coexisting periodic one takes "
                      "over",
    "unclassified": "unstable, kind not recorded",
}


def _what_computed(kind: str, lo: float, hi: float, secondary, found: bool) -> str:
    """What the run computed of the response that takes over on ``lo``–``hi`` rpm: the
    period-k branches (``secondary``, :class:`hbm.branching.SecondaryBranch`) over that
    range at a period doubling, the time responses below it (``found``), or why none."""
    if kind == "period_doubling":
        over = [s for s in secondary or ()
                if len(s.branch) and min(s.branch.rpm) <= hi and max(s.branch.rpm) >= lo]
        if over:
            return (" (computed: " + ", ".join(f"`{s.name}`" for s in over)
                    + ", section \"Period doubling\")")
        return (" (not computed: `[continuation] period_doubling_depth = 0`, or no period-2 "
                "branch found over this range: see section \"Period doubling\" or the log)"
                if not found else "")
    if kind == "neimark_sacker" and not found:
        return " (not computed: `[outputs] attractor_transient_turns`)"
    return ""


def unstable_lines(segments: list[UnstableSegment], found: list | None = None,
                   secondary=None) -> list[str]:
    """Report lines for the unstable segments of a branch and what each kind means, with
    the time response at each where computed (``found``: :class:`study.outputs.attractors.Attractor`
    per segment) and the period-k branches over each period-doubling segment
    (``secondary``: :class:`hbm.branching.SecondaryBranch`)."""
    if not segments:
        return []
    how = ("below each, the time response from its most unstable orbit (or from "
           "`attractor_speeds_per_segment` orbits across it) and what the machine does "
           "there" if found else
           "to see its response, integrate in time from the orbit: `[outputs] "
           "attractor_transient_turns`")
    out = ["- unstable segments (branch order; the curve shows the periodic orbit, which the "
           f"machine leaves there; {how}; docs/theory.md §11 and §13.5):"]
    at: dict = {}                       # segments are frozen: equal by value
    for a in found or []:
        at.setdefault(a.segment, []).append(a)
    for group in _winding_groups(segments):
        lo, hi = min(g.rpm[0] for g in group), max(g.rpm[1] for g in group)
        pts, top = sum(g.points for g in group), max(g.peak_std for g in group)
        if len(group) == 1:
            u = group[0]
            out.append(f"  - {lo:.1f}–{hi:.1f} rpm, {pts} point{'' if pts == 1 else 's'}, "
                       f"std up to {top:.4g} N: {u.label}, {_MEANING[u.kind]}"
                       + _what_computed(u.kind, lo, hi, secondary, u in at))
        else:
            kinds = {g.kind: g.label for g in group}
            count = ", ".join(f"{label} {sum(g.points for g in group if g.kind == k)}"
                              for k, label in kinds.items())
            out.append(f"  - {lo:.1f}–{hi:.1f} rpm, where the branch winds: {pts} points in "
                       f"{len(group)} segments ({count}), std up to {top:.4g} N; "
                       + "; ".join(f"{label}: {_MEANING[k]}"
                                   + _what_computed(k, lo, hi, secondary,
                                                    any(g in at for g in group))
                                   for k, label in kinds.items()))
        out += [attractor_line(a) for g in group for a in at.get(g, [])]
    return out


#: speeds closer than this (relative) are one place of the curve in report.md
_NEAR = 2e-3


def _winding_groups(segments: list[UnstableSegment]) -> list[list[UnstableSegment]]:
    """Consecutive segments (branch order), grouped while together they span less than
    :data:`_NEAR` of the speed: a group of several is where the branch winds (one line)."""
    groups: list[list[UnstableSegment]] = []
    for u in segments:
        if groups:
            lo = min(u.rpm[0], *(g.rpm[0] for g in groups[-1]))
            hi = max(u.rpm[1], *(g.rpm[1] for g in groups[-1]))
            if hi - lo <= _NEAR * hi:
                groups[-1].append(u)
                continue
        groups.append([u])
    return groups


def _folds_text(folds: list[float]) -> str:
    """Fold speeds in branch order; three or more within :data:`_NEAR` of the speed of
    each other (the branch winding) as one range with their count."""
    if not folds:
        return "none"
    runs: list[list[float]] = []
    for f in folds:
        if runs and max(*runs[-1], f) - min(*runs[-1], f) <= _NEAR * max(*runs[-1], f):
            runs[-1].append(f)
        else:
            runs.append([f])
    parts = []
    for r in runs:
        if len(r) < 3:
            parts += [f"{x:.1f}" for x in r]
        else:
            span = f"{min(r):.1f}" if f"{min(r):.1f}" == f"{max(r):.1f}" else \
                f"{min(r):.1f}–{max(r):.1f}"
            parts.append(f"{span} ({len(r)} folds)")
    return ", ".join(parts) + " rpm"


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


def rom_line(result) -> list[str]:
    """Report line on the ROM's check against the full FE model (Fig. 9), beside the
    highest mesh frequency of the run; none for a lumped scene."""
    rd = result.rom
    if rd is None:
        return []
    top = result.scene.continuation.speed[1]
    f_mesh = result.scene.gear.teeth * top / 60.0
    head = f"- ROM: {rd.n_cm} component modes; "
    reach = f"the mesh frequency reaches {f_mesh:.0f} Hz at {top:g} rpm"
    v = rd.validation
    if v is None or len(v.full_hz) == 0:
        return [head + f"**not checked** against the full FE model (`rom.n_check` = 0); {reach}"]
    err, n = np.asarray(v.relative_error), len(v.full_hz)
    bad = np.flatnonzero(err > v.tol)
    if bad.size == 0:
        checked = float(v.full_hz[-1])
        txt = f"its {n} lowest coupled frequencies agree with the full FE model's within " \
              f"{err.max():.1e} (tol {v.tol:g}) up to {checked:.0f} Hz, where the check stops"
    else:
        k = int(bad[0])
        checked = float(v.validity_hz)
        txt = f"**valid only to {checked:.0f} Hz** (tol {v.tol:g}): coupled mode {k + 1} of " \
              f"the {n} checked, {v.full_hz[k]:.0f} Hz in the full FE model, is " \
              f"{err[k]:.1e} off; raise `rom.n_cm`"
    if checked < f_mesh:
        reach += " (above the checked range, `geardyn convergence --only n_cm` measures the " \
                 "ROM's effect on the curve, docs/convergence.md)"
    return [head + txt + "; " + reach]



def _mesh_source_lines(result) -> list[str]:
    """The ``ltca``/``table`` sources of k_m and TE (none for ``fourier`` scenes)."""
    from study.outputs.mesh_excitation import source_lines

    src = result.scene.mesh_source
    if src is None:
        return []
    return source_lines(src, getattr(result, "mesh_excitation", None), "/mesh_excitation")


def _pair_model_lines(result) -> list[str]:
    """The model lines of a one-pair scene: gears, load, mesh, damping, harmonic set."""
    sc = result.scene
    g = sc.gear
    return [f"- gears: Z = {g.teeth}, r_b = {g.base_radius * 1e3:.3f} mm, α = "
            f"{np.degrees(g.pressure_angle):.1f}°, b_f = {g.face_width * 1e3:.1f} mm, "
            f"ε_α = {g.contact_ratio:.3f}",
            f"- torque T = {sc.load.torque:g} N·m, static load F_s = {sc.static_load:.2f} N, "
            f"half backlash b = {g.backlash * 1e6:g} µm",
            f"- mean mesh stiffness {sc.mesh_stiffness.mean / 1e6:.1f} N/µm, "
            f"{len(sc.mesh_stiffness.amplitudes)} harmonics; TE ({sc.transmission_error.kind}) "
            f"{len(sc.transmission_error.amplitudes)} harmonics",
            *_mesh_source_lines(result),
            f"- damping ξ = {sc.damping.modal_ratio:g}; harmonic set: "
            f"{result.problem.harmonics.n_harmonics} indices of the "
            f"{result.problem.harmonics.fundamental} frequency, "
            f"{result.problem.harmonics.n_time} AFT samples"]


def _train_model_lines(result) -> list[str]:
    """The model lines of a train: drive, loads, damping; its meshes follow in their own
    section (:func:`study.outputs.train.mesh_report_lines`)."""
    sc = result.scene
    return [f"- drive: {sc.drive.torque:g} N·m on shaft `{sc.drive.shaft}` (its speed is the "
            "reference Ω); loads: " + ", ".join(f"`{ld.shaft}` ({ld.share:g})"
                                                for ld in sc.loads),
            f"- {len(sc.meshes)} meshes (section Meshes); damping ξ = "
            f"{sc.damping.modal_ratio:g}",
            "- the sections below up to the meshes' are those of the first mesh "
            f"(`{sc.meshes[0].name}`)"]


def write_report(result) -> Path:
    """Write ``<out>/report.md`` atomically and return its path."""
    s, sc = summary(result), result.scene
    checks = list(getattr(result, "checks", []) or [])
    lines = [f"# {sc.name}", "", *banner_lines(checks), sc.scene.description or "", "",
             "## Model", "",
             f"- kind: {sc.scene.kind}; {result.problem.system.n_dof} DOF, condensation "
             f"`{result.problem.condensation}`", *rom_line(result),
             *(_train_model_lines(result) if sc.is_train else _pair_model_lines(result)),
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
             _largest_line(s, sc.hbm.stability and result.problem.periodic),
             "- points per class: " + ", ".join(f"{_CLASS[c]} {n}" for c, n in
                                                 s["classes"].items()),
             *_stability_lines(s, sc.hbm.stability, result.attractors,
                               result.problem.periodic, getattr(result, "secondary", None),
                               getattr(result, "verdict_checks", None),
                               sc.hbm.mesh_harmonics),
             "- folds (jumps) near: " + _folds_text(s["folds"]),
             "", "### Grazing bifurcations", "",
             "| rpm | kind | flank |", "|---:|---|---|"]
    lines += [f"| {r:.2f} | {k} | {sd} |" for r, k, sd in s["grazing"]] or ["| – | – | – |"]
    lines += ["", "### Speed ranges with impacts (rpm)", ""]
    for c, iv in s["intervals"].items():
        txt = ", ".join(f"{a:.1f}–{b:.1f}" for a, b in iv) or "none"
        lines.append(f"- {_CLASS[c]}: {txt}")
    if getattr(result, "secondary", None):
        from hbm.branching import doubling_brackets
        from study.outputs.branches import report_lines

        lines += ["", *report_lines(result.secondary, len(doubling_brackets(result.branch)),
                                    depth=sc.continuation.period_doubling_depth,
                                    seconds=getattr(result, "branches_seconds", None))]
    if sc.is_train:
        from study.outputs.train import mesh_report_lines

        lines += ["", *mesh_report_lines(result)]
    if result.attractors:                # what the machine reaches (bifurcation diagram)
        from study.outputs.bifurcation import response_lines

        lines += ["", *response_lines(result)]
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
                  f"{nvh.order_name(j, sc.gear.teeth)} ({nvh.erp_db[i, j]:.1f} dB)",
                  "- curves per point: `curves.csv`; per order: `/nvh` in results.h5"]
        if getattr(result, "secondary", None):
            from study.outputs.branches import erp_lines

            lines += erp_lines(result, s["unstable_segments"])
        if nvh.accel_velocity is not None:
            lv = velocity_level_db(nvh.accel_velocity)
            lines += [f"- accelerometer `{n}`: velocity level up to {lv[a].max():.1f} dB re "
                      f"1 nm/s (at {br.rpm[int(np.argmax(lv[a]))]:.1f} rpm)"
                      for a, n in enumerate(nvh.accel_names)]
    lines += ["", *check_lines(checks)] if checks else []
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
