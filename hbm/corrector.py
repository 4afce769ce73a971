"""The continuation corrector: Newton on the augmented system (pseudo-arc-length plane
or sphere), its refinement step, the branch tangent and the corner step past a kink of
the piecewise-linear branch (:mod:`hbm.continuation`).

Unknowns are the scaled ``y = (x_hat, w_hat)``, ``w_hat = Omega / omega_scale``.
"""

from __future__ import annotations

import numpy as np

from .krylov import bordered
from .newton import ConvergenceError, backtrack, solve_checked
from .problem import HBMProblem

REFINE_BOUND = 1e-7     # refine a converged point when cond * residual exceeds this
CORNER_STEP = 1e-4      # steps below this may turn sharply (corners of the branch)
CORNER_RADIUS = 1e-3    # largest sphere of a corner step (no room for another branch)


class _StepRejected(Exception):
    pass


def _augmented(problem: HBMProblem, omega_scale: float):
    def evaluate(y, jacobian=True):
        omega = y[-1] * omega_scale
        if not omega > 0:
            raise ConvergenceError(f"corrector reached Omega = {omega:.3g} <= 0")
        if not jacobian:
            return problem.scaled(y[:-1], omega, False)
        r, jx, jw = problem.scaled(y[:-1], omega)
        return r, jx, jw * omega_scale
    return evaluate


def _correct(evaluate, y_pred, direction, tol, max_iter, conds=None, sphere=None):
    """Newton on R_hat(y) = 0, direction . (y - y_pred) = 0.

    ``conds``, if given, collects the condition estimates of the Newton matrices.
    ``sphere = (centre, radius)`` replaces the plane by ``|y - centre| = radius``
    (spherical arc length: it meets any branch leaving the centre, even one that
    turns by more than 90 degrees at a corner).
    """
    y = y_pred.copy()
    res0 = None
    cond = np.nan
    for it in range(max_iter + 1):
        r, jx, jw = evaluate(y)
        res = float(np.linalg.norm(r) / max(np.linalg.norm(y[:-1]), 1.0))
        if not np.isfinite(res):
            raise ConvergenceError("non-finite residual", res)
        res0 = res if res0 is None else res0
        if res < tol and (it == 0 or cond * res > REFINE_BOUND):
            # within tol already at the predictor (tiny step), or an error bound
            # cond * res that a poorly conditioned Jacobian makes loose: one Newton step
            # more, so that the point does not carry a tol-sized error along the branch
            refined = _refine(evaluate, y, y_pred, direction, sphere, r, jx, jw, res, it)
            return refined if refined is not None else (y, it, res, jx, jw)
        if res < tol:
            return y, it, res, jx, jw
        if it == max_iter or (it > 2 and res > 1e3 * res0):
            break
        row, con = _constraint(y, y_pred, direction, sphere)
        j = bordered(jx, jw, row)
        rhs = -np.concatenate([r, [con]])
        try:
            dy, cond = solve_checked(j, rhs, "continuation corrector", warn=False)
        except ConvergenceError as exc:
            raise ConvergenceError(f"{exc} (relative residual {res:.3g})", res,
                                   exc.condition) from exc
        if conds is not None:
            conds.append(cond)
        if it >= 2:
            # Newton may cycle on the piecewise-linear force: backtrack on ||R||
            # (the constraint is linear, so every partial step keeps it)
            dy = backtrack(lambda yt: _relative_residual(evaluate, yt), y, dy, res, 6) * dy
        y = y + dy
    raise ConvergenceError(f"corrector: relative residual {res:.3g} > tol {tol:.1g} after {it} "
                           f"iterations (condition estimate {cond:.2g})", res, cond)


def _relative_residual(evaluate, y) -> float:
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


def _refine(evaluate, y, y_pred, direction, sphere, r, jx, jw, res, it0=0):
    """One Newton step from a point already within tol; kept if it lowers the residual."""
    row, con = _constraint(y, y_pred, direction, sphere)
    j = bordered(jx, jw, row)
    try:
        dy = solve_checked(j, -np.concatenate([r, [con]]), "continuation corrector",
                           warn=False)[0]
        yn = y + dy
        rn, jxn, jwn = evaluate(yn)
    except (ConvergenceError, np.linalg.LinAlgError):
        return None
    resn = float(np.linalg.norm(rn) / max(np.linalg.norm(yn[:-1]), 1.0))
    return (yn, 1 + it0, resn, jxn, jwn) if resn < res else None


def _tangent(jx, jw, previous):
    j = bordered(jx, jw, previous)
    rhs = np.zeros(jw.size + 1)
    rhs[-1] = 1.0
    t = solve_checked(j, rhs, "continuation tangent", warn=False)[0]
    t /= np.linalg.norm(t)
    return t if t @ previous >= 0 else -t



def _corner_step(evaluate, y, t, travel, ds, tol, max_iter, conds):
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
        tb = _tangent(jx, jw, t)
        dirs += [tb, -tb]
    except (ConvergenceError, np.linalg.LinAlgError):
        pass
    dirs.append(t)
    last: Exception = ConvergenceError("corner step: no predictor")
    nb = np.linalg.norm(travel)
    for d in dirs:
        try:
            yn, it, res, jx, jw = _correct(evaluate, y + ds * d, d, tol, max_iter, conds,
                                           sphere=(y, ds))
        except (ConvergenceError, np.linalg.LinAlgError) as exc:
            last = exc
            continue
        chord = yn - y
        if nb > 0 and chord @ travel < -0.9 * np.linalg.norm(chord) * nb:
            last = _StepRejected("spherical corrector went back along the branch")
            continue
        return yn, it, res, jx, jw
    raise last

