"""The predictor strategies of :func:`hbm.continuation.continue_branch`, tried in turn
from the last point (:data:`PREDICTORS`), each with its corrector
(:mod:`hbm.continuation.corrector`), and the corner leap tried when they all failed
(:func:`leap`).

Each predictor takes ``(ctx, rec, y, t, ds, conds)``: the context of the trace, the
recorder, the last point ``y`` and its tangent ``t``, the step, and a list that collects
the corrector's condition estimates. It returns the corrected ``(y_new, iterations,
residual, tangent)`` or raises :class:`~hbm.newton.ConvergenceError`,
:class:`~hbm.continuation.corrector.StepRejected` or ``LinAlgError``.
"""

from __future__ import annotations

import logging
from collections.abc import Callable

import numpy as np

from ..newton import ConvergenceError
from .branch import Recorder, note_condition
from .context import TraceContext
from .corrector import CORNER_RADIUS, CORNER_STEP, StepRejected, corner_step, correct, tangent
from .revisits import check_forward, revisit

# the tracer's log: one name for the continuation and its modules
logger = logging.getLogger("hbm.continuation")

__all__ = ["LEAP_FACTORS", "ORBIT_JUMP", "PREDICTORS", "leap", "orbit_change"]

LEAP_FACTORS = (2.0, 4.0, 8.0, 16.0, 32.0, 64.0)   # corner leap: lengths in last chords

#: Largest change of the orbit's vibration the corrector may make off the predictor, as a
#: fraction of the vibration itself (see :func:`orbit_change`); more is a jump onto another
#: branch. On pump-paper's three default curves the largest accepted change was 0.215 (so
#: the guard leaves them as they were), the jumps 0.5-1.2 (docs/hbm.md "Jumps the scaled
#: unknowns hide").
ORBIT_JUMP = 0.25


def orbit_change(ctx: TraceContext, y: np.ndarray, y_pred: np.ndarray,
                 y_new: np.ndarray) -> float:
    """How far the corrector moved the orbit off the predictor, relative to the orbit.

    The norm is over the vibration, the coefficients of the harmonics other than the
    mean of every signal (real layout, ``nr`` per signal), and is divided by the larger
    vibration of the last and the new point. The scaled unknowns cannot show this: their
    scale (an element's length scale, :mod:`hbm.modes`) is the backlash when it is the largest
    length, often a hundred times the vibration, and a jump between two orbits then
    moves them by far less than the step in speed. Vibrations below ``sqrt(tol)`` of the
    unknowns' scale count as that floor.
    """
    vib = ctx.model.vibration
    size = max(np.linalg.norm(y[:-1][vib]), np.linalg.norm(y_new[:-1][vib]),
               np.sqrt(ctx.tol) * max(np.linalg.norm(y_new[:-1]), 1.0))
    return float(np.linalg.norm((y_new - y_pred)[:-1][vib]) / size)


def _plane_step(ctx: TraceContext, rec: Recorder, y, t, d, ds, max_iter, conds):
    """Predictor ``y + ds d``, corrector on the plane through it normal to ``d``; refused
    when it lands far from the predictor, changes the orbit by more than ``ORBIT_JUMP``
    of itself, or the tangent turns sharply (another branch)."""
    y_pred = y + ds * d
    yn, it, res, jx, jw = correct(ctx.evaluate, y_pred, d, ctx.tol, max_iter, conds)
    note_condition(rec, conds)
    tn = tangent(jx, jw, t)
    jump = np.linalg.norm(yn - y_pred)
    if jump > 0.5 * ds and ds > 4 * ctx.min_step:
        # a long way from the predictor: likely a jump onto another branch
        raise StepRejected(f"corrector moved {jump / ds:.2f} steps off the predictor")
    moved = orbit_change(ctx, y, y_pred, yn)
    if moved > ORBIT_JUMP and ds > 4 * ctx.min_step:
        raise StepRejected(f"corrector changed the orbit by {moved:.2f} of its vibration "
                            "off the predictor")
    if tn @ t < 0.7 and ds > max(4 * ctx.min_step, CORNER_STEP):
        # (below CORNER_STEP a sharp turn is a corner of the piecewise-smooth
        # branch, an AFT sample entering contact, not a jump to another branch)
        angle = np.degrees(np.arccos(np.clip(tn @ t, -1, 1)))
        raise StepRejected(f"tangent turned by {angle:.0f} deg")
    check_forward(rec, y, yn)
    return yn, it, res, tn


def _tangent_predictor(ctx, rec, y, t, ds, conds):
    """Along the unit tangent of the branch."""
    return _plane_step(ctx, rec, y, t, t, ds, ctx.max_iter, conds)


def _corner_predictor(ctx, rec, y, t, ds, conds):
    """Spherical corrector past a corner of the piecewise-linear branch
    (:func:`hbm.continuation.corrector.corner_step`, radius at most ``CORNER_RADIUS``)."""
    travel = y - ctx.state(rec, -2) if len(rec) >= 2 else t
    yn, it, res, jx, jw = corner_step(ctx.evaluate, y, t, travel, min(ds, CORNER_RADIUS),
                                       ctx.tol, ctx.max_iter, conds)
    note_condition(rec, conds)
    chord = (yn - y) / np.linalg.norm(yn - y)
    tn = tangent(jx, jw, chord)
    check_forward(rec, y, yn)
    rec.counters["corner_steps"] += 1
    return yn, it, res, tn


def _secant_predictor(ctx, rec, y, t, ds, conds):
    """Along the secant through the last two points (the tangent at the first point)."""
    if len(rec) >= 2:
        sec = y - ctx.state(rec, -2)
        if np.linalg.norm(sec) > 0:
            rec.counters["secant_retries"] += 1
            return _plane_step(ctx, rec, y, t, sec / np.linalg.norm(sec), ds, ctx.max_iter,
                               conds)
    return _tangent_predictor(ctx, rec, y, t, ds, conds)


def _patient_predictor(ctx, rec, y, t, ds, conds):
    """Along the tangent with four times the corrector iterations."""
    return _plane_step(ctx, rec, y, t, t, ds, 4 * ctx.max_iter, conds)


#: The predictor strategies, tried in turn from a point, the step halved after each
#: failure (cycling until the step falls below min_step with every one tried).
PREDICTORS: list[tuple[str, Callable]] = [
    ("tangent", _tangent_predictor),
    ("corner (spherical corrector)", _corner_predictor),
    ("secant", _secant_predictor),
    ("tangent (patient corrector)", _patient_predictor),
]


def leap(ctx: TraceContext, rec: Recorder):
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
                yn, it, res, jx, jw = correct(ctx.evaluate, y + f * h * d,
                                               d if plane is None else plane, ctx.tol,
                                               ctx.max_iter)
                tn = tangent(jx, jw, d)
            except (ConvergenceError, np.linalg.LinAlgError):
                continue
            if (yn - y) @ d > 0 and revisit(ctx, rec, yn) is None:
                rec.counters["leaps"] += 1
                logger.info("corner leap past rpm %.6g (%.0f chords ahead%s)", rec.last("rpm"),
                            f, ", speed turned back" if d[-1] * travel[-1] < 0 else "")
                return yn, it, res, tn
    return None
