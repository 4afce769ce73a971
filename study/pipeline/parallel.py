"""The pipeline under ``mpirun``: one communicator, rank-0 sections whose outcome every
rank shares, and errors every rank agrees on (consistent exit codes).

``mpirun -n N geardyn run SCENE`` runs the distributed stages (FE assembly, Craig–Bampton,
housing reconstruction) on all ranks and the serial, cheap ones (gmsh meshing, the cache
bookkeeping, the HBM continuation, results.h5, plots, report) on rank 0; their result is
broadcast. Ranks other than 0 wait for a rank-0 section without spinning (a polled
non-blocking barrier), so they leave the cores to rank 0.

Launched without ``mpirun`` (or with ``-n 1``) :func:`world` returns a serial stand-in and
mpi4py is not imported: a lumped scene still loads none of the MPI/FE packages.

An exception raised in a rank-0 section is re-raised on every rank with the same type and
message and marked ``collective = True``; :func:`study.cli.main` then returns the same exit
code on every rank. Any other exception under MPI may have left the other ranks inside a
collective call, so the CLI aborts the job (``MPI_Abort``) with the exit code instead.
"""
from __future__ import annotations

import logging
import os
import time
from collections.abc import Callable
from typing import Any

logger = logging.getLogger(__name__)

__all__ = ["world", "launched_size", "Serial", "World", "mark_collective"]

_ENV_SIZE = ("OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_SIZE", "MPI_LOCALNRANKS")


def launched_size() -> int:
    """Number of ranks the launcher (mpirun/mpiexec) started, 1 without one."""
    for name in _ENV_SIZE:
        v = os.environ.get(name)
        if v and v.isdigit():
            return int(v)
    return 1


def mark_collective(exc: BaseException) -> BaseException:
    """Mark ``exc`` as raised identically on every rank (exit without ``MPI_Abort``)."""
    try:
        exc.collective = True  # type: ignore[attr-defined]
    except AttributeError:  # pragma: no cover - exceptions with __slots__
        pass
    return exc


def _rebuild(kind: type, message: str) -> BaseException:
    try:
        exc = kind(message)
    except Exception:  # noqa: BLE001 - a constructor with other arguments
        exc = RuntimeError(message)
    return mark_collective(exc)


class Serial:
    """The communicator of a run without mpirun: rank 0 of 1, every call local."""

    rank = 0
    size = 1
    mpi = None

    def root_call(self, fn: Callable[..., Any], *args, **kwargs) -> Any:
        """``fn(*args, **kwargs)``."""
        return fn(*args, **kwargs)

    def bcast(self, value: Any) -> Any:
        return value

    def barrier(self) -> None:
        pass


class World(Serial):
    """``MPI.COMM_WORLD`` with the pipeline's helpers.

    Parameters
    ----------
    comm : mpi4py.MPI.Comm
    poll : float
        Sleep between polls of a waiting rank [s].
    """

    def __init__(self, comm, poll: float = 0.02) -> None:
        self.mpi = comm
        self.rank = comm.rank
        self.size = comm.size
        self.poll = poll

    def barrier(self) -> None:
        """Barrier that sleeps instead of spinning (other ranks may be computing)."""
        req = self.mpi.Ibarrier()
        while not req.Test():
            time.sleep(self.poll)

    def bcast(self, value: Any) -> Any:
        """Rank 0's ``value`` on every rank (after an idle wait)."""
        self.barrier()
        return self.mpi.bcast(value if self.rank == 0 else None, root=0)

    def root_call(self, fn: Callable[..., Any], *args, **kwargs) -> Any:
        """Run ``fn`` on rank 0 only and return its value on every rank.

        If ``fn`` raises on rank 0, every rank raises an exception of the same type and
        message, marked collective (rank 0 re-raises the original one).
        """
        outcome: tuple = (True, None)
        if self.rank == 0:
            try:
                outcome = (True, fn(*args, **kwargs))
            except BaseException as exc:  # noqa: BLE001 - shared with the other ranks
                mark_collective(exc)
                self.bcast((False, (type(exc), str(exc))))
                raise
        ok, value = self.bcast(outcome)
        if not ok:
            raise _rebuild(*value)
        return value


_WORLD: Serial | None = None


def world() -> Serial:
    """The run's communicator: :class:`World` under mpirun with more than one rank,
    else :class:`Serial` (mpi4py not imported)."""
    global _WORLD
    if _WORLD is None:
        if launched_size() > 1:
            from mpi4py import MPI

            _WORLD = World(MPI.COMM_WORLD) if MPI.COMM_WORLD.size > 1 else Serial()
        else:
            _WORLD = Serial()
    return _WORLD
