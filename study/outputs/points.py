"""Branch queries: points of a run's branch (``result.branch``) as :class:`hbm.Point`,
and solutions at exactly a requested speed (:func:`point_at_speed`)."""
from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from hbm import ConvergenceError, Point

logger = logging.getLogger(__name__)

__all__ = ["time_series_speeds", "point_at", "nearest_point", "SpeedUse", "point_at_speed"]

#: Relative speed difference below which a branch point is "at" the requested speed.
SAME_SPEED = 1e-9


def time_series_speeds(result) -> list[float]:
    """Speeds for time series: the scene's list, else per contact class the stable point
    with the largest dynamic mesh load."""
    s = result.scene.outputs.time_series
    if s:
        return list(s)
    br = result.branch
    out = []
    mesh = br.element(0)
    for cls in (0, 1, 2):
        idx = np.flatnonzero((mesh.contact == cls) & br.stable)
        if idx.size:
            out.append(float(br.rpm[idx[np.argmax(mesh.mesh_load_std[idx])]]))
    return out


def point_at(result, i: int):
    """Point ``i`` of the branch as an :class:`hbm.Point`."""
    br = result.branch
    return Point(rpm=float(br.rpm[i]), omega=float(br.omega[i]), unknowns=br.unknowns[i],
                 coefficients=br.stats["coefficients"][i], residual=float(br.residual[i]),
                 iterations=int(br.newton_iterations[i]))


def nearest_point(result, rpm: float):
    """The stored point closest in speed (stable ones preferred) as an :class:`hbm.Point`."""
    br = result.branch
    d = np.abs(br.rpm - rpm) + np.where(br.stable, 0.0, 1e9)
    i = int(np.argmin(d))
    return i, point_at(result, i)


@dataclass(frozen=True)
class SpeedUse:
    """Which speed a point output asked at a speed was computed at.

    ``how``: ``"branch point"`` (a branch point lies at the speed), ``"solved"`` (a
    fixed-speed solve from the nearest branch point, ``start`` rpm) or ``"nearest
    point"`` (that solve failed: the output shows the nearest point, ``used`` rpm).
    """

    what: str
    requested: float
    used: float
    how: str
    start: float
    note: str = ""

    @property
    def exact(self) -> bool:
        """True when the output is at the requested speed."""
        return self.how != "nearest point"

    @property
    def text(self) -> str:
        """One sentence for report.md."""
        head = f"{self.what} asked at {self.requested:g} rpm"
        if self.how == "branch point":
            return f"{head}: a branch point"
        if self.how == "solved":
            return (f"{head}: solved at exactly that speed from the branch point at "
                    f"{self.start:.2f} rpm{self.note}")
        return (f"{head}: **shown at {self.used:.2f} rpm**, the nearest branch point (the "
                f"fixed-speed solve failed: {self.note})")


def point_at_speed(result, rpm: float, what: str) -> tuple[int, Point, SpeedUse]:
    """The solution at exactly ``rpm``: the nearest stored point (stable ones preferred,
    :func:`nearest_point`) when it lies there, else a fixed-speed Newton solve
    (:meth:`hbm.HBMProblem.solve`, the continuation's tolerance) started from it. When
    that solve fails the nearest point is returned and :class:`SpeedUse` says so.

    Returns the nearest point's index, the point and the :class:`SpeedUse`; the use is
    also appended to ``result.speed_uses`` (report.md and the ``speeds`` check).
    """
    i, pt = nearest_point(result, rpm)
    if abs(pt.rpm - rpm) <= SAME_SPEED * rpm:
        use = SpeedUse(what, rpm, pt.rpm, "branch point", pt.rpm)
    else:
        tol = result.scene.continuation.tolerance
        try:
            sol = result.problem.solve(rpm, x0=pt.unknowns, tol=tol)
            use = SpeedUse(what, rpm, sol.rpm, "solved", pt.rpm,
                           f" (residual {sol.residual:.1e}, {sol.iterations} Newton "
                           "iterations; its stability is not computed)")
            pt = sol
        except (ConvergenceError, ValueError, np.linalg.LinAlgError) as exc:
            logger.warning("%s at %g rpm: fixed-speed solve failed (%s); using the nearest "
                           "point at %.2f rpm", what, rpm, exc, pt.rpm)
            use = SpeedUse(what, rpm, pt.rpm, "nearest point", pt.rpm, str(exc))
    uses = getattr(result, "speed_uses", None)
    if uses is not None:
        uses.append(use)
    return i, pt, use
