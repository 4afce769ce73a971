"""Refusals of :func:`hbm.continuation.continue_branch` arguments out of range, each naming
the argument."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from .branch import Branch
    from .protocol import ContinuationModel


def check_settings(rpm_start, rpm_end, step, min_step, max_step, tol, max_points,
                    overshoot) -> None:
    """Refuse trace settings out of range, naming the argument."""
    for name, v in (("rpm_start", rpm_start), ("rpm_end", rpm_end)):
        if not np.isfinite(v) or v <= 0:
            raise ValueError(f"trace.{name} = {v!r}: must be > 0 rpm")
    if rpm_start == rpm_end:
        raise ValueError(f"trace.rpm_end = {rpm_end!r}: must differ from rpm_start")
    if not (0 < min_step <= step <= max_step):
        raise ValueError(f"trace.step = {step!r}: need 0 < min_step ({min_step}) <= step <= "
                         f"max_step ({max_step})")
    if not (0 < tol < 1e-2):
        raise ValueError(f"trace.tol = {tol!r}: must be in (0, 1e-2)")
    if int(max_points) != max_points or max_points < 1:
        raise ValueError(f"trace.max_points = {max_points!r}: must be an integer >= 1")
    if not overshoot >= 0:
        raise ValueError(f"trace.overshoot = {overshoot!r}: must be >= 0")


def check_resume(problem: ContinuationModel, resume: Branch) -> None:
    """Refuse a branch to resume that has no point or other unknowns than ``problem``."""
    if len(resume) == 0:
        raise ValueError("trace.resume: the branch has no point to resume from")
    if resume.unknowns.ndim != 2 or resume.unknowns.shape[1] != problem.n_unknowns:
        raise ValueError("trace.resume: branch does not match this problem's unknowns")


def check_start(problem: ContinuationModel, start: np.ndarray | None,
                resume: Branch | None) -> np.ndarray | None:
    """``start`` as floats of the problem's unknowns (None stays None); refused with
    ``resume`` (a resumed trace starts from its branch)."""
    if start is None:
        return None
    start = np.asarray(start, dtype=float)
    if start.shape != (problem.n_unknowns,) or not np.all(np.isfinite(start)):
        raise ValueError(f"start shape = {start.shape}: must be ({problem.n_unknowns},) "
                         "finite floats")
    if resume is not None:
        raise ValueError("start and resume: give one of them")
    return start
