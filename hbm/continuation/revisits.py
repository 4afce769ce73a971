"""The branch walking back over itself: the distance of a new point to the segments
traced, revisits (a walk back), closed loops (coming round onto its own path the same
way), whether a nearby piece is another solution, and the point where the path turned
(:func:`hbm.continuation.continue_branch`; docs/hbm.md "Reversals", "Closed loops")."""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from ..newton import ConvergenceError
from ..units import RPM_TO_RAD_S
from .branch import Recorder
from .context import TraceContext
from .corrector import StepRejected, correct
from .segments import pair_gaps, segment_gaps

# the tracer's log: one name for the continuation and its modules
logger = logging.getLogger("hbm.continuation")

__all__ = ["LOOP_CONFIRM", "LOOP_MIN_POINTS", "REVISIT_RATIO", "SAME_SOLUTION", "Gaps",
           "branch_gaps", "check_forward", "closed_loop", "distinct_solution",
           "near_segments", "nearest_segment", "past_fold", "reversal_point", "revisit",
           "segment_gaps", "untraced", "untraced_segments"]

# A new point closer than REVISIT_RATIO times its chord to an earlier segment of the
# branch (all but the last) is the branch walking back over itself, not a fold: on the
# pump the retraced points lie 1e-3..5e-2 chords from the old polyline, distinct pieces
# that meet at a fold or corner 0.7..2 chords (docs/hbm.md, "Reversals").
REVISIT_RATIO = 0.1
# A point flagged by REVISIT_RATIO is a revisit only if the old branch at its speed is the
# same solution: Newton at that speed from the old polyline lands within this distance
# (scaled unknowns, relative to max(|y|, 1)) of it. Past a sharp fold whose two pieces
# differ little in state (the pump at 12 mesh harmonics, 1220-1236 rpm: 1e-4..1e-3 apart
# while the chords are ~1e-2, mostly speed) the piece coming back is a distinct solution.
SAME_SOLUTION = 1e-5
# A closed loop (the branch arriving back on its own path in the same direction) has at
# least this many points: the last LOOP_MIN_POINTS segments are not searched.
LOOP_MIN_POINTS = 6
# The step after a point that closed a loop must land on one of the next LOOP_CONFIRM
# segments of the old path (a branch going round again, not crossing its path once).
LOOP_CONFIRM = 3



def check_forward(rec, y, yn) -> None:
    """After a reversal was undone at point k, refuse a step from k that goes back."""
    if rec.guard is not None and rec.guard[0] == len(rec) - 1 and (yn - y) @ rec.guard[1] <= 0:
        raise StepRejected("step goes back over the branch (a reversal was undone here)")


def nearest_segment(ys: np.ndarray, y: np.ndarray, skip: np.ndarray | None = None
                     ) -> tuple[int, float, np.ndarray]:
    """Segment ``(i, i + 1)`` of the polyline ``ys`` nearest to ``y``: ``(i, distance,
    foot)``; segments where ``skip`` is True are left out (distance inf if all are)."""
    d, foot = segment_gaps(ys, y, skip)
    i = int(np.argmin(d))
    return i, float(d[i]), foot[i]


@dataclass(frozen=True)
class Gaps:
    """The segments ``(i, i + 1)`` of a branch closer to a point than a radius: their
    indices (ascending), distances and feet (:func:`segment_gaps`, bitwise)."""

    index: np.ndarray
    distance: np.ndarray
    foot: np.ndarray

    def nearest(self, upto: int) -> tuple[int, float, np.ndarray] | None:
        """The nearest of the segments ``i < upto`` (the first of equals), or None.

        Every segment farther than the radius is left out, so this is the nearest
        segment of the whole branch (:func:`nearest_segment`) whenever that lies
        within the radius, and None otherwise."""
        k = int(np.searchsorted(self.index, upto))
        if k == 0:
            return None
        j = int(np.argmin(self.distance[:k]))
        return int(self.index[j]), float(self.distance[j]), self.foot[j]


def near_segments(ctx: TraceContext, rec: Recorder, y: np.ndarray, radius: float,
                  upto: int) -> Gaps:
    """The segments ``i < upto`` of the branch closer than ``radius`` to ``y``, traced ones
    only (not the join after a closed loop).

    The recorder's :class:`~hbm.continuation.segments.SegmentIndex` drops the blocks of
    segments that lie farther (``O(log n)`` per point on a branch that moves on); a
    stand-in without one has every segment measured. Either way the distances are those
    of a scan of the whole branch, bit for bit.
    """
    ys = ctx.states(rec)
    index = getattr(rec, "segments", None)
    idx = index.near(y, radius, upto) if index is not None else np.arange(max(upto, 0))
    skip = untraced_segments(rec)
    if skip.size and idx.size:
        idx = idx[~np.isin(idx, skip)]
    d, foot = pair_gaps(ys[idx], ys[idx + 1], y)
    keep = d < radius
    return Gaps(idx[keep], d[keep], foot[keep])


def branch_gaps(ctx: TraceContext, rec: Recorder, yn: np.ndarray) -> Gaps | None:
    """The segments of the branch but its last within ``REVISIT_RATIO`` of the last chord
    of a new point (:func:`near_segments`), shared by the walk-back and closed-loop tests
    of one point (None below 3 points)."""
    n = len(rec)
    if n < 3:
        return None
    chord = float(np.linalg.norm(yn - ctx.states(rec)[-1]))
    return near_segments(ctx, rec, yn, REVISIT_RATIO * chord, n - 2)


def revisit(ctx: TraceContext, rec: Recorder, yn: np.ndarray,
             gaps: Gaps | None = None) -> int | None:
    """Index i of the earlier segment (i, i+1) that ``yn`` lies on, or None.

    Every segment but the last is checked; ``yn`` is near the branch when its distance
    to the segment is below ``REVISIT_RATIO`` times its chord from the last point and
    the step from the last point runs against the segment's direction. A
    near point is a revisit only if it is the same solution as the old branch at its
    speed (:func:`distinct_solution`); otherwise it is another piece of the branch lying
    close by (past a sharp fold) and None is returned. ``gaps``: :func:`branch_gaps` of
    ``yn``, if computed already.
    """
    n = len(rec)
    if n < 3:
        return None
    ys = ctx.states(rec)
    gaps = branch_gaps(ctx, rec, yn) if gaps is None else gaps
    near = gaps.nearest(n - 2)
    if near is None:         # no segment closer than REVISIT_RATIO times the chord
        return None
    i, d, foot = near
    chord = float(np.linalg.norm(yn - ys[-1]))
    if (yn - ys[-1]) @ (ys[i + 1] - ys[i]) > 0:
        # the step goes the way the old segment went: a branch that winds past its own
        # earlier loops (a spiral near a resonance with impacts), not a walk back. A walk
        # back runs against the old segment, also when it turned gradually (no single
        # step going back) or came round a loop onto the old branch.
        return None
    if distinct_solution(ctx.evaluate, foot, yn, ctx.tol, ctx.max_iter):
        logger.info("point at scaled speed %.9g lies %.2g chords from the branch traced but "
                    "is another solution there (a sharp fold): not a revisit", yn[-1],
                    d / chord)
        return None
    return i


def untraced_segments(rec) -> np.ndarray:
    """The segments ``(i, i + 1)`` the trace did not go along (from a closed loop's last
    point to the copies of its entry point), ascending: ``i = restart - 1`` of each loop
    (none for a stand-in without loops)."""
    n = len(rec)
    return np.array(sorted({restart - 1 for *_, restart in getattr(rec, "loops", ())
                            if 0 < restart <= n - 1}), dtype=np.intp)


def untraced(rec) -> np.ndarray:
    """Mask over the segments of the branch, True where :func:`untraced_segments`."""
    m = np.zeros(max(len(rec) - 1, 0), dtype=bool)
    m[untraced_segments(rec)] = True
    return m


def closed_loop(ctx: TraceContext, rec: Recorder, yn: np.ndarray, tn: np.ndarray,
                 gaps: Gaps | None = None) -> int | None:
    """Index i of the old segment (i, i+1) on which the branch closed a loop, or None.

    The branch has closed on itself when ``yn`` lies on a segment traced at least
    ``LOOP_MIN_POINTS`` points ago (distance below ``REVISIT_RATIO`` times its chord),
    the step runs the way that segment went (against it is a walk back,
    :func:`revisit`), ``yn`` is the same solution as the old branch at its speed (Newton
    at that speed from the old path lands within ``SAME_SOLUTION`` of ``yn`` relative to
    the state norm, :func:`distinct_solution`), and one more step along ``tn`` lands on
    the old path again, on one of the next ``LOOP_CONFIRM`` segments, the same way: the
    branch goes round the loop again rather than crossing its earlier path once.
    ``gaps``: :func:`branch_gaps` of ``yn``, if computed already.
    """
    n = len(rec)
    upto = n - LOOP_MIN_POINTS          # segments (i, i+1) with i < upto
    if upto < 1:
        return None
    ys = ctx.states(rec)
    gaps = branch_gaps(ctx, rec, yn) if gaps is None else gaps
    near = gaps.nearest(upto)
    if near is None:         # no segment closer than REVISIT_RATIO times the chord
        return None
    i, d, foot = near
    chord = float(np.linalg.norm(yn - ys[-1]))
    if not (yn - ys[-1]) @ (ys[i + 1] - ys[i]) > 0:
        return None
    if distinct_solution(ctx.evaluate, foot, yn, ctx.tol, ctx.max_iter):
        return None
    try:
        y2, *_ = correct(ctx.evaluate, yn + chord * tn, tn, ctx.tol, ctx.max_iter)
    except (ConvergenceError, np.linalg.LinAlgError):
        return None
    step = float(np.linalg.norm(y2 - yn))
    near = near_segments(ctx, rec, y2, REVISIT_RATIO * step, upto).nearest(upto)
    if near is None:
        return None
    j = near[0]
    if not (i <= j <= i + LOOP_CONFIRM and (y2 - yn) @ (ys[j + 1] - ys[j]) > 0):
        return None
    logger.info("the branch closed on itself at rpm %.6g: the new point and the next lie on "
                "the path traced from point %d on, going the same way (a closed loop)",
                yn[-1] * ctx.wscale / RPM_TO_RAD_S, i)
    return i


def distinct_solution(evaluate, foot, yn, tol, max_iter) -> bool:
    """True if the branch traced, at the speed of ``yn``, is a solution other than ``yn``.

    Newton at the fixed speed of ``yn`` from ``foot`` (the nearest point of the old
    polyline, its speed replaced by that of ``yn``). Distinct when it converges to a point
    ``y*`` farther than ``SAME_SOLUTION`` from ``yn`` and closer to ``foot`` than to
    ``yn`` (the old piece, not ``yn``'s or a third one). A failed solve counts as the
    same solution (the revisit is then undone as before).
    """
    y0 = foot.copy()
    y0[-1] = yn[-1]
    e_w = np.zeros_like(yn)
    e_w[-1] = 1.0
    try:
        ys, *_ = correct(evaluate, y0, e_w, tol, max_iter)
    except (ConvergenceError, np.linalg.LinAlgError) as exc:
        logger.debug("revisit check: no solution at the new point's speed from the old "
                     "branch (%s)", exc)
        return False
    gap = float(np.linalg.norm(ys - yn))
    logger.debug("revisit check: old branch at the new point's speed %.3g from it, %.3g from "
                 "the old polyline", gap, float(np.linalg.norm(ys - y0)))
    return gap > SAME_SOLUTION * max(float(np.linalg.norm(yn[:-1])), 1.0) and \
        float(np.linalg.norm(ys - y0)) < 0.5 * gap


def past_fold(ctx: TraceContext, rec: Recorder, hit: int) -> bool:
    """True if the branch turned at a fold after the revisited segment ``hit`` and its
    last point lies on the fold's far piece: another solution than the piece that led to
    the fold, at the same speed (:func:`distinct_solution`), not that piece walked back.
    """
    if not rec.fold_index:
        return False
    f, n = rec.fold_index[-1], len(rec)
    if not (hit < f < n - 1 and f >= 1):
        return False
    ys = ctx.states(rec)
    _, _, foot = nearest_segment(ys[:f + 1], ys[-1], untraced(rec))
    return distinct_solution(ctx.evaluate, foot, ys[-1], ctx.tol, ctx.max_iter)


def reversal_point(ctx: TraceContext, rec: Recorder, yn: np.ndarray, hit: int) -> int:
    """The point after the revisited segment ``hit`` where the path turned the most."""
    n = len(rec)
    # never back past the restart after a closed loop (the copies of its entry point)
    lo = max(hit + 1, 1, (rec.restart() + 1) if rec.loops else 0)
    if lo >= n:
        return n - 1
    ys = np.vstack([ctx.states(rec)[lo - 1:], yn])
    ch = np.diff(ys, axis=0)
    nrm = np.maximum(np.linalg.norm(ch, axis=1), 1e-300)
    cos = np.einsum("ij,ij->i", ch[1:], ch[:-1]) / (nrm[1:] * nrm[:-1])
    return lo + int(np.argmin(cos))


