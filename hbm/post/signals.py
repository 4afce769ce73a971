"""An element's signals in time and its force spectrum, reconstructed from a solution."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..problem import HBMProblem, Point

__all__ = ["TimeSeries", "spectrum", "time_series"]


@dataclass
class TimeSeries:
    """An element's signals over ``n_periods`` fundamental periods (SI units).

    ``t`` (s), ``delta`` its deflection ``Delta_e`` (m), ``load`` its force ``f_e`` (N)
    and ``signals`` the element's own (a gear mesh: ``gap_active``, ``gap_reverse`` the
    contact thresholds of ``Delta`` and ``stiffness`` k_m, :meth:`Element.signals`).
    """

    t: np.ndarray
    delta: np.ndarray
    load: np.ndarray
    signals: dict[str, np.ndarray]


def _element_signals(problem: HBMProblem, point: Point, n: int, element: int):
    """``Delta_e``, the element, its samples on a grid of ``n`` instants."""
    synth, samples = problem.fine_grid(n)
    delta = (synth @ problem.delta_real(point.unknowns))[element]
    return delta, problem.elements[element], samples[element]


def time_series(problem: HBMProblem, point: Point, n_periods: int = 1,
                samples_per_period: int | None = None, element: int = 0) -> TimeSeries:
    """Reconstruct the deflection, the force and the signals of element ``element``
    (a gear mesh: Delta(t), f_LoA(t) and the contact thresholds, eq. 12-13).

    Time ``t`` in s from 0 over ``n_periods`` fundamental periods;
    ``samples_per_period`` rounded up to a whole number per base period of every element
    (default four times the AFT grid).
    """
    problem.require_periodic("time_series")
    if int(n_periods) != n_periods or n_periods < 1:
        raise ValueError(f"n_periods = {n_periods!r}: must be an integer >= 1")
    n = problem.fine_periods(samples_per_period)
    delta, el, smp = _element_signals(problem, point, n, element)
    f = el.load(delta, smp)
    w0 = problem.harmonics.fundamental_rad_s(point.omega)
    reps = int(n_periods)
    t = 2 * np.pi * np.arange(n * reps) / n / w0

    def tile(x):
        return np.tile(x, reps)

    return TimeSeries(t=t, delta=tile(delta), load=tile(f),
                      signals={k: tile(v) for k, v in el.signals(delta, smp).items()})


def spectrum(problem: HBMProblem, point: Point, n_time: int | None = None,
             element: int = 0) -> dict:
    """One-sided amplitude spectra of element ``element``'s force and deflection over one
    period (a gear mesh: the mesh load f_LoA and the dynamic transmission error
    Delta = g^T q, eqs. 10, 13).

    Returns a dict with ``index`` (of w0), ``shaft_order`` (index times ``w0 / Omega``),
    ``frequency_hz``, ``amplitude`` (N, |f_k| in the convention
    f = Re sum f_k exp(i k w0 t)), ``dte_amplitude`` (m, |Delta_k| likewise) and
    ``peak_to_peak`` (N, of the force in time).
    """
    problem.require_periodic("spectrum")
    n = problem.fine_periods(n_time)
    delta, el, smp = _element_signals(problem, point, n, element)
    f = el.load(delta, smp)
    c, d = _one_sided(f), _one_sided(delta)
    idx = np.arange(c.size)
    r = problem.harmonics.ratio
    order = idx * r.numerator if r.denominator == 1 else idx * float(r)
    w0 = problem.harmonics.fundamental_rad_s(point.omega)
    return {"index": idx, "shaft_order": order, "frequency_hz": idx * w0 / (2 * np.pi),
            "amplitude": c, "dte_amplitude": d, "peak_to_peak": float(np.ptp(f))}


def _one_sided(y: np.ndarray) -> np.ndarray:
    """|c_k| of a real periodic sample, k = 0 … n/2 (y = Re sum c_k exp(i k tau))."""
    c = np.abs(np.fft.rfft(y)) / y.size
    c[1:] *= 2.0
    return c
