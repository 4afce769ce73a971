"""The backlash (dead-zone) contact law of the gear mesh, eq. (13).

With ``p = Delta - e(t)`` the approach along the line of action net of the unloaded
transmission error, ``b`` the half backlash and ``k = k_m(t)`` the mesh stiffness::

    f_LoA = k (p - b)   if p >  b    (active flank)
          = 0           if |p| <= b  (contact loss)
          = k (p + b)   if p < -b    (reverse flank)

One definition, used by the AFT force (:mod:`hbm.problem`), the time signals
(:mod:`hbm.postprocess`) and the independent checks (:mod:`hbm.verify`).
"""
from __future__ import annotations

import numpy as np

__all__ = ["dead_zone", "dead_zone_stiffness"]


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
