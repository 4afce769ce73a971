"""Convergence study of a scene: error against run time for each numerical knob.

``geardyn convergence SCENE --out DIR`` (and :func:`run_convergence`) sweeps one
knob at a time around the scene's own settings, every other value fixed:

==========  ==========================================  =========================  =====
knob        scene value changed                         default values             ref.
==========  ==========================================  =========================  =====
mesh        ``mesh.size`` = factor × preset size (FE)   factors 1.5, 1, 0.75       min
n_cm        ``rom.n_cm`` (FE, not with ``cutoff_Hz``)   ×0.5, ×1, ×2               max
harmonics   ``hbm.mesh_harmonics``                      ×0.5, ×1, ×2               max
sidebands   ``hbm.sideband_order`` (external orders)    s−1, s, s+1 (>= 0)         max
aft         ``hbm.aft_samples`` (0 = automatic)         ×0.5, ×1, ×2 of the value  max
step        ``continuation.max_step_rpm``               ×2, ×1, ×0.5               min
==========  ==========================================  =========================  =====

The most converged value of each knob (last column) is that knob's reference.
Each setting is run through the cached pipeline (:class:`study.pipeline.Pipeline`,
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
changes (mesh: mesh+fe+rom+hbm; n_cm: fe+rom+hbm; others: hbm), measured when the
stage ran; the stage times of cached entries are kept in ``<cache>/timings.json``.
"""
from __future__ import annotations

import csv
import io
import json
import logging
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from geometry.files import atomic_write
from study.pipeline import Pipeline, RunResult, SolverError
from study.scene import Scene, SceneError, apply_overrides, load_scene, scene_from_dict

logger = logging.getLogger(__name__)

__all__ = ["KNOBS", "KNOB_KEYS", "Setting", "Row", "ConvergenceResult", "default_values",
           "knob_overrides", "plan", "curve_error", "grazing_error", "GrazingMatch",
           "rom_frequency_error", "run_convergence", "recommend", "write_outputs"]

#: Knobs in the order they are swept.
KNOBS = ("mesh", "n_cm", "harmonics", "sidebands", "aft", "step")
#: Scene key each knob changes (``--set KEY=v1,v2`` on it is the same as ``--knob``).
KNOB_KEYS = {"mesh": "mesh.size", "n_cm": "rom.n_cm", "harmonics": "hbm.mesh_harmonics",
             "sidebands": "hbm.sideband_order", "aft": "hbm.aft_samples",
             "step": "continuation.max_step_rpm"}
#: Stages whose cost counts for a knob (they rerun for every value).
_COST_STAGES = {"mesh": ("mesh", "fe", "rom", "hbm"), "n_cm": ("fe", "rom", "hbm")}
_FINEST = {"mesh": min, "step": min}          # others: max
FIG11_BAND = 0.01        # grazing speeds within ±1 % (Fig. 11)
MATCH_WINDOW = 0.05      # grazings further apart than 5 % are not matched
SPEED_SLACK = 2e-3       # relative speed slack of the curve comparison


@dataclass(frozen=True)
class Setting:
    """One run of the study: a knob, its value and the scene overrides it means."""

    knob: str
    value: float
    overrides: dict

    @property
    def label(self) -> str:
        return f"{self.knob}={_num(self.value)}"


@dataclass
class GrazingMatch:
    """Grazing speeds of a setting matched to the reference's.

    ``pairs`` holds ``(ref_rpm, rpm, side)``; ``missing`` the reference grazings
    without a partner, ``extra`` the setting's without one (rpm).
    """

    pairs: list = field(default_factory=list)
    missing: list = field(default_factory=list)
    extra: list = field(default_factory=list)

    @property
    def max_abs_rpm(self) -> float:
        return max((abs(b - a) for a, b, _ in self.pairs), default=0.0)

    @property
    def max_rel(self) -> float:
        return max((abs(b - a) / a for a, b, _ in self.pairs), default=0.0)

    @property
    def fig11(self) -> int:
        """Pairs within ±1 % of the reference speed (Fig. 11)."""
        return sum(abs(b - a) <= FIG11_BAND * a for a, b, _ in self.pairs)

    @property
    def unmatched(self) -> int:
        return len(self.missing) + len(self.extra)


@dataclass
class Row:
    """One setting's outcome: cost, errors against its knob's reference, status."""

    setting: Setting
    status: str = "ok"
    reference: bool = False
    seconds: float | None = None       # cost of the knob's stages (None: unknown)
    seconds_run: float = 0.0           # wall time of this invocation
    stages: dict = field(default_factory=dict)
    points: int = 0
    rom_freq_err: float | None = None
    curve_err: float | None = None
    grazing: GrazingMatch | None = None
    housing_err: float | None = None
    housing_metric: str = ""
    recommended: bool = False
    result: Any = field(default=None, repr=False)
    housing: Any = field(default=None, repr=False)

    def errors(self) -> dict[str, float]:
        """The relative errors that apply (name -> value)."""
        out = {"rom_freq_err": self.rom_freq_err, "curve_err": self.curve_err,
               "grazing_rel_err": self.grazing.max_rel if self.grazing else None,
               "housing_err": self.housing_err}
        return {k: v for k, v in out.items() if v is not None}

    @property
    def max_err(self) -> float | None:
        """Largest error; an unmatched grazing counts as 1 (100 %)."""
        if self.status != "ok" or self.curve_err is None:
            return None
        e = max(self.errors().values(), default=0.0)
        if self.grazing is not None and self.grazing.unmatched:
            e = max(e, 1.0)
        return e

    def within(self, tol: float) -> bool:
        e = self.max_err
        return e is not None and e <= tol


@dataclass
class ConvergenceResult:
    """All rows, the recommended value per knob and the files written."""

    rows: list[Row]
    recommendation: dict[str, Row]
    tol: float
    files: list[Path] = field(default_factory=list)

    def overrides(self) -> dict:
        """Scene overrides of the recommended values (all knobs combined)."""
        out: dict = {}
        for r in self.recommendation.values():
            out.update(r.setting.overrides)
        return out


# --------------------------------------------------------------------------- planning

def _num(v) -> str:
    return f"{v:g}" if isinstance(v, float) else str(v)


def _mesh_size(scene: Scene) -> float:
    from study.fe_params import fe_parameters
    return float(fe_parameters(scene.fe, scene.gear).mesh.size)


def _n_time(scene: Scene) -> int:
    from study.model import harmonic_set
    return int(harmonic_set(scene).n_time)


def applicable(scene: Scene, knob: str) -> str | None:
    """``None`` if the knob applies to the scene, else the reason it does not."""
    fe = scene.scene.kind == "fe"
    if knob not in KNOBS:
        raise SceneError(f"--knob {knob!r}: unknown knob; allowed: {', '.join(KNOBS)}")
    if knob in ("mesh", "n_cm") and not fe:
        return "FE scenes only"
    if knob == "n_cm" and scene.rom.cutoff:
        return "the scene selects modes by rom.cutoff_Hz"
    if knob in ("harmonics", "sidebands") and scene.hbm.harmonics is not None:
        return "the scene gives an explicit hbm.harmonics set"
    if knob == "sidebands" and not scene.external.present:
        return "no external excitation (no sidebands)"
    return None


def default_values(scene: Scene, knob: str) -> list:
    """Default values of a knob around the scene's own value (see the module table)."""
    if knob == "mesh":
        return [1.5, 1.0, 0.75]
    if knob == "n_cm":
        n = scene.rom.n_cm
        return sorted({max(1, round(n / 2)), n, min(5000, 2 * n)})
    if knob == "harmonics":
        n = scene.hbm.mesh_harmonics
        return sorted({max(1, round(n / 2)), n, min(200, 2 * n)})
    if knob == "sidebands":
        s = scene.hbm.sideband_order
        return sorted({max(0, s - 1), s, s + 1})
    if knob == "aft":
        n = _n_time(scene)
        return [n // 2, n, 2 * n]
    if knob == "step":
        m = scene.continuation.max_step
        span = scene.continuation.speed[1] - scene.continuation.speed[0]
        return sorted({min(2 * m, span), m, m / 2}, reverse=True)
    raise SceneError(f"--knob {knob!r}: unknown knob; allowed: {', '.join(KNOBS)}")


def knob_overrides(scene: Scene, knob: str, value) -> dict:
    """Scene overrides (``{"section.key": value}``) that set ``knob`` to ``value``."""
    if knob == "mesh":
        if not value > 0:
            raise SceneError(f"--knob mesh={value}: the mesh size factor must be > 0")
        return {"mesh.size": float(value) * _mesh_size(scene)}
    if knob == "n_cm":
        return {"rom.n_cm": _int(knob, value)}
    if knob == "harmonics":
        return {"hbm.mesh_harmonics": _int(knob, value)}
    if knob == "sidebands":
        return {"hbm.sideband_order": _int(knob, value)}
    if knob == "aft":
        return {"hbm.aft_samples": _int(knob, value)}
    if knob == "step":
        v = float(value)
        c = scene.continuation
        return {"continuation.max_step_rpm": v, "continuation.step_rpm": min(c.step, v),
                "continuation.min_step_rpm": min(c.min_step, c.step, v)}
    raise SceneError(f"--knob {knob!r}: unknown knob; allowed: {', '.join(KNOBS)}")


def _int(knob: str, value) -> int:
    if isinstance(value, bool) or float(value) != int(value):
        raise SceneError(f"--knob {knob}={value}: must be an integer")
    return int(value)


def plan(scene: Scene, knobs: dict[str, list] | None = None,
         only: list[str] | None = None) -> list[tuple[Setting, Scene]]:
    """Settings to run, each validated (raises :class:`SceneError` before any run).

    Parameters
    ----------
    scene
        The base scene (the study varies one knob at a time around it).
    knobs
        ``{knob: [values]}`` replacing the default values of those knobs.
    only
        Sweep only these knobs (default: every knob that applies to the scene).
    """
    knobs = dict(knobs or {})
    for k in list(knobs) + list(only or []):
        if k not in KNOBS:
            raise SceneError(f"--knob/--only {k!r}: unknown knob; allowed: {', '.join(KNOBS)}")
    names = list(only) if only else list(KNOBS)
    out = []
    for k in names:
        why = applicable(scene, k)
        if why is not None:
            if only or k in knobs:
                raise SceneError(f"--knob/--only {k}: does not apply to scene "
                                 f"{scene.name!r} ({why})")
            logger.info("knob %s skipped: %s", k, why)
            continue
        values = knobs.get(k) or default_values(scene, k)
        if len(values) < 2:
            raise SceneError(f"--knob {k}={values}: give at least 2 values")
        for v in values:
            ov = knob_overrides(scene, k, v)
            sc = scene_from_dict(apply_overrides(scene.raw, ov), scene.name, scene.text)
            if k == "aft":
                try:
                    _n_time(sc)  # HarmonicSet checks n_time > 2 max index
                except ValueError as exc:
                    raise SceneError(f"--knob aft={_num(v)}: {exc}") from exc
            out.append((Setting(k, v, ov), sc))
    if not out:
        raise SceneError(f"no knob applies to scene {scene.name!r}")
    return out


# --------------------------------------------------------------------------- errors

def _segments(rpm: np.ndarray) -> list[np.ndarray]:
    """Index ranges of the pieces of a branch that are monotonic in speed."""
    n = len(rpm)
    if n < 2:
        return [np.arange(n)]
    d = np.sign(np.diff(rpm))
    for i in range(1, len(d)):  # flat steps take the previous direction
        if d[i] == 0:
            d[i] = d[i - 1]
    cuts = [0] + [i + 1 for i in range(1, len(d)) if d[i] != d[i - 1]] + [n - 1]
    segs = []
    for a, b in zip(cuts[:-1], cuts[1:], strict=True):
        segs.append(np.arange(a, b + 1))  # consecutive segments share the fold point
    return segs


def curve_error(ref_rpm, ref_val, rpm, val, slack: float = SPEED_SLACK) -> float:
    """Max relative error of a response curve against a reference (see module doc).

    Parameters
    ----------
    ref_rpm, ref_val
        Reference branch: speeds (rpm) and values (e.g. mesh-load std, N).
    rpm, val
        The compared branch, same units; both may turn back at folds.
    slack
        Relative speed slack (-): values at ``rpm_ref (1 ± slack)`` also count.

    Returns
    -------
    float
        ``max_i min_candidates |v − v_ref,i| / max(|v_ref,i|, 1e-9 max|v_ref|)`` over
        the reference points inside the compared branch's speed range.
    """
    ref_rpm, ref_val = np.asarray(ref_rpm, float), np.asarray(ref_val, float)
    rpm, val = np.asarray(rpm, float), np.asarray(val, float)
    if len(ref_rpm) == 0 or len(rpm) < 2:
        raise ValueError("curve_error: branches need points (reference >= 1, compared >= 2)")
    inside = (ref_rpm >= rpm.min()) & (ref_rpm <= rpm.max())
    r, v = ref_rpm[inside], ref_val[inside]
    best = np.full(len(r), np.inf)
    for seg in _segments(rpm):
        x, y = rpm[seg], val[seg]
        o = np.argsort(x, kind="stable")
        x, y = x[o], y[o]
        for f in (1.0, 1.0 - slack, 1.0 + slack):
            q = r * f
            ok = (q >= x[0]) & (q <= x[-1])
            if ok.any():
                best[ok] = np.minimum(best[ok], np.abs(np.interp(q[ok], x, y) - v[ok]))
    # points of the compared branch within the slack window (steep stretches)
    win = np.abs(rpm[None, :] - r[:, None]) <= slack * r[:, None]
    if win.any():
        d = np.where(win, np.abs(val[None, :] - v[:, None]), np.inf)
        best = np.minimum(best, d.min(axis=1))
    scale = np.maximum(np.abs(v), 1e-9 * np.max(np.abs(ref_val)))
    rel = best / scale
    if rel.size == 0 or not np.all(np.isfinite(rel)):
        raise ValueError("curve_error: the branches share no speed")
    return float(rel.max())


def grazing_error(ref: list, graz: list, window: float = MATCH_WINDOW) -> GrazingMatch:
    """Match grazing points (``hbm.GrazingPoint``) to the reference's, same flank.

    Pairs are taken greedily by increasing relative speed distance, at most
    ``window`` (relative) apart; the rest is missing (reference) or extra (setting).
    """
    cand = []
    for i, a in enumerate(ref):
        for j, b in enumerate(graz):
            if a.side == b.side:
                d = abs(b.rpm - a.rpm) / a.rpm
                if d <= window:
                    cand.append((d, i, j))
    cand.sort()
    used_i, used_j = set(), set()
    m = GrazingMatch()
    for _, i, j in cand:
        if i in used_i or j in used_j:
            continue
        used_i.add(i)
        used_j.add(j)
        m.pairs.append((float(ref[i].rpm), float(graz[j].rpm), ref[i].side))
    m.pairs.sort()
    m.missing = sorted(float(a.rpm) for i, a in enumerate(ref) if i not in used_i)
    m.extra = sorted(float(b.rpm) for j, b in enumerate(graz) if j not in used_j)
    return m


def rom_frequency_error(ref_rom, rom, f_max: float) -> float:
    """Max relative error of the coupled ROM frequencies (eq. 17) up to ``f_max`` (Hz).

    Modes are matched by rank; the error of mode k is ``|f_k − f_ref,k| /
    max(f_ref,k, f_1)`` with ``f_1`` the reference's first non-zero frequency
    (as Fig. 9). A missing mode counts as 1.
    """
    fr = np.sort(np.asarray(ref_rom.frequencies_hz, float))
    f = np.sort(np.asarray(rom.frequencies_hz, float))
    nz = fr[fr > 1e-6 * fr.max()]
    f1 = nz[0] if nz.size else 1.0
    keep = np.flatnonzero(fr <= f_max)
    if keep.size == 0:
        return 0.0
    err = np.ones(keep.size)
    ok = keep < f.size
    err[ok] = np.abs(f[keep[ok]] - fr[keep[ok]]) / np.maximum(fr[keep[ok]], f1)
    return float(err.max())


def _validity_hz(scene: Scene, rom) -> float:
    v = getattr(rom, "validation", None)
    if v is not None and float(v.validity_hz) > 0:
        return float(v.validity_hz)
    # no validation stored: the highest mesh harmonic at the top speed
    return scene.hbm.mesh_harmonics * scene.gear.teeth * scene.continuation.speed[1] / 60.0


# --------------------------------------------------------------------------- housing

@dataclass
class _Field:
    """Complex displacement amplitudes per harmonic index at the housing speed."""

    rpm: float
    n_fe: int
    amplitudes: dict  # harmonic index -> complex (n_fe,) (link-node rows zeroed)
    max_amplitude: float


def _housing_field(result: RunResult, rpm: float) -> _Field:
    """Re-solve the HBM point at ``rpm``, recover q and rebuild u = T q from rom.h5."""
    import h5py

    from hbm import ConvergenceError
    from study.points import nearest_point

    _, pt = nearest_point(result, rpm)
    prob = result.problem
    try:
        pt = prob.solve(rpm, x0=pt.unknowns, tol=result.scene.continuation.tolerance)
    except ConvergenceError as exc:
        logger.warning("housing: no HBM point exactly at %g rpm (%s); using the branch "
                       "point at %.6g rpm", rpm, exc, pt.rpm)
    q = prob.recover(pt)                                      # (n_r, nS)
    rd = result.rom
    with h5py.File(rd.folder / "rom.h5", "r") as f:
        T = f["rom/basis"][()]                                # (n_fe, n_r)
    with h5py.File(rd.folder / "nodes.h5", "r") as f:
        link = np.asarray(f["rows"][()], dtype=np.int64)
    U = T @ q                                                 # (n_fe, nS)
    U[link[(link >= 0) & (link < U.shape[0])]] = 0.0          # 6-DOF link nodes (rotations)
    idx = [int(k) for k in prob.harmonics.indices]
    tau = 2 * np.pi * np.arange(64) / 64
    u_t = (U[:, :, None] * np.exp(1j * np.outer(idx, tau))[None]).real.sum(axis=1)
    return _Field(float(pt.rpm), U.shape[0], {k: U[:, i] for i, k in enumerate(idx)},
                  float(np.abs(u_t).max()))


def _field_error(ref: _Field, f: _Field) -> tuple[float, str]:
    """Relative L2 error over space and one period (Parseval), or of the max amplitude."""
    if ref.n_fe != f.n_fe:
        return abs(f.max_amplitude - ref.max_amplitude) / ref.max_amplitude, "max amplitude"
    num = den = 0.0
    for k in set(ref.amplitudes) | set(f.amplitudes):
        w = 1.0 if k == 0 else 0.5
        a = ref.amplitudes.get(k)
        b = f.amplitudes.get(k)
        a = np.zeros(ref.n_fe) if a is None else a
        b = np.zeros(ref.n_fe) if b is None else b
        num += w * float(np.vdot(b - a, b - a).real)
        den += w * float(np.vdot(a, a).real)
    return math.sqrt(num / den) if den > 0 else 0.0, "L2 field"


# --------------------------------------------------------------------------- running

class _TimedPipeline(Pipeline):
    """The pipeline, recording the wall time of every stage that runs."""

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.stage_seconds: dict[str, float] = {}

    def _log_stage(self, name: str, how: str, seconds: float | None = None) -> None:
        super()._log_stage(name, how, seconds)
        if seconds is not None and how in ("ran", "resumed"):
            self.stage_seconds[name] = self.stage_seconds.get(name, 0.0) + seconds


class _Timings:
    """``<cache>/timings.json``: stage key -> seconds it took when it ran."""

    def __init__(self, cache_dir: Path) -> None:
        self.path = Path(cache_dir) / "timings.json"
        try:
            self.data = json.loads(self.path.read_text())
        except (OSError, ValueError):
            self.data = {}

    def record(self, pipe: _TimedPipeline) -> None:
        for st, s in pipe.stage_seconds.items():
            if st in pipe.keys:
                self.data[pipe.keys[st]] = s
        self.path.parent.mkdir(parents=True, exist_ok=True)
        _write_text(self.path, json.dumps(self.data, indent=1))

    def cost(self, pipe: _TimedPipeline, stages: tuple[str, ...]) -> float | None:
        total = 0.0
        for st in stages:
            key = pipe.keys.get(st)
            if key is None:
                continue
            if key not in self.data:
                return None
            total += float(self.data[key])
        return total


def _write_text(path: Path, text: str) -> None:
    with atomic_write(path, "w") as f:
        f.write(text)


def _run_one(setting: Setting, scene: Scene, out: Path, cache_dir: Path, timings: _Timings,
             refresh: bool, progress: bool) -> Row:
    row = Row(setting)
    # housing fields are rebuilt here from the ROM basis, not written as XDMF
    sc = scene_from_dict(apply_overrides(scene.raw, {"outputs.housing_field_rpm": []}),
                         scene.name, scene.text)
    pipe = _TimedPipeline(sc, out, cache_dir=cache_dir, refresh=refresh, progress=progress)
    logger.info("setting %s (%s)", setting.label,
                ", ".join(f"{k}={_num(v)}" for k, v in setting.overrides.items()))
    from hbm import ConvergenceError
    try:
        res = pipe.run(until="hbm")
    except (SolverError, ConvergenceError) as exc:
        logger.error("setting %s: %s", setting.label, exc)
        row.status = "solver failure"
        row.stages = dict(pipe.stages)
        return row
    res.scene = scene
    timings.record(pipe)
    row.result = res
    row.stages = {k: v.split(" ")[0] for k, v in pipe.stages.items()}
    row.seconds_run = res.seconds
    row.points = len(res.branch)
    stages = _COST_STAGES.get(setting.knob, ("hbm",))
    if scene.scene.kind == "lumped":
        stages = ("hbm",)
    row.seconds = timings.cost(pipe, stages)
    reused = [k for k, v in pipe.stages.items() if v.startswith(("cached", "skipped (rom"))]
    logger.info("setting %s: %d points, stages %s; reused from cache: %s; cost %s",
                setting.label, row.points,
                ", ".join(f"{k} {v}" for k, v in pipe.stages.items()
                          if not v.startswith("skipped (lumped")),
                ", ".join(reused) or "-",
                "unknown" if row.seconds is None else f"{row.seconds:.2f} s")
    return row


def _compare(rows: list[Row], scene: Scene, slack: float) -> None:
    """Fill the errors of every row against the reference row of its knob."""
    ok = [r for r in rows if r.status == "ok"]
    finest = _FINEST.get(rows[0].setting.knob, max)
    ref_value = finest(r.setting.value for r in rows)
    ref = next((r for r in ok if r.setting.value == ref_value), None)
    if ref is None:
        logger.error("knob %s: the reference %s failed; no errors computed",
                     rows[0].setting.knob, rows[0].setting.knob + "=" + _num(ref_value))
        return
    ref.reference = True
    rb = ref.result.branch
    fe = scene.scene.kind == "fe"
    f_max = _validity_hz(scene, ref.result.rom) if fe else 0.0
    house_rpm = scene.outputs.housing_field[0] if fe and scene.outputs.housing_field else None
    if house_rpm is not None:
        ref.housing = _housing_field(ref.result, house_rpm)
    for r in ok:
        br = r.result.branch
        r.curve_err = curve_error(rb.rpm, rb.mesh_load_std, br.rpm, br.mesh_load_std, slack)
        r.grazing = grazing_error(list(rb.grazing), list(br.grazing))
        if fe:
            r.rom_freq_err = rom_frequency_error(ref.result.rom, r.result.rom, f_max)
        if house_rpm is not None:
            if r.housing is None:
                r.housing = _housing_field(r.result, house_rpm)
            r.housing_err, r.housing_metric = _field_error(ref.housing, r.housing)
        if r is ref:  # exactly 0 by definition (re-solves are deterministic anyway)
            r.curve_err, r.rom_freq_err = 0.0, (0.0 if fe else None)
            r.housing_err = 0.0 if house_rpm is not None else None


def recommend(rows: list[Row], tol: float) -> Row | None:
    """Cheapest row (known cost) whose errors are all within ``tol``; else the reference."""
    good = [r for r in rows if r.within(tol) and r.seconds is not None]
    if good:
        return min(good, key=lambda r: (r.seconds, r.reference))
    return next((r for r in rows if r.reference), None)


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
        ``{knob: [values]}`` replacing default values (knobs: :data:`KNOBS`; ``mesh``
        values are factors of the mesh size, the others the scene values themselves).
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
    if isinstance(scene, Scene):
        base = scene if not overrides else scene_from_dict(
            apply_overrides(scene.raw, overrides), scene.name, scene.text)
    else:
        base = load_scene(scene, overrides)
    settings = plan(base, knobs, only)  # everything validated before any run
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    cache = Path(cache_dir) if cache_dir else out.resolve().parent / ".geardyn-cache"
    timings = _Timings(cache)
    logger.info("convergence of %r: %d settings over knobs %s (cache %s)", base.name,
                len(settings), ", ".join(dict.fromkeys(s.knob for s, _ in settings)), cache)
    rows: list[Row] = []
    for st, sc in settings:
        folder = out / "runs" / st.label.replace("=", "-")
        rows.append(_run_one(st, sc, folder, cache, timings, refresh, progress))
    rec: dict[str, Row] = {}
    for knob in dict.fromkeys(r.setting.knob for r in rows):
        kr = [r for r in rows if r.setting.knob == knob]
        _compare(kr, base, speed_slack)
        best = recommend(kr, tol)
        if best is not None:
            best.recommended = True
            rec[knob] = best
    result = ConvergenceResult(rows, rec, tol)
    result.files = write_outputs(result, out, base)
    for knob, r in rec.items():
        logger.info("recommended %s = %s (cost %s, max error %.3g <= tol %g)", knob,
                    _num(r.setting.value), _cost_text(r), r.max_err or 0.0, tol)
    failed = [r.setting.label for r in rows if r.status != "ok"]
    if failed:
        raise SolverError(f"convergence: settings failed: {', '.join(failed)} (the table "
                          f"in {out} lists the others)", result)
    return result


# --------------------------------------------------------------------------- outputs

_COLUMNS = ["knob", "value", "reference", "status", "seconds", "seconds_run", "points",
            "stages", "rom_freq_err", "curve_err", "grazing_ref", "grazing_matched",
            "grazing_fig11", "grazing_missing", "grazing_extra", "grazing_max_abs_rpm",
            "grazing_rel_err", "housing_err", "housing_metric", "max_err", "within_tol",
            "recommended", "overrides"]


def _cost_text(r: Row) -> str:
    return "unknown" if r.seconds is None else f"{r.seconds:.2f} s"


def _csv_row(r: Row, tol: float) -> dict:
    g = r.grazing

    def f(x):
        return "" if x is None else f"{x:.6g}"
    return {"knob": r.setting.knob, "value": _num(r.setting.value),
            "reference": int(r.reference), "status": r.status, "seconds": f(r.seconds),
            "seconds_run": f"{r.seconds_run:.3f}", "points": r.points,
            "stages": " ".join(f"{k}:{v}" for k, v in r.stages.items() if v != "skipped"),
            "rom_freq_err": f(r.rom_freq_err), "curve_err": f(r.curve_err),
            "grazing_ref": "" if g is None else len(g.pairs) + len(g.missing),
            "grazing_matched": "" if g is None else len(g.pairs),
            "grazing_fig11": "" if g is None else g.fig11,
            "grazing_missing": "" if g is None else " ".join(f"{x:.1f}" for x in g.missing),
            "grazing_extra": "" if g is None else " ".join(f"{x:.1f}" for x in g.extra),
            "grazing_max_abs_rpm": "" if g is None else f"{g.max_abs_rpm:.4g}",
            "grazing_rel_err": "" if g is None else f"{g.max_rel:.6g}",
            "housing_err": f(r.housing_err), "housing_metric": r.housing_metric,
            "max_err": f(r.max_err), "within_tol": int(r.within(tol)),
            "recommended": int(r.recommended),
            "overrides": ";".join(f"{k}={_num(v)}" for k, v in r.setting.overrides.items())}


def table_markdown(result: ConvergenceResult) -> str:
    """The Markdown table of all rows (one per setting)."""
    fe = any(r.rom_freq_err is not None for r in result.rows)
    house = any(r.housing_err is not None for r in result.rows)
    head = ["knob", "value", "cost (s)", "points"]
    head += ["ROM freq. err"] if fe else []
    head += ["curve err", "grazing: matched (±1 %) / ref", "grazing err (rpm, rel.)",
             "missing / extra"]
    head += ["housing err"] if house else []
    head += ["max err", ""]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]

    def e(x):
        return "–" if x is None else f"{x:.2e}"
    for r in result.rows:
        g = r.grazing
        cells = [r.setting.knob, _num(r.setting.value) + (" (ref)" if r.reference else ""),
                 "n/a" if r.seconds is None else f"{r.seconds:.2f}", str(r.points)]
        cells += [e(r.rom_freq_err)] if fe else []
        if g is None:
            cells += [e(r.curve_err), "–", "–", "–"]
        else:
            n_ref = len(g.pairs) + len(g.missing)
            cells += [e(r.curve_err), f"{len(g.pairs)} ({g.fig11}) / {n_ref}",
                      f"{g.max_abs_rpm:.3g}, {g.max_rel:.2e}",
                      (", ".join(f"{x:.0f}" for x in g.missing) or "–") + " / " +
                      (", ".join(f"{x:.0f}" for x in g.extra) or "–")]
        cells += [e(r.housing_err) + (f" ({r.housing_metric})" if r.housing_metric else "")] \
            if house else []
        mark = "**recommended**" if r.recommended else ("" if r.status == "ok" else r.status)
        cells += [e(r.max_err), mark]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def recommendation_text(result: ConvergenceResult) -> str:
    lines = [f"Recommendation (tolerance {result.tol:g}: cheapest value of each knob "
             "whose errors are all within it):", ""]
    for knob, r in result.recommendation.items():
        why = "within tolerance" if r.within(result.tol) else \
            "no other value within tolerance: the reference"
        lines.append(f"- {knob} = {_num(r.setting.value)} (cost {_cost_text(r)}, max error "
                     f"{(r.max_err or 0.0):.2e}; {why})")
    ov = result.overrides()
    if ov:
        lines += ["", "As scene overrides: " + " ".join(
            f"`--set {k}={_num(v)}`" for k, v in ov.items())]
    return "\n".join(lines)


def write_outputs(result: ConvergenceResult, out: Path, scene: Scene) -> list[Path]:
    """``convergence.csv``, ``convergence.md`` and ``pareto.png`` in ``out``."""
    out = Path(out)
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=_COLUMNS, lineterminator="\n")
    w.writeheader()
    for r in result.rows:
        w.writerow(_csv_row(r, result.tol))
    _write_text(out / "convergence.csv", buf.getvalue())
    png = pareto_plot(result, out / "pareto.png")
    md = [f"# Convergence study: {scene.name}", "",
          "One knob varied at a time around the scene's settings; errors are relative, "
          "against the knob's most converged value (ref). Cost: wall time of the stages "
          "the knob changes. See docs/convergence.md for the definitions.", "",
          table_markdown(result), "", recommendation_text(result), "",
          "![error against cost](pareto.png)", ""]
    _write_text(out / "convergence.md", "\n".join(md))
    text = recommendation_text(result)
    logger.info("%s", text)
    return [out / "convergence.csv", out / "convergence.md", png]


def pareto_plot(result: ConvergenceResult, path: Path) -> Path:
    """Max error against cost, log-log, one series per knob, recommended points starred."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = [r for r in result.rows if r.max_err is not None and r.seconds is not None]
    pos = [r.max_err for r in rows if r.max_err > 0]
    floor = min(pos + [result.tol]) / 10          # where the references (error 0) are drawn
    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    for i, knob in enumerate(dict.fromkeys(r.setting.knob for r in rows)):
        kr = sorted((r for r in rows if r.setting.knob == knob), key=lambda r: r.seconds)
        x = [max(r.seconds, 1e-3) for r in kr]
        y = [max(r.max_err, floor) for r in kr]
        line, = ax.plot(x, y, "o-", color=f"C{i}", label=knob)
        for r, xi, yi in zip(kr, x, y, strict=True):
            ax.annotate(_num(r.setting.value) + (" (ref)" if r.reference else ""), (xi, yi),
                        textcoords="offset points", xytext=(4, 4), fontsize=7)
            if r.reference:
                ax.plot([xi], [yi], "o", ms=10, mfc="none", mec=f"C{i}")
            if r.recommended:
                ax.plot([xi], [yi], "*", ms=16, mfc="none", mec="k", mew=1.5)
    ax.axhline(result.tol, color="0.5", ls="--", lw=1, label=f"tol {result.tol:g}")
    ax.plot([], [], "*", ms=12, mfc="none", mec="k", label="recommended")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("cost: wall time of the knob's stages (s)")
    ax.set_ylabel(f"max relative error (ref: 0, drawn at {floor:.1e})")
    ax.set_title("Error against run time")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    try:
        with atomic_write(path) as tmp:
            fig.savefig(tmp, dpi=120)
    finally:
        plt.close(fig)
    return path
