"""Pseudo-arc-length continuation in Omega with grazing, fold and stability tracking.

Unknowns and equations are scaled (``x_hat = u / x_scale``, ``R_hat = R /
eq_scale``, the model's scales) and the speed by the speed range,
``w_hat = Omega / |Omega_end - Omega_start|``, so the arc length ``s`` is
dimensionless: a step of 0.01 moves the speed by at most 1 % of the range.

Every step of :func:`continue_branch` reads PREDICT / CORRECT / ACCEPT:

- PREDICT and CORRECT (:func:`_advance`): the strategies of :data:`PREDICTORS` in turn,
  the step halved after each failure: the unit tangent of the branch (null vector of
  ``[J_x, J_w]``), a corner step (spherical corrector past a kink of the
  piecewise-linear branch), the secant through the last two points, a patient
  corrector (docs/hbm.md); then a corner leap. Corrector: Newton on the augmented
  system ``R_hat = 0, t . (y - y_pred) = 0`` (pseudo-arc-length,
  :mod:`hbm.continuation.corrector`).
- ACCEPT: a point walking back over the branch is undone (:func:`_undo_reversal`), a
  closed loop kept and left through its entry point (:mod:`hbm.continuation.loops`), a
  point past a bound of the range is landed on it (:func:`_land`); otherwise the events
  since the last point (an element's test function crossing zero, folds) are located and
  the point recorded (:func:`hbm.continuation.events.check_events`), and the step adapted
  to the corrector's effort.

A trace stopped by a walk back, a closed loop or a failed step is resumed from before
where it was caught with another initial step (``retry_steps``,
:mod:`hbm.continuation.loops`).

The tracer knows only a residual and its tangent (:class:`~hbm.continuation.protocol.
ContinuationModel`) and what measures a converged point (:class:`~hbm.continuation.
protocol.Monitor`), as NLvib's ``solve_and_continue``: :func:`hbm.trace` gives it an HBM
problem and its monitor. The branch and its recorder live in
:mod:`hbm.continuation.branch`, the events in :mod:`hbm.continuation.events`, the walk
back over the branch in :mod:`hbm.continuation.revisits`.
"""

from __future__ import annotations

import logging
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np

from ..newton import ConvergenceError, newton, solve_checked
from ..units import RPM_TO_RAD_S
from .branch import Branch, Recorder, note_condition
from .context import SpeedRange, TraceContext
from .corrector import StepRejected, augmented, tangent
from .events import check_events
from .loops import RETRIED, TRAPPED, back_into_loop, leave_loop, resume_point
from .predictors import PREDICTORS, leap
from .protocol import ContinuationModel, Monitor
from .revisits import branch_gaps, closed_loop, past_fold, reversal_point, revisit
from .settings import check_resume, check_settings, check_start

# the tracer's log: one name for the continuation and its modules
logger = logging.getLogger("hbm.continuation")

__all__ = ["MAX_REVERSALS", "RETRY_STEPS", "continue_branch"]

MAX_REVERSALS = 8       # roll-backs without progress before the trace gives up
# accepted points whose on_point call may wait for their stability verdicts (an
# asynchronous monitor) before the tracer waits for them: room for the workers to
# measure a few costly points while the corrector goes on
MAX_LAG = 8
# progress: the branch has grown by more than this many points past its length at the
# furthest reversal so far (a pump curve at converged settings turns at dozens of folds)
REVERSAL_PROGRESS = 5


@dataclass
class _Step:
    """Outcome of PREDICT and CORRECT from the last point."""

    point: tuple | None         # (y, iterations, residual, tangent), None if no step
    ds: float                   # the step size now
    predictor: str
    message: str = ""           # why no step converged


def _advance(ctx: TraceContext, rec: Recorder, ds: float) -> _Step:
    """PREDICT and CORRECT: a new point from the last one by the :data:`PREDICTORS` in
    turn, halving the step after each failure; a corner leap when all failed."""
    y = ctx.state(rec, -1)
    t = rec.last("tangents")
    fails = 0
    accepted = None
    predictor = "tangent"
    message = ""
    if rec.releap == len(rec) - 1:
        # the trace came back to the same turn twice: the steps from it keep landing
        # on the piece traced (a fold sharper than the step); leap across the fold
        rec.releap = None
        accepted = leap(ctx, rec)
        predictor = "leap after repeated reversals"
    while accepted is None:
        predictor, strategy = PREDICTORS[fails % len(PREDICTORS)]
        conds: list[float] = []
        try:
            accepted = strategy(ctx, rec, y, t, ds, conds)
        except (ConvergenceError, StepRejected, np.linalg.LinAlgError) as exc:
            note_condition(rec, conds)
            fails += 1
            rec.counters["step_cuts"] += 1
            ds *= 0.5
            logger.debug("%s step failed at rpm %.6g (%s); step cut to %.3g", predictor,
                         rec.last("rpm"), exc, ds)
            if ds < ctx.min_step and fails < len(PREDICTORS):
                ds = ctx.min_step        # every predictor gets a try at the smallest step
            elif ds < ctx.min_step:
                message = (f"step fell below min_step = {ctx.min_step} after {fails} failed "
                           f"steps (tangent, corner, secant and patient retries) from the "
                           f"last converged point at rpm {rec.last('rpm'):.6g}: {exc}")
                break
    if accepted is None and len(rec) >= 2:
        # corner leap: past a non-smooth point along the direction of travel
        accepted = leap(ctx, rec)
        if accepted is not None:
            message = ""
            ds = max(ctx.min_step, min(ctx.step, ctx.max_step))
    if accepted is None and rec.guard is not None and rec.guard[0] == len(rec) - 1:
        message += ("; the branch had turned back over its own points here (a "
                    "reversal, undone) and no step forward converged")
    return _Step(accepted, ds, predictor, message)


# ------------------------------------------------------------------------------ accepting
def _undo_reversal(ctx: TraceContext, rec: Recorder, yn: np.ndarray, hit: int,
                   ds: float) -> tuple[float, str]:
    """The new point ``yn`` revisits segment ``hit``: drop the points after the turn and
    re-predict from it with the old orientation and a smaller step. Returns the step and,
    after ``MAX_REVERSALS`` reversals without progress, why the trace stops ("" else)."""
    # past a genuine fold, the step from its far side jumped back onto the piece
    # that led to the fold: keep the fold and retry from the last point, shorter
    beyond = past_fold(ctx, rec, hit)
    k = len(rec) - 1 if beyond else reversal_point(ctx, rec, yn, hit)
    rec.counters["reversals"] += 1
    # reversals count until the branch grows well past its length at the last one
    if len(rec) > rec.stuck_at + REVERSAL_PROGRESS:
        rec.stuck = 0
    rec.stuck += 1
    rec.stuck_at = max(rec.stuck_at, len(rec))
    if rec.stuck > MAX_REVERSALS:
        message = (f"the branch walked back over its own points (near rpm "
                   f"{rec.lists['rpm'][hit]:.6g}) after {MAX_REVERSALS} recoveries from "
                   f"reversals; the curve is complete up to rpm {rec.lists['rpm'][k]:.6g}"
                   " only")
        rec.truncate(k + 1)
        return ds, message
    logger.warning("continuation reversal: the new point at rpm %.6g revisits the "
                   "branch near rpm %.6g; back to %s at rpm %.6g (point %d of %d) "
                   "with the old orientation (%d without progress)",
                   yn[-1] * ctx.wscale / RPM_TO_RAD_S, rec.lists["rpm"][hit],
                   "the last point past the fold" if beyond else "the turn",
                   rec.lists["rpm"][k], k, len(rec), rec.stuck)
    rec.releap = k if rec.last_turn == k else None
    rec.last_turn = k
    rec.truncate(k + 1)
    travel = ctx.state(rec, k) - ctx.state(rec, k - 1)
    rec.guard = (k, travel / np.linalg.norm(travel))
    tk = rec.lists["tangents"][k]
    if tk @ travel < 0:      # re-predict with the orientation the branch came in
        rec.set("tangents", k, -tk)
    ds = max(ctx.min_step, (0.25 if beyond else 0.5) * min(ds, float(np.linalg.norm(travel))))
    return ds, ""


def _land(ctx: TraceContext, rec: Recorder, yn: np.ndarray, tn: np.ndarray,
          wb: float) -> str:
    """The step from the last point crossed the bound ``wb`` (rad/s): record the point
    on it (Newton at that speed from the chord). Returns "" or why there is none."""
    model, wscale = ctx.model, ctx.wscale
    y = ctx.state(rec, -1)
    lam = (wb - y[-1] * wscale) / (yn[-1] * wscale - y[-1] * wscale)
    guess = y[:-1] + lam * (yn[:-1] - y[:-1])
    try:
        xb, itb, resb = newton(lambda x, j=True, wb=wb: model.scaled(x, wb, j), guess,
                               ctx.tol, 30)
        yb = np.concatenate([xb, [wb / wscale]])
        _, jx, jw = ctx.evaluate(yb)
        tb = tangent(jx, jw, tn)
        check_events(ctx, rec, yb, tb, itb, resb)
        return ""
    except (ConvergenceError, np.linalg.LinAlgError) as exc:
        logger.warning("could not land on the bound %.6g rpm: %s", wb / RPM_TO_RAD_S, exc)
        return f" (no converged point exactly on the bound: {exc})"


def _accept(ctx: TraceContext, rec: Recorder, advanced: _Step, bounds: SpeedRange,
            ds: float) -> tuple[str, str, float]:
    """ACCEPT the corrected point: undo a reversal, land on a bound crossed, or record
    the point with its events and adapt the step. Returns (status, message, step)."""
    yn, it, res, tn = advanced.point
    logger.debug("accepted rpm %.6g from rpm %.6g (%s, step %.3g, %d iterations)",
                 yn[-1] * ctx.wscale / RPM_TO_RAD_S, rec.last("rpm"), advanced.predictor, ds,
                 it)
    gaps = branch_gaps(ctx, rec, yn)
    hit = revisit(ctx, rec, yn, gaps)
    if hit is not None and not back_into_loop(rec, hit):
        ds, message = _undo_reversal(ctx, rec, yn, hit, ds)
        return ("reversal" if message else "running"), message, ds
    if hit is None:
        hit = closed_loop(ctx, rec, yn, tn, gaps)
    if hit is not None:     # closed a loop, or walked back into the one just left
        ds, message = leave_loop(ctx, rec, hit, yn, ds)
        return ("loop" if message else "running"), message, ds
    crossed = bounds.crossed(yn[-1] * ctx.wscale)
    if crossed is not None:
        status, message, wb = crossed
        return status, message + _land(ctx, rec, yn, tn, wb), ds
    check_events(ctx, rec, yn, tn, it, res)
    if it <= 3:
        ds = min(ds * 1.5, ctx.max_step)
    elif it >= 7:
        ds = max(ds * 0.6, ctx.min_step)
    return "running", "", ds


# initial-step factors of the retries after a trace was caught by a walk back or a loop
# (on the pump at 0.6 x TE, 2 of 11 initial steps were caught; resumed with another step
# from before the trap, each got through: docs/hbm.md "Closed loops")
RETRY_STEPS = (0.75, 1.25)


# ---------------------------------------------------------------------------- the trace
def continue_branch(model: ContinuationModel, monitor: Monitor, rpm_start: float,
                    rpm_end: float, *, step: float = 0.01, min_step: float = 1e-6,
                    max_step: float = 0.05, tol: float = 1e-8, max_points: int = 2000,
                    max_iter: int = 12, on_point: Callable[[Branch], None] | None = None,
                    resume: Branch | None = None, overshoot: float = 0.25,
                    grazing_tol_rpm: float | None = None, start_fallback: bool = True,
                    retry_steps: tuple[float, ...] = RETRY_STEPS,
                    start: np.ndarray | None = None) -> Branch:
    """Follow the solutions of ``model`` from ``rpm_start`` to ``rpm_end``, measuring every
    point by ``monitor``.

    Parameters
    ----------
    model
        The equations: scaled residual and Jacobians in the unknowns and the speed, the
        unknowns' scales, a fixed-speed solve (:class:`~hbm.continuation.protocol.
        ContinuationModel`).
    monitor
        Measures every converged point (statistics, stability) and names the event test
        functions located on the branch (:class:`~hbm.continuation.protocol.Monitor`).
    rpm_start, rpm_end
        Speed bounds (rpm, > 0, different); the sweep direction is start -> end.
    step, min_step, max_step
        Initial, smallest and largest arc-length step (dimensionless, scaled
        unknowns, speed scaled by the range).
    tol
        Relative residual tolerance of every point.
    max_points
        Total number of points (including resumed ones).
    on_point
        Called with the branch so far after every accepted point (checkpoint); with an
        asynchronous monitor, for each point (with the branch up to it) once its
        stability verdict has come, at most :data:`MAX_LAG` points later; a point
        rolled back before that is not handed out.
    resume
        A previous Branch of the same problem and bounds: continue from its
        last point, tangent and step, giving the same curve as one run.
    grazing_tol_rpm
        Tolerance on located event speeds (default 1e-9 of rpm_end).
    start_fallback
        If the fixed-speed solve fails at ``rpm_start``, approach ``rpm_start`` by a
        continuation from ``rpm_start / 4`` (closer to the quasi-static limit, where
        Newton converges) and start from its point at ``rpm_start``.
    overshoot
        A branch that folds back may go past ``rpm_start`` by this fraction of
        the range (never below half of rpm_start when sweeping up) before the
        trace stops with ``"left_range"``; those points are kept.
    retry_steps
        A trace stopped by a walk back, a closed loop it could not leave or a failed step
        (status ``"reversal"``, ``"loop"``, ``"step_failed"``) is resumed from before the
        speeds where it was caught (:func:`hbm.continuation.loops.resume_point`) with
        ``step`` times each factor in turn, until one gets through; ``()`` stops at the
        first failure.
    start
        Unknowns from which Newton finds the first point at ``rpm_start`` (a point of
        another, coexisting branch, e.g. from a time integration); without it the model's
        own guess. With ``start`` there is no fallback: if Newton fails from it the trace
        stops (status ``"start_failed"``) rather than follow another branch.

    Returns
    -------
    Branch
        Never holds an unconverged point; ``status``/``message`` say why it stopped.
    """
    check_settings(rpm_start, rpm_end, step, min_step, max_step, tol, max_points, overshoot)
    start = check_start(model, start, resume)
    bounds = SpeedRange(rpm_start, rpm_end, overshoot)
    if resume is not None:
        check_resume(model, resume)
        if resume.status == "completed":
            return resume
    wscale = bounds.wscale if resume is None else resume.omega_scale
    ctx = TraceContext(
        model, monitor, augmented(model, wscale), wscale, tol, max_iter,
        1e-9 * rpm_end if grazing_tol_rpm is None else float(grazing_tol_rpm),
        step, min_step, max_step)
    meta = monitor.branch_meta()
    rec = Recorder(meta, model.x_scale, rpm_start, rpm_end, wscale, resume)
    monitor.start()
    try:
        branch = _run(ctx, rec, bounds, resume, step, min_step, max_step, max_points,
                      on_point, start_fallback, start=start)
        for factor in retry_steps:
            if branch.status not in RETRIED:
                break
            logger.warning("retrying the trace from before the speeds where it was caught, "
                           "initial step x %g", factor)
            rec = Recorder(meta, model.x_scale, rpm_start, rpm_end, wscale, branch)
            branch = _run(ctx, rec, bounds, branch, min(max(step * factor, min_step),
                                                        max_step),
                          min_step, max_step, max_points, on_point, start_fallback, RETRIED)
        return branch
    finally:
        monitor.stop()


def _run(ctx: TraceContext, rec: Recorder, bounds: SpeedRange, resume: Branch | None,
         step: float, min_step: float, max_step: float, max_points: int,
         on_point: Callable[[Branch], None] | None, start_fallback: bool,
         trapped: tuple[str, ...] = TRAPPED, start: np.ndarray | None = None) -> Branch:
    """The PREDICT / CORRECT / ACCEPT loop of :func:`trace`; a ``resume`` whose status is
    in ``trapped`` restarts from before the speeds where it stopped."""
    rpm_start = bounds.rpm_start
    if resume is not None:
        keep = resume_point(resume.rpm, resume.loops, resume.status, trapped)
        if keep < len(rec):
            logger.warning("resuming a branch that stopped (%s): back to point %d at rpm "
                           "%.6g, before the speeds it could not leave",
                           resume.status, keep, resume.rpm[keep - 1])
            rec.truncate(keep)
        ds = _resumed_step(resume, step, min_step, max_step)
    else:
        failed = _first_point(ctx, rec, rpm_start, bounds.dirn, start_fallback, max_points,
                              start)
        if failed:
            return rec.branch("start_failed", failed, step)
        ds = step
        if on_point:
            on_point(rec.branch("running", "", ds))

    status, message = "running", ""
    # with stability workers a point's branch is handed to on_point once its verdict has
    # come (:class:`_Deferred`), while the corrector goes on
    deferred = _Deferred(ctx, rec, on_point) if ctx.monitor.asynchronous and on_point \
        else None

    while status == "running":
        if len(rec) >= max_points:
            if deferred is not None:
                deferred.flush(wait=True)
            status, message = "max_points", f"stopped after max_points = {max_points} points"
            break
        # PREDICT and CORRECT
        advanced = _advance(ctx, rec, ds)
        if deferred is not None:
            deferred.flush()
        ds = advanced.ds
        if advanced.point is None:
            status, message = "step_failed", advanced.message
            break
        # ACCEPT
        status, message, ds = _accept(ctx, rec, advanced, bounds, ds)
        if status == "running" and on_point:
            if deferred is not None:
                deferred.add(ds)
            else:
                on_point(rec.branch("running", "", ds))
    if deferred is not None:
        deferred.flush(wait=True)
    if status != "completed":
        logger.warning("continuation stopped: %s", message)
    else:
        logger.info("continuation %s: %d points", message, len(rec))
    branch = rec.branch(status, message, ds)
    if on_point:
        on_point(branch)
    return branch


class _Deferred:
    """The ``on_point`` calls of an asynchronous monitor: each accepted point's branch
    (its first points, with the step and counters it had) is handed out, in order, once
    the verdicts of the point and of every point before it have come; a point rolled
    back before that is not handed out. More than :data:`MAX_LAG` points waiting make
    the tracer wait for the verdicts, one at a time (the workers stay busy)."""

    def __init__(self, ctx: TraceContext, rec: Recorder, on_point: Callable) -> None:
        self.ctx, self.rec, self.on_point = ctx, rec, on_point
        self.queue: deque = deque()         # (index, serial, step, counters)

    def add(self, ds: float) -> None:
        """The point just accepted (the last of the recorder), with the step after it."""
        i = len(self.rec) - 1
        self.queue.append((i, self.rec.serials[i], ds, dict(self.rec.counters)))
        self.flush()

    def flush(self, wait: bool = False) -> None:
        """Hand out every point whose verdicts have come (waiting for all if ``wait``)."""
        ctx, rec, queue = self.ctx, self.rec, self.queue
        ctx.settle(rec, wait=False)
        while queue:
            i, serial, ds, counters = queue[0]
            if not rec.holds(i, serial):              # rolled back meanwhile
                queue.popleft()
                continue
            if rec.settled_prefix() > i:
                queue.popleft()
                self.on_point(rec.branch("running", "", ds, counters, upto=i + 1))
                continue
            if not (wait or len(queue) > MAX_LAG):
                break
            if ctx.monitor.pending == 0:
                raise RuntimeError(f"point {i}: no stability verdict pending nor received")
            ctx.settle(rec, wait=True, keep=ctx.monitor.pending - 1)   # one more verdict


def _resumed_step(resume: Branch, step: float, min_step: float, max_step: float) -> float:
    """A run that was interrupted (or hit max_points) continues with its step; one that
    failed (step, reversal) restarts from its last point with this call's step settings."""
    ds = resume.next_step if resume.status in ("running", "max_points") and \
        resume.next_step > 0 else step
    return min(max(ds, min_step), max_step)


def _first_point(ctx: TraceContext, rec: Recorder, rpm_start: float, dirn: float,
                 start_fallback: bool, max_points: int, start: np.ndarray | None = None
                 ) -> str:
    """Record the solution at ``rpm_start`` (Newton from ``start`` if given) with its
    tangent; "" or why there is none."""
    model = ctx.model
    fallback = start_fallback and start is None      # a given start allows no other branch
    try:
        p0 = model.solve(rpm_start, x0=start, tol=ctx.tol)
    except ConvergenceError as exc:
        p0 = _approach_start(ctx, rpm_start, max_points) if fallback else None
        if p0 is None:
            how = ("; nor by continuation from rpm_start / 4" if fallback else
                   " (from the given start)" if start is not None else "")
            msg = f"no converged solution at rpm_start = {rpm_start}: {exc}{how}"
            logger.error(msg)
            return msg
    y0 = np.concatenate([p0.unknowns / model.x_scale, [p0.omega / ctx.wscale]])
    _, jx, jw = ctx.evaluate(y0)
    try:
        tx = -solve_checked(jx, jw, "initial tangent")[0]
    except ConvergenceError as exc:
        msg = f"singular Jacobian at the first point rpm_start = {rpm_start}: {exc}"
        logger.error(msg)
        return msg
    t0 = np.concatenate([tx, [1.0]]) * dirn
    t0 /= np.linalg.norm(t0)
    ctx.record(rec, y0, p0.iterations, p0.residual, t0)
    return ""


def _approach_start(ctx: TraceContext, rpm_start: float, max_points: int):
    """Point at ``rpm_start`` reached by continuation from ``rpm_start / 4`` (measured by
    the monitor's auxiliary, without stability), or None."""
    logger.warning("Newton failed at rpm_start = %.6g; approaching it by continuation from "
                   "%.6g rpm", rpm_start, rpm_start / 4)
    sub = continue_branch(ctx.model, ctx.monitor.auxiliary(), rpm_start / 4, rpm_start,
                          tol=ctx.tol, max_iter=ctx.max_iter, max_points=max_points,
                          start_fallback=False)
    if sub.status != "completed" or abs(sub.rpm[-1] - rpm_start) > 1e-12 * rpm_start:
        logger.warning("approach to rpm_start failed: %s", sub.message)
        return None
    return SimpleNamespace(unknowns=np.array(sub.unknowns[-1], dtype=float),
                           omega=sub.omega[-1], iterations=int(sub.newton_iterations[-1]),
                           residual=float(sub.residual[-1]))
