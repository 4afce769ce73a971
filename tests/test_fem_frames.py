"""Gear-pair frame of Fig. 1 and the projection vector of eq. (11), checked against
the motion of the base-circle tangent points."""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("mpi4py")

import fem  # noqa: E402


def test_line_of_action_from_base_circle_tangent_points() -> None:
    alpha, rb1, rb2 = math.radians(20.0), 46.984e-3, 40.0e-3
    a = (rb1 + rb2) / math.cos(alpha)
    R = fem.gear_pair_frame(alpha)
    n = np.array([-math.sin(alpha), math.cos(alpha), 0.0])
    np.testing.assert_allclose(R[:, 1], n, atol=1e-15)
    np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-15)
    c1, c2 = np.zeros(3), np.array([a, 0.0, 0.0])
    t1 = c1 + rb1 * R[:, 0]  # tangent points of the line of action on the base circles
    t2 = c2 - rb2 * R[:, 0]
    assert abs(np.dot(t2 - t1, R[:, 0])) < 1e-15  # both on the same line along n
    G = fem.projection_vector(alpha, 0.0, rb1, rb2)
    rng = np.random.default_rng(1)
    for _ in range(5):
        u1, th1, u2, th2 = rng.normal(size=(4, 3)) * [[1e-5], [1e-4], [1e-5], [1e-4]]
        # approach of gear 1's flank towards gear 2's along n
        delta = n @ ((u1 + np.cross(th1, t1 - c1)) - (u2 + np.cross(th2, t2 - c2)))
        q_c = np.concatenate([R.T @ u1, R.T @ th1, R.T @ u2, R.T @ th2])
        assert abs(G @ q_c - delta) < 1e-12 * np.abs(q_c).max()


def test_eq11_helical_entries() -> None:
    alpha, beta, rb1, rb2 = 0.35, 0.2, 0.05, 0.04
    G = fem.projection_vector(alpha, beta, rb1, rb2)
    ta, tb = math.tan(alpha), math.tan(beta)
    expected = [0, 1, tb, rb1 * ta * tb, -rb1 * tb, rb1, 0, -1, -tb, rb2 * ta * tb, -rb2 * tb, rb2]
    np.testing.assert_allclose(G, expected, rtol=0, atol=1e-16)
    with pytest.raises(ValueError, match="rb2"):
        fem.projection_vector(alpha, beta, rb1, 0.0)


def test_disk_mass_matches_integrated_annulus() -> None:
    ro, ri, b, rho = 0.0513, 0.016, 0.02, 7850.0
    Mm = fem.disk_mass(ro, ri, b, rho)
    # numerical integration over the annulus (r, z) with the midpoint rule
    r = np.linspace(ri, ro, 4001)
    r = 0.5 * (r[1:] + r[:-1])
    dr = (ro - ri) / r.size
    z = np.linspace(-b / 2, b / 2, 2001)
    z = 0.5 * (z[1:] + z[:-1])
    dz = b / z.size
    rr, zz = np.meshgrid(r, z, indexing="ij")
    dm = rho * 2 * np.pi * rr * dr * dz
    m = dm.sum()
    jz = (dm * rr**2).sum()
    jx = (dm * (rr**2 / 2 + zz**2)).sum()
    np.testing.assert_allclose(np.diag(Mm), [m, m, m, jx, jx, jz], rtol=1e-6)
