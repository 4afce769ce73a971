"""hbm: exactness in permanent contact, condensations and analytic Jacobians."""

import numpy as np
import pytest
from hbm_models import RPM, random_modal_system, sdof_problem
from scipy.integrate import solve_ivp

import hbm


def _random_problem(condensation, te=1e-2, modal=True, seed=0, n=20):
    m, c, k, g = random_modal_system(n=n, seed=seed, n_gear=min(12, n))
    n = m.shape[0]
    if not modal:
        rng = np.random.default_rng(5)
        d = rng.standard_normal((n, n))
        c = c + 0.2 * (d @ d.T) / n
    rng = np.random.default_rng(1)
    system = hbm.LinearSystem(m, c, k)
    mesh = [hbm.GearMesh(direction=g, n_teeth=5, stiffness={0: 2e3, 1: 300 + 100j, 2: 50},
                         te={1: te * 1j, 2: te / 4}, backlash=5e-3)]
    exc = hbm.Excitation(n, constant={0: 10 * g + rng.standard_normal(n),
                                      1: rng.standard_normal(n) + 1j * rng.standard_normal(n)},
                         omega_squared={2: 1e-2 * rng.standard_normal(n)})
    hs = hbm.HarmonicSet.build(5, 2, external_orders=(1, 2), sideband_order=1)
    return hbm.HBMProblem(system, mesh, exc, hs, condensation)


def test_constant_stiffness_contact_equals_direct_linear_response():
    """Permanent contact, constant k_m: f = k (Delta - e - b) makes the system linear."""
    m, c, k, g = random_modal_system(seed=3)
    n = m.shape[0]
    rng = np.random.default_rng(2)
    kbar, b = 2e3, 5e-3
    te = {1: 1e-4 + 2e-4j, 3: 5e-5}
    system = hbm.LinearSystem(m, c, k)
    mesh = [hbm.GearMesh(direction=g, n_teeth=3, stiffness={0: kbar}, te=te, backlash=b)]
    f0 = 20 * g
    f1 = 0.1 * (rng.standard_normal(n) + 1j * rng.standard_normal(n))
    exc = hbm.Excitation(n, constant={0: f0, 1: f1})
    hs = hbm.HarmonicSet.build(3, 4, external_orders=(1,))
    pb = hbm.HBMProblem(system, mesh, exc, hs, "loa")
    pt = pb.solve(90.0)
    assert hbm.point_stats(pb, pt)[0].contact == 0
    q = pb.recover(pt)
    omega = pt.omega
    ref = np.zeros_like(q)
    for i, idx in enumerate(hs.indices):
        w = idx * omega
        z = k + kbar * np.outer(g, g) - w**2 * m + 1j * w * c
        rhs = np.zeros(n, dtype=complex)
        if idx == 0:
            rhs += f0 + kbar * b * g
        if idx == 1:
            rhs += f1
        if idx % 3 == 0 and idx // 3 in te:
            rhs += kbar * te[idx // 3] * g
        ref[:, i] = np.linalg.solve(z, rhs)
    err = np.max(np.abs(q - ref)) / np.max(np.abs(ref))
    assert err < 1e-10


def _shoot_linear_contact(omega, zeta=0.05, fm=0.1, fa=0.05, alpha=0.2, b=1.0):
    """Periodic solution of the SDOF in permanent contact by shooting (solve_ivp)."""
    T = 2 * np.pi / omega

    def rhs(t, y):
        k = 1 + alpha * np.cos(omega * t)
        x, v, xa, va, xb, vb = y
        return [v, fm + fa * np.cos(omega * t) - 2 * zeta * v - k * (x - b),
                va, -2 * zeta * va - k * xa, vb, -2 * zeta * vb - k * xb]

    sol = solve_ivp(rhs, (0, T), [0, 0, 1, 0, 0, 1], method="DOP853", rtol=1e-12, atol=1e-14)
    yT = sol.y[:, -1]
    phi = np.array([[yT[2], yT[4]], [yT[3], yT[5]]])
    y0 = np.linalg.solve(np.eye(2) - phi, yT[:2])
    full = solve_ivp(rhs, (0, T), [*y0, 1, 0, 0, 1], method="DOP853", rtol=1e-12,
                     atol=1e-14, dense_output=True)
    return lambda t: full.sol(t)[0]


def test_time_varying_stiffness_contact_matches_time_integration():
    omega = 0.6
    pb = sdof_problem(harmonics=30)
    pt = pb.solve(omega / RPM)
    assert hbm.point_stats(pb, pt)[0].contact == 0
    ts = hbm.time_series(pb, pt, samples_per_period=512)
    x_ref = _shoot_linear_contact(omega)(ts.t)
    err = np.max(np.abs(ts.delta - x_ref)) / np.max(np.abs(x_ref))
    assert err < 1e-9


@pytest.mark.parametrize("modal", [True, False])
def test_condensations_agree(modal):
    """none / gear / loa on a random 20-DOF system with impacts (contact class 2)."""
    qs = {}
    for cond in ("none", "gear", "loa"):
        pb = _random_problem(cond, modal=modal)
        assert pb.modal == modal
        pt = pb.solve(100.0, tol=1e-12)      # the C1 residual: converged, not exact
        assert pt.residual < 1e-12
        qs[cond] = pb.recover(pt)
        if cond == "loa":
            assert hbm.point_stats(pb, pt)[0].contact == 2
    ref = qs["none"]
    for cond in ("gear", "loa"):
        assert np.max(np.abs(qs[cond] - ref)) / np.max(np.abs(ref)) < 1e-10


@pytest.mark.parametrize("condensation", ["none", "gear", "loa"])
@pytest.mark.parametrize("modal", [True, False])
def test_jacobian_matches_finite_differences(condensation, modal):
    pb = _random_problem(condensation, modal=modal)
    pt = pb.solve(100.0)
    rng = np.random.default_rng(7)
    u = pt.unknowns + 0.01 * pb.x_scale * rng.standard_normal(pt.unknowns.size)
    w = pt.omega
    _, ju, jw = pb.evaluate(u, w)
    h = 1e-7
    jfd = np.empty_like(ju)
    for i in range(u.size):
        du = np.zeros_like(u)
        du[i] = h * pb.x_scale[i]
        jfd[:, i] = (pb.residual(u + du, w) - pb.residual(u - du, w)) / (2 * du[i])
    jwfd = (pb.residual(u, w * (1 + h)) - pb.residual(u, w * (1 - h))) / (2 * h * w)
    scale = pb.x_scale[None, :] / pb.eq_scale[:, None]
    assert np.max(np.abs((jfd - ju) * scale)) < 1e-6 * np.max(np.abs(ju * scale))
    assert np.max(np.abs(jwfd - jw)) < 1e-6 * np.max(np.abs(jw))


def test_multiplication_matrix_equals_dense_aft():
    pb = sdof_problem(harmonics=12)
    s = np.random.default_rng(0).standard_normal(pb.harmonics.n_time)
    dense = pb.A @ (s[:, None] * pb.E)
    assert np.max(np.abs(pb.multiplication_matrix(s) - dense)) < 1e-13


def test_mesh_period_envelope_of_a_linear_contact_response():
    """In permanent contact with constant k̄ the mesh load is k̄ (Delta - e - b) (eq. 13):
    the envelope's peak load and mean DTE per mesh period follow from the recovered
    harmonics (Delta_k = g^T q_k) evaluated on the same time grid."""
    m, c, k, g = random_modal_system(seed=3)
    n = m.shape[0]
    rng = np.random.default_rng(2)
    kbar, b, z = 2e3, 5e-3, 3
    te = {1: 1e-4 + 2e-4j}
    mesh = [hbm.GearMesh(direction=g, n_teeth=z, stiffness={0: kbar}, te=te, backlash=b)]
    exc = hbm.Excitation(n, constant={0: 20 * g, 1: 0.3 * (rng.standard_normal(n)
                                                            + 1j * rng.standard_normal(n))})
    hs = hbm.HarmonicSet.build(z, 4, external_orders=(1,))
    pb = hbm.HBMProblem(hbm.LinearSystem(m, c, k), mesh, exc, hs, "loa")
    pt = pb.solve(90.0)
    assert hbm.point_stats(pb, pt)[0].contact == 0
    n_time = 400 * z
    env = hbm.mesh_period_envelope(pb, pt, n_time=n_time)
    tau = 2 * np.pi * np.arange(n_time) / n_time
    dk = g @ pb.recover(pt)
    delta = sum((dk[i] * np.exp(1j * idx * tau)).real for i, idx in enumerate(hs.indices))
    e = sum((a * np.exp(1j * z * h * tau)).real for h, a in te.items())
    load = kbar * (delta - e - b)
    assert env.peak_load == pytest.approx(load.reshape(z, -1).max(axis=1), rel=1e-10)
    assert env.mean_dte == pytest.approx(delta.reshape(z, -1).mean(axis=1), rel=1e-10)
    peaks = load.reshape(z, -1).max(axis=1)
    assert env.load_variation == pytest.approx(peaks.max() / peaks.min() - 1, rel=1e-10)
    assert env.load_variation > 0.01                # the order-1 forcing modulates the peaks
    assert env.load_cycles == 1
    assert env.dte_swing == pytest.approx(np.ptp(delta.reshape(z, -1).mean(axis=1)), rel=1e-10)
