"""Secondary branches born at period doublings, to a set depth: the period-2 branches of
a traced branch, their own period-4 branches, and so on (docs/theory.md §15).

Each is traced by :func:`hbm.continuation.continue_branch` on the doubled problem with
the same monitor as the main branch (statistics over the doubled period, grazing, folds,
Floquet stability over the doubled period) from its first point away from the period
doubling, until it rejoins its parent (its half-order part passes through zero: the
pitchfork of the doubled problem, reached again, at the same or another period doubling
of the parent), leaves the speed range, or stops as any trace does.
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..continuation import Branch, continue_branch
from ..newton import ConvergenceError
from ..problem import HBMProblem
from ..sweep import PointMonitor
from .doubling import doubled_problem, odd_mask
from .switching import DoublingPoint, doubling_brackets, locate_doubling, switch_branch

logger = logging.getLogger(__name__)

__all__ = ["SecondaryBranch", "period_doubling_branches", "trace_secondary"]

# the period doubling of the parent nearest to where a branch rejoined it, within this
# fraction of the range, is where it rejoined (the estimate from the two points around
# the pitchfork is off by the square of the step: both lie on the same side of it)
REJOIN_MATCH = 0.01
# a branch that rejoins within this many points went back through the pitchfork
SHORT_REJOIN = 3


@dataclass
class SecondaryBranch:
    """A branch of responses of a multiple period, born at a period doubling.

    Attributes
    ----------
    name
        ``"period2_1"``, ``"period2_2"``, ``"period4_1"``, ... (period, then order found).
    period
        Its period in periods of the main branch's fundamental (2, 4, ...).
    problem
        The doubled :class:`hbm.HBMProblem` whose unknowns the branch holds: fundamental
        ``problem.harmonics.ratio`` Omega, the half orders on its odd indices.
    branch
        The :class:`hbm.Branch` (every per-point array, statistics over the doubled
        period, stability, grazing, folds). Its ``status`` is ``"rejoined"`` when it met
        its parent again, or a trace status (``"completed"``/``"left_range"``: it left
        the speed range).
    parent
        ``"main"`` or the name of the secondary branch it doubled from.
    doubling
        The period doubling it was switched at (:class:`DoublingPoint`; ``index`` is the
        bracket on the parent branch).
    rejoin_rpm
        Where it met its parent again (NaN if it did not).
    epsilon
        The deviation along the critical vector of its first point (scaled).
    """

    name: str
    period: int
    problem: HBMProblem
    branch: Branch
    parent: str
    doubling: DoublingPoint
    rejoin_rpm: float
    epsilon: float


class _Rejoined(Exception):
    def __init__(self, branch: Branch, rpm: float) -> None:
        super().__init__("rejoined")
        self.branch, self.rpm = branch, rpm


def _rejoin_watch(child: HBMProblem) -> Callable[[Branch], None]:
    """An ``on_point`` that stops the trace when the half-order part of the unknowns
    passes through zero between two points (their odd parts point opposite ways, one of
    them small against the largest seen): the branch has met its parent again."""
    mask = odd_mask(child)
    largest = [0.0]

    def watch(branch: Branch) -> None:
        n = len(branch)
        if n < 2:
            return
        a = branch.unknowns[n - 2][mask] / child.x_scale[mask]
        b = branch.unknowns[n - 1][mask] / child.x_scale[mask]
        na, nb = np.linalg.norm(a), np.linalg.norm(b)
        largest[0] = max(largest[0], na, nb)
        if a @ b < 0 and min(na, nb) < 0.25 * largest[0]:
            s = na / (na + nb)
            rpm = float(branch.rpm[n - 2] + s * (branch.rpm[n - 1] - branch.rpm[n - 2]))
            raise _Rejoined(branch, rpm)
    return watch


def trace_secondary(child: HBMProblem, first, rpm_range: tuple[float, float],
                     step_rpm: tuple[float, float, float], tol: float, max_points: int,
                     stability: bool) -> tuple[Branch, float]:
    """Trace the doubled problem from its switched first point away from the period
    doubling, to the end of the range in that direction, allowed to turn back to the
    other end; stopped when it rejoins. Returns the branch and the rejoin speed (NaN
    when it did not rejoin)."""
    lo, hi = rpm_range
    end = hi if first.direction > 0 else lo
    span = abs(end - first.rpm)
    if span < 1e-6 * (hi - lo):
        raise ConvergenceError(f"the period-2 branch starts at the end of the range "
                               f"({first.rpm:.6g} rpm)")
    back = (first.rpm - lo) if first.direction > 0 else (hi - first.rpm)
    step, min_step, max_step = (s / span for s in step_rpm)
    min_step = min(min_step, step)
    max_step = max(max_step, step)
    monitor = PointMonitor(child, stability, process=False)
    try:
        br = continue_branch(child, monitor, first.rpm, end, step=step, min_step=min_step,
                             max_step=max_step, tol=tol, max_points=max_points,
                             overshoot=back / span, start=first.unknowns,
                             start_fallback=False, on_point=_rejoin_watch(child))
        if br.status in ("completed", "left_range"):
            br = dataclasses.replace(br, message=f"left the speed range at "
                                                 f"{br.rpm[-1]:.6g} rpm")
        return br, float("nan")
    except _Rejoined as r:
        br = dataclasses.replace(r.branch, status="rejoined", message=(
            f"rejoined its parent near {r.rpm:.6g} rpm (the half orders passed through "
            "zero)"))
        return br, r.rpm


def period_doubling_branches(problem: HBMProblem, branch: Branch,
                             rpm_range: tuple[float, float], depth: int = 1, *,
                             step_rpm: tuple[float, float, float], tol: float = 1e-8,
                             max_points: int = 2000, stability: bool = True,
                             linear_solver: str = "auto", max_branches: int = 50,
                             max_total_points: int | None = None,
                             on_branch: Callable[[SecondaryBranch], None] | None = None,
                             ) -> list[SecondaryBranch]:
    """Switch at every period doubling of ``branch`` (``problem``'s) to the period-2
    branch and trace it, then switch on those, to ``depth`` doublings (1: period 2 only;
    0: none).

    Parameters
    ----------
    problem, branch
        The main problem (periodic basis) and its branch, with its stability (the Floquet
        kinds bracket the period doublings).
    rpm_range
        ``(lo, hi)`` rpm: the secondary branches are traced within it.
    step_rpm
        ``(step, min_step, max_step)`` of the continuation in rpm (as the scene's).
    tol, max_points, stability, linear_solver
        As :func:`hbm.trace` (the doubled problem's linear solver).
    max_branches
        At most this many secondary branches in all.
    max_total_points
        At most this many points on all secondary branches together (None: no bound);
        each branch gets at most what is left.
    on_branch
        Called with each secondary branch when traced.

    Returns
    -------
    list of SecondaryBranch
        In the order found (parents before their children). A period doubling at which a
        branch already traced rejoined its parent is not switched at again.
    """
    if int(depth) != depth or depth < 0:
        raise ValueError(f"period_doubling_depth = {depth!r}: must be an integer >= 0")
    if not problem.periodic:
        raise ValueError("period doubling: needs a periodic basis (a HarmonicSet)")
    lo, hi = sorted(float(r) for r in rpm_range)
    found: list[SecondaryBranch] = []
    budget = np.inf if max_total_points is None else int(max_total_points)
    queue: list[tuple[str, int, HBMProblem, Branch]] = [("main", 1, problem, branch)]
    while queue and depth > 0:
        pname, period, parent, pbranch = queue.pop(0)
        if period >= 2 ** depth:
            continue
        brackets = doubling_brackets(pbranch)
        if not brackets:
            continue
        child = doubled_problem(parent, linear_solver)
        covered = [False] * len(brackets)
        located: dict[int, DoublingPoint | None] = {}

        def locate(j: int, parent=parent, child=child, pbranch=pbranch, pname=pname,
                   located=located, brackets=brackets) -> DoublingPoint | None:
            if j not in located:
                i = brackets[j]
                try:
                    located[j] = locate_doubling(parent, child, pbranch, i)
                except (ConvergenceError, np.linalg.LinAlgError) as exc:
                    logger.warning("period doubling between %.6g and %.6g rpm of %s not "
                                   "located: %s", pbranch.rpm[i], pbranch.rpm[i + 1], pname,
                                   exc)
                    located[j] = None
            return located[j]

        for j in range(len(brackets)):
            if covered[j]:
                logger.info("period doubling near %.6g rpm of %s: its period-%d branch is "
                            "already traced (it rejoined there)", pbranch.rpm[brackets[j]],
                            pname, 2 * period)
                continue
            covered[j] = True
            pd = locate(j)
            if pd is None or any(q is not None and q is not pd and q.rpm == pd.rpm
                                 for q in located.values()):
                continue
            left = budget - sum(len(f.branch) for f in found)
            if len(found) >= max_branches or left < 2:
                logger.warning("period doubling: stopped at %s (the period doubling at "
                               "%.6g rpm of %s and later ones not switched at)",
                               f"max_branches = {max_branches}" if left >= 2 else
                               f"max_total_points = {max_total_points}", pd.rpm, pname)
                return found
            points = int(min(max_points, left))
            try:
                first = switch_branch(parent, child, pd, pbranch.omega_scale, tol)
                sub, rejoin = trace_secondary(child, first, (lo, hi), step_rpm, tol,
                                              points, stability)
                if len(sub) <= SHORT_REJOIN and np.isfinite(rejoin):
                    # came straight back through the pitchfork: the other way
                    logger.info("period doubling at %.6g rpm: the period-%d branch rejoined "
                                "after %d points; tracing it the other way", pd.rpm,
                                2 * period, len(sub))
                    first = dataclasses.replace(first, direction=-first.direction)
                    sub, rejoin = trace_secondary(child, first, (lo, hi), step_rpm, tol,
                                                  points, stability)
            except (ConvergenceError, np.linalg.LinAlgError) as exc:
                logger.warning("period doubling at %.6g rpm of %s: no period-%d branch (%s)",
                               pd.rpm, pname, 2 * period, exc)
                continue
            if np.isfinite(rejoin):
                # the bracket of the parent's period doubling it met again: the nearest
                gap = [np.inf if covered[m] and m != j else
                       max(0.0, min(pbranch.rpm[b], pbranch.rpm[b + 1]) - rejoin,
                           rejoin - max(pbranch.rpm[b], pbranch.rpm[b + 1]))
                       for m, b in enumerate(brackets)]
                m = int(np.argmin(gap))
                if gap[m] < REJOIN_MATCH * (hi - lo):
                    covered[m] = True
                    there = locate(m)
                    if there is not None:
                        rejoin = there.rpm
                        sub = dataclasses.replace(sub, message=(
                            f"rejoined its parent at the period doubling located at "
                            f"{rejoin:.9g} rpm"))
            k = 1 + sum(1 for f in found if f.period == 2 * period)
            sec = SecondaryBranch(f"period{2 * period}_{k}", 2 * period, child, sub, pname,
                                  pd, rejoin, first.eps)
            logger.info("%s: %d points, %.6g-%.6g rpm, %s", sec.name, len(sub),
                        np.min(sub.rpm), np.max(sub.rpm), sub.message or sub.status)
            found.append(sec)
            if on_branch is not None:
                on_branch(sec)
            queue.append((sec.name, 2 * period, child, sub))
    return found
