"""Branch queries: points of a run's branch (``result.branch``) as :class:`hbm.Point`."""
from __future__ import annotations

import numpy as np

from hbm import Point

__all__ = ["time_series_speeds", "point_at", "nearest_point"]


def time_series_speeds(result) -> list[float]:
    """Speeds for time series: the scene's list, else per contact class the stable point
    with the largest dynamic mesh load."""
    s = result.scene.outputs.time_series
    if s:
        return list(s)
    br = result.branch
    out = []
    mesh = br.element(0)
    for cls in (0, 1, 2):
        idx = np.flatnonzero((mesh.contact == cls) & br.stable)
        if idx.size:
            out.append(float(br.rpm[idx[np.argmax(mesh.mesh_load_std[idx])]]))
    return out


def point_at(result, i: int):
    """Point ``i`` of the branch as an :class:`hbm.Point`."""
    br = result.branch
    return Point(rpm=float(br.rpm[i]), omega=float(br.omega[i]), unknowns=br.unknowns[i],
                 coefficients=br.stats["coefficients"][i], residual=float(br.residual[i]),
                 iterations=int(br.newton_iterations[i]))


def nearest_point(result, rpm: float):
    """The stored point closest in speed (stable ones preferred) as an :class:`hbm.Point`."""
    br = result.branch
    d = np.abs(br.rpm - rpm) + np.where(br.stable, 0.0, 1e9)
    i = int(np.argmin(d))
    return i, point_at(result, i)
