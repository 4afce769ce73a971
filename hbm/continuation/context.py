"""The fixed data of one trace (:class:`TraceContext`: the model, its monitor, the
augmented residual, the speed scale, the tolerances and steps) and its speed range
(:class:`SpeedRange`)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..units import RPM_TO_RAD_S
from .branch import Recorder
from .protocol import ContinuationModel, Monitor

__all__ = ["SpeedRange", "TraceContext"]


@dataclass
class TraceContext:
    """The fixed data of one trace.

    Attributes
    ----------
    model
        The equations (:class:`~hbm.continuation.protocol.ContinuationModel`).
    monitor
        What measures the points (:class:`~hbm.continuation.protocol.Monitor`).
    evaluate
        Augmented scaled residual ``y -> (R_hat, J_x, J_w)`` (:func:`hbm.continuation.
        corrector.augmented`).
    wscale
        Speed scale: ``w_hat = Omega / wscale``.
    tol, max_iter
        Corrector tolerance and iterations.
    gtol
        Tolerance on located grazing speeds (rpm).
    step, min_step, max_step
        Initial, smallest and largest arc-length step.
    """

    model: ContinuationModel
    monitor: Monitor
    evaluate: Callable
    wscale: float
    tol: float
    max_iter: int
    gtol: float
    step: float = 0.01
    min_step: float = 1e-6
    max_step: float = 0.05

    def state(self, rec: Recorder, i: int) -> np.ndarray:
        """Scaled ``y`` of point ``i`` of the recorder (a copy)."""
        return rec.states()[i].copy()

    def states(self, rec: Recorder) -> np.ndarray:
        """Scaled ``y`` of every point, (n_points, n_unknowns + 1) (read-only)."""
        return rec.states()

    def record(self, rec: Recorder, y: np.ndarray, it: int, res: float,
               tangent: np.ndarray) -> None:
        """Measure the converged point ``y`` (scaled; corrector iterations and residual,
        branch tangent) by the monitor and add it to the recorder; a stability measured
        later is collected into it (:meth:`settle`)."""
        omega = y[-1] * self.wscale
        u = y[:-1] * self.model.x_scale
        m = self.monitor.measure(u, omega, it, res, tangent)
        rec.add(ticket=m.ticket, stats=m.stats, rpm=omega / RPM_TO_RAD_S, omega=omega,
                unknowns=u, residual=res, newton_iterations=it, stable=bool(m.stable),
                floquet_max_real=m.floquet_max_real, tangents=tangent,
                floquet_kind=m.floquet_kind,
                stability_consistent=bool(m.stability_consistent),
                floquet_amplification=float(m.amplification),
                stability_grazing=bool(m.grazing))
        if m.ticket is not None:
            # placeholders until the verdict arrives (Recorder.branch settles first)
            rec.settle = lambda: self.settle(rec, wait=True)
            self.settle(rec, wait=False)

    def settle(self, rec: Recorder, wait: bool = True, keep: int = 0) -> None:
        """Fill in the stabilities the monitor measured so far; if ``wait``, waiting
        until at most ``keep`` are pending."""
        for ticket, values in self.monitor.collect(wait, keep):
            rec.fill(ticket, **values)


@dataclass(frozen=True)
class SpeedRange:
    """The speed range of a trace (rad/s): a branch folding back may leave it through its
    start by ``overshoot`` of the range (never below half of rpm_start sweeping up)."""

    rpm_start: float
    rpm_end: float
    overshoot: float

    @property
    def w_start(self) -> float:
        return self.rpm_start * RPM_TO_RAD_S

    @property
    def w_end(self) -> float:
        return self.rpm_end * RPM_TO_RAD_S

    @property
    def dirn(self) -> float:
        return 1.0 if self.w_end > self.w_start else -1.0

    @property
    def wscale(self) -> float:
        return abs(self.w_end - self.w_start)

    @property
    def w_floor(self) -> float:
        w_floor = self.w_start - self.dirn * self.overshoot * self.wscale
        return max(w_floor, 0.5 * self.w_start) if self.dirn > 0 else w_floor

    def crossed(self, wn: float) -> tuple[str, str, float] | None:
        """``(status, message, bound)`` if the speed ``wn`` lies past a bound, else None."""
        if self.dirn * (wn - self.w_end) > 0:
            return "completed", f"reached rpm_end = {self.rpm_end}", self.w_end
        if self.dirn * (wn - self.w_floor) < 0:
            return "left_range", (
                f"the branch turned back and left the range through rpm_start = "
                f"{self.rpm_start} (by more than overshoot = {self.overshoot} of the range)"
            ), self.w_floor
        return None
