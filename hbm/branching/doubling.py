"""The period-2 problem of a periodic HBM problem: the fundamental halved, the set holding
the half orders, and the embedding of a period-1 solution into it.

A response of period ``2T`` (``T = 2 pi / w0``) is a Fourier series of ``w0 / 2``: the
harmonics ``k w0`` of the period-1 set become the even indices ``2k`` of the doubled set,
and the Floquet eigenfunction of the multiplier -1, ``p(t) e^{i w0 t / 2}`` with ``p``
``T``-periodic (docs/theory.md, T.50), lives on the odd indices ``2k +- 1`` (the half
orders). A ``T``-periodic solution is a solution of the doubled problem with every odd
coefficient zero; the harmonic-balance Jacobian there does not couple even and odd
indices (shifting time by ``T`` flips the sign of the odd coefficients and leaves the
equations unchanged), and its odd block is Hill's operator at the exponent ``i w0 / 2``.
"""

from __future__ import annotations

import numpy as np

from ..basis import HarmonicSet, embed_coefficients
from ..problem import HBMProblem

__all__ = ["doubled_problem", "doubled_set", "embed", "odd_mask"]


def doubled_set(hs: HarmonicSet) -> HarmonicSet:
    """The harmonic set of fundamental ``hs.ratio / 2``: the indices ``2k`` of ``hs`` (the
    same frequencies) and the half orders ``2k +- 1`` around each of them, on twice the
    AFT samples (the same samples per period of ``hs``, so that an embedded period-1
    solution stays a solution to the last bit of the FFT).

    Refused for a torus basis (the period of a quasi-periodic response is not defined).
    """
    if not isinstance(hs, HarmonicSet):
        raise ValueError(f"doubled_set: harmonics = {type(hs).__name__}: period doubling "
                         "needs a periodic basis (a HarmonicSet)")
    even = {2 * k for k in hs.indices}
    odd = {abs(2 * k + s) for k in hs.indices for s in (1, -1)}
    return HarmonicSet(sorted(even | odd), ratio=hs.ratio / 2,
                       fundamental=f"{hs.fundamental}/2", n_time=2 * hs.n_time)


def doubled_problem(problem: HBMProblem, linear_solver: str = "auto") -> HBMProblem:
    """The same equations on :func:`doubled_set` of ``problem``'s harmonics (its system,
    elements, excitation, condensation and AFT kind)."""
    return HBMProblem(problem.system, list(problem.elements), problem.excitation,
                      doubled_set(problem.harmonics), problem.condensation,
                      linear_solver=linear_solver, aft=problem.aft)


def embed(parent: HBMProblem, child: HBMProblem, unknowns: np.ndarray) -> np.ndarray:
    """Unknowns of ``parent`` (real layout, signal-major: every condensation stores one
    ``n_real`` block per signal) as unknowns of ``child``, whose fundamental divides
    ``parent``'s: each coefficient moved to the index of its frequency, the others 0."""
    u = np.asarray(unknowns, dtype=float).reshape(-1, parent.harmonics.n_real)
    v = embed_coefficients(u, parent.harmonics, child.harmonics).ravel()
    if v.size != child.n_unknowns:
        raise ValueError(f"embed: {v.size} unknowns for a child problem of "
                         f"{child.n_unknowns}")
    return v


def odd_mask(problem: HBMProblem) -> np.ndarray:
    """Mask of ``problem``'s unknowns on odd indices (the half orders of a doubled set)."""
    k = np.asarray(problem.harmonics.indices)
    per = np.concatenate([[False], np.repeat(k[1:] % 2 == 1, 2)])
    return np.tile(per, problem.n_unknowns // per.size)
