"""Newton on scaled unknowns, with a checked LU solve and its condition estimate.

Used by :class:`hbm.problem.HBMProblem` at a fixed speed (plain and damped
Newton, contact-law homotopy) and by :mod:`hbm.continuation` (branch switching).
``solve_checked`` is the one dense solve of every Newton step in hbm/.
"""

from __future__ import annotations

import logging
import warnings

import numpy as np

logger = logging.getLogger(__name__)

__all__ = ["COND_WARN", "ConvergenceError", "backtrack", "factor_checked", "newton",
           "solve_checked"]

COND_WARN = 1e10   # 1-norm condition estimate of a Newton matrix above which we warn


class ConvergenceError(RuntimeError):
    """Newton did not reach the tolerance; carries the last relative residual
    and the condition estimate of the last Newton matrix (inf if singular)."""

    def __init__(self, message: str, residual: float = np.inf,
                 condition: float = np.nan) -> None:
        super().__init__(message)
        self.residual = residual
        self.condition = condition


def factor_checked(j: np.ndarray, where: str = "Newton", warn: bool = True,
                   dtype=np.float64) -> tuple[np.ndarray, np.ndarray, float]:
    """LU factors of ``j`` and the estimate of its 1-norm condition number.

    The estimate is LAPACK's ``gecon`` on the LU factors (O(n^2) on top of the
    factorisation).  Above :data:`COND_WARN` a warning naming ``where`` and the
    estimate is logged (when ``warn``).

    ``dtype=np.float32`` factorises in single precision (a preconditioner: half the
    memory traffic of every solve).

    Returns
    -------
    lu, piv, condition
        As ``scipy.linalg.lu_factor``, and the condition estimate.

    Raises
    ------
    ConvergenceError
        If the matrix is singular to working precision (zero pivot or
        condition estimate above 1/eps) or not finite.
    """
    import scipy.linalg as sla

    j = np.asarray(j, dtype=float)
    if not np.all(np.isfinite(j)):
        raise ConvergenceError(f"{where}: the Jacobian contains NaN or inf", np.inf, np.inf)
    anorm = float(np.max(np.sum(np.abs(j), axis=0))) if j.size else 0.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sla.LinAlgWarning)     # singularity is handled below
        lu, piv = sla.lu_factor(j.astype(dtype, copy=False), check_finite=False)
    diag = np.abs(np.diag(lu))
    if anorm == 0.0 or np.min(diag) == 0.0:
        raise ConvergenceError(f"{where}: singular Jacobian (zero pivot in its LU factors)",
                               np.inf, np.inf)
    gecon = sla.get_lapack_funcs("gecon", (lu,))
    rcond, _ = gecon(lu, anorm, norm="1")
    cond = float(np.inf if rcond <= 0 else 1.0 / rcond)
    if cond * np.finfo(float).eps > 1.0:
        raise ConvergenceError(f"{where}: singular Jacobian (condition estimate {cond:.2g} > "
                               f"1/eps)", np.inf, cond)
    if warn and cond > COND_WARN:
        logger.warning("%s: ill-conditioned Jacobian, condition estimate %.2g (n = %d); "
                       "the solution may lose up to %d digits", where, cond, j.shape[0],
                       int(np.log10(cond)))
    return lu, piv, cond


def solve_checked(j, rhs: np.ndarray, where: str = "Newton",
                  warn: bool = True) -> tuple[np.ndarray, float]:
    """Solve ``j x = rhs``; return ``x`` and the condition estimate of ``j``.

    A dense ``j`` is factorised by :func:`factor_checked` (which raises
    :class:`ConvergenceError` when it is singular or not finite); a matrix-free
    one (:mod:`hbm.krylov`) is solved by preconditioned GMRES, the estimate being
    that of the factor used as preconditioner.
    """
    import scipy.linalg as sla

    if not isinstance(j, np.ndarray) and hasattr(j, "solve"):      # hbm.krylov operator
        rhs = np.asarray(rhs, dtype=float)
        if rhs.ndim == 2:
            cols = [j.solve(c, where, warn) for c in rhs.T]
            return np.stack([c[0] for c in cols], axis=1), max(c[1] for c in cols)
        return j.solve(rhs, where, warn)
    lu, piv, cond = factor_checked(j, where, warn)
    return sla.lu_solve((lu, piv), rhs, check_finite=False), cond


def backtrack(relative_residual, x: np.ndarray, dx: np.ndarray, res: float,
              tries: int) -> float:
    """Step length of a damped Newton step: the first of 1, 1/2, ..., 2^-(tries-1)
    whose relative residual ``relative_residual(x + alpha dx)`` is below
    ``(1 - 1e-4 alpha) res`` (Armijo on the residual norm), else ``2^-tries``.

    Shared by :func:`newton` and the continuation corrector, whose residual is
    only piecewise smooth (the dead-zone force).
    """
    alpha = 1.0
    for _ in range(tries):
        rest = relative_residual(x + alpha * dx)
        if np.isfinite(rest) and rest < (1.0 - 1e-4 * alpha) * res:
            break
        alpha *= 0.5
    return alpha


def newton(fun, x: np.ndarray, tol: float, max_iter: int, diverge: float = 1e8,
           line_search: bool = False):
    """Damped Newton on scaled unknowns: ``fun(x) -> (r, J, ...)``, ``fun(x, False) -> r``.

    Returns (x, iterations, relative residual); raises ConvergenceError.
    """
    res = np.inf
    r0 = None
    cond = np.nan
    warned = False
    for it in range(max_iter + 1):
        r = fun(x, False)
        res = float(np.linalg.norm(r) / max(np.linalg.norm(x), 1.0))
        if not np.isfinite(res):
            raise ConvergenceError(f"non-finite residual at iteration {it}", res, cond)
        if r0 is None:
            r0 = res
        if res < tol and (it == 0 or cond * res > 1e-7):
            # converged at the guess, or with a loose error bound cond * res: one
            # Newton step more (kept if it lowers the residual)
            try:
                rr, jj = fun(x)[:2]
                xn = x + solve_checked(jj, -rr, "Newton refinement", warn=False)[0]
                resn = float(np.linalg.norm(fun(xn, False)) / max(np.linalg.norm(xn), 1.0))
            except ConvergenceError:
                resn = np.inf
            return (xn, it + 1, resn) if resn < res else (x, it, res)
        if res < tol:
            return x, it, res
        if it == max_iter or res > diverge * max(r0, tol):
            break
        r, j = fun(x)[:2]
        try:
            dx, cond = solve_checked(j, -r, f"Newton iteration {it}", warn=not warned)
        except ConvergenceError as exc:
            raise ConvergenceError(f"{exc} (relative residual {res:.3g})", res,
                                   exc.condition) from exc
        warned = warned or cond > COND_WARN
        # backtracking on the residual norm (the force is only piecewise smooth)
        alpha = backtrack(lambda xt: float(np.linalg.norm(fun(xt, False))
                                           / max(np.linalg.norm(xt), 1.0)),
                          x, dx, res, 8) if line_search else 1.0
        x = x + alpha * dx
    why = "diverged: relative residual" if res > diverge * max(r0, tol) else "relative residual"
    raise ConvergenceError(f"Newton {why} {res:.3g} > tol {tol:.1g} after {it} iterations "
                           f"(condition estimate of the scaled Jacobian {cond:.2g})", res, cond)
