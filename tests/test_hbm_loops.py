"""The continuation going round a closed loop in the same direction (issue 14, item 4).

An algebraic system of two unknowns whose solution set is known: the line ``x = 0`` (the
branch) and a circle that crosses it at the branch points ``w_b = w0 -+ sqrt(r^2 - c^2)``
(a loop joined to the branch). At a branch point a continuation can turn onto the loop
(on the pump a corner of the piecewise-smooth branch does it: docs/hbm.md, "Closed
loops"); here the tangent of the last point before the first branch point is turned onto
the circle. Going round, the trace passes that branch point along the circle, straight
through, and goes round again for ever. The loop must be detected where it closes (at the
branch point), its points kept and marked, and the trace must leave it straight through
the branch point along the line and reach the end of the range.
"""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

import hbm.continuation.revisits as revisits
import hbm.continuation.tracer as cont
from hbm.continuation import Measurement, Recorder, SpeedRange, TraceContext
from hbm.continuation.loops import resume_point
from hbm.units import RPM_TO_RAD_S

W0, C, R = 1.5, 0.05, 0.1                     # circle (w - W0)^2 + (x1 - C)^2 = R^2
W_B = W0 - np.sqrt(R ** 2 - C ** 2)           # first branch point (1.4134)
W_B2 = W0 + np.sqrt(R ** 2 - C ** 2)          # second one
STEP = 0.01
TOL = 1e-10


def _residual(y, jacobian=True):
    """R = (x1 ((w - W0)^2 + (x1 - C)^2 - R^2), x2 - x1 w / 2); y = (x1, x2, w)."""
    x1, x2, w = y
    g = (w - W0) ** 2 + (x1 - C) ** 2 - R ** 2
    r = np.array([x1 * g, x2 - 0.5 * x1 * w])
    if not jacobian:
        return r
    jx = np.array([[g + 2 * x1 * (x1 - C), 0.0], [-0.5 * w, 1.0]])
    jw = np.array([2 * x1 * (w - W0), -0.5 * x1])
    return r, jx, jw


def _on_circle(y) -> float:
    return abs((y[2] - W0) ** 2 + (y[0] - C) ** 2 - R ** 2)


class _Monitor:
    """The monitor of the algebraic system: no statistics, no events, no stability."""

    events = ()
    asynchronous = False

    def branch_meta(self):
        return {"harmonics": (0,), "condensation": "algebraic", "statistics": ()}

    def measure(self, unknowns, omega, iterations, residual, tangent):
        return Measurement(True, 0.0, 0, True, {})

    def collect(self, wait):
        return []

    def auxiliary(self):
        return self

    def start(self):
        pass

    def stop(self):
        pass


def _circle_tangent():
    """Unit tangent of the circle at the first branch point, speed increasing."""
    dw, dx1 = C / R, (W_B - W0) / R
    t = np.array([dx1, 0.5 * dx1 * W_B, dw])
    return t / np.linalg.norm(t)


def _context():
    """The algebraic problem, the range w = 1 -> 2 and the trace context."""
    stub = SimpleNamespace(x_scale=np.ones(2), n_unknowns=2, vibration=np.ones(2, dtype=bool),
                           scaled=lambda x, omega, j=True: _residual(np.append(x, omega), j))
    bounds = SpeedRange(1.0 / RPM_TO_RAD_S, 2.0 / RPM_TO_RAD_S, 0.25)
    ctx = TraceContext(stub, _Monitor(), _residual, bounds.wscale, TOL, 12, 1e-9, STEP, 1e-6,
                       STEP)
    return stub, bounds, ctx


def _trace(monkeypatch, max_points=400):
    """Trace w = 1 -> 2 by the continuation's own PREDICT/CORRECT and ACCEPT, the tangent
    of the last point before W_B turned onto the circle."""
    orig = cont.check_events
    turned = []

    def turn(ctx, rec, yn, tn, *args):
        if not turned and W_B - STEP < yn[-1] < W_B:
            turned.append(yn[-1])
            tn = _circle_tangent()
        return orig(ctx, rec, yn, tn, *args)

    monkeypatch.setattr(cont, "check_events", turn)
    stub, bounds, ctx = _context()
    rec = Recorder(_Monitor().branch_meta(), stub.x_scale, bounds.rpm_start, bounds.rpm_end,
                   bounds.wscale)
    ctx.record(rec, np.array([0.0, 0.0, 1.0]), 0, 0.0, np.array([0.0, 0.0, 1.0]))
    status, message, ds = "running", "", STEP
    while status == "running" and len(rec) < max_points:
        advanced = cont._advance(ctx, rec, ds)
        assert advanced.point is not None, advanced.message
        status, message, ds = cont._accept(ctx, rec, advanced, bounds, advanced.ds)
    assert turned, "the tangent was not turned onto the loop"
    return rec.branch(status if status != "running" else "max_points", message, ds)


def test_without_detection_the_trace_circles_the_loop(monkeypatch):
    monkeypatch.setattr(cont, "closed_loop", lambda *a: None)
    br = _trace(monkeypatch, max_points=300)
    assert br.status == "max_points"
    y = np.column_stack([br.unknowns, br.omega])
    on_circle = np.array([_on_circle(p) < 1e-8 for p in y])
    assert on_circle[-150:].all()          # round and round the loop
    assert br.omega.max() < W0 + R + STEP  # never past the loop


def test_closed_loop_is_kept_and_left_through_the_branch_point(monkeypatch):
    calls = []
    orig = cont.closed_loop

    def spy(ctx, rec, yn, tn, *args):
        hit = orig(ctx, rec, yn, tn, *args)
        if hit is not None:
            calls.append(yn.copy())
        return hit

    monkeypatch.setattr(cont, "closed_loop", spy)
    br = _trace(monkeypatch)
    assert br.status == "completed", br.message
    assert br.omega[-1] == pytest.approx(2.0, abs=1e-12)
    # detected once, where the branch came round to the first branch point
    assert len(calls) == 1 and len(br.loops) == 1
    assert calls[0][-1] == pytest.approx(W_B, abs=2 * STEP)
    assert _on_circle(calls[0]) < 1e-8
    first, last, entry, restart = br.loops[0]
    y = np.column_stack([br.unknowns, br.omega])
    # the loop: every point on the circle, going all round it (its speed range)
    loop = y[br.loop == 1]
    assert len(loop) == last - first + 1 >= 30
    assert max(_on_circle(p) for p in loop) < 1e-8
    assert loop[:, 2].min() == pytest.approx(W0 - R, abs=STEP)
    assert loop[:, 2].max() == pytest.approx(W0 + R, abs=STEP)
    # the rest: the line, the entry point just before the branch point, and after the
    # copies of it and its predecessor the trace goes on along the line to the end
    rest = y[br.loop == 0]
    assert np.abs(rest[:, :2]).max() < 1e-12
    assert W_B - STEP < y[entry, 2] < W_B
    np.testing.assert_array_equal(y[restart + 1], y[entry])
    after = y[restart + 1:, 2]
    assert np.all(np.diff(after) > 0) and after[-1] == pytest.approx(2.0)
    assert np.all(br.residual < TOL)


def test_exits_exhausted_stop_cleanly_keeping_the_points(monkeypatch):
    """No exit leaves the loop (every one refused): the trace stops with status "loop",
    every point computed kept, the loop marked."""
    monkeypatch.setattr("hbm.continuation.loops._on_loop", lambda *a: True)
    br = _trace(monkeypatch)
    assert br.status == "loop"
    assert "closed loop" in br.message
    assert len(br.loops) == 1 and np.sum(br.loop == 1) >= 30
    assert np.all(br.residual < TOL)
    assert br.omega.max() < W0 + R + STEP


def test_resuming_a_branch_caught_in_a_loop_restarts_before_it(monkeypatch):
    """--resume of a branch that stopped with status "loop": the points kept end before
    the loop's speeds (resuming from its last point would repeat the trap), and the
    resumed trace reaches the end of the range along the line."""
    with monkeypatch.context() as m:
        m.setattr("hbm.continuation.loops._on_loop", lambda *a: True)
        stopped = _trace(monkeypatch)
    assert stopped.status == "loop"
    keep = resume_point(stopped.rpm, stopped.loops, stopped.status)
    first, last = stopped.loops[0][:2]
    assert 1 < keep <= first
    # the last point kept lies before the loop's speed range, which starts at the circle's
    # leftmost speed W0 - R; the next point lies inside it
    lowest = stopped.rpm[first:last + 1].min()
    assert stopped.rpm[keep - 1] < lowest <= stopped.rpm[keep]
    assert lowest * RPM_TO_RAD_S == pytest.approx(W0 - R, abs=STEP ** 2 / R)  # sagitta
    assert stopped.omega[keep - 1] == pytest.approx(W0 - R, abs=STEP)
    stub, bounds, ctx = _context()
    rec = Recorder(_Monitor().branch_meta(), stub.x_scale, bounds.rpm_start, bounds.rpm_end,
                   bounds.wscale, stopped)
    br = cont._run(ctx, rec, bounds, stopped, STEP, 1e-6, STEP, 400, None, False)
    assert br.status == "completed", br.message
    assert br.omega[-1] == pytest.approx(2.0, abs=1e-12)
    np.testing.assert_array_equal(br.omega[:keep], stopped.omega[:keep])
    assert len(br.loops) == 0 and not br.loop.any()
    assert np.abs(br.unknowns).max() < 1e-12 and np.all(br.residual < TOL)


def test_resume_point_keeps_every_point_unless_the_branch_was_trapped():
    """Statuses other than a walk back keep every point; a reversal trapped in the speed
    window of its last points goes back to where the branch last entered that window."""
    rpm = np.array([1.0, 2.0, 3.0, 4.0, 5.0, 4.9, 5.0, 4.95, 5.0, 4.9, 5.0, 4.95, 5.0, 4.9])
    for status in ("step_failed", "max_points", "running", "completed"):
        assert resume_point(rpm, [], status) == len(rpm)
    assert resume_point(rpm, [], "reversal") == 4           # ends at 4.0, before 4.9-5.0
    # a closed loop reaching down to 3.5 overlapping that window widens it
    rpm2 = np.concatenate([rpm[:4], [3.5, 4.2, 5.0], rpm[4:]])
    assert resume_point(rpm2, [(4, 6, 3, 7)], "loop") == 3   # ends at 3.0, before 3.5


# ------------------------------------------------ the detection on given polylines

class _Polyline:
    """Stand-in for the trace context and recorder: states of a given polyline."""

    def __init__(self, points, evaluate):
        self.points = np.asarray(points, dtype=float)
        self.evaluate, self.tol, self.max_iter, self.wscale = evaluate, 1e-12, 12, 1.0

    def __len__(self):
        return len(self.points)

    def states(self, rec):
        return rec.points


# (speed w, unknown x): along x = 0, round, back onto x = 0 at w ~ 0.9
_ROUND = [(0, 0), (0.5, 0), (1, 0), (1.5, 0), (2, 0), (2.6, 0.3), (2.8, 0.9), (2.3, 1.3),
          (1.6, 1.2), (1.0, 0.8), (0.7, 0.3), (0.9, 0.02)]


def _states(wx):
    """Scaled states ``(x, w)`` (the speed last) of ``(w, x)`` pairs."""
    return [(x, w) for w, x in wx]


def test_a_branch_coming_round_onto_its_path_is_a_closed_loop():
    """The path runs along x = 0, goes round and arrives back on it going the same way:
    the new point and the step after it lie on the old segments."""
    def line(y, jacobian=True):
        r = np.array([y[0]])
        return (r, np.array([[1.0]]), np.array([0.0])) if jacobian else r

    poly = _Polyline(_states(_ROUND), line)
    yn, tn = np.array([0.0, 1.2]), np.array([0.0, 1.0])
    assert revisits.closed_loop(poly, poly, yn, tn) == 2        # segment w = 1 -> 1.5
    # going the other way along the old path: a walk back, not a loop
    assert revisits.closed_loop(poly, poly, np.array([0.0, 0.8]), -tn) is None


def test_a_distinct_nearby_branch_is_not_a_closed_loop():
    """The same pass where two solutions lie close (x = 0 and x = 1e-3): Newton at the new
    point's speed from the old path lands on the old solution, not on the new point."""
    eps = 1e-3

    def two(y, jacobian=True):
        r = np.array([y[0] * (y[0] - eps)])
        return (r, np.array([[2 * y[0] - eps]]), np.array([0.0])) if jacobian else r

    poly = _Polyline(_states(_ROUND), two)
    assert revisits.closed_loop(poly, poly, np.array([eps, 1.2]), np.array([0.0, 1.0])) is None


def test_crossing_the_old_path_once_is_not_a_closed_loop():
    """A branch crossing its earlier path at an angle (a self-intersection, the same
    solution at the crossing) goes on off the old path: the confirming step refuses it."""
    def cross(y, jacobian=True):
        # solutions: the line x = 0 and the line x = w - 1.2 (crossing at w = 1.2)
        r = np.array([y[0] * (y[0] - (y[1] - 1.2))])
        if not jacobian:
            return r
        return r, np.array([[2 * y[0] - (y[1] - 1.2)]]), np.array([-y[0]])

    poly = _Polyline(_states(_ROUND[:-1] + [(1.1, -0.1)]), cross)
    t = np.array([1.0, 1.0]) / np.sqrt(2)
    assert revisits.closed_loop(poly, poly, np.array([0.0, 1.2]), t) is None


def test_a_walk_back_into_the_loop_just_left_is_a_failed_exit():
    """Within LOOP_EXIT_POINTS points of leaving the last loop, a walk back over it
    makes the trace try the next exit (not undo a reversal); later, or over an older
    loop or another part of the branch, it is an ordinary reversal."""
    import hbm.continuation.loops as loops

    class Rec:
        def __init__(self, n):
            self.n = n
            # (first, last, entry, restart): an older loop and the last one
            self.loops = [(10, 30, 9, 31), (50, 80, 49, 81)]

        def __len__(self):
            return self.n

    near = Rec(81 + loops.LOOP_EXIT_POINTS)
    assert loops.back_into_loop(near, 60)          # on the last loop, just after its exit
    assert loops.back_into_loop(near, 49)          # its entry chord
    assert not loops.back_into_loop(near, 20)      # the older loop
    assert not loops.back_into_loop(near, 40)      # the branch between the loops
    assert not loops.back_into_loop(Rec(82 + loops.LOOP_EXIT_POINTS), 60)   # too late
