"""hbm: harmonic sets, input validation, Hill exponents of a linear system."""

import numpy as np
import pytest
from hbm_models import random_modal_system, sdof_problem

import hbm


def test_harmonic_set_mesh_fundamental():
    hs = hbm.HarmonicSet.build(n_teeth=76, mesh_harmonics=5)
    assert hs.indices == (0, 1, 2, 3, 4, 5)
    assert hs.fundamental == "mesh" and hs.ratio == 76
    assert hs.n_time > 3 * 5 and hs.n_time >= 64
    assert hs.index_of(152) == 2 and hs.index_of(1) is None


def test_harmonic_set_shaft_fundamental_with_sidebands():
    hs = hbm.HarmonicSet.build(n_teeth=10, mesh_harmonics=2, external_orders=(1, 2),
                               sideband_order=1)
    assert hs.fundamental == "shaft" and hs.ratio == 1
    assert hs.indices == (0, 1, 2, 8, 9, 10, 11, 12, 18, 19, 20, 21, 22)
    hs2 = hbm.HarmonicSet.build(10, 1, external_orders=(1, 2), sideband_order=2)
    assert set(hs2.indices) == {0, 1, 2, 3, 4, 6, 7, 8, 9, 10, 11, 12, 13, 14}
    assert hbm.HarmonicSet.build(10, 2, external_orders=(1,), max_index=15).max_index == 11
    assert hs.n_time > 3 * hs.max_index


def test_real_complex_layout_round_trip():
    hs = hbm.HarmonicSet([0, 2, 5])
    xc = np.array([1.5, 2 - 1j, -0.5j])
    xr = hs.to_real(xc)
    assert np.allclose(xr, [1.5, 2, -1, 0, -0.5])
    assert np.allclose(hs.to_complex(xr), xc)
    e, a = hs.aft_matrices()
    tau = hs.time_grid()
    x = (xc[None, :] * np.exp(1j * np.outer(tau, [0, 2, 5]))).real.sum(axis=1)
    assert np.allclose(e @ xr, x) and np.allclose(a @ x, xr)


@pytest.mark.parametrize("call, field", [
    (lambda: hbm.HarmonicSet([1, 2]), "harmonics.indices"),
    (lambda: hbm.HarmonicSet([0, 2, 1]), "harmonics.indices"),
    (lambda: hbm.HarmonicSet([0, -1]), "harmonics.indices"),
    (lambda: hbm.HarmonicSet([0, 4], n_time=8), "harmonics.n_time"),
    (lambda: hbm.HarmonicSet.build(0, 3), "harmonics.n_teeth"),
    (lambda: hbm.HarmonicSet.build(10, 3, external_orders=(0,)), "harmonics.external_orders"),
    (lambda: hbm.GearMesh([1.0], 10, {0: 1e8}, backlash=0.0), "mesh.backlash"),
    (lambda: hbm.GearMesh([1.0], 10, {0: -1e8}, backlash=1e-5), "mesh.stiffness[0]"),
    (lambda: hbm.GearMesh([1.0], 10, {0: 1e8, 1: 2e8}, backlash=1e-5), "mesh.stiffness"),
    (lambda: hbm.GearMesh([1.0], 10, {1: 1e8}, backlash=1e-5), "mesh.stiffness[0]"),
    (lambda: hbm.GearMesh([1.0], 10, {0: 1e8}, te={-1: 1e-6}, backlash=1e-5), "mesh.te"),
    (lambda: hbm.GearMesh([1.0], 10, {0: 1e8}, backlash=1e-5, te_kind="x"), "mesh.te_kind"),
    (lambda: hbm.GearMesh([0, 0], 10, {0: 1e8}, backlash=1e-5), "mesh.direction"),
    (lambda: hbm.GearMesh([1, np.nan], 10, {0: 1e8}, backlash=1e-5), "mesh.direction"),
    (lambda: hbm.GearMesh([1.0], 10, {0: 1e8}, backlash=1e-5, speed_ratio=0),
     "mesh.speed_ratio"),
    (lambda: hbm.LinearSystem([[1.0, 0], [0, -1]], np.zeros((2, 2)), np.eye(2)), "system.M"),
    (lambda: hbm.LinearSystem(np.eye(2), np.zeros((3, 3)), np.eye(2)), "system.C"),
    (lambda: hbm.LinearSystem(np.eye(2), np.zeros((2, 2)), np.eye(2) * np.nan), "system.K"),
    (lambda: hbm.Excitation(2, constant={0: [1.0j, 0]}), "excitation.constant[0]"),
    (lambda: hbm.Excitation(2, constant={1: [1.0, 0, 0]}), "excitation.constant[1]"),
    (lambda: hbm.Excitation(2, omega_squared={-1: [1.0, 0]}), "excitation.omega_squared"),
    (lambda: hbm.Excitation(2, constant={0.5: [1.0, 0]}), "excitation.constant key"),
    (lambda: hbm.HarmonicSet([0, 1], ratio=0), "harmonics.ratio"),
])
def test_bad_input_names_the_field(call, field):
    with pytest.raises(ValueError, match=field.replace("[", r"\[").replace("]", r"\]")):
        call()


def _small_parts():
    system = hbm.LinearSystem(np.eye(2), 0.01 * np.eye(2), np.eye(2))
    mesh = hbm.GearMesh([1.0, -1.0], 3, {0: 1.0}, backlash=0.1)
    return system, [mesh]


def test_problem_rejects_inconsistent_parts():
    system, mesh = _small_parts()
    hs_mesh = hbm.HarmonicSet.build(3, 4)
    with pytest.raises(ValueError, match="excitation.constant frequency ratio = 1"):
        hbm.HBMProblem(system, mesh, hbm.Excitation(2, constant={1: [1, 0]}), hs_mesh)
    with pytest.raises(ValueError, match="excitation.n_dof"):
        hbm.HBMProblem(system, mesh, hbm.Excitation(3), hs_mesh)
    with pytest.raises(ValueError, match="problem.condensation"):
        hbm.HBMProblem(system, mesh, hbm.Excitation(2), hs_mesh, "modal")
    with pytest.raises(ValueError, match="harmonics.ratio"):
        hbm.HBMProblem(system, mesh, hbm.Excitation(2), hbm.HarmonicSet([0, 1, 2], ratio=2))
    with pytest.raises(ValueError, match="problem.elements"):
        hbm.HBMProblem(system, mesh[0], hbm.Excitation(2), hs_mesh)
    with pytest.raises(ValueError, match=r"problem.elements\[0\].direction"):
        hbm.HBMProblem(system, [hbm.GearMesh([1.0], 3, {0: 1.0}, backlash=0.1)],
                       hbm.Excitation(2), hs_mesh)
    pb = hbm.HBMProblem(system, mesh, hbm.Excitation(2, constant={0: [0.1, 0]}), hs_mesh)
    with pytest.raises(ValueError, match="rpm"):
        pb.solve(-1.0)
    with pytest.raises(ValueError, match="trace.rpm_end"):
        hbm.trace(pb, 10.0, 10.0)
    with pytest.raises(ValueError, match="trace.step"):
        hbm.trace(pb, 10.0, 20.0, step=0.0)


@pytest.mark.parametrize("external", [(), (1,)])
def test_hill_exponents_of_linear_contact_are_modal_eigenvalues(external):
    """Constant k_m, permanent contact: Floquet exponents = -zeta w +- i w_d (mod i w0)."""
    zeta, kbar = 0.03, 2e3
    m, c, k, g = random_modal_system(n=6, seed=4, zeta=zeta, kbar=kbar, n_gear=4)
    system = hbm.LinearSystem(m, c, k)
    mesh = [hbm.GearMesh(g, 4, {0: kbar}, backlash=1e-3)]
    orders = {0: 50 * g}
    if external:
        orders[1] = 0.1 * g
    exc = hbm.Excitation(6, constant=orders)
    hs = hbm.HarmonicSet.build(4, 3, external_orders=external)
    pb = hbm.HBMProblem(system, mesh, exc, hs, "loa")
    pt = pb.solve(40.0)
    assert hbm.point_stats(pb, pt)[0].contact == 0
    lam_max, exps = hbm.floquet_exponents(pb, pt)
    import scipy.linalg as sla
    w = np.sqrt(sla.eigh(k + kbar * np.outer(g, g), m, eigvals_only=True))
    assert lam_max == pytest.approx(-zeta * w.min(), rel=1e-8)
    assert np.sort(exps.real) == pytest.approx(np.sort(np.repeat(-zeta * w, 2)), rel=1e-8)
    w0 = hs.fundamental_rad_s(pt.omega)
    wd = np.sort(w * np.sqrt(1 - zeta**2))
    # imaginary parts equal +-w_d modulo w0
    folded = np.sort(np.abs((exps.imag + w0 / 2) % w0 - w0 / 2))
    ref = np.sort(np.repeat(np.abs((wd + w0 / 2) % w0 - w0 / 2), 2))
    assert folded == pytest.approx(ref, abs=1e-8 * w.max())


def test_spectrum_and_time_series_consistent():
    pb = sdof_problem(harmonics=20, fa=0.05)
    pt = pb.solve(0.9 / (2 * np.pi / 60))
    ts = hbm.time_series(pb, pt, n_periods=2)
    sp = hbm.spectrum(pb, pt)
    assert sp["amplitude"][0] == pytest.approx(np.mean(ts.load), rel=1e-12)
    assert ts.t[-1] == pytest.approx(2 * 2 * np.pi / pt.omega * (1 - 1 / ts.t.size), rel=1e-12)
    # Parseval: std^2 = sum_k>0 |f_k|^2 / 2
    assert np.sqrt(np.sum(sp["amplitude"][1:] ** 2) / 2) == pytest.approx(
        np.std(ts.load), rel=1e-10)
    gaps = ts.signals["gap_active"] - ts.signals["gap_reverse"]
    assert np.all(gaps == pytest.approx(2 * pb.elements[0].backlash))
    # the same for the dynamic transmission error Delta, and the load's peak-to-peak
    d = sp["dte_amplitude"]
    assert d[0] == pytest.approx(np.mean(ts.delta), rel=1e-12)
    assert np.sqrt(np.sum(d[1:] ** 2) / 2) == pytest.approx(np.std(ts.delta), rel=1e-10)
    assert sp["peak_to_peak"] == pytest.approx(np.ptp(ts.load), rel=1e-12)


def test_loaded_ste_gives_static_load_on_active_flank():
    """te_kind="loaded": quasi-static response under F_s is Delta = b + q_s(t), f = F_s (eq. 12)."""
    kbar, fs, b = 2e8, 500.0, 20e-6
    qs = {0: 3e-6, 1: 0.8e-6 - 0.3e-6j, 2: 0.2e-6}
    system = hbm.LinearSystem([[1e-3]], [[2 * 0.05 * np.sqrt(kbar * 1e-3)]], [[0.0]])
    mesh = [hbm.GearMesh([1.0], 30, {0: kbar, 1: 0.1 * kbar, 2: 0.03j * kbar}, te=qs,
                         backlash=b, static_load=fs, te_kind="loaded")]
    pb = hbm.HBMProblem(system, mesh, hbm.Excitation(1, constant={0: [fs]}),
                        hbm.HarmonicSet.build(30, 8))
    wn = np.sqrt(kbar / 1e-3)
    pt = pb.solve(1e-6 * wn / 30 / (2 * np.pi / 60))   # mesh frequency 1e-6 w_n: quasi-static
    ts = hbm.time_series(pb, pt)
    phase = 30 * pt.omega * ts.t
    q = sum((c * np.exp(1j * m * phase)).real for m, c in qs.items())
    assert hbm.point_stats(pb, pt)[0].contact == 0
    assert np.max(np.abs(ts.delta - (b + q))) < 1e-6 * np.max(np.abs(q))
    assert np.max(np.abs(ts.load - fs)) < 1e-6 * fs


@pytest.mark.parametrize("modal", [True, False])
def test_hill_selection_satisfies_liouville(modal):
    """Sum of the Floquet exponents' real parts = -tr(M^-1 C) (Liouville), any orbit."""
    from test_hbm_linear import _random_problem
    pb = _random_problem("loa", modal=modal, n=10)
    s = pb.system
    trace = np.trace(np.linalg.solve(s.M, s.C))
    for rpm, contact, rel in ((10.0, 0, 1e-4), (60.0, 2, 0.06)):
        pt = pb.solve(rpm)
        assert hbm.point_stats(pb, pt)[0].contact == contact
        lam, exps = hbm.floquet_exponents(pb, pt, max_size=2000)
        assert exps.size == 2 * s.n_dof
        # impacts: Hill converges slowly for the discontinuous df/dDelta
        assert abs(np.sum(exps.real) + trace) < rel * trace
        assert lam < 0
