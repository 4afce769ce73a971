"""Tooth stiffness estimates of ISO 6336-1, method B: the single stiffness c' of a tooth
pair and the mesh stiffness c_γα (ISO 6336-1:2006, clause 9).

    q' = C_1 + C_2/z_n1 + C_3/z_n2 + C_4 x_1 + C_5 x_1/z_n1 + C_6 x_2 + C_7 x_2/z_n2
         + C_8 x_1² + C_9 x_2²   (mm·µm/N),   c'_th = 1/q'                        (T.29a)
    c' = c'_th C_M C_R C_B cos β  [× (F_t/b / 100 N/mm)^0.25 below 100 N/mm]      (T.29b)
    c_γα = c' (0.75 ε_α + 0.25)                                                  (T.29c)
    C_B = [1 + 0.5 (1.2 − h_fP/m_n)] [1 − 0.02 (20° − α_n)]                      (T.29d)

C_M = 0.8 (solid discs, theoretical-to-real correction), C_R = 1 for solid blanks. The
ISO text was not at hand when this was written: the equations are quoted by clause,
not by the standard's numbers; the check is the ISO/TR 6336-30 example pair
(``tests/test_gears_pair.py``). Functions of plain numbers or a
:class:`~gears.pair.GearPair`; stiffnesses in N/m over the face width (SI), the ISO
units (N/(mm·µm)) only where named.
"""
from __future__ import annotations

import math
from collections.abc import Sequence

from core.errors import check_range

from .pair import GearPair

__all__ = ["Q_COEFFICIENTS", "approximate_virtual_teeth", "theoretical_single_stiffness",
           "basic_rack_factor", "single_stiffness", "mesh_stiffness", "pair_stiffness"]

#: C_1 … C_9 of q' (mm·µm/N), ISO 6336-1 method B.
Q_COEFFICIENTS = (0.04723, 0.15551, 0.25791, -0.00635, -0.11654, -0.00193, -0.24188,
                  0.00529, 0.00182)


def approximate_virtual_teeth(teeth: int, helix_angle: float) -> float:
    """z_n ≈ z / cos³β: the scene estimate's virtual number of teeth (exact for spur
    gears; :attr:`GearPair.virtual_teeth` is ISO 21771's z / (cos²β_b cos β))."""
    return teeth / math.cos(helix_angle) ** 3


def theoretical_single_stiffness(virtual_teeth: Sequence[float],
                                 profile_shift: Sequence[float]) -> float:
    """c'_th = 1/q' in N/(mm·µm) (T.29a).

    Parameters
    ----------
    virtual_teeth : (z_n1, z_n2)
        Virtual numbers of teeth of gear 1 and gear 2.
    profile_shift : (x_1, x_2)
        Profile shift coefficients.
    """
    zn1, zn2 = virtual_teeth
    x1, x2 = profile_shift
    q = (0.04723 + 0.15551 / zn1 + 0.25791 / zn2 - 0.00635 * x1 - 0.11654 * x1 / zn1
         - 0.00193 * x2 - 0.24188 * x2 / zn2 + 0.00529 * x1 * x1 + 0.00182 * x2 * x2)
    return 1.0 / q


def basic_rack_factor(dedendum_coef: float, pressure_angle: float) -> float:
    """C_B = [1 + 0.5 (1.2 − h_fP/m_n)] [1 − 0.02 (20° − α_n)] (T.29d), α_n in rad."""
    return ((1.0 + 0.5 * (1.2 - dedendum_coef))
            * (1.0 - 0.02 * (20.0 - math.degrees(pressure_angle))))


def single_stiffness(virtual_teeth: Sequence[float], profile_shift: Sequence[float],
                     helix_angle: float, pressure_angle: float, face_width: float, *,
                     c_m: float = 0.8, c_r: float = 1.0, c_b: float = 1.0,
                     static_load: float | None = None) -> float:
    """Single stiffness of a tooth pair over the face width, c'·b (N/m) (T.29b).

    Parameters
    ----------
    virtual_teeth, profile_shift : (gear 1, gear 2)
        See :func:`theoretical_single_stiffness`.
    helix_angle, pressure_angle : float
        β and α (rad).
    face_width : float
        b (m).
    c_m, c_r, c_b : float
        Correction factor C_M, gear blank factor C_R, basic rack factor C_B
        (:func:`basic_rack_factor`).
    static_load : float, optional
        Static load along the line of action F_s (N); the line load F_s cos α / b
        below 100 N/mm scales c' by its fourth root over 100 N/mm's. None: no
        low-load correction (line load ≥ 100 N/mm).
    """
    check_range("face_width", face_width, lo=0.0, lo_open=True, unit="m")
    c_th = theoretical_single_stiffness(virtual_teeth, profile_shift)  # N/(mm·µm)
    c = c_th * c_m * c_r * c_b * math.cos(helix_angle)
    if static_load is not None:
        line_load = static_load * math.cos(pressure_angle) / (face_width * 1e3)  # N/mm
        if line_load < 100.0:
            c *= max(line_load, 1e-3) ** 0.25 / 100.0 ** 0.25
    return c * face_width * 1e3 * 1e6  # N/(mm·µm) × mm -> N/µm -> N/m


def mesh_stiffness(single_pair: float, contact_ratio: float) -> float:
    """Mean mesh stiffness c_γα b = c' b (0.75 ε_α + 0.25) (N/m) (T.29c)."""
    return single_pair * (0.75 * contact_ratio + 0.25)


def pair_stiffness(pair: GearPair, *, c_m: float = 0.8, c_r: float = 1.0,
                   c_b: float = 1.0, static_load: float | None = None
                   ) -> tuple[float, float]:
    """(c' b, c_γα b) of ``pair`` in N/m (T.29): its virtual teeth, profile shifts, helix
    and normal pressure angles, face width and transverse contact ratio."""
    single = single_stiffness(pair.virtual_teeth, pair.profile_shift, pair.helix_angle,
                              pair.pressure_angle, pair.face_width, c_m=c_m, c_r=c_r,
                              c_b=c_b, static_load=static_load)
    return single, mesh_stiffness(single, pair.transverse_contact_ratio)
