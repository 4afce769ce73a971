"""Events along a continuation branch: grazing points (eq. 30, an element's test function
crossing zero, located on the branch) and folds (:func:`hbm.continuation.continue_branch`).
"""

from __future__ import annotations

import logging

import numpy as np

from ..newton import ConvergenceError
from ..units import RPM_TO_RAD_S
from .branch import GrazingPoint, Recorder
from .context import TraceContext
from .corrector import correct

# the tracer's log: one name for the continuation and its modules
logger = logging.getLogger("hbm.continuation")

__all__ = ["FOLD_MERGE_POINTS", "check_events", "check_fold", "locate"]

FOLD_MERGE_POINTS = 3   # sign changes of dOmega/ds closer than this (points) cancel


def check_events(ctx: TraceContext, rec: Recorder, yn: np.ndarray, tn: np.ndarray,
                  it: int, res: float) -> None:
    """Record the new point ``yn`` (tangent ``tn``, corrector iterations and residual)
    after locating the grazing and fold events since the last one."""
    ya = ctx.state(rec, -1)
    tests = ctx.monitor.events
    before = [rec.stat(ev.statistic, -1, ev.element) for ev in tests]
    ctx.record(rec, yn, it, res, tn)
    after = [rec.stat(ev.statistic, -1, ev.element) for ev in tests]
    check_fold(rec, ctx.wscale, ctx.model.x_scale)
    events = []
    for k, (ev, a, b) in enumerate(zip(tests, before, after, strict=True)):
        if (a > 0) != (b > 0):
            events.append((k, ev, "onset" if (b > 0) == ev.onset_positive else "end"))
    several = len({ev.element for ev in tests}) > 1
    for k, ev, kind in events:
        rpm = locate(ctx, ya, yn, k)
        rec.grazing.append(GrazingPoint(rpm=rpm, kind=kind, side=ev.name, element=ev.element))
        rec.n_grazing[-1] = len(rec.grazing)
        logger.info("grazing (%s, %s flank%s) at %.9g rpm", kind, ev.name,
                    f" of element {ev.element}" if several else "", rpm)


def check_fold(rec, wscale, xs) -> None:
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


def locate(ctx: TraceContext, ya: np.ndarray, yb: np.ndarray, which: int) -> float:
    """Illinois regula falsi on the chord parameter for a zero of the monitor's event
    function ``which`` (a gear mesh: its contact margin on a flank) between ``ya`` and
    ``yb``."""
    wscale = ctx.wscale
    xs = ctx.model.x_scale

    def margin(y):
        return ctx.monitor.test_value(which, y[:-1] * xs)

    d = yb - ya
    d /= np.linalg.norm(d)
    lo, hi = 0.0, 1.0
    flo, fhi = margin(ya), margin(yb)
    ylo, yhi = ya, yb
    side = 0
    mscale = ctx.monitor.events[which].scale
    for _ in range(60):
        if abs(yhi[-1] - ylo[-1]) * wscale / RPM_TO_RAD_S < ctx.gtol:
            break
        s = hi - fhi * (hi - lo) / (fhi - flo) if fhi != flo else 0.5 * (lo + hi)
        if not (lo < s < hi):
            s = 0.5 * (lo + hi)
        y_pred = ya + s * (yb - ya)
        try:
            y, *_ = correct(ctx.evaluate, y_pred, d, ctx.tol, ctx.max_iter)
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


