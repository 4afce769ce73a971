"""Craig–Bampton on small DOLFINx P2 elasticity boxes (clamped and free–free)."""

import math

import h5py
import numpy as np
import pytest
import scipy.linalg as sla
from petsc4py import PETSc

from reduction import (
    build_rom,
    craig_bampton,
    load_basis,
    load_rom,
    reconstruct,
    save_rom,
    validate_rom,
)

pytestmark = pytest.mark.fem

KM = 2e8  # mean mesh stiffness between the "gear" DOF [N/m]
G12 = np.array([0, 1, 0, 0, 0, 0, 0, -1, 0, 0, 0, 0], dtype=float)


@pytest.fixture(scope="module")
def clamped():
    from reduction.models import elastic_box

    return elastic_box(size=(0.3, 0.04, 0.04), cells=(8, 2, 2), clamped=True)


@pytest.fixture(scope="module")
def free():
    from reduction.models import elastic_box

    return elastic_box(size=(0.3, 0.04, 0.04), cells=(6, 1, 1), clamped=False)


def test_rom_converges_to_full_model(clamped):
    n_check = 12
    errs, validity = [], []
    for n_cm in (4, 12, 40):
        cb = craig_bampton(clamped.M, clamped.K, clamped.interface_dofs, n_modes=n_cm)
        rom = build_rom(cb, G12, KM)
        v = validate_rom(rom, clamped.M, clamped.K, clamped.interface_dofs, G12, KM, n_check)
        # Rayleigh–Ritz: ROM frequencies bound the full coupled ones from above
        assert np.all(v.rom_hz >= v.full_hz * (1 - 1e-9))
        errs.append(v.relative_error)
        validity.append(v.validity_hz)
        below = v.full_hz <= v.validity_hz
        assert np.all(v.relative_error[below] < 1e-3)
    errs = np.array(errs)
    assert np.all(np.diff(errs, axis=0) <= 1e-10)  # error never grows with n_CM
    assert validity[0] < validity[1] <= validity[2]
    assert errs[-1].max() < 1e-3  # 40 modes: all 12 checked modes within 0.1 %
    assert errs[0].max() > 1e-3


def test_free_free_keeps_six_rigid_modes(free):
    cb = craig_bampton(free.M, free.K, free.interface_dofs, n_modes=10)
    lam = sla.eigh(cb.K_r, cb.M_r, eigvals_only=True)
    assert np.all(np.abs(lam[:6]) < 1e-10 * lam[6])
    assert lam[6] > (2 * math.pi * 100.0) ** 2
    # with the mesh spring one rigid mode becomes elastic: 5 remain
    rom = build_rom(cb, G12, KM)
    assert np.count_nonzero(rom.frequencies_hz == 0.0) == 5
    assert np.all(rom.mesh_energy[:5] == 0.0)
    v = validate_rom(rom, free.M, free.K, free.interface_dofs, G12, KM, 8)
    np.testing.assert_array_equal(v.full_hz[:5], 0.0)
    assert np.all(v.relative_error[:8] < 1e-2)


def test_static_interface_load_is_exact(clamped):
    M, K, iface = clamped.M, clamped.K, clamped.interface_dofs
    cb = craig_bampton(M, K, iface, n_modes=6)
    fc = np.array([1.0, -2.0, 0.5, 0.3, 1.0, -1.0, 2.0, 0.0, 1.0, -0.5, -1.0, 0.7]) * 1e3
    f = K.createVecLeft()
    f.setValues(iface.astype(PETSc.IntType), fc)
    f.assemble()
    ksp = PETSc.KSP().create(K.getComm())
    ksp.setOperators(K)
    ksp.setType("preonly")
    ksp.getPC().setType("lu")
    ksp.getPC().setFactorSolverType("mumps")
    u_full = K.createVecRight()
    ksp.solve(f, u_full)
    q = np.linalg.solve(cb.K_r, np.concatenate([fc, np.zeros(cb.n_cm)]))
    u = reconstruct(cb.T, q)
    u.axpy(-1.0, u_full)
    assert u.norm() < 1e-9 * u_full.norm()
    # at the interface the ROM coordinates are the physical displacements
    r0, r1 = u_full.getOwnershipRange()
    own = [(k, d) for k, d in enumerate(iface) if r0 <= d < r1]
    for k, d in own:
        assert q[k] == pytest.approx(u_full.getArray()[d - r0], rel=1e-9)


def test_hdf5_roundtrip_and_reconstruction(clamped, tmp_path):
    cb = craig_bampton(clamped.M, clamped.K, clamped.interface_dofs, n_modes=8)
    rom = build_rom(cb, G12, KM, xi=0.02)
    rom.validation = validate_rom(rom, clamped.M, clamped.K, clamped.interface_dofs, G12, KM, 6)
    path = tmp_path / "rom.h5"
    save_rom(path, rom)
    assert [p.name for p in tmp_path.iterdir()] == ["rom.h5"]  # no temp file left
    back = load_rom(path)
    for name in ("M", "K", "C", "G", "frequencies_hz", "mesh_energy", "fixed_interface_hz"):
        np.testing.assert_array_equal(getattr(back, name), getattr(rom, name))
    assert back.gear_dof_names == rom.gear_dof_names and back.n_cm == 8
    with h5py.File(path, "r") as f:  # one mesh: the file keeps its 1-D G and scalar k̄
        assert f["rom/G"].shape == (rom.n_r,) and np.ndim(f["rom"].attrs["km_mean"]) == 0
    np.testing.assert_array_equal(back.validation.relative_error, rom.validation.relative_error)
    T = load_basis(path, row_range=cb.T.getOwnershipRange())
    q = np.random.default_rng(1).standard_normal(rom.n_r) * (1 + 0.5j)
    a_re, a_im = reconstruct(cb.T, q)
    b_re, b_im = reconstruct(T, q)
    b_re.axpy(-1.0, a_re)
    b_im.axpy(-1.0, a_im)
    assert b_re.norm() == 0.0 and b_im.norm() == 0.0


def test_interface_not_holding_rigid_motion_is_rejected(free):
    # one node (3 translations) cannot hold the 3 rotations of a free body: K_ii singular
    with pytest.raises(RuntimeError, match="K_ii is singular"):
        craig_bampton(free.M, free.K, free.interface_dofs[:3], n_modes=5)
