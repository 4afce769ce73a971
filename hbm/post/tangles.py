"""Near-grazing tangles of a branch: clusters of folds within a sliver of speed.

On the steep flank of a resonance the contact pattern of a gear mesh can change one
mesh cycle at a time: over a fundamental period of ``Z`` mesh cycles (the shaft
orders of unbalance, aerodynamic forces or a train's hunting period make the cycles
differ slightly), each cycle in turn gains or loses a contact-loss interval. Every
such change is a grazing of the periodic orbit (the force is only ``C^1`` in the
orbit there, its Jacobian has a square-root singularity), and where the branch is
nearly vertical in speed each of them can turn it: the branch makes many folds within
a fraction of an rpm and the Floquet multipliers cross the unit circle at each
(docs/theory.md §11, "Near-grazing tangles"). On the shipped pump's tangle at 1391.2 rpm
the folds are a property of the equations, not of the discretisation: four times the AFT
grid or 16 instead of 12 mesh harmonics move them by at most 0.004 rpm, while they lie
0.013-0.036 rpm apart. At the top of the resonance (1383.0-1383.2 rpm, no change of the
contact-loss count) the 12/3 orbit is 3-5 % off the 16/3 one and weak verdicts flip
with it, which :mod:`hbm.stability.recheck` checks. :func:`find_tangles` marks the
tangles so the report can say where the branch winds.

A *tangle* is a run of three or more consecutive folds of the branch (speed reversals
of the trace) whose speeds all lie within ``rel_width`` of their mean (0.1 % by
default: a regular resonance has two folds several rpm apart, the pump's tangles 7-20
folds within 0.04-1.7 rpm). Its points are those from one point before its first fold
to one point after its last.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["REL_WIDTH", "MIN_FOLDS", "Tangle", "branch_tangles", "find_tangles",
           "turning_points"]

#: Largest speed spread of a tangle's folds, relative to their mean speed.
REL_WIDTH = 1e-3
#: Fewest folds that make a tangle (a resonance's hysteresis has two).
MIN_FOLDS = 3


@dataclass(frozen=True)
class Tangle:
    """One near-grazing tangle of a branch.

    Attributes
    ----------
    first, last
        Indices of its first and last point (inclusive).
    rpm_min, rpm_max
        Speed range of its points (rpm).
    n_folds
        Folds (speed reversals) inside.
    n_stable
        Points inside reported stable.
    contact_changes
        Change of the contact-loss count over the tangle (its largest minus its smallest
        number of contact-loss intervals per fundamental period, summed over the
        elements); 0 when the branch has no such statistic.
    """

    first: int
    last: int
    rpm_min: float
    rpm_max: float
    n_folds: int
    n_stable: int
    contact_changes: int

    @property
    def points(self) -> np.ndarray:
        """Indices of its points."""
        return np.arange(self.first, self.last + 1)


def turning_points(rpm: np.ndarray) -> np.ndarray:
    """Indices where the speed of a trace reverses (a zero step keeps the direction)."""
    rpm = np.asarray(rpm, dtype=float)
    if rpm.size < 3:
        return np.zeros(0, dtype=np.int64)
    d = np.sign(np.diff(rpm))
    for i in range(1, d.size):
        if d[i] == 0:
            d[i] = d[i - 1]
    return np.where(d[1:] * d[:-1] < 0)[0] + 1


def find_tangles(rpm: np.ndarray, stable: np.ndarray, losses: np.ndarray | None = None,
                 rel_width: float = REL_WIDTH, min_folds: int = MIN_FOLDS) -> list[Tangle]:
    """The near-grazing tangles of a branch (see the module).

    Parameters
    ----------
    rpm, stable
        Speed (rpm) and stability of each point, in the order traced.
    losses
        Contact-loss intervals per fundamental period of each point (summed over the
        elements, ``impacts_per_mesh_period`` times the mesh periods in the fundamental
        period); None when unknown.
    rel_width, min_folds
        The definition of a tangle: at least ``min_folds`` consecutive folds whose
        speeds lie within ``rel_width`` of their mean.
    """
    if not 0 < rel_width < 1:
        raise ValueError(f"rel_width = {rel_width}: must be in (0, 1)")
    if min_folds < 2:
        raise ValueError(f"min_folds = {min_folds}: must be >= 2")
    rpm = np.asarray(rpm, dtype=float)
    stable = np.asarray(stable, dtype=bool)
    turns = turning_points(rpm)
    out: list[Tangle] = []
    k = 0
    while k < turns.size:
        j = k
        # grow the run while every fold stays within rel_width of the run's mean speed
        while j + 1 < turns.size:
            s = rpm[turns[k:j + 2]]
            if s.max() - s.min() > rel_width * s.mean():
                break
            j += 1
        if j - k + 1 >= min_folds:
            first = max(int(turns[k]) - 1, 0)
            last = min(int(turns[j]) + 1, rpm.size - 1)
            sel = slice(first, last + 1)
            changes = 0
            if losses is not None:
                lv = np.asarray(losses, dtype=float)[sel]
                lv = lv[np.isfinite(lv)]
                changes = int(round(lv.max() - lv.min())) if lv.size else 0
            out.append(Tangle(first, last, float(rpm[sel].min()), float(rpm[sel].max()),
                              j - k + 1, int(stable[sel].sum()), changes))
            k = j + 1
        else:
            k += 1
    return out


def branch_tangles(branch) -> list[Tangle]:
    """The near-grazing tangles of a :class:`hbm.Branch` (:func:`find_tangles`), with the
    contact-loss intervals per fundamental period summed over its elements (their ``ipp``
    sequences; padding entries -1 count 0)."""
    ipp = branch.stats.get("ipp")
    losses = None
    if ipp is not None and np.size(ipp):
        a = np.asarray(ipp).reshape(len(branch), -1)
        losses = np.where(a >= 0, a, 0).sum(axis=1).astype(float)
    return find_tangles(branch.rpm, branch.stable, losses)
