"""The pump model of the contract (geometry.build_pump, coarse): named nodes, gear DOF
and G, the single free drivetrain rotation, and the static load path of the drive
(docs/theory.md section 3) with the mean mesh stiffness k_m G G^T added."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("dolfinx")
geometry = pytest.importorskip("geometry")

from mpi4py import MPI  # noqa: E402

import fem  # noqa: E402
from gears.pair import line_of_action_vector  # noqa: E402

pytestmark = pytest.mark.fem


@pytest.fixture(scope="module")
def pump() -> fem.FEModel:
    with geometry.gmsh_session():
        meshed = None
        if MPI.COMM_WORLD.rank == 0:
            meshed = geometry.build_pump(geometry.PumpParams(), geometry.preset("coarse"))
        return fem.build_pump_model(meshed)


def test_contract_nodes_and_gear_dofs(pump: fem.FEModel) -> None:
    names = set(pump.node_dofs)
    for s in ("in", "out"):
        expected = {f"{s}/gear", f"{s}/bearing_a", f"{s}/bearing_b", f"{s}/coupling",
                    f"housing/bore_{s}_a", f"housing/bore_{s}_b"}  # fmt: skip
        expected |= {f"{s}/station_{k}" for k in range(1, 7)}
        assert expected <= names
    idx = np.concatenate(list(pump.node_dofs.values()))
    assert np.all(idx >= 0) and np.unique(idx).size == idx.size
    np.testing.assert_array_equal(
        pump.gear_dofs, np.concatenate([pump.node_dofs["in/gear"], pump.node_dofs["out/gear"]])
    )
    # the gear bodies' DOF by name, one mesh: G has one column
    assert pump.gear_nodes == ("in/gear", "out/gear")
    assert list(pump.gear_body_dofs) == ["in/gear", "out/gear"]
    np.testing.assert_array_equal(np.concatenate(list(pump.gear_body_dofs.values())),
                                  pump.gear_dofs)
    assert pump.G.shape == (12, 1) and pump.n_meshes == 1
    g = fem.GearParams()
    np.testing.assert_allclose(pump.G[:, 0], [0, 1, 0, 0, 0, g.base_radius_1,
                                              0, -1, 0, 0, 0, g.base_radius_2], atol=1e-18)
    # the model's G is the pair's line-of-action vector of gears, bitwise
    G = line_of_action_vector(g.pressure_angle, g.helix_angle, g.base_radius_1, g.base_radius_2)
    np.testing.assert_array_equal(pump.G[:, 0], G)
    assert pump.info["clamped"] > 0


def _eq11_before_gears(alpha: float, beta: float, rb1: float, rb2: float) -> np.ndarray:
    """eq. (11) as fem/frames.py computed it before the gears package took it over, with
    the θ_x' entries' sign corrected since (docs/theory.md §1; spur pairs unchanged)."""
    ta, tb = math.tan(alpha), math.tan(beta)
    return np.array([0.0, 1.0, tb, -rb1 * ta * tb, -rb1 * tb, rb1,
                     0.0, -1.0, -tb, -rb2 * ta * tb, -rb2 * tb, rb2])


@pytest.mark.parametrize("scene", ["pump.toml", "pump-paper.toml"])
def test_pump_g_from_the_scene_is_gears_line_of_action_vector(scene: str) -> None:
    """The scene's gear data reach fem.GearParams (machines.pump.params); their G is
    gears.line_of_action_vector of the same numbers and the pre-gears eq. (11), bitwise,
    and the pump machine's mesh vector is that G."""
    from machines import machine_for
    from machines.pump import fe_parameters
    from study.scene import load_scene

    s = load_scene(Path(__file__).resolve().parents[1] / "scenes" / scene)
    g = fe_parameters(s.fe, s.gear).gears
    args = (s.gear.pressure_angle, s.gear.helix_angle, s.gear.base_radius, s.gear.base_radius)
    assert (g.pressure_angle, g.helix_angle, g.base_radius_1, g.base_radius_2) == args
    np.testing.assert_array_equal(g.G(), line_of_action_vector(*args))
    np.testing.assert_array_equal(g.G(), _eq11_before_gears(*args))
    machine = machine_for(s)
    np.testing.assert_array_equal(machine.gear_meshes[0].vector, g.G())
    np.testing.assert_array_equal(machine.directions(), g.G()[:, None])
    for beta in (0.1, -0.3):          # helical entries too
        np.testing.assert_array_equal(
            fem.GearParams(helix_angle=beta).G(),
            _eq11_before_gears(g.pressure_angle, beta, 46.984e-3, 46.984e-3))


def _with_mesh_stiffness(pump: fem.FEModel, km: float) -> object:
    from petsc4py import PETSc

    K = pump.K.copy()
    K.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, False)
    if pump.comm.rank == 0:
        idx = pump.gear_dofs.astype(PETSc.IntType)
        K.setValues(idx, idx, km * np.outer(pump.G, pump.G), addv=PETSc.InsertMode.ADD_VALUES)
    K.assemble()
    return K


def test_one_free_rotation_removed_by_the_mesh(pump: fem.FEModel) -> None:
    f = fem.eigenfrequencies(pump.K, pump.M, 3, sigma=-1e3)
    # only the output shaft's rotation is free (held by the gear mesh alone); the
    # double-precision floor of a rigid mode is ~1e-3 Hz (see test_fem_links)
    assert abs(f[0]) < 5e-6 * f[1] and f[1] > 10.0
    K = _with_mesh_stiffness(pump, 2e8)
    f_m = fem.eigenfrequencies(K, pump.M, 3, sigma=-1e3)
    assert f_m[0] > 10.0


def test_static_drive_load_path(pump: fem.FEModel) -> None:
    """Torque T on in/coupling and +T rb2/rb1 on out/coupling about +z: the mesh
    carries F = T / rb1 and the motor spring no torque (docs/theory.md section 3)."""
    from petsc4py import PETSc

    km, T = 2e8, 2.5
    g = fem.GearParams()
    K = _with_mesh_stiffness(pump, km)
    f = K.createVecRight()
    if pump.comm.rank == 0:
        f.setValue(int(pump.node_dofs["in/coupling"][5]), T, addv=PETSc.InsertMode.ADD_VALUES)
        f.setValue(int(pump.node_dofs["out/coupling"][5]), T * g.base_radius_2 / g.base_radius_1,
                   addv=PETSc.InsertMode.ADD_VALUES)  # fmt: skip
    f.assemble()
    ksp = PETSc.KSP().create(pump.comm)
    ksp.setOperators(K)
    ksp.setType("preonly")
    ksp.getPC().setType("lu")
    ksp.getPC().setFactorSolverType("mumps")
    q = K.createVecRight()
    ksp.solve(f, q)
    scatter, q0 = PETSc.Scatter.toZero(q)
    scatter.scatter(q, q0)
    if pump.comm.rank == 0:
        arr = q0.getArray()
        mesh_force = km * pump.G[:, 0] @ arr[pump.gear_dofs]
        assert abs(mesh_force / (T / g.base_radius_1) - 1) < 1e-8
        motor_torque = fem.DriveParams().motor_torsional_stiffness * arr[
            pump.node_dofs["in/coupling"][5]]
        assert abs(motor_torque) < 1e-8 * T
        # the input shaft twists: gear 1 lags the (unloaded-spring) coupling end
        assert arr[pump.gear_dofs[5]] < arr[pump.node_dofs["in/coupling"][5]]
        assert math.isfinite(mesh_force) and mesh_force > 0
