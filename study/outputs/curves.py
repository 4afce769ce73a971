"""Features of a forced-response curve: resonance peaks, impact intervals, the
vibro-impact span and the permanent-contact windows between impact regions.

Plain functions of the per-point arrays of a branch (speed in rpm, std of the
dynamic mesh load in N, contact class 0/1/2), so that they can be checked on
synthetic curves. Used by the report, the plots and the studies.
"""
from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, replace

import numpy as np

__all__ = ["Peak", "FoldPair", "UnstableSegment", "CurveSummary", "resonance_peaks",
           "fold_pairs", "unstable_segments", "kind_name", "kind_label", "is_unstable",
           "class_intervals", "contact_intervals", "impact_intervals", "merge_intervals",
           "impact_span", "contact_windows", "summarize_curve", "summarize_branch",
           "primary_peak", "ipp_runs", "ipp_fractions"]

#: Local maxima less prominent than this fraction of the curve's largest std are
#: numerical wiggles, not resonances.
MIN_PROMINENCE = 0.01
# maxima closer than this (relative speed) are one resonance: a branch winding at one
# speed has a local maximum per loop (the pump at 1393 and 2509 rpm)
SAME_PEAK = 5e-3


@dataclass(frozen=True)
class Peak:
    """A local maximum of the mesh-load std along the branch: refined speed and std,
    prominence, the branch point it was found at (``index``) and the leading Floquet
    kind of that point's orbit (``kind``, a :data:`hbm.stability.KINDS` name; "" when
    stable or not computed)."""

    rpm: float
    std: float
    prominence: float
    index: int = -1
    kind: str = ""


@dataclass(frozen=True)
class FoldPair:
    """Two consecutive turning points of the branch: the hysteresis of an amplitude jump
    (the response jumps between the stable parts the unstable middle part joins).

    ``rpm`` and ``std`` are the speeds (rpm) and mesh-load std (N) at the two folds, in
    branch order."""

    rpm: tuple[float, float]
    std: tuple[float, float]

    @property
    def width(self) -> float:
        """Speed interval of the hysteresis (rpm)."""
        return abs(self.rpm[1] - self.rpm[0])

    @property
    def height(self) -> float:
        """Std difference between the two folds (N)."""
        return abs(self.std[1] - self.std[0])

    @property
    def centre(self) -> float:
        """Mid speed of the pair (rpm)."""
        return 0.5 * (self.rpm[0] + self.rpm[1])


def kind_name(code: int) -> str:
    """The :data:`hbm.stability.KINDS` name of a leading-exponent code (1 fold, 2 period
    doubling, 3 Neimark–Sacker; another code, e.g. read from an old file,
    ``"unclassified"``)."""
    from hbm.stability import KINDS

    return KINDS[code] if 1 <= code < len(KINDS) else "unclassified"


def is_unstable(kind: str) -> bool:
    """Whether a stability kind (:data:`hbm.stability.KINDS`, "" when not computed) says
    the orbit is unstable."""
    return kind not in ("", "stable")


def kind_label(kind: str) -> str:
    """A stability kind of :data:`hbm.stability.KINDS` as words ("Neimark–Sacker",
    "period doubling", "fold", "stable")."""
    return {"neimark_sacker": "Neimark–Sacker"}.get(kind, kind.replace("_", " "))


@dataclass(frozen=True)
class UnstableSegment:
    """Consecutive unstable points of a branch (in branch order) with one leading kind.

    ``kind`` is one of :data:`hbm.stability.KINDS` but ``"stable"`` (or
    ``"unclassified"`` for a kind code outside them, e.g. read from an old file): how the periodic
    orbit loses stability there (``"fold"``: the middle part of an amplitude jump;
    ``"period_doubling"``: a response at half the fundamental frequency takes over;
    ``"neimark_sacker"``: a quasi-periodic or a coexisting response takes over).
    ``rpm`` is the (lowest, highest) speed of the segment's points, ``peak_std`` the
    largest mesh-load std on it (N), ``index`` its first and last point in branch order
    (None if not known).
    """

    kind: str
    rpm: tuple[float, float]
    points: int
    peak_std: float
    index: tuple[int, int] | None = None

    @property
    def label(self) -> str:
        """The kind as words ("Neimark–Sacker", "period doubling", "fold")."""
        return kind_label(self.kind)

    def contains(self, rpm: float) -> bool:
        """Whether ``rpm`` lies within the segment's speed interval."""
        return self.rpm[0] <= rpm <= self.rpm[1]


@dataclass(frozen=True)
class CurveSummary:
    """What the paper compares between runs (Sect. 4.2–4.3), SI / rpm.

    Attributes
    ----------
    speed_range
        (start, end) of the continuation (rpm).
    reached
        Highest speed reached (rpm); below ``speed_range[1]`` if the run stopped early.
    peaks
        Every local maximum of the std with prominence >= :data:`MIN_PROMINENCE` × max,
        sorted by speed.
    grazing
        Grazing speeds (rpm), sorted.
    impacts
        Merged speed intervals (rpm) where the branch has impacts (either flank).
    windows
        Permanent-contact windows: gaps between two impact intervals (rpm).
    span
        Total length of the impact intervals (rpm).
    max_std, max_std_rpm
        Largest std of the dynamic mesh load (N) and its speed (rpm).
    max_std_kind
        Leading Floquet kind of that point's orbit ("" when stable or not computed).
    complete
        The continuation reached the end of its range.
    folds
        Fold pairs (amplitude jumps) along the branch, in branch order.
    unstable
        Unstable segments along the branch, in branch order (:func:`unstable_segments`;
        empty when the run computed no stability).
    """

    speed_range: tuple[float, float]
    reached: float
    peaks: list[Peak]
    grazing: list[float]
    impacts: list[tuple[float, float]]
    windows: list[tuple[float, float]]
    span: float
    max_std: float
    max_std_rpm: float
    complete: bool = True
    folds: tuple[FoldPair, ...] = ()
    unstable: tuple[UnstableSegment, ...] = ()
    max_std_kind: str = ""

    def unstable_at(self, rpm: float) -> list[UnstableSegment]:
        """The unstable segments whose speed interval holds ``rpm``."""
        return [u for u in self.unstable if u.contains(rpm)]

    def strongest(self, n: int) -> list[Peak]:
        """The ``n`` most prominent peaks, sorted by speed."""
        best = sorted(self.peaks, key=lambda p: p.prominence, reverse=True)[:n]
        return sorted(best, key=lambda p: p.rpm)


def resonance_peaks(rpm: np.ndarray, std: np.ndarray,
                    min_prominence: float = MIN_PROMINENCE) -> list[Peak]:
    """Local maxima of the std along the branch (in point order, so that the top of a
    fold counts once), with their topographic prominence; sorted by speed.

    End points are not peaks (a range end is not a resonance). The maximum is refined
    by a parabola through the three points around it when the speeds are monotonic
    there.
    """
    from scipy.signal import find_peaks

    rpm = np.asarray(rpm, dtype=float)
    std = np.asarray(std, dtype=float)
    if rpm.shape != std.shape or rpm.ndim != 1:
        raise ValueError(f"rpm {rpm.shape} and std {std.shape}: must be 1-D of equal length")
    if rpm.size < 3:
        return []
    top = float(np.max(std))
    idx, props = find_peaks(std, prominence=min_prominence * top if top > 0 else None)
    out = []
    for i, prom in zip(idx, props["prominences"], strict=True):
        r, s = _refine(rpm[i - 1:i + 2], std[i - 1:i + 2])
        out.append(Peak(r, s, float(prom), int(i)))
    return _merge_close(sorted(out, key=lambda p: p.rpm))


def _merge_close(peaks: list[Peak]) -> list[Peak]:
    """One peak per resonance: maxima within ``SAME_PEAK`` (relative speed) of each other
    are the loops of a branch winding at one speed (docs/convergence.md); the highest
    stays, with the largest prominence of the group."""
    out: list[Peak] = []
    for p in peaks:
        if out and abs(p.rpm - out[-1].rpm) <= SAME_PEAK * p.rpm:
            q = out[-1]
            top = p if p.std > q.std else q
            out[-1] = replace(top, prominence=max(p.prominence, q.prominence))
        else:
            out.append(p)
    return out


def _refine(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """Vertex of the parabola through three points around a maximum (x strictly
    monotonic), else the middle point."""
    x0, x1, x2 = (float(v) for v in x)
    y0, y1, y2 = (float(v) for v in y)
    if not ((x0 < x1 < x2) or (x0 > x1 > x2)):
        return x1, y1
    a = np.polyfit([x0, x1, x2], [y0, y1, y2], 2)
    if a[0] >= 0:
        return x1, y1
    xv = -a[1] / (2 * a[0])
    if not min(x0, x2) <= xv <= max(x0, x2):
        return x1, y1
    return float(xv), float(max(np.polyval(a, xv), y1))


def class_intervals(rpm: np.ndarray, contact: np.ndarray,
                    grazing: Iterable[float] = ()) -> dict[int, list[tuple[float, float]]]:
    """Merged speed intervals (rpm) of the branch with single-sided (1) and double-sided
    (2) impacts.

    A segment between two points of one class is that class's. A segment whose ends
    differ is split at the grazing speed located on it (the continuation's bisection
    of the contact margin), each part to the class of its end; without exactly one
    grazing on it, the whole segment goes to the larger class (the impacts may start
    anywhere on it).
    """
    rpm = np.asarray(rpm, dtype=float)
    contact = np.asarray(contact, dtype=int)
    g = np.sort(np.asarray(list(grazing), dtype=float))
    out: dict[int, list[tuple[float, float]]] = {1: [], 2: []}
    for i in range(len(rpm) - 1):
        a, b, ca, cb = rpm[i], rpm[i + 1], int(contact[i]), int(contact[i + 1])
        lo, hi = min(a, b), max(a, b)
        on = g[(g >= lo) & (g <= hi)]
        if ca != cb and on.size == 1:
            cut = float(on[0])
            for end, c in ((a, ca), (b, cb)):
                if c in out and end != cut:
                    out[c].append((min(end, cut), max(end, cut)))
        elif max(ca, cb) in out:
            out[max(ca, cb)].append((float(lo), float(hi)))
    return {c: merge_intervals(iv) for c, iv in out.items()}


def contact_intervals(branch, element: int = 0) -> dict[int, list[tuple[float, float]]]:
    """Merged speed intervals (rpm) of a branch with impacts on element ``element``, per
    class, bounded by its grazing speeds (:func:`class_intervals`)."""
    mesh = branch.element(element)
    return class_intervals(branch.rpm, mesh.contact, [g.rpm for g in mesh.grazing])


def impact_intervals(rpm: np.ndarray, contact: np.ndarray,
                     grazing: Iterable[float] = ()) -> list[tuple[float, float]]:
    """Merged speed intervals (rpm) with impacts on either flank
    (:func:`class_intervals`, both classes)."""
    iv = class_intervals(rpm, contact, grazing)
    return merge_intervals(iv[1] + iv[2])


def merge_intervals(segments: Iterable[tuple[float, float]]) -> list[tuple[float, float]]:
    """Sorted union of speed intervals (rpm); intervals that overlap or touch (to 1e-9
    rpm) become one."""
    merged: list[list[float]] = []
    for a, b in sorted(segments):
        if merged and a <= merged[-1][1] + 1e-9:
            merged[-1][1] = max(merged[-1][1], b)
        else:
            merged.append([a, b])
    return [(a, b) for a, b in merged]


def impact_span(intervals: list[tuple[float, float]]) -> float:
    """Total length (rpm) of merged impact intervals (the vibro-impact span, Sect. 4.2)."""
    return float(sum(b - a for a, b in intervals))


def contact_windows(intervals: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """Permanent-contact windows: the gaps between consecutive impact intervals."""
    return [(intervals[i][1], intervals[i + 1][0]) for i in range(len(intervals) - 1)]


def fold_pairs(rpm: np.ndarray, std: np.ndarray, fold_index: Iterable[int]) -> list[FoldPair]:
    """Consecutive folds ``(0, 1), (2, 3), …`` of a branch as :class:`FoldPair`.

    ``fold_index`` holds, per fold, the point where the speed turns back
    (:attr:`hbm.Branch.fold_index`). Indices outside the arrays (a branch resumed from a
    file without them) are skipped; a last fold without a partner (its pair lies beyond
    the computed range) is not a pair and is left out.
    """
    rpm = np.asarray(rpm, dtype=float)
    std = np.asarray(std, dtype=float)
    idx = [int(i) for i in fold_index if 0 <= int(i) < rpm.size]
    return [FoldPair((float(rpm[i]), float(rpm[j])), (float(std[i]), float(std[j])))
            for i, j in zip(idx[0::2], idx[1::2], strict=False)]


def unstable_segments(rpm: np.ndarray, std: np.ndarray, stable: np.ndarray,
                      kind: np.ndarray) -> list[UnstableSegment]:
    """Runs of consecutive unstable points with the same leading kind, in branch order.

    Parameters
    ----------
    rpm, std
        Speed (rpm) and mesh-load std (N) per point.
    stable
        Stability verdict per point (bool).
    kind
        Index in :data:`hbm.stability.KINDS` of the leading exponent per point
        (0 stable, 1 fold, 2 period doubling, 3 Neimark–Sacker); an unstable point
        with another code is ``"unclassified"``.
    """
    rpm = np.asarray(rpm, dtype=float)
    std = np.asarray(std, dtype=float)
    bad = ~np.asarray(stable, dtype=bool)
    kind = np.asarray(kind, dtype=int)
    if not (rpm.shape == std.shape == bad.shape == kind.shape):
        raise ValueError(f"rpm, std, stable, kind shapes = {rpm.shape}, {std.shape}, "
                         f"{bad.shape}, {kind.shape}: must be equal")
    out: list[UnstableSegment] = []
    i, n = 0, rpm.size
    while i < n:
        if not bad[i]:
            i += 1
            continue
        j = i
        while j + 1 < n and bad[j + 1] and kind[j + 1] == kind[i]:
            j += 1
        seg = slice(i, j + 1)
        name = kind_name(int(kind[i]))
        out.append(UnstableSegment(name, (float(rpm[seg].min()), float(rpm[seg].max())),
                                   j - i + 1, float(std[seg].max()), (i, j)))
        i = j + 1
    return out


def summarize_curve(rpm, std, contact, grazing, speed_range, complete: bool = True,
                    fold_index: Iterable[int] = (), stable=None, kind=None) -> CurveSummary:
    """:class:`CurveSummary` of per-point arrays, grazing speeds (rpm), the indices
    of the folds (:func:`fold_pairs`) and, if given, the stability verdict and leading
    kind per point (:func:`unstable_segments`)."""
    rpm = np.asarray(rpm, dtype=float)
    std = np.asarray(std, dtype=float)
    grazing = sorted(float(g) for g in grazing)
    iv = impact_intervals(rpm, contact, grazing)
    i = int(np.argmax(std)) if std.size else 0
    at = _point_kinds(stable, kind, rpm.size)
    return CurveSummary(
        speed_range=(float(speed_range[0]), float(speed_range[1])),
        reached=float(np.max(rpm)) if rpm.size else float(speed_range[0]),
        peaks=[replace(p, kind=at[p.index]) for p in resonance_peaks(rpm, std)],
        grazing=grazing, impacts=iv, windows=contact_windows(iv), span=impact_span(iv),
        max_std=float(std[i]) if std.size else float("nan"),
        max_std_rpm=float(rpm[i]) if rpm.size else float("nan"), complete=complete,
        folds=tuple(fold_pairs(rpm, std, fold_index)),
        unstable=() if stable is None else tuple(unstable_segments(rpm, std, stable, kind)),
        max_std_kind=at[i] if rpm.size else "")


def _point_kinds(stable, kind, n: int) -> list[str]:
    """Per point, the leading Floquet kind of an unstable orbit ("" when stable or when
    no verdicts are given)."""
    if stable is None:
        return [""] * n
    bad = ~np.asarray(stable, dtype=bool)
    code = np.asarray(kind, dtype=int)
    return [kind_name(int(c)) if b else "" for b, c in zip(bad, code, strict=True)]


def summarize_branch(branch) -> CurveSummary:
    """:class:`CurveSummary` of an :class:`hbm.Branch`."""
    mesh = branch.element(0)
    return summarize_curve(branch.rpm, mesh.mesh_load_std, mesh.contact,
                           [g.rpm for g in mesh.grazing],
                           (branch.rpm_start, branch.rpm_end),
                           complete=branch.status == "completed",
                           fold_index=branch.fold_index, stable=branch.stable,
                           kind=branch.floquet_kind)


def ipp_runs(ipp: np.ndarray) -> list[tuple[int, float]]:
    """Cyclic run-length code of an IPP sequence (impacts in each mesh period along the
    fundamental period): ``[(impacts, fraction of the period), ...]`` starting at the
    first change after the wrap-around, so that a run crossing the period end is one."""
    a = np.asarray(ipp, dtype=int).ravel()
    n = a.size
    if n == 0:
        return []
    change = np.flatnonzero(a != np.roll(a, 1))
    if change.size == 0:
        return [(int(a[0]), 1.0)]
    a = np.roll(a, -int(change[0]))
    runs: list[tuple[int, float]] = []
    start = 0
    for i in range(1, n + 1):
        if i == n or a[i] != a[start]:
            runs.append((int(a[start]), (i - start) / n))
            start = i
    return runs


def ipp_fractions(ipp: np.ndarray) -> dict[int, float]:
    """Fraction of the fundamental period spent at each impact count per mesh period."""
    a = np.asarray(ipp, dtype=int).ravel()
    if a.size == 0:
        return {}
    vals, counts = np.unique(a, return_counts=True)
    return {int(v): float(c) / a.size for v, c in zip(vals, counts, strict=True)}


def primary_peak(summary: CurveSummary, near: float | None = None,
                 rel: float = 0.15) -> Peak | None:
    """The primary resonance peak: the peak with the largest std, or (``near`` given)
    the largest peak within ``near·(1 ± rel)`` rpm (the same resonance on another
    curve). ``None`` when there is none."""
    cand = summary.peaks if near is None else \
        [p for p in summary.peaks if abs(p.rpm - near) <= rel * near]
    return max(cand, key=lambda p: p.std) if cand else None
