"""The backlash (dead-zone) contact law of the gear mesh, eq. (13).

With ``p = Delta - e(t)`` the approach along the line of action net of the unloaded
transmission error, ``b`` the half backlash and ``k = k_m(t)`` the mesh stiffness::

    f_LoA = k (p - b)   if p >  b    (active flank)
          = 0           if |p| <= b  (contact loss)
          = k (p + b)   if p < -b    (reverse flank)

One definition, used by the gear-mesh element (:mod:`hbm.elements.gear_mesh`) for its
AFT force, its time signals and statistics, and the independent checks
(:mod:`hbm.post.verify`); with the counting of impacts per base period and the refined
minimum of a sampled margin that its statistics use.
"""
from __future__ import annotations

import numpy as np

from .base import KinkCorrection

__all__ = ["dead_zone", "dead_zone_stiffness", "impacts_per_mesh_period",
           "in_contact_fraction", "kink_correction", "refined_minimum"]


def dead_zone(p: np.ndarray, k: np.ndarray, b: float) -> np.ndarray:
    """Mesh force ``f_LoA`` (N) of the dead-zone law, eq. (13), elementwise.

    Parameters
    ----------
    p : array_like
        ``Delta - e`` (m).
    k : array_like
        Mesh stiffness ``k_m`` (N/m), broadcast against ``p``.
    b : float
        Half backlash (m), >= 0.
    """
    return k * (np.where(p > b, p - b, 0.0) + np.where(p < -b, p + b, 0.0))  # eq. (13)


def dead_zone_stiffness(p: np.ndarray, k: np.ndarray, b: float) -> np.ndarray:
    """``d f_LoA / d p`` (N/m) of :func:`dead_zone`: ``k`` in contact, 0 in the gap."""
    return np.where((p > b) | (p < -b), k, 0.0)


def _shape(p, b):
    """``g(p) = f_LoA / k``, its slope and its antiderivative ``Psi`` (eq. 13)."""
    up, lo = np.maximum(p - b, 0.0), np.minimum(p + b, 0.0)
    return up + lo, ((p > b) | (p < -b)).astype(float), 0.5 * (up * up + lo * lo)


def _crossing(a, z, d, b):
    """Mean position ``theta`` in (0, 1) of the kinks crossed from ``a`` to ``z`` and
    its derivatives with respect to ``a`` and ``z``."""
    th, th_a, th_z, cnt = (np.zeros(a.size) for _ in range(4))
    for kink in (b, -b):
        t = (kink - a) / d
        inside = (t >= 0.0) & (t <= 1.0) & ((a - kink) * (z - kink) <= 0.0)
        th += np.where(inside, t, 0.0)
        th_a += np.where(inside, (t - 1.0) / d, 0.0)
        th_z += np.where(inside, -t / d, 0.0)
        cnt += inside
    cnt = np.maximum(cnt, 1.0)
    return th / cnt, th_a / cnt, th_z / cnt


def kink_correction(p: np.ndarray, k: np.ndarray, b: float) -> KinkCorrection:
    """Correction making the sampled dead-zone force C1 in the samples (T.13a).

    The AFT integrates ``f = k g(p)`` by the periodic trapezoidal rule on the samples
    ``p_j``. Where ``p`` crosses a kink ``+-b`` between two samples the rule jumps in
    slope each time the crossing passes a sample: the residual is only piecewise
    smooth, Newton cycles at the 1e-8 level and the branch gets spurious micro-folds.
    Over each interval ``(j, j+1)`` with a crossing, two terms are added, shared
    between the two samples as ``(1 - theta, theta)`` (``theta`` the position of the
    crossing):

    * the exact mean of ``g`` along the linear interpolant,
      ``(Psi(p_{j+1}) - Psi(p_j)) / (p_{j+1} - p_j)``, minus the trapezoid, times the
      mean stiffness of the interval (it vanishes as the crossing reaches a sample);
    * the Euler-Maclaurin end term of the smooth pieces on either side of the kink,
      ``+ J / 12`` per sample width, ``J = k_c (sigma_after - sigma_before) p'_c`` the
      jump of ``df/dtau`` there, with ``k_c`` and ``p'_c`` interpolated at ``theta``
      between the samples (central differences), so that it moves continuously from
      one interval to the next.

    Intervals without a crossing are unchanged. On a torus grid (``p`` of shape
    ``(N_1, ..., N_d)``) the intervals run along the last axis, periodic in each row,
    so that every row's sum, hence the whole grid's, is C1 in the samples. The sum is
    the trapezoidal rule of a function without kinks: O(h^3) per crossing instead of
    O(h^2), and C1 (checked against finite differences and the Omega -> dense-grid limit
    in tests/test_hbm_aft_kinks.py).
    """
    n = p.size
    period = p.shape[-1]
    nxt = np.roll(p, -1, axis=-1)
    nodes = np.flatnonzero((np.sign(p - b) + np.sign(p + b))
                           != (np.sign(nxt - b) + np.sign(nxt + b)))
    if nodes.size == 0:
        return KinkCorrection.none(p.shape)
    corr = KinkCorrection(np.zeros(0), nodes, np.zeros((0, 2, 4)), period)
    cols = corr.columns(n)
    pf, kf = p.reshape(-1), np.broadcast_to(k, p.shape).reshape(-1)
    pm, a, z, pp = (pf[cols[:, c]] for c in range(4))
    ka, kz = kf[cols[:, 1]], kf[cols[:, 2]]
    d = z - a
    ga, sa, psa = _shape(a, b)
    gz, sz, psz = _shape(z, b)
    th, th_a, th_z = _crossing(a, z, d, b)
    # exact mean of g along the interpolant minus the trapezoid (vanishes at theta 0, 1)
    kbar = 0.5 * (ka + kz)
    q = (psz - psa) / d
    d1 = kbar * (q - 0.5 * (ga + gz))
    d1_a = kbar * ((q - ga) / d - 0.5 * sa)
    d1_z = kbar * ((gz - q) / d - 0.5 * sz)
    # Euler-Maclaurin end term J / 12, J = k_c jump p'_c
    jump = sz - sa
    m0, m1 = 0.5 * (z - pm), 0.5 * (pp - a)                 # slopes at j and j+1
    slope = (1.0 - th) * m0 + th * m1
    kc = (1.0 - th) * ka + th * kz
    d2 = kc * jump * slope / 12.0
    # derivatives of d1 + d2 with respect to p at (j-1, j, j+1, j+2)
    dth = np.stack([np.zeros_like(th), th_a, th_z, np.zeros_like(th)], axis=1)
    dslope = (m1 - m0)[:, None] * dth
    dslope += np.stack([-0.5 * (1.0 - th), -0.5 * th, 0.5 * (1.0 - th), 0.5 * th], axis=1)
    dd = np.stack([np.zeros_like(th), d1_a, d1_z, np.zeros_like(th)], axis=1)
    dd += (jump / 12.0)[:, None] * ((kz - ka)[:, None] * dth * slope[:, None]
                                    + kc[:, None] * dslope)
    delta = d1 + d2
    values = np.zeros(n)
    np.add.at(values, nodes, delta * (1.0 - th))
    np.add.at(values, corr.successors(n), delta * th)
    blocks = np.empty((nodes.size, 2, 4))
    blocks[:, 0] = dd * (1.0 - th)[:, None] - delta[:, None] * dth
    blocks[:, 1] = dd * th[:, None] + delta[:, None] * dth
    return KinkCorrection(values.reshape(p.shape), nodes, blocks, period)


def in_contact_fraction(p0: np.ndarray, p1: np.ndarray, thr: float) -> np.ndarray:
    """Fraction of each step where the linear interpolation from p0 to p1 exceeds thr."""
    a, b = p0 > thr, p1 > thr
    d = np.where(p1 != p0, p1 - p0, 1.0)
    th = np.clip((thr - p0) / d, 0.0, 1.0)
    return np.where(a & b, 1.0, np.where(~a & ~b, 0.0, np.where(b, 1.0 - th, th)))


def impacts_per_mesh_period(loss: np.ndarray, mesh_step: int) -> np.ndarray:
    """Impacts in each mesh period (Sect. 4.3) from ``loss``, ``(..., n_time)`` booleans
    (contact lost) over one fundamental period of ``mesh_step`` mesh periods.

    An impact is a loss sample followed, cyclically, by a contact sample. Returns
    ``(..., mesh_step)`` integers.
    """
    loss = np.asarray(loss, dtype=bool)
    n = loss.shape[-1]
    imp = loss & ~np.roll(loss, -1, axis=-1)
    return imp.reshape(*loss.shape[:-1], mesh_step, n // mesh_step).sum(axis=-1)


def refined_minimum(y: np.ndarray) -> float:
    """Minimum of a periodic sampled signal refined by a parabola through 3 samples (on a
    torus grid, along the last axis through the smallest sample)."""
    i = int(np.argmin(y))
    n = y.shape[-1]                       # along the last axis (a row of a torus grid)
    row = y.reshape(-1, n)[i // n]
    i %= n
    ym, y0, yp = row[i - 1], row[i], row[(i + 1) % n]
    curv = ym - 2 * y0 + yp
    if curv > 0:
        return float(y0 - (yp - ym) ** 2 / (8 * curv))
    return float(y0)
