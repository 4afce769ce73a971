"""Poincaré sections (hbm.post.poincare) and the quasi-periodic response past a
Neimark–Sacker bifurcation (hbm.post.time_response), on sequences of known kind and on
the two-mode gear model of tests/hbm_models.py against its own Floquet exponents and a
refined integration (issue 40 items 3 and 5)."""

from fractions import Fraction
from types import SimpleNamespace

import numpy as np
import pytest
from hbm_models import RPM, neimark_sacker_problem, sdof_problem

import hbm
from hbm.post.poincare import (
    classify_section,
    orbit_section,
    periods_in,
    windowed_lines,
)
from hbm.post.signals import time_series
from hbm.post.time_response import integrate


def test_sections_of_known_kind_are_classified():
    j = np.arange(1024)
    assert classify_section(np.full(50, 3.0), 1.0).label == "period-1"
    two = classify_section(np.where(j % 2, 1.0, -1.0), 1.0)
    assert (two.kind, two.period) == ("periodic", 2)
    three = classify_section(np.sin(2 * np.pi * j / 3) + 1e-6 * np.cos(j), 1.0)
    assert three.label == "period-3"
    rho = (np.sqrt(5) - 1) / 4                      # irrational rotation, 0.309
    torus = np.cos(2 * np.pi * rho * j) + 0.3 * np.cos(4 * np.pi * rho * j + 1.0)
    qp = classify_section(torus, 1.0)
    assert qp.kind == "quasi-periodic" and qp.concentration > 0.999
    assert qp.rotation == pytest.approx(rho, abs=2e-4)    # ~1/50 of a bin
    x = np.empty(1024)                               # logistic map at r = 4: chaotic
    x[0] = 0.3
    for i in range(1, x.size):
        x[i] = 4 * x[i - 1] * (1 - x[i - 1])
    assert classify_section(x, float(x.std())).kind == "chaotic-like"
    assert classify_section(torus[:100], 1.0).kind == "aperiodic"   # too few to tell
    with pytest.raises(ValueError, match="scale"):
        classify_section(torus, 0.0)


def test_windowed_lines_amplitudes_do_not_depend_on_the_bin():
    t = np.arange(8192) / 64                          # 64 samples per unit, 128 units
    for f in (0.3, 0.3 + 1 / 256, 0.61803):           # on a bin, half a bin off, between
        x = 0.7 * np.cos(2 * np.pi * f * t + 0.3) + 0.2 * np.cos(2 * np.pi * t)
        (f1, a1), (f2, a2) = windowed_lines(x, 64, 2)
        assert (f1, a1) == pytest.approx((f, 0.7), rel=1e-3)
        assert (f2, a2) == pytest.approx((1.0, 0.2), rel=1e-3)


def test_periods_in_counts_reference_periods():
    ref = SimpleNamespace(harmonics=SimpleNamespace(ratio=Fraction(13)))
    half = SimpleNamespace(harmonics=SimpleNamespace(ratio=Fraction(13, 2)))
    third = SimpleNamespace(harmonics=SimpleNamespace(ratio=Fraction(13, 3)))
    assert periods_in(ref, ref) == 1
    assert periods_in(ref, half) == 2
    assert periods_in(ref, third) == 3
    with pytest.raises(ValueError, match="whole number"):
        periods_in(half, ref)


def test_orbit_section_is_the_load_at_the_section_instants():
    p = sdof_problem(harmonics=12)
    pt = p.solve(0.8 / RPM)
    ts = time_series(p, pt, samples_per_period=240)
    assert orbit_section(p, pt)[0] == pytest.approx(ts.load[0], rel=1e-12)
    assert orbit_section(p, pt, 3) == pytest.approx(ts.load[::80], rel=1e-12)


@pytest.fixture(scope="module")
def ns():
    """The two-mode model's orbits at a stable speed and inside the Neimark–Sacker
    segment, with their Floquet verdicts."""
    p = neimark_sacker_problem()
    out = {}
    for w in (2.70, 2.84):
        pt = p.solve(w / RPM)
        out[w] = (pt, hbm.stability.stability(p, pt))
    return p, out


def test_stable_orbit_time_section_is_the_harmonic_balance_one(ns):
    p, pts = ns
    pt, st = pts[2.70]
    assert st.max_real < 0
    tr = integrate(p, pt.rpm, pt, transient=2, window=8)     # started on the orbit
    sec = tr.poincare
    assert sec.label == "period-1"
    assert tr.section == pytest.approx(orbit_section(p, pt)[0], rel=1e-6)


def test_quasi_periodic_response_past_neimark_sacker(ns):
    """Inside the segment the orbit is unstable by a complex pair (Neimark–Sacker); the
    time response from it is quasi-periodic with the secondary frequency of that pair
    (rotation within 2 % of arg(mu) / 2 pi at 2.84 rad/s, past the onset at 2.77), and
    its std, largest load and spectral lines agree within 1 % between a coarse
    integration (rtol 1e-7, 1e-6 disturbance, 400 turns left out) and a refined one
    (rtol 1e-9, 1e-4 disturbance, 600 turns left out): the attractor, not the run."""
    p, pts = ns
    pt, st = pts[2.84]
    assert st.max_real > 0 and st.kind == "neimark_sacker"
    lead = st.exponents[np.argmax(st.exponents.real)]
    floquet_rotation = abs(lead.imag) * 2 * np.pi / pt.omega / (2 * np.pi) % 1.0
    runs = [integrate(p, pt.rpm, pt, transient=tr, window=1024, rtol=rtol, perturbation=eps)
            for rtol, tr, eps in ((1e-7, 400, 1e-6), (1e-9, 600, 1e-4))]
    for r in runs:
        sec = r.poincare
        assert sec.kind == "quasi-periodic", sec
        assert sec.rotation == pytest.approx(min(floquet_rotation, 1 - floquet_rotation),
                                             rel=0.02)
        assert r.std > 2.0 * orbit_std(p, pt)      # the orbit: 0.026 N, the torus 0.09 N
    coarse, fine = runs
    assert coarse.std == pytest.approx(fine.std, rel=1e-2)
    assert coarse.max_load == pytest.approx(fine.max_load, rel=1e-2)
    for (fc, ac), (ff, af) in zip(coarse.windowed_lines(4), fine.windowed_lines(4),
                                  strict=True):
        assert fc == pytest.approx(ff, abs=1e-3)         # orders: 0.305, 0.695, 1, 0.389
        assert ac == pytest.approx(af, rel=1e-2)
    orders = [o for o, _ in fine.windowed_lines(3)]
    assert any(abs(o - round(o)) > 0.1 for o in orders)   # lines between the mesh orders


def orbit_std(p, pt) -> float:
    return float(time_series(p, pt).load.std())
