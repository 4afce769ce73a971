"""core.processes.forked_map: the items computed over forked processes come back in
order, bitwise those computed in one process; an error in a child is raised with its
type and message; small counts stay in the calling process."""

import os

import numpy as np
import pytest

from core import processes

pytestmark = pytest.mark.skipif("fork" not in processes.mp.get_all_start_methods(),
                                reason="needs the fork start method")


def _item(i: int) -> np.ndarray:
    rng = np.random.default_rng(i)
    a = rng.standard_normal((40, 40))
    return np.linalg.solve(a @ a.T + np.eye(40), rng.standard_normal(40)) * (i + 1)


@pytest.mark.parametrize("workers", [2, 3])
def test_items_come_back_in_order_and_bitwise(workers):
    pids = processes.forked_map(lambda i: os.getpid(), 30, workers=workers)
    assert len(set(pids)) == workers and pids[0] == os.getpid()   # shares in order
    got = processes.forked_map(_item, 37, workers=workers)
    ref = [_item(i) for i in range(37)]
    assert len(got) == 37 and all(np.array_equal(a, b) for a, b in zip(got, ref,
                                                                       strict=True))


def test_a_failure_in_a_child_is_raised():
    def broken(i):
        if i == 25:
            raise ValueError("no radiation matrix")
        return i
    with pytest.raises(RuntimeError, match="items 20-39: ValueError: no radiation matrix"):
        processes.forked_map(broken, 40, workers=2)


def test_few_items_stay_in_the_calling_process():
    pids = processes.forked_map(lambda i: os.getpid(), 10, workers=4, min_items=8)
    assert set(pids) == {os.getpid()}
    assert processes.forked_map(lambda i: i, 0) == []


def test_the_cores_are_shared_among_mpi_ranks(monkeypatch):
    monkeypatch.setattr(processes.os, "cpu_count", lambda: 4)
    for k in processes._RANK_COUNTS:
        monkeypatch.delenv(k, raising=False)
    assert processes.fork_workers() == 4
    monkeypatch.setenv("OMPI_COMM_WORLD_SIZE", "2")
    assert processes.fork_workers() == 2
    monkeypatch.setenv("OMPI_COMM_WORLD_SIZE", "4")
    assert processes.fork_workers() == 1
