"""The continuation never walks back over its own branch (issue 14, item 4).

A reversal is provoked on the single-DOF gear pair by flipping the stored tangent of one
point (the tangent flipping without a fold, as at a corner of the piecewise-smooth
branch): without detection the trace walks back to rpm_start and leaves the range. The
recovered branch must equal an undisturbed trace, be monotone where that one is, and
never revisit traced points.
"""
from __future__ import annotations

import numpy as np
import pytest
from hbm_models import RPM, sdof_problem

import hbm
import hbm.continuation.revisits as revisits
import hbm.continuation.tracer as cont
from hbm.continuation.revisits import REVISIT_RATIO


def _flip_once_at(monkeypatch, rpm_flip: float, times: int = 1, active=lambda: True) -> list:
    """Store the reversed tangent for the first ``times`` points accepted beyond rpm_flip
    (while ``active()``)."""
    orig = cont.check_events
    done: list[float] = []

    def flipped(ctx, rec, yn, tn, *args):
        if active() and len(done) < times and \
                yn[-1] * rec.meta["omega_scale"] / RPM > rpm_flip:
            done.append(yn[-1] * rec.meta["omega_scale"] / RPM)
            tn = -tn
        return orig(ctx, rec, yn, tn, *args)

    monkeypatch.setattr(cont, "check_events", flipped)
    return done


def _scaled(pb, br):
    return np.hstack([br.unknowns / pb.x_scale, br.omega[:, None] / br.omega_scale])


def _min_revisit_ratio(pb, br) -> float:
    """Smallest distance of a point to an earlier segment (not its own), over its chord."""
    y = _scaled(pb, br)
    worst = np.inf
    for i in range(3, len(y)):
        a, b = y[:i - 2], y[1:i - 1]
        ab = b - a
        t = np.clip(np.sum((y[i] - a) * ab, 1) / np.sum(ab * ab, 1), 0, 1)
        d = np.linalg.norm(a + t[:, None] * ab - y[i], axis=1).min()
        worst = min(worst, d / np.linalg.norm(y[i] - y[i - 1]))
    return worst


@pytest.fixture(scope="module")
def reference():
    pb = sdof_problem(harmonics=20, fa=0.1, b=0.2)
    return pb, hbm.trace(pb, 0.3 / RPM, 1.6 / RPM, stability=False)


def test_reversal_is_detected_and_recovered(reference, monkeypatch):
    pb, ref = reference
    assert ref.status == "completed" and ref.reversals == 0
    flips = _flip_once_at(monkeypatch, 0.5 / RPM)
    br = hbm.trace(pb, 0.3 / RPM, 1.6 / RPM, stability=False)
    assert flips, "the tangent flip was not applied"
    assert br.status == "completed", br.message
    assert br.reversals >= 1
    # never revisits a traced point (the undisturbed branch has no ratio below ~1)
    assert _min_revisit_ratio(pb, br) > REVISIT_RATIO
    # monotone in speed where the reference is: up to its first fold
    first_fold = ref.fold_index[0] if ref.fold_index else len(ref) - 1
    lim = ref.rpm[first_fold]
    seg = br.rpm[br.rpm <= lim - 1e-9]
    seg = seg[:np.argmax(seg) + 1]
    assert np.all(np.diff(seg) > 0)
    # the same curve: mesh-load std interpolated on the monotone stretch
    sel = ref.rpm[:first_fold] <= seg[-1]
    np.testing.assert_allclose(np.interp(ref.rpm[:first_fold][sel], seg,
                                         br.element(0).mesh_load_std[:seg.size]),
                               ref.element(0).mesh_load_std[:first_fold][sel], rtol=2e-3)
    np.testing.assert_allclose(br.folds, ref.folds, rtol=1e-3)
    assert len(br.grazing) == len(ref.grazing)


def test_repeated_reversals_stop_with_reason_and_keep_points(reference, monkeypatch):
    pb, _ = reference
    _flip_once_at(monkeypatch, 0.5 / RPM, times=10 ** 6)    # every point flips
    snapshots = []
    br = hbm.trace(pb, 0.3 / RPM, 1.6 / RPM, stability=False, on_point=snapshots.append,
                   retry_steps=())
    assert br.status == "reversal"
    assert "walked back over its own points" in br.message
    assert br.reversals == cont.MAX_REVERSALS + 1
    assert len(br) >= 2 and np.all(br.residual < 1e-8)
    assert br.rpm[-1] > 0.5 / RPM - 1e-9 and snapshots[-1].status == "reversal"
    assert _min_revisit_ratio(pb, br) > REVISIT_RATIO


def test_a_trace_caught_by_reversals_is_retried_from_before_the_trap(reference,
                                                                    monkeypatch):
    """Every point beyond 0.5 flips during the first attempt, which stops walking back;
    the retry (another initial step) resumes from before the speeds where it was caught
    and, the flips gone, gives the undisturbed curve."""
    pb, ref = reference
    runs = []
    run = cont._run

    def counted(*args, **kwargs):
        runs.append(args[4])                    # the initial step of each attempt
        return run(*args, **kwargs)

    monkeypatch.setattr(cont, "_run", counted)
    flips = _flip_once_at(monkeypatch, 0.5 / RPM, times=10 ** 6, active=lambda: len(runs) == 1)
    br = hbm.trace(pb, 0.3 / RPM, 1.6 / RPM, stability=False, step=0.01)
    assert flips and len(runs) == 2
    assert runs[1] == pytest.approx(0.01 * cont.RETRY_STEPS[0])
    assert br.status == "completed", br.message
    assert _min_revisit_ratio(pb, br) > REVISIT_RATIO
    np.testing.assert_allclose(br.folds, ref.folds, rtol=1e-3)
    assert len(br.grazing) == len(ref.grazing)
    np.testing.assert_allclose(br.element(0).mesh_load_std.max(),
                               ref.element(0).mesh_load_std.max(), rtol=1e-3)


def test_a_failed_step_is_retried_from_before_it(reference, monkeypatch):
    """The first attempt's corrector fails past 0.8 (a stall): the trace stops with
    ``step_failed``, is retried from before the speeds where it stopped and gives the
    undisturbed curve; with ``retry_steps=()`` it stops there, keeping its points."""
    pb, ref = reference
    runs = []
    run, advance = cont._run, cont._advance

    def counted(*args, **kwargs):
        runs.append(args[4])
        return run(*args, **kwargs)

    def stalled(ctx, rec, ds):
        if len(runs) == 1 and rec.last("rpm") > 0.8 / RPM:
            return cont._Step(None, ds, "tangent", "corrector stalled (test)")
        return advance(ctx, rec, ds)

    monkeypatch.setattr(cont, "_run", counted)
    monkeypatch.setattr(cont, "_advance", stalled)
    br = hbm.trace(pb, 0.3 / RPM, 1.6 / RPM, stability=False, retry_steps=())
    assert br.status == "step_failed" and br.rpm[-1] > 0.8 / RPM
    assert np.all(br.residual < 1e-8)
    runs.clear()
    br = hbm.trace(pb, 0.3 / RPM, 1.6 / RPM, stability=False)
    assert len(runs) == 2 and br.status == "completed", br.message
    assert _min_revisit_ratio(pb, br) > REVISIT_RATIO
    np.testing.assert_allclose(br.folds, ref.folds, rtol=1e-3)
    assert len(br.grazing) == len(ref.grazing)


def test_resume_after_a_step_change_continues_from_the_last_point(reference):
    pb, ref = reference
    part = hbm.trace(pb, 0.3 / RPM, 1.6 / RPM, stability=False, max_points=15)
    assert part.status == "max_points"
    part.status = "step_failed"     # as after a failed step: the new settings apply
    rest = hbm.trace(pb, 0.3 / RPM, 1.6 / RPM, stability=False, resume=part, step=0.002,
                     max_step=0.02)
    assert rest.status == "completed"
    np.testing.assert_array_equal(rest.rpm[:15], part.rpm)
    assert np.all(np.diff(rest.rpm[14:20]) > 0)
    assert rest.rpm[15] - rest.rpm[14] < ref.rpm[15] - ref.rpm[14]    # the new, smaller step
    np.testing.assert_allclose(
        np.interp(ref.rpm[:20], rest.rpm, rest.element(0).mesh_load_std),
        ref.element(0).mesh_load_std[:20], rtol=1e-3)


# ------------------------------------------------ distinct pieces past a sharp fold (issue 13)

def _s_curve(y, jacobian=True):
    """x^3 - 3x = w: three solutions for |w| < 2, folds at x = +-1 (w = -+2)."""
    x, w = y[0], y[1]
    r = np.array([x ** 3 - 3 * x - w])
    if not jacobian:
        return r
    return r, np.array([[3 * x ** 2 - 3]]), np.array([-1.0])


def test_a_near_point_on_another_piece_is_not_a_revisit():
    foot = np.array([0.05, 0.3])          # on the old polyline, near the piece x ~ 0
    other = np.array([np.sqrt(3.0), 0.0])      # the piece x = +sqrt(3) at w = 0
    assert revisits.distinct_solution(_s_curve, foot, other, 1e-12, 20)
    same = np.array([1e-9, 0.0])          # the old piece itself at w = 0 (x = -w/3 ~ 0)
    assert not revisits.distinct_solution(_s_curve, foot, same, 1e-12, 20)


def test_a_failed_check_keeps_the_revisit():
    def fails(y, jacobian=True):
        raise hbm.ConvergenceError("no solution")
    assert not revisits.distinct_solution(fails, np.array([0.05, 0.3]), np.array([1.7, 0.0]),
                                       1e-12, 20)


def test_reversals_far_apart_do_not_add_up(reference, monkeypatch):
    """A reversal budget of one per place: two flips many points apart both recover."""
    pb, ref = reference
    orig = cont.check_events
    at = [len(ref) // 4, len(ref) // 2]
    done: list[int] = []

    def flipped(ctx, rec, yn, tn, *args):
        if len(rec) in at and len(rec) not in done:
            done.append(len(rec))
            tn = -tn
        return orig(ctx, rec, yn, tn, *args)

    monkeypatch.setattr(cont, "check_events", flipped)
    monkeypatch.setattr(cont, "MAX_REVERSALS", 1)
    br = hbm.trace(pb, 0.3 / RPM, 1.6 / RPM, stability=False)
    assert done == at
    assert br.status == "completed", br.message
    assert br.reversals == 2
    np.testing.assert_allclose(br.folds, ref.folds, rtol=1e-3)


# ------------------------------------ a walk back after a gradual turn (issue 14, item 4)

class _Polyline:
    """Stand-in for the trace context and recorder: states of a given polyline."""

    def __init__(self, points):
        self.points = np.asarray(points, dtype=float)
        self.evaluate, self.tol, self.max_iter = None, 1e-10, 5

    def __len__(self):
        return len(self.points)

    def states(self, rec):
        return rec.points


def test_a_walk_back_is_found_without_a_step_that_turned_back(monkeypatch):
    """The branch runs right along y = 0, turns round a loop and comes back along it: the
    last step goes the way the step before went (the turn was gradual), but against the
    old segment it lies on, so it is a revisit of that segment (the pump at 0.6 x the
    shipped TE, 3/1 set, walked back from 1514 to 250 rpm this way). A step along an old
    segment in its own direction (a branch winding past its earlier loop) is not."""
    monkeypatch.setattr(revisits, "distinct_solution", lambda *a: False)   # same solutions
    out = [(0, 0), (1, 0), (2, 0), (3, 0), (3.7, 0.3), (3.9, 0.9), (3.5, 1.2), (2.9, 0.7)]
    walk = _Polyline(out + [(2.3, 0.2), (1.9, 0.01)])
    yn = np.array([1.4, 0.005])
    assert (yn - walk.points[-1]) @ (walk.points[-1] - walk.points[-2]) > 0   # no turn back
    assert revisits.revisit(walk, walk, yn) == 1                 # segment (1, 0) -> (2, 0)
    wind = _Polyline(out + [(2.3, 1.2), (1.2, 1.05), (0.5, 0.6), (0.4, 0.1), (0.9, 0.01)])
    assert revisits.revisit(wind, wind, np.array([1.4, 0.005])) is None
