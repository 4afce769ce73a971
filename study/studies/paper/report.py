"""``paper.md``: the findings of the paper's Sect. 4 beside those of a run.

The paper's figures are the constants of :mod:`~study.studies.paper.findings`, each with
the section and figure it comes from; the run's values are measured from its curves
(:mod:`study.outputs.curves`, :mod:`~study.studies.paper.measure`): the
resonance speeds are the most prominent local maxima of the mesh-load std, the
grazing speeds those located by the continuation, the span the length of the speed
intervals with impacts. Nothing of the run is typed in. Written by
``geardyn excitations`` (:mod:`study.studies.excitations`), the only command that has the
three excitation cases the Sect. 4.2 comparison needs.
"""
from __future__ import annotations

import logging
from pathlib import Path
from typing import NamedTuple

import numpy as np

from core.files import atomic_write
from study.outputs.curves import (
    CurveSummary,
    Peak,
    ipp_fractions,
    ipp_runs,
    is_unstable,
    kind_label,
)
from study.scene.data import Scene
from study.studies.paper.findings import FIGURES, IPP_KEYS, PAPER, TOLERANCE
from study.studies.paper.measure import IppAt, PaperInputs, SpectrumAt, comparison_inputs

logger = logging.getLogger(__name__)

__all__ = ["Row", "paper_markdown", "write_paper", "write_paper_files", "format_ipp",
           "runs_fractions"]


class Row(NamedTuple):
    """One line of the Sect. 4 table: what, the paper's value, the run's, and the
    :data:`PAPER` key it compares (its source, and the scene's ``[calibration]`` entry);
    ``source`` replaces the key's source when the row's yardstick is derived."""

    quantity: str
    paper: str
    run: str
    key: str
    source: str = ""


def _pct(a: float, b: float) -> str:
    return f"{100 * (a - b) / b:+.1f} %"


def _ok(errs: list[float]) -> str:
    return "yes" if errs and max(abs(e) for e in errs) <= TOLERANCE else "no"


def format_ipp(runs) -> str:
    """``contact 14 % → 1-IPP 4 % → …`` for ``[(impacts, fraction), ...]``."""
    def name(n: int) -> str:
        return "contact" if n == 0 else f"{n}-IPP"
    return " → ".join(f"{name(n)} {100 * f:.3g} %" for n, f in runs)


def _fractions_text(fr: dict[int, float]) -> str:
    return ", ".join(f"{'contact' if n == 0 else f'{n}-IPP'} {100 * f:.3g} %"
                     for n, f in sorted(fr.items()))


def _rpms(xs) -> str:
    return ", ".join(f"{x:.0f}" for x in xs) or "none"


def _windows(ws) -> str:
    return ", ".join(f"{a:.0f}–{b:.0f}" for a, b in ws) or "none"


def _orbit_note(*solved) -> str:
    """``; **unstable orbit** …`` for the solutions among ``solved`` (IppAt, SpectrumAt or
    why-not strings) whose Floquet exponents say unstable, else ""."""
    bad = [p for p in solved if isinstance(p, IppAt | SpectrumAt) and is_unstable(p.stability)]
    if not bad:
        return ""
    kinds = ", ".join(f"{p.rpm:.0f} rpm ({kind_label(p.stability)})" for p in bad)
    return f"; **unstable orbit** at {kinds}: the machine leaves it, so this compares " \
           "orbits as the paper computes them (docs/theory.md §13.5)"


def _resonance_rows(inp: PaperInputs) -> list[Row]:
    ref = PAPER["resonances"]
    paper = ref.value
    s = inp.cases.get("all")
    if s is None:
        return [Row("resonance speeds (rpm)", _rpms(paper), "not computed", "resonances")]
    found = s.strongest(len(paper))
    rpm = [p.rpm for p in found]
    ratio_p = " : ".join(f"{x / paper[0]:.2f}" for x in paper)
    if len(rpm) < len(paper):
        txt = f"{_rpms(rpm)} (only {len(rpm)} peaks)"
        return [Row("resonance speeds (rpm)", _rpms(paper), txt, "resonances"),
                Row("resonance ratios", ratio_p, "–", "resonances")]
    errs = [(a - b) / b for a, b in zip(rpm, paper, strict=True)]
    dev = ", ".join(f"{100 * e:+.1f} %" for e in errs)
    ratio_r = " : ".join(f"{x / rpm[0]:.2f}" for x in rpm)
    return [Row(f"resonance speeds (rpm), {len(paper)} most prominent std peaks", _rpms(paper),
                f"{_rpms(rpm)} ({dev}; within 3 %: {_ok(errs)})", "resonances"),
            Row("resonance ratios", ratio_p, ratio_r, "resonances")]


def _grazing_rows(inp: PaperInputs) -> list[Row]:
    g, w = PAPER["grazing"], PAPER["windows"]
    s = inp.cases.get("all")
    if s is None:
        return [Row("grazing speeds (rpm)", _rpms(g.value), "not computed", "grazing")]
    run = s.grazing
    txt = f"{len(run)}: {_rpms(run)}"
    if len(run) == len(g.value):
        errs = [(a - b) / b for a, b in zip(run, g.value, strict=True)]
        txt += f" (within 3 %: {_ok(errs)})"
    return [Row("grazing speeds (rpm), all excitations", f"{len(g.value)}: {_rpms(g.value)}",
                txt, "grazing"),
            Row("permanent-contact windows (rpm)", _windows(w.value), _windows(s.windows),
                "windows")]


def _jumps_text(s: CurveSummary | None, peak: Peak | None, rel: float = 0.15) -> str:
    """The fold pairs of a curve within ``peak.rpm·(1 ± rel)``, or why none."""
    if s is None or peak is None:
        return "not computed"
    near = [f for f in s.folds if abs(f.centre - peak.rpm) <= rel * peak.rpm]
    if not near:
        return f"none within ±{100 * rel:.0f} % of {peak.rpm:.0f} rpm"
    return ", ".join(f"{min(f.rpm):.0f}–{max(f.rpm):.0f} rpm ({f.width:.1f} rpm wide, "
                     f"std {f.std[0]:.1f} / {f.std[1]:.1f} N)" for f in near)


def _peak_stability(s: CurveSummary | None, peak: Peak | None) -> str | None:
    """Why the periodic orbit at ``peak`` is not what the machine does, or None if it
    is stable (or the run computed no stability): the unstable segments there."""
    if s is None or peak is None or not peak.kind:
        return None
    segs = [u for u in s.unstable_at(peak.rpm) if u.kind == peak.kind] or \
        s.unstable_at(peak.rpm)
    if not segs:
        return None
    return ", ".join(f"{u.label} {u.rpm[0]:.0f}–{u.rpm[1]:.0f} rpm"
                     for u in segs)


def _effect_rows(inp: PaperInputs) -> list[Row]:
    pk, sp = PAPER["primary_peak"], PAPER["span_change"]
    a, b = pk.value
    paper_pk = f"{a:g} → {b:g} N ({_pct(b, a)})"
    paper_sp = f"{100 * sp.value:+.0f} %"
    si, sa = inp.cases.get("internal"), inp.cases.get("all")
    pi, pa = inp.primary.get("internal"), inp.primary.get("all")
    if pi is not None and pa is not None:
        run_pk = f"{pi.std:.1f} → {pa.std:.1f} N ({_pct(pa.std, pi.std)}; at {pi.rpm:.0f} → " \
                 f"{pa.rpm:.0f} rpm)"
    else:
        run_pk = "not computed" if si is None or sa is None else "no peak found"
    if si is not None and sa is not None:
        run_pk += f"; largest std of each curve {si.max_std:.1f} → {sa.max_std:.1f} N " \
                  f"({_pct(sa.max_std, si.max_std)}; at {si.max_std_rpm:.0f} → " \
                  f"{sa.max_std_rpm:.0f} rpm)"
    unstable = {c: _peak_stability(inp.cases.get(c), inp.primary.get(c))
                for c in ("internal", "all")}
    if any(unstable.values()):
        run_pk += "; **the periodic orbit at the peak is unstable** (" + "; ".join(
            f"{c}: {v}" for c, v in unstable.items() if v) + "): the machine leaves it " \
            "there, so this row compares orbits the paper's method computes, not the " \
            "machine's response (each case's report.md, docs/theory.md §13.5)"
        mi, ma = inp.machine.get("internal"), inp.machine.get("all")
        if mi is not None and ma is not None:
            run_pk += f"; time integration from the most unstable orbit there: {mi[1]:.1f} " \
                      f"→ {ma[1]:.1f} N ({_pct(ma[1], mi[1])}; from {mi[0]:.0f} → " \
                      f"{ma[0]:.0f} rpm)"
    if si is not None and sa is not None and not (si.complete and sa.complete):
        run_sp = f"{si.span:.0f} → {sa.span:.0f} rpm (incomplete curve: not comparable)"
        run_pk += " (incomplete curve: not comparable)"
    elif si is not None and sa is not None and si.span > 0:
        run_sp = f"{si.span:.0f} → {sa.span:.0f} rpm ({_pct(sa.span, si.span)})"
    elif si is not None and sa is not None:
        run_sp = f"{si.span:.0f} → {sa.span:.0f} rpm (no impacts with internal excitation only)"
    else:
        run_sp = "not computed"
    jp = PAPER["primary_jumps"]
    run_jp = f"internal only: {_jumps_text(si, pi)}; all: {_jumps_text(sa, pa)}"
    return [Row("primary peak, internal only → all", paper_pk, run_pk, "primary_peak"),
            Row("amplitude jumps (fold pairs) at the primary peak", jp.value, run_jp,
                "primary_jumps"),
            Row("vibro-impact span, internal only → all", paper_sp, run_sp, "span_change")]


def _ipp_rows(inp: PaperInputs) -> list[Row]:
    rows = []
    for target, key in IPP_KEYS.items():
        ref = PAPER[key]
        paper = f"{format_ipp(ref.value)} (per count: " \
                f"{_fractions_text(runs_fractions(ref.value))})"
        got = inp.ipp.get(target)
        if got is None:
            run = "not computed"
        elif isinstance(got, str):
            run = got
        else:
            run = f"{format_ipp(ipp_runs(got.ipp))} (per count: " \
                  f"{_fractions_text(ipp_fractions(got.ipp))}; {got.how} at {got.rpm:.1f} rpm, " \
                  f"{got.ipp.size} mesh periods){_orbit_note(got)}"
        rows.append(Row(f"IPP sequence at {target:.0f} rpm, one turn", paper, run, key))
    return rows


def runs_fractions(runs) -> dict[int, float]:
    """Share of the turn at each impact count of ``[(impacts, fraction), ...]`` (the
    paper's IPP sequences, :data:`PAPER`), summed over the runs of that count."""
    out: dict[int, float] = {}
    for n, f in runs:
        out[n] = out.get(n, 0.0) + f
    return out


def _spectrum_rows(inp: PaperInputs) -> list[Row]:
    """Figs. 15–16: what leads the gear response and the mesh load at 6875 rpm, and the
    mesh-load peak-to-peak against 2970 rpm."""
    ref, ref_z, ptp = PAPER["h2_speed"], PAPER["hz_speed"], PAPER["peak_to_peak"]
    hi, lo = inp.spectra.get(ref.value), inp.spectra.get(ref_z.value)
    if not isinstance(hi, SpectrumAt):
        why = hi or "not computed"
        return [Row(f"response at {ref.value:.0f} rpm", "led by H_2 (aero), H_2 ~ mesh "
                    "harmonics", why, "h2_speed")]
    z = hi.teeth
    top_d = hi.largest(dte=True)
    dte = f"at {hi.rpm:.0f} rpm: largest H_{top_d}, {1e6 * hi.at(top_d, True):.3g} µm; " \
          f"H_2 {1e6 * hi.at(2, True):.3g} µm, H_Z {1e6 * hi.at(z, True):.3g} µm"
    h2, hz = hi.at(2), hi.at(z)
    load = f"largest H_{hi.largest()}; H_2 = {h2:.3g} N, H_Z = {hz:.3g} N " \
           f"(H_2/H_Z = {h2 / hz:.2f}" if hz > 0 else f"H_2 = {h2:.3g} N, H_Z = 0 (–"
    if isinstance(lo, SpectrumAt) and lo.at(z) > 0:
        load += f"; at {lo.rpm:.0f} rpm {lo.at(2) / lo.at(z):.2f})"
    else:
        load += ")"
    a, b = ptp.value
    paper_ptp = f"{a:g} → {b:g} N (×{b / a:.2f})"
    if isinstance(lo, SpectrumAt) and lo.peak_to_peak > 0:
        run_ptp = f"{lo.peak_to_peak:.0f} → {hi.peak_to_peak:.0f} N " \
                  f"(×{hi.peak_to_peak / lo.peak_to_peak:.2f}; at {lo.rpm:.0f} → {hi.rpm:.0f} rpm)"
    else:
        why = lo if isinstance(lo, str) else "not computed"
        run_ptp = f"{why} (at {ref_z.value:.0f} rpm); {hi.peak_to_peak:.0f} N " \
                  f"at {hi.rpm:.0f} rpm"
    dte, load = dte + _orbit_note(hi), load + _orbit_note(hi, lo)
    run_ptp += _orbit_note(lo, hi)
    return [Row(f"gear response (DTE, eq. 10) at {ref.value:.0f} rpm, largest harmonic",
                "H_2 (aero): 'the gear response is governed by the second harmonic'", dte,
                "h2_speed"),
            Row(f"mesh-load harmonics at {ref.value:.0f} rpm", "H_2 of the same order as the "
                f"mesh harmonics; H_2 much more prominent than at {ref_z.value:.0f} rpm", load,
                "h2_speed"),
            Row(f"mesh-load peak-to-peak, {ref_z.value:.0f} → {ref.value:.0f} rpm", paper_ptp,
                run_ptp, "peak_to_peak")]


def _modulation_rows(inp: PaperInputs) -> list[Row]:
    """Fig. 15b, d: how strongly the external excitation modulates the response at the
    primary resonance, mesh period by mesh period over a turn."""
    ref_z, il, dm = PAPER["hz_speed"], PAPER["impact_loads"], PAPER["dte_modulation"]
    lo = inp.spectra.get(ref_z.value)
    env = lo.envelope if isinstance(lo, SpectrumAt) else None
    a, b, cycles = il.value
    paper_il = f"{a:g} → {b:g} N ({100 * (b / a - 1):+.0f} %), {cycles} cycles per turn"
    if env is None:
        run_il = run_dm = lo if isinstance(lo, str) else "not computed"
    else:
        per = "turn" if env.peak_load.size == lo.teeth else "fundamental period"
        var = "(no load in some mesh period)" if not np.isfinite(env.load_variation) \
            else f"({100 * env.load_variation:+.0f} %)"
        run_il = f"{env.peak_load.min():.0f} → {env.peak_load.max():.0f} N {var}, " \
                 f"{env.load_cycles} cycle{'' if env.load_cycles == 1 else 's'} per {per} " \
                 f"(at {lo.rpm:.0f} rpm)"
        run_dm = f"{1e6 * env.dte_swing:.3g} µm (H_2 amplitude {1e6 * lo.at(2, True):.3g} µm; " \
                 f"at {lo.rpm:.0f} rpm)"
        run_il, run_dm = run_il + _orbit_note(lo), run_dm + _orbit_note(lo)
        if lo.machine is not None:
            n0, n1, me = lo.machine
            how = f"; the machine (time integration from that orbit, {n0} turns left out, " \
                  f"{n1} analysed):"
            run_il += f"{how} {me.peak_load.min():.0f} → {me.peak_load.max():.0f} N, " \
                      f"{me.load_cycles / n1:.4g} cycles per turn"
            run_dm += f"{how} {1e6 * me.dte_swing:.3g} µm"
    return [Row(f"impact loads at {ref_z.value:.0f} rpm (largest mesh load in each mesh "
                "period, over a turn)", paper_il, run_il, "impact_loads"),
            Row(f"low-frequency DTE modulation at {ref_z.value:.0f} rpm (peak-to-peak of the "
                "DTE's mean in each mesh period)", f"{1e6 * dm.value:g} µm (H_2)", run_dm,
                "dte_modulation")]


def _mode_rows(inp: PaperInputs) -> list[Row]:
    """Fig. 8: the mode with most mesh energy, and how much the mesh stiffens it (T.33)."""
    mm = PAPER["mesh_mode"]
    paper = f"{mm.value[0]:.0f} Hz, ρ = {mm.value[1]:.2f}"
    rows = []
    if inp.mesh_mode is not None:
        f, rho = inp.mesh_mode
        rows.append(Row("mode with most mesh energy", paper, f"{f:.0f} Hz, ρ = {rho:.2f}",
                        "mesh_mode"))
    if inp.reached_mode is not None and inp.reached_mode != inp.mesh_mode:
        f, rho = inp.reached_mode
        rows.append(Row("mode with most mesh energy that the mesh harmonics reach (f ≥ H_Z at "
                        f"the lowest speed, {inp.reached_from:.0f} Hz)", paper,
                        f"{f:.0f} Hz, ρ = {rho:.2f}", "mesh_mode"))
    if inp.softening is not None:
        f, r = inp.softening
        paper_r = (1.0 - mm.value[1] / 2.0) ** 0.5
        rows.append(Row("resonance shift when k̄ is halved, f½/f (T.33: how much of the "
                        "stiffness seen at the mesh the mesh supplies)",
                        f"{paper_r:.2f} if its ρ = {mm.value[1]:.2f} mode were alone (derived, "
                        "not stated)", f"{r:.2f} (dynamic-factor peak {f:.0f} Hz)", "mesh_mode",
                        "docs/theory.md §13.4"))
    return rows


def _table(rows: list[Row], calibration: dict[str, str]) -> list[str]:
    """The Markdown table; with a last column, the scene's ``[calibration]`` per row."""
    head, rule = "| quantity | paper | this run | paper source |", "|---|---|---|---|"
    if calibration:
        head, rule = head + " in this scene |", rule + "---|"
    out = [head, rule]
    for r in rows:
        line = f"| {r.quantity} | {r.paper} | {r.run} | {r.source or PAPER[r.key].source} |"
        if calibration:
            fit = calibration.get(r.key)
            line += f" **calibrated**: {fit} |" if fit else " not fitted |"
        out.append(line)
    return out


def paper_markdown(inp: PaperInputs) -> str:
    """The Sect. 4 table of a run, paper beside result, with sources and, when the scene
    says which findings it was fitted to (``[calibration]``), which rows are not
    predictions."""
    t, fs = PAPER["static_load"].value
    rows = [Row("static mesh load F_s", f"{fs:g} N at T = {t:g} N·m",
                f"{inp.static_load:.1f} N at T = {inp.torque:g} N·m (F_s = T/r_b)",
                "static_load")]
    rows += _mode_rows(inp) + _resonance_rows(inp) + _grazing_rows(inp) + _effect_rows(inp)
    rows += _ipp_rows(inp) + _spectrum_rows(inp) + _modulation_rows(inp)
    fitted = ("The last column is the scene's `[calibration]`: what its parameters were "
              "fitted to, so a **calibrated** row is not a prediction (`not fitted`: the "
              "scene declares no fit to that finding)." if inp.calibration else
              "The scene does not say which findings its parameters were fitted to "
              "(`[calibration]`, docs/scenes.md): agreement here may be by calibration.")
    lines = [f"# {inp.scene}: the paper's Sect. 4 beside this run", "",
             "Paper values are those of the paper's pump (Sect. 4, T = 2.5 N·m, 20 harmonics); "
             "for another scene they are a yardstick only. Run values are measured from the "
             "curves of `geardyn excitations` (resonances: the most prominent local maxima of "
             "the mesh-load std, all excitations; grazings and impact intervals as located by "
             "the continuation; IPP: impacts in each mesh period over one turn; `contact`: "
             f"no impact in that mesh period). {fitted}", "",
             *_table(rows, inp.calibration), ""]
    lines += _details(inp) + _figures(inp)
    return "\n".join(lines) + "\n"


def _figures(inp: PaperInputs) -> list[str]:
    """Links to the run's time series at the paper's speeds, each beside its figure."""
    if not inp.figures:
        return []
    out = ["## Time series at the paper's speeds (all excitations)", "",
           "Each shows the DTE with the gap limit, the mesh load over one turn and a close-up, "
           "as the paper's figure named in its caption; a title saying *unstable orbit* is "
           "an orbit the machine leaves (the rows above).", ""]
    for rpm, name in sorted(inp.figures.items()):
        out.append(f"![{rpm:.0f} rpm, cf. the paper's {FIGURES.get(rpm, '')}]({name})")
    return out + [""]


def _details(inp: PaperInputs) -> list[str]:
    out = ["## Curves per case", "",
           "| case | range reached (rpm) | std peaks (rpm: N) | grazing (rpm) | impacts (rpm) | "
           "span (rpm) | contact windows (rpm) |", "|---|---|---|---|---|---:|---|"]
    for name, s in inp.cases.items():
        pk = ", ".join(f"{p.rpm:.0f}: {p.std:.3g}" for p in s.peaks) or "none"
        reach = f"{s.speed_range[0]:.0f}–{s.reached:.0f}" + ("" if s.complete else " (stopped)")
        out.append(f"| {name} | {reach} | {pk} | {_rpms(s.grazing)} | {_windows(s.impacts)} | "
                   f"{s.span:.0f} | {_windows(s.windows)} |")
    return out + [""]


def write_paper(out: str | Path, inp: PaperInputs) -> Path:
    """Write ``<out>/paper.md`` atomically and return its path."""
    path = Path(out) / "paper.md"
    with atomic_write(path, "w") as f:
        f.write(paper_markdown(inp))
    return path


def _time_series_figures(out: Path, scene: Scene, result, solved: dict) -> dict[float, str]:
    """``paper_<rpm>rpm.png``: the time series of the ``all`` case's solution at each of
    the paper's time-series speeds (:data:`~study.studies.paper.findings.FIGURES`) that the
    range holds."""
    from study.plots.point import time_series_plot

    names = {}
    for rpm, fig in FIGURES.items():
        if rpm not in solved:
            continue
        p, _, kind = solved[rpm]
        note = f" — unstable orbit ({kind_label(kind)})" if is_unstable(kind) else ""
        name = f"paper_{rpm:.0f}rpm.png"
        time_series_plot(result.problem, p, out / name,
                         title=f"{scene.name}, all excitations: {p.rpm:.0f} rpm (cf. the "
                               f"paper's {fig}){note}")
        names[rpm] = name
    return names


def write_paper_files(out: str | Path, scene: Scene, results: dict) -> Path:
    """``paper.md`` of the excitation cases' results (``{case: RunResult}``,
    :func:`study.studies.excitations.run_cases`) and the time series at the paper's
    speeds (``paper_<rpm>rpm.png``) in ``out`` (rank 0 under mpirun); returns the path
    of ``paper.md``."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    solved: dict[float, tuple] = {}
    inp = comparison_inputs(scene, results, solved)
    inp.figures = _time_series_figures(out, scene, results.get("all"), solved)
    path = write_paper(out, inp)
    logger.info("wrote %s", path)
    return path
