"""A verdict checked on a richer harmonic set: does it hold when the orbit is resolved
better?

Near the top of a resonance where contact is lost over a large share of the period, and
in the near-grazing tangles (:mod:`hbm.post.tangles`), the orbit of a harmonic set that
is converged elsewhere can still be a few per cent off, and the sign of a weak Floquet
exponent with it: on the shipped pump at 1383.133 rpm the 12/3 set's orbit is stable
(-7.3 1/s, converged in the monodromy's steps) while the 16/3 orbit at the same speed,
4.6 % away in its coefficients, is unstable (+46.6 1/s) — and a time integration from
the 12/3 orbit leaves it within one shaft turn (docs/theory.md §11, "Verdicts on a
richer set").

:func:`recheck_verdicts` solves the points again at their speeds on a richer problem
(the same machine with more harmonics), from the point padded with zeros, and takes the
verdict there (:func:`hbm.stability.stability`): a verdict that differs is the richer
set's, with how far the orbit moved. Newton only, no homotopy: a start that does not
converge, or converges to an orbit farther than ``max_change`` away, is not a recheck
of the same orbit and is reported as such.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from ..basis import embed_coefficients, index_positions
from ..newton import ConvergenceError, newton
from ..problem import HBMProblem, Point
from ..units import RPM_TO_RAD_S
from .verdict import stability

logger = logging.getLogger(__name__)

__all__ = ["MAX_CHANGE", "NEIGHBOURS", "VerdictCheck", "recheck_candidates",
           "recheck_verdicts", "richer_mesh_harmonics"]

#: Largest relative change of the orbit's coefficients for the richer solution to count
#: as the same orbit resolved better (beyond it Newton went to another sheet).
MAX_CHANGE = 0.25
#: Points on each side of a near-grazing tangle whose stable verdicts are rechecked (on the
#: pump the stable points the time integration leaves lie 3-7 points past the tangle).
NEIGHBOURS = 10


def richer_mesh_harmonics(n: int) -> int:
    """Mesh harmonics of the richer set: a third more, at least one more (12 -> 16)."""
    return max(int(n) + 1, -(-4 * int(n) // 3))


def recheck_candidates(stable: np.ndarray, consistent: np.ndarray, grazing: np.ndarray,
                       tangles, neighbours: int = NEIGHBOURS) -> np.ndarray:
    """Points whose verdict is checked on the richer set: the stable points inside a
    near-grazing tangle (:class:`hbm.post.tangles.Tangle`: ``first``, ``last``) or within
    ``neighbours`` points of one, and every point whose verdict is already in doubt
    (fold parity against the variational equation, ``consistent`` False; unresolved near
    grazing, ``grazing`` True). Sorted indices."""
    stable = np.asarray(stable, dtype=bool)
    n = stable.size
    near = np.zeros(n, dtype=bool)
    for t in tangles:
        near[max(t.first - neighbours, 0):min(t.last + neighbours, n - 1) + 1] = True
    doubt = ~np.asarray(consistent, dtype=bool) | np.asarray(grazing, dtype=bool)
    return np.flatnonzero((near & stable) | doubt)


@dataclass(frozen=True)
class VerdictCheck:
    """The verdict of one point of a branch on the richer harmonic set.

    Attributes
    ----------
    index, rpm
        The point of the branch and its speed (rpm).
    stable
        Verdict on the richer set (meaningful when ``same_orbit``).
    kind
        Index in :data:`hbm.stability.KINDS` of that verdict (-1 when not computed).
    max_real
        Largest real part of its Floquet exponents on the richer set (1/s; NaN when not
        computed).
    change
        Relative change of the elements' deflection coefficients on the harmonics both
        sets share (L2, against the point's own non-constant part); NaN when Newton
        failed.
    same_orbit
        Newton converged within ``max_change`` of the point: the recheck is of the same
        orbit.
    """

    index: int
    rpm: float
    stable: bool
    kind: int
    max_real: float
    change: float
    same_orbit: bool


def _change(u_source: np.ndarray, u_target: np.ndarray, source: HBMProblem,
            target: HBMProblem) -> float:
    """Relative L2 change of the deflections' coefficients on the harmonics of ``source``
    (all of them in ``target``), against the non-constant part of ``u_source``'s."""
    cs = source.harmonics.to_complex(source.delta_real(u_source))
    ct = target.harmonics.to_complex(target.delta_real(u_target))
    ct = ct[:, index_positions(source.harmonics, target.harmonics)]
    scale = float(np.linalg.norm(cs[:, 1:]))
    return float(np.linalg.norm(ct - cs) / scale) if scale > 0 else float("nan")


def recheck_verdicts(problem: HBMProblem, richer: HBMProblem, rpm: np.ndarray,
                     unknowns: np.ndarray, indices, tol: float = 1e-8,
                     max_change: float = MAX_CHANGE, max_iter: int = 30
                     ) -> list[VerdictCheck]:
    """Verdicts of the points ``indices`` of a branch (``rpm``, ``unknowns`` of
    ``problem``) on the ``richer`` problem; see the module.

    Parameters
    ----------
    problem, richer
        The branch's problem and the same machine on a richer harmonic set.
    rpm, unknowns
        The branch's speeds (rpm) and unknowns (n_points, problem.n_unknowns).
    indices
        The points to check.
    tol, max_iter
        Newton's relative tolerance and iterations on the richer set.
    max_change
        Largest relative change of the orbit that still counts as the same orbit.
    """
    richer.require_periodic("a verdict on a richer harmonic set")
    out: list[VerdictCheck] = []
    for i in indices:
        i = int(i)
        u = np.asarray(unknowns[i], dtype=float)
        omega = float(rpm[i]) * RPM_TO_RAD_S
        x0 = embed_coefficients(u.reshape(-1, problem.nr), problem.harmonics,
                                richer.harmonics).ravel()
        try:
            xh, it, res = newton(lambda x, j=True, w=omega: richer.scaled(x, w, j),
                                 x0 / richer.x_scale, tol, max_iter, line_search=True)
        except ConvergenceError as exc:
            logger.info("verdict recheck at %.4f rpm: Newton on the richer set failed (%s)",
                        rpm[i], exc)
            out.append(VerdictCheck(i, float(rpm[i]), False, -1, float("nan"),
                                    float("nan"), False))
            continue
        pt: Point = richer.point(xh * richer.x_scale, omega, it, res)
        change = _change(u, pt.unknowns, problem, richer)
        if not change <= max_change:
            logger.info("verdict recheck at %.4f rpm: the richer set converged %.3g away "
                        "(another orbit)", rpm[i], change)
            out.append(VerdictCheck(i, float(rpm[i]), False, -1, float("nan"), change,
                                    False))
            continue
        st = stability(richer, pt)
        out.append(VerdictCheck(i, float(rpm[i]), st.kind == "stable", st.code,
                                float(st.max_real), change, True))
    return out
