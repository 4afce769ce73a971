"""Compliance of a spur tooth pair along the line of action: the potential-energy method.

Hertzian contact (Yang & Sun 1985), bending, shear and axial compression of the tooth as
a non-uniform cantilever (Yang & Lin 1987; Tian 2004) and the fillet-foundation (gear
body) deflection of Sainsot, Velex & Duverger (2004), equations T.21-T.26 of
docs/theory.md §13.3. Pure NumPy, SI units; per unit face width.
"""
from __future__ import annotations

import math

import numpy as np

from core.errors import InputError

from .pair import involute
from .spur import SpurPair

__all__ = ["beam_compliance", "pair_compliance", "pitch_point_stiffness"]

# Sainsot, Velex & Duverger (2004), Table: coefficients A..F of
# X*(h, θ) = A/θ² + B h² + C h/θ + D/θ + E h + F for X* = L*, M*, P*, Q*.
_SAINSOT = np.array([
    # A            B            C            D            E        F
    [-5.574e-5, -1.9986e-3, -2.3015e-4, 4.7702e-3, 0.0271, 6.8045],   # L*
    [60.111e-5, 28.100e-3, -83.431e-4, -9.9256e-3, 0.1624, 0.9086],   # M*
    [-50.952e-5, 185.50e-3, 0.0538e-4, 53.300e-3, 0.2895, 0.9236],    # P*
    [-6.2042e-5, 9.0889e-3, -4.0964e-4, 7.8297e-3, -0.1472, 0.6904],  # Q*
])


def _half_angle(pair: SpurPair, r: np.ndarray) -> np.ndarray:
    """Half tooth-thickness angle ψ(r) = π/(2Z) + inv α − inv α_r of the involute (T.21)."""
    a_r = np.arccos(np.clip(pair.base_radius / r, -1.0, 1.0))
    return math.pi / (2 * pair.teeth) + involute(pair.pressure_angle) - involute(a_r)


def beam_compliance(y: np.ndarray, h: np.ndarray, dy: np.ndarray, y_c: np.ndarray,
                    h_c: np.ndarray, a1: np.ndarray, e: float, g: float) -> np.ndarray:
    """Bending + shear + axial compliance per unit width (m²/N) of a cantilever tooth.

    Sections at centreline positions ``y`` (rows: load cases, columns: quadrature
    points with weights already in ``dy``) of half-thickness ``h``, loaded at
    (h_c, y_c) by a unit force at angle a1 to the section (its bending part cos a1,
    its compressive part sin a1, lever h_c): with M = cos a1 (y_c − y) − sin a1 h_c,
    A = 2h, I = (2h)³/12 (Yang & Lin 1987; Tian 2004)

        c_b = ∫ M² / (E I) dy,  c_s = ∫ 1.2 cos² a1 / (G A) dy,  c_a = ∫ sin² a1 / (E A) dy
                                                                     (T.23–T.24)
    """
    area = 2.0 * h
    inertia = (2.0 * h) ** 3 / 12.0
    ca, sa = np.cos(a1)[:, None], np.sin(a1)[:, None]
    moment = ca * (y_c[:, None] - y) - sa * h_c[:, None]
    c_b = np.sum(moment**2 / (e * inertia) * dy, axis=1)
    c_s = np.sum(1.2 * ca**2 / (g * area) * dy, axis=1)
    c_a = np.sum(sa**2 / (e * area) * dy, axis=1)
    return c_b + c_s + c_a


def _tooth_compliance(pair: SpurPair, r_c: np.ndarray, n_quad: int = 64) -> np.ndarray:
    """Compliance of one tooth per unit face width (m²/N) loaded at radius r_c.

    Potential energy of a non-uniform cantilever on the tooth centreline y, from the
    root circle to the load, section 2h(y) (T.22–T.24), plus Sainsot's fillet-foundation
    term (T.25). The involute is extended down to the root circle (r_f > r_b here; the
    fillet's own shape is left to the T.25 term).
    """
    r_c = np.atleast_1d(np.asarray(r_c, dtype=float))
    rb, rf = pair.base_radius, pair.root_radius
    if rf < rb:
        raise InputError(f"root radius {rf * 1e3:.4g} mm < base radius {rb * 1e3:.4g} mm: "
                         "the involute-to-root beam needs r_f ≥ r_b (fewer than ~42 teeth at "
                         "20°); not covered")
    e, g = pair.e_tooth, pair.young / (2.0 * (1.0 + pair.poisson))
    psi_c = _half_angle(pair, r_c)
    a_c = np.arccos(rb / r_c)
    a1 = a_c - psi_c                      # load angle to the section (T.22)
    y_c, h_c = r_c * np.cos(psi_c), r_c * np.sin(psi_c)
    # Gauss–Legendre in r from r_f to r_c
    xg, wg = np.polynomial.legendre.leggauss(n_quad)
    r = rf + (r_c[:, None] - rf) * 0.5 * (xg[None, :] + 1.0)
    w = 0.5 * (r_c[:, None] - rf) * wg[None, :]
    psi = _half_angle(pair, r)
    dpsi = -np.sqrt(np.maximum(r**2 - rb**2, 0.0)) / (r * rb)
    dy = (np.cos(psi) - r * np.sin(psi) * dpsi) * w          # dy = (dy/dr) dr
    c_beam = beam_compliance(r * np.cos(psi), r * np.sin(psi), dy, y_c, h_c, a1, e, g)
    # fillet foundation, Sainsot et al. (2004) (T.25)
    theta_f = float(_half_angle(pair, np.array(rf)))
    h_f = rf / pair.bore_radius
    basis = np.array([1.0 / theta_f**2, h_f**2, h_f / theta_f, 1.0 / theta_f, h_f, 1.0])
    l_s, m_s, p_s, q_s = _SAINSOT @ basis
    u_f = y_c - h_c * np.tan(a1) - rf
    s_f = 2.0 * rf * theta_f
    c_f = np.cos(a1)**2 / e * (l_s * (u_f / s_f)**2 + m_s * (u_f / s_f)
                               + p_s * (1.0 + q_s * np.tan(a1)**2))
    return c_beam + c_f


def pair_compliance(pair: SpurPair, s: np.ndarray) -> np.ndarray:
    """Compliance of one tooth pair per unit face width (m²/N) at LoA positions s (m).

    s is measured from gear 1's base tangent point T_1; gear 1 is loaded at radius
    √(r_b² + s²), gear 2 at √(r_b² + (T_1T_2 − s)²); Hertz after Yang & Sun (1985),
    1/k_h = 4 (1 − ν²) / (π E) per unit width (T.26).
    """
    s = np.atleast_1d(np.asarray(s, dtype=float))
    rb = pair.base_radius
    line = 2.0 * pair.pitch_radius * math.sin(pair.pressure_angle)
    r1 = np.sqrt(rb**2 + s**2)
    r2 = np.sqrt(rb**2 + (line - s) ** 2)
    c_h = 4.0 * (1.0 - pair.poisson**2) / (math.pi * pair.young)
    return _tooth_compliance(pair, r1) + _tooth_compliance(pair, r2) + c_h


def pitch_point_stiffness(pair: SpurPair) -> float:
    """Single-pair stiffness at the pitch point, times the face width (N/m)."""
    s_p = pair.pitch_radius * math.sin(pair.pressure_angle)
    return float(pair.face_width / pair_compliance(pair, np.array([s_p]))[0])
