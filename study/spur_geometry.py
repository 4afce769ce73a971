"""Geometry of a 1:1 external spur pair at the standard centre distance (SI units).

The data of the loaded tooth contact analysis (:mod:`study.tooth_contact`): radii,
contact path and the tooth profile needed by the potential-energy compliance.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["SpurPair", "check_pair", "involute", "spur_pair"]


def involute(a: np.ndarray | float) -> np.ndarray | float:
    """Involute function inv α = tan α − α."""
    return np.tan(a) - a


@dataclass(frozen=True)
class SpurPair:
    """A 1:1 external spur pair at the standard centre distance, SI units.

    Attributes
    ----------
    teeth : int
        Teeth of each gear, Z.
    module : float
        Module m (m).
    pressure_angle : float
        Pressure angle α (rad).
    face_width : float
        Face width b (m).
    addendum_coef, dedendum_coef : float
        h_a and h_f in modules (1 and 1.25 for the ISO 53 rack).
    bore_radius : float
        Radius r_int of the gear body's bore (m), for the fillet-foundation term.
    young : float
        Young's modulus E (Pa), both gears.
    poisson : float
        Poisson's ratio ν, both gears.
    plane_strain : bool
        Use E/(1−ν²) in the tooth terms (wide teeth, b ≫ m); E otherwise.
    """

    teeth: int
    module: float
    pressure_angle: float
    face_width: float
    addendum_coef: float = 1.0
    dedendum_coef: float = 1.25
    bore_radius: float = 0.016
    young: float = 210e9
    poisson: float = 0.3
    plane_strain: bool = True

    @property
    def pitch_radius(self) -> float:
        """r = m Z / 2 (m)."""
        return 0.5 * self.module * self.teeth

    @property
    def base_radius(self) -> float:
        """r_b = r cos α (m)."""
        return self.pitch_radius * math.cos(self.pressure_angle)

    @property
    def tip_radius(self) -> float:
        """r_a = r + h_a m (m)."""
        return self.pitch_radius + self.addendum_coef * self.module

    @property
    def root_radius(self) -> float:
        """r_f = r − h_f m (m)."""
        return self.pitch_radius - self.dedendum_coef * self.module

    @property
    def base_pitch(self) -> float:
        """p_b = π m cos α (m)."""
        return math.pi * self.module * math.cos(self.pressure_angle)

    @property
    def path(self) -> tuple[float, float]:
        """(s_A, s_E): start and end of contact on the line of action, measured from the
        tangent point T_1 of gear 1's base circle (m) (T.20)."""
        rb, ra = self.base_radius, self.tip_radius
        ta = math.sqrt(ra**2 - rb**2)
        line = 2.0 * self.pitch_radius * math.sin(self.pressure_angle)  # T_1 T_2
        return line - ta, ta

    @property
    def contact_ratio(self) -> float:
        """ε_α = (s_E − s_A) / p_b."""
        s_a, s_e = self.path
        return (s_e - s_a) / self.base_pitch

    @property
    def e_tooth(self) -> float:
        """Modulus in the tooth terms: E/(1−ν²) in plane strain, E otherwise (Pa)."""
        return self.young / (1.0 - self.poisson**2) if self.plane_strain else self.young


def spur_pair(gear: object, *, bore_radius: float = 0.016, young: float = 210e9,
              poisson: float = 0.3, plane_strain: bool = True) -> SpurPair:
    """A :class:`SpurPair` from a ``study.scene.GearData`` (or any object with its fields).

    Refuses what the model does not cover: helical gears, profile shift, contact ratio
    outside [1, 3), a root circle inside the bore.
    """
    if abs(getattr(gear, "helix_angle", 0.0)) > 1e-12:
        raise ValueError(f"gear.helix_angle_deg = {math.degrees(gear.helix_angle):g}: the "
                         "tooth-contact model covers spur gears only (allowed: 0)")
    if abs(getattr(gear, "profile_shift", 0.0)) > 1e-12:
        raise ValueError(f"gear.profile_shift = {gear.profile_shift:g}: the tooth-contact "
                         "model covers zero profile shift only (allowed: 0)")
    pair = SpurPair(teeth=int(gear.teeth), module=float(gear.module),
                    pressure_angle=float(gear.pressure_angle),
                    face_width=float(gear.face_width),
                    addendum_coef=float(gear.addendum_coef),
                    dedendum_coef=float(gear.dedendum_coef), bore_radius=bore_radius,
                    young=young, poisson=poisson, plane_strain=plane_strain)
    check_pair(pair)
    return pair


def check_pair(pair: SpurPair) -> None:
    if not (5 <= pair.teeth <= 1000):
        raise ValueError(f"teeth = {pair.teeth}: allowed 5..1000")
    for name in ("module", "face_width", "bore_radius", "young"):
        v = getattr(pair, name)
        if not (math.isfinite(v) and v > 0):
            raise ValueError(f"{name} = {v!r}: must be finite and > 0")
    if not (0.0 <= pair.poisson < 0.5):
        raise ValueError(f"poisson = {pair.poisson!r}: allowed [0, 0.5)")
    if not (math.radians(10) <= pair.pressure_angle <= math.radians(35)):
        raise ValueError(f"pressure_angle = {math.degrees(pair.pressure_angle):g}°: "
                         "allowed 10..35°")
    if pair.bore_radius >= pair.root_radius:
        raise ValueError(f"bore_radius = {pair.bore_radius * 1e3:g} mm: must be < the root "
                         f"radius {pair.root_radius * 1e3:.4g} mm")
    if not (1.0 <= pair.contact_ratio < 3.0):
        raise ValueError(f"contact ratio ε_α = {pair.contact_ratio:.3f}: allowed [1, 3)")


# --------------------------------------------------------------------------- ISO 1328
