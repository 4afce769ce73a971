"""Harmonic balance for gear-mesh vibro-impacts (pure NumPy/SciPy).

Solves ``M q'' + C q' + K q + G f_LoA(G^T q, t) = f_ex(t)`` (eq. 4, 13-14) for
periodic responses over a speed range: AFT, exact condensation onto the line of
action, Newton corrector, pseudo-arc-length continuation, grazing (eq. 30) and
fold detection, Hill stability, time reconstruction.  See docs/hbm.md.
"""

from .continuation import Branch, GrazingPoint, trace
from .harmonics import HarmonicSet
from .model import Excitation, GearMesh, LinearSystem
from .postprocess import (
    MeshPeriodEnvelope,
    PointStats,
    TimeSeries,
    impacts_per_mesh_period,
    ipp_sequence,
    mesh_period_envelope,
    point_stats,
    spectrum,
    time_series,
)
from .problem import RPM_TO_RAD_S, ConvergenceError, HBMProblem, Point
from .stability import floquet_exponents
from .verify import ShootingCheck, full_residual, quasi_static_delta, shooting_error

__all__ = [
    "Branch", "ConvergenceError", "Excitation", "GearMesh", "GrazingPoint", "HBMProblem",
    "HarmonicSet", "LinearSystem", "MeshPeriodEnvelope", "Point", "PointStats", "RPM_TO_RAD_S",
    "ShootingCheck", "TimeSeries",
    "floquet_exponents", "full_residual", "impacts_per_mesh_period", "ipp_sequence",
    "mesh_period_envelope", "point_stats", "quasi_static_delta",
    "shooting_error",
    "spectrum", "time_series", "trace",
]
