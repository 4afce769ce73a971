"""Micro-geometry of a gear's active flanks: designed modifications (tip and root relief,
lead crowning) and deviations (profile and lead slope, profile form, single pitch
deviations), as the material each puts on the flank along the transverse line of
action (docs/gears.md, "Micro-geometry", equations M.1–M.6).

Sign: ISO's, positive = material added (the flank stands nearer its mate); a
modification removes material. The LTCA (:mod:`gears.ltca`) puts −(d_1 + d_2) between
the flanks of a tooth pair as their initial separation (T.27). Pure NumPy, SI units.

The flank is described by its roll length L = √(r² − r_b²) (the distance from the base
tangent point along the line of action, :meth:`GearPair.roll_length`) and the axial
position z ∈ [−b/2, b/2] (along the shaft axis e_z of the pair frame).
"""
from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

import numpy as np

from core.errors import InputError, check_range

from .pair import GearPair

__all__ = ["Relief", "Flank", "check_flank", "flank_deviation", "pitch_positions",
           "eccentricity_pitch_deviations"]

SHAPES = ("linear", "parabolic")


@dataclass(frozen=True)
class Relief:
    """A profile relief (tip or root) of one gear, in the transverse plane.

    Attributes
    ----------
    amount : float
        C (m), > 0: material removed at the end of the relief — the tip diameter for a
        tip relief C_a, the involute form diameter d_Ff for a root relief C_f.
    start_diameter : float
        d_C (m) where the relief starts (d_Ca for a tip relief, between the reference
        and the tip diameter; d_Cf for a root relief, between the form and the
        reference diameter).
    shape : {"linear", "parabolic"}
        Removal growing linearly or with the square of the roll length from the start
        (M.1).
    """

    amount: float
    start_diameter: float
    shape: str = "linear"

    def __post_init__(self) -> None:
        check_range("amount", self.amount, lo=0.0, lo_open=True, unit="m")
        check_range("start_diameter", self.start_diameter, lo=0.0, lo_open=True, unit="m")
        if self.shape not in SHAPES:
            raise InputError.of("shape", self.shape, f"must be one of {', '.join(SHAPES)}")


@dataclass(frozen=True)
class Flank:
    """Micro-geometry of one gear's active flanks (all teeth alike but the pitch).

    Attributes
    ----------
    tip_relief, root_relief : Relief, optional
        Profile reliefs (M.1).
    crowning : float
        Lead crowning C_β (m), ≥ 0: material removed at each face end, parabolic in z,
        zero at mid-face (M.2).
    profile_slope : float
        Profile slope deviation f_Hα (m): linear over the active profile (start of active
        profile to tip), this much more material at the tip end than at the start, zero
        at the middle (M.3).
    profile_form : float
        Profile form deviation f_fα (m): parabolic over the active profile, zero at both
        ends, this value at its middle (positive = barrelled) (M.3).
    lead_slope : float
        Helix (lead) slope deviation f_Hβ (m): linear across the face width, this much
        more material at the +z face end than at the −z end, zero at mid-face (M.4).
    pitch_deviations : tuple of float
        Single pitch deviations f_pt,i (m) of teeth i = 0 … z − 1 (ISO 1328-1: in the
        transverse plane, along the reference circle), f_pt,i the deviation of the pitch
        from tooth i − 1 to tooth i, positive when tooth i's active flank stands ahead,
        toward the mate; they sum to zero around the gear. Empty: none (M.5).
    """

    tip_relief: Relief | None = None
    root_relief: Relief | None = None
    crowning: float = 0.0
    profile_slope: float = 0.0
    profile_form: float = 0.0
    lead_slope: float = 0.0
    pitch_deviations: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        check_range("crowning", self.crowning, lo=0.0, hi=1e-3, unit="m")
        for name in ("profile_slope", "profile_form", "lead_slope"):
            check_range(name, getattr(self, name), lo=-1e-3, hi=1e-3, unit="m")
        values = self.pitch_deviations
        if isinstance(values, np.ndarray) or isinstance(values, list):
            object.__setattr__(self, "pitch_deviations", tuple(float(v) for v in values))
        for i, v in enumerate(self.pitch_deviations):
            if isinstance(v, bool) or not isinstance(v, numbers.Real):
                raise InputError.of(f"pitch_deviations[{i}]", v, "must be a number (m)")
            check_range(f"pitch_deviations[{i}]", float(v), lo=-1e-3, hi=1e-3, unit="m")

    @property
    def uniform_along_face(self) -> bool:
        """True when nothing varies across the face width (no crowning, no lead slope)."""
        return self.crowning == 0.0 and self.lead_slope == 0.0


def check_flank(flank: Flank, pair: GearPair, gear: int, field: str = "flanks") -> None:
    """Refuse micro-geometry that does not fit gear ``gear`` of ``pair`` (InputError
    naming ``field[gear]`` and the attribute).

    A tip relief must start between the reference and the tip diameter and remove less
    than the addendum; a root relief must start between the form and the reference
    diameter and remove less than the dedendum (a relief longer or deeper than the
    addendum/dedendum is refused). The pitch deviations must be one per tooth and sum
    to zero (within 1 nm: the circle closes).
    """
    i = gear - 1
    name = f"{field}[{gear}]"
    d, d_a = 2.0 * pair.pitch_radii[i], 2.0 * pair.tip_radii[i]
    d_ff = 2.0 * pair.form_radii[i]
    addendum, dedendum = 0.5 * (d_a - d), 0.5 * (d - 2.0 * pair.root_radii[i])
    tip, root = flank.tip_relief, flank.root_relief
    if tip is not None:
        if not d < tip.start_diameter < d_a:
            raise InputError.of(
                f"{name}.tip_relief.start_diameter", tip.start_diameter,
                f"must be > the reference diameter d = {d:.6g} m and < the tip diameter "
                f"d_a = {d_a:.6g} m (a tip relief longer than the addendum is refused)",
                unit="m")
        if tip.amount >= addendum:
            raise InputError.of(f"{name}.tip_relief.amount", tip.amount,
                                f"must be < the addendum {addendum:.6g} m", unit="m")
    if root is not None:
        if not d_ff < root.start_diameter < d:
            raise InputError.of(
                f"{name}.root_relief.start_diameter", root.start_diameter,
                f"must be > the form diameter d_Ff = {d_ff:.6g} m and < the reference "
                f"diameter d = {d:.6g} m (a root relief longer than the dedendum is "
                "refused)", unit="m")
        if root.amount >= dedendum:
            raise InputError.of(f"{name}.root_relief.amount", root.amount,
                                f"must be < the dedendum {dedendum:.6g} m", unit="m")
    z = pair.teeth[i]
    pitch = flank.pitch_deviations
    if pitch:
        if len(pitch) != z:
            raise InputError(f"{name}.pitch_deviations: {len(pitch)} values; must be one "
                             f"per tooth ({z})", field=f"{name}.pitch_deviations",
                             value=len(pitch), allowed=f"{z} values")
        total = math.fsum(pitch)
        if abs(total) > 1e-9:
            raise InputError(f"{name}.pitch_deviations sum to {total * 1e6:.4g} µm: single "
                             "pitch deviations must sum to zero around the gear (within "
                             "1 nm)", field=f"{name}.pitch_deviations", value=total,
                             unit="m", allowed="sum 0")


def _relief(amount: float, length: np.ndarray, span: float, shape: str) -> np.ndarray:
    """Removal of a relief at ``length`` (m) past its start, over ``span`` (M.1)."""
    u = np.clip(length / span, 0.0, None)
    return amount * (u if shape == "linear" else u * u)


def flank_deviation(flank: Flank, pair: GearPair, gear: int, roll: np.ndarray,
                    z: np.ndarray) -> np.ndarray:
    """Material d(L, z) on gear ``gear``'s active flank (m, positive = added), at roll
    lengths ``roll`` and axial positions ``z`` (broadcast), pitch deviations excluded
    (:func:`pitch_positions`)::

        tip relief:   −C_a ((L − L_Ca)/(L_a − L_Ca))^p,  L > L_Ca                      (M.1)
        root relief:  −C_f ((L_Cf − L)/(L_Cf − L_Ff))^p, L < L_Cf    (p = 1 or 2)
        crowning:     −C_β (2z/b)²                                                     (M.2)
        profile:      f_Hα (u − ½) + f_fα 4u(1 − u),  u = (L − L_s)/(L_e − L_s)           (M.3)
        lead slope:   f_Hβ z/b                                                         (M.4)

    with L_a, L_C, L_Ff the roll lengths of the tip, relief start and form diameters
    and [L_s, L_e] the active profile (:attr:`GearPair.active_roll_lengths`).
    """
    i = gear - 1
    rb = pair.base_radii[i]
    roll = np.asarray(roll, dtype=float)
    z = np.asarray(z, dtype=float)
    out = np.zeros(np.broadcast(roll, z).shape)
    if flank.tip_relief is not None:
        r = flank.tip_relief
        l_c = pair.roll_length(rb, 0.5 * r.start_diameter)
        l_a = pair.roll_length(rb, pair.tip_radii[i])
        out = out - _relief(r.amount, roll - l_c, l_a - l_c, r.shape)
    if flank.root_relief is not None:
        r = flank.root_relief
        l_c = pair.roll_length(rb, 0.5 * r.start_diameter)
        l_f = max(pair.form_roll_lengths[i], 0.0)
        out = out - _relief(r.amount, l_c - roll, l_c - l_f, r.shape)
    if flank.profile_slope or flank.profile_form:
        l_s, l_e = pair.active_roll_lengths[i]
        u = (roll - l_s) / (l_e - l_s)
        out = out + flank.profile_slope * (u - 0.5) + flank.profile_form * 4.0 * u * (1.0 - u)
    b = pair.face_width
    if flank.crowning:
        out = out - flank.crowning * (2.0 * z / b) ** 2
    if flank.lead_slope:
        out = out + flank.lead_slope * z / b
    return out


def pitch_positions(flank: Flank, pair: GearPair, gear: int) -> np.ndarray:
    """Position of each tooth's active flank along the line of action (m, positive =
    toward the mate), from the single pitch deviations (M.5)::

        F_p,i = Σ_{k=1..i} f_pt,k (tooth 0 the datum),   e_i = F_p,i cos α_t

    (a deviation along the reference circle moves the flank by r_b/r = cos α_t times
    as much along the line of action). Zeros when no pitch deviation is given.
    """
    z = pair.teeth[gear - 1]
    if not flank.pitch_deviations:
        return np.zeros(z)
    f = np.asarray(flank.pitch_deviations, dtype=float)
    cumulative = np.concatenate([[0.0], np.cumsum(f[1:])])
    return cumulative * math.cos(pair.transverse_pressure_angle)


def eccentricity_pitch_deviations(teeth: int, amplitude: float, phase: float = 0.0
                                  ) -> tuple[float, ...]:
    """Single pitch deviations of a gear whose cumulative pitch deviation is a once-per-
    revolution sine (a mounting eccentricity or run-out, M.6)::

        F_p,i = A sin(2π i / z + φ) − A sin φ,   f_pt,i = F_p,i − F_p,i−1

    Parameters
    ----------
    teeth : int
        z.
    amplitude : float
        A (m), the amplitude of the cumulative pitch deviation.
    phase : float
        φ (rad).
    """
    i = np.arange(teeth + 1)
    cumulative = amplitude * (np.sin(2.0 * math.pi * i / teeth + phase) - math.sin(phase))
    f = np.diff(cumulative)
    f = np.roll(f, 1)       # f_pt,i is the step from tooth i − 1 to tooth i; f_pt,0 closes
    f -= f.mean()           # exact closure (round-off)
    return tuple(float(v) for v in f)
