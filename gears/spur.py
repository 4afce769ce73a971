"""The pair the loaded tooth contact analysis models: a 1:1 external spur pair at the
standard centre distance, with the material and the gear body's bore (SI units).

:class:`SpurPair` takes its radii, contact path and contact ratio from
:class:`gears.pair.GearPair`; the tooth compliance (:mod:`gears.compliance`), the ISO 1328
deviations (:mod:`gears.iso1328`) and the LTCA (:mod:`gears.ltca`) read them here.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from core.errors import InputError

from .pair import GearPair

__all__ = ["SpurPair", "check_pair"]


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

    @classmethod
    def from_pair(cls, pair: GearPair, *, bore_radius: float = 0.016,
                  young: float = 210e9, poisson: float = 0.3,
                  plane_strain: bool = True) -> SpurPair:
        """The LTCA's model of ``pair``, checked (:func:`check_pair`).

        Refuses what the model does not cover: unequal teeth, helical gears, profile
        shift, tip or root diameters other than the rack's, contact ratio outside
        [1, 3), a root circle inside the bore.
        """
        if pair.teeth[0] != pair.teeth[1]:
            raise InputError.of("teeth", pair.teeth, "the tooth-contact model covers "
                                "1:1 pairs only (allowed: equal teeth)")
        if abs(pair.helix_angle) > 1e-12:
            raise InputError(f"helix_angle = {math.degrees(pair.helix_angle):g}°: the "
                             "tooth-contact model covers spur gears only (allowed: 0)",
                             field="helix_angle", value=pair.helix_angle, unit="rad",
                             allowed="0")
        if any(abs(x) > 1e-12 for x in pair.profile_shift):
            raise InputError.of("profile_shift", pair.profile_shift, "the tooth-contact "
                                "model covers zero profile shift only (allowed: 0)")
        if pair.tip_diameters is not None or pair.root_diameters is not None:
            raise InputError("tip_diameters, root_diameters: the tooth-contact model "
                             "takes the rack's (addendum_coef, dedendum_coef)")
        spur = cls(teeth=int(pair.teeth[0]), module=float(pair.module),
                   pressure_angle=float(pair.pressure_angle),
                   face_width=float(pair.face_width),
                   addendum_coef=float(pair.addendum_coef),
                   dedendum_coef=float(pair.dedendum_coef), bore_radius=bore_radius,
                   young=young, poisson=poisson, plane_strain=plane_strain)
        check_pair(spur)
        return spur

    @property
    def geometry(self) -> GearPair:
        """The pair's geometry (zero shift, standard centre distance)."""
        return GearPair(teeth=(self.teeth, self.teeth), module=self.module,
                        pressure_angle=self.pressure_angle, face_width=self.face_width,
                        addendum_coef=self.addendum_coef, dedendum_coef=self.dedendum_coef)

    @property
    def pitch_radius(self) -> float:
        """r = m Z / 2 (m)."""
        return self.geometry.pitch_radii[0]

    @property
    def base_radius(self) -> float:
        """r_b = r cos α (m)."""
        return self.geometry.base_radii[0]

    @property
    def tip_radius(self) -> float:
        """r_a = r + h_a m (m)."""
        return self.geometry.tip_radii[0]

    @property
    def root_radius(self) -> float:
        """r_f = r − h_f m (m)."""
        return self.geometry.root_radii[0]

    @property
    def base_pitch(self) -> float:
        """p_b = π m cos α (m)."""
        return self.geometry.base_pitch

    @property
    def path(self) -> tuple[float, float]:
        """(s_A, s_E): start and end of contact on the line of action, measured from the
        tangent point T_1 of gear 1's base circle (m) (T.20)."""
        return self.geometry.path

    @property
    def contact_ratio(self) -> float:
        """ε_α = (s_E − s_A) / p_b."""
        return self.geometry.transverse_contact_ratio

    @property
    def e_tooth(self) -> float:
        """Modulus in the tooth terms: E/(1−ν²) in plane strain, E otherwise (Pa)."""
        return self.young / (1.0 - self.poisson**2) if self.plane_strain else self.young


def check_pair(pair: SpurPair) -> None:
    """Refuse a pair the tooth-contact model does not cover (the message names the field)."""
    if not (5 <= pair.teeth <= 1000):
        raise InputError(f"teeth = {pair.teeth}: allowed 5..1000")
    for name in ("module", "face_width", "bore_radius", "young"):
        v = getattr(pair, name)
        if not (math.isfinite(v) and v > 0):
            raise InputError(f"{name} = {v!r}: must be finite and > 0")
    if not (0.0 <= pair.poisson < 0.5):
        raise InputError(f"poisson = {pair.poisson!r}: allowed [0, 0.5)")
    if not (math.radians(10) <= pair.pressure_angle <= math.radians(35)):
        raise InputError(f"pressure_angle = {math.degrees(pair.pressure_angle):g}°: "
                         "allowed 10..35°")
    if pair.bore_radius >= pair.root_radius:
        raise InputError(f"bore_radius = {pair.bore_radius * 1e3:g} mm: must be < the root "
                         f"radius {pair.root_radius * 1e3:.4g} mm")
    if not (1.0 <= pair.contact_ratio < 3.0):
        raise InputError(f"contact ratio ε_α = {pair.contact_ratio:.3f}: allowed [1, 3)")
