"""Coupled ROM (eq. 17), modal damping (eq. 18–19), mesh energy (eq. 31), Campbell."""

import math

import numpy as np
import pytest

from reduction import campbell, couple, coupled_modes, mesh_energy, modal_damping


def _two_dof_closed_form(m1, m2, k1, k2, km, g):
    """Eigenvalues, eigenvectors and ρ of the 2-DOF model from the quadratic formula."""
    Kc = np.diag([k1, k2]) + km * np.outer(g, g)
    a, b, c = m1 * m2, -(m1 * Kc[1, 1] + m2 * Kc[0, 0]), np.linalg.det(Kc)
    disc = math.sqrt(b * b - 4 * a * c)
    lams = np.array([(-b - disc) / (2 * a), (-b + disc) / (2 * a)])
    rho = []
    for lam in lams:
        phi = np.array([Kc[0, 1], lam * m1 - Kc[0, 0]])
        rho.append(km * (g @ phi) ** 2 / (phi @ Kc @ phi))
    return lams, np.array(rho)


def test_mesh_energy_two_dof_closed_form():
    m1, m2, k1, k2, km = 2.0, 3.0, 4e6, 1e6, 5e6
    g = np.array([0.04, -0.05])  # e.g. base radii of two torsional inertias
    lams, rho_ref = _two_dof_closed_form(m1, m2, k1, k2, km, g)
    M, K = np.diag([m1, m2]), np.diag([k1, k2])
    modes = coupled_modes(M, K, g, km)
    np.testing.assert_allclose(modes.omega2, lams, rtol=1e-12)
    rho = mesh_energy(M, K, g, km)
    np.testing.assert_allclose(rho, rho_ref, rtol=1e-10)
    assert np.all((rho >= 0) & (rho <= 1))


def test_pure_mesh_mode_has_unit_mesh_energy():
    # two free inertias joined only by the mesh: one rigid mode (ρ = 0, ω = 0) and
    # the mesh mode ω² = k̄_m (g1²/m1 + g2²/m2) with ρ = 1
    m1, m2, km = 0.8, 1.7, 2e8
    g = np.array([0.047, 0.047])
    M, K = np.diag([m1, m2]), np.zeros((2, 2))
    modes = coupled_modes(M, K, g, km)
    assert modes.rigid.tolist() == [True, False] and modes.omega2[0] == 0.0
    assert modes.omega2[1] == pytest.approx(km * (g[0] ** 2 / m1 + g[1] ** 2 / m2), rel=1e-12)
    np.testing.assert_allclose(mesh_energy(M, K, g, km), [0.0, 1.0], atol=1e-12)


def _random_system(n=10, n_rigid=1, seed=3):
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n, n))
    M = A @ A.T + n * np.eye(n)
    B = rng.standard_normal((n, n - n_rigid)) * 1e3
    K = B @ B.T  # rank n − n_rigid: n_rigid rigid modes before coupling
    G = np.zeros(n)
    G[:4] = rng.standard_normal(4)
    return M, K, G


def test_mesh_energy_bounds_random():
    M, K, G = _random_system(12, n_rigid=2)
    rho = mesh_energy(M, K, G, 1e6)
    assert rho.shape == (12,) and np.all((rho >= 0) & (rho <= 1))
    assert rho.max() > 0.01


@pytest.mark.parametrize("xi", [0.05, "per-mode"])
def test_modal_damping_gives_requested_ratio(xi):
    M, K, G = _random_system(10, n_rigid=2)
    km = 1e5
    if xi == "per-mode":
        xi = np.linspace(0.01, 0.2, 10)
    C = modal_damping(M, K, G, km, xi)
    Kc = couple(K, G, km)
    modes = coupled_modes(M, K, G, km)
    assert modes.rigid.sum() == 1  # one rigid mode survives the mesh coupling
    # independent check: eigenvalues of the first-order (state-space) system
    n = M.shape[0]
    Minv = np.linalg.inv(M)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ Kc, -Minv @ C]])
    lam = np.linalg.eigvals(A)
    lam = lam[lam.imag > 1e-6 * np.abs(lam).max()]  # one of each elastic pair
    lam = lam[np.argsort(np.abs(lam))]
    zeta = -lam.real / np.abs(lam)
    xi_el = np.broadcast_to(xi, (n,))[~modes.rigid]
    np.testing.assert_allclose(np.abs(lam), np.sqrt(modes.omega2[~modes.rigid]), rtol=1e-8)
    np.testing.assert_allclose(zeta, xi_el, rtol=1e-8)
    # the rigid mode is left undamped
    phi0 = modes.phi[:, modes.rigid][:, 0]
    assert np.linalg.norm(C @ phi0) < 1e-10 * np.linalg.norm(C)


def test_modal_damping_bad_xi():
    M, K, G = _random_system(4, n_rigid=0)
    with pytest.raises(ValueError, match="xi"):
        modal_damping(M, K, G, 1e5, 1.5)
    with pytest.raises(ValueError, match="xi"):
        modal_damping(M, K, G, 1e5, np.ones(3) * 0.05)


def test_campbell_crossings():
    f = np.array([0.0, 850.0, 4000.0, 5000.0])
    rho = np.array([0.0, 0.05, 0.32, 0.1])
    Z = 76
    cb = campbell(f, rho, (0.0, 4000.0), [Z, 2 * Z, 3 * Z, 2, 4], n_rpm=50)
    assert cb.order_hz.shape == (5, 50)
    assert cb.crossings.shape[1] == 5 and cb.crossings.shape[0] > 0
    for j, order, rpm, fj, r in cb.crossings:
        assert order * rpm / 60.0 == pytest.approx(fj) and fj == f[int(j)]
        assert 0 <= rpm <= 4000 and r == rho[int(j)]
    # the 4 kHz mode is crossed by H_Z at 3158 rpm (paper Fig. 14: ~3000 rpm)
    hz = cb.crossings[(cb.crossings[:, 0] == 2) & (cb.crossings[:, 1] == Z)]
    assert hz[0, 2] == pytest.approx(60 * 4000 / 76)
    # H_2 and H_4 of 850 Hz lie above 4000 rpm: no crossing
    assert not np.any((cb.crossings[:, 0] == 1) & (cb.crossings[:, 1] <= 4))
    with pytest.raises(ValueError, match="rpm_range"):
        campbell(f, rho, (100.0, 10.0), [Z])
