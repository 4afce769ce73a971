"""The segment index of the continuation (hbm.continuation.segments): the segments it
keeps near a point, the distances measured and the walk-back / closed-loop decisions are
those of a scan of the whole branch, bit for bit, also after truncations and closed
loops (issue 39 item 5: the per-point bookkeeping must not grow with the branch)."""

import numpy as np
import pytest
from hbm_models import sdof_problem

import hbm
from hbm.continuation import revisits
from hbm.continuation.branch import POINT_FIELDS, Recorder
from hbm.continuation.segments import LEAF, SegmentIndex, segment_gaps
from hbm.examples import Geared3
from hbm.sweep import PointMonitor
from hbm.units import RPM_TO_RAD_S


def _walk(rng, n, dim):
    """A polyline that moves on, turns back and spirals: steps of random length, a
    slowly turning direction, the speed (last coordinate) going to and fro."""
    d = rng.standard_normal(dim)
    pts = [rng.standard_normal(dim)]
    for k in range(n - 1):
        d = d + 0.6 * rng.standard_normal(dim)
        d /= np.linalg.norm(d)
        d[-1] = abs(d[-1]) * (1 if (k // 37) % 3 else -1)
        pts.append(pts[-1] + d * 10.0 ** rng.uniform(-4, -1))
    return np.array(pts)


@pytest.mark.parametrize("dim", [2, 5, 34])
def test_the_index_keeps_every_near_segment_with_the_same_distances(dim):
    """For points on, near and off a polyline, and radii from 1e-6 to 1: the segments
    :meth:`SegmentIndex.near` keeps hold every segment closer than the radius, and their
    distances and feet gathered are those of the whole scan, bitwise; after a truncation
    and regrowth too."""
    rng = np.random.default_rng(dim)
    ys = _walk(rng, 700, dim)
    index = SegmentIndex()
    index.grow(ys, len(ys))
    for cut, regrow in ((None, None), (333, 517), (LEAF * 4 + 1, 700), (2, 700)):
        if cut is not None:
            index.truncate(cut)
            ys = np.vstack([ys[:cut], _walk(rng, regrow - cut + 1, dim)[1:]])
            for k in range(cut + 1, regrow + 1):
                index.grow(ys, k)
        n = len(ys)
        for _ in range(60):
            y = ys[rng.integers(n)] + rng.standard_normal(dim) * 10.0 ** rng.uniform(-7, 0)
            radius = 10.0 ** rng.uniform(-6, 0)
            upto = int(rng.integers(0, n))
            d, foot = segment_gaps(ys, y)
            near = index.near(y, radius, upto)
            assert np.all(np.diff(near) > 0) and (near.size == 0 or near[-1] < upto)
            assert set(np.flatnonzero(d[:upto] < radius)) <= set(near)
            gaps = revisits.pair_gaps(ys[near], ys[near + 1], y)
            assert np.array_equal(gaps[0], d[near]) and np.array_equal(gaps[1], foot[near])


def test_the_index_skips_far_blocks():
    """On a branch that moves on, a query near its end measures a bounded number of
    segments whatever the branch's length."""
    ys = np.zeros((20001, 3))
    ys[:, -1] = np.linspace(0, 1, len(ys))
    ys[:, 0] = np.sin(40 * ys[:, -1])
    index = SegmentIndex()
    for n in (1000, 20001):
        index.grow(ys, n)
        y = ys[n - 1] + 0.5e-4
        assert index.near(y, 0.1 * 5e-5, n - 2).size <= 4 * LEAF


class _Branch:
    """Trace context and recorder of a given polyline, with or without the index."""

    def __init__(self, points, indexed, loops=()):
        self.points = np.asarray(points, dtype=float)
        self.loops = list(loops)
        self.evaluate, self.tol, self.max_iter, self.wscale = None, 1e-12, 5, 1.0
        if indexed:
            self.segments = SegmentIndex()
            self.segments.grow(self.points, len(self.points))

    def __len__(self):
        return len(self.points)

    def states(self, rec):
        return rec.points


def test_walk_back_and_loop_decisions_equal_a_whole_scan(monkeypatch):
    """revisit and closed_loop with the index answer as with every segment measured, on
    random branches and new points near them (same solutions assumed; the confirming
    corrector step replaced by a step along the given tangent), with an untraced join."""
    monkeypatch.setattr(revisits, "distinct_solution", lambda *a: False)
    monkeypatch.setattr(revisits, "correct", lambda ev, y, t, *a: (y, 0, 0.0, None, None))
    rng = np.random.default_rng(7)
    found = {"revisit": 0, "loop": 0}
    for trial in range(40):
        ys = _walk(rng, int(rng.integers(12, 400)), 3)
        loops = [(5, 9, 4, 10)] if trial % 2 else []
        for _ in range(30):
            # the branch came back to old point k (either way) and steps on from there
            k = int(rng.integers(len(ys) - 8))
            seg = ys[k + 1] - ys[k]
            way = 1.0 if rng.random() < 0.5 else -1.0
            last = ys[k + (way < 0)] + rng.standard_normal(3) * 1e-5
            yn = ys[k] + rng.uniform(0.2, 0.8) * seg + rng.standard_normal(3) * 1e-5
            t = way * seg / np.linalg.norm(seg)
            full, fast = _Branch(np.vstack([ys, last]), False, loops), \
                _Branch(np.vstack([ys, last]), True, loops)
            a = revisits.revisit(full, full, yn)
            assert a == revisits.revisit(fast, fast, yn, revisits.branch_gaps(fast, fast, yn))
            c = revisits.closed_loop(full, full, yn, t)
            assert c == revisits.closed_loop(fast, fast, yn, t)
            found["revisit"] += a is not None
            found["loop"] += c is not None
    assert found["revisit"] > 20 and found["loop"] > 20


def test_the_recorder_keeps_its_index_through_truncations_and_resume():
    """A Recorder's index after points added, a truncation and more points, and one
    rebuilt from a resumed branch, keep the segments a fresh index of the same states
    keeps."""
    pb = Geared3(harmonics=4).problem()
    br = hbm.trace(pb, 300, 2000, stability=False, max_points=90, step=0.002, max_step=0.005)
    meta = PointMonitor(pb, False).branch_meta()
    rec = Recorder(meta, pb.x_scale, 300, 2000, br.omega_scale, br)
    states = rec.states().copy()
    assert rec.segments.n_points == 90
    rec.truncate(50)
    for i in range(50, 70):      # the same states again
        rec.add(stats={k: v[i] for k, v in br.stats.items()},
                **{k: getattr(br, k)[i] for k in POINT_FIELDS})
    assert rec.segments.n_points == 70
    fresh = SegmentIndex()
    fresh.grow(states, 70)
    assert len(fresh.centres) == len(rec.segments.centres) == 3
    for level, (c, r) in enumerate(zip(fresh.centres, fresh.radii, strict=True)):
        assert len(c) == len(rec.segments.centres[level]) == 69 // (LEAF << level)
        assert all(np.array_equal(u, v) for u, v in zip(c, rec.segments.centres[level],
                                                         strict=True))
        assert r == rec.segments.radii[level]
    assert br.omega[0] == pytest.approx(300 * RPM_TO_RAD_S)


def test_running_branches_are_the_lists_stacked_and_never_change():
    """Recorder.branch: after random additions, changed rows, truncations and restacks
    (a row of another shape or dtype), every array equals np.array of its list (the
    padded stack for statistics) bitwise, and the views handed out before keep their
    values."""
    from hbm.continuation.branch import _Rows, _stacked

    rng = np.random.default_rng(3)
    for padded in (False, True):
        rows, values, handed = _Rows(), [], []
        for _ in range(600):
            action = rng.random()
            if action < 0.55:
                width = 3 if not padded or rng.random() < 0.97 else int(rng.integers(1, 5))
                values.append(rng.standard_normal((2, width)) if padded else
                              rng.standard_normal(3))
            elif action < 0.65 and values:
                i = int(rng.integers(len(values)))
                values[i] = (np.full_like(values[i], rng.random()) if rng.random() < 0.8 else
                             values[i].astype(np.float32))
                rows.invalidate(i)
            elif action < 0.7 and values:
                n = int(rng.integers(len(values)))
                del values[n:]
                rows.invalidate(n)
            view = rng.random() < 0.9
            out = rows.stacked(values, padded, view)
            ref = (_stacked(values) if padded else np.array(values)) if values else \
                np.zeros((0,))
            assert out.dtype == ref.dtype and np.array_equal(out, ref)
            assert view or out.flags.writeable      # a final branch owns its arrays
            handed.append((out, out.copy()))
        assert all(np.array_equal(a, b) for a, b in handed)


def test_a_prefix_branch_is_the_truncated_one():
    """Recorder.branch(upto=n) (a point handed out once its verdict came, later than it was
    reached): the first n points with the folds, grazing points and loops found on them,
    as the same recorder truncated to n points gives; points waiting for a verdict are
    refused."""
    pb = sdof_problem(harmonics=10, fa=0.05)
    r0, r1 = 0.3 / RPM_TO_RAD_S, 1.6 / RPM_TO_RAD_S
    br = hbm.trace(pb, r0, r1, stability=False)
    assert len(br.folds) == 2 and len(br.grazing) == 2 and len(br) > 40
    meta = PointMonitor(pb, False).branch_meta()
    rec = Recorder(meta, pb.x_scale, r0, r1, br.omega_scale, br)
    n_all = len(br)
    for n in (1, 17, 28, 29, 45, n_all - 1, n_all):
        part = rec.branch("running", "", 0.01, upto=n)
        cut = Recorder(meta, pb.x_scale, r0, r1, br.omega_scale, br)
        cut.truncate(n)
        ref = cut.branch("running", "", 0.01)
        assert len(part) == n
        for k in POINT_FIELDS:
            assert np.array_equal(getattr(part, k), getattr(ref, k), equal_nan=True), (n, k)
        assert (part.folds, part.fold_index, part.loops) == (ref.folds, ref.fold_index,
                                                              ref.loops)
        assert [g.rpm for g in part.grazing] == [g.rpm for g in ref.grazing]
    rec.add(ticket="later", stats={k: v[-1] for k, v in br.stats.items()},
            **{k: getattr(br, k)[-1] for k in POINT_FIELDS})
    assert rec.settled_prefix() == n_all
    with pytest.raises(ValueError, match="hold their verdicts"):
        rec.branch("running", "", 0.01, upto=n_all + 1)
    rec.fill("later", stable=True)
    assert rec.settled_prefix() == n_all + 1
    assert len(rec.branch("running", "", 0.01, upto=n_all + 1)) == n_all + 1
