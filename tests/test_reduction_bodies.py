"""Craig–Bampton keeps 6 DOF per gear body, any number of bodies and meshes: three gear
bodies A, B, C meshing A–B and B–C (an idler), checked against a direct eigen-solve of
the full model with both mesh couplings (eq. 17 summed over the meshes)."""
from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg as sla
from petsc4py import PETSc

from gears.pair import line_of_action_vector
from reduction import (
    add_mesh_coupling,
    build_rom,
    couple,
    coupled_modes,
    craig_bampton,
    gear_body_dof_names,
    load_rom,
    mesh_energy,
    modal_damping,
    reduce_fe_model,
    save_rom,
    validate_rom,
)

N_S = 36                      # elastic structure DOF (a grounded spring chain)
BODY_AT = (0, 10, 24)         # each body's 6 DOF are joined to these chain DOF onwards
KM = (2.0e8, 1.5e8)           # mean stiffness of the meshes A–B and B–C (N/m)


def _vectors() -> np.ndarray:
    """(18, 2): eq. (11) of A–B on the DOF of A, B and of B–C on those of B, C."""
    G = np.zeros((18, 2))
    G[:12, 0] = line_of_action_vector(math.radians(20), 0.0, 0.03, 0.05)
    G[6:, 1] = line_of_action_vector(math.radians(20), math.radians(10), 0.05, 0.04)
    return G


def _dense_model() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(M, K, interface): 3 bodies (18 DOF, first), a chain of N_S DOF each body is joined
    to by springs on all 6 DOF, and one isolated stiff DOF (last).

    SLEPc gives at most n_i − 1 fixed-interface modes: the one left out is the isolated
    DOF's (the highest, joined to nothing), so the ROM keeps every mode that couples and
    is exact; the full model has that one frequency more."""
    n = 18 + N_S + 1
    rng = np.random.default_rng(3)
    M = np.zeros((n, n))
    K = np.zeros((n, n))

    def spring(i: int, j: int | None, k: float) -> None:
        K[i, i] += k
        if j is not None:
            K[j, j] += k
            K[i, j] -= k
            K[j, i] -= k

    for b in range(3):
        m, inertia = 1.0 + b, 2e-3 * (1.0 + b)
        M[6 * b:6 * b + 6, 6 * b:6 * b + 6] = np.diag([m, m, m, inertia, inertia,
                                                        2 * inertia])
        for d in range(6):
            spring(6 * b + d, 18 + BODY_AT[b] + d, (1e7 if d < 3 else 1e4) * (1 + rng.random()))
    s = np.arange(18, 18 + N_S)
    M[s, s] = 0.2 + rng.random(N_S)
    for i in range(N_S - 1):
        spring(s[i], s[i + 1], 5e7 * (1 + rng.random()))
    spring(s[0], None, 5e7)
    spring(s[-1], None, 5e7)
    M[-1, -1] = 1.0
    spring(n - 1, None, 1e6 * np.abs(K).max())
    return M, K, np.arange(18)


def _petsc(A: np.ndarray) -> PETSc.Mat:
    n = A.shape[0]
    P = PETSc.Mat().createAIJ((n, n), comm=PETSc.COMM_WORLD)
    P.setPreallocationNNZ(n)
    r0, r1 = P.getOwnershipRange()
    for i in range(r0, r1):
        cols = np.flatnonzero(A[i]).astype(PETSc.IntType)
        P.setValues([i], cols, A[i, cols])
    P.assemble()
    return P


@pytest.fixture(scope="module")
def three():
    M, K, iface = _dense_model()
    return M, K, iface, _petsc(M), _petsc(K)


def _full_coupled(M: np.ndarray, K: np.ndarray, G18: np.ndarray) -> tuple:
    """Direct eigen-solve of the full model with both couplings: (Hz, modes, G full)."""
    G = np.zeros((K.shape[0], 2))
    G[:18] = G18
    Kc = K + KM[0] * np.outer(G[:, 0], G[:, 0]) + KM[1] * np.outer(G[:, 1], G[:, 1])
    lam, phi = sla.eigh(Kc, M)
    return np.sqrt(lam) / (2 * math.pi), phi, G, lam


def test_three_bodies_keep_18_dof_and_the_full_coupled_frequencies(three):
    M, K, iface, Mp, Kp = three
    n_i = M.shape[0] - 18
    cb = craig_bampton(Mp, Kp, iface, n_modes=n_i - 1)
    G18 = _vectors()
    rom = build_rom(cb, G18, KM, xi=0.03)
    assert rom.n_c == 18 and rom.n_r == 18 + n_i - 1
    assert rom.gear_dof_names == gear_body_dof_names(3)
    assert rom.gear_dof_names[12:] == ("u7", "u8", "u9", "theta7", "theta8", "theta9")
    assert rom.G.shape == (rom.n_r, 2) and rom.n_meshes == 2
    np.testing.assert_array_equal(rom.G[:18], G18)
    assert not rom.G[18:].any()
    # the physical DOF stay in q: the first 18 columns of T are unit on the interface
    np.testing.assert_allclose(rom.M[:18, :18], M[:18, :18] + _schur_mass(M, K), rtol=1e-9,
                               atol=1e-12 * np.abs(M).max())
    f_full, phi, G, lam = _full_coupled(M, K, G18)
    # the full model has the isolated DOF's frequency more (its highest)
    assert f_full[-1] > 100 * rom.frequencies_hz.max()
    rel = np.abs(rom.frequencies_hz - f_full[:-1]) / f_full[:-1]
    assert rel.max() <= 1e-8, rel.max()
    # eq. (31) summed over both meshes: the same energies as the full model's
    rho_full = sum(k * (G[:, e] @ phi) ** 2 for e, k in enumerate(KM)) / lam
    np.testing.assert_allclose(rom.mesh_energy, rho_full[:-1], rtol=0, atol=1e-9)
    assert rom.mesh_energy.max() > 0.1


def _schur_mass(M: np.ndarray, K: np.ndarray) -> np.ndarray:
    """Guyan mass correction Ψᵀ M_ii Ψ + Ψᵀ M_ic + M_ci Ψ (the ROM's interface block minus
    M_cc), Ψ = −K_ii⁻¹ K_ic."""
    c, i = np.arange(18), np.arange(18, M.shape[0])
    psi = -np.linalg.solve(K[np.ix_(i, i)], K[np.ix_(i, c)])
    return psi.T @ M[np.ix_(i, i)] @ psi + psi.T @ M[np.ix_(i, c)] + M[np.ix_(c, i)] @ psi


def test_validation_couples_the_full_model_by_both_meshes(three):
    M, K, iface, Mp, Kp = three
    n_i = M.shape[0] - 18
    G18 = _vectors()
    rom = build_rom(craig_bampton(Mp, Kp, iface, n_modes=n_i - 1), G18, KM)
    v = validate_rom(rom, Mp, Kp, iface, G18, KM, n_check=12)
    f_full = _full_coupled(M, K, G18)[0]
    np.testing.assert_allclose(v.full_hz, f_full[:12], rtol=1e-8)
    assert v.relative_error.max() <= 1e-8
    # the full matrix is K + Σ k̄_e g_e g_eᵀ on the gear DOF
    Kc = add_mesh_coupling(Kp, iface, G18, KM)
    r0, r1 = Kc.getOwnershipRange()
    dense = np.array([Kc.getValues([r], range(K.shape[0]))[0] for r in range(r0, r1)])
    G = _full_coupled(M, K, G18)[2]
    ref = K + KM[0] * np.outer(G[:, 0], G[:, 0]) + KM[1] * np.outer(G[:, 1], G[:, 1])
    np.testing.assert_allclose(dense, ref[r0:r1], rtol=1e-14, atol=1e-14 * np.abs(ref).max())


def test_reduce_fe_model_and_the_rom_file_keep_every_mesh(three, tmp_path):
    from types import SimpleNamespace

    M, K, iface, Mp, Kp = three
    model = SimpleNamespace(M=Mp, K=Kp, gear_dofs=iface, G=_vectors())
    rom = reduce_fe_model(model, KM, n_modes=20, n_check=8)
    assert rom.G.shape == (38, 2) and rom.validation.full_hz.size == 8
    path = tmp_path / "rom.h5"
    save_rom(path, rom, write_basis=False)
    back = load_rom(path)
    np.testing.assert_array_equal(back.G, rom.G)
    np.testing.assert_array_equal(back.km_mean, KM)
    np.testing.assert_array_equal(back.mesh_energy, rom.mesh_energy)
    assert back.gear_dof_names == gear_body_dof_names(3)


def test_one_mesh_is_the_one_mesh_formula_bit_for_bit():
    """A (n, 1) G and (k̄,) give exactly the numbers of the 1-D G and scalar k̄ (the
    pump's results do not move), and the sum over meshes is the sum of the terms."""
    rng = np.random.default_rng(0)
    A = rng.standard_normal((9, 9))
    K = A @ A.T + 9 * np.eye(9)
    M = np.diag(1 + rng.random(9))
    g = rng.standard_normal(9)
    for f in (coupled_modes,):
        a, b = f(M, K, g, 3.0), f(M, K, g[:, None], (3.0,))
        np.testing.assert_array_equal(a.omega2, b.omega2)
        np.testing.assert_array_equal(a.phi, b.phi)
    np.testing.assert_array_equal(mesh_energy(M, K, g, 3.0), mesh_energy(M, K, g[:, None], [3.0]))
    np.testing.assert_array_equal(modal_damping(M, K, g, 3.0, 0.02),
                                  modal_damping(M, K, g[:, None], 3.0, 0.02))
    G2 = rng.standard_normal((9, 2))
    np.testing.assert_allclose(couple(K, G2, (2.0, 5.0)),
                               K + 2 * np.outer(G2[:, 0], G2[:, 0])
                               + 5 * np.outer(G2[:, 1], G2[:, 1]), rtol=1e-15)
    with pytest.raises(ValueError, match="km_mean"):
        couple(K, G2, (1.0, 2.0, 3.0))
    with pytest.raises(ValueError, match=r"G.shape = \(8,\)"):
        couple(K, g[:8], 1.0)


@pytest.mark.fem
def test_fe_model_exposes_three_gear_bodies_and_two_mesh_directions():
    """A small FE bar (P2, DOLFINx) with gear bodies A and B on its end faces and C on a
    spring from B; meshes A–B and B–C: the FE model holds 6 DOF per body by name and G
    (18, 2); the ROM keeps the 18 DOF and converges to the full model coupled by both
    meshes (Fig. 9 validation; 4 rigid modes: 6 of the free bar, 2 taken by the meshes)."""
    pytest.importorskip("dolfinx")
    import fem_support as fs
    from mpi4py import MPI

    import fem
    from gears.pair import pair_frame

    with fs.gmsh_session() as model:
        c = fs.build_box_bar(0.2, 0.02, 0.01, MPI.COMM_WORLD.rank)
        fe_mesh = fem.load_gmsh_mesh(model)
    spec = fem.ModelSpec()
    frame = pair_frame(math.radians(20))
    for name, surface in (("A", "end_a"), ("B", "end_b")):
        spec.add_node(name, c[surface], frame=frame)
        spec.add_link(surface, name)
    spec.add_node("C", [0.06, 0.0, 0.2], frame=frame)
    spec.add_mass("C", fem.rigid_body_mass(0.5, [2e-4, 2e-4, 4e-4]))
    spec.add_spring("C", fem.axial_spring(1e8, 1e8, 1e4, 1e4), other="B")
    G = _vectors()
    m = fem.build_model(fe_mesh, {"shaft": fs.STEEL_TEST}, spec, gear_nodes=("A", "B", "C"),
                        G=G)
    assert m.gear_nodes == ("A", "B", "C") and m.n_meshes == 2 and m.G.shape == (18, 2)
    assert list(m.gear_body_dofs) == ["A", "B", "C"]
    np.testing.assert_array_equal(np.concatenate(list(m.gear_body_dofs.values())),
                                  m.gear_dofs)
    errors = []
    for n_cm in (20, 60):
        rom = reduce_fe_model(m, KM, n_modes=n_cm, n_check=14)
        assert rom.n_c == 18 and rom.G.shape == (18 + n_cm, 2)
        assert np.count_nonzero(rom.validation.full_hz == 0.0) == 4
        errors.append(rom.validation.relative_error.max())
    # about 6e-4 and 3e-5 (Rayleigh–Ritz: the ROM converges from above)
    assert errors[1] < 1e-4 and errors[1] < errors[0] / 5
    with pytest.raises(ValueError, match=r"G shape = \(12, 2\): must be \(18, n_meshes\)"):
        fem.build_model(fe_mesh, {"shaft": fs.STEEL_TEST}, spec, gear_nodes=("A", "B", "C"),
                        G=G[:12])
