"""Per-point contact statistics, time reconstruction and mesh-load spectrum."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .contact import dead_zone
from .problem import HBMProblem, Point

__all__ = ["PointStats", "TimeSeries", "MeshPeriodEnvelope", "point_stats", "time_series",
           "spectrum", "ipp_sequence", "impacts_per_mesh_period", "mesh_period_envelope"]


@dataclass
class PointStats:
    """Contact statistics of one periodic solution (one fundamental period).

    Attributes
    ----------
    mesh_load_std, mesh_load_max
        Standard deviation and maximum in time of f_LoA (N).
    contact
        0 permanent contact, 1 single-sided impacts, 2 double-sided impacts.
    contact_loss_fraction
        Fraction of the period with ``|Delta - e| <= b``.
    impacts_per_mesh_period
        Mean number of impacts (re-contacts) per mesh period.
    margin_active
        ``min_t (Delta - e - b)`` (m): > 0 means permanent active contact; its
        sign is phi_GR of eq. (30).
    margin_reverse
        ``max_t (e - Delta - b)`` (m): > 0 means the reverse flank is hit.
    ipp
        Impacts in each mesh period along the fundamental period (ints).
    """

    mesh_load_std: float
    mesh_load_max: float
    contact: int
    contact_loss_fraction: float
    impacts_per_mesh_period: float
    margin_active: float
    margin_reverse: float
    ipp: np.ndarray


@dataclass
class TimeSeries:
    """Signals over ``n_periods`` fundamental periods (SI units)."""

    t: np.ndarray
    delta: np.ndarray
    mesh_load: np.ndarray
    gap_active: np.ndarray
    gap_reverse: np.ndarray
    stiffness: np.ndarray


@dataclass(frozen=True)
class MeshPeriodEnvelope:
    """The slow modulation of a solution, mesh period by mesh period along one
    fundamental period (Sect. 4.3, Fig. 15b, d): ``peak_load`` the largest mesh load in
    each (N; with impacts, the impact load), ``mean_dte`` the mean of Delta (eq. 10) in
    each (m)."""

    peak_load: np.ndarray
    mean_dte: np.ndarray

    @classmethod
    def of(cls, load: np.ndarray, delta: np.ndarray, periods: int) -> MeshPeriodEnvelope:
        """From a mesh load (N) and Delta (m) sampled evenly over ``periods`` mesh
        periods (a multiple of ``periods`` samples each)."""
        return cls(peak_load=load.reshape(periods, -1).max(axis=1),
                   mean_dte=delta.reshape(periods, -1).mean(axis=1))

    @property
    def load_variation(self) -> float:
        """Largest over smallest peak load, minus one (the paper's "44 %"); inf when a
        mesh period carries no load."""
        lo = float(np.min(self.peak_load))
        return float(np.max(self.peak_load)) / lo - 1.0 if lo > 0 else float("inf")

    @property
    def dte_swing(self) -> float:
        """Peak-to-peak of ``mean_dte`` (m): the low-frequency modulation of the DTE."""
        return float(np.ptp(self.mean_dte))

    @property
    def load_cycles(self) -> int:
        """Cycles of ``peak_load`` per fundamental period: its largest Fourier line
        above the mean (0 with a single mesh period)."""
        c = np.abs(np.fft.rfft(self.peak_load))
        return int(np.argmax(c[1:]) + 1) if c.size > 1 else 0


def _n_fine(problem: HBMProblem, n_time: int | None) -> int:
    step = problem.mesh_step
    n = 4 * problem.harmonics.n_time if n_time is None else int(n_time)
    return step * int(np.ceil(n / step))


def _signals(problem: HBMProblem, delta_r: np.ndarray, n: int):
    e_fine, k, e = problem.fine_grid(n)
    tau = 2 * np.pi * np.arange(n) / n
    return tau, e_fine @ delta_r, k, e


def _refined_min(y: np.ndarray) -> float:
    """Minimum of a periodic sampled signal refined by a parabola through 3 samples."""
    i = int(np.argmin(y))
    ym, y0, yp = y[i - 1], y[i], y[(i + 1) % y.size]
    curv = ym - 2 * y0 + yp
    if curv > 0:
        return float(y0 - (yp - ym) ** 2 / (8 * curv))
    return float(y0)


def _unknowns(point) -> np.ndarray:
    return point.unknowns if isinstance(point, Point) else np.asarray(point, dtype=float)


def point_stats(problem: HBMProblem, point: Point | np.ndarray,
                n_time: int | None = None) -> PointStats:
    """Contact classification, margins and mesh-load statistics of a solution."""
    n = _n_fine(problem, n_time)
    _, delta, k, e = _signals(problem, problem.delta_real(_unknowns(point)), n)
    b = problem.b
    p = delta - e
    f = dead_zone(p, k, b)
    act = p > b
    rev = p < -b
    loss = ~(act | rev)
    touch_a, touch_r = bool(act.any()), bool(rev.any())
    if not loss.any():
        contact = 0
    elif touch_a and touch_r:
        contact = 2
    else:
        contact = 1
    ipp = impacts_per_mesh_period(loss, problem.mesh_step)
    return PointStats(
        mesh_load_std=float(np.std(f)), mesh_load_max=float(np.max(f)), contact=contact,
        contact_loss_fraction=float(np.mean(loss)),
        impacts_per_mesh_period=float(np.mean(ipp)),
        margin_active=_refined_min(p - b), margin_reverse=-_refined_min(p + b) ,
        ipp=ipp.astype(int))


def mesh_period_envelope(problem: HBMProblem, point: Point | np.ndarray,
                         n_time: int | None = None) -> MeshPeriodEnvelope:
    """Largest mesh load and mean DTE in each mesh period of one fundamental period.

    Parameters
    ----------
    problem
        The HBM problem.
    point
        A solution (:class:`Point` or its unknowns).
    n_time
        Time samples over the fundamental period (rounded up to a multiple of the mesh
        periods in it); default four times the AFT's.

    Returns
    -------
    MeshPeriodEnvelope
        ``problem.mesh_step`` values each: Z over a shaft turn when the fundamental is
        the shaft frequency, one when it is the mesh frequency.
    """
    n = _n_fine(problem, n_time)
    _, delta, k, e = _signals(problem, problem.delta_real(_unknowns(point)), n)
    return MeshPeriodEnvelope.of(dead_zone(delta - e, k, problem.b), delta, problem.mesh_step)


def impacts_per_mesh_period(loss: np.ndarray, mesh_step: int) -> np.ndarray:
    """Impacts in each mesh period (Sect. 4.3) from ``loss``, ``(..., n_time)`` booleans
    (contact lost) over one fundamental period of ``mesh_step`` mesh periods.

    An impact is a loss sample followed, cyclically, by a contact sample. Returns
    ``(..., mesh_step)`` integers.
    """
    loss = np.asarray(loss, dtype=bool)
    n = loss.shape[-1]
    imp = loss & ~np.roll(loss, -1, axis=-1)
    return imp.reshape(*loss.shape[:-1], mesh_step, n // mesh_step).sum(axis=-1)


def ipp_sequence(problem: HBMProblem, point: Point | np.ndarray) -> np.ndarray:
    """Impacts in each successive mesh period over one fundamental period (Sect. 4.3)."""
    return point_stats(problem, point).ipp


def time_series(problem: HBMProblem, point: Point, n_periods: int = 1,
                samples_per_period: int | None = None) -> TimeSeries:
    """Reconstruct Delta(t), f_LoA(t) and the contact thresholds (eq. 12-13).

    ``gap_active = b + e(t)`` (contact on the active flank when Delta exceeds
    it), ``gap_reverse = -b + e(t)`` (reverse flank when Delta is below it).
    Time ``t`` in s from 0 over ``n_periods`` fundamental periods.
    """
    if int(n_periods) != n_periods or n_periods < 1:
        raise ValueError(f"n_periods = {n_periods!r}: must be an integer >= 1")
    n = _n_fine(problem, samples_per_period)
    _, delta, k, e = _signals(problem, problem.delta_real(point.unknowns), n)
    b = problem.b
    f = dead_zone(delta - e, k, b)
    w0 = problem.harmonics.fundamental_rad_s(point.omega)
    reps = int(n_periods)
    t = 2 * np.pi * np.arange(n * reps) / n / w0

    def tile(x):
        return np.tile(x, reps)

    return TimeSeries(t=t, delta=tile(delta), mesh_load=tile(f), gap_active=tile(b + e),
                      gap_reverse=tile(e - b), stiffness=tile(k))


def spectrum(problem: HBMProblem, point: Point, n_time: int | None = None) -> dict:
    """One-sided amplitude spectra of the mesh load f_LoA and of the dynamic
    transmission error Delta = G^T q (eqs. 10, 13) over one period.

    Returns a dict with ``index`` (of w0), ``shaft_order``, ``frequency_hz``,
    ``amplitude`` (N, |f_k| in the convention f = Re sum f_k exp(i k w0 t)),
    ``dte_amplitude`` (m, |Delta_k| likewise) and ``peak_to_peak`` (N, of f_LoA in time).
    """
    n = _n_fine(problem, n_time)
    _, delta, k, e = _signals(problem, problem.delta_real(point.unknowns), n)
    f = dead_zone(delta - e, k, problem.b)
    c, d = _one_sided(f), _one_sided(delta)
    idx = np.arange(c.size)
    div = problem.harmonics.divisor
    w0 = problem.harmonics.fundamental_rad_s(point.omega)
    return {"index": idx, "shaft_order": idx * div, "frequency_hz": idx * w0 / (2 * np.pi),
            "amplitude": c, "dte_amplitude": d, "peak_to_peak": float(np.ptp(f))}


def _one_sided(y: np.ndarray) -> np.ndarray:
    """|c_k| of a real periodic sample, k = 0 … n/2 (y = Re sum c_k exp(i k tau))."""
    c = np.abs(np.fft.rfft(y)) / y.size
    c[1:] *= 2.0
    return c
