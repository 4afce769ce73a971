"""Geometry of an external involute gear pair, its frame and its line-of-action vector.

:class:`GearPair` holds the macro-geometry of two external involute gears (teeth, normal
module, normal pressure angle, helix angle and hand, profile shifts, face width,
addendum/dedendum factors or tip/root radii) and derives what the dynamics and the tooth
contact need: pitch, base, tip and root radii, the working pressure angle and centre
distance, the path of contact on the line of action and the transverse, overlap and
total contact ratios (ISO 21771 notation; docs/gears.md, equations G.1-G.8), the
involute form radii of the generating rack (G.9) and :meth:`GearPair.check_mesh`, which
refuses interference and a total contact ratio below 1.

:func:`pair_frame` is the gear-pair frame of the paper's Fig. 1 (docs/theory.md, T.1)
and :func:`line_of_action_vector` the restriction of the projection vector G to the
gear DOF, the paper's eq. (11), with the helix hand and the sense of rotation as
parameters. Pure NumPy, SI units (m, rad).
"""
from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

import numpy as np

from core.errors import InputError, check_range

__all__ = ["GearPair", "involute", "inverse_involute", "contact_path_length", "pair_frame",
           "line_of_action_vector"]


def involute(a: np.ndarray | float) -> np.ndarray | float:
    """Involute function inv α = tan α − α (G.1)."""
    return np.tan(a) - a


def inverse_involute(value: float) -> float:
    """The angle α in [0, π/2) with inv α = ``value`` (≥ 0), by Newton's method.

    Starts from Cheng's approximation α ≈ (3 inv)^(1/3) and converges to a few ulp
    (inv' α = tan² α).
    """
    check_range("inv", value, lo=0.0, hi=10.0)
    if value == 0.0:
        return 0.0
    a = min((3.0 * value) ** (1.0 / 3.0), 1.5)
    for _ in range(60):
        step = (math.tan(a) - a - value) / math.tan(a) ** 2
        a -= step
        if abs(step) <= 4e-16 * a:
            break
    return a


def contact_path_length(tip_radii: tuple[float, float], base_radii: tuple[float, float],
                        centre_distance: float, working_pressure_angle: float) -> float:
    """Length of the path of contact (m) (G.5)::

        g_α = √(r_a1² − r_b1²) + √(r_a2² − r_b2²) − a_w sin α_wt

    Parameters
    ----------
    tip_radii, base_radii : (gear 1, gear 2)
        r_a and r_b (m).
    centre_distance : float
        a_w (m).
    working_pressure_angle : float
        α_wt (rad).
    """
    (ra1, ra2), (rb1, rb2) = tip_radii, base_radii
    return (math.sqrt(ra1**2 - rb1**2) + math.sqrt(ra2**2 - rb2**2)
            - centre_distance * math.sin(working_pressure_angle))


def _check_sign(field: str, value: int) -> None:
    if value not in (1, -1):
        raise InputError.of(field, value, "must be 1 or -1")


def pair_frame(alpha: float, *, sense: int = 1) -> np.ndarray:
    """Rotation R = [e_x' e_y' e_z'] (columns) of the gear-pair frame of Fig. 1 (T.1).

    Gear 1 is centred on the z axis, gear 2 on the positive x axis; the gear node DOF
    are expressed in this frame (global components = R @ local components).

    Parameters
    ----------
    alpha : float
        Transverse (working) pressure angle (rad), in [0, π/2).
    sense : {1, -1}
        Sense of rotation of the driving gear 1 about +z: 1 (counter-clockwise seen
        from +z, the paper's and the pump's) puts the line of action through the base
        tangent point T_1 = r_b1 (cos α, sin α, 0); -1 uses the other tangent,
        T_1 = r_b1 (cos α, −sin α, 0).

    Returns
    -------
    numpy.ndarray, shape (3, 3)
        ``sense = 1``: e_x' = (cos α, sin α, 0), e_y' = n = (−sin α, cos α, 0) (the line
        of action), e_z' = e_z. ``sense = -1``: e_x' = (−cos α, sin α, 0),
        e_y' = n = (−sin α, −cos α, 0), e_z' = e_z — the first frame turned by π about
        the global x axis, then by π about its own y' axis, so that e_z' stays the shaft
        axis. In both, n points from gear 1's active flank into gear 2's.
    """
    check_range("alpha", alpha, lo=0.0, hi=0.5 * math.pi, hi_open=True, unit="rad")
    _check_sign("sense", sense)
    c, s = math.cos(alpha), math.sin(alpha)
    return np.array([[sense * c, -s, 0.0], [s, sense * c, 0.0], [0.0, 0.0, 1.0]])


def line_of_action_vector(alpha: float, beta: float, rb1: float, rb2: float, *,
                          hand: int = 1, sense: int = 1) -> np.ndarray:
    """Restriction of G to q_c = (u1..u3, θ1..θ3, u4..u6, θ4..θ6), the paper's eq. (11)
    with the sign of its θ_x' entries corrected (docs/theory.md §1).

    Δ = Gᵀ q_c (m) is the approach of the two active flanks along the line of action,
    the gear DOF expressed in the frame :func:`pair_frame` (same ``sense``): the motion of
    the pitch point as a point of each gear, projected on the flank normal
    ``n + tan β e_z'``. Every rigid motion of the pair gives Δ = 0. Eq. (11) as printed
    has ``+r_b tan α tan β`` on θ_x' (θ1 and θ4), which puts the two gears' contact points
    at different places along the line of action: a rigid rotation of the whole pair
    about x' would load the teeth. The entries differ only for helical pairs.

    Parameters
    ----------
    alpha, beta : float
        Pressure and helix angles (rad); α in [0, π/2), β in (−π/2, π/2).
    rb1, rb2 : float
        Base radii of gear 1 and gear 2 (m), > 0.
    hand : {1, -1}
        Sign applied to tan β: 1 is the hand of eq. (11). In the frame of (T.1) a flank
        normal with a +tan β axial part belongs to a left-hand gear 1 (right-hand
        gear 2); -1 gives the other hand. No effect when β = 0.
    sense : {1, -1}
        Sense of rotation of the driving gear 1 (:func:`pair_frame`). With -1 the
        entries on u3, θ1, θ3 and u6, θ4, θ6 change sign: eq. (11) written in the frame
        turned by π about y'.

    Returns
    -------
    numpy.ndarray, shape (12,)
        ``sense = hand = 1``:
        (0, 1, tan β, −r_b1 tan α tan β, −r_b1 tan β, r_b1,
        0, −1, −tan β, −r_b2 tan α tan β, −r_b2 tan β, r_b2).
    """
    check_range("alpha", alpha, lo=0.0, hi=0.5 * math.pi, hi_open=True, unit="rad")
    check_range("beta", beta, lo=-0.5 * math.pi, hi=0.5 * math.pi, lo_open=True,
                hi_open=True, unit="rad")
    check_range("rb1", rb1, lo=0.0, lo_open=True, unit="m")
    check_range("rb2", rb2, lo=0.0, lo_open=True, unit="m")
    _check_sign("hand", hand)
    _check_sign("sense", sense)
    ta, tb = math.tan(alpha), hand * math.tan(beta)
    return np.array(  # eq. (11), θ_x' corrected; sense = ±1 and hand = ±1 multiply exactly
        [0.0, 1.0, sense * tb, -sense * rb1 * ta * tb, -rb1 * tb, sense * rb1,
         0.0, -1.0, -sense * tb, -sense * rb2 * ta * tb, -rb2 * tb, sense * rb2]
    )  # fmt: skip


@dataclass(frozen=True)
class GearPair:
    """An external involute gear pair (ISO 21771 notation), SI units.

    Attributes
    ----------
    teeth : tuple of int
        (z_1, z_2), gear 1 the driving gear.
    module : float
        Normal module m_n (m).
    pressure_angle : float
        Normal pressure angle α_n (rad).
    face_width : float
        Common face width b (m).
    helix_angle : float
        Helix angle β at the reference cylinder (rad), in [0, π/2); 0 for spur gears.
    hand : {1, -1}
        Helix hand as the sign of tan β in eq. (11) (:func:`line_of_action_vector`).
    profile_shift : tuple of float
        Profile shift coefficients (x_1, x_2).
    addendum_coef, dedendum_coef : float
        h_a and h_f of the basic rack in modules (1 and 1.25 for ISO 53 profile A).
    tip_diameters, root_diameters : tuple of float, optional
        (d_a1, d_a2) and (d_f1, d_f2) (m) as drawn or measured; otherwise from the
        rack (:attr:`tip_radii`, :attr:`root_radii`).
    root_radius_coef : float
        ρ_fP / m_n, the tip radius of the generating tool (the root fillet radius of
        the basic rack; 0.38 for ISO 53 profile A): sets where the involute ends
        (:attr:`form_radii`).

    Notes
    -----
    The pair runs at the working centre distance of its profile shifts (no backlash,
    G.4); the tips are not shortened (r_a as given or from the rack).
    """

    teeth: tuple[int, int]
    module: float
    pressure_angle: float
    face_width: float
    helix_angle: float = 0.0
    hand: int = 1
    profile_shift: tuple[float, float] = (0.0, 0.0)
    addendum_coef: float = 1.0
    dedendum_coef: float = 1.25
    tip_diameters: tuple[float, float] | None = None
    root_diameters: tuple[float, float] | None = None
    root_radius_coef: float = 0.38

    def __post_init__(self) -> None:
        if len(self.teeth) != 2:
            raise InputError.of("teeth", self.teeth, "must be (z_1, z_2)")
        for i, z in enumerate(self.teeth, start=1):
            if (isinstance(z, bool) or not isinstance(z, numbers.Integral)
                    or not 5 <= z <= 1000):
                raise InputError.of(f"teeth[{i}]", z, "must be an integer >= 5 and <= 1000")
        check_range("module", self.module, lo=0.0, lo_open=True, unit="m")
        check_range("pressure_angle", self.pressure_angle, lo=0.0, hi=0.5 * math.pi,
                    lo_open=True, hi_open=True, unit="rad")
        check_range("face_width", self.face_width, lo=0.0, lo_open=True, unit="m")
        check_range("helix_angle", self.helix_angle, lo=0.0, hi=0.5 * math.pi,
                    hi_open=True, unit="rad")
        _check_sign("hand", self.hand)
        for i, x in enumerate(self.profile_shift, start=1):
            check_range(f"profile_shift[{i}]", x, lo=-2.0, hi=2.0)
        check_range("addendum_coef", self.addendum_coef, lo=0.0, lo_open=True)
        check_range("dedendum_coef", self.dedendum_coef, lo=0.0, lo_open=True)
        check_range("root_radius_coef", self.root_radius_coef, lo=0.0,
                    hi=self.dedendum_coef)
        for name in ("tip_diameters", "root_diameters"):
            values = getattr(self, name)
            if values is not None:
                if len(values) != 2:
                    raise InputError.of(name, values, "must be two diameters (gear 1, 2)")
                for i, d in enumerate(values, start=1):
                    check_range(f"{name}[{i}]", d, lo=0.0, lo_open=True, unit="m")
        for i, (ra, rb, rf) in enumerate(zip(self.tip_radii, self.base_radii,
                                             self.root_radii, strict=True), start=1):
            if ra <= rb:
                raise InputError.of(f"tip radius of gear {i}", ra, f"must be > its base "
                                    f"radius {rb:.6g} m (no involute flank)", unit="m")
            if not 0.0 < rf < ra:
                raise InputError.of(f"root radius of gear {i}", rf, f"must be > 0 and < its "
                                    f"tip radius {ra:.6g} m", unit="m")

    # ---------------------------------------------------------------- transverse section

    @property
    def transverse_pressure_angle(self) -> float:
        """α_t = atan(tan α_n / cos β) (rad) (G.2); α_n itself for spur gears."""
        if self.helix_angle == 0.0:
            return self.pressure_angle
        return math.atan(math.tan(self.pressure_angle) / math.cos(self.helix_angle))

    @property
    def transverse_module(self) -> float:
        """m_t = m_n / cos β (m) (G.2)."""
        return self.module / math.cos(self.helix_angle)

    @property
    def base_helix_angle(self) -> float:
        """β_b = atan(tan β cos α_t) (rad)."""
        return math.atan(math.tan(self.helix_angle) * math.cos(self.transverse_pressure_angle))

    @property
    def virtual_teeth(self) -> tuple[float, float]:
        """Virtual numbers of teeth z_ni = z_i / (cos²β_b cos β) (ISO 21771)."""
        c = math.cos(self.base_helix_angle) ** 2 * math.cos(self.helix_angle)
        return self.teeth[0] / c, self.teeth[1] / c

    @property
    def pitch_radii(self) -> tuple[float, float]:
        """Reference radii r_i = ½ m_t z_i (m) (G.3)."""
        m = self.transverse_module
        return 0.5 * m * self.teeth[0], 0.5 * m * self.teeth[1]

    @property
    def base_radii(self) -> tuple[float, float]:
        """Base radii r_bi = r_i cos α_t (m) (G.3)."""
        c = math.cos(self.transverse_pressure_angle)
        r1, r2 = self.pitch_radii
        return r1 * c, r2 * c

    @property
    def tip_radii(self) -> tuple[float, float]:
        """Tip radii r_ai (m): ½ d_ai as given, or r_i + (h_a + x_i) m_n (G.3)."""
        if self.tip_diameters is not None:
            return 0.5 * self.tip_diameters[0], 0.5 * self.tip_diameters[1]
        return tuple(r + (self.addendum_coef + x) * self.module
                     for r, x in zip(self.pitch_radii, self.profile_shift, strict=True))

    @property
    def root_radii(self) -> tuple[float, float]:
        """Root radii r_fi (m): ½ d_fi as given, or r_i − (h_f − x_i) m_n (G.3)."""
        if self.root_diameters is not None:
            return 0.5 * self.root_diameters[0], 0.5 * self.root_diameters[1]
        return tuple(r - (self.dedendum_coef - x) * self.module
                     for r, x in zip(self.pitch_radii, self.profile_shift, strict=True))

    @property
    def form_radii(self) -> tuple[float, float]:
        """Involute form radii r_Ffi (m): where the generating rack's straight flank ends
        on each gear (ISO 21771), below them the root fillet (G.9)::

            L_Ff = r sin α_t − (h_fP − x m_n − ρ_fP (1 − sin α_n)) / sin α_t,
            r_Ff = √(r_b² + L_Ff²)

        L_Ff is the roll length of the form circle (:meth:`roll_length`); L_Ff < 0 is
        an undercut tooth, whose involute starts at the base circle (r_Ff = r_b)."""
        return tuple(math.hypot(rb, max(length, 0.0)) for rb, length in
                     zip(self.base_radii, self.form_roll_lengths, strict=True))

    @property
    def form_roll_lengths(self) -> tuple[float, float]:
        """L_Ffi (m), the roll lengths of the form circles (G.9); negative when the rack
        undercuts the tooth."""
        a_n, a_t = self.pressure_angle, self.transverse_pressure_angle
        h = (self.dedendum_coef - self.root_radius_coef * (1.0 - math.sin(a_n))) * self.module
        return tuple(r * math.sin(a_t) - (h - x * self.module) / math.sin(a_t)
                     for r, x in zip(self.pitch_radii, self.profile_shift, strict=True))

    @staticmethod
    def roll_length(base_radius: float, radius: float) -> float:
        """Roll length L = √(r² − r_b²) (m) of the involute point at ``radius``: its
        distance from the base tangent point along the line of action."""
        return math.sqrt(max(radius * radius - base_radius * base_radius, 0.0))

    @property
    def base_pitch(self) -> float:
        """Transverse base pitch p_bt = π m_t cos α_t (m)."""
        return math.pi * self.transverse_module * math.cos(self.transverse_pressure_angle)

    # ---------------------------------------------------------------- the pair in mesh

    @property
    def working_pressure_angle(self) -> float:
        """α_wt from inv α_wt = inv α_t + 2 tan α_n (x_1 + x_2)/(z_1 + z_2) (G.4);
        α_t itself when x_1 + x_2 = 0."""
        shift = self.profile_shift[0] + self.profile_shift[1]
        if shift == 0.0:
            return self.transverse_pressure_angle
        inv = (involute(self.transverse_pressure_angle)
               + 2.0 * math.tan(self.pressure_angle) * shift / (self.teeth[0] + self.teeth[1]))
        return inverse_involute(float(inv))

    @property
    def centre_distance(self) -> float:
        """Working centre distance a_w = (r_1 + r_2) cos α_t / cos α_wt (m) (G.4)."""
        r1, r2 = self.pitch_radii
        a_t, a_w = self.transverse_pressure_angle, self.working_pressure_angle
        if a_w == a_t:
            return r1 + r2
        return (r1 + r2) * math.cos(a_t) / math.cos(a_w)

    @property
    def line_of_action_length(self) -> float:
        """T_1T_2 = a_w sin α_wt (m): the line of action between the base tangent points."""
        return self.centre_distance * math.sin(self.working_pressure_angle)

    @property
    def path(self) -> tuple[float, float]:
        """(s_A, s_E): start and end of contact on the line of action, measured from gear
        1's base tangent point T_1 (m) (G.5, T.20): s_A = T_1T_2 − √(r_a2² − r_b2²) where
        gear 2's tip meets gear 1's flank, s_E = √(r_a1² − r_b1²) at gear 1's tip.
        s_A < 0 means gear 2's tip reaches below gear 1's base circle (interference)."""
        (ra1, ra2), (rb1, rb2) = self.tip_radii, self.base_radii
        return (self.line_of_action_length - math.sqrt(ra2**2 - rb2**2),
                math.sqrt(ra1**2 - rb1**2))

    @property
    def path_length(self) -> float:
        """g_α = s_E − s_A (m), the length of the path of contact (G.5,
        :func:`contact_path_length`)."""
        return contact_path_length(self.tip_radii, self.base_radii, self.centre_distance,
                                   self.working_pressure_angle)

    @property
    def transverse_contact_ratio(self) -> float:
        """ε_α = g_α / p_bt (G.6)."""
        return self.path_length / self.base_pitch

    @property
    def overlap_ratio(self) -> float:
        """ε_β = b sin β / (π m_n) (G.7); 0 for spur gears."""
        return self.face_width * math.sin(self.helix_angle) / (math.pi * self.module)

    @property
    def total_contact_ratio(self) -> float:
        """ε_γ = ε_α + ε_β (G.8)."""
        return self.transverse_contact_ratio + self.overlap_ratio

    @property
    def active_roll_lengths(self) -> tuple[tuple[float, float], tuple[float, float]]:
        """((L_1 start, L_1 end), (L_2 start, L_2 end)) (m): the active profile of each
        gear as roll lengths, from where the mate's tip meets it (start of active
        profile, SAP) to its own tip: gear 1 from s_A to s_E, gear 2 from T_1T_2 − s_E
        to T_1T_2 − s_A."""
        s_a, s_e = self.path
        line = self.line_of_action_length
        return (s_a, s_e), (line - s_e, line - s_a)

    def check_mesh(self) -> None:
        """Refuse a pair that cannot run as an involute mesh (InputError naming which).

        - *Interference*: the mate's tip reaches a gear below its involute form circle
          (SAP roll length < L_Ff, G.9), i.e. into the root fillet or below the base
          circle (undercut or tip interference);
        - *contact ratio below 1*: the total contact ratio ε_γ = ε_α + ε_β (G.8) is
          below 1, so some positions have no pair in contact (for a spur pair ε_γ =
          ε_α; a helical pair with ε_α < 1 runs when the overlap makes up for it).
        """
        for i, ((start, _), l_ff, r_ff) in enumerate(zip(
                self.active_roll_lengths, self.form_roll_lengths, self.form_radii,
                strict=True), start=1):
            other = 3 - i
            if start < max(l_ff, 0.0) - 1e-12 * self.module:
                where = (f"at d = {2e3 * math.hypot(self.base_radii[i - 1], start):.4f} mm"
                         if start >= 0.0 else "below its base circle")
                raise InputError(
                    f"interference: the tip of gear {other} (d_a{other} = "
                    f"{2e3 * self.tip_radii[other - 1]:.4f} mm) meets gear {i} {where} "
                    f"(roll length {start * 1e3:.4f} mm), below its involute form circle "
                    f"d_Ff{i} = {2e3 * r_ff:.4f} mm (roll length {max(l_ff, 0.0) * 1e3:.4f}"
                    f" mm): shorten the tip of gear {other} or shift gear {i} positively",
                    field=f"tip_diameters[{other}]", value=2.0 * self.tip_radii[other - 1],
                    unit="m", allowed=f"a tip meeting gear {i} above d_Ff{i}")
        eps_a, eps_b = self.transverse_contact_ratio, self.overlap_ratio
        if eps_a + eps_b < 1.0:
            which = ("transverse contact ratio ε_α (spur pair: ε_γ = ε_α)" if eps_b == 0.0
                     else f"total contact ratio ε_γ = ε_α + ε_β = {eps_a:.4f} + {eps_b:.4f}")
            raise InputError(f"{which} = {eps_a + eps_b:.4f}: must be >= 1 (no pair in "
                             "contact over part of the mesh period)",
                             field="contact_ratio", value=eps_a + eps_b,
                             allowed=">= 1")

    # ---------------------------------------------------------------- frame and G

    def frame(self, sense: int = 1) -> np.ndarray:
        """The gear-pair frame (:func:`pair_frame`) at the working pressure angle."""
        return pair_frame(self.working_pressure_angle, sense=sense)

    def line_of_action_vector(self, sense: int = 1) -> np.ndarray:
        """G restricted to the 12 gear DOF, eq. (11) (:func:`line_of_action_vector`),
        with the working pressure angle, the helix angle and hand and the base radii."""
        rb1, rb2 = self.base_radii
        return line_of_action_vector(self.working_pressure_angle, self.helix_angle, rb1,
                                     rb2, hand=self.hand, sense=sense)
