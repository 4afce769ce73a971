"""Stability of the accepted continuation points in worker processes (the other cores).

The continuation's stability verdict (:func:`hbm.stability.verdict.stability`, T.10) of a
point depends only on that point and on the dominant Floquet basis it starts the
subspace iteration from: that of the point measured ``stride`` points before it
(:func:`warm_stride`). A :class:`StabilityProcess` holds ``stride`` forked workers; point
``i`` goes to worker ``i mod stride``, which measures its points one after the other
keeping its last basis, that of point ``i - stride``: the same calls on the same data as
:class:`hbm.sweep.PointMonitor` makes in-line with the same stride, hence bitwise the same
verdicts (tests/test_hbm_stability_process.py), whatever the number of cores. The tracer
sends each point as it accepts it and collects the verdicts when it needs them (before
handing a point's branch out, at most :data:`hbm.continuation.tracer.MAX_LAG` points
later), so the Floquet exponents of several points are computed while the corrector
looks for the next ones. On the shipped pump (772 modes) the monodromy of a point takes
0.03-0.05 s where it is stable and 0.3-0.8 s near the resonances' unstable sheets, against
0.19 s for the corrector: with one worker the corrector waited half of the curve for it.

Fork only (Linux): the problem reaches the child by the fork, nothing is pickled but
the point's unknowns and the verdicts. Where fork is unavailable :func:`available` is
False and the tracer measures in-line.
"""

from __future__ import annotations

import logging
import multiprocessing as mp
import os
from collections import deque

import numpy as np

from ..problem import HBMProblem
from .verdict import Verdict
from .verdict import stability as point_stability

logger = logging.getLogger(__name__)

__all__ = ["StabilityProcess", "available", "wanted", "warm_stride"]

#: Workers (and warm-start stride) for a matrix-free problem: the large harmonic sets,
#: whose many-mode monodromies cost more than the corrector's steps.
MATRIX_FREE_STRIDE = 2


def warm_stride(problem: HBMProblem) -> int:
    """How many points back the stability of a point takes its warm start from, and how
    many workers measure a branch's points: :data:`MATRIX_FREE_STRIDE` for a matrix-free
    problem, else 1 (the previous point, in-line). A property of the problem, not of
    the machine, so that the verdicts do not depend on where they were computed."""
    return MATRIX_FREE_STRIDE if problem.matrix_free else 1


def available() -> bool:
    """True where a forked worker process can be used (the ``fork`` start method)."""
    return "fork" in mp.get_all_start_methods()


def wanted(problem: HBMProblem, stability: bool, asked: bool | None) -> bool:
    """Whether :func:`hbm.trace` measures the stability in a worker process: when asked
    (``asked`` True) and possible; by default (None) for a matrix-free problem (a large
    harmonic set, where a point's Newton work dwarfs the fork) on more than one core."""
    if not stability or asked is False or not available():
        return False
    return bool(asked) or (problem.matrix_free and (os.cpu_count() or 1) > 1)


def _serve(problem: HBMProblem, conn) -> None:
    """A worker: measure every point received, in order, warm-starting from the basis
    of the previous one it measured, until ``None`` arrives."""
    basis = None
    while True:
        msg = conn.recv()
        if msg is None:
            break
        unknowns, omega, iterations, residual, parity = msg
        try:
            pt = problem.point(unknowns, omega, iterations, residual)
            stab = point_stability(problem, pt, start=basis, parity=parity)
            if not np.isfinite(stab.exponents[0].real):
                raise ValueError(f"largest Floquet real part {stab.exponents[0].real}")
            basis = stab.basis
            conn.send(Verdict.of(stab))
        except Exception as exc:  # noqa: BLE001  (handed to the parent, raised there)
            conn.send(RuntimeError(f"stability at {omega:.6g} rad/s in the worker "
                                   f"process: {type(exc).__name__}: {exc}"))
    conn.close()


class StabilityProcess:
    """Forked worker processes measuring the stability of points; point ``i`` (in
    submission order) goes to worker ``i mod workers``.

    :meth:`submit` sends a point with a ticket; :meth:`collect` returns
    ``(ticket, Verdict)`` pairs in submission order, waiting for them or taking only
    those ready. :meth:`close` ends the processes (also on garbage collection).
    """

    def __init__(self, problem: HBMProblem, workers: int = 1) -> None:
        if workers < 1:
            raise ValueError(f"workers = {workers}: at least 1")
        ctx = mp.get_context("fork")
        self._conns, self._procs = [], []
        for k in range(workers):
            conn, child = ctx.Pipe()
            proc = ctx.Process(target=_serve, args=(problem, child), daemon=True,
                               name=f"hbm-stability-{k}")
            proc.start()
            child.close()
            self._conns.append(conn)
            self._procs.append(proc)
        self._sent = 0
        self._tickets: deque = deque()            # (ticket, worker) in submission order

    def submit(self, ticket, unknowns: np.ndarray, omega: float, iterations: int,
               residual: float, parity: bool | None) -> None:
        """Send one point (its unknowns, speed, corrector iterations and residual, and
        the fold parity the tracer knows, or None)."""
        worker = self._sent % len(self._conns)
        self._conns[worker].send((np.asarray(unknowns, dtype=float), float(omega),
                                  int(iterations), float(residual), parity))
        self._sent += 1
        self._tickets.append((ticket, worker))

    @property
    def pending(self) -> int:
        """Points sent whose verdict has not been collected."""
        return len(self._tickets)

    def collect(self, wait: bool = True, keep: int = 0) -> list[tuple[object, Verdict]]:
        """Verdicts received so far, in submission order; if ``wait``, waiting until at
        most ``keep`` remain pending.

        Raises
        ------
        RuntimeError
            If a worker failed on a point, or died.
        """
        out = []
        while self._tickets:
            ticket, worker = self._tickets[0]
            conn = self._conns[worker]
            if not ((wait and len(self._tickets) > keep) or conn.poll()):
                break
            try:
                v = conn.recv()
            except EOFError as exc:
                raise RuntimeError("a stability worker process died") from exc
            if isinstance(v, Exception):
                self._tickets.clear()
                raise v
            self._tickets.popleft()
            out.append((ticket, v))
        return out

    def close(self) -> None:
        """Stop the workers (pending verdicts are dropped)."""
        if not self._procs:
            return
        for conn in self._conns:
            try:
                conn.send(None)
            except (BrokenPipeError, OSError):
                pass
        for proc in self._procs:
            proc.join(timeout=10)
            if proc.is_alive():
                proc.terminate()
                proc.join()
        for conn in self._conns:
            conn.close()
        self._procs, self._conns = [], []

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:  # noqa: BLE001  (interpreter shutdown)
            pass
