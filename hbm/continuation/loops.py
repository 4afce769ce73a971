"""Closed loops: the continuation going round a loop of solutions and arriving back on its
own path in the same direction (:func:`hbm.continuation.revisits.closed_loop`), and the
way out of it for :func:`hbm.continuation.continue_branch` (docs/hbm.md, "Closed loops").

A loop joined to the branch at a branch point is entered by a step that turns onto it
there; going round, the trace passes the branch point again along the loop and would
circle for ever. The loop's points are solutions and are kept (``Branch.loop`` marks
them); the trace goes back to the point where it entered the loop and steps on along the
direction it arrived with, straight through the branch point, onto the continuing branch.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from ..newton import ConvergenceError
from .branch import Recorder
from .context import TraceContext
from .corrector import correct, tangent
from .events import check_events
from .revisits import LOOP_MIN_POINTS, REVISIT_RATIO, distinct_solution, nearest_segment, revisit

logger = logging.getLogger("hbm.continuation")

__all__ = ["MAX_LOOPS", "RETRIED", "TRAPPED", "back_into_loop", "leave_loop", "resume_point"]

MAX_LOOPS = 8     # closed loops and re-entries handled before the trace stops
# Going back from the segment the branch closed on, an old point belongs to the loop while
# it lies within this many of its chords of the path that came round (on the pump the
# loop's points lie 0.02-0.1 chords from it, the last point before the corner where the
# branch turned onto the loop 0.34 and 0.97; chord: the shorter of the point's two)
LOOP_ENTRY_RATIO = 0.25
# a walk back over the loop within this many points of its exit is a failed exit
LOOP_EXIT_POINTS = 8
# exit steps from the entry point, in chords of the step that arrived there
LOOP_EXIT_FACTORS = (0.5, 1.0, 1.5, 2.0, 0.25, 3.0)


@dataclass(frozen=True)
class _Exit:
    """One way out of a loop: a plane predictor ``factor`` arrival chords (``chord``) from
    the point ``base`` along ``direction`` (the arrival chord or the point's tangent)."""

    base: int
    direction: np.ndarray
    factor: float
    chord: float
    kind: str


def _known_loop(rec: Recorder, hit: int) -> int | None:
    """Number (0-based) of the recorded loop whose path holds the segment ``hit``."""
    for j, (_, last, entry, _) in enumerate(rec.loops):
        if entry <= hit <= last:
            return j
    return None


def _entry(ctx: TraceContext, rec: Recorder, hit: int, yn: np.ndarray) -> int:
    """The last point before the loop: going back from the segment ``hit`` the branch
    closed on, the first old point farther than ``LOOP_ENTRY_RATIO`` of its chord from
    the path that came round (the points from ``hit + LOOP_MIN_POINTS`` to ``yn``)."""
    ys = ctx.states(rec)
    arc = np.vstack([ys[hit + LOOP_MIN_POINTS:], yn])
    lo = max(rec.restart() + 1, 0) if rec.loops else 0
    i = hit
    while i > lo:
        # the shorter of the point's two chords
        chord = float(np.linalg.norm(ys[i] - ys[i - 1]))
        if i + 1 < len(ys):
            chord = min(chord, float(np.linalg.norm(ys[i + 1] - ys[i])))
        d = nearest_segment(arc, ys[i])[1]
        logger.debug("loop entry: point %d lies %.3g chords from the path that came round",
                     i, d / chord)
        if not d < LOOP_ENTRY_RATIO * chord:
            return i
        i -= 1
    return i


def back_into_loop(rec: Recorder, hit: int) -> bool:
    """True if a walk back over the segment ``hit`` goes back over the last closed loop
    within ``LOOP_EXIT_POINTS`` points of leaving it: that exit failed (the next is
    tried, :func:`leave_loop`), rather than a reversal to undo."""
    j = _known_loop(rec, hit)
    return j is not None and j == len(rec.loops) - 1 and \
        len(rec) - rec.loops[j][3] <= LOOP_EXIT_POINTS


def _exits(ctx: TraceContext, rec: Recorder, entry: int) -> list[_Exit]:
    """The exits tried in turn: from the entry point, then from the point before it,
    along the arrival chord, then along the tangent, ``LOOP_EXIT_FACTORS`` chords."""
    out = []
    for base in (entry, entry - 1):
        if base < 0:
            continue
        t = np.asarray(rec.lists["tangents"][base], dtype=float)
        if base == 0:
            out += [_Exit(base, t, f, ctx.step, "tangent") for f in LOOP_EXIT_FACTORS]
            continue
        arrival = ctx.state(rec, base) - ctx.state(rec, base - 1)
        h = float(np.linalg.norm(arrival))
        d = arrival / h
        t = t if t @ d >= 0 else -t
        out += [_Exit(base, v, f, h, kind) for v, kind in ((d, "arrival chord"), (t, "tangent"))
                for f in LOOP_EXIT_FACTORS]
    return out


def _on_loop(ctx: TraceContext, rec: Recorder, loop: tuple[int, int, int, int],
             yn: np.ndarray, step: float) -> bool:
    """True if ``yn`` lies on the loop's path (from its entry point round to its first
    point) and is the same solution there."""
    first, last, entry, _ = loop
    ys = ctx.states(rec)
    path = np.vstack([ys[entry:last + 1], ys[first]])
    _, d, foot = nearest_segment(path, yn)
    return d < REVISIT_RATIO * step and not distinct_solution(ctx.evaluate, foot, yn,
                                                                ctx.tol, ctx.max_iter)


def _copies_last(ctx: TraceContext, rec: Recorder, j: int, base: int | None = None) -> bool:
    """True if the branch ends with the copies appended after loop ``j`` (of ``base``)."""
    restart = rec.loops[j][3]
    if len(rec) != restart + 2:
        return False
    ys = ctx.states(rec)
    return base is None or np.array_equal(ys[-1], ys[base])


def _restart(ctx: TraceContext, rec: Recorder, j: int, base: int) -> None:
    """Drop what follows loop ``j`` and append copies of the point ``base`` and its
    predecessor, unless they are there already: the branch goes on from there (the
    segment from the loop's last point to the first copy was not traced)."""
    if _copies_last(ctx, rec, j, base):
        return
    rec.truncate(rec.loops[j][3])
    for i in (max(base - 1, 0), base):
        ctx.record(rec, ctx.state(rec, i), int(rec.lists["newton_iterations"][i]),
                   float(rec.lists["residual"][i]), np.asarray(rec.lists["tangents"][i]))


def _try_exits(ctx: TraceContext, rec: Recorder, j: int) -> float | None:
    """Step out of loop ``j`` by the exits not tried yet (:func:`_exits`); record the
    first point that moves forward, off the loop and without walking back. Returns the
    step it took, or None when every exit failed."""
    loop = rec.loops[j]
    exits = _exits(ctx, rec, loop[2])
    while rec.loop_tries.get(j, 0) < len(exits):
        k = rec.loop_tries.get(j, 0)
        rec.loop_tries[j] = k + 1
        e = exits[k]
        _restart(ctx, rec, j, e.base)
        y = ctx.state(rec, -1)
        step = e.factor * e.chord
        try:
            yn, it, res, jx, jw = correct(ctx.evaluate, y + step * e.direction, e.direction,
                                           ctx.tol, ctx.max_iter)
            tn = tangent(jx, jw, e.direction)
        except (ConvergenceError, np.linalg.LinAlgError) as exc:
            logger.debug("loop exit %d (%.2g chords) failed: %s", k, e.factor, exc)
            continue
        if (yn - y) @ e.direction <= 0 or _on_loop(ctx, rec, loop, yn, step) or \
                revisit(ctx, rec, yn) is not None:
            logger.debug("loop exit %d (%.2g chords) landed back on the branch", k, e.factor)
            continue
        check_events(ctx, rec, yn, tn, it, res)
        logger.info("left the closed loop from rpm %.6g: %.2g chords along the %s, to rpm "
                    "%.6g", rec.lists["rpm"][e.base], e.factor, e.kind, rec.last("rpm"))
        return step
    return None


def leave_loop(ctx: TraceContext, rec: Recorder, hit: int, yn: np.ndarray,
                ds: float) -> tuple[float, str]:
    """The branch closed on itself at the old segment ``hit``: keep the loop's points
    (marked in ``rec.lists["loop"]``), go back to where it entered the loop and step out
    straight through. A re-entry into a known loop drops the points traced since its
    last exit and tries the next exit. Returns the step and "" or why the trace stops."""
    j = _known_loop(rec, hit)
    rec.guard = None
    rec.counters["loops"] = rec.counters.get("loops", 0) + 1
    if rec.counters["loops"] > MAX_LOOPS:
        return ds, (f"the branch closed on itself {MAX_LOOPS} times (closed loops near rpm "
                    f"{rec.lists['rpm'][hit]:.6g}); the curve is complete up to rpm "
                    f"{rec.last('rpm'):.6g} only, the loops' points kept")
    if j is None:
        n = len(rec)
        entry = _entry(ctx, rec, hit, yn)
        first = entry + 1
        rec.loops.append((first, n - 1, entry, n))
        j = len(rec.loops) - 1
        for i in range(first, n):
            rec.set("loop", i, j + 1)
        rpm = np.asarray(rec.lists["rpm"][first:n])
        logger.warning("closed loop: the branch came round to its own path at rpm %.6g; the "
                       "loop (points %d-%d, %.6g-%.6g rpm) is kept; back to its entry point "
                       "at rpm %.6g", rec.lists["rpm"][hit], first, n - 1, rpm.min(),
                       rpm.max(), rec.lists["rpm"][entry])
    else:
        logger.warning("the branch re-entered closed loop %d at rpm %.6g: back to its entry "
                       "point, next exit", j + 1, rec.lists["rpm"][hit])
    first, last, entry, _ = rec.loops[j]
    step = _try_exits(ctx, rec, j)
    if step is None:
        if _copies_last(ctx, rec, j):
            rec.truncate(rec.loops[j][3])
        rpm = rec.lists["rpm"][entry]
        return ds, (f"the branch went round a closed loop ({rec.lists['rpm'][first]:.6g}-"
                    f"{rec.lists['rpm'][last]:.6g} rpm, points {first}-{last}, kept) and no "
                    f"step from its entry point at rpm {rpm:.6g} left it; the curve is "
                    f"complete up to there only")
    return max(ctx.min_step, min(step, ctx.max_step)), ""


# a resumed branch that stopped walking back (status "reversal" or "loop") was caught in
# the speed window of its last this-many points; --resume restarts before that window
TRAP_POINTS = 10
TRAPPED = ("reversal", "loop")
# what trace() retries by itself: also a corrector stall (a fresh run with another step
# usually passes it: the contiguous 2/3 pump set at 1364.8 rpm, docs/hbm.md)
RETRIED = (*TRAPPED, "step_failed")


def resume_point(rpm: np.ndarray, loops, status: str,
                 trapped: tuple[str, ...] = TRAPPED) -> int:
    """Number of points of a stopped branch to keep when it is resumed.

    A branch that stopped on a walk back (``status`` in ``trapped``) ends in a speed
    window it could not leave: resuming from its last point repeats the trap whatever the
    step. The window is the speed range of its last ``TRAP_POINTS`` points, widened by
    every closed loop (``loops`` rows ``(first, last, entry, restart)``) that overlaps it;
    the points kept end where the branch last entered that window, before any of those
    loops, so that the resumed run (with other steps) traces the window afresh. Other
    statuses keep every point.
    """
    n = len(rpm)
    if status not in trapped or n < 3:
        return n
    tail = rpm[max(n - TRAP_POINTS, 0):]
    lo, hi = float(tail.min()), float(tail.max())
    spans = [(first, float(rpm[first:last + 1].min()), float(rpm[first:last + 1].max()))
             for first, last, *_ in loops]
    firsts = []
    grown = True
    while grown:
        grown = False
        for first, a, b in spans:
            if a <= hi and b >= lo and first not in firsts:
                firsts.append(first)
                lo, hi, grown = min(lo, a), max(hi, b), True
    i = n - 1
    while i > 0 and lo <= rpm[i] <= hi:
        i -= 1
    return max(min([i + 1, *firsts]), 1)
