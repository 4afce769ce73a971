"""Events along a continuation branch: grazing points (eq. 30), folds, and the branch
walking back over itself (revisits, reversal points, corner leaps), for
:func:`hbm.continuation.trace`.

:class:`TraceContext` holds what they share for one trace (the problem, the augmented
residual, the speed scale, the tolerances and the point recorder).
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .branch import GrazingPoint, _Recorder
from .corrector import _correct, _StepRejected, _tangent
from .newton import ConvergenceError
from .postprocess import point_stats
from .problem import RPM_TO_RAD_S, HBMProblem

# the tracer's log: one name for the continuation and its modules
logger = logging.getLogger("hbm.continuation")

FOLD_MERGE_POINTS = 3   # sign changes of dOmega/ds closer than this (points) cancel
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
LEAP_FACTORS = (2.0, 4.0, 8.0, 16.0, 32.0, 64.0)   # corner leap: lengths in last chords
# A closed loop (the branch arriving back on its own path in the same direction) has at
# least this many points: the last LOOP_MIN_POINTS segments are not searched.
LOOP_MIN_POINTS = 6
# The step after a point that closed a loop must land on one of the next LOOP_CONFIRM
# segments of the old path (a branch going round again, not crossing its path once).
LOOP_CONFIRM = 3


@dataclass
class TraceContext:
    """The fixed data of one trace.

    Attributes
    ----------
    problem
        The HBM problem.
    evaluate
        Augmented scaled residual ``y -> (R_hat, J_x, J_w)`` (:func:`hbm.corrector._augmented`).
    wscale
        Speed scale: ``w_hat = Omega / wscale``.
    tol, max_iter
        Corrector tolerance and iterations.
    gtol
        Tolerance on located grazing speeds (rpm).
    record
        ``record(rec, y, iterations, residual, tangent)``: measure a converged point and
        add it to the recorder.
    step, min_step, max_step
        Initial, smallest and largest arc-length step.
    """

    problem: HBMProblem
    evaluate: Callable
    wscale: float
    tol: float
    max_iter: int
    gtol: float
    record: Callable
    step: float = 0.01
    min_step: float = 1e-6
    max_step: float = 0.05

    def state(self, rec: _Recorder, i: int) -> np.ndarray:
        """Scaled ``y`` of point ``i`` of the recorder (a copy)."""
        return rec.states()[i].copy()

    def states(self, rec: _Recorder) -> np.ndarray:
        """Scaled ``y`` of every point, (n_points, n_unknowns + 1) (read-only)."""
        return rec.states()


def _check_forward(rec, y, yn) -> None:
    """After a reversal was undone at point k, refuse a step from k that goes back."""
    if rec.guard is not None and rec.guard[0] == len(rec) - 1 and (yn - y) @ rec.guard[1] <= 0:
        raise _StepRejected("step goes back over the branch (a reversal was undone here)")


def _segment_gaps(ys: np.ndarray, y: np.ndarray,
                  skip: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Distance of ``y`` to every segment ``(i, i + 1)`` of the polyline ``ys`` (inf where
    ``skip`` is True) and the nearest point (foot) of each: ``(distances, feet)``."""
    a, b = ys[:-1], ys[1:]
    ab = b - a
    t = np.clip(np.einsum("ij,ij->i", y - a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab),
                                                               1e-300), 0.0, 1.0)
    foot = a + t[:, None] * ab
    d = np.linalg.norm(foot - y, axis=1)
    if skip is not None:
        d[skip[:d.size]] = np.inf
    return d, foot


def _nearest_segment(ys: np.ndarray, y: np.ndarray, skip: np.ndarray | None = None,
                     gaps: tuple[np.ndarray, np.ndarray] | None = None
                     ) -> tuple[int, float, np.ndarray]:
    """Segment ``(i, i + 1)`` of the polyline ``ys`` nearest to ``y``: ``(i, distance,
    foot)``; segments where ``skip`` is True are left out (distance inf if all are).
    ``gaps``: :func:`_segment_gaps` of ``y`` to a polyline that begins with ``ys``,
    computed once for several of its beginnings (:func:`_branch_gaps`)."""
    d, foot = _segment_gaps(ys, y, skip) if gaps is None else gaps
    i = int(np.argmin(d[:len(ys) - 1]))
    return i, float(d[i]), foot[i]


def _branch_gaps(ctx: TraceContext, rec: _Recorder,
                 yn: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """:func:`_segment_gaps` of a new point to the branch but its last segment, shared by
    the walk-back and closed-loop tests of one point (None below 3 points)."""
    n = len(rec)
    if n < 3:
        return None
    return _segment_gaps(ctx.states(rec)[:n - 1], yn, _untraced(rec))


def _revisit(ctx: TraceContext, rec: _Recorder, yn: np.ndarray,
             gaps: tuple[np.ndarray, np.ndarray] | None = None) -> int | None:
    """Index i of the earlier segment (i, i+1) that ``yn`` lies on, or None.

    Every segment but the last is checked; ``yn`` is near the branch when its distance
    to the segment is below ``REVISIT_RATIO`` times its chord from the last point and
    the step from the last point runs against the segment's direction. A
    near point is a revisit only if it is the same solution as the old branch at its
    speed (:func:`_distinct_solution`); otherwise it is another piece of the branch lying
    close by (past a sharp fold) and None is returned. ``gaps``: :func:`_branch_gaps` of
    ``yn``, if computed already.
    """
    n = len(rec)
    if n < 3:
        return None
    ys = ctx.states(rec)
    i, d, foot = _nearest_segment(ys[:n - 1], yn, _untraced(rec), gaps)
    chord = float(np.linalg.norm(yn - ys[-1]))
    if not d < REVISIT_RATIO * chord:
        return None
    if (yn - ys[-1]) @ (ys[i + 1] - ys[i]) > 0:
        # the step goes the way the old segment went: a branch that winds past its own
        # earlier loops (a spiral near a resonance with impacts), not a walk back. A walk
        # back runs against the old segment, also when it turned gradually (no single
        # step going back) or came round a loop onto the old branch.
        return None
    if _distinct_solution(ctx.evaluate, foot, yn, ctx.tol, ctx.max_iter):
        logger.info("point at scaled speed %.9g lies %.2g chords from the branch traced but "
                    "is another solution there (a sharp fold): not a revisit", yn[-1],
                    d / chord)
        return None
    return i


def _untraced(rec) -> np.ndarray | None:
    """The recorder's mask of segments not traced (joins after a closed loop), if any."""
    untraced = getattr(rec, "untraced", None)
    return untraced() if untraced is not None else None


def _closed_loop(ctx: TraceContext, rec: _Recorder, yn: np.ndarray, tn: np.ndarray,
                 gaps: tuple[np.ndarray, np.ndarray] | None = None) -> int | None:
    """Index i of the old segment (i, i+1) on which the branch closed a loop, or None.

    The branch has closed on itself when ``yn`` lies on a segment traced at least
    ``LOOP_MIN_POINTS`` points ago (distance below ``REVISIT_RATIO`` times its chord),
    the step runs the way that segment went (against it is a walk back,
    :func:`_revisit`), ``yn`` is the same solution as the old branch at its speed (Newton
    at that speed from the old path lands within ``SAME_SOLUTION`` of ``yn`` relative to
    the state norm, :func:`_distinct_solution`), and one more step along ``tn`` lands on
    the old path again, on one of the next ``LOOP_CONFIRM`` segments, the same way: the
    branch goes round the loop again rather than crossing its earlier path once.
    ``gaps``: :func:`_branch_gaps` of ``yn``, if computed already.
    """
    n = len(rec)
    upto = n - LOOP_MIN_POINTS          # segments (i, i+1) with i < upto
    if upto < 1:
        return None
    ys = ctx.states(rec)
    skip = _untraced(rec)
    i, d, foot = _nearest_segment(ys[:upto + 1], yn, skip, gaps)
    chord = float(np.linalg.norm(yn - ys[-1]))
    if not (d < REVISIT_RATIO * chord and (yn - ys[-1]) @ (ys[i + 1] - ys[i]) > 0):
        return None
    if _distinct_solution(ctx.evaluate, foot, yn, ctx.tol, ctx.max_iter):
        return None
    try:
        y2, *_ = _correct(ctx.evaluate, yn + chord * tn, tn, ctx.tol, ctx.max_iter)
    except (ConvergenceError, np.linalg.LinAlgError):
        return None
    j, d2, _ = _nearest_segment(ys[:upto + 1], y2, skip)
    step = float(np.linalg.norm(y2 - yn))
    if not (i <= j <= i + LOOP_CONFIRM and d2 < REVISIT_RATIO * step
            and (y2 - yn) @ (ys[j + 1] - ys[j]) > 0):
        return None
    logger.info("the branch closed on itself at rpm %.6g: the new point and the next lie on "
                "the path traced from point %d on, going the same way (a closed loop)",
                yn[-1] * ctx.wscale / RPM_TO_RAD_S, i)
    return i


def _distinct_solution(evaluate, foot, yn, tol, max_iter) -> bool:
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
        ys, *_ = _correct(evaluate, y0, e_w, tol, max_iter)
    except (ConvergenceError, np.linalg.LinAlgError) as exc:
        logger.debug("revisit check: no solution at the new point's speed from the old "
                     "branch (%s)", exc)
        return False
    gap = float(np.linalg.norm(ys - yn))
    logger.debug("revisit check: old branch at the new point's speed %.3g from it, %.3g from "
                 "the old polyline", gap, float(np.linalg.norm(ys - y0)))
    return gap > SAME_SOLUTION * max(float(np.linalg.norm(yn[:-1])), 1.0) and \
        float(np.linalg.norm(ys - y0)) < 0.5 * gap


def _past_fold(ctx: TraceContext, rec: _Recorder, hit: int) -> bool:
    """True if the branch turned at a fold after the revisited segment ``hit`` and its
    last point lies on the fold's far piece: another solution than the piece that led to
    the fold, at the same speed (:func:`_distinct_solution`), not that piece walked back.
    """
    if not rec.fold_index:
        return False
    f, n = rec.fold_index[-1], len(rec)
    if not (hit < f < n - 1 and f >= 1):
        return False
    ys = ctx.states(rec)
    _, _, foot = _nearest_segment(ys[:f + 1], ys[-1], _untraced(rec))
    return _distinct_solution(ctx.evaluate, foot, ys[-1], ctx.tol, ctx.max_iter)


def _reversal_point(ctx: TraceContext, rec: _Recorder, yn: np.ndarray, hit: int) -> int:
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


def _leap(ctx: TraceContext, rec: _Recorder):
    """Corner leap: plane predictors ``LEAP_FACTORS`` last chords ahead of the last point
    along its direction of travel, then with the speed component of that direction
    reversed (a fold at a corner: the state goes on, the speed turns back); accepted if
    it moves forward along the predictor without revisiting the branch."""
    y = ctx.state(rec, -1)
    travel = y - ctx.state(rec, -2)
    h = float(np.linalg.norm(travel))
    if not h > 0:
        return None
    folded = travel.copy()
    folded[-1] = -folded[-1]
    e_w = np.zeros_like(y)
    e_w[-1] = 1.0
    for d, plane in ((travel / h, None), (folded / np.linalg.norm(folded), e_w)):
        # folded: longest first (near the fold the piece traced lies close by)
        for f in (LEAP_FACTORS if plane is None else LEAP_FACTORS[::-1]):
            if f * h > ctx.max_step:
                continue
            try:
                # folded: corrector at the predicted speed (the state from the last point)
                yn, it, res, jx, jw = _correct(ctx.evaluate, y + f * h * d,
                                               d if plane is None else plane, ctx.tol,
                                               ctx.max_iter)
                tn = _tangent(jx, jw, d)
            except (ConvergenceError, np.linalg.LinAlgError):
                continue
            if (yn - y) @ d > 0 and _revisit(ctx, rec, yn) is None:
                rec.counters["leaps"] += 1
                logger.info("corner leap past rpm %.6g (%.0f chords ahead%s)", rec.last("rpm"),
                            f, ", speed turned back" if d[-1] * travel[-1] < 0 else "")
                return yn, it, res, tn
    return None



def _check_events(ctx: TraceContext, rec: _Recorder, yn: np.ndarray, tn: np.ndarray,
                  it: int, res: float) -> None:
    """Record the new point ``yn`` (tangent ``tn``, corrector iterations and residual)
    after locating the grazing and fold events since the last one."""
    ya = ctx.state(rec, -1)
    ma, mra = rec.last("margin_active"), rec.last("margin_reverse")
    ctx.record(rec, yn, it, res, tn)
    mb, mrb = rec.last("margin_active"), rec.last("margin_reverse")
    _check_fold(rec, ctx.wscale, ctx.problem.x_scale)
    events = []
    if (ma > 0) != (mb > 0):
        events.append(("active", 0, "onset" if ma > 0 else "end"))
    if (mra > 0) != (mrb > 0):
        events.append(("reverse", 1, "onset" if mrb > 0 else "end"))
    for side, which, kind in events:
        rpm = _locate(ctx, ya, yn, which)
        rec.grazing.append(GrazingPoint(rpm=rpm, kind=kind, side=side))
        rec.n_grazing[-1] = len(rec.grazing)
        logger.info("grazing (%s, %s flank) at %.9g rpm", kind, side, rpm)


def _check_fold(rec, wscale, xs) -> None:
    """Fold (turning point): the speed increments of the last two steps change sign.

    Secant increments, not the tangent, are used: at kinks of the
    piecewise-smooth branch the one-sided Jacobian can give a tangent whose
    speed component has the wrong sign. The fold speed is the vertex of the
    parabola through the last three points in arc length.
    """
    if len(rec) < 3:
        return
    w = np.array(rec.lists["omega"][-3:])
    if (w[1] - w[0]) * (w[2] - w[1]) >= 0:
        return
    here = len(rec) - 2
    if rec.fold_index and here - rec.fold_index[-1] < FOLD_MERGE_POINTS:
        # two turns within a few points: a kink of the branch, not two folds
        logger.debug("fold pair near %.6g rpm merged", rec.folds[-1])
        rec.folds.pop()
        rec.fold_index.pop()
        return
    y = np.array(rec.lists["unknowns"][-3:]) / xs
    s1 = np.linalg.norm(np.append(y[1] - y[0], (w[1] - w[0]) / wscale))
    s2 = s1 + np.linalg.norm(np.append(y[2] - y[1], (w[2] - w[1]) / wscale))
    c = np.polyfit([0.0, s1, s2], w, 2)
    w_fold = w[1]
    if c[0] != 0:
        sv = -c[1] / (2 * c[0])
        if 0 <= sv <= s2:
            w_fold = np.polyval(c, sv)
    rec.folds.append(float(w_fold / RPM_TO_RAD_S))
    rec.fold_index.append(here)
    logger.info("fold near %.6g rpm", rec.folds[-1])


def _locate(ctx: TraceContext, ya: np.ndarray, yb: np.ndarray, which: int) -> float:
    """Illinois regula falsi on the chord parameter for a zero contact margin
    (``which`` 0: active flank, 1: reverse flank) between ``ya`` and ``yb``."""
    problem, wscale = ctx.problem, ctx.wscale
    xs = problem.x_scale

    def margin(y):
        st = point_stats(problem, y[:-1] * xs)
        return st.margin_active if which == 0 else st.margin_reverse

    d = yb - ya
    d /= np.linalg.norm(d)
    lo, hi = 0.0, 1.0
    flo, fhi = margin(ya), margin(yb)
    ylo, yhi = ya, yb
    side = 0
    mscale = problem.length_scale
    for _ in range(60):
        if abs(yhi[-1] - ylo[-1]) * wscale / RPM_TO_RAD_S < ctx.gtol:
            break
        s = hi - fhi * (hi - lo) / (fhi - flo) if fhi != flo else 0.5 * (lo + hi)
        if not (lo < s < hi):
            s = 0.5 * (lo + hi)
        y_pred = ya + s * (yb - ya)
        try:
            y, *_ = _correct(ctx.evaluate, y_pred, d, ctx.tol, ctx.max_iter)
        except ConvergenceError as exc:
            logger.warning("grazing location stopped (corrector failed: %s); bracket "
                           "[%.9g, %.9g] rpm", exc, ylo[-1] * wscale / RPM_TO_RAD_S,
                           yhi[-1] * wscale / RPM_TO_RAD_S)
            break
        f = margin(y)
        if abs(f) <= 1e-12 * mscale:
            ylo = yhi = y
            break
        if (f > 0) == (fhi > 0):
            hi, fhi, yhi = s, f, y
            if side == -1:
                flo *= 0.5
            side = -1
        else:
            lo, flo, ylo = s, f, y
            if side == 1:
                fhi *= 0.5
            side = 1
    w = 0.5 * (ylo[-1] + yhi[-1]) * wscale
    return float(w / RPM_TO_RAD_S)


@dataclass(frozen=True)
class _Range:
    """The speed range of a trace (rad/s): a branch folding back may leave it through its
    start by ``overshoot`` of the range (never below half of rpm_start sweeping up)."""

    rpm_start: float
    rpm_end: float
    overshoot: float

    @property
    def w_start(self) -> float:
        return self.rpm_start * RPM_TO_RAD_S

    @property
    def w_end(self) -> float:
        return self.rpm_end * RPM_TO_RAD_S

    @property
    def dirn(self) -> float:
        return 1.0 if self.w_end > self.w_start else -1.0

    @property
    def wscale(self) -> float:
        return abs(self.w_end - self.w_start)

    @property
    def w_floor(self) -> float:
        w_floor = self.w_start - self.dirn * self.overshoot * self.wscale
        return max(w_floor, 0.5 * self.w_start) if self.dirn > 0 else w_floor

    def crossed(self, wn: float) -> tuple[str, str, float] | None:
        """``(status, message, bound)`` if the speed ``wn`` lies past a bound, else None."""
        if self.dirn * (wn - self.w_end) > 0:
            return "completed", f"reached rpm_end = {self.rpm_end}", self.w_end
        if self.dirn * (wn - self.w_floor) < 0:
            return "left_range", (
                f"the branch turned back and left the range through rpm_start = "
                f"{self.rpm_start} (by more than overshoot = {self.overshoot} of the range)"
            ), self.w_floor
        return None
