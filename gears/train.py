"""Mesh phasing in a gear train: the phase of each mesh's cycle (stiffness, transmission
error) from the angular position of the teeth and of the mating gears (docs/theory.md,
§14.5, T.41-T.47).

Two meshes on one gear — an idler driven by one gear and driving another, or the two
gears of an intermediate shaft — are not in phase: where a tooth pair of each mesh sits on
its path of contact at a given instant depends on the angle between the two lines of
centres, the tooth count and the tooth thickness at each working pitch circle, and on the
flank that carries the load (an idler is driven on one flank and drives with the other).

Convention of the phase (that of :mod:`gears.ltca` and
:func:`gears.excitation.rectangular_mesh_stiffness`, the scene's ``k_m(t) = k̄ + Σ a_k
cos(k Z Ω t + φ_k)``): the mesh phase is 0 when a pair sits in the middle of the zone where
⌊ε_α⌋ + 1 pairs touch, and grows by 2π per base pitch travelled along the line of action
(s from gear 1's base tangent point T_1, gear 1 driving). On a gear turning in its own
sense of rotation by φ the phase grows by Z φ; an element's phase at t = 0 is
:attr:`hbm.GearMesh.phase`.

Angles of the functions below are measured on the gear in question, from any fixed line
through its centre, positive in its sense of rotation; tooth angles at the mid-face
transverse section, teeth without backlash thinning (the pair's zero-backlash geometry,
G.4). Pure NumPy, SI units (m, rad); imports only :mod:`core` and :mod:`gears.pair`.
"""
from __future__ import annotations

import math

from core.errors import InputError, check_range

from .pair import GearPair, involute

__all__ = ["idler_phase_difference", "mesh_phase", "pitch_point_phase", "relative_phase",
           "tooth_half_angle", "working_radius"]


def _check_gear(gear: int) -> int:
    if isinstance(gear, bool) or gear not in (1, 2):
        raise InputError.of("gear", gear, "must be 1 (the pair's driving gear) or 2 (driven)")
    return int(gear)


def working_radius(pair: GearPair, gear: int) -> float:
    """Working pitch radius r_w = r_b / cos α_wt of gear ``gear`` (1 or 2) in the pair (m):
    where the pitch point C sits on the line of centres."""
    g = _check_gear(gear)
    return pair.base_radii[g - 1] / math.cos(pair.working_pressure_angle)


def tooth_half_angle(pair: GearPair, gear: int, radius: float) -> float:
    """Half the angular thickness of a tooth of gear ``gear`` at ``radius`` (rad, T.41):

        ψ(r) = (π/2 + 2 x tan α_n) / z + inv α_t − inv α_r,   cos α_r = r_b / r,

    the transverse tooth thickness at the reference circle s_t = m_t (π/2 + 2 x tan α_n)
    carried along the involute (ISO 21771)."""
    g = _check_gear(gear)
    rb = pair.base_radii[g - 1]
    check_range("radius", radius, lo=rb, unit="m")
    z = pair.teeth[g - 1]
    x = pair.profile_shift[g - 1]
    a_r = math.acos(min(1.0, rb / radius))
    return ((0.5 * math.pi + 2.0 * x * math.tan(pair.pressure_angle)) / z
            + float(involute(pair.transverse_pressure_angle)) - float(involute(a_r)))


def pitch_point_phase(pair: GearPair, gear: int, centre_angle: float,
                      tooth_angle: float = 0.0) -> float:
    """Phase (rad, [0, 2π)) of the mesh cycle counted from a pair's passage through the
    pitch point C (T.43): ``Z (γ − α)`` with γ the angle of the loaded flank of a tooth at
    the working pitch circle and α that of C (the mate's centre), both on gear ``gear``.

    Parameters
    ----------
    pair
        The pair (gear 1 drives: gear 1 is loaded on the leading flank of its teeth,
        gear 2 on the trailing one).
    gear
        Which gear of the pair the angles are measured on (1 or 2).
    centre_angle
        Angle of the line of centres towards the mating gear (rad).
    tooth_angle
        Angle of the centreline of one tooth (rad).
    """
    g = _check_gear(gear)
    for name, v in (("centre_angle", centre_angle), ("tooth_angle", tooth_angle)):
        check_range(name, v, unit="rad")
    z = pair.teeth[g - 1]
    sigma = 1.0 if g == 1 else -1.0              # leading flank drives, trailing is driven
    half = tooth_half_angle(pair, g, working_radius(pair, g))
    return (z * (tooth_angle + sigma * half - centre_angle)) % (2.0 * math.pi)


def mesh_phase(pair: GearPair, gear: int, centre_angle: float,
               tooth_angle: float = 0.0) -> float:
    """Mesh phase (rad, [0, 2π)) in the scene's convention (the module) at the instant when
    a tooth of gear ``gear`` has its centreline at ``tooth_angle`` and the mating gear's
    centre is at ``centre_angle`` (T.44)::

        θ = 2π (s_C − s_A)/p_b − π (ε_α − ⌊ε_α⌋) + Z (γ − α),

    s_C = r_b1 tan α_wt the pitch point and s_A the start of contact on the line of action
    (from T_1), p_b the base pitch, ``Z (γ − α)`` :func:`pitch_point_phase`."""
    p = pitch_point_phase(pair, gear, centre_angle, tooth_angle)
    s_a, _ = pair.path
    s_c = pair.base_radii[0] * math.tan(pair.working_pressure_angle)
    eps = pair.transverse_contact_ratio
    frac = eps - math.floor(eps)
    return (2.0 * math.pi * (s_c - s_a) / pair.base_pitch - math.pi * frac + p) \
        % (2.0 * math.pi)


def relative_phase(first: tuple, second: tuple, tooth_angle: float = 0.0) -> float:
    """Phase of the second mesh minus the first's (rad, [0, 2π)) when both are measured on
    one gear (an idler, T.45 with T.44): ``first`` and ``second`` are ``(pair, gear, centre_angle)``
    for each mesh, the gear being the shared one in both pairs (same tooth count)."""
    (p1, g1, a1), (p2, g2, a2) = first, second
    z1, z2 = p1.teeth[_check_gear(g1) - 1], p2.teeth[_check_gear(g2) - 1]
    if z1 != z2:
        raise InputError(f"relative_phase: the shared gear has {z1} teeth in the first pair "
                         f"and {z2} in the second; both must be the same gear",
                         field="second", value=z2, allowed=f"{z1} teeth")
    return (mesh_phase(p2, g2, a2, tooth_angle) - mesh_phase(p1, g1, a1, tooth_angle)) \
        % (2.0 * math.pi)


def idler_phase_difference(n_teeth: int, angle: float) -> float:
    """Closed form for an idler of standard teeth (no profile shift, standard centre
    distances, no backlash) driven at the first pitch point and driving at the second,
    ``angle`` (rad) after it in the idler's sense of rotation (T.46): the phase of the
    second mesh minus the first's, both counted from a pair at its pitch point,

        Δθ_C = π − Z Δα   (mod 2π)

    (half a mesh cycle from the two flanks, Z Δα from the angle between the lines of
    centres)."""
    if isinstance(n_teeth, bool) or int(n_teeth) != n_teeth or n_teeth < 1:
        raise InputError.of("n_teeth", n_teeth, "must be an integer >= 1")
    check_range("angle", angle, unit="rad")
    return (math.pi - int(n_teeth) * angle) % (2.0 * math.pi)
