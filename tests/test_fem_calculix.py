"""First 10 frequencies of DOLFINx (quadrature degree 2) against CalculiX C3D10 on
the very same gmsh tet10 mesh. Measured agreement: ~1e-7 relative, the print
precision of CalculiX's .dat file."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

pytest.importorskip("dolfinx")

import fem_support as fs  # noqa: E402
from mpi4py import MPI  # noqa: E402

import fem  # noqa: E402
from fem import calculix  # noqa: E402

pytestmark = [
    pytest.mark.fem,
    pytest.mark.skipif(shutil.which("ccx") is None, reason="CalculiX (calculix-ccx) missing"),
]


def _compare(build: object, materials: dict, clamps: list[str], tmp_path: object) -> None:
    import gmsh

    comm = MPI.COMM_WORLD
    with fs.gmsh_session():
        build()
        f_ccx = None
        if comm.rank == 0:
            groups = fem.gmsh_physical_groups(gmsh.model)
            f_ccx = calculix.run_frequency(gmsh.model, materials, groups, clamps, 10, tmp_path)
        fe_mesh = fem.load_gmsh_mesh(gmsh.model, comm)
    f_ccx = comm.bcast(f_ccx)
    spec = fem.ModelSpec()
    for c in clamps:
        spec.add_clamp(c)
    m = fem.build_model(fe_mesh, materials, spec, quadrature_degree=2)
    f = fem.eigenfrequencies(m.K, m.M, 10, sigma=0.0)
    rel = np.abs(f / f_ccx - 1)
    assert rel.max() < 1e-4, (f, f_ccx)


def test_clamped_cylinder_matches_calculix(tmp_path: object) -> None:
    mats = {"shaft": fem.Material(210e9, 0.3, 7800.0)}
    _compare(lambda: fs.build_cylinder(0.2, 0.01, 0.01), mats, ["end_a"], tmp_path)


def test_coarse_pump_shaft_matches_calculix(tmp_path: object) -> None:
    geometry = pytest.importorskip("geometry")
    mats = {"shaft_in": fem.STEEL}

    def build() -> None:
        if MPI.COMM_WORLD.rank == 0:
            geometry.build_single_shaft(name="in", mesh_options=geometry.preset("coarse"))

    _compare(build, mats, ["in/coupling"], tmp_path)


def test_coarse_housing_matches_calculix(tmp_path: object) -> None:
    geometry = pytest.importorskip("geometry")
    mats = {"housing": fem.CAST_IRON}

    def build() -> None:
        if MPI.COMM_WORLD.rank == 0:
            meshed = geometry.build_pump(geometry.PumpParams(), geometry.preset("coarse"))
            fs.keep_only_housing(meshed)

    _compare(build, mats, ["housing/feet"], tmp_path)


def test_c3d10_node_order_swaps_last_two_mid_edge_nodes() -> None:
    # gmsh tet10 mid-edge order: 01 12 20 03 23 13; C3D10: 01 12 20 03 13 23
    gmsh_edges = [(0, 1), (1, 2), (2, 0), (0, 3), (2, 3), (1, 3)]
    c3d10_edges = [(0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3)]
    perm = calculix.TET10_TO_C3D10[4:] - 4
    assert [gmsh_edges[i] for i in perm] == c3d10_edges
