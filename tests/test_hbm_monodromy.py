"""Floquet exponents from the variational equation (T.10, hbm.stability.monodromy),
against an independent integration of the same equation (scipy DOP853, physical coordinates)
and the parity of the harmonic balance's real exponents (T.9)."""

import numpy as np
import pytest
from hbm_models import (
    RPM,
    gear_and_stiff_mode_problem,
    random_mesh_problem,
    random_modal_system,
    sdof_problem,
)
from scipy.integrate import solve_ivp

import hbm
from hbm.stability import KINDS, stability
from hbm.stability.monodromy import monodromy_exponents


def _reference_exponents(pb, pt):
    """Exponents of M y'' + C y' + K y + s(t) G G^T y = 0 along the HBM orbit, by DOP853
    on the monodromy columns (s = k_m where a flank is loaded, eq. 13)."""
    s = pb.system
    n = s.n_dof
    w0 = pb.harmonics.fundamental_rad_s(pt.omega)
    period = 2 * np.pi / w0
    minv = np.linalg.inv(s.M)
    g, mesh = pb.directions[0], pb.elements[0]
    mk, mc, mg = minv @ s.K, minv @ s.C, minv @ g
    kS = pb.kS * w0

    def rhs(t, y):
        ph = np.array([pb.steps[0] * w0 * t])
        delta = float((pt.coefficients[0] * np.exp(1j * kS * t)).real.sum())
        p = delta - mesh.error_at(ph)[0]
        km = mesh.stiffness_at(ph)[0] if abs(p) > mesh.backlash else 0.0
        x = y.reshape(2 * n, 2 * n)
        acc = -mk @ x[:n] - mc @ x[n:] - km * np.outer(mg, g @ x[:n])
        return np.vstack([x[n:], acc]).ravel()

    sol = solve_ivp(rhs, (0.0, period), np.eye(2 * n).ravel(), method="DOP853",
                    rtol=1e-11, atol=1e-12)
    mu = np.linalg.eigvals(sol.y[:, -1].reshape(2 * n, 2 * n))
    lam = np.log(mu.astype(complex)) / period
    return lam[np.argsort(-lam.real)]


def _twelve_dof(modal=True):
    m, c, k, g = random_modal_system(n=6, seed=1, zeta=0.02, kbar=2e3, n_gear=4)
    if not modal:
        c = c + 0.5 * np.diag(np.diag(c)) * np.linspace(0.0, 1.0, 6)   # non-proportional
    pb = hbm.HBMProblem(hbm.LinearSystem(m, c, k),
                        [hbm.GearMesh(g, 1, {0: 2e3, 1: 400}, backlash=1e-3)],
                        hbm.Excitation(6, constant={0: 2.0 * g, 1: 1.0 * g}),
                        hbm.HarmonicSet.build(1, 12))
    assert pb.modal == modal
    w = np.sqrt(pb.w2[~pb.rigid]) if modal else np.sqrt(np.linalg.eigvalsh(pb.Kp))
    return pb, 0.3 * w.min() / RPM, 1.3 * w.max() / RPM


@pytest.fixture(scope="module", params=[True, False], ids=["modal", "dense"])
def six_dof_branch(request):
    pb, r0, r1 = _twelve_dof(request.param)
    br = hbm.trace(pb, r0, r1, max_points=3000, stability=False)
    assert br.status == "completed"
    return pb, br


def test_exponents_match_independent_integration(six_dof_branch):
    """Leading exponents at a contact, an impact and a fold-segment point, to 1e-3."""
    pb, br = six_dof_branch
    d = np.diff(br.rpm)
    mesh = br.element(0)
    picks = [int(np.flatnonzero(mesh.contact == 0)[0]), int(np.argmax(mesh.contact_loss_fraction))]
    down = np.flatnonzero(np.r_[False, (d[:-1] < 0) & (d[1:] < 0), False])
    if down.size:
        picks.append(int(down[down.size // 2]))
    for i in picks:
        pt = pb.point(br.unknowns[i], br.omega[i])
        res = monodromy_exponents(pb, pt, rtol=1e-5, sign_margin=np.inf, max_refine=6)
        ref = _reference_exponents(pb, pt)
        scale = abs(ref[0].real) + 1e-3 * pb.harmonics.fundamental_rad_s(pt.omega)
        assert abs(res.max_real - ref[0].real) < 1e-3 * scale, br.rpm[i]
        assert res.exponents.size == ref.size            # full monodromy: 2 n exponents


def test_liouville_holds_exactly(six_dof_branch):
    """det Phi = exp(-T tr M^-1 C): the mesh kicks have determinant one (T.10)."""
    pb, br = six_dof_branch
    trace = np.trace(np.linalg.solve(pb.system.M, pb.system.C))
    i = int(np.argmax(br.element(0).contact_loss_fraction))
    res = monodromy_exponents(pb, pb.point(br.unknowns[i], br.omega[i]))
    assert np.sum(res.exponents.real) == pytest.approx(-trace, rel=1e-9)


def test_second_order_in_the_time_step():
    """Permanent contact (smooth coefficients): the error falls 4x per halved step (on
    the imaginary part: the real parts of the SDOF's complex pair are exact, Liouville)."""
    pb = sdof_problem(harmonics=20, fa=0.01, b=1.0)
    pt = pb.solve(0.8 / RPM)
    assert hbm.point_stats(pb, pt)[0].contact == 0
    ref = abs(_reference_exponents(pb, pt)[0].imag)
    errs = [abs(abs(monodromy_exponents(pb, pt, n_steps=n, rtol=1.0, max_refine=0)
                    .exponents[0].imag) - ref) for n in (64, 128, 256)]
    assert errs[0] / errs[1] == pytest.approx(4.0, rel=0.1)
    assert errs[1] / errs[2] == pytest.approx(4.0, rel=0.1)


@pytest.mark.parametrize("make", [lambda: (sdof_problem(harmonics=30, fa=0.05), 0.3, 1.6),
                                  lambda: (gear_and_stiff_mode_problem(), 0.3, 1.6)],
                         ids=["sdof", "2dof"])
def test_converged_harmonic_set_agrees_with_fold_parity(make):
    """With a converged harmonic set, T.9 (parity of the HBM's real exponents) and T.10
    (variational equation) agree at every point but next to a fold (where the real
    exponent crosses 0 at speeds that differ by the truncation); folds bound the
    unstable segment and the exponent there is real (multiplier > 1)."""
    pb, r0, r1 = make()
    br = hbm.trace(pb, r0 / RPM, r1 / RPM)
    assert br.status == "completed" and len(br.folds) == 2
    near_fold = np.zeros(len(br), dtype=bool)
    for f in br.fold_index:
        near_fold[max(f - 1, 0): f + 2] = True
    assert np.all(br.stability_consistent[~near_fold])
    d = np.diff(br.rpm)
    inner = np.flatnonzero(np.r_[False, (d[:-1] < 0) & (d[1:] < 0), False])
    inner = inner[(inner > min(br.fold_index) + 1) & (inner < max(br.fold_index) - 1)]
    assert inner.size >= 3
    assert not np.any(br.stable[inner])
    assert np.all(br.floquet_kind[inner] == KINDS.index("fold"))
    for i in inner[::4]:
        st = stability(pb, pb.point(br.unknowns[i], br.omega[i]))
        assert st.fold_parity and st.consistent and st.exponents[0].imag == 0.0


def _twenty_modes():
    """20 modes, a period long against all but a few of them (they contract)."""
    pb = random_mesh_problem(n=20, seed=3, zeta=0.03, n_gear=8, k1=600, harmonics=10)
    return pb, pb.solve(0.15 * np.sqrt(pb.w2).min() / RPM)


def test_subspace_iteration_matches_full_monodromy():
    """Dominant exponents from a 4-column block equal those of the full monodromy."""
    pb, pt = _twenty_modes()
    full = monodromy_exponents(pb, pt, columns=40, rtol=1.0, max_refine=0)
    sub = monodromy_exponents(pb, pt, columns=4, rtol=1.0, max_refine=0)
    assert full.columns == 40 and sub.columns < 40
    assert sub.max_real == pytest.approx(full.max_real, rel=1e-9)
    k = min(sub.exponents.size, 2)
    assert sub.exponents[:k] == pytest.approx(full.exponents[:k], rel=1e-8)


def test_chunked_period_equals_stepping():
    """The chunked closed form (hbm.stability.monodromy.ModalPeriod) is the product of the
    steps E (I - kappa_i b c^T), E = expm(A dt) per step: same matrix to 1e-11,
    with a step count that leaves a partial last chunk."""
    import scipy.linalg as sla

    from hbm.stability.monodromy import ModalPeriod, orbit_deltas, step_stiffness

    pb, r0, r1 = _twelve_dof(True)
    pt = pb.solve(0.5 * (r0 + r1))
    n = 200
    period = 2 * np.pi / pb.harmonics.fundamental_rad_s(pt.omega)
    jbar = step_stiffness(pb, orbit_deltas(pb, pt.unknowns, n))
    phi = ModalPeriod(pb, jbar, period)(np.eye(2 * pb.w2.size))
    jbar = jbar[0]
    m, dt = pb.w2.size, period / n
    a = np.block([[np.zeros((m, m)), np.eye(m)], [-np.diag(pb.w2), -np.diag(pb.cj)]])
    e = sla.expm(a * dt)
    b = np.r_[np.zeros(m), pb.gj[0]]
    c = np.r_[pb.gj[0], np.zeros(m)]
    ref = np.eye(2 * m)
    for i in range(n):
        ref = e @ (ref - dt * jbar[i] * np.outer(b, c @ ref))
    assert np.max(np.abs(phi - ref)) < 1e-11 * np.max(np.abs(ref))


def test_a_fold_parity_without_a_positive_real_root_gives_a_fold_with_nan():
    """A point the caller places between two folds (parity=True, as the continuation's
    tangent does) where det T(0) >= 0 (no positive real root to locate, the point within
    round-off of a fold): reported unstable, a fold, its exponent not computed: NaN (it was
    written 0.0, a number nothing computed)."""
    pb = sdof_problem(harmonics=20, fa=0.01, b=1.0)
    pt = pb.solve(0.3 / RPM)
    ref = stability(pb, pt)
    assert not ref.fold_parity and ref.kind == "stable"
    st = stability(pb, pt, parity=True)
    assert np.isnan(st.max_real) and st.exponents[0] == ref.exponents[0]
    assert st.kind == "fold" and st.fold_parity and not st.consistent


def test_exponents_of_zero_multipliers_are_minus_infinity_without_warnings():
    """log(mu) / T by decreasing real part; mu = 0 (a direction the period annihilates)
    gives -inf quietly, and the others are exact."""
    import warnings

    from hbm.stability.monodromy import floquet_from_multipliers

    period = 0.01
    mu = np.array([0.0, 0.4, -2.0, 0.3 + 0.4j])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        lam = floquet_from_multipliers(mu, period)
    assert lam[0] == pytest.approx(np.log(complex(-2.0)) / period, rel=1e-14)
    assert lam[1] == pytest.approx(np.log(0.3 + 0.4j) / period, rel=1e-14)
    assert lam[2] == pytest.approx(np.log(0.4) / period, rel=1e-14)
    assert lam[3].real == -np.inf and lam[3].imag == 0.0


def test_a_wider_start_basis_keeps_its_block_size():
    """A neighbour's basis wider than ``columns`` (its multipliers needed it) starts the
    subspace iteration at that width: same exponents, no narrow attempt first."""
    pb, pt = _twenty_modes()
    wide = monodromy_exponents(pb, pt, columns=8, rtol=1.0, max_refine=0)
    assert 4 < wide.columns < 40 and wide.basis.shape == (40, wide.columns)
    again = monodromy_exponents(pb, pt, columns=4, rtol=1.0, max_refine=0, start=wide.basis)
    assert again.columns == wide.columns
    assert again.max_real == pytest.approx(wide.max_real, rel=1e-9)


def test_the_amplification_bound_from_the_last_sweep(monkeypatch):
    """Beyond FULL_AMPLIFICATION_STATES the amplification is the map's on the dominant
    subspace; taken from the subspace iteration's last block and its image it equals the
    one from a further application of the map to the converged basis."""
    from hbm.stability import monodromy as mono

    monkeypatch.setattr(mono, "FULL_AMPLIFICATION_STATES", 10)
    pb, pt = _twenty_modes()
    res = monodromy_exponents(pb, pt, columns=4, rtol=1.0, max_refine=0)
    assert res.basis is not None and not res.amplification_exact
    period = 2 * np.pi / pb.harmonics.fundamental_rad_s(pt.omega)
    step = mono.period_map(pb, mono.orbit_deltas(pb, pt.unknowns, res.n_steps), period)
    again, exact = mono.period_amplification(pb, step, basis=res.basis)
    assert not exact and res.amplification == pytest.approx(again, rel=1e-6)
    whole, exact = mono.period_amplification(pb, step, phi=step(np.eye(40)))
    assert exact and res.amplification <= whole * (1 + 1e-12)        # a lower bound
