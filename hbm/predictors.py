"""The predictor strategies of :func:`hbm.continuation.trace`, tried in turn from the
last point (:data:`PREDICTORS`), each with its corrector (:mod:`hbm.corrector`).

Each takes ``(ctx, rec, y, t, ds, conds)``: the context of the trace, the recorder, the
last point ``y`` and its tangent ``t``, the step, and a list that collects the
corrector's condition estimates. It returns the corrected ``(y_new, iterations,
residual, tangent)`` or raises :class:`~hbm.newton.ConvergenceError`,
:class:`~hbm.corrector._StepRejected` or ``LinAlgError``.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .branch import _note_condition, _Recorder
from .corrector import CORNER_RADIUS, CORNER_STEP, _corner_step, _correct, _StepRejected, _tangent
from .events import TraceContext, _check_forward

__all__ = ["PREDICTORS"]

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
    scale (:func:`hbm.modes.length_scale`) is the backlash when it is the largest
    length, often a hundred times the vibration, and a jump between two orbits then
    moves them by far less than the step in speed. Vibrations below ``sqrt(tol)`` of the
    unknowns' scale count as that floor.
    """
    vib = np.arange(y.size - 1) % ctx.problem.nr != 0
    size = max(np.linalg.norm(y[:-1][vib]), np.linalg.norm(y_new[:-1][vib]),
               np.sqrt(ctx.tol) * max(np.linalg.norm(y_new[:-1]), 1.0))
    return float(np.linalg.norm((y_new - y_pred)[:-1][vib]) / size)


def _plane_step(ctx: TraceContext, rec: _Recorder, y, t, d, ds, max_iter, conds):
    """Predictor ``y + ds d``, corrector on the plane through it normal to ``d``; refused
    when it lands far from the predictor, changes the orbit by more than ``ORBIT_JUMP``
    of itself, or the tangent turns sharply (another branch)."""
    y_pred = y + ds * d
    yn, it, res, jx, jw = _correct(ctx.evaluate, y_pred, d, ctx.tol, max_iter, conds)
    _note_condition(rec, conds)
    tn = _tangent(jx, jw, t)
    jump = np.linalg.norm(yn - y_pred)
    if jump > 0.5 * ds and ds > 4 * ctx.min_step:
        # a long way from the predictor: likely a jump onto another branch
        raise _StepRejected(f"corrector moved {jump / ds:.2f} steps off the predictor")
    moved = orbit_change(ctx, y, y_pred, yn)
    if moved > ORBIT_JUMP and ds > 4 * ctx.min_step:
        raise _StepRejected(f"corrector changed the orbit by {moved:.2f} of its vibration "
                            "off the predictor")
    if tn @ t < 0.7 and ds > max(4 * ctx.min_step, CORNER_STEP):
        # (below CORNER_STEP a sharp turn is a corner of the piecewise-smooth
        # branch, an AFT sample entering contact, not a jump to another branch)
        angle = np.degrees(np.arccos(np.clip(tn @ t, -1, 1)))
        raise _StepRejected(f"tangent turned by {angle:.0f} deg")
    _check_forward(rec, y, yn)
    return yn, it, res, tn


def _tangent_predictor(ctx, rec, y, t, ds, conds):
    """Along the unit tangent of the branch."""
    return _plane_step(ctx, rec, y, t, t, ds, ctx.max_iter, conds)


def _corner_predictor(ctx, rec, y, t, ds, conds):
    """Spherical corrector past a corner of the piecewise-linear branch
    (:func:`hbm.corrector._corner_step`, radius at most ``CORNER_RADIUS``)."""
    travel = y - ctx.state(rec, -2) if len(rec) >= 2 else t
    yn, it, res, jx, jw = _corner_step(ctx.evaluate, y, t, travel, min(ds, CORNER_RADIUS),
                                       ctx.tol, ctx.max_iter, conds)
    _note_condition(rec, conds)
    chord = (yn - y) / np.linalg.norm(yn - y)
    tn = _tangent(jx, jw, chord)
    _check_forward(rec, y, yn)
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
