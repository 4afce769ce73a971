"""The modal sums of the "loa" condensation (LoaCondensation._modal_sums, eq. 18-19):
H, d and their Omega-derivatives in real arithmetic and blocks of harmonics equal the
sums over the complex receptance arrays of HBMProblem.modal_inverse to round-off, the
derivatives equal finite differences, a rigid mode no element restrains contributes no
static term, and the modal coordinates are those of the recovery."""

import numpy as np
import pytest

import hbm
from hbm import condensation
from tests.test_hbm_recover import _problem


def _reference(pb: hbm.HBMProblem, omega: float):
    """H, dH, d, dd summed over the whole complex arrays (the former formulas)."""
    inv, dinv = pb.modal_inverse(omega)
    ne = pb.n_elements
    h = np.array([[(pb.gj[e] * pb.gj[f]) @ inv for f in range(ne)] for e in range(ne)])
    dh = np.array([[(pb.gj[e] * pb.gj[f]) @ dinv for f in range(ne)] for e in range(ne)])
    gpf = [g[:, None] * (pb.pfc + omega ** 2 * pb.pfu) for g in pb.gj]
    d = np.array([np.einsum("jk,jk->k", x, inv) for x in gpf])
    dd = np.array([np.einsum("jk,jk->k", x, dinv) + 2.0 * omega * np.einsum(
        "jk,jk->k", g[:, None] * pb.pfu, inv) for x, g in zip(gpf, pb.gj, strict=True)])
    return h, dh, d, dd


def _rel(a, b):
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


@pytest.mark.parametrize("block", [1 << 12, condensation.BLOCK_BYTES, 1 << 30])
def test_the_sums_equal_the_complex_arrays(monkeypatch, block):
    monkeypatch.setattr(condensation, "BLOCK_BYTES", block)   # blocks of 1, 9, all harmonics
    pb = _problem()
    assert pb.n_elements == 2 and np.any(pb.pfu) and np.any(pb.pfc)
    for rpm in (900.0, 2600.0):
        omega = rpm * hbm.RPM_TO_RAD_S
        (h, d), (dh, dd) = pb.scheme._compute(omega)
        rh, rdh, rd, rdd = _reference(pb, omega)
        assert _rel(h, rh) < 1e-14 and _rel(dh, rdh) < 1e-13
        # d only at the forced harmonics (zero elsewhere, as the whole sums)
        assert _rel(d, rd) < 1e-14 and _rel(dd, rdd) < 1e-14
        assert np.array_equal(d == 0, rd == 0)


def test_the_derivatives_are_those_of_the_sums():
    pb = _problem()
    omega, eps = 1700.0 * hbm.RPM_TO_RAD_S, 1e-5
    (_, _), (dh, dd) = pb.scheme._compute(omega)
    (hp, dp), _ = pb.scheme._compute(omega * (1 + eps))
    (hm, dm), _ = pb.scheme._compute(omega * (1 - eps))
    assert _rel((hp - hm) / (2 * eps * omega), dh) < 1e-6
    assert _rel((dp - dm) / (2 * eps * omega), dd) < 1e-6


def test_a_free_mode_no_element_restrains_has_no_static_term():
    """Three masses, the first free and untouched by the mesh: its rigid mode is left out
    of the static harmonic (as the complex arrays do), and the sums stay finite."""
    m = np.eye(3)
    k = np.array([[0.0, 0.0, 0.0], [0.0, 2e6, -1e6], [0.0, -1e6, 2e6]])
    c = 1e-4 * k
    mesh = hbm.GearMesh([0.0, 1.0, -1.0], 10, {0: 1e6, 1: 2e5}, te={1: 1e-6},
                        backlash=1e-5)
    exc = hbm.Excitation(3, constant={0: np.array([0.0, 10.0, 0.0])})
    hs = hbm.HarmonicSet.build(10, 3, external_orders=(), sideband_order=0)
    pb = hbm.HBMProblem(hbm.LinearSystem(m, c, k), [mesh], exc, hs, "loa")
    assert pb.modal and np.any(pb.rigid)
    omega = 1200.0 * hbm.RPM_TO_RAD_S
    (h, d), (dh, dd) = pb.scheme._compute(omega)
    rh, rdh, rd, rdd = _reference(pb, omega)
    assert np.all(np.isfinite(h)) and _rel(h, rh) < 1e-14 and _rel(dh, rdh) < 1e-13
    assert _rel(d, rd) < 1e-14


def test_the_modal_coordinates_are_those_of_the_recovery():
    pb = _problem()
    pt = pb.solve(1500.0, tol=1e-11)
    eta = pb.modal_coordinates(pt)
    assert eta.shape == (pb.w2.size, pb.nS)
    q = pb.recover(pt)
    assert np.max(np.abs(pb.phi @ eta - q)) < 1e-14 * np.max(np.abs(q))
    # a quadratic form of every DOF in the modes: q^H W q = eta^H (phi^T W phi) eta
    w = np.random.default_rng(3).standard_normal((pb.n_dof, pb.n_dof))
    w = w @ w.T
    direct = np.einsum("ik,ik->k", q.conj(), w @ q).real
    modal = np.einsum("ik,ik->k", eta.conj(), (pb.phi.T @ w @ pb.phi) @ eta).real
    assert _rel(modal, direct) < 1e-12
