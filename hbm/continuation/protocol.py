"""What the continuation needs of a problem and of the measures of its points.

The tracer (:func:`hbm.continuation.continue_branch`) knows only a residual and its
tangent, as NLvib's ``solve_and_continue`` does: a :class:`ContinuationModel` gives the
scaled residual and its Jacobians in the unknowns and the speed, the unknowns' scales, a
fixed-speed solve for the first point; a :class:`Monitor` measures every converged point
(per-element statistics, stability) and names the event test functions whose sign
changes the tracer locates (:class:`EventFunction`: a grazing is a test function of an
element crossing zero). The HBM problem and its monitor (:mod:`hbm.sweep`) implement
them; the tests drive the tracer with algebraic ones.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

__all__ = ["ContinuationModel", "EventFunction", "Measurement", "Monitor", "SolvedPoint"]


class SolvedPoint(Protocol):
    """A converged point at one speed: unknowns (physical units), Omega (rad/s), Newton
    iterations and relative residual."""

    unknowns: np.ndarray
    omega: float
    iterations: int
    residual: float


class ContinuationModel(Protocol):
    """The equations the tracer follows: ``R(x, Omega) = 0``, ``x`` the unknowns.

    Attributes
    ----------
    n_unknowns
        Number of unknowns.
    x_scale
        Scale of each unknown (physical units): the tracer works on ``x / x_scale``.
    vibration
        Mask of the unknowns that measure a vibration (not a mean): what the predictors'
        test against jumps between orbits compares
        (:func:`hbm.continuation.predictors.orbit_change`).
    """

    n_unknowns: int
    x_scale: np.ndarray
    vibration: np.ndarray

    def scaled(self, xh: np.ndarray, omega: float, jacobian: bool = True):
        """Scaled residual ``R_hat(xh, Omega)`` and, if ``jacobian``, ``dR_hat/dxh`` (an
        array or a matrix-free operator of :mod:`hbm.krylov`) and ``dR_hat/dOmega``."""

    def solve(self, rpm: float, x0: np.ndarray | None = None, tol: float = 1e-8
              ) -> SolvedPoint:
        """Newton at a fixed speed (rpm) from ``x0`` (None: the model's own guess);
        raises :class:`hbm.newton.ConvergenceError`."""


@dataclass(frozen=True)
class EventFunction:
    """An event test function of the monitor: the statistic ``statistic`` of element
    ``element``; a sign change between two points is an event located on the branch,
    named ``name`` (a gear mesh: the flank), an ``"onset"`` when the value becomes
    positive if ``onset_positive`` (not positive otherwise), else an ``"end"``; values
    below ``1e-12 scale`` in magnitude count as zero when it is located."""

    element: int
    name: str
    statistic: str
    onset_positive: bool
    scale: float


@dataclass
class Measurement:
    """What a monitor measured at a converged point: its stability (placeholders when it
    is measured later, ``ticket`` then identifying it for :meth:`Monitor.collect`) and
    the per-element statistics ``stats`` (name -> (n_elements, ...) array)."""

    stable: bool
    floquet_max_real: float
    floquet_kind: int
    stability_consistent: bool
    stats: dict[str, np.ndarray] = field(default_factory=dict)
    ticket: Any = None
    amplification: float = float("nan")
    grazing: bool = False


class Monitor(Protocol):
    """Measures the converged points of a branch and names its events.

    Attributes
    ----------
    events
        The event test functions, each a statistic of one element.
    asynchronous
        True when stabilities arrive later (:meth:`collect`), measured in another process.
    pending
        Stabilities sent away and not collected yet (0 for a synchronous monitor).
    """

    events: tuple[EventFunction, ...]
    asynchronous: bool
    pending: int

    def branch_meta(self) -> dict[str, Any]:
        """What the branch records about the problem: ``harmonics`` (indices),
        ``condensation``, ``element_names``, ``statistics`` (the names of the
        per-element statistics every measurement holds) and ``element_statistics`` (per
        element, the names of its own)."""

    def measure(self, unknowns: np.ndarray, omega: float, iterations: int, residual: float,
                tangent: np.ndarray) -> Measurement:
        """Measure the converged point (unknowns in physical units, Omega in rad/s, the
        scaled unit tangent of the branch there)."""

    def test_value(self, index: int, unknowns: np.ndarray) -> float:
        """Value of event function ``index`` at the unknowns (a point being located)."""

    def collect(self, wait: bool, keep: int = 0) -> list[tuple[Any, dict[str, Any]]]:
        """Stabilities measured since the last call, ``(ticket, fields)``, in order; if
        ``wait``, waiting until at most ``keep`` are pending."""

    def auxiliary(self) -> Monitor:
        """A monitor for an auxiliary trace (the approach to the first point): the same
        statistics, no stability."""

    def start(self) -> None:
        """Before a trace (e.g. start a worker process)."""

    def stop(self) -> None:
        """After a trace, also on error (e.g. stop the worker)."""
