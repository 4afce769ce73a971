"""Harmonic balance for vibro-impact dynamics of geared machines (pure NumPy/SciPy).

Solves ``M q'' + C q' + K q + sum_e g_e f_e(g_e^T q, t) = f_ex(t)`` (eq. 4, 13-14) for
periodic responses over a speed range: a linear system with any number of nonlinear
elements (:mod:`hbm.elements`: the gear mesh's dead zone with TVMS and loaded TE, a
cubic spring), each acting along its direction; a harmonic basis of any fundamental that
divides the excitation and element frequencies (:mod:`hbm.basis`), or of several
independent base frequencies on a torus (:mod:`hbm.torus`, a gear train's meshes and
shafts with hunting ratios); AFT, exact
condensation onto the elements' deflections, Newton corrector (dense or matrix-free),
pseudo-arc-length continuation of any residual (:mod:`hbm.continuation`), grazing (eq. 30)
and fold detection, stability (:mod:`hbm.stability`), post-processing and independent
checks (:mod:`hbm.post`). See docs/hbm.md.
"""

from .basis import HarmonicSet, common_fundamental
from .continuation import Branch, ElementCurve, GrazingPoint, continue_branch
from .elements import CubicSpring, Element, GearMesh, make_element
from .newton import ConvergenceError
from .post import (
    MeshPeriodEnvelope,
    ShootingCheck,
    TimeSeries,
    full_residual,
    impacts_per_mesh_period,
    ipp_sequence,
    mesh_period_envelope,
    point_stats,
    quasi_static_delta,
    shooting_error,
    spectrum,
    time_series,
)
from .problem import HBMProblem, Point
from .records import Record
from .stability import floquet_exponents
from .sweep import PointMonitor, trace
from .system import Excitation, LinearSystem
from .torus import TorusBasis, train_basis
from .units import RPM_TO_RAD_S

__all__ = [
    "Branch", "ConvergenceError", "CubicSpring", "Element", "ElementCurve", "Excitation",
    "GearMesh", "GrazingPoint", "HBMProblem", "HarmonicSet", "LinearSystem",
    "MeshPeriodEnvelope", "Point", "PointMonitor", "RPM_TO_RAD_S", "Record", "ShootingCheck",
    "TimeSeries", "TorusBasis", "common_fundamental", "continue_branch", "floquet_exponents",
    "full_residual", "impacts_per_mesh_period", "ipp_sequence", "make_element",
    "mesh_period_envelope", "point_stats", "quasi_static_delta", "shooting_error",
    "spectrum", "time_series", "trace", "train_basis",
]
