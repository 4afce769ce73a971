"""A gear mesh whose stiffness and transmission error repeat only every ``cycles`` mesh
periods (pitch deviations: the hunting period of the pair; issue 38).

Numbers against the same mesh written with ``cycles = 1`` (a series that happens to hold
only multiples of ``cycles`` is the same signal) and against scipy's DOP853 integration
of the equations written here with their own dead zone (a series with sidebands of the
hunting frequency).
"""
from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import hbm
from hbm.stability import stability

RPM = hbm.RPM_TO_RAD_S
C = 3  # mesh periods of the hunting period


def _problem(k: dict, te: dict, cycles: int, h: int) -> hbm.HBMProblem:
    """Unit mass, damping 0.1, a dead-zone mesh (Z = 1, b = 1) and a static load 0.1 with
    a mesh-frequency force 0.05; the fundamental is the base frequency Omega / cycles,
    256 AFT samples per mesh period."""
    mesh = hbm.GearMesh([1.0], 1, k, te=te, backlash=1.0, cycles=cycles)
    idx = list(range(0, cycles * h + 1))
    hs = hbm.HarmonicSet(idx, ratio=Fraction(1, cycles), fundamental="hunting",
                         n_time=cycles * 256)
    return hbm.HBMProblem(hbm.LinearSystem([[1.0]], [[0.1]], [[0.0]]), [mesh],
                          hbm.Excitation(1, constant={0: [0.1], 1: [0.05]}), hs)


def test_a_series_of_multiples_of_cycles_is_the_one_cycle_mesh():
    """k and TE holding only harmonics c, 2c ... with ``cycles = c``: the same mesh-load
    signal, statistics and impacts per mesh period as the mesh-period series (1e-10)."""
    k1, te1 = {0: 1.0, 1: 0.2}, {1: 0.3j}
    one = _problem(k1, te1, 1, 20)
    three = _problem({m * C if m else 0: v for m, v in k1.items()},
                     {m * C: v for m, v in te1.items()}, C, 20)
    assert three.elements[0].base_ratio == Fraction(1, C)
    for w in (0.5, 0.9, 1.3):
        a, b = one.solve(w / RPM, tol=1e-12), three.solve(w / RPM, tol=1e-12)
        la = hbm.time_series(one, a, samples_per_period=512).load
        lb = hbm.time_series(three, b, samples_per_period=C * 512).load
        assert np.max(np.abs(np.tile(la, C) - lb)) < 1e-10 * np.max(np.abs(la))
        sa, sb = hbm.point_stats(one, a)[0], hbm.point_stats(three, b)[0]
        assert sb.mesh_load_std == pytest.approx(sa.mesh_load_std, rel=1e-10)
        assert sb.contact == sa.contact
        assert sb.impacts_per_mesh_period == pytest.approx(sa.impacts_per_mesh_period)
        assert len(sb.ipp) == C * len(sa.ipp)


def _dead(p: float, k: float, b: float) -> float:
    return k * (p - b) if p > b else k * (p + b) if p < -b else 0.0


def test_hunting_sidebands_against_time_integration():
    """Stiffness and TE with content at the hunting frequency Omega/3 and its sidebands
    about the mesh harmonics (a pitch error on one gear of three teeth per hunting
    period): the mesh-load std of the harmonic balance against DOP853 (rtol 1e-11) of
    x'' + 0.1 x' + f(x - e(t), k(t)) = 0.1 + 0.05 cos(Omega t), in permanent contact and
    with contact loss, both stable orbits (<= 1e-4)."""
    k = {0: 1.0, 1: 0.03, 2: 0.02j, 3: 0.2, 4: 0.015}
    te = {1: 0.05, 2: 0.02j, 3: 0.3j, 5: 0.01}
    pb = _problem(k, te, C, 24)

    def series(c: dict, ph: float) -> float:
        return sum((v * np.exp(1j * m * ph)).real for m, v in c.items())

    for w, lost in ((0.4, False), (2.0, True)):
        pt = pb.solve(w / RPM, tol=1e-12)
        assert stability(pb, pt).kind == "stable"      # (0.95: period doubling)
        base = w / C
        period = 2 * np.pi / base

        def rhs(t, y, w=w, base=base):
            ph = base * t
            km, e = series(k, ph), series(te, ph)
            f = _dead(y[0] - e, km, 1.0)
            return [y[1], 0.1 + 0.05 * np.cos(w * t) - 0.1 * y[1] - f]

        q = pb.recover(pt)
        w0 = pb.harmonics.fundamental_rad_s(pt.omega)          # the hunting frequency
        y = np.array([q.real.sum(), (1j * pb.kS * w0 * q).real.sum()])
        opts = dict(method="DOP853", rtol=1e-11, atol=1e-13)
        for _ in range(60):
            y1 = solve_ivp(rhs, (0.0, period), y, **opts).y[:, -1]
            done = np.linalg.norm(y1 - y) < 1e-10 * np.linalg.norm(y1)
            y = y1
            if done:
                break
        assert done
        t = period * np.arange(4096) / 4096
        x = solve_ivp(rhs, (0.0, period), y, t_eval=t, **opts).y[0]
        load = np.array([_dead(xi - series(te, base * ti), series(k, base * ti), 1.0)
                         for xi, ti in zip(x, t, strict=True)])
        st = hbm.point_stats(pb, pt)[0]
        assert (st.contact_loss_fraction > 0) == lost
        assert st.mesh_load_std == pytest.approx(np.std(load), rel=1e-4)


def test_cycles_refused_when_not_a_whole_number():
    with pytest.raises(ValueError, match="mesh.cycles"):
        hbm.GearMesh([1.0], 1, {0: 1.0}, backlash=1.0, cycles=0)
    with pytest.raises(ValueError, match="mesh.cycles"):
        hbm.GearMesh([1.0], 1, {0: 1.0}, backlash=1.0, cycles=1.5)
