"""Compliance of a tooth pair along the transverse line of action: the potential-energy
method, for any external involute pair (teeth, profile shift, helix through its
transverse section).

Each gear's tooth is a non-uniform cantilever on its centreline, from the root circle to
the load: bending, shear and axial compression (Yang & Lin 1987; Tian 2004), plus the
deflection of the gear body under the tooth (the fillet-foundation term of Sainsot,
Velex & Duverger 2004); the pair adds the linear Hertzian term of Yang & Sun (1985).
Equations T.21–T.26 of docs/theory.md §13.3 and docs/gears.md ("Tooth compliance").
Pure NumPy, SI units; compliances per unit face width (m²/N), in the transverse plane
(a helical pair is sliced into transverse sections, :mod:`gears.ltca`).

Below the base circle (fewer than ~42 teeth at 20°, r_f < r_b) the flank is continued
by the radial line of its base-circle half angle down to the root circle (the usual
extension of the method; the fillet's own shape enters only through T.25).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from core.errors import InputError, check_range

from .pair import GearPair, involute

__all__ = ["Material", "STEEL", "beam_compliance", "tooth_compliance", "hertz_compliance",
           "pair_compliance", "half_angle"]


@dataclass(frozen=True)
class Material:
    """Isotropic elastic material of a gear body.

    Attributes
    ----------
    young : float
        Young's modulus E (Pa), > 0.
    poisson : float
        Poisson's ratio ν, in [0, 0.5).
    """

    young: float = 210e9
    poisson: float = 0.3

    def __post_init__(self) -> None:
        check_range("young", self.young, lo=0.0, lo_open=True, unit="Pa")
        check_range("poisson", self.poisson, lo=0.0, hi=0.5, hi_open=True)

    def modulus(self, plane_strain: bool) -> float:
        """E' = E/(1 − ν²) in plane strain (wide teeth, b ≫ m), E otherwise (Pa)."""
        return self.young / (1.0 - self.poisson**2) if plane_strain else self.young

    @property
    def shear_modulus(self) -> float:
        """G = E / (2 (1 + ν)) (Pa)."""
        return self.young / (2.0 * (1.0 + self.poisson))


#: Steel: E = 210 GPa, ν = 0.3.
STEEL = Material()

# Sainsot, Velex & Duverger (2004), Table: coefficients A..F of
# X*(h, θ) = A/θ² + B h² + C h/θ + D/θ + E h + F for X* = L*, M*, P*, Q*.
_SAINSOT = np.array([
    # A            B            C            D            E        F
    [-5.574e-5, -1.9986e-3, -2.3015e-4, 4.7702e-3, 0.0271, 6.8045],   # L*
    [60.111e-5, 28.100e-3, -83.431e-4, -9.9256e-3, 0.1624, 0.9086],   # M*
    [-50.952e-5, 185.50e-3, 0.0538e-4, 53.300e-3, 0.2895, 0.9236],    # P*
    [-6.2042e-5, 9.0889e-3, -4.0964e-4, 7.8297e-3, -0.1472, 0.6904],  # Q*
])


def half_angle(pair: GearPair, gear: int, r: np.ndarray) -> np.ndarray:
    """Half tooth-thickness angle ψ(r) (rad) of gear ``gear`` (1 or 2) in the transverse
    section (T.21)::

        ψ(r) = π/(2z) + 2 x tan α_n / z + inv α_t − inv α_r,   α_r = arccos(r_b / r),

    for r ≥ r_b, and ψ(r_b) below the base circle (radial flank)."""
    z, x = pair.teeth[gear - 1], pair.profile_shift[gear - 1]
    rb = pair.base_radii[gear - 1]
    a_r = np.arccos(np.clip(rb / np.maximum(r, rb), -1.0, 1.0))
    return (math.pi / (2 * z) + 2.0 * x * math.tan(pair.pressure_angle) / z
            + involute(pair.transverse_pressure_angle) - involute(a_r))


def beam_compliance(y: np.ndarray, h: np.ndarray, dy: np.ndarray, y_c: np.ndarray,
                    h_c: np.ndarray, a1: np.ndarray, e: float, g: float) -> np.ndarray:
    """Bending + shear + axial compliance per unit width (m²/N) of a cantilever tooth.

    Sections at centreline positions ``y`` (rows: load cases, columns: quadrature
    points with weights already in ``dy``) of half-thickness ``h``, loaded at
    (h_c, y_c) by a unit force at angle a1 to the section (its bending part cos a1,
    its compressive part sin a1, lever h_c): with M = cos a1 (y_c − y) − sin a1 h_c,
    A = 2h, I = (2h)³/12 (Yang & Lin 1987; Tian 2004)::

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


def _segment(pair: GearPair, gear: int, lo: float, hi: np.ndarray, n_quad: int
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Centreline y, half thickness h and weights dy of Gauss–Legendre points on the
    flank between radii lo and hi (rows: load cases); involute above r_b, radial below."""
    rb = pair.base_radii[gear - 1]
    xg, wg = np.polynomial.legendre.leggauss(n_quad)
    r = lo + (hi[:, None] - lo) * 0.5 * (xg[None, :] + 1.0)
    w = 0.5 * (hi[:, None] - lo) * wg[None, :]
    psi = half_angle(pair, gear, r)
    dpsi = -np.sqrt(np.maximum(r**2 - rb**2, 0.0)) / (r * rb)   # dψ/dr (0 below r_b)
    dy = (np.cos(psi) - r * np.sin(psi) * dpsi) * w              # dy = (dy/dr) dr
    return r * np.cos(psi), r * np.sin(psi), dy


def tooth_compliance(pair: GearPair, gear: int, r_c: np.ndarray, bore_radius: float,
                     material: Material = STEEL, *, plane_strain: bool = True,
                     n_quad: int = 48) -> np.ndarray:
    """Compliance of one tooth of gear ``gear`` (1 or 2) per unit face width (m²/N),
    loaded on its involute at radii ``r_c`` along the transverse line of action.

    Potential energy of a cantilever on the tooth centreline y, from the root circle to
    the load, section 2h(y) (T.22–T.24), plus Sainsot's fillet-foundation term (T.25)
    with h_f = r_f / r_int and θ_f = ψ(r_f). The load's angle to the section is
    a_1 = α_c − ψ_c (T.22), its bending part acts at y_c = r_c cos ψ_c, its compressive
    part with lever h_c = r_c sin ψ_c.

    Parameters
    ----------
    pair : GearPair
    gear : {1, 2}
    r_c : array_like
        Load radii (m), on the involute (r_b < r_c ≤ r_a).
    bore_radius : float
        r_int (m): the radius at which the gear body is held (its bore, or where the
        web meets the hub), < r_f.
    material : Material
    plane_strain : bool
        E/(1 − ν²) in the tooth and foundation terms (b ≫ m); E otherwise.
    n_quad : int
        Gauss–Legendre points per flank segment (converged to 1e-12 from ~16).
    """
    r_c = np.atleast_1d(np.asarray(r_c, dtype=float))
    rb, rf = pair.base_radii[gear - 1], pair.root_radii[gear - 1]
    if not 0.0 < bore_radius < rf:
        raise InputError.of(f"bore_radii[{gear}]", bore_radius,
                            f"must be > 0 and < the root radius {rf:.6g} m", unit="m")
    e, g = material.modulus(plane_strain), material.shear_modulus
    psi_c = half_angle(pair, gear, r_c)
    a_c = np.arccos(np.clip(rb / r_c, -1.0, 1.0))
    a1 = a_c - psi_c                                  # load angle to the section (T.22)
    y_c, h_c = r_c * np.cos(psi_c), r_c * np.sin(psi_c)
    if rf < rb:                                       # radial flank, then the involute
        y1, h1, d1 = _segment(pair, gear, rf, np.full_like(r_c, rb), n_quad)
        y2, h2, d2 = _segment(pair, gear, rb, r_c, n_quad)
        y, h, dy = (np.concatenate(v, axis=1) for v in ((y1, y2), (h1, h2), (d1, d2)))
    else:
        y, h, dy = _segment(pair, gear, rf, r_c, n_quad)
    c_beam = beam_compliance(y, h, dy, y_c, h_c, a1, e, g)
    # fillet foundation, Sainsot et al. (2004) (T.25)
    theta_f = float(half_angle(pair, gear, np.array(rf)))
    h_f = rf / bore_radius
    basis = np.array([1.0 / theta_f**2, h_f**2, h_f / theta_f, 1.0 / theta_f, h_f, 1.0])
    l_s, m_s, p_s, q_s = _SAINSOT @ basis
    u_f = y_c - h_c * np.tan(a1) - rf
    s_f = 2.0 * rf * theta_f
    c_f = np.cos(a1)**2 / e * (l_s * (u_f / s_f)**2 + m_s * (u_f / s_f)
                               + p_s * (1.0 + q_s * np.tan(a1)**2))
    return c_beam + c_f


def hertz_compliance(materials: tuple[Material, Material]) -> float:
    """Linear Hertzian compliance of a tooth pair per unit face width (m²/N), Yang & Sun
    (1985) for two materials: (2/π) [(1 − ν_1²)/E_1 + (1 − ν_2²)/E_2] (T.26); 4 (1 − ν²)/(πE)
    for one."""
    return 2.0 / math.pi * sum((1.0 - m.poisson**2) / m.young for m in materials)


def pair_compliance(pair: GearPair, s: np.ndarray, bore_radii: tuple[float, float],
                    materials: tuple[Material, Material] = (STEEL, STEEL), *,
                    plane_strain: bool = True) -> np.ndarray:
    """Compliance of one tooth pair per unit face width (m²/N) at transverse line-of-action
    positions ``s`` (m), measured from gear 1's base tangent point T_1 (T.26)::

        c_pair(s) = c_1(√(r_b1² + s²)) + c_2(√(r_b2² + (T_1T_2 − s)²)) + c_h
    """
    s = np.atleast_1d(np.asarray(s, dtype=float))
    rb1, rb2 = pair.base_radii
    line = pair.line_of_action_length
    c1 = tooth_compliance(pair, 1, np.sqrt(rb1**2 + s**2), bore_radii[0], materials[0],
                          plane_strain=plane_strain)
    c2 = tooth_compliance(pair, 2, np.sqrt(rb2**2 + (line - s) ** 2), bore_radii[1],
                          materials[1], plane_strain=plane_strain)
    return c1 + c2 + hertz_compliance(materials)
