"""Verdicts near grazing: how much a Floquet verdict depends on the orbit's distance to a
contact switch.

The dead-zone force of eq. (13) is continuous, its stiffness is not. Where an orbit
nearly grazes a flank (the gap comes within a distance ``d`` of the backlash), an orbit
change ``eps`` opens or closes a contact interval of length ``~ sqrt(eps / |p''|)``: the
variational equation (T.10) changes by ``k_m sqrt(eps)``, not ``O(eps)`` (the square-root
singularity of the discontinuity map of a flow with a discontinuous Jacobian, di
Bernardo et al., *Piecewise-smooth Dynamical Systems*, 2008, §7.4: the correction of order
3/2 whose derivative is of order 1/2). An HBM orbit is only as good as its harmonic set
(errors of 1e-5 to 2e-4 of the orbit on the shipped pump against a time integration), so
within that distance of grazing the monodromy of the HBM orbit may not be the one of the
orbit the machine follows, and near a fold the sign of the leading exponent may flip.

:func:`grazing_sensitivity` measures it: the deflections of every element shifted by
``+- eps_e`` (:func:`orbit_shift`: the orbit's truncation error estimated from its highest
harmonics, at least ``rtol`` times the peak-to-peak of ``Delta_e``); when that opens or
closes a contact interval (:func:`contact_runs` of the step stiffness of
:func:`hbm.stability.monodromy.step_stiffness` changes; a transversal switch moving by
``eps / |p'|`` does not) the leading exponent is computed again on both shifted orbits
(same steps, warm-started). The verdict is *unresolved near
grazing* when their signs differ from the nominal one.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from ..problem import HBMProblem, Point
from .monodromy import (
    MonodromyResult,
    dominant_multipliers,
    floquet_from_multipliers,
    orbit_deltas,
    period_map,
    step_stiffness,
)

logger = logging.getLogger(__name__)

__all__ = ["GRAZING_RTOL", "TAIL_FACTOR", "GrazingSensitivity", "contact_runs",
           "grazing_sensitivity", "orbit_shift", "shifted_deltas"]

#: Smallest orbit shift, relative to the peak-to-peak of each element's deflection (the
#: HBM orbit errors measured on the shipped pump against time integration: 1e-5 to 2e-4).
GRAZING_RTOL = 1e-5
#: The shift is at least this many times the amplitudes of the two highest harmonics of
#: the deflection (the truncation error of the orbit is of their order: on the SDOF gear
#: pair with 16 mesh harmonics, 7.3e-9 m against the time integration's orbit, top two
#: harmonics 6.1e-9 m). Near a fold at grazing the speed error of the fold matters too:
#: with 8 mesh harmonics the two "stable" points the time integration leaves (1791.08,
#: 1791.16 rpm, the fold is at 1791.24) are flagged from a factor 10 (3: one of them).
TAIL_FACTOR = 10.0


@dataclass(frozen=True)
class GrazingSensitivity:
    """The leading Floquet real part of the orbit shifted by ``+- eps``
    (:func:`grazing_sensitivity`).

    Attributes
    ----------
    near
        The shift opens or closes a contact interval (the orbit is within ``eps`` of
        grazing); False: nothing computed, ``shifted`` empty.
    shifted
        Largest real part (1/s) of the exponents of the orbit shifted by ``+eps`` and
        ``-eps`` (empty when not ``near``).
    eps
        The shift per element (m).
    """

    near: bool
    shifted: tuple[float, ...]
    eps: np.ndarray

    def unresolved(self, max_real: float, tiny: float) -> bool:
        """True when a shifted orbit's verdict differs from ``max_real``'s."""
        nominal = max_real > tiny
        return any((m > tiny) != nominal for m in self.shifted if np.isfinite(m))


def orbit_shift(problem: HBMProblem, point: Point, deltas: np.ndarray,
                rtol: float = GRAZING_RTOL) -> np.ndarray:
    """The shift ``eps_e`` (m) of each element's deflection that the verdict should
    survive: ``max(rtol * ptp(Delta_e), TAIL_FACTOR * (|c_e,K-1| + |c_e,K|))``, ``K`` the
    highest harmonic index of the set (an estimate of the orbit's truncation error)."""
    coef = np.atleast_2d(point.coefficients)                  # (E, nS) complex, m
    tail = np.sum(np.abs(coef[:, -2:]), axis=-1) if coef.shape[-1] > 2 else \
        np.zeros(coef.shape[0])
    return np.maximum(rtol * np.ptp(deltas, axis=-1), TAIL_FACTOR * tail)


def shifted_deltas(deltas: np.ndarray, eps: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(deltas + eps, deltas - eps)``, ``eps`` (m) per element."""
    return deltas + eps[:, None], deltas - eps[:, None]


def contact_runs(jbar: np.ndarray) -> np.ndarray:
    """Per element, the number of runs (cyclic) of steps at the element's lowest step
    stiffness along the orbit (a gear mesh: the steps wholly in the backlash, ``-k_bar``),
    (E,). A contact switch that moves keeps it; a contact interval that opens or closes
    (grazing) changes it. Zero for an element without such steps."""
    lo = np.min(jbar, axis=-1, keepdims=True)
    span = np.maximum(np.ptp(jbar, axis=-1, keepdims=True), 1e-300)
    at = jbar <= lo + 1e-12 * span
    starts = at & ~np.roll(at, 1, axis=-1)
    runs = np.sum(starts, axis=-1)
    return np.where(np.all(at, axis=-1) | (span[:, 0] <= 1e-300), 0, runs)


def grazing_sensitivity(problem: HBMProblem, point: Point, res: MonodromyResult,
                        rtol: float = GRAZING_RTOL) -> GrazingSensitivity:
    """Largest Floquet real part of the orbit shifted by ``+- eps`` (:func:`orbit_shift`),
    when the shift opens or closes a contact interval (see the module).

    ``res``: the monodromy of the unshifted orbit (its step count and basis are reused).
    """
    n = res.n_steps
    deltas = orbit_deltas(problem, point.unknowns, n)
    eps = orbit_shift(problem, point, deltas, rtol)
    plus, minus = shifted_deltas(deltas, eps)
    counts = [contact_runs(step_stiffness(problem, d)) for d in (deltas, plus, minus)]
    if np.array_equal(counts[0], counts[1]) and np.array_equal(counts[0], counts[2]):
        return GrazingSensitivity(False, (), eps)
    period = 2 * np.pi / problem.harmonics.fundamental_rad_s(point.omega)
    size = 2 * (int(np.sum(~problem.rigid)) if problem.modal else problem.n_dof)
    rng = np.random.default_rng(12345)
    out = []
    for d in (plus, minus):
        with np.errstate(over="ignore", invalid="ignore"):
            try:
                mu, _, _ = dominant_multipliers(period_map(problem, d, period), size,
                                                res.columns, 1e-8, res.basis, rng)
                out.append(float(floquet_from_multipliers(mu, period)[0].real))
            except np.linalg.LinAlgError:
                out.append(float("nan"))
    logger.debug("%.4f rpm: near grazing (a contact interval changes under +-%s m); "
                 "largest real part %.4g 1/s, shifted %s", point.rpm, eps, res.max_real, out)
    return GrazingSensitivity(True, tuple(out), eps)
