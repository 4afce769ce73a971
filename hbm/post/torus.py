"""Post-processing of a torus (multi-frequency) solution: statistics over the torus, the
response along the time line, the state at given instants (docs/hbm.md, "Several base
frequencies"; docs/theory.md T.39-T.40).

A torus solution ``x(theta)`` (:class:`hbm.torus.TorusBasis`) gives the response in time
along the line ``theta(t) = r Omega t``. Its statistics are the elements' own
(:meth:`hbm.elements.Element.measure`) over a torus grid — the ergodic average: for
incommensurate bases the time average along the line; for commensurate ones (a gear
train) the average over every relative phase of the bases, which differs from the time
average over the common period only by the statistic's Fourier coefficients at the
resonant combinations ``k . r = 0`` (T.39) — except the *temporal* ones (impacts: a loss of
contact followed by contact, :attr:`hbm.elements.Statistic.temporal`), measured along the
time line over a window of base periods of the element.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..problem import HBMProblem, Point
from .signals import TimeSeries

__all__ = ["LINE_PERIODS", "line_samples", "line_series", "line_state", "line_statistics",
           "torus_statistics"]

#: Base periods of an element along the time line for its temporal statistics.
LINE_PERIODS = 16


def _unknowns(point) -> np.ndarray:
    return point.unknowns if isinstance(point, Point) else np.asarray(point, dtype=float)


def _samples_per_period(problem: HBMProblem, q: int) -> int:
    """Samples per base period (frequency index ``q``) resolving every harmonic of the set
    four times over: a power of two >= max(32, 4 max|p| / q + 4)."""
    top = max(abs(p) for p in problem.harmonics.frequency_index)
    need = max(32, int(np.ceil(4 * top / q)) + 4)
    return int(2 ** int(np.ceil(np.log2(need))))


def _element_index(problem: HBMProblem, element: int) -> int:
    """Frequency index ``c . (r / ratio)`` of an element's base frequency (> 0)."""
    step = problem.steps[element]
    if not step:
        raise ValueError(f"{problem.labels[element]} has no base frequency (its "
                         "parameters do not vary in time)")
    return sum(a * b for a, b in zip(step, problem.harmonics.multiples, strict=True))


def line_samples(problem: HBMProblem, point: Point | np.ndarray, element: int,
                 periods: int = LINE_PERIODS, samples_per_period: int | None = None):
    """Element ``element``'s deflection and parameters along the time line from t = 0 over
    ``periods`` of its base periods, ``samples_per_period`` each (default: every harmonic
    resolved four times): ``(delta, samples, tau)``, ``tau = ratio Omega t`` (rad)."""
    problem.require_torus("line_samples")
    hs = problem.harmonics
    q = _element_index(problem, element)
    spp = samples_per_period or _samples_per_period(problem, q)
    n = int(periods) * int(spp)
    rows = hs.line_rows(periods, q, n)
    delta = rows @ problem.delta_real(_unknowns(point))[element]
    base = 2.0 * np.pi * (np.arange(n) % spp) / spp
    tau = 2.0 * np.pi * np.arange(n) / (q * spp)
    return delta, problem.elements[element].sample(base), tau


def torus_statistics(problem: HBMProblem, point: Point | np.ndarray, n_time=None,
                     periods: int = LINE_PERIODS,
                     samples_per_period: int | None = None) -> list[dict[str, Any]]:
    """Every element's statistics of a torus solution (one dict per element).

    Over the torus grid ``problem.fine_periods(n_time)`` (default twice the AFT grid
    along every base within :data:`hbm.torus.STATS_MAX_SAMPLES`): the ergodic averages
    and extremes; the temporal statistics (a gear mesh: ``impacts_per_mesh_period``,
    ``ipp``) along the time line over ``periods`` base periods of the element
    (:func:`line_samples`).
    """
    problem.require_torus("torus_statistics")
    u = _unknowns(point)
    grid = problem.fine_periods(n_time)
    synth, samples = problem.fine_grid(grid)
    deltas = synth @ problem.delta_real(u)
    out = [el.measure(d, smp, 1) for el, d, smp in
           zip(problem.elements, deltas, samples, strict=True)]
    for e, el in enumerate(problem.elements):
        names = [st.name for st in el.statistics if st.temporal]
        if not names or not problem.steps[e]:
            continue
        d, smp, _ = line_samples(problem, u, e, periods, samples_per_period)
        line = el.measure(d, smp, int(periods))
        for name in names:
            out[e][name] = line[name]
    return out


def line_statistics(problem: HBMProblem, point: Point | np.ndarray,
                    samples_per_period: int | None = None) -> list[dict[str, Any]]:
    """Every element's statistics along the time line over the common period of the bases
    (the periodic response's own, the same as a :class:`hbm.basis.HarmonicSet` over that
    period gives; T.40). Refused when that period holds more than 2**22 samples: use
    :func:`torus_statistics`."""
    problem.require_torus("line_statistics")
    hs = problem.harmonics
    u = _unknowns(point)
    dr = problem.delta_real(u)
    out = []
    for e, el in enumerate(problem.elements):
        if not problem.steps[e]:
            q = max(1, max(abs(p) for p in hs.frequency_index))
            spp = samples_per_period or 16
            n = q * spp
            if n > 1 << 22:
                raise ValueError(f"line_statistics: {n} samples over the common period")
            d = hs.line_rows(1, 1, n) @ dr[e]
            out.append(el.measure(d, None, 1))
            continue
        q = _element_index(problem, e)
        spp = samples_per_period or _samples_per_period(problem, q)
        n = q * spp
        if n > 1 << 22:
            raise ValueError(f"line_statistics: the common period holds {q} base periods of "
                             f"{problem.labels[e]}, {n} samples: too long, use "
                             "torus_statistics")
        d, smp, _ = line_samples(problem, u, e, q, spp)
        out.append(el.measure(d, smp, q))
    return out


def line_series(problem: HBMProblem, point: Point, periods: int = LINE_PERIODS,
                samples_per_period: int | None = None, element: int = 0) -> TimeSeries:
    """Element ``element``'s deflection, force and signals along the time line from t = 0
    over ``periods`` of its base periods (t in s): the torus counterpart of
    :func:`hbm.time_series`."""
    d, smp, tau = line_samples(problem, point, element, periods, samples_per_period)
    el = problem.elements[element]
    w = problem.harmonics.fundamental_rad_s(point.omega)
    return TimeSeries(t=tau / w, delta=d, load=el.load(d, smp), signals=el.signals(d, smp))


def line_state(problem: HBMProblem, point: Point, t) -> tuple[np.ndarray, np.ndarray]:
    """Every coordinate and its velocity along the time line at the instants ``t`` (s):
    ``q(t) = Re sum_k q_k exp(i w_k t)``, ``w_k = (k . r) Omega``; arrays (n_dof, len(t))
    (the start of a time integration on the torus solution)."""
    problem.require_torus("line_state")
    q = problem.recover(point)                                        # (n, nS)
    w = problem.kS * problem.harmonics.rate * point.omega
    ex = np.exp(1j * np.outer(w, np.atleast_1d(np.asarray(t, dtype=float))))
    return (q @ ex).real, ((q * (1j * w)[None, :]) @ ex).real
