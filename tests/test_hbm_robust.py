"""hbm: unit-independent scaling, stiff meshes, sparse harmonic sets, checkpoints."""

import numpy as np
import pytest
from hbm_models import RPM, gear_and_stiff_mode_problem, random_modal_system

import hbm


def _physical_pair(length_unit=1.0, kbar=1e8, mass=2.0, b=10e-6):
    """Single-DOF pair in SI, or with lengths expressed in ``length_unit`` metres."""
    s = 1.0 / length_unit            # numbers per metre
    fm, fa = 2e-6 * kbar, 0.5e-6 * kbar    # 2 um static deflection
    wn = np.sqrt(kbar / mass)
    system = hbm.LinearSystem(M=[[mass / s]], C=[[2 * 0.05 * wn * mass / s]], K=[[0.0]])
    mesh = hbm.GearMesh(direction=[1.0], n_teeth=20,
                        stiffness={0: kbar / s, 1: 0.15 * kbar / s},
                        te={1: 0.5e-6 * s * 1j}, backlash=b * s)
    exc = hbm.Excitation(1, constant={0: [fm], 20: [fa]})
    hs = hbm.HarmonicSet.build(20, 24)
    return hbm.HBMProblem(system, [mesh], exc, hs, "loa"), wn


@pytest.mark.parametrize("kbar", [1e6, 1e11])
def test_branch_is_independent_of_length_unit(kbar):
    """Same physics in metres and in micrometres: same points, Delta scaled by 1e6."""
    out = []
    for unit in (1.0, 1e-6):
        pb, wn = _physical_pair(unit, kbar=kbar)
        rpm_n = wn / 20 / RPM            # mesh frequency at the natural frequency
        out.append(hbm.trace(pb, 0.5 * rpm_n, 1.5 * rpm_n, stability=False))
    si, micro = out
    assert si.status == micro.status == "completed"
    assert len(si.grazing) >= 1
    assert len(si) == len(micro)
    assert np.max(np.abs(si.rpm - micro.rpm)) < 1e-9 * si.rpm.max()
    c_si, c_micro = si.element(0).coefficients, micro.element(0).coefficients
    assert np.max(np.abs(c_si * 1e6 - c_micro)) < 1e-8 * np.max(np.abs(c_micro))
    assert np.allclose(si.element(0).mesh_load_std, micro.element(0).mesh_load_std, rtol=1e-8)
    assert [g.rpm for g in si.grazing] == pytest.approx([g.rpm for g in micro.grazing],
                                                         rel=1e-8)


def test_shaft_fundamental_branch_with_sidebands():
    """6 DOF, Z = 4, external order 1: sparse set, Hill by eigenvector weight, IPP per tooth."""
    m, c, k, g = random_modal_system(n=6, seed=2, zeta=0.04, kbar=2e3, n_gear=4)
    system = hbm.LinearSystem(m, c, k)
    mesh = [hbm.GearMesh(g, 4, {0: 2e3, 1: 400}, te={1: 3e-3j}, backlash=2e-3)]
    exc = hbm.Excitation(6, constant={0: 4 * g, 1: 0.5 * g})
    hs = hbm.HarmonicSet.build(4, 4, external_orders=(1,), sideband_order=1)
    assert hs.indices != tuple(range(hs.n_harmonics))
    pb = hbm.HBMProblem(system, mesh, exc, hs, "loa")
    br = hbm.trace(pb, 20.0, 120.0, max_points=2000, max_step=0.1, stability=False)
    assert br.status == "completed"
    # Hill by eigenvector weight on a few points: permanent contact is stable
    for i in np.flatnonzero(br.element(0).contact == 0)[::25]:
        lam, exps = hbm.floquet_exponents(pb, pb.point(br.unknowns[i], br.omega[i]))
        assert lam < 0 and exps.size == 12
    assert np.all(br.residual < 1e-8)
    assert br.element(0).ipp.shape == (len(br), 4)
    assert np.all(br.element(0).impacts_per_mesh_period == br.element(0).ipp.mean(axis=1))
    assert set(np.unique(br.element(0).contact)) >= {0, 1}
    # the gear-condensed and full solutions at a branch point coincide with loa
    i = int(np.argmax(br.element(0).contact_loss_fraction))
    q_loa = pb.recover(pb.point(br.unknowns[i], br.omega[i]))
    full = hbm.HBMProblem(system, mesh, exc, hs, "none")
    q_full = full.recover(full.solve(br.rpm[i], x0=hs.to_real(q_loa).ravel()))
    assert np.max(np.abs(q_full - q_loa)) < 1e-9 * np.max(np.abs(q_loa))


def test_checkpoint_callback_sees_only_converged_points():
    m, c, k, g = random_modal_system(n=6, seed=2, zeta=0.04, kbar=2e3, n_gear=4)
    pb = hbm.HBMProblem(hbm.LinearSystem(m, c, k),
                        [hbm.GearMesh(g, 4, {0: 2e3}, te={1: 3e-3j}, backlash=2e-3)],
                        hbm.Excitation(6, constant={0: 4 * g}), hbm.HarmonicSet.build(4, 6))
    snapshots = []
    br = hbm.trace(pb, 10.0, 40.0, on_point=lambda b: snapshots.append(b), stability=False)
    assert snapshots[-1].status == br.status == "completed"
    assert all(np.all(s.residual < 1e-8) for s in snapshots)
    assert [len(s) for s in snapshots] == [*range(1, len(br)), len(br)]


def test_truncated_hill_with_residual_compliance_matches_full():
    """Gear mode + a weakly coupled stiff mode: Hill on the gear mode alone (the
    other one as residual compliance) gives the same verdicts as the full Hill."""
    pb = gear_and_stiff_mode_problem()
    br = hbm.trace(pb, 0.3 / RPM, 1.6 / RPM)
    assert br.status == "completed" and len(br.folds) == 2
    assert not np.all(br.stable)
    for i in range(len(br)):
        pt = pb.point(br.unknowns[i], br.omega[i])
        lam, exps = hbm.floquet_exponents(pb, pt, max_size=2 * pb.nr, method="hill")
        assert exps.size == 2
        full, _ = hbm.floquet_exponents(pb, pt, max_size=10 ** 6, method="hill")
        # worst point (68 % contact loss): 6.1e-4 with the plain AFT samples, 1.9e-3 with
        # the kink-corrected ones (T.13a), whose 2x4 blocks the residual compliance of the
        # dropped mode does not see
        assert abs(lam - full) < 3e-3 * (abs(full) + 0.01)
