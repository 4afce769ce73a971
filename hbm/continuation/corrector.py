"""The continuation corrector: Newton on the augmented system (pseudo-arc-length plane
or sphere), its refinement step, the branch tangent and the corner step past a kink of
the piecewise-linear branch (:mod:`hbm.continuation`).

Unknowns are the scaled ``y = (x_hat, w_hat)``, ``w_hat = Omega / omega_scale``.
"""

from __future__ import annotations

import numpy as np

from ..krylov import bordered
from ..newton import ConvergenceError, NewtonSystem, iterate, solve_checked
from .protocol import ContinuationModel

__all__ = ["CORNER_RADIUS", "CORNER_STEP", "Bordered", "StepRejected", "augmented",
           "corner_step", "correct", "tangent"]

CORNER_STEP = 1e-4      # steps below this may turn sharply (corners of the branch)
CORNER_RADIUS = 1e-3    # largest sphere of a corner step (no room for another branch)


class StepRejected(Exception):
    """A corrected point refused by a predictor's checks (a jump, a turn back)."""


def augmented(model: ContinuationModel, omega_scale: float):
    """``y -> (R_hat, J_x, J_w)`` (or ``R_hat``) of the model on ``y = (x_hat, w_hat)``."""
    def evaluate(y, jacobian=True):
        omega = y[-1] * omega_scale
        if not omega > 0:
            raise ConvergenceError(f"corrector reached Omega = {omega:.3g} <= 0")
        if not jacobian:
            return model.scaled(y[:-1], omega, False)
        r, jx, jw = model.scaled(y[:-1], omega)
        return r, jx, jw * omega_scale
    return evaluate


class Bordered(NewtonSystem):
    """The continuation corrector's equations: ``R_hat(y) = 0`` bordered by the plane
    ``direction . (y - y_pred) = 0`` or the sphere ``|y - centre| = radius``, on the
    augmented unknowns ``y = (x_hat, w_hat)``; backtracking from the third iteration, a
    growth by 1e3 counts as divergence (:func:`hbm.newton.iterate`)."""

    warn = False
    recoverable = (ConvergenceError, np.linalg.LinAlgError)
    refine_where = "continuation corrector"

    def __init__(self, evaluate, y_pred, direction, sphere=None) -> None:
        self.evaluate_y = evaluate
        self.y_pred, self.direction, self.sphere = y_pred, direction, sphere

    def evaluate(self, y):
        return self.evaluate_y(y)

    def relative(self, y, ev) -> float:
        return float(np.linalg.norm(ev[0]) / max(np.linalg.norm(y[:-1]), 1.0))

    def trial(self, y) -> float:
        return relative_residual(self.evaluate_y, y)

    def matrix(self, y, ev):
        r, jx, jw = ev
        row, con = _constraint(y, self.y_pred, self.direction, self.sphere)
        return bordered(jx, jw, row), -np.concatenate([r, [con]])

    def where(self, it: int) -> str:
        return "continuation corrector"

    def tries(self, it: int) -> int:
        # Newton may cycle on the piecewise-linear force: backtrack on ||R||
        # (the constraint is linear, so every partial step keeps it)
        return 6 if it >= 2 else 0

    def diverged(self, it: int, res: float, res0: float, tol: float) -> bool:
        return it > 2 and res > 1e3 * res0

    def non_finite(self, it: int, res: float, cond: float) -> ConvergenceError:
        return ConvergenceError("non-finite residual", res)

    def failure(self, it: int, res: float, res0: float, tol: float, cond: float) -> str:
        return (f"corrector: relative residual {res:.3g} > tol {tol:.1g} after {it} "
                f"iterations (condition estimate {cond:.2g})")


def correct(evaluate, y_pred, direction, tol, max_iter, conds=None, sphere=None):
    """Newton on R_hat(y) = 0, direction . (y - y_pred) = 0 (:class:`Bordered`).

    ``conds``, if given, collects the condition estimates of the Newton matrices.
    ``sphere = (centre, radius)`` replaces the plane by ``|y - centre| = radius``
    (spherical arc length: it meets any branch leaving the centre, even one that
    turns by more than 90 degrees at a corner). Returns ``(y, iterations, residual,
    J_x, J_w)``.
    """
    system = Bordered(evaluate, y_pred, direction, sphere)
    y, it, res, (_, jx, jw) = iterate(system, y_pred.copy(), tol, max_iter, conds)
    return y, it, res, jx, jw


def relative_residual(evaluate, y) -> float:
    """``||R_hat(y)|| / max(||x_hat||, 1)``, inf where the residual cannot be evaluated."""
    try:
        r = evaluate(y, False)
    except ConvergenceError:
        return np.inf
    return np.linalg.norm(r) / max(np.linalg.norm(y[:-1]), 1.0)


def _constraint(y, y_pred, direction, sphere):
    if sphere is None:
        return direction, direction @ (y - y_pred)
    v = y - sphere[0]
    return v / sphere[1], 0.5 * (v @ v / sphere[1] - sphere[1])


def tangent(jx, jw, previous):
    """Unit null vector of ``[J_x, J_w]`` oriented along ``previous`` (bordered by it)."""
    j = bordered(jx, jw, previous)
    rhs = np.zeros(jw.size + 1)
    rhs[-1] = 1.0
    t = solve_checked(j, rhs, "continuation tangent", warn=False)[0]
    t /= np.linalg.norm(t)
    return t if t @ previous >= 0 else -t



def corner_step(evaluate, y, t, travel, ds, tol, max_iter, conds):
    """Step past a corner of the piecewise-linear branch (an AFT sample switching
    contact, possibly a fold of the branch there).

    Predictors ``y +- ds t_B`` along the tangent ``t_B`` of the piece beyond the
    corner (null vector of the Jacobian at ``y + ds t``), then ``y + ds t``;
    corrector on the sphere ``|y' - y| = ds``, which meets every branch leaving
    ``y``. A point going back along the branch (chord against the direction of
    ``travel``, the last chord) is refused.
    """
    dirs = []
    try:
        _, jx, jw = evaluate(y + ds * t)
        tb = tangent(jx, jw, t)
        dirs += [tb, -tb]
    except (ConvergenceError, np.linalg.LinAlgError):
        pass
    dirs.append(t)
    last: Exception = ConvergenceError("corner step: no predictor")
    nb = np.linalg.norm(travel)
    for d in dirs:
        try:
            yn, it, res, jx, jw = correct(evaluate, y + ds * d, d, tol, max_iter, conds,
                                           sphere=(y, ds))
        except (ConvergenceError, np.linalg.LinAlgError) as exc:
            last = exc
            continue
        chord = yn - y
        if nb > 0 and chord @ travel < -0.9 * np.linalg.norm(chord) * nb:
            last = StepRejected("spherical corrector went back along the branch")
            continue
        return yn, it, res, jx, jw
    raise last

