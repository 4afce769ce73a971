"""Newton on scaled unknowns, with a checked LU solve and its condition estimate.

:func:`iterate` is the one Newton loop of hbm/ (line search by :func:`backtrack`,
refinement step, condition bookkeeping): :func:`newton` runs it on the equations at a
fixed speed (:class:`NewtonSystem`; used by :class:`hbm.problem.HBMProblem`: plain and
damped Newton, contact-law homotopy, and by :mod:`hbm.continuation` to land on a bound),
the continuation corrector on its bordered system
(:class:`hbm.continuation.corrector.Bordered`).
``solve_checked`` is the one dense solve of every Newton step in hbm/.
"""

from __future__ import annotations

import logging
import warnings

import numpy as np

logger = logging.getLogger(__name__)

__all__ = ["COND_WARN", "ConvergenceError", "NewtonSystem", "backtrack", "factor_checked",
           "iterate", "newton", "solve_checked"]

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
        # one pass into LAPACK's column order (lu_factor would copy a C-ordered array)
        lu, piv = sla.lu_factor(np.array(j, dtype=dtype, order="F"), overwrite_a=True,
                                check_finite=False)
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


REFINE_BOUND = 1e-7   # refine a converged point when cond * residual exceeds this


class NewtonSystem:
    """What :func:`iterate` solves: the scaled equations of :func:`newton` at a fixed
    speed, ``fun(x) -> (r, J, ...)``, ``fun(x, False) -> r``.

    A subclass changes what differs (the continuation corrector,
    :class:`hbm.continuation.corrector.Bordered`: the augmented unknowns, the bordered
    matrix, its damping and divergence test); the iteration, the line search, the
    refinement step and the condition bookkeeping are :func:`iterate`'s.
    """

    #: ``solve_checked`` may log an ill-conditioned matrix (once per solve)
    warn = True
    #: errors of the refinement step that only make it fail (the point is kept)
    recoverable: tuple[type[Exception], ...] = (ConvergenceError,)

    def __init__(self, fun, diverge: float = 1e8, line_search: bool = False) -> None:
        self.fun, self.diverge, self.line_search = fun, diverge, line_search

    def evaluate(self, x: np.ndarray):
        """The residual at ``x`` (what :meth:`relative` and :meth:`matrix` read)."""
        return self.fun(x, False)

    def relative(self, x: np.ndarray, ev) -> float:
        """Relative residual ``||R|| / max(||x||, 1)`` of an evaluation."""
        return float(np.linalg.norm(ev) / max(np.linalg.norm(x), 1.0))

    def trial(self, x: np.ndarray) -> float:
        """Relative residual at a trial point of the line search."""
        return float(np.linalg.norm(self.fun(x, False)) / max(np.linalg.norm(x), 1.0))

    def matrix(self, x: np.ndarray, ev):
        """Newton matrix and right-hand side at ``x``: the step solves ``J dx = rhs``."""
        r, j = self.fun(x)[:2]
        return j, -r

    def where(self, it: int) -> str:
        return f"Newton iteration {it}"

    refine_where = "Newton refinement"

    def tries(self, it: int) -> int:
        """Halvings of the backtracking line search at iteration ``it`` (0: full step)."""
        return 8 if self.line_search else 0

    def diverged(self, it: int, res: float, res0: float, tol: float) -> bool:
        return res > self.diverge * max(res0, tol)

    def non_finite(self, it: int, res: float, cond: float) -> ConvergenceError:
        return ConvergenceError(f"non-finite residual at iteration {it}", res, cond)

    def failure(self, it: int, res: float, res0: float, tol: float, cond: float) -> str:
        why = "diverged: relative residual" if self.diverged(it, res, res0, tol) else \
            "relative residual"
        return (f"Newton {why} {res:.3g} > tol {tol:.1g} after {it} iterations "
                f"(condition estimate of the scaled Jacobian {cond:.2g})")


def iterate(system: NewtonSystem, x: np.ndarray, tol: float, max_iter: int,
            conds: list | None = None):
    """Newton on ``system`` from ``x``: the one loop of :func:`newton` and the
    continuation corrector.

    Converged when the relative residual is below ``tol``; then one Newton step more
    (kept if it lowers the residual) when converged at the guess or with a loose error
    bound ``cond * res > REFINE_BOUND``. Each step is damped by :func:`backtrack` when
    ``system.tries(it)`` says so. ``conds``, if given, collects the condition estimates.

    Returns
    -------
    x, iterations, relative residual, evaluation
        The evaluation is ``system.evaluate(x)`` at the returned point.

    Raises
    ------
    ConvergenceError
        Not converged in ``max_iter`` iterations, diverged, or a singular matrix.
    """
    res0 = None
    cond = np.nan
    warned = False
    for it in range(max_iter + 1):
        ev = system.evaluate(x)
        res = system.relative(x, ev)
        if not np.isfinite(res):
            raise system.non_finite(it, res, cond)
        res0 = res if res0 is None else res0
        if res < tol and (it == 0 or cond * res > REFINE_BOUND):
            # within tol already at the guess, or an error bound cond * res that a poorly
            # conditioned matrix makes loose: one Newton step more, so that the point
            # does not carry a tol-sized error along
            return _refine(system, x, ev, res, it)
        if res < tol:
            return x, it, res, ev
        if it == max_iter or system.diverged(it, res, res0, tol):
            break
        j, rhs = system.matrix(x, ev)
        try:
            dx, cond = solve_checked(j, rhs, system.where(it), warn=system.warn and not warned)
        except ConvergenceError as exc:
            raise ConvergenceError(f"{exc} (relative residual {res:.3g})", res,
                                   exc.condition) from exc
        warned = warned or cond > COND_WARN
        if conds is not None:
            conds.append(cond)
        tries = system.tries(it)
        if tries:
            # backtracking on the residual norm (the force is only piecewise smooth)
            dx = backtrack(system.trial, x, dx, res, tries) * dx
        x = x + dx
    raise ConvergenceError(system.failure(it, res, res0, tol, cond), res, cond)


def _refine(system: NewtonSystem, x: np.ndarray, ev, res: float, it: int):
    """One Newton step from a point within tol; kept if it lowers the residual."""
    try:
        j, rhs = system.matrix(x, ev)
        xn = x + solve_checked(j, rhs, system.refine_where, warn=False)[0]
        evn = system.evaluate(xn)
        resn = system.relative(xn, evn)
    except system.recoverable:
        resn = np.inf
    return (xn, it + 1, resn, evn) if resn < res else (x, it, res, ev)


def newton(fun, x: np.ndarray, tol: float, max_iter: int, diverge: float = 1e8,
           line_search: bool = False):
    """Damped Newton on scaled unknowns: ``fun(x) -> (r, J, ...)``, ``fun(x, False) -> r``
    (:func:`iterate` on a :class:`NewtonSystem`).

    Returns (x, iterations, relative residual); raises ConvergenceError.
    """
    x, it, res, _ = iterate(NewtonSystem(fun, diverge, line_search), x, tol, max_iter)
    return x, it, res
