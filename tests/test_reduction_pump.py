"""Craig–Bampton ROM of the coarse pump (geometry + fem), checked against the full model."""

import math

import numpy as np
import pytest
import scipy.linalg as sla
from petsc4py import PETSc

pytest.importorskip("dolfinx")

pytestmark = pytest.mark.fem

KM = 3e8  # mean mesh stiffness [N/m]
N_CM = 60
N_CHECK = 30


@pytest.fixture(scope="module")
def pump():
    import fem
    import geometry
    from reduction import reduce_fe_model

    meshed = geometry.build_pump()
    model = fem.build_pump_model(meshed)
    rom = reduce_fe_model(model, KM, n_modes=N_CM, n_check=N_CHECK)
    return model, rom


def test_pump_rom_converges_to_full_model(pump):
    from reduction import coupled_modes
    from reduction.validate import compare

    model, rom = pump
    v = rom.validation
    assert np.all(v.rom_hz >= v.full_hz * (1 - 1e-9))  # Rayleigh–Ritz upper bounds
    assert np.all(v.relative_error[v.full_hz <= v.validity_hz] < 1e-3)
    assert v.validity_hz > 3000.0
    # truncating η gives the CB model with fewer modes: errors shrink as n_CM grows
    worst, valid = [], []
    for n_cm in (5, 15, 30, N_CM):
        k = 12 + n_cm
        f = coupled_modes(rom.M[:k, :k], rom.K[:k, :k], rom.G[:k], KM).frequencies_hz
        n = min(N_CHECK, k)
        c = compare(v.full_hz[:n], f[:n], 1e-3)
        worst.append(c.relative_error[:12].max())
        valid.append(c.validity_hz)
    assert all(a >= b for a, b in zip(worst, worst[1:], strict=False))
    assert all(a <= b for a, b in zip(valid, valid[1:], strict=False))
    assert worst[0] > 1e-3 > worst[-1]


def test_pump_rigid_mode_and_mesh_energy(pump):
    model, rom = pump
    # the output shaft turns freely until the mesh is added: exactly one rigid mode
    lam = sla.eigh(rom.K, rom.M, eigvals_only=True)
    assert abs(lam[0]) < 1e-9 * lam[1] and lam[1] > (2 * math.pi * 10.0) ** 2
    assert np.count_nonzero(rom.frequencies_hz == 0.0) == 0  # the mesh removes it
    # eq. (31) without clipping: km (Gᵀφ)² / ω² for mass-normalised φ, in [0, 1]
    lam_c, phi = sla.eigh(rom.K + KM * np.outer(rom.G, rom.G), rom.M)
    rho = KM * (rom.G[:, 0] @ phi) ** 2 / lam_c
    assert np.all(rho >= 0) and np.all(rho <= 1 + 1e-10)
    np.testing.assert_allclose(rom.mesh_energy, rho, atol=1e-10)
    assert rho.max() > 0.05  # some modes do load the mesh


def test_pump_static_mesh_load_is_exact(pump):
    from reduction import add_mesh_coupling, reconstruct

    model, rom = pump
    Kc = add_mesh_coupling(model.K, model.gear_dofs, model.G, KM)
    fc = 100.0 * model.G[:, 0] + np.array([5.0, 0, -3.0, 0.1, 0, 0, 0, 2.0, 0, 0, 0.2, 0])
    f = Kc.createVecLeft()
    f.setValues(np.asarray(model.gear_dofs, dtype=PETSc.IntType), fc)
    f.assemble()
    ksp = PETSc.KSP().create(Kc.getComm())
    ksp.setOperators(Kc)
    ksp.setType("preonly")
    ksp.getPC().setType("lu")
    ksp.getPC().setFactorSolverType("mumps")
    u_full = Kc.createVecRight()
    ksp.solve(f, u_full)
    f_r = np.concatenate([fc, np.zeros(rom.n_cm)])
    q = np.linalg.solve(rom.K + KM * np.outer(rom.G, rom.G), f_r)
    u = reconstruct(rom.T, q)
    u.axpy(-1.0, u_full)
    assert u.norm() < 1e-8 * u_full.norm()
