"""HBMProblem.recover in the modes (issue 39 item 5: the NVH export recovers every
point): the coordinates satisfy the dynamic equations of every harmonic and equal the
former two complex products with the modes to round-off, with several elements and a
forcing growing with Omega^2."""

import numpy as np

import hbm
from hbm.examples import modal_damping, synthetic_rom


def _problem() -> hbm.HBMProblem:
    """The synthetic ROM (40 component modes) with its gear mesh and a second mesh between
    other DOF (damping modal in the modes of both), and an unbalance-like forcing ~
    Omega^2."""
    rom = synthetic_rom(40, clustered=False, harmonics=6)
    s, mesh = rom.system, rom.elements[0]
    n = s.M.shape[0]
    g2 = np.zeros(n)
    g2[[0, 4, 6, 10]] = [1.0, 0.03, -1.0, 0.03]
    second = hbm.GearMesh(g2, 20, {0: 2e8, 1: 3e7}, te={1: 1e-6}, backlash=5e-6,
                          name="second mesh")
    kp = s.K + 5e8 * np.outer(mesh.direction, mesh.direction) + 2e8 * np.outer(g2, g2)
    c = modal_damping(s.M, kp, 0.02)
    f0, fu = np.zeros(n, dtype=complex), np.zeros(n, dtype=complex)
    f0[5], f0[11] = 47.0, 47.0
    fu[0], fu[7] = 3e-5, 2e-5j
    exc = hbm.Excitation(n, constant={0: f0}, omega_squared={1: fu})
    hs = hbm.HarmonicSet.build(20, 4, external_orders=(1,), sideband_order=1)
    return hbm.HBMProblem(hbm.LinearSystem(s.M, c, s.K), [mesh, second], exc, hs, "loa")


def test_modal_recovery_solves_the_dynamic_equations():
    pb = _problem()
    assert pb.modal and pb.scheme.name == "loa"
    for rpm in (900.0, 2600.0):
        pt = pb.solve(rpm, tol=1e-11)
        q = pb.recover(pt)                                            # (n, nS)
        # Z'_k q_k = F_k - sum_e g_e f'_e,k for every retained harmonic (eq. 22)
        ft, _ = pb.forces(pb.scheme.delta_real(pt.unknowns), jacobian=False)
        fc = pb.harmonics.to_complex(ft)
        f, _ = pb.forcing(pt.omega)
        rhs = f - sum(fc[e][:, None] * g[None, :] for e, g in enumerate(pb.directions))
        z, _ = pb.dynamic_stiffness(pt.omega)
        lhs = np.einsum("kij,jk->ki", z, q)
        assert np.max(np.abs(lhs - rhs)) < 1e-12 * np.max(np.abs(rhs))
        # the former product with the modes, phi (inv * phi^T rhs^T), to round-off
        inv, _ = pb.modal_inverse(pt.omega)
        ref = pb.phi @ (inv * (pb.phi.T @ rhs.T))
        assert np.max(np.abs(q - ref)) < 1e-13 * np.max(np.abs(ref))
        # the derivative is not needed for the recovery: the receptances are the same
        assert np.array_equal(pb.modal_inverse(pt.omega, derivative=False)[0], inv)
