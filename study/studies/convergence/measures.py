"""Error measures of the convergence study and the table they fill.

Every setting is compared with its knob's reference (docs/convergence.md gives the
definitions): :func:`curve_error` (mesh-load standard deviation along the branch,
fold by fold), :func:`grazing_error` (grazing speeds matched on the same flank,
eq. 30, Fig. 11) and :func:`rom_frequency_error` (coupled ROM frequencies, eq. 17,
Fig. 9). A :class:`Row` holds one setting's cost and errors; :func:`recommend`
picks the cheapest row within the tolerance.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from study.scene.data import Scene
from study.studies.convergence.knobs import Setting, fmt_value

__all__ = ["FIG11_BAND", "MATCH_WINDOW", "SPEED_SLACK", "GrazingMatch", "Row",
           "ConvergenceResult", "curve_error", "grazing_error", "rom_frequency_error",
           "validity_hz", "recommend", "MIN_VALUES"]

FIG11_BAND = 0.01        # grazing speeds within ±1 % (Fig. 11)
MATCH_WINDOW = 0.05      # grazings further apart than 5 % are not matched
SPEED_SLACK = 2e-3       # relative speed slack of the curve comparison


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
    note: str = ""                     # why the setting failed (status != "ok")
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
    #: knob -> why it has no recommendation (:func:`recommend`)
    verdicts: dict[str, str] = field(default_factory=dict)

    def overrides(self) -> dict:
        """Scene overrides of the recommended values (all knobs combined)."""
        out: dict = {}
        for r in self.recommendation.values():
            out.update(r.setting.overrides)
        return out



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


def validity_hz(scene: Scene, rom) -> float:
    """Validity frequency (Hz, Fig. 9) of a ROM: its validation's, else the highest mesh
    harmonic at the top speed."""
    v = getattr(rom, "validation", None)
    if v is not None and float(v.validity_hz) > 0:
        return float(v.validity_hz)
    # no validation stored: the highest mesh harmonic at the top speed
    from machines import machine_for

    top = max(m.frequency_ratio for m in machine_for(scene).gear_meshes)
    return scene.hbm.mesh_harmonics * top * scene.continuation.speed[1] / 60.0


#: Fewest values of a knob that must have run for a verdict: the reference (the finest)
#: and two coarser ones. With two, the finest is its own reference and unchecked: a
#: coarser value agreeing with it shows no trend towards a limit (the classic three-grid
#: argument of Richardson extrapolation).
MIN_VALUES = 3


def recommend(rows: list[Row], tol: float) -> tuple[Row | None, str]:
    """The recommended row of one knob and the verdict behind it.

    Returns ``(row, "within tolerance")`` for the cheapest row (known cost) other than
    the reference whose errors are all within ``tol``; ``(None, why)`` when the rows
    cannot support a recommendation: the reference failed, fewer than
    :data:`MIN_VALUES` values ran, or no value but the reference is within ``tol`` (the
    reference is never recommended: nothing finer checks it).
    """
    ok = [r for r in rows if r.status == "ok"]
    ref = next((r for r in ok if r.reference), None)
    if ref is None:
        return None, "its reference setting failed, so no errors were computed"
    name, v = ref.setting.knob, fmt_value(ref.setting.value)
    if len(ok) < MIN_VALUES:
        return None, (f"too few values to judge ({len(ok)} ran, at least {MIN_VALUES} "
                      f"needed): the finest, {name} = {v}, is its own reference and "
                      "nothing checks it, so no value can be called converged; add values "
                      "(`--knob`)")
    good = [r for r in ok if not r.reference and r.within(tol) and r.seconds is not None]
    if not good:
        return None, (f"not converged over the values tried: no value but the reference "
                      f"{name} = {v} is within {tol:g} of it, and the reference itself is "
                      "unchecked; add finer values (`--knob`)")
    return min(good, key=lambda r: r.seconds), "within tolerance"
