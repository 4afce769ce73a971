"""Harmonic sets that follow the excitation (issue 13, item 3).

The builder's three kinds are checked against brute-force enumerations of the
frequencies the excitation creates, and their accuracy against a converged contiguous
reference on a small gear pair excited at two shaft orders (Z = 20, orders 2 and 5):
with impacts, the order-2 combinations leave gaps (orders 1, 3, 6, 8, 9 around each mesh
harmonic) that the bands and the contiguous set fill.
"""
from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

import hbm
from hbm import HarmonicSet
from hbm.basis import SET_KINDS, combination_offsets

CASES = [(76, 3, (1, 2, 4), 1), (76, 12, (1, 2, 4), 3), (76, 2, (1, 2, 4), 5), (20, 3, (2, 5), 2),
         (9, 4, (3, 6), 3), (7, 2, (3,), 4), (50, 1, (4, 10), 2)]


def _brute_combinations(z, h, orders, s):
    """|k Z + sum c_i e_i| over every coefficient vector with sum |c_i| <= s, 0 <= k <= h."""
    out = set()
    for coeffs in itertools.product(range(-s, s + 1), repeat=len(orders)):
        if sum(abs(c) for c in coeffs) > s:
            continue
        off = sum(c * e for c, e in zip(coeffs, orders, strict=True))
        for k in range(h + 1):
            out.add(abs(k * z + off))
    return out | set(orders)


def _brute_bands(z, h, orders, s):
    """Every n >= 0 within s max(e) of a mesh harmonic kZ (k <= h) on the lattice gcd(e)."""
    g, reach = math.gcd(*orders), max(s, 1) * max(orders)
    top = h * z + reach
    return {n for n in range(top + 1)
            if any(abs(n - k * z) <= reach and (n - k * z) % g == 0 for k in range(h + 1))}


@pytest.mark.parametrize("z, h, orders, s", CASES)
def test_combinations_are_every_index_the_excitation_creates(z, h, orders, s):
    hs = HarmonicSet.build(z, h, orders, s, kind="combinations")
    assert set(hs.indices) == _brute_combinations(z, h, orders, s)
    assert hs.fundamental == "shaft" and hs.ratio == 1


@pytest.mark.parametrize("z, h, orders, s", CASES)
def test_bands_fill_the_reach_of_the_combinations(z, h, orders, s):
    hs = HarmonicSet.build(z, h, orders, s, kind="bands")
    comb = set(HarmonicSet.build(z, h, orders, s).indices)
    assert set(hs.indices) == _brute_bands(z, h, orders, s)
    assert comb <= set(hs.indices)
    contig = HarmonicSet.build(z, h, orders, s, kind="contiguous")
    assert contig.indices == tuple(range(max(comb) + 1))
    assert set(hs.indices) <= set(contig.indices)
    assert hs.n_time == contig.n_time       # same largest index, same AFT grid


def test_pump_sidebands_60_to_66():
    """Z - 16 ... Z - 10 of the pump (Z = 76, orders 1, 2, 4): the order needed by each."""
    order = {n: min(s for s in range(1, 9)
                    if n in HarmonicSet.build(76, 1, (1, 2, 4), s).indices)
             for n in range(60, 67)}
    # |c| counts: 64 = 76 - 4 - 4 - 4, 66 = 76 - 4 - 4 - 2, 61 = 76 - 4 - 4 - 4 - 2 - 1
    assert order == {60: 4, 61: 5, 62: 4, 63: 4, 64: 3, 65: 4, 66: 3}
    bands = HarmonicSet.build(76, 12, (1, 2, 4), 4, kind="bands")
    assert set(range(60, 67)) <= set(bands.indices)
    assert 61 not in HarmonicSet.build(76, 12, (1, 2, 4), 4).indices


def test_combination_offsets_small_case():
    # e = {2, 4}, degree 2: 2, 4, 2 + 2, 2 + 4, 4 + 4, 4 - 2
    assert combination_offsets((2, 4), 2) == {2, 4, 6, 8}
    assert combination_offsets((3, 5), 2) == {2, 3, 5, 6, 8, 10}
    assert combination_offsets((3,), 0) == set()


@pytest.mark.parametrize("kind", SET_KINDS)
def test_without_external_orders_every_kind_is_contiguous_in_the_mesh_fundamental(kind):
    hs = HarmonicSet.build(30, 7, (), 3, kind=kind)
    assert hs.indices == tuple(range(8)) and hs.fundamental == "mesh" and hs.ratio == 30


def test_bad_kind_is_refused_by_name():
    with pytest.raises(ValueError, match=r"harmonics.kind = 'band'"):
        HarmonicSet.build(76, 3, (1,), 1, kind="band")


# --------------------------------------------------------------- accuracy on a gear pair

Z = 20
ORDERS = (2, 5)
RPM = hbm.RPM_TO_RAD_S
RPM_LO, RPM_HI = 0.3 / Z / RPM, 0.06 / RPM      # mesh frequency 0.3 -> 1.2 w_n, impacts


def _pair(hs):
    """Unit-mass gear pair, Z teeth, mesh stiffness 1 +- 0.2, shaft orders 2 and 5."""
    system = hbm.LinearSystem(M=[[1.0]], C=[[0.1]], K=[[0.0]])
    mesh = hbm.GearMesh(direction=[1.0], n_teeth=Z, stiffness={0: 1.0, 1: 0.2}, te={},
                        backlash=1.0)
    exc = hbm.Excitation(1, constant={0: [0.1], 2: [0.04], 5: [0.06]})
    return hbm.HBMProblem(system, [mesh], exc, hs, "loa")


def _std_at_end(hs):
    br = hbm.trace(_pair(hs), RPM_LO, RPM_HI, stability=False)
    assert br.status == "completed", br.message
    return float(br.element(0).mesh_load_std[-1])


@pytest.fixture(scope="module")
def reference():
    """Contiguous set to 6 Z (121 harmonics); 0..3Z+10 agrees with 0..12Z to 1.3e-5."""
    return _std_at_end(HarmonicSet(range(6 * Z + 1), fundamental="shaft"))


def _err(reference, kind, h, s):
    return abs(_std_at_end(HarmonicSet.build(Z, h, ORDERS, s, kind=kind)) - reference) / reference


def test_bands_and_contiguous_sets_converge_where_combinations_do_not(reference):
    comb = _err(reference, "combinations", 3, 2)
    bands = _err(reference, "bands", 3, 2)
    # the order-2 combinations miss 1, 3, 6, 8, 9 around each kZ: their branch misses
    # folds and ends ~10 % off; the bands (here equal to 0..70) agree to ~1e-5
    assert comb > 3e-2
    assert bands < 1e-4
    assert _err(reference, "contiguous", 3, 2) == pytest.approx(bands, abs=1e-12)


def test_at_sideband_order_one_each_kind_adds_accuracy(reference):
    errs = [_err(reference, k, 2, 1) for k in SET_KINDS]
    # combinations (2, 5 around kZ) 8e-3, bands (every index within 5) 1.3e-3,
    # contiguous (0..45) 5e-4
    assert errs[0] > errs[1] > errs[2]
    assert errs[2] < 1e-3
    assert np.all(np.isfinite(errs))
