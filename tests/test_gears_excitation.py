"""gears.excitation: the mesh stiffness of perfect teeth as a rectangular wave, the STE
q_s = F_s/k_m, and the Fourier sampling and analysis they share (T.31)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from gears import fourier_harmonics, fourier_sample, perfect_teeth_ste, rectangular_mesh_stiffness


def test_sample_and_harmonics_are_inverse() -> None:
    mean, amps, phases = 2.0, (0.5, 0.0, 0.25), (0.3, 0.0, -2.0)
    x = fourier_sample(mean, amps, phases, 64)
    assert x[0] == pytest.approx(2.0 + 0.5 * math.cos(0.3) + 0.25 * math.cos(-2.0))
    m, a, p = fourier_harmonics(x, 3)
    assert m == pytest.approx(mean, rel=1e-15)
    np.testing.assert_allclose(a, amps, atol=1e-15)
    assert (p[0], p[2]) == pytest.approx((0.3, -2.0), rel=1e-13)
    with pytest.raises(ValueError, match="n_harmonics = 32: allowed 1..31 for 64 positions"):
        fourier_harmonics(x, 32)


@pytest.mark.parametrize("eps", [1.0, 1.6, 2.25])
def test_rectangular_wave_between_its_pair_counts(eps: float) -> None:
    """⌊ε⌋ pairs, one more over the fraction ε − ⌊ε⌋ of the period centred on θ = 0;
    the truncated series converges to it away from the jumps."""
    k1 = 3.0e8
    mean, amps, phases = rectangular_mesh_stiffness(k1, eps, 400)
    assert mean == pytest.approx(k1 * eps, rel=1e-15)
    assert set(phases) <= {0.0, math.pi}
    n = 4000
    k = fourier_sample(mean, amps, phases, n)
    t = np.arange(n) / n
    d = eps - math.floor(eps)
    dist = np.abs((t + 0.5) % 1.0 - 0.5)          # distance to θ = 0 in periods
    more, fewer = dist < d / 2 - 0.02, dist > d / 2 + 0.02   # Gibbs ripple near the jumps
    np.testing.assert_allclose(k[more], k1 * (math.floor(eps) + 1), rtol=1e-2)
    np.testing.assert_allclose(k[fewer], k1 * math.floor(eps), rtol=1e-2)
    with pytest.raises(ValueError, match="contact_ratio = 0.9"):
        rectangular_mesh_stiffness(k1, 0.9, 3)
    with pytest.raises(ValueError, match="n_harmonics = 0: must be an integer >= 1"):
        rectangular_mesh_stiffness(k1, eps, 0)


def test_perfect_teeth_ste_is_load_over_stiffness() -> None:
    km = (2.0e8, (4.0e7, 2.0e7), (0.0, 1.0))
    q0, qa, qp = perfect_teeth_ste(km, 1000.0, 40)
    q = fourier_sample(q0, qa, qp, 128)
    np.testing.assert_allclose(q * fourier_sample(*km, 128), 1000.0, rtol=1e-9)
    assert q0 >= 1000.0 / km[0]                      # Jensen
    with pytest.raises(ValueError, match="k_m.*must stay > 0"):
        perfect_teeth_ste((1.0e8, (2.0e8,), (0.0,)), 1000.0, 3)
