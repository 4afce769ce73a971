"""NVH plot helpers: order names, the spectrum's drawn lines, the Campbell plot's mode
selection (external orders keep low-mesh-energy modes), and the PNGs themselves."""
from __future__ import annotations

from types import SimpleNamespace

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


def _capture(monkeypatch, module):
    """Keep the figures ``module`` saves open, in a list (save_figure closes them)."""
    figs = []
    monkeypatch.setattr(module, "save_figure", lambda fig, path: figs.append(fig) or path)
    return figs


def _span(patch, axis: int) -> tuple[float, float]:
    """Data extent of an axvspan/axhspan along x (0) or y (1)."""
    x, y = patch.get_xy()
    return (x, x + patch.get_width()) if axis == 0 else (y, y + patch.get_height())


def _shaded(ax) -> list[str]:
    return [t.get_text() for t in (ax.get_legend().get_texts() if ax.get_legend() else [])
            if "ROM" in t.get_text()]


def test_order_map_stops_at_20_khz_and_shades_beyond_the_rom(tmp_path, monkeypatch):
    """The pump's case: orders 1…924 to 7000 rpm (108 kHz) and a ROM valid to 3997 Hz."""
    import study.plots.modes as modes
    from study.plots.common import F_STOP

    figs = _capture(monkeypatch, modes)
    rpm = np.linspace(500.0, 7000.0, 40)
    orders = np.arange(0, 925)
    lv = np.random.default_rng(1).uniform(0, 60, (rpm.size, orders.size))
    order_map_plot(rpm, orders, lv, 76, tmp_path / "m.png", "dB", rom_valid_hz=3997.0)
    ax, bx = figs[0].axes[:2]
    assert bx.get_ylim()[1] == F_STOP == 20_000.0
    assert _shaded(bx) == ["ROM not validated above 3997 Hz"] == _shaded(ax)
    # the band from 3997 Hz up on the frequency panel
    band = [p for p in bx.patches if p.get_label().startswith("ROM")][0]
    assert _span(band, 1) == pytest.approx((3997.0, F_STOP))
    # every painted pixel of the left panel lies below 20 kHz: the highest order drawn at
    # 7000 rpm is 171 (171 × 7000/60 = 19 950 Hz); a pixel may show any row within half a
    # line width (1 pt here, 925 rows) and a pixel of its centre
    im = ax.images[0]
    img = np.asarray(im.get_array(), dtype=float)
    x0, x1, y0, y1 = im.get_extent()
    ny, nx = img.shape
    p, c = np.nonzero(np.isfinite(img))
    y = y0 + (p + 0.5) * (y1 - y0) / ny
    reach = (0.5 * 130 / 72 + 1.0) * (y1 - y0) / ny            # rows per half line + pixel
    lowest = np.clip(np.ceil(y - reach), 0, None).astype(int)     # row r is orders[1:][r]
    f = orders[1:][lowest] * (x0 + c * (x1 - x0) / nx) / 60.0
    assert p.size > 1000 and f.max() <= F_STOP
    # nothing painted above the frequency of the highest row drawn at each speed
    assert np.isnan(img[-1, -1]) and np.isfinite(img[0, 0])


def test_campbell_spectrum_and_erp_shade_beyond_the_rom(tmp_path, monkeypatch):
    import study.plots.modes as modes
    import study.plots.speed as speed

    figs = _capture(monkeypatch, modes)
    campbell_plot(np.array([300.0, 2500.0, 6000.0]), [0.004, 0.05, 0.94], (500.0, 7000.0), 76,
                  12, tmp_path / "c.png", external_orders=(1, 2), rom_valid_hz=3997.0)
    ax = figs[0].axes[0]
    assert ax.get_ylim()[1] == 20_000.0                 # 12 Z at 7350 rpm would be 112 kHz
    assert _shaded(ax) == ["ROM not validated above 3997 Hz"]
    # ERP: the mesh order 76 passes 3997 Hz at 3155.5 rpm: shaded from there
    figs = _capture(monkeypatch, speed)
    br = SimpleNamespace(rpm=np.linspace(500.0, 7000.0, 30), rpm_start=500.0, rpm_end=7000.0)
    monkeypatch.setattr(speed, "shade_impacts", lambda *a, **k: None)
    orders = np.array([0, 1, 2, 76, 152])
    db = np.full((30, 5), 40.0)
    speed.erp_plot(br, np.full(30, 47.0), db, orders, 76, tmp_path / "e.png",
                   rom_valid_hz=3997.0)
    ax = figs[0].axes[0]
    band = [p for p in ax.patches if "ROM" in p.get_label()][0]
    assert _span(band, 0) == pytest.approx((60 * 3997.0 / 76, 7000.0))
    valid_total = [ln for ln in ax.lines if ln.get_label().startswith("total of orders")][0]
    y = valid_total.get_ydata()
    # at 500 rpm the orders 1, 2, 76, 152 are inside (4 × 40 dB), at 7000 rpm only 1 and 2
    assert y[0] == pytest.approx(40 + 10 * np.log10(4)) and y[-1] == pytest.approx(
        40 + 10 * np.log10(2))
