"""Per-point statistics of every element, the slow modulation of a solution period by
period (:class:`MeshPeriodEnvelope`), and the impacts per mesh period.

The statistics are each element's own (:meth:`hbm.elements.Element.measure`, names in
:attr:`~hbm.elements.Element.statistics`; a gear mesh: mesh-load std and max, contact
class, contact-loss fraction, impacts per mesh period, contact margins, IPP sequence),
measured on a grid of a whole number of samples per base period of every element, four
times the AFT grid by default.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..elements.contact_law import impacts_per_mesh_period
from ..problem import HBMProblem, Point
from ..records import Record
from .torus import torus_statistics

__all__ = ["MeshPeriodEnvelope", "element_statistics", "impacts_per_mesh_period",
           "ipp_sequence", "mesh_period_envelope", "point_stats", "unknowns_of"]


def unknowns_of(point: Point | np.ndarray) -> np.ndarray:
    """The unknowns of a :class:`Point`, or the array given."""
    return point.unknowns if isinstance(point, Point) else np.asarray(point, dtype=float)


def element_statistics(problem: HBMProblem, unknowns: np.ndarray,
                       n_time: int | None = None) -> list[dict[str, Any]]:
    """Every element's statistics at the unknowns ``unknowns`` (one dict per element); on
    a torus basis :func:`hbm.post.torus.torus_statistics`."""
    if not problem.periodic:
        return torus_statistics(problem, unknowns, n_time)
    n = problem.fine_periods(n_time)
    synth, samples = problem.fine_grid(n)
    deltas = synth @ problem.delta_real(unknowns)
    return [el.measure(d, smp, step or 1) for el, d, smp, step in
            zip(problem.elements, deltas, samples, problem.steps, strict=True)]


def point_stats(problem: HBMProblem, point: Point | np.ndarray,
                n_time: int | None = None) -> list[Record]:
    """Statistics of a solution, one :class:`hbm.records.Record` per element (read by name
    or attribute: ``point_stats(pb, pt)[0].mesh_load_std``).

    ``n_time``: samples over the fundamental period (rounded up to a whole number per base
    period of every element); default four times the AFT's.
    """
    return [Record(s) for s in element_statistics(problem, unknowns_of(point), n_time)]


def ipp_sequence(problem: HBMProblem, point: Point | np.ndarray, element: int = 0
                 ) -> np.ndarray:
    """Impacts in each successive mesh period of gear mesh ``element`` over one
    fundamental period (Sect. 4.3)."""
    return point_stats(problem, point)[element]["ipp"]


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


def mesh_period_envelope(problem: HBMProblem, point: Point | np.ndarray,
                         n_time: int | None = None, element: int = 0) -> MeshPeriodEnvelope:
    """Largest load and mean deflection of element ``element`` in each of its base periods
    (a gear mesh: each mesh period) of one fundamental period.

    Parameters
    ----------
    problem
        The HBM problem.
    point
        A solution (:class:`Point` or its unknowns).
    n_time
        Time samples over the fundamental period (rounded up to a multiple of the base
        periods in it); default four times the AFT's.
    element
        Which element (its parameters must vary with a base frequency).

    Returns
    -------
    MeshPeriodEnvelope
        ``problem.steps[element]`` values each: Z over a shaft turn when the fundamental
        is the shaft frequency, one when it is the mesh frequency.
    """
    problem.require_periodic("mesh_period_envelope")
    step = problem.steps[element]
    if not step:
        raise ValueError(f"mesh_period_envelope: {problem.labels[element]} has no base "
                         "frequency (its parameters do not vary in time)")
    n = problem.fine_periods(n_time)
    synth, samples = problem.fine_grid(n)
    delta = (synth @ problem.delta_real(unknowns_of(point)))[element]
    load = problem.elements[element].load(delta, samples[element])
    return MeshPeriodEnvelope.of(load, delta, step)
