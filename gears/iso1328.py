"""Flank tolerances of ISO 1328-1:2013 and the deviations a tolerance class allows.

:func:`iso1328_tolerances` evaluates the standard's tolerance formulas for a class (T.30);
:func:`class_deviations` gives the flanks (:class:`gears.flank.Flank`) an assumed shape
at a class's tolerances (docs/theory.md §13.3). Pure Python, µm in the tolerances, m in
the deviations.
"""
from __future__ import annotations

import math

from core.errors import InputError, check_range

from .flank import Flank
from .pair import GearPair

__all__ = ["iso1328_tolerances", "class_deviations"]


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


def class_deviations(pair: GearPair, grade: int, *, fraction: float = 1.0,
                     slope_signs: tuple[int, int] = (1, -1),
                     form_signs: tuple[int, int] = (1, 1),
                     helix: bool = True) -> tuple[tuple[Flank, Flank], dict[str, float]]:
    """Flank deviations of size ``fraction`` × the ISO 1328-1:2013 class-``grade``
    tolerances of gear 1 (its reference diameter, the module and face width).

    Assumed shape (docs/theory.md §13.3): on each gear a linear profile slope deviation of
    size f_HαT with sign ``slope_signs[i]`` (opposite signs by default: the largest
    mismatch the class allows; equal signs cancel on a 1:1 pair), a parabolic form
    deviation of depth f_fαT with sign ``form_signs[i]`` (barrelled by default), and,
    when ``helix``, a lead slope of f_HβT on gear 1 (the pair's mismatch across the
    face). A sign 0 leaves that deviation out. Returns the two gears' :class:`Flank` and
    the tolerances (µm) they come from.
    """
    check_range("fraction", fraction, lo=0.0, hi=2.0)
    tol = iso1328_tolerances(pair.module * 1e3, 2e3 * pair.pitch_radii[0],
                             pair.face_width * 1e3, grade)
    um = 1e-6 * fraction
    flanks = tuple(
        Flank(profile_slope=slope_signs[i] * tol["f_HaT"] * um,
              profile_form=form_signs[i] * tol["f_faT"] * um,
              lead_slope=tol["f_HbT"] * um if (helix and i == 0) else 0.0)
        for i in range(2))
    return flanks, tol
