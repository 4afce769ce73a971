"""hbm on the Kahraman-Singh single-DOF gear pair against time integration."""

import numpy as np
import pytest
from hbm_models import RPM, sdof_problem
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

import hbm

ZETA, FM, ALPHA = 0.05, 0.1, 0.2


def _rhs(fa, b, omega):
    def rhs(t, y):
        x, v = y
        k = 1 + ALPHA * np.cos(omega * t)
        f = k * ((x - b) if x > b else (x + b) if x < -b else 0.0)
        return [v, FM + fa * np.cos(omega * t) - 2 * ZETA * v - f]
    return rhs


def _steady_mesh_load(point, fa, b, n_periods=60):
    """RMS and peak-to-peak of the mesh load at steady state by DOP853 (rtol 1e-10)."""
    w = point.omega
    T = 2 * np.pi / w
    c = point.coefficients[0]
    k = np.arange(c.size)
    y0 = [np.sum(c.real), np.sum((1j * k * w * c).real)]
    rhs = _rhs(fa, b, w)
    opts = dict(method="DOP853", rtol=1e-10, atol=1e-12)
    y1 = solve_ivp(rhs, (0, n_periods * T), y0, **opts).y[:, -1]
    last = solve_ivp(rhs, (0, T), y1, dense_output=True, **opts)
    assert np.max(np.abs(last.y[:, -1] - y1)) < 1e-6          # steady state reached
    t = np.linspace(0, T, 4001)[:-1]
    x = last.sol(t)[0]
    kk = 1 + ALPHA * np.cos(w * t)
    f = kk * (np.where(x > b, x - b, 0) + np.where(x < -b, x + b, 0))
    return np.sqrt(np.mean(f**2)), np.ptp(f)


@pytest.fixture(scope="module")
def rattle_branch():
    pb = sdof_problem(harmonics=40, fa=0.1, b=0.2)
    br = hbm.trace(pb, 2.0 / RPM, 0.3 / RPM, step=0.02, max_step=0.05)
    return pb, br


@pytest.fixture(scope="module")
def softening_branch():
    pb = sdof_problem(harmonics=30, fa=0.05, b=1.0)
    br = hbm.trace(pb, 0.3 / RPM, 1.6 / RPM)
    return pb, br


def test_branch_points_converged(rattle_branch):
    pb, br = rattle_branch
    assert br.status == "completed"
    assert np.all(br.residual < 1e-8)
    for i in range(0, len(br), 37):
        r = pb.residual(br.unknowns[i], br.omega[i])
        assert pb.relative_residual(r, br.unknowns[i]) < 1e-8


@pytest.mark.parametrize("contact", [0, 1, 2])
def test_hbm_matches_time_integration(rattle_branch, contact):
    """Stable points in each contact regime: RMS and peak-to-peak of f_LoA to 1e-3."""
    pb, br = rattle_branch
    candidates = np.flatnonzero((br.element(0).contact == contact) & br.stable)
    assert candidates.size > 3
    i = candidates[candidates.size // 2]
    pt = pb.point(br.unknowns[i], br.omega[i])
    ts = hbm.time_series(pb, pt)
    rms_h, pp_h = np.sqrt(np.mean(ts.load**2)), np.ptp(ts.load)
    rms_t, pp_t = _steady_mesh_load(pt, 0.1, 0.2)
    assert abs(rms_h - rms_t) < 1e-3 * rms_t
    assert abs(pp_h - pp_t) < 1e-3 * pp_t
    st = hbm.point_stats(pb, pt)[0]
    assert abs(st.mesh_load_std - np.std(ts.load)) < 1e-12 * rms_h


def test_softening_jump_has_two_folds_and_unstable_middle(softening_branch):
    pb, br = softening_branch
    assert br.status == "completed"
    assert len(br.folds) == 2
    hi, lo = br.folds
    assert hi > lo
    i1, i2 = br.fold_index
    assert np.all(br.stable[: i1 - 1]) and np.all(br.stable[i2 + 4:])
    assert not np.any(br.stable[i1 + 1: i2 - 4])        # kinks blur the last few points
    # the folds bound the speed range of the middle segment
    mid = br.rpm[i1:i2]
    assert mid.max() <= hi * (1 + 1e-3) and mid.min() >= lo * (1 - 1e-3)
    assert hi >= br.rpm[:i1].max() and lo <= br.rpm[i2:].min()


def test_hill_matches_monodromy(softening_branch):
    """Largest Floquet exponent of an unstable point vs the variational equations."""
    pb, br = softening_branch
    i1, i2 = br.fold_index
    i = (i1 + i2) // 2
    pt = pb.point(br.unknowns[i], br.omega[i])
    lam_max, _ = hbm.floquet_exponents(pb, pt)
    w, T, b = pt.omega, 2 * np.pi / pt.omega, 1.0
    c = pt.coefficients[0]
    k = np.arange(c.size)
    y0 = [np.sum(c.real), np.sum((1j * k * w * c).real)]

    def rhs(t, y):
        x, v = y[:2]
        kk = 1 + ALPHA * np.cos(w * t)
        f = kk * ((x - b) if x > b else (x + b) if x < -b else 0.0)
        s = kk if abs(x) > b else 0.0
        ph = y[2:].reshape(2, 2)
        dph = np.array([[0, 1], [-s, -2 * ZETA]]) @ ph
        return [v, FM + 0.05 * np.cos(w * t) - 2 * ZETA * v - f, *dph.ravel()]

    sol = solve_ivp(rhs, (0, T), [*y0, 1, 0, 0, 1], method="DOP853", rtol=1e-11, atol=1e-13)
    mu = np.linalg.eigvals(sol.y[2:, -1].reshape(2, 2))
    assert lam_max > 0
    # Hill converges slowly for the discontinuous df/dDelta: ~5 % at 30 harmonics
    assert abs(lam_max - np.log(np.max(np.abs(mu))) / T) < 0.1 * lam_max


def test_grazing_matches_time_integration(softening_branch):
    """Speeds where the contact-maintaining periodic orbit of solve_ivp grazes b."""
    pb, br = softening_branch
    assert [(g.kind, g.side) for g in br.grazing] == [("onset", "active"), ("end", "active")]
    from test_hbm_linear import _shoot_linear_contact

    def margin(omega):
        x = _shoot_linear_contact(omega)
        t = np.linspace(0, 2 * np.pi / omega, 4001)
        i = np.argmin(x(t))
        from scipy.optimize import minimize_scalar
        r = minimize_scalar(x, bracket=(t[max(i - 1, 0)], t[i], t[min(i + 1, 4000)]))
        return r.fun - 1.0

    for g, bracket in zip(br.grazing, [(0.7, 0.95), (1.0, 1.3)], strict=True):
        w_ref = brentq(margin, *bracket, xtol=1e-10)
        assert abs(g.rpm * RPM - w_ref) < 1e-6 * w_ref


def test_resume_gives_same_curve(softening_branch):
    pb, full = softening_branch
    seen = []
    part = hbm.trace(pb, 0.3 / RPM, 1.6 / RPM, max_points=20,
                     on_point=lambda b: seen.append(len(b)))
    assert part.status == "max_points" and len(part) == 20
    assert seen[:20] == list(range(1, 21))
    rest = hbm.trace(pb, 0.3 / RPM, 1.6 / RPM, resume=part)
    assert rest.status == "completed"
    assert len(rest) == len(full)
    assert np.max(np.abs(rest.rpm - full.rpm)) < 1e-9 * full.rpm.max()
    assert np.max(np.abs(rest.element(0).coefficients - full.element(0).coefficients)) < 1e-9
    assert [g.rpm for g in rest.grazing] == pytest.approx([g.rpm for g in full.grazing], rel=1e-9)


def test_ipp_and_classification(rattle_branch):
    pb, br = rattle_branch
    mesh = br.element(0)
    i = np.flatnonzero(mesh.contact == 2)[0]
    seq = mesh.ipp[i]
    assert seq.shape == (1,) and seq[0] >= 2         # both flanks hit: >= 2 impacts
    assert np.all(mesh.impacts_per_mesh_period[mesh.contact == 0] == 0)
    assert np.all(mesh.contact_loss_fraction[mesh.contact == 0] == 0)
    assert np.all(mesh.contact_loss_fraction[mesh.contact > 0] > 0)


def test_period_doubling_instability_matches_monodromy(rattle_branch):
    """Unstable points with a negative Floquet multiplier (Im lambda = w0/2)."""
    pb, br = rattle_branch
    found = 0
    for i in np.flatnonzero(~br.stable):
        pt = pb.point(br.unknowns[i], br.omega[i])
        lam_max, exps = hbm.floquet_exponents(pb, pt)
        w, T = pt.omega, 2 * np.pi / pt.omega
        if lam_max < 0.02 or np.min(np.abs(np.abs(exps.imag) - w / 2)) > 1e-6 * w:
            continue
        c = pt.coefficients[0]
        k = np.arange(c.size)
        y0 = [np.sum(c.real), np.sum((1j * k * w * c).real)]

        def rhs(t, y, w=w, b=0.2):
            x, v = y[:2]
            kk = 1 + ALPHA * np.cos(w * t)
            f = kk * ((x - b) if x > b else (x + b) if x < -b else 0.0)
            s = kk if abs(x) > b else 0.0
            dph = np.array([[0, 1], [-s, -2 * ZETA]]) @ y[2:].reshape(2, 2)
            return [v, FM + 0.1 * np.cos(w * t) - 2 * ZETA * v - f, *dph.ravel()]

        sol = solve_ivp(rhs, (0, T), [*y0, 1, 0, 0, 1], method="DOP853", rtol=1e-11,
                        atol=1e-13)
        mu = np.linalg.eigvals(sol.y[2:, -1].reshape(2, 2))
        top = mu[np.argmax(np.abs(mu))]
        assert top.real < 0 and abs(top.imag) < 1e-6 * abs(top)      # period doubling
        assert abs(lam_max - np.log(abs(top)) / T) < 0.1 * lam_max
        found += 1
        if found == 3:
            break
    assert found == 3


def test_trace_from_a_given_start_follows_that_branch(softening_branch):
    """``trace(start=...)`` begins on the coexisting branch its start lies on: inside the
    hysteresis of the softening jump, the upper (resonant) branch, where Newton from the
    linear response finds the lower one. (Sweeping up, the branch runs on the lower
    orbit to the fold at ``hi``, back through the unstable middle to ``lo`` and on along
    the upper orbit.)"""
    pb, full = softening_branch
    i1, i2 = full.fold_index
    lo, hi = min(full.folds), max(full.folds)
    s = 0.5 * (lo + hi)
    upper = np.arange(i2 + 1, len(full))             # after the second fold
    j = upper[np.argmin(np.abs(full.rpm[upper] - s))]
    want = np.interp(s, full.rpm[upper], full.element(0).mesh_load_std[upper])
    low = np.arange(i1)                              # before the first fold
    want_low = np.interp(s, full.rpm[low], full.element(0).mesh_load_std[low])
    assert want > 1.5 * want_low                      # two distinct orbits at s
    plain = hbm.trace(pb, s, 1.6 / RPM, max_points=3)
    given = hbm.trace(pb, s, 1.6 / RPM, max_points=3, start=full.unknowns[j])
    assert plain.element(0).mesh_load_std[0] == pytest.approx(want_low, rel=1e-2)
    assert given.element(0).mesh_load_std[0] == pytest.approx(want, rel=1e-2)
    assert given.rpm[0] == pytest.approx(s, rel=1e-12) and given.stable[0]
    with pytest.raises(ValueError, match="start shape"):
        hbm.trace(pb, s, 1.6 / RPM, start=full.unknowns[j][:-1])
    with pytest.raises(ValueError, match="start and resume"):
        hbm.trace(pb, s, 1.6 / RPM, start=full.unknowns[j], resume=plain)


@pytest.mark.parametrize("guard", [True, False])
def test_a_wide_backlash_does_not_hide_the_softening_jump(softening_branch, guard,
                                                          monkeypatch):
    """The same softening pair with a backlash 100 times wider: the back flank is never
    reached, so the branch is the same, but the unknowns' scale (the backlash) is then
    hundreds of times the vibration and a step past the upper fold moves the scaled unknowns
    by little, whichever orbit it lands on. The orbit-change guard
    (:data:`hbm.predictors.ORBIT_JUMP`) keeps the trace on its branch: both folds and the
    resonant peak as with the narrow backlash. Without it (guard off) the trace steps
    from the lower orbit over the hysteresis and reports a completed branch without it."""
    import hbm.continuation.predictors as hp

    pb, ref = softening_branch
    if not guard:
        monkeypatch.setattr(hp, "ORBIT_JUMP", np.inf)
    wide = sdof_problem(harmonics=30, fa=0.05, b=100.0)
    br = hbm.trace(wide, 0.3 / RPM, 1.6 / RPM, step=0.05, max_step=0.1, stability=False)
    assert br.status == "completed"
    if not guard:                                # the failure the guard is for
        assert br.folds == [] and br.element(0).mesh_load_std.max() < \
            0.6 * ref.element(0).mesh_load_std.max()
        return
    assert sorted(br.folds) == pytest.approx(sorted(ref.folds), rel=2e-3)
    assert br.element(0).mesh_load_std.max() == pytest.approx(ref.element(0).mesh_load_std.max(),
                                                               rel=1e-3)
