"""Run by tests/test_fem_mpi.py under mpirun -n 1 and -n 2: builds a small model with
every fem feature and writes its frequencies and a reconstruction norm as JSON."""

from __future__ import annotations

import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))


def main(out: str) -> None:
    import fem_support as fs
    import numpy as np
    import ufl
    from dolfinx import fem as dfem
    from mpi4py import MPI

    import fem
    from core.files import atomic_write
    from gears.pair import pair_frame

    comm = MPI.COMM_WORLD
    with fs.gmsh_session() as model:
        centres = fs.build_cylinder(0.2, 0.01, 0.008, comm.rank)
        fe_mesh = fem.load_gmsh_mesh(model, comm, centres=centres)
    spec = fem.ModelSpec()
    spec.add_clamp("end_a")
    spec.add_node("b", fe_mesh.centres["end_b"], frame=pair_frame(0.349))
    spec.add_link("end_b", "b")
    spec.add_mass("b", fem.disk_mass(0.05, 0.016, 0.02, 7850.0))
    spec.add_node("c", [0.05, 0.0, 0.2])
    spec.add_mass("c", fem.rigid_body_mass(0.3, [1e-4, 1e-4, 2e-4]))
    spec.add_spring("b", fem.axial_spring(1e7, 5e6, 1e3, 1e3), other="c")
    m = fem.build_model(fe_mesh, {"shaft": fs.STEEL_TEST}, spec)
    f = fem.eigenfrequencies(m.K, m.M, 10, sigma=0.0)
    q = m.rigid_motion([1e-3, 2e-3, 0.0], [0.01, 0.02, 0.03], [0.0, 0.0, 0.0])
    u = m.displacement(q)
    u2 = comm.allreduce(dfem.assemble_scalar(dfem.form(ufl.inner(u, u) * ufl.dx)), op=MPI.SUM)
    kq = m.K.createVecLeft()
    m.K.mult(q, kq)
    res = {"size": comm.size, "f": [float(x) for x in f], "u2": float(u2),
           "kq": float(kq.norm()), "n_red": int(m.n_red),
           "gear_node": [int(i) for i in m.node_dofs["b"]],
           **distributing_case(fe_mesh)}  # fmt: skip
    if comm.rank == 0:
        with atomic_write(out, "w") as fh:
            fh.write(json.dumps(res))
    np.testing.assert_array_less(0, f)


def distributing_case(fe_mesh: object) -> dict:
    """The clamped shaft with distributing links on the free end (gear frame, a fixed
    DOF) and on the side (shares the end's rim): frequencies, rigid-motion residual."""
    import fem_support as fs
    import numpy as np

    import fem
    from gears.pair import pair_frame

    spec = fem.ModelSpec()
    spec.add_clamp("end_a")
    spec.add_node("b", fe_mesh.centres["end_b"], frame=pair_frame(0.349),
                  fixed=np.array([False] * 4 + [True, False]))
    spec.add_link("end_b", "b", kind="distributing")
    spec.add_mass("b", fem.disk_mass(0.05, 0.016, 0.02, 7850.0))
    spec.add_node("s", [0.0, 0.0, 0.1])
    spec.add_link("side", "s", kind="distributing")
    spec.add_mass("s", fem.rigid_body_mass(0.2, [1e-4, 1e-4, 2e-4]))
    m = fem.build_model(fe_mesh, {"shaft": fs.STEEL_TEST}, spec)
    f = fem.eigenfrequencies(m.K, m.M, 10, sigma=0.0)
    return {"f_dist": [float(x) for x in f], "n_red_dist": int(m.n_red),
            "linked_dist": int(m.info["linked"])}


if __name__ == "__main__":
    main(sys.argv[1])
