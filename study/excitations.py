"""``geardyn excitations``: the paper's three excitation cases (Sect. 4.2, Fig. 12–13).

1. ``internal`` — internal excitation only: STE and time-varying mesh stiffness
   (TVMS) under the static load; ``[external]`` removed.
2. ``external`` — "the external excitation (aerodynamic loading and mass unbalance)
   and STE with a constant mesh stiffness (the average value over one vibration
   cycle)" (Sect. 4.2; Fig. 12 labels it "all excitations except TVMS"): the
   mesh-stiffness amplitudes set to zero, the STE and ``[external]`` kept.
3. ``all`` — the scene as it is.

The three run on the same cached ROM (the mesh, FE and ROM stages do not depend on
the excitation, :mod:`study.pipeline`), each into ``OUT/<case>/`` as a full run, then
the comparison is written: ``excitations_forced_response.png`` (std curves overlaid),
``excitations.csv`` and ``excitations.md`` (grazing speeds per case, primary peak
and vibro-impact span and their change against the internal-only case) and
``paper.md`` (:mod:`study.paper`).
"""
from __future__ import annotations

import copy
import csv
import logging
from pathlib import Path

import numpy as np

from core.files import atomic_write
from study.curves import Peak, kind_label, primary_peak, summarize_branch
from study.errors import SceneError
from study.scene_data import Scene
from study.scene_load import scene_from_dict

logger = logging.getLogger(__name__)

__all__ = ["CASES", "case_scenes", "run_cases", "solution_at", "comparison_inputs",
           "write_comparison", "comparison_table"]

#: Case name -> label (Fig. 12 legend).
CASES = {"internal": "internal excitation only",
         "external": "all but TVMS (external + STE, constant mesh stiffness)",
         "all": "all excitations"}


def _internal_present(scene: Scene) -> bool:
    return any(a != 0 for a in scene.mesh_stiffness.amplitudes) or \
        any(a != 0 for a in scene.transmission_error.amplitudes)


def _explicit_mesh(scene: Scene, constant_stiffness: bool) -> dict:
    """``[mesh_stiffness]`` and ``[transmission_error]`` tables with the base scene's
    values written out (estimates resolved), the stiffness amplitudes zeroed if asked."""
    ms, te = scene.mesh_stiffness, scene.transmission_error
    n = len(ms.amplitudes)
    amps = [0.0] * n if constant_stiffness else [a / 1e6 for a in ms.amplitudes]
    return {"mesh_stiffness": {"mean_N_per_um": ms.mean / 1e6, "amplitudes_N_per_um": amps,
                               "phases_deg": [float(np.degrees(p)) for p in ms.phases]},
            "transmission_error": {"kind": te.kind, "mean_um": te.mean * 1e6,
                                   "amplitudes_um": [a * 1e6 for a in te.amplitudes],
                                   "phases_deg": [float(np.degrees(p)) for p in te.phases]}}


def case_scenes(scene: Scene) -> dict[str, Scene]:
    """The three case scenes of ``scene`` (validated), in the order of :data:`CASES`.

    Raises
    ------
    SceneError
        If the scene lacks internal excitation (all mesh-stiffness and TE amplitudes
        zero) or external excitation (no ``[[external.aero]]`` or
        ``[[external.unbalance]]``).
    """
    if not scene.external.present:
        raise SceneError("excitations: the scene has no external excitation "
                         "([[external.aero]] or [[external.unbalance]]); the three cases "
                         "compare internal and external excitation")
    if not _internal_present(scene):
        raise SceneError("excitations: mesh_stiffness.amplitudes_N_per_um and "
                         "transmission_error.amplitudes_um are all zero (no internal "
                         "excitation); the three cases compare internal and external excitation")
    out: dict[str, Scene] = {}
    for case, label in CASES.items():
        raw = copy.deepcopy(scene.raw)
        note = ""
        if case == "internal":
            raw.pop("external", None)
            hs = scene.hbm.harmonics
            if hs is not None:  # shaft-order list -> mesh-order list (fundamental ZΩ)
                z = scene.gear.teeth
                raw.setdefault("hbm", {})["harmonics"] = sorted({h // z for h in hs
                                                                  if h % z == 0})
            note = "[external] removed"
        elif case == "external":
            raw.update(_explicit_mesh(scene, constant_stiffness=True))
            note = "mesh_stiffness amplitudes set to 0 (constant k̄), STE and [external] kept"
        info = dict(raw.get("scene", {}))
        info["name"] = f"{scene.name}-{case}"
        info["description"] = f"{scene.scene.description} — case '{case}': {label}".strip(" —")
        raw["scene"] = info
        text = scene.text + (f"\n# geardyn excitations, case '{case}': {note}\n" if note else "")
        try:
            out[case] = scene_from_dict(raw, f"{scene.name}-{case}", text)
        except SceneError as exc:
            raise SceneError(f"excitations, case '{case}' ({note}): {exc}") from exc
    return out


def run_cases(scene: Scene, out: str | Path, cache_dir: str | None = None,
              resume: bool = False, refresh: bool = False, progress: bool = False
              ) -> tuple[dict, list[str]]:
    """Run the three cases into ``out/<case>`` on a shared stage cache.

    Returns ``({case: RunResult}, [failed cases])``; a case whose continuation stopped
    early keeps its partial result when it has at least two points.
    """
    import study
    from study.pipeline import SolverError

    scenes = case_scenes(scene)           # every case validated before any heavy work
    out = Path(out)
    cache = cache_dir or str(out.resolve().parent / ".geardyn-cache")  # as `run --out OUT`
    results, failed = {}, []
    for case, sc in scenes.items():
        logger.info("excitation case %r: %s", case, CASES[case])
        try:
            results[case] = study.run(sc, out / case, cache_dir=cache, resume=resume,
                                      refresh=refresh, progress=progress)
        except SolverError as exc:
            logger.error("case %s: %s", case, exc)
            failed.append(case)
            if exc.result is not None and exc.result.branch is not None \
                    and len(exc.result.branch) > 1:
                results[case] = exc.result
    return results, failed


def solution_at(result, rpm: float):
    """The solution at ``rpm``: Newton at that speed from the nearest branch point
    (stable preferred), or that point itself if Newton fails. Returns (Point, how)."""
    from hbm import ConvergenceError
    from study.export import nearest_point

    _, pt = nearest_point(result, rpm)
    if abs(pt.rpm - rpm) <= 1e-9 * rpm:
        return pt, "branch point"
    try:
        p = result.problem.solve(rpm, x0=pt.unknowns, tol=result.scene.continuation.tolerance)
    except ConvergenceError as exc:
        logger.warning("no solution at %g rpm from the branch point at %.1f rpm (%s); using "
                       "that point", rpm, pt.rpm, exc)
        return pt, "nearest branch point"
    return p, f"solved from the branch point at {pt.rpm:.1f} rpm"


def _stability_kind(result, point) -> str:
    """Kind of :data:`hbm.stability.KINDS` of a solution off the branch ("" when the
    Floquet analysis fails: logged, and the rows then say nothing of stability)."""
    from hbm.stability import stability
    try:
        return stability(result.problem, point).kind
    except Exception as exc:                    # noqa: BLE001 - reported, the table goes on
        logger.warning("stability at %.1f rpm not computed: %s", point.rpm, exc)
        return ""


def _machine(result, point):
    """(turns left out, turns analysed, envelope) of the time response from ``point``
    when the scene asks for time responses (``[outputs] attractor_transient_turns`` > 0),
    else None; a failed integration is logged and gives None."""
    from study.attractors import scene_time_response

    try:
        tr = scene_time_response(result, point)
    except (RuntimeError, ValueError) as exc:
        logger.warning("time integration at %.1f rpm failed: %s", point.rpm, exc)
        return None
    return None if tr is None else (tr.transient, tr.window, tr.envelope)


def _in_range(result, rpm: float) -> bool:
    br = result.branch
    return float(np.min(br.rpm)) <= rpm <= float(np.max(br.rpm))


def _range_text(result) -> str:
    br = result.branch
    return f"outside the computed range {np.min(br.rpm):.0f}–{np.max(br.rpm):.0f} rpm"


def comparison_inputs(scene: Scene, results: dict, solved: dict | None = None):
    """:class:`study.paper.PaperInputs` of the case results (IPP, spectrum and mesh mode
    from the ``all`` case). ``solved``, if given, receives the ``all`` case's solutions
    at the paper's speeds: ``{rpm: (Point, how, stability kind)}``."""
    from hbm import mesh_period_envelope, point_stats, spectrum
    from study.curves import is_unstable
    from study.paper import IPP_KEYS, SPECTRUM_SPEEDS, IppAt, PaperInputs, SpectrumAt

    inp = PaperInputs(scene.name, scene.load.torque, scene.static_load,
                      calibration=dict(scene.calibration))
    for case in CASES:
        if case in results:
            inp.cases[case] = summarize_branch(results[case].branch)
    pi = primary_peak(inp.cases["internal"]) if "internal" in inp.cases else None
    for case, s in inp.cases.items():
        inp.primary[case] = pi if case == "internal" else \
            (primary_peak(s, near=pi.rpm) if pi is not None else None)
        peak = inp.primary[case]
        for a in getattr(results[case], "attractors", []):
            if peak is not None and a.response is not None and a.segment.contains(peak.rpm):
                inp.machine[case] = (a.rpm, a.response.std)
    r = results.get("all")
    if r is None:
        return inp
    solved = {} if solved is None else solved
    for target in (*IPP_KEYS, *SPECTRUM_SPEEDS):
        if target not in solved and _in_range(r, target):
            p, how = solution_at(r, target)
            solved[target] = (p, how, _stability_kind(r, p) if scene.hbm.stability else "")
    for target in IPP_KEYS:
        if target not in solved:
            inp.ipp[target] = _range_text(r)
            continue
        p, how, kind = solved[target]
        inp.ipp[target] = IppAt(target, p.rpm, point_stats(r.problem, p)[0].ipp, how, kind)
    for target in SPECTRUM_SPEEDS:
        if target not in solved:
            inp.spectra[target] = _range_text(r)
            continue
        p, _, kind = solved[target]
        sp = spectrum(r.problem, p)
        unstable = is_unstable(kind)
        inp.spectra[target] = SpectrumAt(p.rpm, sp["shaft_order"], sp["amplitude"],
                                         scene.gear.teeth, sp["dte_amplitude"],
                                         sp["peak_to_peak"], mesh_period_envelope(r.problem, p),
                                         kind, _machine(r, p) if unstable else None)
    rom = r.rom
    if rom is not None and getattr(rom, "mesh_energy", None) is not None:
        f_min = scene.gear.teeth * scene.continuation.speed[0] / 60.0  # H_Z, lowest speed
        inp.mesh_mode, inp.reached_mode, inp.softening = rom_measures(
            rom, scene.damping.modal_ratio, f_min)
        inp.reached_from = f_min
    return inp


def rom_measures(rom, xi: float, f_min: float = 0.0) -> tuple[tuple[float, float], ...]:
    """Of a cached ROM (:class:`machines.rom.RomData`): the mode with most mesh energy
    ``(Hz, ρ)`` (eq. 31), the same among the modes at or above ``f_min`` [Hz] (those the
    mesh harmonics reach), and the dynamic-factor peak near the latter with its shift
    under k̄/2 ``(Hz, f½/f)`` (T.33), for modal damping ratio ``xi``."""
    f, rho = np.asarray(rom.frequencies_hz), np.asarray(rom.mesh_energy)
    j = int(np.argmax(rho))
    k = int(np.argmax(np.where(f >= f_min, rho, 0.0)))
    return ((float(f[j]), float(rho[j])), (float(f[k]), float(rho[k])),
            rom.mesh_softening(xi, f_min=f_min))


def _change(new: float | None, ref: float | None) -> float | None:
    if new is None or ref is None or ref == 0:
        return None
    return (new - ref) / ref


def _fmt_change(x: float | None) -> str:
    return "–" if x is None else f"{100 * x:+.1f} %"


def _flag(kind: str) -> str:
    return f" (**unstable**: {kind_label(kind)})" if kind else ""


def _rows(inp) -> list[dict]:
    si = inp.cases.get("internal")
    pi: Peak | None = inp.primary.get("internal")
    rows = []
    for case, s in inp.cases.items():
        pk = inp.primary.get(case)
        rows.append({
            "case": case, "label": CASES[case], "complete": s.complete,
            "comparable": s.complete and (si is None or si.complete),
            "reached_rpm": s.reached,
            "peaks_rpm": ";".join(f"{p.rpm:.1f}" for p in s.peaks),
            "peaks_N": ";".join(f"{p.std:.4g}" for p in s.peaks),
            "primary_peak_rpm": None if pk is None else pk.rpm,
            "primary_peak_N": None if pk is None else pk.std,
            "primary_peak_change": _change(None if pk is None else pk.std,
                                           None if pi is None else pi.std),
            "primary_peak_unstable": "" if pk is None else pk.kind,
            "max_std_rpm": s.max_std_rpm, "max_std_N": s.max_std,
            "max_std_change": _change(s.max_std, None if si is None else si.max_std),
            "max_std_unstable": s.max_std_kind,
            "grazing_rpm": ";".join(f"{g:.1f}" for g in s.grazing),
            "impacts_rpm": ";".join(f"{a:.1f}-{b:.1f}" for a, b in s.impacts),
            "span_rpm": s.span,
            "span_change": _change(s.span, None if si is None else si.span),
            "contact_windows_rpm": ";".join(f"{a:.1f}-{b:.1f}" for a, b in s.windows)})
    return rows


def comparison_table(inp) -> str:
    """Markdown table of the cases (Fig. 12–13): peaks, grazings, span, changes."""
    lines = ["| case | primary peak (N at rpm) | change | largest std (N at rpm) | change | "
             "grazing (rpm) | impacts (rpm) | span (rpm) | change |",
             "|---|---|---:|---|---:|---|---|---:|---:|"]
    for row in _rows(inp):
        pk = "–" if row["primary_peak_N"] is None else \
            f"{row['primary_peak_N']:.1f} at {row['primary_peak_rpm']:.0f}" \
            f"{_flag(row['primary_peak_unstable'])}"
        stop = "" if row["complete"] else f" (stopped at {row['reached_rpm']:.0f} rpm)"
        ok = row["comparable"]
        lines.append(
            f"| {row['case']}: {row['label']}{stop} | {pk} | "
            f"{_fmt_change(row['primary_peak_change']) if ok else 'incomplete curve'} | "
            f"{row['max_std_N']:.1f} at {row['max_std_rpm']:.0f}"
            f"{_flag(row['max_std_unstable'])} | "
            f"{_fmt_change(row['max_std_change']) if ok else 'incomplete curve'} | "
            f"{row['grazing_rpm'].replace(';', ', ') or 'none'} | "
            f"{row['impacts_rpm'].replace(';', ', ') or 'none'} | {row['span_rpm']:.0f} | "
            f"{_fmt_change(row['span_change']) if ok else 'incomplete curve'} |")
    return "\n".join(lines)


def _atomic_text(path: Path, write) -> Path:
    with atomic_write(path, "w") as f:
        write(f)
    return path


def _time_series_figures(out: Path, scene: Scene, result, solved: dict) -> dict[float, str]:
    """``paper_<rpm>rpm.png``: the time series of the ``all`` case's solution at each of
    the paper's time-series speeds (:data:`study.paper.FIGURES`) that the range holds."""
    from study.curves import is_unstable
    from study.paper import FIGURES
    from study.plots_point import time_series_plot

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


def write_comparison(out: str | Path, scene: Scene, results: dict) -> dict[str, Path]:
    """``excitations_forced_response.png``, ``excitations.csv``, ``excitations.md``,
    ``paper.md`` and the time series at the paper's speeds (``paper_<rpm>rpm.png``) in
    ``out`` (rank 0 under mpirun)."""
    from study.paper import write_paper
    from study.plots_speed import forced_response_overlay

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    solved: dict[float, tuple] = {}
    inp = comparison_inputs(scene, results, solved)
    inp.figures = _time_series_figures(out, scene, results.get("all"), solved)
    cases = [c for c in CASES if c in results]
    png = forced_response_overlay([results[c].branch for c in cases],
                                  [CASES[c] for c in cases],
                                  out / "excitations_forced_response.png",
                                  title=f"{scene.name}: excitation cases (cf. Fig. 12; bars: "
                                        "impact ranges)")
    rows = _rows(inp)

    def csv_rows(f) -> None:
        w = csv.DictWriter(f, fieldnames=list(rows[0]) if rows else ["case"])
        w.writeheader()
        for r in rows:
            w.writerow({k: ("" if v is None else v) for k, v in r.items()})
    path_csv = _atomic_text(out / "excitations.csv", csv_rows)
    text = (f"# {scene.name}: excitation cases (paper Sect. 4.2, Fig. 12–13)\n\n"
            f"{comparison_table(inp)}\n\n"
            "Primary peak: the largest local maximum of the mesh-load std with internal "
            "excitation only, and on the other curves the largest peak within ±15 % of its "
            "speed (the same resonance), refined by the parabola through its three points "
            "(so it may top the largest computed point); the largest std of each curve is "
            "shown beside it, "
            "since an external-excitation resonance may top the curve elsewhere; "
            "**unstable**: the periodic orbit there is unstable (the leading Floquet kind; "
            "each case's report.md), so the machine does not stay on it. Span: total "
            "length of the speed intervals with impacts; changes are against the "
            "internal-only case. Each case's run is in its folder "
            f"({', '.join(f'`{c}/`' for c in cases)}).\n\n"
            "![excitation cases](excitations_forced_response.png)\n")
    path_md = _atomic_text(out / "excitations.md", lambda f: f.write(text))
    path_paper = write_paper(out, inp)
    logger.info("wrote %s, %s, %s and %s", png, path_csv, path_md, path_paper)
    return {"png": png, "csv": path_csv, "md": path_md, "paper": path_paper}

