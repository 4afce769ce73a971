"""Quasi-static loaded tooth contact analysis (LTCA) of a 1:1 external spur pair.

Gives the mesh stiffness k_m(θ) and the loaded static transmission error q_s(θ) of
eq. (15)–(16) over one mesh period from the tooth geometry, the material and the
profile/helix deviations, instead of invented Fourier amplitudes
(docs/theory.md §13.3, equations T.20–T.31):

- each tooth pair's compliance along the line of action from the potential-energy
  method: Hertzian contact (Yang & Sun 1985), bending, shear and axial compression of
  the tooth as a non-uniform cantilever (Yang & Lin 1987; Tian 2004), and the
  fillet-foundation (gear body) deflection of Sainsot, Velex & Duverger (2004);
- the face width cut into independent slices (no coupling along the face), each
  slice a linear spring in series with the deviations' initial separation;
- the load sharing between the pairs and slices in contact solved exactly (the total
  force is piecewise linear in the approach) so that the loads sum to F_s = T / r_b;
- the deviations of ISO 1328-1:2013 (profile slope f_Hα, profile form f_fα, helix
  slope f_Hβ) from the standard's tolerance formulas, with an assumed shape.

Pure NumPy, SI units inside; µm, N/µm and degrees only in :func:`scene_coefficients`.
Time origin and phase convention are those of ``study.scene.MeshStiffness``
(``k_m(t) = k̄ + Σ a_k cos(k Z Ω t + φ_k)``, the double-contact zone centred on t = 0,
as ``study.scene.estimate_mesh_stiffness``); t grows with the rotation of the driving
gear 1, whose contact point moves from its root to its tip.
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np

from .spur_geometry import SpurPair, check_pair, involute, spur_pair

logger = logging.getLogger(__name__)

__all__ = ["SpurPair", "Deviations", "LtcaResult", "spur_pair", "iso1328_tolerances",
           "class_deviations", "beam_compliance", "pair_compliance", "pitch_point_stiffness",
           "solve_ltca", "harmonics", "scene_coefficients", "iso6336_stiffness"]

# Sainsot, Velex & Duverger (2004), Table: coefficients A..F of
# X*(h, θ) = A/θ² + B h² + C h/θ + D/θ + E h + F for X* = L*, M*, P*, Q*.
_SAINSOT = np.array([
    # A            B            C            D            E        F
    [-5.574e-5, -1.9986e-3, -2.3015e-4, 4.7702e-3, 0.0271, 6.8045],   # L*
    [60.111e-5, 28.100e-3, -83.431e-4, -9.9256e-3, 0.1624, 0.9086],   # M*
    [-50.952e-5, 185.50e-3, 0.0538e-4, 53.300e-3, 0.2895, 0.9236],    # P*
    [-6.2042e-5, 9.0889e-3, -4.0964e-4, 7.8297e-3, -0.1472, 0.6904],  # Q*
])


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
        raise ValueError(f"grade = {grade!r}: ISO 1328-1:2013 classes are 1..11")
    for name, v in (("module_mm", module_mm), ("diameter_mm", diameter_mm),
                    ("face_width_mm", face_width_mm)):
        if not (math.isfinite(v) and v > 0):
            raise ValueError(f"{name} = {v!r}: must be finite and > 0")
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
        raise ValueError(f"fraction = {fraction!r}: allowed [0, 2]")
    tol = iso1328_tolerances(pair.module * 1e3, 2e3 * pair.pitch_radius,
                             pair.face_width * 1e3, grade)
    um = 1e-6 * fraction
    dev = Deviations(
        profile_slope=(slope_signs[0] * tol["f_HaT"] * um, slope_signs[1] * tol["f_HaT"] * um),
        profile_form=(form_signs[0] * tol["f_faT"] * um, form_signs[1] * tol["f_faT"] * um),
        helix_slope=tol["f_HbT"] * um if helix else 0.0)
    return dev, tol


# --------------------------------------------------------------------------- compliance

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
        raise ValueError(f"root radius {rf * 1e3:.4g} mm < base radius {rb * 1e3:.4g} mm: "
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


def iso6336_stiffness(pair: SpurPair, c_m: float = 0.8) -> tuple[float, float]:
    """ISO 6336-1 method B, spur, x = 0, solid discs, line load ≥ 100 N/mm:
    (c' b, c_γα b) in N/m with c' = C_M / q' and c_γα = c' (0.75 ε_α + 0.25) (T.29)."""
    z = pair.teeth
    q = 0.04723 + 0.15551 / z + 0.25791 / z          # mm·µm/N
    c1 = c_m / q * 1e3 * 1e6 * pair.face_width       # N/(mm·µm) × b (mm) -> N/m
    return c1, c1 * (0.75 * pair.contact_ratio + 0.25)


# --------------------------------------------------------------------------- LTCA

@dataclass(frozen=True)
class LtcaResult:
    """Loaded tooth contact over one mesh period, t / T_mesh = ``t`` in [0, 1).

    Attributes
    ----------
    t : ndarray (n,)
        Mesh-period fraction (origin: middle of the double-contact zone).
    ste : ndarray (n,)
        Loaded static transmission error q_s (m), approach along the line of action.
    stiffness : ndarray (n,)
        Tangent mesh stiffness k_m = dF/dq_s (N/m).
    pair_load : ndarray (n, p)
        Load of each pair slot (N), 0 where the pair is out of the path or not touching.
    pair_s : ndarray (n, p)
        LoA position of each pair slot (m), NaN where it is out of the path.
    load : float
        Static load F_s (N).
    """

    t: np.ndarray
    ste: np.ndarray
    stiffness: np.ndarray
    pair_load: np.ndarray
    pair_s: np.ndarray
    load: float


def _separation(pair: SpurPair, dev: Deviations, s: np.ndarray) -> np.ndarray:
    """Initial separation of a pair at LoA position s from the profile deviations (m):
    minus the material added on gear 1 at roll length s and on gear 2 at T_1T_2 − s (T.27)."""
    s_a, s_e = pair.path
    line = 2.0 * pair.pitch_radius * math.sin(pair.pressure_angle)
    length = s_e - s_a
    # roll lengths on each gear, as a fraction of the active profile (0 = SAP, 1 = tip)
    u1 = (s - s_a) / length
    u2 = (line - s - s_a) / length
    dev1 = dev.profile_slope[0] * (u1 - 0.5) + dev.profile_form[0] * 4.0 * u1 * (1.0 - u1)
    dev2 = dev.profile_slope[1] * (u2 - 0.5) + dev.profile_form[1] * 4.0 * u2 * (1.0 - u2)
    return -(dev1 + dev2)


def solve_ltca(pair: SpurPair, load: float, dev: Deviations | None = None, *,
               n_positions: int = 720, n_slices: int = 1280) -> LtcaResult:
    """Quasi-static LTCA over one mesh period at the static load F_s = ``load`` (N).

    At each position, pair j sits at s_j = s_A + (τ + j) p_b (in the path [s_A, s_E]);
    slice i of pair j is a spring k_ij = b/n_s / c(s_j) behind an initial separation
    g_ij (profile and helix deviations). The approach δ solves
    Σ k_ij max(0, δ − g_ij) = F_s exactly (T.28); q_s = δ and k_m = Σ_{δ > g_ij} k_ij.
    """
    if dev is None:
        dev = Deviations()
    if not (math.isfinite(load) and load > 0):
        raise ValueError(f"load = {load!r} N: must be finite and > 0")
    if not (16 <= n_positions <= 100000):
        raise ValueError(f"n_positions = {n_positions}: allowed 16..100000")
    if not (1 <= n_slices <= 10000):
        raise ValueError(f"n_slices = {n_slices}: allowed 1..10000")
    for v in (*dev.profile_slope, *dev.profile_form, dev.helix_slope):
        if not (math.isfinite(v) and abs(v) < 1e-3):
            raise ValueError(f"deviation {v!r} m: must be finite and below 1 mm")
    check_pair(pair)
    s_a, s_e = pair.path
    pb, eps = pair.base_pitch, pair.contact_ratio
    t = np.arange(n_positions) / n_positions
    tau = (t + 0.5 * (eps - 1.0)) % 1.0            # origin: middle of the double zone
    n_pairs = int(math.ceil(eps)) + 1
    s = s_a + (tau[:, None] + np.arange(n_pairs)[None, :]) * pb
    inside = s <= s_e + 1e-12 * pb
    s_in = np.where(inside, s, s_a)
    k_width = np.where(inside, 1.0 / pair_compliance(pair, s_in.ravel()).reshape(s.shape),
                       0.0)                       # N/m per m of face width
    z = (np.arange(n_slices) + 0.5) / n_slices - 0.5
    gap = (_separation(pair, dev, s_in)[:, :, None]
           + dev.helix_slope * z[None, None, :])  # (n, p, n_s)
    k = np.broadcast_to(k_width[:, :, None] * pair.face_width / n_slices, gap.shape)
    n = n_positions
    g_flat = np.where(k > 0, gap, np.inf).reshape(n, -1)
    k_flat = k.reshape(n, -1)
    order = np.argsort(g_flat, axis=1)
    g_sorted = np.take_along_axis(g_flat, order, axis=1)
    k_sorted = np.take_along_axis(k_flat, order, axis=1)
    k_cum = np.cumsum(k_sorted, axis=1)
    kg_cum = np.cumsum(k_sorted * np.where(k_sorted > 0, g_sorted, 0.0), axis=1)
    # force when δ reaches the next gap, with the first m springs engaged
    g_next = np.concatenate([g_sorted[:, 1:], np.full((n, 1), np.inf)], axis=1)
    f_next = np.where(np.isfinite(g_next), k_cum * g_next - kg_cum, np.inf)
    m = np.argmax(f_next >= load, axis=1)          # last engaged spring index
    rows = np.arange(n)
    k_m = k_cum[rows, m]
    delta = (load + kg_cum[rows, m]) / k_m
    slice_load = k * np.maximum(delta[:, None, None] - gap, 0.0)
    pair_load = slice_load.sum(axis=2)
    if not np.all(np.isfinite(delta)) or not np.all(k_m > 0):
        raise RuntimeError("tooth contact: no pair in contact at some position")
    return LtcaResult(t=t, ste=delta, stiffness=k_m, pair_load=pair_load,
                      pair_s=np.where(inside, s, np.nan), load=float(load))


def harmonics(signal: np.ndarray, n_harmonics: int) -> tuple[float, np.ndarray, np.ndarray]:
    """Mean, amplitudes a_k and phases φ_k (rad) of x(t) = x̄ + Σ a_k cos(2πk t + φ_k),
    k = 1..n, from samples on t = j/n (T.31)."""
    x = np.asarray(signal, dtype=float)
    if not (1 <= n_harmonics < x.size // 2):
        raise ValueError(f"n_harmonics = {n_harmonics}: allowed 1..{x.size // 2 - 1} for "
                         f"{x.size} positions")
    c = np.fft.rfft(x) / x.size
    ks = np.arange(1, n_harmonics + 1)
    return float(c[0].real), 2.0 * np.abs(c[ks]), np.angle(c[ks])


def scene_coefficients(result: LtcaResult, n_harmonics: int = 3) -> dict[str, dict]:
    """The ``[mesh_stiffness]`` and ``[transmission_error]`` tables of a scene file
    (N/µm, µm, degrees in [0, 360)), ``kind = "loaded"``."""
    km0, kma, kmp = harmonics(result.stiffness, n_harmonics)
    te0, tea, tep = harmonics(result.ste, n_harmonics)

    def deg(p: np.ndarray) -> list[float]:
        return [float(round(math.degrees(x) % 360.0, 2)) for x in p]

    return {
        "mesh_stiffness": {"mean_N_per_um": round(km0 * 1e-6, 3),
                           "amplitudes_N_per_um": [round(float(a) * 1e-6, 3) for a in kma],
                           "phases_deg": deg(kmp)},
        "transmission_error": {"kind": "loaded", "mean_um": round(te0 * 1e6, 4),
                               "amplitudes_um": [round(float(a) * 1e6, 4) for a in tea],
                               "phases_deg": deg(tep)},
    }
