"""Gear-pair local frame (Fig. 1) and the projection vector of eq. (11)."""

from __future__ import annotations

import math

import numpy as np


def gear_pair_frame(alpha: float) -> np.ndarray:
    """Rotation R = [e_x' e_y' e_z'] (columns) of the gear-pair frame of Fig. 1.

    Parameters
    ----------
    alpha : float
        Pressure angle (rad), in [0, pi/2).

    Returns
    -------
    numpy.ndarray, shape (3, 3)
        e_x' = (cos a, sin a, 0), e_y' = n = (-sin a, cos a, 0) (line of action),
        e_z' = e_z. Global components = R @ local components.
    """
    if not (0.0 <= alpha < 0.5 * math.pi):
        raise ValueError(f"alpha = {alpha}: must be in [0, pi/2) rad")
    c, s = math.cos(alpha), math.sin(alpha)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def projection_vector(alpha: float, beta: float, rb1: float, rb2: float) -> np.ndarray:
    """Restriction of G to q_c = (u1..u3, th1..th3, u4..u6, th4..th6), eq. (11).

    Parameters
    ----------
    alpha, beta : float
        Pressure and helix angles (rad).
    rb1, rb2 : float
        Base radii of gear 1 and gear 2 (m), > 0.

    Returns
    -------
    numpy.ndarray, shape (12,)
        Delta = G^T q_c (m) along the line of action.
    """
    if not (0.0 <= alpha < 0.5 * math.pi):
        raise ValueError(f"alpha = {alpha}: must be in [0, pi/2) rad")
    if not (-0.5 * math.pi < beta < 0.5 * math.pi):
        raise ValueError(f"beta = {beta}: must be in (-pi/2, pi/2) rad")
    for name, rb in (("rb1", rb1), ("rb2", rb2)):
        if not (math.isfinite(rb) and rb > 0):
            raise ValueError(f"{name} = {rb}: must be > 0 (m)")
    ta, tb = math.tan(alpha), math.tan(beta)
    return np.array(  # eq. (11)
        [0.0, 1.0, tb, rb1 * ta * tb, -rb1 * tb, rb1,
         0.0, -1.0, -tb, rb2 * ta * tb, -rb2 * tb, rb2]
    )  # fmt: skip
