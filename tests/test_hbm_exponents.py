"""Exact real exponents on the line of action (T.9) against the dense Hill matrix.

The dense reference keeps every mode and every harmonic of the set (companion
matrix of size 2 m n_real, all eigenvalues); the line-of-action test uses only the
n_real-sized ``T(lam) = I + R(lam) J_f``.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla
from hbm_models import (
    RPM,
    gear_and_stiff_mode_problem,
    random_mesh_problem,
    random_modal_system,
    sdof_problem,
)

import hbm
from hbm.basis import real_blocks
from hbm.stability.exponents import (
    classify_exponent,
    det_sign,
    line_of_action_operator,
    positive_real_root,
    real_root_bound,
)


def _dense_hill_eigenvalues(pb, pt):
    """All eigenvalues of the Hill companion matrix of every non-rigid mode (T.8)."""
    keep = np.flatnonzero(~pb.rigid)
    m, nr = keep.size, pb.nr
    w0 = pb.harmonics.fundamental_rad_s(pt.omega)
    w = pb.kS * w0
    jf = pb.element_jacobian(pb.delta_real(pt.unknowns))
    cm, km, g = np.diag(pb.cj[keep]), np.diag(pb.w2[keep]), pb.gj[0][keep]
    z0 = km[None] - (w ** 2)[:, None, None] * np.eye(m)[None] + 1j * w[:, None, None] * cm[None]
    z1 = cm[None] + 2j * w[:, None, None] * np.eye(m)[None]
    d0 = real_blocks(z0, nr) + np.kron(np.outer(g, g), jf)
    n = m * nr
    a = np.zeros((2 * n, 2 * n))
    a[:n, n:] = np.eye(n)
    a[n:, :n] = -d0
    a[n:, n:] = -real_blocks(z1, nr)
    return sla.eigvals(a), jf, w0


def _two_dof():
    return gear_and_stiff_mode_problem(), 0.3 / RPM, 1.6 / RPM


def _twelve_dof():
    pb = random_mesh_problem(n=12, seed=1, zeta=0.02, n_gear=6, k1=400, harmonics=8)
    w = np.sqrt(pb.w2[~pb.rigid])
    return pb, 0.3 * w.min() / RPM, 1.5 * w.max() / RPM


def _sparse_set():
    """Shaft fundamental with external order 4 and sidebands (a sparse harmonic set, as
    the pump's): the eigenvector-weight selection alone misses fold exponents here."""
    m, c, k, g = random_modal_system(n=8, seed=1, zeta=0.02, kbar=2e3, n_gear=6)
    pb = hbm.HBMProblem(hbm.LinearSystem(m, c, k),
                        [hbm.GearMesh(g, 4, {0: 2e3, 1: 400}, backlash=1e-3)],
                        hbm.Excitation(8, constant={0: 2.0 * g, 1: 0.3 * g, 4: 1.0 * g}),
                        hbm.HarmonicSet.build(4, 2, external_orders=(1,), sideband_order=1))
    w = np.sqrt(pb.w2[~pb.rigid])
    return pb, 0.3 * w.min() / 4 / RPM, 1.3 * w.max() / 4 / RPM


CASES = {"sparse": _sparse_set,
         "sdof": lambda: (sdof_problem(harmonics=30, fa=0.05, b=1.0), 0.3 / RPM, 1.6 / RPM),
         "2dof": _two_dof, "12dof": _twelve_dof}


# branches whose speed-decreasing segments all carry a real positive exponent; the
# 12-DOF branch also turns at corners of the dead zone, where the speed may decrease
# on a stable orbit (the dense Hill matrix has no exponent with Re > 0 there)
SADDLE_NODE_ONLY = {"sparse", "sdof", "2dof"}


@pytest.fixture(scope="module", params=sorted(CASES))
def branch(request):
    pb, r0, r1 = CASES[request.param]()
    br = hbm.trace(pb, r0, r1, max_points=3000, stability=False)
    assert br.status == "completed" and len(br.folds) >= 2
    return request.param, pb, br


def _decreasing(br) -> np.ndarray:
    """Points inside a segment where the speed decreases along the branch, one point
    away from its turns (at a turn two real exponents may pair off into a complex one
    near the real axis: an even count, see docs/theory.md T.9)."""
    d = np.diff(br.rpm)
    down = np.r_[False, (d[:-1] < 0) & (d[1:] < 0), False]
    return np.flatnonzero(down & np.roll(down, 1) & np.roll(down, -1))


def test_segments_between_folds_are_unstable(branch):
    """Hill truncated to a few modes plus the exact real root (T.9): every point inside
    a speed-decreasing segment between two saddle-node folds is unstable, and every
    point where the dense Hill matrix has an odd number of real positive exponents."""
    name, pb, br = branch
    inner = _decreasing(br)
    assert inner.size >= 3
    for i in inner[:: max(1, inner.size // 40)]:
        pt = pb.point(br.unknowns[i], br.omega[i])
        lam, _ = hbm.floquet_exponents(pb, pt)
        lam_hill, _ = hbm.floquet_exponents(pb, pt, 200, method="hill")
        if name in SADDLE_NODE_ONLY:
            assert lam > 0 and lam_hill > 0, br.rpm[i]
        dense, _, _ = _dense_hill_eigenvalues(pb, pt)
        real_pos = dense.real[(np.abs(dense.imag) <= 1e-7 * np.abs(dense)) & (dense.real > 0)]
        if real_pos.size % 2:
            assert lam > 0, br.rpm[i]
            assert lam_hill >= real_pos.max() * (1 - 1e-8), br.rpm[i]


def test_real_root_matches_dense_hill(branch):
    """Parity of the real positive exponents from sign det T(0) and the located root,
    against every eigenvalue of the dense Hill matrix (all modes), to 1e-8."""
    _, pb, br = branch
    inner = _decreasing(br)
    others = np.setdiff1d(np.arange(len(br)), inner)[::15]
    checked = 0
    for i in np.r_[inner[:: max(1, inner.size // 6)], others[:6]]:
        pt = pb.point(br.unknowns[i], br.omega[i])
        lam, jf, w0 = _dense_hill_eigenvalues(pb, pt)
        real_pos = lam.real[(np.abs(lam.imag) <= 1e-7 * np.abs(lam)) & (lam.real > 0)]
        sign = det_sign(line_of_action_operator(pb, jf, 0.0, w0).real)
        assert (sign < 0) == (real_pos.size % 2 == 1), br.rpm[i]
        assert real_root_bound(pb, jf) > np.max(lam.real)
        root = positive_real_root(pb, jf, w0)
        if sign < 0:
            assert np.min(np.abs(real_pos - root)) <= 1e-8 * root, (br.rpm[i], root, real_pos)
            checked += 1
        else:
            assert np.isnan(root)
    assert checked >= 3


def test_line_of_action_operator_is_the_newton_matrix():
    """T(0) is the Jacobian of the 'loa' residual, and dT/dlam its finite difference."""
    pb, r0, r1 = _twelve_dof()
    pt = pb.solve(0.5 * (r0 + r1))
    jf = pb.element_jacobian(pb.delta_real(pt.unknowns))
    w0 = pb.harmonics.fundamental_rad_s(pt.omega)
    ju, _ = pb.jacobian(pt.unknowns, pt.omega)
    np.testing.assert_allclose(line_of_action_operator(pb, jf, 0.0, w0), ju, atol=1e-12)
    lam, h = 0.3 + 2.0j, 1e-6
    t, dt = line_of_action_operator(pb, jf, lam, w0, derivative=True)
    fd = (line_of_action_operator(pb, jf, lam + h, w0)
          - line_of_action_operator(pb, jf, lam - h, w0)) / (2 * h)
    assert np.max(np.abs(fd - dt)) <= 1e-7 * np.max(np.abs(dt))


@pytest.mark.parametrize(("lam", "kind"), [(0.5 + 0j, "fold"), (0.5 + 3.0j, "fold"),
                                           (0.5 + 1.5j, "period_doubling"),
                                           (0.5 - 4.5j, "period_doubling"),
                                           (0.5 + 0.7j, "neimark_sacker")])
def test_classify_exponent(lam, kind):
    assert classify_exponent(lam, w0=3.0) == kind
