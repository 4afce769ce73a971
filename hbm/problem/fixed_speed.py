"""Solutions at one speed: the converged :class:`Point`, the permanent-contact initial
guess and Newton at a fixed speed with its fallbacks (contact-law homotopy, damped
Newton), for :meth:`hbm.problem.HBMProblem.solve`.

The functions take the problem (:class:`hbm.problem.HBMProblem`) as their first
argument; this module does not import it (residual.py delegates here).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from ..newton import ConvergenceError, newton, solve_checked
from ..units import RPM_TO_RAD_S

logger = logging.getLogger(__name__)

__all__ = ["Point", "contact_homotopy", "initial_guess", "solve"]


@dataclass
class Point:
    """A converged periodic solution at one speed.

    Attributes
    ----------
    rpm, omega
        Shaft speed (rpm) and Omega (rad/s).
    unknowns
        Real unknown vector of the problem's condensation (physical units).
    coefficients
        Complex Fourier coefficients of every element's ``Delta_e = g_e^T q`` (m),
        (n_elements, n_harmonics).
    residual
        Relative residual norm ``||R_hat|| / max(||x_hat||, 1)`` (scaled).
    iterations
        Newton iterations used.
    """

    rpm: float
    omega: float
    unknowns: np.ndarray
    coefficients: np.ndarray
    residual: float
    iterations: int


def initial_guess(problem, omega: float) -> np.ndarray:
    """Linear response with every element's linear law (a gear mesh: permanent contact on
    the active flank), one Newton step."""
    u0 = np.zeros(problem.n_unknowns)
    r, ju, _ = problem.evaluate(u0, omega, law=0.0)
    dx = solve_checked(problem.scaled_jacobian(ju), r / problem.eq_scale,
                       "initial guess (linear contact)")[0]
    return u0 - dx * problem.x_scale


def solve(problem, rpm: float, x0: np.ndarray | None = None, tol: float = 1e-8,
          max_iter: int = 40) -> Point:
    """Newton at the fixed speed ``rpm`` from ``x0`` (default :func:`initial_guess`);
    on failure the contact-law homotopy, then damped Newton
    (:meth:`hbm.problem.HBMProblem.solve`)."""
    if not np.isfinite(rpm) or rpm <= 0:
        raise ValueError(f"rpm = {rpm!r}: must be > 0")
    omega = float(rpm) * RPM_TO_RAD_S
    u = initial_guess(problem, omega) if x0 is None else np.array(x0, dtype=float)
    if u.shape != (problem.n_unknowns,):
        raise ValueError(f"x0 shape = {u.shape}: must be ({problem.n_unknowns},)")

    def fun(x, j=True):
        return problem.scaled(x, omega, j)

    try:
        xh, it, res = newton(fun, u / problem.x_scale, tol, max_iter, line_search=False)
    except ConvergenceError as exc:
        logger.debug("plain Newton failed at %.6g rpm (%s); homotopy from linear contact",
                     rpm, exc)
        try:
            xh, it, res = contact_homotopy(problem, omega, tol, max_iter)
        except ConvergenceError:
            logger.debug("homotopy failed at %.6g rpm; damped Newton", rpm)
            xh, it, res = newton(fun, u / problem.x_scale, tol, 4 * max_iter,
                                 line_search=True)
    return problem.point(xh * problem.x_scale, omega, it, res)


def contact_homotopy(problem, omega: float, tol: float, max_iter: int):
    """Natural continuation in lam from the elements' linear laws (0) to their own (1)
    (a gear mesh: from the linear contact law to the dead zone).

    Returns (scaled unknowns, total iterations, relative residual); raises
    ConvergenceError when the step in lam falls below 1e-4.
    """
    x = initial_guess(problem, omega) / problem.x_scale
    lam, dlam, total = 0.0, 0.25, 0
    slope = np.zeros_like(x)
    while lam < 1.0:
        target = min(1.0, lam + dlam)
        guess = x + slope * (target - lam)

        def fun(y, j=True, t=target):
            return problem.scaled(y, omega, j, law=t)

        try:
            xn, it, _ = newton(fun, guess, tol, max_iter)
        except ConvergenceError:
            dlam *= 0.5
            if dlam < 1e-4:
                raise
            continue
        slope = (xn - x) / (target - lam)
        x, lam = xn, target
        total += it
        dlam = min(2 * dlam, 0.5) if it <= 4 else dlam
    r = problem.scaled(x, omega, False)
    return x, total, float(np.linalg.norm(r) / max(np.linalg.norm(x), 1.0))
