"""hbm on stiff and extreme cases: every point verified independently, or a clear refusal.

References: time integration started on the HBM orbit (``hbm.shooting_error``),
the uncondensed harmonic balance (``hbm.full_residual``), the Omega -> 0
pointwise statics (``hbm.quasi_static_delta``), dense solves of the condensed
compliances, doubled harmonic counts and AFT grids, the same model in other
units. The heavy variants are in ``benchmarks/bench_extreme.py``.
"""

import logging

import numpy as np
import pytest

import hbm
from hbm.examples import Geared3, synthetic_rom
from hbm.newton import COND_WARN, solve_checked

TOL = 1e-8
FULL = 100 * TOL     # uncondensed, per-DOF residual of a point converged to TOL


def _trace(mdl: Geared3, lo=0.6, hi=1.4, **kw) -> tuple[hbm.HBMProblem, hbm.Branch]:
    pb = mdl.problem()
    r = mdl.mesh_rpm()
    return pb, hbm.trace(pb, lo * r, hi * r, stability=False, **kw)


def _verified(pb: hbm.HBMProblem, br: hbm.Branch, every: int = 1) -> float:
    """All points below tol; largest uncondensed residual (independent check)."""
    assert len(br) > 0
    assert np.all(br.residual < TOL)
    assert np.all(np.isfinite(br.element(0).coefficients))
    return max(hbm.full_residual(pb, pb.point(u, w))
               for u, w in zip(br.unknowns[::every], br.omega[::every], strict=True))


def _shoot(pb: hbm.HBMProblem, br: hbm.Branch) -> float:
    """Time-integration error at the point of largest dynamic mesh load."""
    i = int(np.argmax(br.element(0).mesh_load_std))
    return hbm.shooting_error(pb, pb.point(br.unknowns[i], br.omega[i])).relative


@pytest.mark.parametrize("km", [1e6, 1e11])
def test_stiff_mesh_against_soft_structure(km):
    """Mesh 10 to 10^6 times stiffer than the bearing: same inertia, verified curves."""
    mdl = Geared3(km=km)
    pb, br = _trace(mdl)
    assert br.status == "completed"
    assert _verified(pb, br) < FULL
    # 1e6: permanent contact (smooth, near-exact); 1e11: 10 nm static deflection
    # against 1 um of TE, impacts at every point (H = 20 truncation)
    assert _shoot(pb, br) < (1e-7 if km == 1e6 else 3e-3)
    if km == 1e11:
        assert np.all(br.element(0).contact >= 1)
        # the uncondensed formulation lands on the same point
        i = int(np.argmax(br.element(0).mesh_load_std))
        full = Geared3(km=km, condensation="none").problem()
        q = pb.recover(pb.point(br.unknowns[i], br.omega[i]))
        pf = full.solve(br.rpm[i], x0=full.harmonics.to_real(q).ravel(), tol=1e-10)
        ci = br.element(0).coefficients[i]
        assert np.max(np.abs(pf.coefficients[0] - ci)) < 1e-8 * np.max(np.abs(ci))


@pytest.mark.parametrize("zeta", [0.005, 0.2])
def test_modal_damping_extremes(zeta):
    pb, br = _trace(Geared3(zeta=zeta, te=3e-6), max_points=5000)
    assert br.status == "completed"
    assert _verified(pb, br, every=10) < FULL
    assert _shoot(pb, br) < 1e-3


@pytest.mark.parametrize("b", [1e-7, 1e-3])
def test_backlash_from_tenth_of_micrometre_to_millimetre(b):
    pb, br = _trace(Geared3(b=b, te=5e-6))
    assert br.status == "completed"
    assert pb.length_scales[0] == pytest.approx(max(b, 8e-6), rel=0.01)   # b or static deflection
    assert _verified(pb, br, every=5) < FULL
    assert _shoot(pb, br) < 1e-3
    assert set(np.unique(br.element(0).contact)) & {1, 2}


def test_rattle_at_zero_static_load():
    """TE 20 um > backlash 10 um, no torque: double-sided impacts, same curve as a tiny torque."""
    out = []
    for torque in (0.0, 1e-6):
        pb, br = _trace(Geared3(torque=torque, te=20e-6, b=10e-6))
        assert br.status == "completed"
        assert _verified(pb, br, every=10) < FULL
        assert np.any(br.element(0).contact == 2)
        out.append((pb, br))
    (pb, br), (_, br2) = out
    assert _shoot(pb, br) < 1e-3
    assert len(br) == len(br2)
    c1, c2 = br.element(0).coefficients, br2.element(0).coefficients
    assert np.max(np.abs(c1 - c2)) < 1e-6 * np.max(np.abs(c1))


def test_large_transmission_error_permanent_impacts():
    """TE 100 times the static deflection: above the speed where the TE acceleration
    beats the load, double-sided impacts in every period."""
    pb, br = _trace(Geared3(te=1e-3, harmonics=30), max_points=3000)
    assert br.status == "completed"
    assert np.mean(br.element(0).contact == 2) > 0.6
    assert np.all(br.element(0).contact[br.rpm > 1.2 * Geared3().mesh_rpm()] == 2)
    assert _verified(pb, br, every=10) < FULL
    assert _shoot(pb, br) < 1e-3


def test_speed_near_zero_is_quasi_static_and_top_speed_matches_time_integration():
    mdl = Geared3(te=20e-6, harmonics=60)
    pb = mdl.problem()
    ref = hbm.quasi_static_delta(pb)[0]
    assert np.ptp(ref) > 1e-5                 # the gear follows the 20 um TE
    for rpm, bound in ((1e-6, 1e-10), (1e-3, 1e-7)):
        pt = pb.solve(rpm)
        assert pt.residual < 1e-12
        err = np.max(np.abs(pb.E @ pt.unknowns - ref)) / np.ptp(ref)
        assert err < bound
    top = pb.solve(1000 * mdl.mesh_rpm(), tol=1e-12)
    assert hbm.full_residual(pb, top) < 1e-10
    assert hbm.shooting_error(pb, top).relative < 1e-3
    with pytest.raises(ValueError, match="rpm"):
        pb.solve(0.0)


def test_sixty_and_more_harmonics_converge():
    mdl = Geared3(te=20e-6)
    rpm = 0.9 * mdl.mesh_rpm()
    pts = {}
    for h in (60, 120):
        m = Geared3(te=20e-6, harmonics=h)
        pb = m.problem()
        pts[h] = (pb, pb.solve(rpm, tol=1e-12))
        assert pts[h][1].residual < 1e-12
        assert hbm.full_residual(pb, pts[h][1]) < 1e-10
    (p60, x60), (p120, x120) = pts[60], pts[120]
    n = p120.harmonics.n_time
    d60 = (p60.fine_grid(n)[0] @ p60.delta_real(x60.unknowns))[0]
    d120 = p120.E @ x120.unknowns
    assert np.max(np.abs(d60 - d120)) / np.ptp(d120) < 1e-4
    assert hbm.shooting_error(p60, x60).relative < 3e-5
    assert hbm.shooting_error(p120, x120).relative < 3e-6


def test_very_fine_aft_grid_agrees_with_default():
    mdl = Geared3(te=20e-6, harmonics=30)
    rpm = 0.9 * mdl.mesh_rpm()
    base = mdl.problem()
    p0 = base.solve(rpm)
    assert base.harmonics.n_time == 256
    for n in (4096, 16384):
        pb = Geared3(te=20e-6, harmonics=30, n_time=n).problem()
        pt = pb.solve(rpm)
        assert pt.residual < 1e-12 and hbm.full_residual(pb, pt) < 1e-10
        d = (pb.fine_grid(256)[0] @ pb.delta_real(pt.unknowns))[0]
        d0 = base.E @ p0.unknowns
        # aliasing of the default grid is below the truncation error of H = 30
        assert np.max(np.abs(d - d0)) / np.ptp(d0) < 1e-4
        assert hbm.shooting_error(pb, pt).relative < 3e-4


@pytest.mark.parametrize("clustered", [False, True])
def test_rom_with_hundreds_of_modes(clustered):
    """312-DOF ROM, 300 modes spread 200 Hz - 20 kHz or in 30 clusters of 10."""
    pb = synthetic_rom(300, clustered)
    assert pb.modal
    br = hbm.trace(pb, 4500.0, 7000.0, stability=False)
    assert br.status == "completed"
    assert _verified(pb, br, every=4) < FULL
    for i in (0, len(br) // 2, len(br) - 1):
        (h, d), _ = pb.scheme.receptance(br.omega[i])
        z, _ = pb.dynamic_stiffness(br.omega[i])
        f, _ = pb.forcing(br.omega[i])
        g = pb.directions[0]
        h, d = h[0, 0], d[0]
        x = np.linalg.solve(z, np.stack([np.broadcast_to(g, f.shape), f], -1))
        assert np.max(np.abs(h - x[..., 0] @ g)) < 1e-10 * np.max(np.abs(h))
        assert np.max(np.abs(d - x[..., 1] @ g)) < 1e-10 * np.max(np.abs(d))


@pytest.mark.parametrize("condensation", ["loa", "gear", "none"])
def test_badly_scaled_units_give_identical_curves(condensation):
    """m/N against um/N, km/MN and um/uN (rotations stay in rad): same branch."""
    r = Geared3(km=1e9).mesh_rpm()
    out = []
    for ell, phi in ((1.0, 1.0), (1e-6, 1.0), (1e3, 1e6), (1e-6, 1e-6)):
        pb = Geared3(km=1e9, te=5e-6, length_unit=ell, force_unit=phi,
                     condensation=condensation).problem()
        assert pb.length_scales[0] * ell == pytest.approx(1e-5, rel=1e-12)
        br = hbm.trace(pb, 0.6 * r, 1.4 * r, stability=False)
        assert br.status == "completed"
        out.append((br, ell))
    si = out[0][0]
    for br, ell in out[1:]:
        assert len(br) == len(si)
        assert np.max(np.abs(br.rpm - si.rpm)) < 1e-9 * si.rpm.max()
        c, c_si = br.element(0).coefficients, si.element(0).coefficients
        assert np.max(np.abs(c * ell - c_si)) < 1e-9 * np.max(np.abs(c_si))


def test_condition_estimate_is_reported(caplog):
    """LU + LAPACK gecon: the estimate tracks cond_1, is logged when poor, and a
    singular matrix is refused with the reason."""
    n = 9
    hilb = 1.0 / (np.arange(n)[:, None] + np.arange(n)[None, :] + 1.0)
    x_true = np.ones(n)
    with caplog.at_level(logging.WARNING, logger="hbm.newton"):
        x, cond = solve_checked(hilb, hilb @ x_true, "test")
    exact = np.linalg.cond(hilb, 1)
    assert exact > COND_WARN
    assert exact / 10 < cond < exact * 10
    assert "ill-conditioned" in caplog.text and f"{cond:.2g}" in caplog.text
    assert np.max(np.abs(x - x_true)) < 1e-3
    with pytest.raises(hbm.ConvergenceError, match="singular Jacobian") as err:
        solve_checked(np.ones((3, 3)), np.ones(3), "test")
    assert err.value.condition == np.inf
    _, good = solve_checked(np.eye(4) * 1e-20, np.ones(4), "test")     # scale-free
    assert good == pytest.approx(1.0)


def test_continuation_retries_cut_steps_and_change_predictor():
    """One Newton iteration per corrector: the trace still completes, through step
    cuts and retries with the other predictors; every point is converged."""
    mdl = Geared3(te=5e-6)
    pb, ref = _trace(mdl)
    _, br = _trace(mdl, max_iter=1, max_points=5000)
    assert br.status == "completed"
    # retried with the corner predictor (spherical corrector), which then succeeds
    assert br.step_cuts > 10 and br.corner_steps > 10
    assert ref.step_cuts < br.step_cuts / 10
    assert np.all(br.residual < TOL)
    # one iteration, plus at most one refinement step (patient retry: 4 + 1)
    it = br.newton_iterations[1:-1]            # (ends: fixed-speed Newton solves)
    assert np.mean(it <= 2) > 0.9 and it.max() <= 5
    # same curve: points of the forced run lie on the reference branch
    i = len(br) // 2
    pt = pb.solve(br.rpm[i], x0=br.unknowns[i], tol=1e-12)
    assert np.max(np.abs(pt.coefficients[0] - br.element(0).coefficients[i])) < 1e-6 * np.max(
        np.abs(pt.coefficients))


def test_continuation_that_must_stop_keeps_last_good_point(caplog):
    """A solver that breaks down past 9000 rpm (non-finite residual, a stand-in for
    any failure): every retry fails, the trace stops with the reason logged, and the
    branch (and the last checkpoint) holds the converged points up to the failure."""
    mdl = Geared3(te=5e-6)
    pb = mdl.problem()
    scaled = pb.scaled

    def broken(x, omega, jacobian=True, law=1.0):
        out = scaled(x, omega, jacobian, law)
        if omega > 9000 * hbm.RPM_TO_RAD_S:
            return (out[0] * np.nan, *out[1:]) if jacobian else out * np.nan
        return out

    pb.scaled = broken
    snapshots = []
    r = mdl.mesh_rpm()
    with caplog.at_level(logging.WARNING, logger="hbm.continuation"):
        br = hbm.trace(pb, 0.6 * r, 1.4 * r, stability=False, on_point=snapshots.append)
    assert br.status == "step_failed"
    assert "min_step" in br.message and "non-finite residual" in br.message
    assert "continuation stopped" in caplog.text and br.message in caplog.text
    assert len(br) > 10 and 8900 < br.rpm[-1] <= 9000
    assert br.step_cuts >= 4
    assert np.all(br.residual < TOL)
    assert snapshots[-1].status == "step_failed" and len(snapshots[-1]) == len(br)
    assert np.array_equal(snapshots[-1].unknowns, br.unknowns)
    pb.scaled = scaled
    assert _verified(pb, br) < FULL


def test_start_failure_is_approached_or_reported(caplog):
    """Large TE under full load: Newton, the contact-law homotopy and damped Newton
    all fail at the start speed. Without fallback the branch is empty and says why;
    with it, the start is reached by continuation from a quarter of the speed."""
    mdl = Geared3(torque=47.0, te=20e-6, b=10e-6)
    # with the C1 (kink-corrected) AFT, Newton converges at the start directly ...
    pb, br = _trace(mdl, start_fallback=False)
    assert br.status == "completed" and len(br) > 100
    # ... with the plain samples (piecewise-linear residual) it cycles and fails
    r = mdl.mesh_rpm()
    pb = mdl.problem()
    pb.aft = "sampled"
    with caplog.at_level(logging.ERROR, logger="hbm.continuation"):
        br = hbm.trace(pb, 0.6 * r, 1.4 * r, stability=False, start_fallback=False)
    assert br.status == "start_failed" and len(br) == 0
    assert "rpm_start" in br.message and "Newton" in br.message
    assert br.message in caplog.text
    with caplog.at_level(logging.WARNING, logger="hbm.continuation"):
        br = hbm.trace(pb, 0.6 * r, 1.4 * r, stability=False)
    assert "approaching it by continuation" in caplog.text
    assert br.status == "completed"
    assert br.rpm[0] == pytest.approx(0.6 * mdl.mesh_rpm(), rel=1e-12)
    assert _verified(pb, br, every=10) < FULL
    assert _shoot(pb, br) < 1e-3
