"""Run by tests/test_fem_housing.py under mpirun -n 1 and -n 2: the gearbox housing read
from STEP on rank 0 and distributed, distributing seats with masses, feet clamped; writes
the frequencies and the seat weights' areas and centroids as JSON."""

from __future__ import annotations

import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))


def main(step: str, out: str) -> None:
    import cad_support as cs
    from mpi4py import MPI

    import fem
    from core.files import atomic_write
    from geometry import CadPart, gmsh_session, import_cad, preset

    gb = cs.gearbox_script()
    p = gb.GearboxHousing()
    comm = MPI.COMM_WORLD
    with gmsh_session():
        model = None
        if comm.rank == 0:
            model = import_cad([CadPart("housing", step, unit="mm")], gb.seats(p),
                               [gb.feet_mount(p)],
                               preset("coarse", size=0.03, curvature_points=6))
        fe_mesh = fem.load_meshed_model(model, comm)
    seats = sorted(g for g in fe_mesh.groups if "/bore_" in g)
    weights = {s: fem.surface_weights(fe_mesh, s) for s in seats}
    spec = fem.housing_spec(fe_mesh, dict.fromkeys(seats, "distributing"),
                            {"housing/feet": fem.MountSupport()})
    for s in seats:
        spec.add_mass(s, fem.rigid_body_mass(2.0, [0.0, 0.0, 0.0]))
    m = fem.build_model(fe_mesh, {"housing": fem.CAST_IRON}, spec, quadrature_degree=2)
    f = fem.eigenfrequencies(m.K, m.M, 6)
    res = {"size": comm.size, "f": [float(x) for x in f],
           "areas": [weights[s].area for s in seats],
           "centroids": [weights[s].centroid.tolist() for s in seats]}
    if comm.rank == 0:
        with atomic_write(out, "w") as fh:
            fh.write(json.dumps(res))


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
