"""The dead-zone law of eq. (13), hbm.elements.contact_law, against the piecewise-linear
law by hand."""
from __future__ import annotations

import numpy as np

from hbm.elements.contact_law import dead_zone, dead_zone_stiffness


def test_dead_zone_by_hand():
    b = 1e-5                                   # half backlash, m
    k = 2e8                                    # mesh stiffness, N/m
    p = np.array([3e-5, 1e-5, 0.5e-5, 0.0, -1e-5, -4e-5])
    # active flank k (p - b), gap 0 (edges included), reverse flank k (p + b)
    expected = np.array([2e8 * 2e-5, 0.0, 0.0, 0.0, 0.0, 2e8 * -3e-5])
    np.testing.assert_allclose(dead_zone(p, k, b), expected, rtol=1e-15, atol=0.0)
    np.testing.assert_array_equal(dead_zone_stiffness(p, k, b), [k, 0, 0, 0, 0, k])


def test_time_varying_stiffness_and_zero_backlash():
    p = np.array([2e-6, -2e-6, 5e-6])
    k = np.array([1e8, 3e8, 5e8])              # k_m(t) per sample
    np.testing.assert_allclose(dead_zone(p, k, 0.0), [200.0, -600.0, 2500.0], rtol=1e-15)
    np.testing.assert_allclose(dead_zone(p, k, 3e-6), [0.0, 0.0, 5e8 * 2e-6], rtol=1e-15)
    np.testing.assert_array_equal(dead_zone_stiffness(p, k, 3e-6), [0.0, 0.0, 5e8])


def test_slope_matches_finite_difference():
    rng = np.random.default_rng(3)
    b, k = 4e-6, 1.5e8
    p = rng.uniform(-2e-5, 2e-5, 200)
    p = p[np.abs(np.abs(p) - b) > 1e-8]        # away from the kinks
    h = 1e-10
    fd = (dead_zone(p + h, k, b) - dead_zone(p - h, k, b)) / (2 * h)
    np.testing.assert_allclose(dead_zone_stiffness(p, k, b), fd, rtol=1e-6, atol=1e-3)
