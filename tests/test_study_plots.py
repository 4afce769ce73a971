"""NVH plot helpers: order names, the spectrum's drawn lines, the Campbell plot's mode
selection (external orders keep low-mesh-energy modes), and the PNGs themselves."""
from __future__ import annotations

import numpy as np
import pytest

from study.outputs.nvh import order_label
from study.plots.modes import campbell_modes, campbell_plot, order_map_plot
from study.plots.point import spectrum_lines


@pytest.mark.parametrize(("order", "name"), [(76, "Z"), (152, "2Z"), (74, "Z−2"), (80, "Z+4"),
                                             (229, "3Z+1"), (2, "2"), (4, "4"), (37, "37")])
def test_order_label(order, name):
    assert order_label(order, 76) == name


def test_spectrum_lines_limit_orders_and_range():
    order = np.arange(4097)
    amp = np.full(order.size, 1e-9)
    amp[[2, 76, 152, 228]] = [5.0, 100.0, 30.0, 1e-3]   # 1e-3: 100 dB below, dropped
    o, a, floor = spectrum_lines(order, amp, max_order=260, dynamic_range_db=60)
    assert floor == pytest.approx(0.1)
    np.testing.assert_array_equal(o, [2, 76, 152])
    assert o.max() <= 260


def test_campbell_keeps_modes_crossed_by_external_orders():
    f = np.array([0.0, 91.0, 751.0, 4115.0, 9000.0])
    rho = np.array([0.0, 0.004, 0.05, 0.94, 0.001])
    sel = campbell_modes(f, rho, (600.0, 4000.0), (1, 2, 4))
    # 91 Hz: order 2 at 2730 rpm and order 4 at 1365 rpm lie in the range (ρ = 0.4 %)
    assert 1 in sel and 2 in sel and 3 in sel
    assert 4 not in sel and 0 not in sel  # weak 9 kHz mode: no external order reaches it
    assert list(campbell_modes(f, rho, (600.0, 4000.0), ())) == [2, 3]


def test_plots_are_written(tmp_path):
    f = np.array([91.0, 751.0, 4115.0])
    p = campbell_plot(f, [0.004, 0.05, 0.94], (600.0, 4000.0), 76, 3,
                            tmp_path / "c.png", external_orders=(1, 2, 4))
    assert p.stat().st_size > 10_000
    rpm = np.linspace(600, 4000, 30)
    orders = np.array([0, 2, 4, 74, 76, 78, 152])
    lv = np.random.default_rng(0).uniform(0, 60, (30, orders.size))
    p = order_map_plot(rpm, orders, lv, 76, tmp_path / "m.png", "test dB", modes_hz=f)
    assert p.stat().st_size > 10_000


def test_order_map_labels_do_not_pile_up():
    """Contiguous set 0…12Z+12 (925 rows, Z = 76): every mesh order labelled, no two
    labels closer than 925 // 40 = 23 rows; a sparse set keeps every row's label."""
    from study.plots.modes import _order_ticks

    orders = np.arange(925)
    ticks = _order_ticks(orders, 76)
    assert {76 * k for k in range(13)} <= {int(orders[t]) for t in ticks}
    assert np.min(np.diff(ticks)) >= 23
    sparse = np.array([0, 1, 2, 4, 74, 76, 78, 152, 228])
    assert _order_ticks(sparse, 76) == list(range(sparse.size))
