"""Stability of the accepted continuation points in a second process (the second core).

The continuation's stability verdict (:func:`hbm.stability.verdict.stability`, T.10) of a
point depends only on that point and on the dominant Floquet basis of the point measured
before it (the warm start of the subspace iteration). A :class:`StabilityProcess` is a
forked process that measures the points it is sent one after the other, in the order
they were sent, keeping that basis itself: the same calls on the same data in the same
order as :class:`hbm.sweep.PointMonitor` makes in-line, hence bitwise the same verdicts
(tests/test_hbm_stability_process.py). The tracer sends each point as it accepts it and
collects the verdicts when it needs them (before handing out a branch), so the Floquet
exponents of point i are computed while the corrector looks for point i + 1.

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

__all__ = ["StabilityProcess", "available", "wanted"]


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
    """The worker: measure every point received, in order, warm-starting from the basis
    of the previous one, until ``None`` arrives."""
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
    """A forked process measuring the stability of points in submission order.

    :meth:`submit` sends a point with a ticket; :meth:`collect` returns
    ``(ticket, Verdict)`` pairs in submission order, waiting for all of them or taking
    only those ready. :meth:`close` ends the process (also on garbage collection).
    """

    def __init__(self, problem: HBMProblem) -> None:
        ctx = mp.get_context("fork")
        self._conn, child = ctx.Pipe()
        self._proc = ctx.Process(target=_serve, args=(problem, child), daemon=True,
                                 name="hbm-stability")
        self._proc.start()
        child.close()
        self._tickets: deque = deque()

    def submit(self, ticket, unknowns: np.ndarray, omega: float, iterations: int,
               residual: float, parity: bool | None) -> None:
        """Send one point (its unknowns, speed, corrector iterations and residual, and
        the fold parity the tracer knows, or None)."""
        self._conn.send((np.asarray(unknowns, dtype=float), float(omega), int(iterations),
                         float(residual), parity))
        self._tickets.append(ticket)

    @property
    def pending(self) -> int:
        """Points sent whose verdict has not been collected."""
        return len(self._tickets)

    def collect(self, wait: bool = True) -> list[tuple[object, Verdict]]:
        """Verdicts received so far, in submission order; all pending ones if ``wait``.

        Raises
        ------
        RuntimeError
            If the worker failed on a point, or died.
        """
        out = []
        while self._tickets and (wait or self._conn.poll()):
            try:
                v = self._conn.recv()
            except EOFError as exc:
                raise RuntimeError("the stability worker process died") from exc
            if isinstance(v, Exception):
                self._tickets.clear()
                raise v
            out.append((self._tickets.popleft(), v))
        return out

    def close(self) -> None:
        """Stop the worker (pending verdicts are dropped)."""
        if self._proc is None:
            return
        try:
            self._conn.send(None)
        except (BrokenPipeError, OSError):
            pass
        self._proc.join(timeout=10)
        if self._proc.is_alive():
            self._proc.terminate()
            self._proc.join()
        self._conn.close()
        self._proc = None

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:  # noqa: BLE001  (interpreter shutdown)
            pass
