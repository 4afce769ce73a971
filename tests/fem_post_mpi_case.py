"""Run by tests/test_fem_post_fields.py in process and under mpirun -n 1 / -n 2: a
housing-like block (clamped feet, bore rigidly linked to a node) with a basis whose
rows are a function of their partition-independent keys, its ``housing.h5`` written in
blocks of a few nodes and its ``radiation.h5``."""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

N_R = 5


def block_model(h: float = 0.02):
    """The FE model of the block (volume ``housing``, feet clamped, bore on node ``c``)."""
    import fem_support as fs
    from mpi4py import MPI

    import fem

    comm = MPI.COMM_WORLD
    with fs.gmsh_session() as model:
        centres = fs.build_housing_block((0.12, 0.08, 0.06), 0.015, h, comm.rank)
        fe_mesh = fem.load_gmsh_mesh(model, comm, centres=centres)
    spec = fem.ModelSpec()
    spec.add_clamp("housing/feet")
    spec.add_node("c", fe_mesh.centres["bore"])
    spec.add_link("bore", "c")
    return fem.build_model(fe_mesh, {"housing": fs.STEEL_TEST}, spec)


def keyed_basis(model):
    """A dense PETSc basis (n_red × N_R) on ``model.K``'s rows: row of key k is
    ``cos(0.37 k (j + 1)) + j`` (the same on any partition)."""
    import numpy as np
    from petsc4py import PETSc

    keys = model.row_keys().astype(float)
    r0, r1 = model.K.getOwnershipRange()
    T = PETSc.Mat().createDense(((r1 - r0, model.K.getSize()[0]), (PETSc.DECIDE, N_R)),
                                comm=model.K.getComm())
    T.setUp()
    j = np.arange(N_R)
    T.getDenseArray()[:] = np.cos(0.37 * np.outer(keys, j + 1)) + j
    T.assemble()
    return T


def write_files(out: Path, block_bytes: int) -> None:
    from fem import post

    model = block_model()
    T = keyed_basis(model)
    PT = post.field_operator(model, T)
    post.housing_data(model, PT, out / post.HOUSING_FILE, block_bytes=block_bytes)
    post.radiation_data(model, PT, out / post.RADIATION_FILE)
    PT.destroy()


if __name__ == "__main__":
    write_files(Path(sys.argv[1]), int(sys.argv[2]))
