"""Stability of periodic solutions: the verdict of a point.

:func:`stability` is what the continuation calls: the Floquet exponents of the
variational equation (T.10, :mod:`hbm.stability.monodromy`, every mode, no harmonic
truncation of the perturbation), checked against the exact parity of the real
positive exponents of the harmonic balance itself (T.9,
:mod:`hbm.stability.exponents`): a point between two folds of the HBM branch has
``det T(0) < 0``. When the two disagree the harmonic set does not resolve the orbit
there (the flag is kept per point); the verdict then follows the branch (unstable, with
the exact real root of T.9 as its exponent, NaN when no root is bracketed: never a number
that was not computed), so a segment between two folds is not reported stable — except
near grazing. Hill's method stays for comparisons (:mod:`hbm.stability.hill`).

Near grazing (:mod:`hbm.stability.grazing`) the monodromy depends on the orbit like the
square root of its distance to the contact switch; the leading exponent is computed
again on the orbit shifted by a relative ``grazing_rtol`` and the verdict flagged
*unresolved near grazing* when that changes its sign. There the fold parity of the
harmonic balance (its Jacobian resolves a grazing contact interval only on the AFT grid)
does not overrule the variational equation: the verdict is T.10's, flagged.

Beside the exponents: the transient amplification over one period (the largest singular
value of the monodromy in the energy norm), large where the monodromy is non-normal.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from ..problem import HBMProblem, Point
from .exponents import classify_exponent, det_sign, line_of_action_operator, positive_real_root
from .grazing import GRAZING_RTOL, grazing_sensitivity
from .monodromy import monodromy_exponents

logger = logging.getLogger(__name__)

__all__ = ["KINDS", "Stability", "Verdict", "loss_of_stability", "stability"]

#: Kinds of a point's stability, in the order of the codes stored per point.
KINDS = ("stable", "fold", "period_doubling", "neimark_sacker")


@dataclass(frozen=True)
class Stability:
    """Stability of one periodic solution.

    Attributes
    ----------
    max_real
        Largest real part of the Floquet exponents (1/s); > 0 is unstable. NaN when the
        point lies between two folds (T.9) but neither (T.10) nor the root search of
        T.9 finds a positive exponent (not computed: see :func:`stability`).
    exponents
        Exponents (1/s) by decreasing real part, ``|Im| <= w0 / 2``.
    kind
        One of :data:`KINDS`: ``"stable"``, or how the leading exponent leaves the
        unit circle (multiplier +1: ``"fold"``, -1: ``"period_doubling"``, complex:
        ``"neimark_sacker"``).
    fold_parity
        ``det T(0) < 0`` (T.9): an odd number of real positive exponents of the
        harmonic balance, i.e. the point lies between two folds of the branch
        (modal damping only; False otherwise).
    consistent
        False when ``fold_parity`` holds but the variational equation finds no
        exponent with a positive real part: the harmonic set does not resolve the
        orbit there.
    error
        Estimated error of ``max_real`` from the time step (1/s).
    basis
        Dominant subspace of the monodromy (see :class:`hbm.stability.monodromy.MonodromyResult`).
    amplification
        Transient amplification over one period (largest singular value of the
        monodromy in the energy norm; a lower bound from the dominant subspace for a
        large model, :class:`hbm.stability.monodromy.MonodromyResult`).
    grazing
        The verdict is unresolved near grazing: the orbit shifted by ``grazing_rtol``
        (:mod:`hbm.stability.grazing`) has a verdict of the other sign, or the fold
        parity contradicts (T.10) at an orbit that near grazing.
    """

    max_real: float
    exponents: np.ndarray
    kind: str
    fold_parity: bool
    consistent: bool
    error: float
    basis: np.ndarray | None = None
    amplification: float = float("nan")
    grazing: bool = False

    @property
    def code(self) -> int:
        """Index of ``kind`` in :data:`KINDS`."""
        return KINDS.index(self.kind)


@dataclass(frozen=True)
class Verdict:
    """What a branch keeps of a point's stability (:class:`Stability`)."""

    max_real: float
    code: int
    consistent: bool
    stable: bool
    amplification: float = float("nan")
    grazing: bool = False

    @classmethod
    def of(cls, stab: Stability) -> Verdict:
        """The verdict of a :class:`Stability`."""
        return cls(float(stab.max_real), int(stab.code), bool(stab.consistent),
                   stab.kind == "stable", float(stab.amplification), bool(stab.grazing))


def stability(problem: HBMProblem, point: Point, start: np.ndarray | None = None,
              parity: bool | None = None, grazing_rtol: float = GRAZING_RTOL) -> Stability:
    """Floquet exponents (T.10) and the fold parity (T.9) of a solution; see the module.

    ``start``: :attr:`Stability.basis` of a neighbouring point (faster, same result).
    ``parity``: ``det T(0) < 0`` when the caller knows it (the continuation does, from
    the sign of its tangent's speed component, T.9a in docs/theory.md); else it is
    computed from the dense ``T(0)`` (an LU of the harmonic-balance size).
    ``grazing_rtol``: the orbit shift of the test near grazing, relative to each
    element's peak-to-peak deflection (:mod:`hbm.stability.grazing`; 0 switches it off).
    """
    problem.require_periodic("Floquet stability")
    res = monodromy_exponents(problem, point, start=start)
    w0 = problem.harmonics.fundamental_rad_s(point.omega)
    exps, max_real = res.exponents, res.max_real
    # round-off of the multipliers (|mu| = 1 +- 1e-15 for a rigid mode) is not growth
    w_top = float(np.sqrt(np.max(np.abs(problem.w2))))
    tiny = 1e-9 * (w0 + w_top)
    near = grazing_sensitivity(problem, point, res, grazing_rtol) if grazing_rtol > 0 \
        else None
    unresolved = near is not None and near.unresolved(max_real, tiny)
    jf = None
    if not problem.modal:
        parity = False
    elif parity is None:
        jf = problem.element_jacobian(problem.delta_real(point.unknowns))
        parity = det_sign(line_of_action_operator(problem, jf, 0.0, w0).real) < 0
    consistent = not parity or max_real > 0
    kind = None
    if not consistent and near is not None and near.near:
        # near grazing the parity of the harmonic balance (its AFT Jacobian) and the
        # variational equation may both be off: flagged; the branch still decides (below)
        logger.debug("%.4f rpm: between two folds by T.9 but T.10 finds max Re %.4g 1/s, "
                     "near grazing: unresolved", point.rpm, max_real)
        unresolved = True
    if not consistent:
        if jf is None:
            jf = problem.element_jacobian(problem.delta_real(point.unknowns))
        root = positive_real_root(problem, jf, w0)
        if np.isnan(root):
            # the branch puts the point between two folds (the tangent, T.9a) but the
            # computed det T(0) >= 0: the point lies within round-off of a fold, whose
            # real exponent is below what T(0) resolves. A fold, unstable by the branch;
            # its exponent was not computed: NaN
            logger.debug("%.2f rpm: between two folds by the tangent but det T(0) >= 0; "
                         "real exponent not resolved, NaN (variational equation: max Re "
                         "%.4g 1/s)", point.rpm, max_real)
            kind = "fold"
        else:
            logger.debug("%.2f rpm: between two folds (T.9 root %.4g 1/s) but the "
                         "variational equation has max Re %.4g 1/s", point.rpm, root,
                         max_real)
            exps = np.concatenate([[complex(root, 0.0)], exps])
        max_real = float(root)
    # between two folds: never stable
    stable = max_real <= tiny and consistent
    if kind is None:
        kind = "stable" if stable else classify_exponent(complex(exps[0]), w0)
    return Stability(max_real, exps, kind, bool(parity), bool(consistent), res.error,
                     res.basis, res.amplification, bool(unresolved))


def loss_of_stability(problem: HBMProblem, point: Point) -> str:
    """``"stable"`` or the kind of the exponent of largest real part:
    ``"fold"``, ``"period_doubling"`` or ``"neimark_sacker"`` (see classify_exponent)."""
    return stability(problem, point).kind
