"""Quasi-static loaded tooth contact analysis (LTCA) of an external involute pair, spur
or helical, with micro-geometry and pitch deviations, at a given torque.

Gives the mesh stiffness k_m(θ) and the loaded static transmission error q_s(θ) of
eq. (15)–(16) over the mesh period — and over the hunting period when pitch deviations
are given — from the macro-geometry (:class:`gears.pair.GearPair`), the bodies
(bore radii, materials) and the flanks (:class:`gears.flank.Flank`)
(docs/theory.md §13.3, equations T.20–T.31; docs/gears.md, "LTCA"):

- each tooth pair's compliance along the transverse line of action from the
  potential-energy method (:mod:`gears.tooth`);
- the face width cut into thin transverse slices (the thin-slice model). Slice i of
  a helical pair sits at z_i and meets its mate at s + η z_i tan β_b on the line of
  action, so the slices follow the inclined contact lines. **Slices are uncoupled**
  (a Winkler foundation along the face: no load spreads from one slice to the next
  through the tooth), each a linear spring in series with its initial separation;
- the load sharing between all slices of all pairs in contact solved exactly (the
  total force is piecewise linear in the approach) so that the loads are ≥ 0 and sum
  to F_s = T / r_b1: a slice whose separation exceeds the approach carries nothing
  (loss of contact in the loaded zone);
- contact only on the nominal path of contact [s_A, s_E] (no contact outside it under
  deflection, no corner contact).

Pure NumPy, SI units inside; µm, N/µm and degrees only in :func:`scene_coefficients`.
Time origin and phase convention are those of the scene's mesh stiffness
(``k_m(t) = k̄ + Σ a_k cos(k Z Ω t + φ_k)``): t = 0 is the middle of the zone where
⌊ε_α⌋ + 1 pairs touch (mid-face slice), as :func:`gears.excitation.rectangular_mesh_stiffness`;
t grows with the rotation of the driving gear 1, whose contact moves from its root to
its tip. :class:`LtcaCase` is a hashable frozen dataclass: the pipeline caches by it.
"""
from __future__ import annotations

import logging
import math
import numbers
from dataclasses import dataclass, field

import numpy as np

from core.errors import InputError, check_range

from .excitation import Series, fourier_harmonics
from .flank import Flank, check_flank, flank_deviation, pitch_positions
from .pair import GearPair
from .tooth import STEEL, Material, pair_compliance

logger = logging.getLogger(__name__)

__all__ = ["LtcaCase", "LtcaResult", "solve_ltca", "HarrisMap", "harris_map",
           "ContactPattern", "contact_pattern", "mesh_series", "hunting_series", "order_series",
           "scene_coefficients"]

#: Chebyshev degree of the pair-compliance interpolant over the path (error < 1e-12).
_CHEB_DEGREE = 40
#: Springs (positions × slots × slices) solved at once.
_CHUNK = 1 << 21


def _check_int(field_name: str, value: object, lo: int, hi: int) -> None:
    if (isinstance(value, bool) or not isinstance(value, numbers.Integral)
            or not lo <= value <= hi):
        raise InputError.of(field_name, value, f"must be an integer >= {lo} and <= {hi}")


@dataclass(frozen=True)
class LtcaCase:
    """Inputs of one LTCA (hashable: the pipeline caches results by it).

    Attributes
    ----------
    pair : GearPair
        Macro-geometry; refused when it interferes or ε_γ < 1 (:meth:`GearPair.check_mesh`).
    torque : float
        Torque on the driving gear 1 (N·m), > 0; F_s = T / r_b1 along the transverse line
        of action.
    bore_radii : (float, float)
        r_int of gear 1 and gear 2 (m): where each body is held (T.25).
    flanks : (Flank, Flank)
        Micro-geometry of gear 1 and gear 2 (:class:`gears.flank.Flank`).
    materials : (Material, Material)
        Elastic bodies (steel by default).
    n_positions : int
        Positions per mesh period (8 … 100000).
    n_slices : int
        Slices across the face width when anything varies along it (helix, crowning,
        lead slope); a spur pair with uniform flanks uses one (1 … 10000).
    plane_strain : bool
        E/(1 − ν²) in the tooth terms (wide teeth).
    """

    pair: GearPair
    torque: float
    bore_radii: tuple[float, float]
    flanks: tuple[Flank, Flank] = (Flank(), Flank())
    materials: tuple[Material, Material] = (STEEL, STEEL)
    n_positions: int = 64
    n_slices: int = 200
    plane_strain: bool = True

    def __post_init__(self) -> None:
        if not isinstance(self.pair, GearPair):
            raise InputError.of("pair", type(self.pair).__name__, "must be a GearPair")
        check_range("torque", self.torque, lo=0.0, lo_open=True, unit="N·m")
        for name in ("bore_radii", "flanks", "materials"):
            value = tuple(getattr(self, name))
            if len(value) != 2:
                raise InputError.of(name, value, "must be (gear 1, gear 2)")
            object.__setattr__(self, name, value)
        for i, (r, rf) in enumerate(zip(self.bore_radii, self.pair.root_radii, strict=True),
                                    start=1):
            check_range(f"bore_radii[{i}]", r, lo=0.0, hi=rf, lo_open=True, hi_open=True,
                        unit="m")
        _check_int("n_positions", self.n_positions, 8, 100000)
        _check_int("n_slices", self.n_slices, 1, 10000)
        self.pair.check_mesh()
        for i, flank in enumerate(self.flanks, start=1):
            if not isinstance(flank, Flank):
                raise InputError.of(f"flanks[{i}]", type(flank).__name__, "must be a Flank")
            check_flank(flank, self.pair, i)
        for i, mat in enumerate(self.materials, start=1):
            if not isinstance(mat, Material):
                raise InputError.of(f"materials[{i}]", type(mat).__name__,
                                    "must be a Material")

    @property
    def load(self) -> float:
        """F_s = T / r_b1 (N), along the transverse line of action."""
        return self.torque / self.pair.base_radii[0]

    @property
    def periods(self) -> int:
        """Mesh periods solved: 1, or the hunting period of the gears with pitch
        deviations (lcm of their tooth numbers), after which the same teeth meet again."""
        teeth = [z for z, f in zip(self.pair.teeth, self.flanks, strict=True)
                 if f.pitch_deviations]
        return math.lcm(*teeth) if teeth else 1

    @property
    def slices(self) -> int:
        """Slices used: 1 for a spur pair whose flanks do not vary along the face."""
        uniform = self.pair.helix_angle == 0.0 and all(f.uniform_along_face
                                                       for f in self.flanks)
        return 1 if uniform else self.n_slices


@dataclass(frozen=True)
class LtcaResult:
    """Loaded tooth contact over ``periods`` mesh periods, ``n_positions`` each.

    Attributes
    ----------
    case : LtcaCase
    t : ndarray (N,)
        Time in mesh periods, [0, periods) (origin: :mod:`gears.ltca`).
    ste : ndarray (N,)
        Loaded static transmission error q_s (m): the approach of the flanks along the
        transverse line of action.
    stiffness : ndarray (N,)
        Tangent mesh stiffness k_m = dF/dq_s (N/m) at the load.
    no_load_te : ndarray (N,)
        Kinematic (unloaded) transmission error (m): the approach at first touch.
    slots : ndarray (p,)
        Index j of each tooth-pair slot (pair j meets at s_A + (τ + j) p_bt, mid-face).
    slot_s : ndarray (N, p)
        Mid-face line-of-action position of each slot (m), in or out of the path.
    pair_load : ndarray (N, p)
        Load carried by each tooth pair (N): the load sharing.
    line_load : ndarray (N, p, n_s)
        Load per unit face width of each slice (N/m), 0 out of the path or of contact.
    z : ndarray (n_s,)
        Axial position of the slices (m), mid-face 0.
    teeth : ndarray (N, p, 2)
        Tooth index of gear 1 and gear 2 in each slot (they meet in mesh cycle c at
        slot j as teeth (c − j) mod z_1 and (c − j) mod z_2: a tooth pair moves up one
        slot per cycle, so it keeps its number from the root to the tip (L.3)).
    """

    case: LtcaCase
    t: np.ndarray
    ste: np.ndarray
    stiffness: np.ndarray
    no_load_te: np.ndarray
    slots: np.ndarray
    slot_s: np.ndarray
    pair_load: np.ndarray
    line_load: np.ndarray
    z: np.ndarray
    teeth: np.ndarray = field(repr=False)

    @property
    def load(self) -> float:
        """F_s (N)."""
        return self.case.load

    @property
    def periods(self) -> int:
        """Mesh periods covered."""
        return self.case.periods

    def mesh_cycle(self, values: np.ndarray) -> np.ndarray:
        """The synchronous average of ``values`` (N,) over the mesh period (n_positions,):
        its Fourier series holds exactly the mesh orders of ``values``."""
        return np.asarray(values).reshape(self.periods, self.case.n_positions).mean(axis=0)

    def slice_positions(self) -> np.ndarray:
        """Line-of-action position of every slice (N, p, n_s) (m)."""
        pair = self.case.pair
        tan_bb = pair.hand * math.tan(pair.base_helix_angle)
        return self.slot_s[:, :, None] + tan_bb * self.z[None, None, :]


class _Mesh:
    """The torque-independent part of an LTCA: slice stiffnesses and separations."""

    def __init__(self, case: LtcaCase) -> None:
        pair = case.pair
        self.case = case
        s_a, s_e = pair.path
        pb, eps_a, eps_b = pair.base_pitch, pair.transverse_contact_ratio, pair.overlap_ratio
        line = pair.line_of_action_length
        tan_bb = pair.hand * math.tan(pair.base_helix_angle)
        n_s = case.slices
        b = pair.face_width
        self.z = ((np.arange(n_s) + 0.5) / n_s - 0.5) * b
        half = 0.5 * eps_b if n_s > 1 else 0.0
        self.slots = np.arange(-math.ceil(half) - 1, math.ceil(eps_a + half) + 1)
        n_pos, periods = case.n_positions, case.periods
        frac = np.arange(n_pos) / n_pos
        self.t = (np.arange(periods)[:, None] + frac[None, :]).ravel()
        u = self.t + 0.5 * (eps_a - math.floor(eps_a))   # t = 0: middle of the extra zone
        cycle = np.floor(u).astype(np.int64)
        tau = u - cycle
        self.slot_s = s_a + (tau[:, None] + self.slots[None, :]) * pb          # (N, p)
        s = self.slot_s[:, :, None] + tan_bb * self.z[None, None, :]            # (N, p, n_s)
        tol = 1e-12 * pb
        inside = (s >= s_a - tol) & (s <= s_e + tol)
        keep = inside.any(axis=(0, 2))            # drop slots that never touch
        self.slots, self.slot_s = self.slots[keep], self.slot_s[:, keep]
        s, inside = s[:, keep], inside[:, keep]
        self.inside = inside
        compliance = np.polynomial.chebyshev.Chebyshev.interpolate(
            lambda x: pair_compliance(pair, x, case.bore_radii, case.materials,
                                      plane_strain=case.plane_strain),
            _CHEB_DEGREE, domain=[s_a - tol, s_e + tol])
        s_in = np.clip(s, s_a, s_e)
        self.k = np.where(inside, (b / n_s) / compliance(s_in), 0.0)           # N/m
        tooth = (cycle[:, None] - self.slots[None, :])   # (L.3): c − j is one tooth pair
        self.teeth = np.stack([tooth % pair.teeth[0], tooth % pair.teeth[1]], axis=-1)
        f1, f2 = case.flanks
        gap = -(flank_deviation(f1, pair, 1, s_in, self.z)
                + flank_deviation(f2, pair, 2, line - s_in, self.z))
        e1, e2 = pitch_positions(f1, pair, 1), pitch_positions(f2, pair, 2)
        gap -= (e1[self.teeth[..., 0]] + e2[self.teeth[..., 1]])[:, :, None]
        self.gap = np.where(inside, gap, np.inf)
        if not np.all(inside.any(axis=(1, 2))):
            raise RuntimeError("tooth contact: no slice in the path at some position")

    def no_load_te(self) -> np.ndarray:
        """Approach at first touch: the smallest separation in the path (N,)."""
        return self.gap.reshape(self.gap.shape[0], -1).min(axis=1)

    def solve(self, load: float) -> tuple[np.ndarray, np.ndarray]:
        """Approach δ and tangent stiffness at ``load`` (N) for every position (T.28):
        Σ k_i max(0, δ − g_i) = F_s, exact (sort the separations, accumulate)."""
        n = self.gap.shape[0]
        g_all = self.gap.reshape(n, -1)
        k_all = self.k.reshape(n, -1)
        delta, k_m = np.empty(n), np.empty(n)
        step = max(1, _CHUNK // g_all.shape[1])
        for lo in range(0, n, step):
            g, k = g_all[lo:lo + step], k_all[lo:lo + step]
            order = np.argsort(g, axis=1, kind="stable")
            g_s = np.take_along_axis(g, order, axis=1)
            k_s = np.take_along_axis(k, order, axis=1)
            k_cum = np.cumsum(k_s, axis=1)
            kg_cum = np.cumsum(np.where(k_s > 0, k_s * np.where(np.isfinite(g_s), g_s, 0.0),
                                        0.0), axis=1)
            g_next = np.concatenate([g_s[:, 1:], np.full((g.shape[0], 1), np.inf)], axis=1)
            with np.errstate(invalid="ignore"):
                f_next = np.where(np.isfinite(g_next), k_cum * g_next - kg_cum, np.inf)
            m = np.argmax(f_next >= load, axis=1)        # last engaged spring
            rows = np.arange(g.shape[0])
            k_m[lo:lo + step] = k_cum[rows, m]
            delta[lo:lo + step] = (load + kg_cum[rows, m]) / k_cum[rows, m]
        if not np.all(np.isfinite(delta)) or not np.all(k_m > 0):
            raise RuntimeError("tooth contact: no pair in contact at some position")
        return delta, k_m


def _result(mesh: _Mesh, delta: np.ndarray, k_m: np.ndarray) -> LtcaResult:
    case = mesh.case
    b, n_s = case.pair.face_width, mesh.z.size
    with np.errstate(invalid="ignore"):
        slice_load = np.where(mesh.inside,
                              mesh.k * np.maximum(delta[:, None, None] - mesh.gap, 0.0), 0.0)
    return LtcaResult(case=case, t=mesh.t, ste=delta, stiffness=k_m,
                      no_load_te=mesh.no_load_te(), slots=mesh.slots, slot_s=mesh.slot_s,
                      pair_load=slice_load.sum(axis=2), line_load=slice_load * (n_s / b),
                      z=mesh.z, teeth=mesh.teeth)


def solve_ltca(case: LtcaCase) -> LtcaResult:
    """The LTCA of ``case``: over one mesh period, or the hunting period with pitch
    deviations (T.27–T.28).

    At each position, slot j's slice i sits at s_ij = s_A + (τ + j) p_bt + η z_i tan β_b
    (in the path [s_A, s_E]), a spring k_ij = (b/n_s) / c_pair(s_ij) behind an initial
    separation g_ij = −(d_1 + d_2) − (e_1 + e_2) (M.1–M.5). The approach δ solves
    Σ k_ij max(0, δ − g_ij) = F_s; q_s = δ and k_m = Σ_{δ > g_ij} k_ij.
    """
    mesh = _Mesh(case)
    delta, k_m = mesh.solve(case.load)
    return _result(mesh, delta, k_m)


@dataclass(frozen=True)
class HarrisMap:
    """Peak-to-peak loaded STE against torque (a Harris map, Harris 1958).

    Attributes
    ----------
    torque, load : ndarray (n,)
        T (N·m) and F_s (N).
    ste_peak_to_peak, ste_mean : ndarray (n,)
        Peak-to-peak and mean of q_s over the periods solved (m).
    stiffness_mean, stiffness_peak_to_peak : ndarray (n,)
        Of the tangent k_m (N/m).
    """

    torque: np.ndarray
    load: np.ndarray
    ste_peak_to_peak: np.ndarray
    ste_mean: np.ndarray
    stiffness_mean: np.ndarray
    stiffness_peak_to_peak: np.ndarray

    @property
    def best_torque(self) -> float:
        """The torque of the smallest STE fluctuation among those solved (N·m)."""
        return float(self.torque[int(np.argmin(self.ste_peak_to_peak))])


def harris_map(case: LtcaCase, torques: np.ndarray) -> HarrisMap:
    """Solve ``case`` at each of ``torques`` (N·m, > 0); the slice stiffnesses and
    separations are built once (``case.torque`` is not used)."""
    torques = np.asarray(torques, dtype=float).ravel()
    if torques.size == 0 or not np.all(np.isfinite(torques) & (torques > 0)):
        raise InputError.of("torques", torques.tolist(), "must be finite and > 0 (N·m)")
    mesh = _Mesh(case)
    rb1 = case.pair.base_radii[0]
    out = np.empty((4, torques.size))
    for i, torque in enumerate(torques):
        delta, k_m = mesh.solve(torque / rb1)
        out[:, i] = (np.ptp(delta), delta.mean(), k_m.mean(), np.ptp(k_m))
    return HarrisMap(torque=torques, load=torques / rb1, ste_peak_to_peak=out[0],
                     ste_mean=out[1], stiffness_mean=out[2], stiffness_peak_to_peak=out[3])


@dataclass(frozen=True)
class ContactPattern:
    """Largest load per unit face width met on one gear's flank over the periods solved:
    the contact pattern (a marking-compound picture).

    Attributes
    ----------
    gear : int
    diameter : ndarray (n_profile,)
        Centres of the profile bins (m), start of active profile to tip.
    z : ndarray (n_s,)
        Axial positions (m).
    line_load : ndarray (n_profile, n_s)
        N/m; 0 where the flank never carries load.
    """

    gear: int
    diameter: np.ndarray
    z: np.ndarray
    line_load: np.ndarray


def contact_pattern(result: LtcaResult, gear: int = 1, n_profile: int = 40
                    ) -> ContactPattern:
    """The contact pattern on gear ``gear``'s flank: every slice's load binned by the
    roll length where it touches that gear (:class:`ContactPattern`)."""
    if gear not in (1, 2):
        raise InputError.of("gear", gear, "must be 1 or 2")
    _check_int("n_profile", n_profile, 2, 10000)
    pair = result.case.pair
    s = result.slice_positions()
    roll = s if gear == 1 else pair.line_of_action_length - s
    lo, hi = pair.active_roll_lengths[gear - 1]
    idx = np.clip(((roll - lo) / (hi - lo) * n_profile).astype(np.int64), 0, n_profile - 1)
    pattern = np.zeros((n_profile, result.z.size))
    loaded = result.line_load > 0
    zi = np.broadcast_to(np.arange(result.z.size), s.shape)
    np.maximum.at(pattern, (idx[loaded], zi[loaded]), result.line_load[loaded])
    centres = lo + (np.arange(n_profile) + 0.5) / n_profile * (hi - lo)
    rb = pair.base_radii[gear - 1]
    return ContactPattern(gear=gear, diameter=2.0 * np.hypot(rb, centres), z=result.z,
                          line_load=pattern)


def mesh_series(result: LtcaResult, n_harmonics: int) -> tuple[Series, Series]:
    """(k_m, q_s) as Fourier series over the mesh period, n harmonics each (T.31), from
    the synchronous averages (exactly the mesh orders of the hunting-period signals).

    Returns
    -------
    (stiffness, ste) : Series, Series
        (mean, amplitudes, phases) in N/m, m and rad, the scene's convention.
    """
    _check_int("n_harmonics", n_harmonics, 1, 100000)
    out = []
    for values in (result.stiffness, result.ste):
        mean, amps, phases = fourier_harmonics(result.mesh_cycle(values), n_harmonics)
        out.append((mean, tuple(float(a) for a in amps), tuple(float(p) for p in phases)))
    return out[0], out[1]


def hunting_series(result: LtcaResult, n_harmonics: int) -> tuple[Series, Series, int]:
    """(k_m, q_s, c) as Fourier series over the ``c = periods`` mesh periods solved (the
    hunting period with pitch deviations), up to mesh harmonic ``n_harmonics``: the
    harmonics q = 1 … n c of the base frequency (mesh frequency / c), i.e. the mesh
    harmonics and their shaft-order sidebands (T.31 over the whole signal)::

        x(t) = x̄ + Σ_q a_q cos(2π q t / c + φ_q),   t in mesh periods

    With ``c = 1`` (no pitch deviation) the mesh-period series of :func:`mesh_series`.
    """
    _check_int("n_harmonics", n_harmonics, 1, 100000)
    c = result.periods
    if c == 1:
        ms, ste = mesh_series(result, n_harmonics)
        return ms, ste, 1
    out = []
    for values in (result.stiffness, result.ste):
        mean, amps, phases = fourier_harmonics(values, n_harmonics * c)
        out.append((mean, tuple(float(a) for a in amps), tuple(float(p) for p in phases)))
    return out[0], out[1], c


def order_series(result: LtcaResult, gear: int, n_orders: int, quantity: str = "ste"
                 ) -> Series:
    """Shaft orders 1 … n of gear ``gear`` in q_s (``quantity = "ste"``) or k_m
    (``"stiffness"``) over the hunting period::

        x(t) = x̄ + Σ_q a_q cos(2π q t / z_i + φ_q),   t in mesh periods

    Refused when the result does not span whole revolutions of that gear (no pitch
    deviation on it, so no shaft-order content was computed)."""
    if gear not in (1, 2):
        raise InputError.of("gear", gear, "must be 1 or 2")
    if quantity not in ("ste", "stiffness"):
        raise InputError.of("quantity", quantity, "must be 'ste' or 'stiffness'")
    z, periods = result.case.pair.teeth[gear - 1], result.periods
    if periods % z:
        raise InputError.of("gear", gear, f"has no shaft-order content here: the result "
                            f"spans {periods} mesh period(s), not whole turns of its {z} "
                            "teeth (give it pitch deviations)")
    values = getattr(result, quantity)
    turns = periods // z
    _check_int("n_orders", n_orders, 1, (values.size // turns) // 2 - 1)
    c = np.fft.rfft(values) / values.size
    bins = turns * np.arange(1, n_orders + 1)
    return (float(c[0].real), tuple(float(2.0 * abs(c[b])) for b in bins),
            tuple(float(np.angle(c[b])) for b in bins))


def scene_coefficients(result: LtcaResult, n_harmonics: int = 3) -> dict[str, dict]:
    """The ``[mesh_stiffness]`` and ``[transmission_error]`` tables of a scene file
    (N/µm, µm, degrees in [0, 360)), ``kind = "loaded"``, from :func:`mesh_series`."""
    (km0, kma, kmp), (te0, tea, tep) = mesh_series(result, n_harmonics)

    def deg(p: tuple[float, ...]) -> list[float]:
        return [float(round(math.degrees(x) % 360.0, 2) % 360.0) for x in p]

    return {
        "mesh_stiffness": {"mean_N_per_um": round(km0 * 1e-6, 3),
                           "amplitudes_N_per_um": [round(a * 1e-6, 3) for a in kma],
                           "phases_deg": deg(kmp)},
        "transmission_error": {"kind": "loaded", "mean_um": round(te0 * 1e6, 4),
                               "amplitudes_um": [round(a * 1e6, 4) for a in tea],
                               "phases_deg": deg(tep)},
    }
