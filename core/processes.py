"""Independent per-item work shared with forked processes (the other cores).

:func:`forked_map` returns ``[func(i) for i in range(n)]``: the items are cut into
contiguous shares, the calling process computes the first while forked children compute
the others, and the results come back through pipes in item order. Each item is computed
by the same call on the same data wherever it runs, so the results do not depend on the
number of processes (bitwise). The children get everything by the fork (nothing but the
results is pickled) and leave with ``os._exit`` (multiprocessing's fork start), so they
close no file the parent holds open. Where ``fork`` is missing, or one core is all there
is, the items are computed in the calling process.
"""
from __future__ import annotations

import multiprocessing as mp
import os
from collections.abc import Callable
from typing import Any

__all__ = ["forked_map", "fork_workers"]

#: Most processes :func:`forked_map` uses by default (the parent included).
MAX_WORKERS = 4


#: Variables in which MPI launchers give the number of ranks they started.
_RANK_COUNTS = ("OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_SIZE")


def fork_workers() -> int:
    """Processes available for :func:`forked_map`: the cores shared among the ranks an MPI
    launcher started (each rank forks its own), at most :data:`MAX_WORKERS`; 1 where
    ``fork`` is missing."""
    if "fork" not in mp.get_all_start_methods():
        return 1
    ranks = next((int(v) for v in (os.environ.get(k, "") for k in _RANK_COUNTS)
                  if v.isdigit() and int(v) > 0), 1)
    return max(1, min((os.cpu_count() or 1) // ranks, MAX_WORKERS))


def _share(func: Callable[[int], Any], start: int, stop: int, conn) -> None:
    """A child: compute its items and send them, or the error."""
    try:
        conn.send(("ok", [func(i) for i in range(start, stop)]))
    except Exception as exc:  # noqa: BLE001  (handed to the parent, raised there)
        conn.send(("error", f"{type(exc).__name__}: {exc}"))
    finally:
        conn.close()


def forked_map(func: Callable[[int], Any], n: int, workers: int | None = None,
               min_items: int = 8) -> list[Any]:
    """``[func(i) for i in range(n)]`` over ``workers`` processes (default
    :func:`fork_workers`), each taking a contiguous share of at least ``min_items``.

    Raises
    ------
    RuntimeError
        If an item failed in a child (its error type and message), or a child died.
    """
    workers = fork_workers() if workers is None else max(1, int(workers))
    workers = min(workers, max(1, n // max(1, min_items)))
    if workers <= 1 or "fork" not in mp.get_all_start_methods():
        return [func(i) for i in range(n)]
    ctx = mp.get_context("fork")
    bounds = [round(k * n / workers) for k in range(workers + 1)]
    children = []
    try:
        for k in range(1, workers):
            receive, send = ctx.Pipe(duplex=False)
            proc = ctx.Process(target=_share, args=(func, bounds[k], bounds[k + 1], send),
                               daemon=True, name=f"forked-map-{k}")
            proc.start()
            send.close()
            children.append((proc, receive))
        out = [func(i) for i in range(bounds[0], bounds[1])]
        for k, (_, receive) in enumerate(children, start=1):
            try:
                status, value = receive.recv()
            except EOFError as exc:
                raise RuntimeError(f"items {bounds[k]}-{bounds[k + 1] - 1}: the process "
                                   "computing them died") from exc
            if status != "ok":
                raise RuntimeError(f"items {bounds[k]}-{bounds[k + 1] - 1}: {value}")
            out.extend(value)
        return out
    finally:
        for proc, receive in children:
            receive.close()
            proc.join(timeout=10)
            if proc.is_alive():
                proc.terminate()
                proc.join()
