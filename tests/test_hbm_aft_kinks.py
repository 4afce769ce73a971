"""The kink-corrected AFT samples of the dead-zone force (T.13a, hbm/contact.py)."""

import numpy as np
import pytest

import hbm
from hbm.elements.contact_law import dead_zone, dead_zone_stiffness, kink_correction
from hbm.examples import Geared3

B = 0.3


def _signal(n: int, shift: float = 0.0):
    tau = 2 * np.pi * np.arange(n) / n
    p = 0.8 * np.sin(tau) + 0.2 * np.cos(3 * tau) + 0.101 + shift
    k = 1.0 + 0.2 * np.cos(5 * tau)
    return tau, p, k


def _corrected(p, k):
    return dead_zone(p, k, B) + kink_correction(p, k, B).values


def test_derivative_blocks_equal_finite_differences():
    _, p, k = _signal(64)
    kc = kink_correction(p, k, B)
    assert kc.nodes.size == 4                          # two contacts, both flanks
    n = p.size
    jac = np.diag(dead_zone_stiffness(p, k, B)) + np.array([kc.apply(e) for e in np.eye(n)]).T
    fd = np.empty((n, n))
    h = 1e-7
    for i in range(n):
        e = np.zeros(n)
        e[i] = h
        fd[:, i] = (_corrected(p + e, k) - _corrected(p - e, k)) / (2 * h)
    assert np.max(np.abs(jac - fd)) < 1e-7


def test_galerkin_mean_converges_faster_than_the_plain_samples():
    """Mean of k g(p) over a period: plain samples O(h^2), corrected O(h^3) or better."""
    _, pf, kf = _signal(2 ** 18)
    exact = np.mean(dead_zone(pf, kf, B))
    err_plain, err_corr = [], []
    for n in (64, 128, 256):
        _, p, k = _signal(n)
        err_plain.append(abs(np.mean(dead_zone(p, k, B)) - exact))
        err_corr.append(abs(np.mean(_corrected(p, k)) - exact))
    assert all(c < 0.05 * q for c, q in zip(err_corr, err_plain, strict=True))
    assert err_corr[0] / err_corr[2] > 30                 # >= h^2.5 over a factor 4 in h


def test_samples_are_smooth_along_a_path_that_moves_the_crossings():
    """The change of slope between small steps: O(step) when corrected, O(1) jumps plain."""
    tau, p, k = _signal(64)
    steps = np.linspace(0.0, 0.2, 4001)
    for w in (np.ones_like(tau), np.cos(3 * tau)):      # mean and a harmonic
        corr = np.array([w @ _corrected(p + s, k) for s in steps])
        plain = np.array([w @ dead_zone(p + s, k, B) for s in steps])
        dc = np.abs(np.diff(np.diff(corr) / np.diff(steps)))
        dp = np.abs(np.diff(np.diff(plain) / np.diff(steps)))
        assert dc.max() < 0.1 * dp.max()


def test_stiff_impacts_on_a_coarse_grid_match_the_dense_grid():
    """Stiff mesh (1e11 N/m), 87 % contact loss, 21 harmonics: at 256 samples the
    corrected AFT gives the 8192-sample mesh-load std to 1e-6, the plain one to 5e-4."""
    r = Geared3(km=1e11).mesh_rpm()
    std = {}
    for nt in (256, 8192):
        for aft in ("sampled", "corrected"):
            pb = Geared3(km=1e11, n_time=nt).problem()
            pb.aft = aft
            br = hbm.trace(pb, 0.6 * r, 1.2 * r, stability=False)
            assert br.status == "completed"
            pt = pb.solve(1.2 * r, x0=br.unknowns[-1], tol=1e-12)
            std[nt, aft] = hbm.point_stats(pb, pt)[0].mesh_load_std
    ref = std[8192, "corrected"]
    assert std[8192, "sampled"] == pytest.approx(ref, rel=3e-7)
    assert std[256, "corrected"] == pytest.approx(ref, rel=1e-6)
    assert abs(std[256, "sampled"] / ref - 1) > 1e-4
