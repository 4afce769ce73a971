"""``geardyn excitations``: the three excitation cases of the paper (Sect. 4.2, Fig. 12–13).

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
and vibro-impact span and their change against the internal-only case). The command
also writes ``paper.md``, the comparison with the paper's findings
(:mod:`study.studies.paper`), from these results.
"""
from __future__ import annotations

import copy
import csv
import logging
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from core.files import atomic_write
from study.outputs.curves import CurveSummary, Peak, kind_label, primary_peak, summarize_branch
from study.pipeline.runs import SolverError
from study.pipeline.stages import run_scene
from study.scene.data import Scene
from study.scene.errors import SceneError
from study.scene.load import scene_from_dict

logger = logging.getLogger(__name__)

__all__ = ["CASES", "CaseCurves", "case_scenes", "run_cases", "case_curves",
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
    scenes = case_scenes(scene)           # every case validated before any heavy work
    out = Path(out)
    cache = cache_dir or str(out.resolve().parent / ".geardyn-cache")  # as `run --out OUT`
    results, failed = {}, []
    for case, sc in scenes.items():
        logger.info("excitation case %r: %s", case, CASES[case])
        try:
            results[case] = run_scene(sc, out / case, cache_dir=cache, resume=resume,
                                      refresh=refresh, progress=progress)
        except SolverError as exc:
            logger.error("case %s: %s", case, exc)
            failed.append(case)
            if exc.result is not None and exc.result.branch is not None \
                    and len(exc.result.branch) > 1:
                results[case] = exc.result
    return results, failed


@dataclass
class CaseCurves:
    """The curve of each case (:class:`~study.outputs.curves.CurveSummary`), its primary
    peak and, where the orbit there is unstable and time responses were asked for, what
    the machine does there."""

    #: case -> the features of its forced-response curve, in the order of :data:`CASES`
    cases: dict[str, CurveSummary] = field(default_factory=dict)
    #: case -> the primary peak: the internal-only curve's largest peak, and on the other
    #: curves the largest peak near its speed (:func:`~study.outputs.curves.primary_peak`)
    primary: dict[str, Peak | None] = field(default_factory=dict)
    #: case -> (start speed [rpm], mesh-load std [N]) of the time response on the
    #: unstable segment at the primary peak (``[outputs] attractor_transient_turns``)
    machine: dict[str, tuple[float, float]] = field(default_factory=dict)


def case_curves(results: dict) -> CaseCurves:
    """:class:`CaseCurves` of the cases' results (``{case: RunResult}``)."""
    out = CaseCurves()
    for case in CASES:
        if case in results:
            out.cases[case] = summarize_branch(results[case].branch)
    pi = primary_peak(out.cases["internal"]) if "internal" in out.cases else None
    for case, s in out.cases.items():
        out.primary[case] = pi if case == "internal" else \
            (primary_peak(s, near=pi.rpm) if pi is not None else None)
        peak = out.primary[case]
        for a in getattr(results[case], "attractors", []):
            if peak is not None and a.response is not None and a.segment.contains(peak.rpm):
                out.machine[case] = (a.rpm, a.response.std)
    return out


def _change(new: float | None, ref: float | None) -> float | None:
    if new is None or ref is None or ref == 0:
        return None
    return (new - ref) / ref


def _fmt_change(x: float | None) -> str:
    return "–" if x is None else f"{100 * x:+.1f} %"


def _flag(kind: str) -> str:
    return f" (**unstable**: {kind_label(kind)})" if kind else ""


def _rows(inp: CaseCurves) -> list[dict]:
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


def comparison_table(inp: CaseCurves) -> str:
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


def write_comparison(out: str | Path, scene: Scene, results: dict) -> dict[str, Path]:
    """``excitations_forced_response.png``, ``excitations.csv`` and ``excitations.md`` in
    ``out`` (rank 0 under mpirun)."""
    from study.plots.speed import forced_response_overlay

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    inp = case_curves(results)
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
    logger.info("wrote %s, %s and %s", png, path_csv, path_md)
    return {"png": png, "csv": path_csv, "md": path_md}

