"""Flank tolerances of ISO 1328-1:2013 and the deviations a tolerance class allows.

:func:`iso1328_tolerances` evaluates the standard's tolerance formulas for a class (T.30);
:class:`Deviations` are the profile and helix deviations of a pair that the loaded tooth
contact analysis (:mod:`gears.ltca`) puts between the flanks (T.27), and
:func:`class_deviations` gives them an assumed shape at a class's tolerances
(docs/theory.md §13.3). Pure Python, µm in the tolerances, m in the deviations.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from core.errors import InputError

from .spur import SpurPair

__all__ = ["iso1328_tolerances", "Deviations", "class_deviations"]


def _iso1328_round(v: float) -> float:
    """ISO 1328-1:2013 rounding: > 10 µm to 1 µm, 5–10 µm to 0.5 µm, < 5 µm to 0.1 µm."""
    step = 1.0 if v > 10.0 else (0.5 if v >= 5.0 else 0.1)
    return round(math.floor(v / step + 0.5 + 1e-9) * step, 1)  # half up


def iso1328_tolerances(module_mm: float, diameter_mm: float, face_width_mm: float,
                       grade: int) -> dict[str, float]:
    """Flank tolerances of ISO 1328-1:2013 (µm) for tolerance class ``grade`` (1..11).

    Class 5 values times √2^(grade−5), rounded as the standard says (T.30):
    f_pT = 0.001 d + 0.4 m + 5, f_HαT = 0.4 m + 0.001 d + 4, f_fαT = 0.55 m + 5,
    F_αT = √(f_HαT² + f_fαT²), f_HβT = 0.05 √d + 0.35 √b + 4,
    f_fβT = 0.07 √d + 0.45 √b + 4, F_βT = √(f_HβT² + f_fβT²); d, m, b in mm.
    """
    if not (1 <= int(grade) <= 11) or int(grade) != grade:
        raise InputError(f"grade = {grade!r}: ISO 1328-1:2013 classes are 1..11")
    for name, v in (("module_mm", module_mm), ("diameter_mm", diameter_mm),
                    ("face_width_mm", face_width_mm)):
        if not (math.isfinite(v) and v > 0):
            raise InputError(f"{name} = {v!r}: must be finite and > 0")
    m, d, b = module_mm, diameter_mm, face_width_mm
    s = math.sqrt(2.0) ** (grade - 5)
    f_h_a = (0.4 * m + 0.001 * d + 4.0) * s
    f_f_a = (0.55 * m + 5.0) * s
    f_h_b = (0.05 * math.sqrt(d) + 0.35 * math.sqrt(b) + 4.0) * s
    f_f_b = (0.07 * math.sqrt(d) + 0.45 * math.sqrt(b) + 4.0) * s
    raw = {"f_pT": (0.001 * d + 0.4 * m + 5.0) * s, "f_HaT": f_h_a, "f_faT": f_f_a,
           "F_aT": math.hypot(f_h_a, f_f_a), "f_HbT": f_h_b, "f_fbT": f_f_b,
           "F_bT": math.hypot(f_h_b, f_f_b)}
    return {k: _iso1328_round(v) for k, v in raw.items()}


@dataclass(frozen=True)
class Deviations:
    """Flank deviations of the two gears (m); positive = material added (ISO sign).

    ``profile_slope[i]``: linear deviation of gear i+1 rising by this amount from the
    start of its active profile to its tip (a profile slope deviation f_Hα).
    ``profile_form[i]``: parabolic deviation of gear i+1, zero at both ends of the active
    profile and this value at its middle (a form deviation f_fα; negative = material
    removed in the middle, positive = barrelled).
    ``helix_slope``: relative helix slope deviation of the pair across the face width
    (linear in the axial coordinate, mean zero, total range this value; for a 1:1 pair
    the two gears' f_Hβ add when their signs differ).
    """

    profile_slope: tuple[float, float] = (0.0, 0.0)
    profile_form: tuple[float, float] = (0.0, 0.0)
    helix_slope: float = 0.0


def class_deviations(pair: SpurPair, grade: int, *, fraction: float = 1.0,
                     slope_signs: tuple[int, int] = (1, -1),
                     form_signs: tuple[int, int] = (1, 1),
                     helix: bool = True) -> tuple[Deviations, dict[str, float]]:
    """Deviations of size ``fraction`` × the ISO 1328-1:2013 class-``grade`` tolerances.

    Assumed shape (docs/theory.md §13.3): on each gear a linear profile slope deviation of
    size f_HαT with sign ``slope_signs[i]`` (opposite signs by default: the largest
    mismatch the class allows; equal signs cancel on a 1:1 pair), a parabolic form
    deviation of depth f_fαT with sign ``form_signs[i]`` (barrelled by default), and,
    when ``helix``, a relative helix slope of f_HβT across the face. Returns the
    deviations and the tolerances (µm) they come from.
    """
    if not (0.0 <= fraction <= 2.0):
        raise InputError(f"fraction = {fraction!r}: allowed [0, 2]")
    tol = iso1328_tolerances(pair.module * 1e3, 2e3 * pair.pitch_radius,
                             pair.face_width * 1e3, grade)
    um = 1e-6 * fraction
    dev = Deviations(
        profile_slope=(slope_signs[0] * tol["f_HaT"] * um, slope_signs[1] * tol["f_HaT"] * um),
        profile_form=(form_signs[0] * tol["f_faT"] * um, form_signs[1] * tol["f_faT"] * um),
        helix_slope=tol["f_HbT"] * um if helix else 0.0)
    return dev, tol
