"""The painter behind the order maps (study.plots.raster): which segment and which line
a pixel shows, folds, transparent (NaN) segments, line width, no gaps along a line."""
from __future__ import annotations

import numpy as np
import pytest

from study.plots.raster import paint_lines, segment_per_column


def test_last_segment_of_a_fold_wins():
    """Branch 0 → 10 → 5 → 10 over 10 columns of width 1: columns 0–4 are covered only by
    the first pass, columns 5–9 last by the third segment (drawn over the others)."""
    x = np.array([0.0, 10.0, 5.0, 10.0])
    seg = segment_per_column(x, 0.0, 1.0, 10)
    np.testing.assert_array_equal(seg, [0] * 5 + [2] * 5)
    # outside the branch: no segment
    np.testing.assert_array_equal(segment_per_column(x, -5.0, 1.0, 20)[:5], [-1] * 5)


def test_two_rows_rank_and_width():
    """Rows y = 0 and y = 1 (levels 1 and 2) on a 10 × 40 grid from y = -1 to 3 (0.1 per
    pixel), 4 px wide: each row paints 4 pixel rows around it; the higher rank wins where
    they overlap; nothing elsewhere."""
    x = np.linspace(0.0, 10.0, 5)
    level = np.column_stack([np.full(5, 1.0), np.full(5, 2.0)])
    img = paint_lines(x, level, np.array([0.0, 1.0]), np.zeros(2), np.array([0, 1]),
                      (0.0, 10.0), (-1.0, 3.0), (40, 10), lw_px=4.0)
    col = img[:, 3]
    yc = -1.0 + (np.arange(40) + 0.5) * 0.1
    np.testing.assert_array_equal(np.flatnonzero(col == 1.0), np.flatnonzero(np.abs(yc) < 0.2))
    np.testing.assert_array_equal(np.flatnonzero(col == 2.0),
                                  np.flatnonzero(np.abs(yc - 1.0) < 0.2))
    assert np.isnan(col[np.abs(yc) > 1.25]).all()
    assert (img == col[:, None]).sum() == 10 * np.isfinite(col).sum()   # same every column
    # swap the ranks: row 0 above row 1, same pixels (they do not overlap at 4 px)
    swapped = paint_lines(x, level, np.array([0.0, 1.0]), np.zeros(2), np.array([1, 0]),
                          (0.0, 10.0), (-1.0, 3.0), (40, 10), lw_px=4.0)
    np.testing.assert_array_equal(np.isfinite(swapped), np.isfinite(img))
    # 14 px wide (0.7 each side): rows overlap between 0.3 and 0.7; the higher rank wins
    wide = paint_lines(x, level, np.array([0.0, 1.0]), np.zeros(2), np.array([0, 1]),
                       (0.0, 10.0), (-1.0, 3.0), (40, 10), lw_px=14.0)[:, 3]
    over = (yc > 0.3) & (yc < 0.7)
    assert (wide[over] == 2.0).all()
    wide_swapped = paint_lines(x, level, np.array([0.0, 1.0]), np.zeros(2), np.array([1, 0]),
                               (0.0, 10.0), (-1.0, 3.0), (40, 10), lw_px=14.0)[:, 3]
    assert (wide_swapped[over] == 1.0).all()


def test_nan_segment_is_transparent():
    """A NaN level paints nothing: the lower-ranked line under it shows, and a segment
    takes the mean level of its ends."""
    x = np.array([0.0, 5.0, 10.0])
    under = np.array([1.0, 1.0, 1.0])
    over = np.array([3.0, 5.0, np.nan])             # segment 0: 4.0; segment 1: NaN
    img = paint_lines(x, np.column_stack([under, over]), np.zeros(2), np.zeros(2),
                      np.array([0, 1]), (0.0, 10.0), (-1.0, 1.0), (4, 10), lw_px=1.0)
    row = img[2]                                     # the pixel row holding y = 0
    np.testing.assert_array_equal(row, [4.0] * 5 + [1.0] * 5)
    assert np.isnan(img[[0, 3]]).all()


@pytest.mark.parametrize("slope", [0.3, 2.0, 40.0])
def test_slanted_line_has_no_gaps(slope):
    """y = slope·x on a 100 × 100 grid: every pixel row and column the line passes
    through is painted, and every painted pixel lies within half the width (+1 px) of
    the line."""
    x = np.linspace(0.0, 10.0, 7)                  # coarse branch: the line is straight
    img = paint_lines(x, np.ones((7, 1)), np.zeros(1), np.array([slope]), np.array([0]),
                      (0.0, 10.0), (0.0, 10.0 * min(slope, 1.0)), (100, 100), lw_px=2.0)
    p, c = np.nonzero(np.isfinite(img))
    ymax = 10.0 * min(slope, 1.0)
    xc, yc = (c + 0.5) * 0.1, (p + 0.5) * ymax / 100
    # distance in pixels from the line
    d = np.abs(slope * xc - yc) / np.hypot(slope * 0.1 / (ymax / 100), 1.0) / (ymax / 100)
    assert d.max() <= 1.0 + 1.5
    top = min(100, int(100 * 10.0 * slope / ymax))
    assert set(p) >= set(range(top))
    assert set(c) >= set(range(int(100 * min(1.0, ymax / (10 * slope)))))
