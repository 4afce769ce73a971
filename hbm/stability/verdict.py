"""Stability of periodic solutions: the verdict of a point.

:func:`stability` is what the continuation calls: the Floquet exponents of the
variational equation (T.10, :mod:`hbm.stability.monodromy`, every mode, no harmonic
truncation of the perturbation), checked against the exact parity of the real
positive exponents of the harmonic balance itself (T.9,
:mod:`hbm.stability.exponents`): a point between two folds of the HBM branch has
``det T(0) < 0``. When the two disagree the harmonic set does not resolve the orbit
there (the flag is kept per point); the verdict then follows the branch (unstable, with
the exact real root of T.9 as its exponent), so a segment between two folds is never
reported stable. Hill's method stays for comparisons (:mod:`hbm.stability.hill`).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from ..problem import HBMProblem, Point
from .exponents import classify_exponent, det_sign, line_of_action_operator, positive_real_root
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
        Largest real part of the Floquet exponents (1/s); > 0 is unstable.
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
    """

    max_real: float
    exponents: np.ndarray
    kind: str
    fold_parity: bool
    consistent: bool
    error: float
    basis: np.ndarray | None = None

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

    @classmethod
    def of(cls, stab: Stability) -> Verdict:
        """The verdict of a :class:`Stability`."""
        return cls(float(stab.max_real), int(stab.code), bool(stab.consistent),
                   stab.kind == "stable")


def stability(problem: HBMProblem, point: Point, start: np.ndarray | None = None,
              parity: bool | None = None) -> Stability:
    """Floquet exponents (T.10) and the fold parity (T.9) of a solution; see the module.

    ``start``: :attr:`Stability.basis` of a neighbouring point (faster, same result).
    ``parity``: ``det T(0) < 0`` when the caller knows it (the continuation does, from
    the sign of its tangent's speed component, T.9a in docs/theory.md); else it is
    computed from the dense ``T(0)`` (an LU of the harmonic-balance size).
    """
    problem.require_periodic("Floquet stability")
    res = monodromy_exponents(problem, point, start=start)
    w0 = problem.harmonics.fundamental_rad_s(point.omega)
    exps, max_real = res.exponents, res.max_real
    jf = None
    if not problem.modal:
        parity = False
    elif parity is None:
        jf = problem.element_jacobian(problem.delta_real(point.unknowns))
        parity = det_sign(line_of_action_operator(problem, jf, 0.0, w0).real) < 0
    consistent = not parity or max_real > 0
    if not consistent:
        if jf is None:
            jf = problem.element_jacobian(problem.delta_real(point.unknowns))
        root = positive_real_root(problem, jf, w0)
        if np.isnan(root):
            # the branch puts the point between two folds (the tangent, T.9a) but the
            # computed det T(0) >= 0: the point lies within round-off of a fold, whose
            # real exponent is below what T(0) resolves; reported as that fold, 0 1/s
            logger.debug("%.2f rpm: between two folds by the tangent but det T(0) >= 0; "
                         "real exponent taken as 0 (variational equation: max Re %.4g "
                         "1/s)", point.rpm, max_real)
            root = 0.0
        else:
            logger.debug("%.2f rpm: between two folds (T.9 root %.4g 1/s) but the "
                         "variational equation has max Re %.4g 1/s", point.rpm, root,
                         max_real)
        exps = np.concatenate([[complex(root, 0.0)], exps])
        max_real = float(root)
    # round-off of the multipliers (|mu| = 1 +- 1e-15 for a rigid mode) is not growth
    w_top = float(np.sqrt(np.max(np.abs(problem.w2))))
    tiny = 1e-9 * (w0 + w_top)
    stable = max_real <= tiny and consistent          # between two folds: never stable
    kind = "stable" if stable else classify_exponent(complex(exps[0]), w0)
    return Stability(max_real, exps, kind, bool(parity), bool(consistent), res.error, res.basis)


def loss_of_stability(problem: HBMProblem, point: Point) -> str:
    """``"stable"`` or the kind of the exponent of largest real part:
    ``"fold"``, ``"period_doubling"`` or ``"neimark_sacker"`` (see classify_exponent)."""
    return stability(problem, point).kind
