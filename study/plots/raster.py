"""Straight lines coloured along a branch, painted into one image.

An order map draws, for every order r of the harmonic set, the line ``y = a_r + b_r·x``
(a row ``y = r`` against speed, or the order's frequency ``y = o_r·Ω/60``) coloured
point by point by its level along the continuation branch ``x = Ω``. As one line
segment per branch step and order (a ``LineCollection``), the pump's two order maps held
2.3 M segments and cost ~40 s of its export, nearly all in matplotlib's per-segment
``Path`` objects. Here the same picture is painted directly at the figure's resolution,
the way a rasteriser would (painter's algorithm; no anti-aliasing):

* along x, a pixel column takes the colour of the **last** branch segment that covers it
  (branch order: where the branch folds back, the later part is drawn over the earlier
  one, as the segment collection drew it);
* across lines, a pixel takes the line of the **highest rank** that covers it (lines
  painted in rank order, e.g. the loudest last), each line ``lw_px`` pixels wide;
* a segment whose level is NaN paints nothing (a transparent segment), so what lies
  under it stays visible.

The result is an (ny, nx) array of levels (NaN where nothing is painted) for
:meth:`matplotlib.axes.Axes.imshow` with the same colour map and norm. Cost: O(pixels
covered), about 0.5 s for a pump order map.
"""
from __future__ import annotations

import numpy as np

__all__ = ["segment_per_column", "paint_lines"]


def segment_per_column(x: np.ndarray, x0: float, dx: float, nx: int) -> np.ndarray:
    """For each of ``nx`` pixel columns ``[x0 + c·dx, x0 + (c+1)·dx)``, the index of the
    last segment ``(x[i], x[i+1])`` of the branch that covers its centre (a segment
    narrower than a pixel covers the pixel of its middle), -1 where none does."""
    x = np.asarray(x, dtype=float)
    best = np.full(nx, -1, dtype=np.int64)
    if x.size < 2 or nx <= 0:
        return best
    lo = np.minimum(x[:-1], x[1:])
    hi = np.maximum(x[:-1], x[1:])
    c_lo, c_hi = _pixel_span((lo - x0) / dx, (hi - x0) / dx)
    seg = np.flatnonzero((c_hi >= 0) & (c_lo < nx))
    c_lo, c_hi = np.clip(c_lo, 0, nx - 1), np.clip(c_hi, 0, nx - 1)
    n = c_hi[seg] - c_lo[seg] + 1
    cols = np.repeat(c_lo[seg], n) + _ramps(n)
    # segments in branch order: a column's last writer is its highest index
    np.maximum.at(best, cols, np.repeat(seg, n))
    return best


def _pixel_span(u_lo, u_hi):
    """First and last pixel whose centre (``p + 0.5``, in pixel units) lies in
    ``[u_lo, u_hi]``; a span narrower than a pixel that holds no centre takes the pixel
    of its middle (a thin line is not lost)."""
    p_lo = np.ceil(u_lo - 0.5).astype(np.int64)
    p_hi = np.floor(u_hi - 0.5).astype(np.int64)
    thin = p_hi < p_lo
    mid = np.floor(0.5 * (u_lo + u_hi)).astype(np.int64)
    return np.where(thin, mid, p_lo), np.where(thin, mid, p_hi)


def _ramps(n: np.ndarray) -> np.ndarray:
    """Concatenated ``arange(n_k)`` for every k."""
    total = int(n.sum())
    starts = np.repeat(np.cumsum(n) - n, n)
    return np.arange(total, dtype=np.int64) - starts


def paint_lines(x: np.ndarray, level: np.ndarray, a: np.ndarray, b: np.ndarray,
                rank: np.ndarray, xlim: tuple[float, float], ylim: tuple[float, float],
                shape: tuple[int, int], lw_px: float) -> np.ndarray:
    """Image of the lines ``y = a[r] + b[r]·x`` coloured by ``level[:, r]`` along ``x``.

    Parameters
    ----------
    x : (n,) abscissa of the branch points (any order, folds allowed).
    level : (n, R) level of line r at point i; a segment takes the mean of its two ends.
    a, b : (R,) offset and slope of each line (data units).
    rank : (R,) painting rank of each line (distinct integers; higher is painted later).
    xlim, ylim : data range of the image (its extent).
    shape : (ny, nx) pixels of the image.
    lw_px : line width in pixels (the line is widened by half of it on each side, in x
        and in y, a square brush).

    Returns
    -------
    (ny, nx) array, row 0 at ``ylim[0]`` (``imshow(origin="lower")``), NaN where no line
    is painted.
    """
    ny, nx = shape
    x = np.asarray(x, dtype=float)
    level = np.asarray(level, dtype=float)
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    rank = np.asarray(rank, dtype=np.int64)
    img = np.full((ny, nx), np.nan)
    if x.size < 2 or level.shape[1] == 0:
        return img
    (x0, x1), (y0, y1) = xlim, ylim
    dx, dy = (x1 - x0) / nx, (y1 - y0) / ny
    half = 0.5 * lw_px
    seg = segment_per_column(x, x0, dx, nx)            # butt ends, as matplotlib's
    cols = np.flatnonzero(seg >= 0)
    mid = 0.5 * (level[:-1] + level[1:])                    # (n-1, R)
    val = mid[seg[cols]]                                    # (C, R)
    # x-range of each column clipped to the branch (widened by the brush)
    xa = np.maximum(x0 + (cols - half) * dx, x.min())
    xb = np.minimum(x0 + (cols + 1 + half) * dx, x.max())
    ya = a[None, :] + b[None, :] * xa[:, None]
    yb = a[None, :] + b[None, :] * xb[:, None]
    p_lo, p_hi = _pixel_span((np.minimum(ya, yb) - y0) / dy - half,
                             (np.maximum(ya, yb) - y0) / dy + half)
    ok = np.isfinite(val) & (p_hi >= 0) & (p_lo < ny)
    ci, ri = np.nonzero(ok)
    lo = np.clip(p_lo[ci, ri], 0, ny - 1)
    n = np.clip(p_hi[ci, ri], 0, ny - 1) - lo + 1
    pix = (np.repeat(lo, n) + _ramps(n)) * nx + np.repeat(cols[ci], n)
    # the highest rank per pixel: sort the keys (pixel, rank), keep each pixel's last
    span = int(rank.max()) + 1
    key = np.sort(pix * span + np.repeat(rank[ri], n))
    last = np.ones(key.size, dtype=bool)
    last[:-1] = key[1:] // span != key[:-1] // span
    key = key[last]
    pix, rk = key // span, key % span
    row_of_rank = np.zeros(span, dtype=np.int64)
    row_of_rank[rank] = np.arange(rank.size)
    col_index = np.full(nx, -1, dtype=np.int64)
    col_index[cols] = np.arange(cols.size)
    img.reshape(-1)[pix] = val[col_index[pix % nx], row_of_rank[rk]]
    return img
