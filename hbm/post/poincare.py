"""Poincaré sections of an element's load: samples once per reference period, from a
harmonic-balance orbit or from a time integration, and what they say about the response
(periodic, period-k, quasi-periodic, chaotic-like; docs/theory.md §16).

The section is ``t = j T_ref``, ``T_ref = 2 pi / w_ref`` the fundamental period of the
reference problem (the main branch's: the mesh period of a gear pair whose harmonic set
is the mesh's). A period-1 orbit of that problem has one sample; an orbit of a problem
whose fundamental is ``w_ref / k`` (a period-k branch, e.g. :mod:`hbm.branching`'s
doubled set) has ``k`` samples, at ``t = 0, T_ref, …, (k-1) T_ref`` of its own period.

A sequence of ``N`` section samples ``x_j`` of a time integration — the pair (Delta,
load) relative to their std (:func:`section_coordinates`: the load alone is zero
wherever contact is lost and can hide a period-2 motion) — is classified as
(:func:`classify_section`):

- ``period-k`` when ``max_j |x_{j+k} - x_j| <= tol * scale`` for the smallest ``k`` up to
  ``max_period`` (``k = 1``: periodic with the reference period);
- else, with enough samples, ``quasi-periodic`` when the section's own spectrum (Hann
  window) is a few discrete lines: on a two-torus ``x_j = F(j rho mod 1)`` with ``F``
  smooth, so its power sits in lines at ``m rho`` (mod 1) and the strongest
  :data:`LINES` lines hold at least :data:`CONCENTRATION` of it; ``rho`` (cycles per
  reference period, folded into (0, 1/2]) is the strongest line's frequency — the
  Neimark–Sacker rotation ``arg(mu) / 2 pi`` of the Floquet multiplier at the onset;
- ``chaotic-like`` when the power is spread (a broadband section);
- ``aperiodic`` when neither test can be made (too few samples for the line count: the
  lines would cover more than a quarter of the spectrum).

The test on line concentration follows the frequency analysis of quasi-periodic orbits
(Laskar's NAFF idea: a torus is a sum of discrete lines); it is a heuristic for
"chaotic-like", not a Lyapunov exponent.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from ..problem import HBMProblem, Point

__all__ = ["CONCENTRATION", "LINES", "SECTION_KINDS", "Section", "classify_section",
           "orbit_samples", "orbit_section", "periods_in", "section_coordinates",
           "section_kind_code", "windowed_lines"]

#: Relative tolerance of the period-k test (of the load's std).
PERIOD_TOL = 1e-3
#: Strongest lines of the section's spectrum counted for the quasi-periodic test.
LINES = 12
#: Half width (bins) of a line of the Hann-windowed spectrum (main lobe +-2, one margin).
LINE_HALF_WIDTH = 3
#: Fraction of the section's power the lines must hold for a quasi-periodic verdict.
CONCENTRATION = 0.99
#: Largest fraction of the spectrum's bins the counted lines may cover.
MAX_LINE_SHARE = 0.25
#: Names of the section kinds, by code (results.h5 ``/bifurcation`` and ``/attractors``).
SECTION_KINDS = ("aperiodic", "periodic", "quasi-periodic", "chaotic-like")


def periods_in(reference: HBMProblem, problem: HBMProblem) -> int:
    """Reference fundamental periods in one fundamental period of ``problem``: 1 for the
    reference itself, ``k`` for a problem whose fundamental is ``w_ref / k``.

    Raises
    ------
    ValueError
        If the ratio of the fundamentals is not a whole number.
    """
    k = Fraction(reference.harmonics.ratio) / Fraction(problem.harmonics.ratio)
    if k.denominator != 1 or k < 1:
        raise ValueError(f"Poincaré section: the problem's fundamental "
                         f"{problem.harmonics.ratio} Omega is not the reference's "
                         f"{reference.harmonics.ratio} Omega divided by a whole number")
    return int(k)


def orbit_samples(problem: HBMProblem, point: Point, periods: int = 1, element: int = 0
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Load (N) and deflection Delta (m) of element ``element`` on the orbit ``point``
    at ``t = j T / periods``, ``j = 0 … periods - 1`` (``T`` the problem's fundamental
    period): the orbit's Poincaré samples when its period holds ``periods`` reference
    periods (:func:`periods_in`).

    Evaluated at those instants only, from the point's coefficients of Delta,
    ``Delta(t) = Re sum_k c_k exp(i k w0 t)``, and the element's parameters at its phase
    ``base_ratio Omega t`` (as the time integration evaluates them): no time grid, so a
    long fundamental period (a hunting set) costs no more than a short one.
    """
    problem.require_periodic("Poincaré samples of an orbit")
    if int(periods) != periods or periods < 1:
        raise ValueError(f"periods = {periods!r}: must be an integer >= 1")
    w0 = problem.harmonics.fundamental_rad_s(point.omega)
    t = 2 * np.pi / w0 * np.arange(int(periods)) / int(periods)
    c = np.asarray(point.coefficients)[element]
    delta = (np.exp(1j * w0 * np.outer(t, np.asarray(problem.kS, dtype=float))) @ c).real
    el = problem.elements[element]
    rate = 0.0 if el.base_ratio is None else float(el.base_ratio) * point.omega
    return el.load(delta, el.sample(rate * t)), delta


def orbit_section(problem: HBMProblem, point: Point, periods: int = 1, element: int = 0
                  ) -> np.ndarray:
    """The load samples of :func:`orbit_samples` (N)."""
    return orbit_samples(problem, point, periods, element)[0]


def section_coordinates(delta: np.ndarray, delta_std: float, load: np.ndarray,
                        load_std: float) -> np.ndarray:
    """The section's samples as ``(N, 2)`` coordinates ``(Delta / std, load / std)``
    for :func:`classify_section` with scale 1: Delta first (smooth, its spectrum is the
    one tested for lines), the load beside it (a gear mesh's load is zero whenever
    contact is lost, so alone it can hide a period-2 motion that loses contact at the
    section's instants)."""
    def unit(x, s):
        x = np.asarray(x, dtype=float)
        return x / max(s, 1e-12 * float(np.max(np.abs(x), initial=0.0)), 1e-300)
    return np.column_stack([unit(delta, delta_std), unit(load, load_std)])


@dataclass(frozen=True)
class Section:
    """What a sequence of Poincaré samples says (:func:`classify_section`).

    ``kind`` one of :data:`SECTION_KINDS`; ``period`` the number of reference periods
    of a periodic response (0 otherwise); ``rotation`` the strongest line of the
    section's spectrum in cycles per reference period, folded into (0, 1/2] (NaN for a
    periodic section); ``concentration`` the share of the section's power in its
    :data:`LINES` strongest lines (NaN when not measured); ``mismatch`` the smallest
    ``max_j |x_{j+k} - x_j| / scale`` over the periods tried; ``samples`` their number.
    """

    kind: str
    period: int
    rotation: float
    concentration: float
    mismatch: float
    samples: int

    @property
    def label(self) -> str:
        """"period-1", "period-2", …, or the kind ("quasi-periodic", "chaotic-like",
        "aperiodic")."""
        return f"period-{self.period}" if self.kind == "periodic" else self.kind

    @property
    def code(self) -> int:
        """Kind code: index in :data:`SECTION_KINDS`."""
        return section_kind_code(self.kind)


def section_kind_code(kind: str) -> int:
    """Index of ``kind`` in :data:`SECTION_KINDS`."""
    return SECTION_KINDS.index(kind)


def classify_section(samples: np.ndarray, scale: float, max_period: int = 8,
                     tol: float = PERIOD_TOL) -> Section:
    """Classify a sequence of Poincaré samples (module docstring).

    Parameters
    ----------
    samples
        Section samples in time order, ``(N,)`` or ``(N, d)`` (several observables, each
        compared with ``scale``).
    scale
        Size of the response the tolerance is relative to (the load's std, N; > 0).
    max_period
        Longest period tried (reference periods).
    tol
        Relative tolerance of the period-k test.

    Raises
    ------
    ValueError
        On fewer than two samples, a non-positive ``scale`` or ``max_period`` < 1.
    """
    x = np.asarray(samples, dtype=float)
    x = x.reshape(x.shape[0], -1)
    n = x.shape[0]
    if n < 2:
        raise ValueError(f"Poincaré section of {n} samples: at least 2 are needed")
    if not scale > 0:
        raise ValueError(f"scale = {scale!r}: must be > 0")
    if max_period < 1:
        raise ValueError(f"max_period = {max_period}: must be >= 1")
    best = math.inf
    for k in range(1, min(max_period, n - 1) + 1):
        d = float(np.max(np.abs(x[k:] - x[:-k]))) / scale
        best = min(best, d)
        if d <= tol:
            return Section("periodic", k, math.nan, math.nan, d, n)
    rotation, conc = _lines(x[:, 0])
    if math.isnan(conc):
        return Section("aperiodic", 0, rotation, conc, best, n)
    kind = "quasi-periodic" if conc >= CONCENTRATION else "chaotic-like"
    return Section(kind, 0, rotation, conc, best, n)


def _lines(x: np.ndarray) -> tuple[float, float]:
    """Strongest line of the section's Hann-windowed spectrum (cycles per sample, in
    (0, 1/2]; parabolic interpolation of the log power) and the share of the power in
    the :data:`LINES` strongest lines (NaN when they would cover more than
    :data:`MAX_LINE_SHARE` of the bins)."""
    n = x.size
    p = np.abs(np.fft.rfft((x - x.mean()) * np.hanning(n))) ** 2
    p[0] = 0.0
    total = float(p.sum())
    if total <= 0.0:
        return math.nan, math.nan
    j = int(np.argmax(p))
    rotation = (j + _vertex(p, j)) / n
    if LINES * (2 * LINE_HALF_WIDTH + 1) > MAX_LINE_SHARE * p.size:
        return rotation, math.nan
    left, held = p.copy(), 0.0
    for _ in range(LINES):
        i = int(np.argmax(left))
        lo, hi = max(i - LINE_HALF_WIDTH, 0), min(i + LINE_HALF_WIDTH + 1, left.size)
        held += float(left[lo:hi].sum())
        left[lo:hi] = 0.0
    return rotation, held / total


def _vertex(p: np.ndarray, j: int) -> float:
    """Offset (bins, within +-1/2) of the vertex of the parabola through the log power
    around bin ``j``."""
    if j < 1 or j >= p.size - 1 or min(p[j - 1], p[j + 1]) <= 0:
        return 0.0
    a, b, c = np.log(p[j - 1]), np.log(p[j]), np.log(p[j + 1])
    den = a - 2 * b + c
    return float(np.clip(0.5 * (a - c) / den, -0.5, 0.5)) if den < 0 else 0.0


def windowed_lines(signal: np.ndarray, samples_per_unit: float, n_lines: int = 12
                   ) -> list[tuple[float, float]]:
    """The ``n_lines`` strongest lines of a sampled signal, leakage-proof: Hann window,
    each line's frequency from the parabola through the log power around its peak and
    its amplitude from the power of its :data:`LINE_HALF_WIDTH` bins either side
    (Parseval: a sinusoid ``A cos(2 pi f t)`` gives ``A`` whatever ``f`` between bins).

    Frequencies in cycles per unit (``samples_per_unit`` samples per unit: per shaft
    turn, shaft orders), amplitudes in the signal's unit; strongest first.
    """
    x = np.asarray(signal, dtype=float)
    n = x.size
    w = np.hanning(n)
    p = np.abs(np.fft.rfft((x - x.mean()) * w)) ** 2
    p[0] = 0.0
    norm = n * float(np.sum(w ** 2)) / 4.0       # one-sided power of a unit sinusoid
    left, out = p.copy(), []
    for _ in range(min(n_lines, p.size)):
        i = int(np.argmax(left))
        if left[i] <= 0.0:
            break
        lo, hi = max(i - LINE_HALF_WIDTH, 0), min(i + LINE_HALF_WIDTH + 1, left.size)
        out.append(((i + _vertex(p, i)) * samples_per_unit / n,
                    math.sqrt(float(left[lo:hi].sum()) / norm)))
        left[lo:hi] = 0.0
    return out
