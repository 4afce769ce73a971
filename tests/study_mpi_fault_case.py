"""Run by tests/test_study_mpi.py under mpirun -n 2: ``geardyn`` with a failure injected
on rank 1 only, while rank 0 goes on into the distributed FE stages."""
from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def main(argv: list[str]) -> int:
    from mpi4py import MPI

    import study.pipeline as sp
    from study.cli import main as geardyn

    run_rom = sp.Pipeline.run_rom

    def faulty(self):
        if MPI.COMM_WORLD.rank == 1:
            raise RuntimeError("injected failure on rank 1")
        return run_rom(self)

    sp.Pipeline.run_rom = faulty
    return geardyn(argv)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
