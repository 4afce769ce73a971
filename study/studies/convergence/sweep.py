"""Convergence study of a scene: error against run time for each numerical knob.

``geardyn convergence SCENE --out DIR`` (and :func:`run_convergence`) sweeps one
knob at a time around the scene's own settings, every other value fixed:

==========  ==========================================  =========================  =====
knob        scene value changed                         default values             ref.
==========  ==========================================  =========================  =====
mesh        ``mesh.size`` = factor × preset size (FE)   factors 1.5, 1, 0.75       min
n_cm        ``rom.n_cm`` (FE, the scene gives it)       ×0.5, ×1, ×2               max
cutoff      ``rom.cutoff_factor`` (FE, without n_cm     ×0.75 (>= 1), ×1, ×1.5     max
            and cutoff_Hz: the default)
harmonics   ``hbm.mesh_harmonics``                      ×0.5, ×1, ×2               max
sidebands   ``hbm.sideband_order`` (external orders)    s−1, s, s+1 (>= 0)         max
aft         ``hbm.aft_samples`` (0 = automatic)         ×0.5, ×1, ×2 of the value  max
step        ``continuation.max_step_rpm``               ×2, ×1, ×0.5               min
==========  ==========================================  =========================  =====

The most converged value of each knob (last column) is that knob's reference.
Each knob is one :class:`~study.studies.convergence.knobs.Knob` entry of
:data:`~study.studies.convergence.knobs.KNOBS` (scene key, ladder, reference,
applicability, cost stages); the error measures are in
:mod:`~study.studies.convergence.measures` and :mod:`study.outputs.housing_error`, the
files in :mod:`~study.studies.convergence.report`.
Each setting is run through the cached pipeline (:class:`study.pipeline.stages.Pipeline`,
up to ``results.h5``), so a harmonics sweep of an FE scene reuses the cached ROM and
only the hbm stage runs; the log says which stages ran and which came from cache.

Errors of a setting against its knob's reference (relative, dimensionless):

rom_freq_err
    (FE) max over the coupled ROM frequencies (eq. 17) of the reference below its
    validity frequency (Fig. 9) of ``|f − f_ref| / max(f_ref, f_1)``, modes matched
    by rank, ``f_1`` the first non-zero frequency.
curve_err
    max over the reference's continuation points of the relative error of the
    mesh-load standard deviation. The setting's branch is cut at its folds into
    segments monotonic in speed; each segment is interpolated linearly at the
    reference's speed and at the speed ± ``speed_slack`` (relative), and the value
    closest to the reference's is taken. So a multi-valued response is compared
    branch by branch, and a jump moved by less than the slack is not counted as
    an error of the size of the jump (the grazing error measures such shifts).
grazing
    each grazing bifurcation of the reference (eq. 30) is matched to the nearest
    one of the setting on the same flank (within 5 %); the error is the largest
    relative speed difference of the matched pairs; pairs within ±1 % count as
    matched in the sense of Fig. 11; unmatched ones are listed as missing/extra.
housing_err
    (FE, ``outputs.housing_field_rpm`` set) at the first housing speed: the HBM point
    re-solved exactly at that speed, its ROM coordinates recovered and the
    displacement field ``u = T q`` rebuilt from the cached ROM basis (all FE
    unknowns but the named link nodes). Same mesh: relative L2 error over the
    field and one period (Parseval); different meshes: relative error of the
    largest displacement amplitude.

The recommendation of a knob is its cheapest value whose errors are all within
``tol`` (no unmatched grazing). Costs are the wall times of the stages the knob
changes (mesh: mesh+fe+rom+hbm; n_cm, cutoff: fe+rom+hbm; others: hbm), measured when the
stage ran; the stage times of cached entries are kept in ``<cache>/timings.json`` and in
each entry's manifest (:meth:`study.pipeline.cache.StageCache.seconds`).
"""

from __future__ import annotations

import json
import logging
import math
from pathlib import Path

from study.outputs.housing_error import field_error, housing_field
from study.pipeline.runs import SolverError
from study.pipeline.stages import Pipeline
from study.scene.data import Scene
from study.scene.errors import SceneError
from study.scene.load import load_scene, scene_from_dict
from study.scene.overrides import apply_overrides
from study.studies.convergence.knobs import Setting, fmt_value, knob, plan
from study.studies.convergence.measures import (
    SPEED_SLACK,
    ConvergenceResult,
    Row,
    curve_error,
    grazing_error,
    recommend,
    rom_frequency_error,
    validity_hz,
)
from study.studies.convergence.report import cost_text, write_outputs, write_text

logger = logging.getLogger(__name__)

__all__ = ["run_convergence"]


class _Timings:
    """``<cache>/timings.json``: stage key -> seconds it took when it ran."""

    def __init__(self, cache_dir: Path) -> None:
        self.path = Path(cache_dir) / "timings.json"
        try:
            self.data = json.loads(self.path.read_text())
        except (OSError, ValueError):
            self.data = {}

    def record(self, pipe: Pipeline) -> None:
        for st, s in pipe.status.items():
            if s.seconds is not None and st in pipe.keys:
                self.data[pipe.keys[st]] = s.seconds
        self.path.parent.mkdir(parents=True, exist_ok=True)
        write_text(self.path, json.dumps(self.data, indent=1))

    def cost(self, pipe: Pipeline, stages: tuple[str, ...]) -> float | None:
        total = 0.0
        for st in stages:
            key = pipe.keys.get(st)
            if key is None:
                continue
            seconds = self.data.get(key, pipe.cache.seconds(st, key))
            if seconds is None:  # cached by a run that did not time it
                return None
            total += float(seconds)
        return total


def _run_one(setting: Setting, scene: Scene, out: Path, cache_dir: Path, timings: _Timings,
             refresh: bool, progress: bool) -> Row:
    row = Row(setting)
    # housing fields are rebuilt here from the ROM basis, not written as XDMF
    sc = scene_from_dict(apply_overrides(scene.raw, {"outputs.housing_field_rpm": []}),
                         scene.name, scene.text)
    pipe = Pipeline(sc, out, cache_dir=cache_dir, refresh=refresh, progress=progress)
    logger.info("setting %s (%s)", setting.label,
                ", ".join(f"{k}={fmt_value(v)}" for k, v in setting.overrides.items()))
    from hbm import ConvergenceError
    try:
        res = pipe.run(until="hbm")
    except (SolverError, ConvergenceError) as exc:
        logger.error("setting %s: %s", setting.label, exc)
        row.status, row.note = "solver failure", str(exc)
        row.stages = dict(pipe.stages)
        partial = getattr(getattr(exc, "result", None), "branch", None)
        row.points = 0 if partial is None else len(partial)
        return row
    res.scene = scene
    timings.record(pipe)
    row.result = res
    row.stages = {k: s.state for k, s in pipe.status.items()}
    row.seconds_run = res.seconds
    row.points = len(res.branch)
    row.seconds = timings.cost(pipe, knob(setting.knob).stages)
    reused = [k for k, s in pipe.status.items() if s.from_cache]
    logger.info("setting %s: %d points, stages %s; reused from cache: %s; cost %s",
                setting.label, row.points,
                ", ".join(f"{k} {s.text}" for k, s in pipe.status.items() if s.applies),
                ", ".join(reused) or "-", cost_text(row))
    return row


def _compare(rows: list[Row], scene: Scene, slack: float) -> None:
    """Fill the errors of every row against the reference row of its knob."""
    ok = [r for r in rows if r.status == "ok"]
    name = rows[0].setting.knob
    ref_value = knob(name).finest(r.setting.value for r in rows)
    ref = next((r for r in ok if r.setting.value == ref_value), None)
    if ref is None:
        logger.error("knob %s: the reference %s failed; no errors computed",
                     name, name + "=" + fmt_value(ref_value))
        return
    ref.reference = True
    rb = ref.result.branch
    fe = ref.result.rom is not None             # an FE machine's run: a ROM to compare
    f_max = validity_hz(scene, ref.result.rom) if fe else 0.0
    # housing speeds are refused at load for a machine without a radiating part
    house_rpm = scene.outputs.housing_field[0] if fe and scene.outputs.housing_field else None
    if house_rpm is not None:
        ref.housing = housing_field(ref.result, house_rpm)
    for r in ok:
        br = r.result.branch
        r.curve_err = curve_error(rb.rpm, rb.element(0).mesh_load_std, br.rpm,
                                  br.element(0).mesh_load_std, slack)
        r.grazing = grazing_error(list(rb.grazing), list(br.grazing))
        if fe:
            r.rom_freq_err = rom_frequency_error(ref.result.rom, r.result.rom, f_max)
        if house_rpm is not None:
            if r.housing is None:
                r.housing = housing_field(r.result, house_rpm)
            r.housing_err, r.housing_metric = field_error(ref.housing, r.housing)
        if r is ref:  # exactly 0 by definition (re-solves are deterministic anyway)
            r.curve_err, r.rom_freq_err = 0.0, (0.0 if fe else None)
            r.housing_err = 0.0 if house_rpm is not None else None


def _base_scene(scene: str | Path | Scene, overrides: dict | None) -> Scene:
    """The study's base: the scene (file or validated) with ``overrides`` applied."""
    if not isinstance(scene, Scene):
        return load_scene(scene, overrides)
    if not overrides:
        return scene
    return scene_from_dict(apply_overrides(scene.raw, overrides), scene.name, scene.text)


def _recommend_all(rows: list[Row], base: Scene, tol: float,
                   slack: float) -> tuple[dict[str, Row], dict[str, str]]:
    """Compare the rows of each knob with its reference; the recommended row per knob and,
    for a knob without one, why (:func:`recommend`)."""
    rec: dict[str, Row] = {}
    verdicts: dict[str, str] = {}
    for name in dict.fromkeys(r.setting.knob for r in rows):
        kr = [r for r in rows if r.setting.knob == name]
        _compare(kr, base, slack)
        best, why = recommend(kr, tol)
        if best is None:
            verdicts[name] = why
            logger.warning("knob %s: no recommendation: %s", name, why)
            continue
        best.recommended = True
        rec[name] = best
    return rec, verdicts


def run_convergence(scene: str | Path | Scene, out: str | Path, *,
                    knobs: dict[str, list] | None = None, only: list[str] | None = None,
                    tol: float = 1e-2, overrides: dict | None = None,
                    cache_dir: str | Path | None = None, refresh: bool = False,
                    progress: bool = False, speed_slack: float = SPEED_SLACK
                    ) -> ConvergenceResult:
    """Sweep each knob around the scene's settings; write the table, plot and advice.

    Parameters
    ----------
    scene
        Scene file or validated :class:`~study.scene.Scene`.
    out
        Output folder: ``convergence.csv``, ``convergence.md``, ``pareto.png`` and
        one run folder per setting under ``runs/``.
    knobs
        ``{knob: [values]}`` replacing default values (knobs: :data:`KNOB_NAMES`;
        ``mesh`` values are factors of the mesh size, the others the scene values).
    only
        Knobs to sweep (default: all that apply).
    tol
        Tolerance (relative) of the recommendation, > 0.
    overrides
        ``{"section.key": value}`` applied to the scene first (the study's base).
    cache_dir
        Stage cache (default ``<out>/../.geardyn-cache``).
    refresh
        Recompute every stage.
    progress
        tqdm bars.
    speed_slack
        Relative speed slack of the curve comparison (see :func:`curve_error`).

    Returns
    -------
    ConvergenceResult
    """
    if not (isinstance(tol, (int, float)) and math.isfinite(tol) and 0 < tol < 1):
        raise SceneError(f"--tol = {tol}: must be > 0 and < 1")
    if not (0 <= speed_slack < 0.1):
        raise SceneError(f"speed_slack = {speed_slack}: must be >= 0 and < 0.1")
    base = _base_scene(scene, overrides)
    settings = plan(base, knobs, only)  # everything validated before any run
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    cache = Path(cache_dir) if cache_dir else out.resolve().parent / ".geardyn-cache"
    timings = _Timings(cache)
    logger.info("convergence of %r: %d settings over knobs %s (cache %s)", base.name,
                len(settings), ", ".join(dict.fromkeys(s.knob for s, _ in settings)), cache)
    rows = [_run_one(st, sc, out / "runs" / st.label.replace("=", "-"), cache, timings,
                     refresh, progress) for st, sc in settings]
    rec, verdicts = _recommend_all(rows, base, tol, speed_slack)
    result = ConvergenceResult(rows, rec, tol, verdicts=verdicts)
    result.files = write_outputs(result, out, base)
    for name, r in rec.items():
        logger.info("recommended %s = %s (cost %s, max error %.3g <= tol %g)", name,
                    fmt_value(r.setting.value), cost_text(r), r.max_err or 0.0, tol)
    failed = [r.setting.label for r in rows if r.status != "ok"]
    if failed:
        raise SolverError(f"convergence: settings failed: {', '.join(failed)} (the table "
                          f"in {out} lists the others)", result)
    return result
