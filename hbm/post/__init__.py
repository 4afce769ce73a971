"""Post-processing of solutions: per-element statistics (:mod:`.stats`), signals in time
and spectra (:mod:`.signals`), time integration of the equations (:mod:`.time_response`),
the independent checks of a solution (:mod:`.verify`) and the statistics and time line of
a torus solution (:mod:`.torus`)."""

from .signals import TimeSeries, spectrum, time_series
from .stats import (
    MeshPeriodEnvelope,
    element_statistics,
    impacts_per_mesh_period,
    ipp_sequence,
    mesh_period_envelope,
    point_stats,
)
from .torus import line_series, line_state, line_statistics, torus_statistics
from .verify import ShootingCheck, full_residual, quasi_static_delta, shooting_error

__all__ = ["MeshPeriodEnvelope", "ShootingCheck", "TimeSeries", "element_statistics",
           "full_residual", "impacts_per_mesh_period", "ipp_sequence", "line_series",
           "line_state", "line_statistics", "mesh_period_envelope", "point_stats",
           "quasi_static_delta", "shooting_error", "spectrum", "time_series",
           "torus_statistics"]
