"""Lumped parts of the FE model: the rigid disk of a gear blank against the integrated
annulus. (The gear-pair frame and eq. 11 are tested in tests/test_gears_pair.py.)"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("mpi4py")

import fem  # noqa: E402


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
