"""Quasi-static loaded tooth contact analysis (LTCA) of a 1:1 external spur pair.

Gives the mesh stiffness k_m(θ) and the loaded static transmission error q_s(θ) of
eq. (15)–(16) over one mesh period from the tooth geometry, the material and the
profile/helix deviations, instead of invented Fourier amplitudes
(docs/theory.md §13.3, equations T.20–T.31):

- each tooth pair's compliance along the line of action from the potential-energy
  method (:mod:`gears.compliance`);
- the face width cut into independent slices (no coupling along the face), each
  slice a linear spring in series with the deviations' initial separation;
- the load sharing between the pairs and slices in contact solved exactly (the total
  force is piecewise linear in the approach) so that the loads sum to F_s = T / r_b;
- the deviations of ISO 1328-1:2013 (profile slope f_Hα, profile form f_fα, helix
  slope f_Hβ) from the standard's tolerance formulas, with an assumed shape
  (:mod:`gears.iso1328`).

Pure NumPy, SI units inside; µm, N/µm and degrees only in :func:`scene_coefficients`.
Time origin and phase convention are those of the scene's mesh stiffness
(``k_m(t) = k̄ + Σ a_k cos(k Z Ω t + φ_k)``, the double-contact zone centred on t = 0,
as :func:`gears.excitation.rectangular_mesh_stiffness`); t grows with the rotation of
the driving gear 1, whose contact point moves from its root to its tip.
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np

from core.errors import InputError

from .compliance import pair_compliance
from .excitation import fourier_harmonics
from .iso1328 import Deviations
from .spur import SpurPair, check_pair

logger = logging.getLogger(__name__)

__all__ = ["LtcaResult", "solve_ltca", "scene_coefficients"]


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
        raise InputError(f"load = {load!r} N: must be finite and > 0")
    if not (16 <= n_positions <= 100000):
        raise InputError(f"n_positions = {n_positions}: allowed 16..100000")
    if not (1 <= n_slices <= 10000):
        raise InputError(f"n_slices = {n_slices}: allowed 1..10000")
    for v in (*dev.profile_slope, *dev.profile_form, dev.helix_slope):
        if not (math.isfinite(v) and abs(v) < 1e-3):
            raise InputError(f"deviation {v!r} m: must be finite and below 1 mm")
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


def scene_coefficients(result: LtcaResult, n_harmonics: int = 3) -> dict[str, dict]:
    """The ``[mesh_stiffness]`` and ``[transmission_error]`` tables of a scene file
    (N/µm, µm, degrees in [0, 360)), ``kind = "loaded"``."""
    km0, kma, kmp = fourier_harmonics(result.stiffness, n_harmonics)
    te0, tea, tep = fourier_harmonics(result.ste, n_harmonics)

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
