"""Stability measured in a worker process (hbm/stability/process.py): the branch is
bitwise the one measured in-line, every branch handed to ``on_point`` carries the
verdicts, and a failure in the worker reaches the caller."""

import numpy as np
import pytest

import hbm
from hbm.basis import HarmonicSet
from hbm.stability import process as stability_process

Z = 20
RPM = hbm.RPM_TO_RAD_S

pytestmark = pytest.mark.skipif(not stability_process.available(),
                                reason="needs the fork start method")


def _pair():
    """Unit-mass gear pair with impacts, matrix-free (as tests/test_hbm_krylov.py)."""
    system = hbm.LinearSystem(M=[[1.0]], C=[[0.1]], K=[[0.0]])
    mesh = hbm.GearMesh(direction=[1.0], n_teeth=Z, stiffness={0: 1.0, 1: 0.2}, te={},
                        backlash=1.0)
    exc = hbm.Excitation(1, constant={0: [0.1], 2: [0.04], 5: [0.06]})
    hs = HarmonicSet(range(3 * Z + 11), fundamental="shaft")
    return hbm.HBMProblem(system, [mesh], exc, hs, "loa", linear_solver="krylov")


def _trace(process: bool, seen: list):
    def on_point(br):
        seen.append((len(br), br.stable.copy(), br.floquet_max_real.copy(), br.step_cuts))
    return hbm.trace(_pair(), 0.3 / Z / RPM, 0.06 / RPM, max_points=80, on_point=on_point,
                     stability=True, stability_process=process)


@pytest.fixture(scope="module")
def both():
    seen_inline: list = []
    seen_process: list = []
    return (_trace(False, seen_inline), seen_inline, _trace(True, seen_process),
            seen_process)


def test_the_branch_is_bitwise_the_in_line_one(both):
    inline, _, proc, _ = both
    assert len(inline) == len(proc) > 20
    assert not np.all(inline.stable) and np.any(inline.stable)    # both verdicts occur
    for k in ("stable", "floquet_max_real", "floquet_kind", "stability_consistent", "rpm",
              "unknowns"):
        assert np.array_equal(getattr(inline, k), getattr(proc, k)), k
    assert np.array_equal(inline.element(0).mesh_load_std, proc.element(0).mesh_load_std)
    assert (inline.folds, inline.status, inline.step_cuts) == \
        (proc.folds, proc.status, proc.step_cuts)


def test_on_point_gets_the_same_branches_with_their_verdicts(both):
    _, seen_inline, _, seen_process = both
    assert [s[0] for s in seen_inline] == [s[0] for s in seen_process]
    for a, b in zip(seen_inline, seen_process, strict=True):
        assert np.all(np.isfinite(b[2]))                      # no placeholder left
        assert np.array_equal(a[1], b[1]) and np.array_equal(a[2], b[2])
        assert a[3] == b[3]                                   # counters of that point


def test_a_failure_in_the_worker_is_raised(monkeypatch):
    def broken(*args, **kwargs):
        raise np.linalg.LinAlgError("no convergence")
    # the worker is forked after the patch: it inherits it
    monkeypatch.setattr(stability_process, "point_stability", broken)
    pb = _pair()
    worker = stability_process.StabilityProcess(pb)
    try:
        worker.submit(0, np.zeros(pb.n_unknowns), 1.0, 0, 0.0, None)
        with pytest.raises(RuntimeError, match="worker process: LinAlgError: no convergence"):
            worker.collect()
        assert worker.pending == 0
    finally:
        worker.close()


def test_a_matrix_free_problem_has_two_workers_and_the_stride_two():
    # the bitwise test above then covers two workers against in-line with stride 2
    assert stability_process.warm_stride(_pair()) == 2
    pb = _pair()
    worker = stability_process.StabilityProcess(pb, workers=2)
    try:
        assert len(worker._procs) == 2
    finally:
        worker.close()


def test_collect_waits_down_to_keep_in_submission_order():
    inline = hbm.trace(_pair(), 0.3 / Z / RPM, 0.06 / RPM, max_points=12, stability=True,
                       stability_process=False)
    pb = _pair()
    worker = stability_process.StabilityProcess(pb, workers=2)
    try:
        for i in range(6):
            worker.submit(("t", i), inline.unknowns[i], inline.omega[i], 1, 0.0, None)
        got = worker.collect(wait=True, keep=2)        # and any other already there
        assert [t for t, _ in got] == [("t", i) for i in range(len(got))]
        assert len(got) >= 4 and worker.pending == 6 - len(got)
        got += worker.collect(wait=True)
        assert [t for t, _ in got] == [("t", i) for i in range(6)] and worker.pending == 0
    finally:
        worker.close()


def test_slow_workers_hand_out_every_point_in_order_with_its_verdicts(monkeypatch):
    """Verdicts that come many points late (a costly monodromy): each point's branch is
    handed out once, in order, as in-line, while the corrector went on."""
    import time

    seen_inline: list = []
    inline = _trace(False, seen_inline)
    measure = stability_process.point_stability

    def slow(*args, **kwargs):
        time.sleep(0.05)
        return measure(*args, **kwargs)
    monkeypatch.setattr(stability_process, "point_stability", slow)   # forked: inherited
    seen: list = []
    proc = _trace(True, seen)
    assert np.array_equal(inline.floquet_max_real, proc.floquet_max_real)
    assert [s[0] for s in seen] == [s[0] for s in seen_inline]
    for a, b in zip(seen_inline, seen, strict=True):
        assert np.array_equal(a[1], b[1]) and np.array_equal(a[2], b[2]) and a[3] == b[3]
