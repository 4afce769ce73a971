"""Lumped rotor parts on the pump's gears (``fem.RotorParams``, docs/theory.md §13.5).

Two independent routes to the same coupled spectrum: the rotors built into the FE model
(their own ``{s}/rotor`` node, inside the Craig–Bampton interior) and the same parts
added exactly on the physical gear DOF of the plain pump's ROM
(``benchmarks.grounded_gears.ground_gears``). Their coupled modes must agree to the
Craig–Bampton accuracy, which checks the node, its frame, the DOF each part acts on and
the spring between gear and rotor.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("dolfinx")
geometry = pytest.importorskip("geometry")

from mpi4py import MPI  # noqa: E402

import fem  # noqa: E402

pytestmark = pytest.mark.fem

KM = 235.3e6  # N/m, the ISO 6336 estimate of the pump's mean mesh stiffness (§13.1)
N_CM = 100


def _blank() -> tuple[float, float]:
    g = fem.GearParams()
    ro, ri = g.blank_outer_radius(1), g.bore_radius
    m = g.density * math.pi * (ro**2 - ri**2) * g.face_width
    return m, 0.5 * m * (ro**2 + ri**2)


M_G, J_G = _blank()
ROTORS = fem.RotorParams(inertia=30 * J_G, torsional_stiffness=2.4e6, gear_inertia=3 * J_G,
                         gear_mass=2.5 * M_G, lateral_stiffness=2.0e9)


@pytest.fixture(scope="module")
def fe_mesh() -> fem.FEMesh:
    with geometry.gmsh_session():
        meshed = None
        if MPI.COMM_WORLD.rank == 0:
            meshed = geometry.build_pump(geometry.PumpParams(), geometry.preset("coarse"))
        return fem.load_meshed_model(meshed, MPI.COMM_WORLD)


def test_rotor_params_refuse_a_rotor_without_its_spring() -> None:
    with pytest.raises(ValueError, match="rotors.inertia"):
        fem.RotorParams(inertia=0.05)
    with pytest.raises(ValueError, match=r"rotors.gear_mass = -1"):
        fem.RotorParams(gear_mass=-1.0)
    assert not fem.RotorParams().active


def test_rotors_in_the_fe_model_match_the_same_parts_added_on_the_rom(fe_mesh) -> None:
    from benchmarks.grounded_gears import ground_gears
    from reduction import coupled_modes, mesh_energy, reduce_fe_model

    plain = fem.build_pump_model(None, fe_mesh=fe_mesh)
    with_rotors = fem.build_pump_model(None, fe_mesh=fe_mesh, rotors=ROTORS)
    assert with_rotors.n_red == plain.n_red + 2  # one free rotation per rotor node
    assert set(with_rotors.node_dofs) - set(plain.node_dofs) == {"in/rotor", "out/rotor"}
    r_plain = reduce_fe_model(plain, KM, n_modes=N_CM)
    r_rot = reduce_fe_model(with_rotors, KM, n_modes=N_CM)

    M, K, G = ground_gears(r_plain.M, r_plain.K, r_plain.G, ROTORS.gear_inertia,
                           ROTORS.inertia, ROTORS.torsional_stiffness, ROTORS.gear_mass,
                           ROTORS.lateral_stiffness)
    M[2, 2] += ROTORS.gear_mass  # the rigid mass moves along the shaft axis too
    M[8, 8] += ROTORS.gear_mass
    f_ref = coupled_modes(M, K, G, KM).frequencies_hz
    f_fe = coupled_modes(r_rot.M, r_rot.K, r_rot.G, KM).frequencies_hz
    below = f_ref < 5000.0
    assert below.sum() > 20
    np.testing.assert_allclose(f_fe[: below.sum()], f_ref[below], rtol=1e-6)  # 6e-8 measured
    # the mesh mode that the parts were chosen for (§13.4: 4036 Hz, ρ 0.35)
    rho_ref, rho_fe = mesh_energy(M, K, G, KM), mesh_energy(r_rot.M, r_rot.K, r_rot.G, KM)
    j = int(np.argmax(np.where(f_ref > 1000.0, rho_ref, 0.0)))
    assert f_ref[j] == pytest.approx(4036.0, rel=2e-3)
    assert rho_fe[j] == pytest.approx(rho_ref[j], abs=1e-3)
