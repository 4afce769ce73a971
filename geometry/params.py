"""Parameter dataclasses of the pump geometry and of its mesh (SI units, metres).

Global frame (docs/architecture.md): shaft axes along ``z``; the input shaft
``in`` on the ``z`` axis, the output shaft ``out`` on ``x = a, y = 0``; the
housing's mounting feet on its bottom face (most negative ``y``).

Layout chosen here (docs/geometry.md): the housing's outer box spans
``z ∈ [0, length_z]``, bearing bosses protrude outwards from both end walls,
and both shafts have their coupling end at the ``z < 0`` side, sticking out of
the end wall ``a`` (motor on ``in``, impeller on ``out``).

Every ``validate()`` refuses bad geometry with a ``ValueError`` that names the
field, its value and the allowed range, before any gmsh work.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from dataclasses import dataclass, field

SHAFT_NAMES: tuple[str, str] = ("in", "out")
N_STATIONS = 6

# Table 1 / docs/architecture.md: base radius 46.984 mm, alpha = 20 deg ->
# pitch radius 50 mm, centre distance 100 mm, effective module 100/76 mm.
DEFAULT_CENTRE_DISTANCE = 0.100
DEFAULT_GEAR_TIP_RADIUS = 0.050 + 0.100 / 76.0  # pitch radius + addendum (h_a = 1)
DEFAULT_GEAR_WIDTH = 0.020  # face width b_f (Table 1)


def _is_number(value: object) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def _positive(owner: str, name: str, value: float) -> None:
    if not (_is_number(value) and math.isfinite(value) and value > 0.0):
        raise ValueError(f"{owner}.{name} = {value!r}: must be a finite number > 0")


def _non_negative(owner: str, name: str, value: float) -> None:
    if not (_is_number(value) and math.isfinite(value) and value >= 0.0):
        raise ValueError(f"{owner}.{name} = {value!r}: must be a finite number >= 0")


# --------------------------------------------------------------------------- shaft


@dataclass(frozen=True)
class ShaftParams:
    """Stepped shaft, a solid of revolution along its own ``+z`` axis [m].

    Segments from the coupling end (local ``z = 0``) towards ``+z``:
    coupling, journal ``a``, span ``a`` (body), hub seat, span ``b`` (body),
    journal ``b``, tail. The six force stations are rings of width
    ``station_width`` cut in the lateral surface of the two body spans.

    Attributes
    ----------
    coupling_radius, coupling_length : float
        Coupling end (motor on ``in``, impeller on ``out``) [m].
    journal_radius, journal_length : float
        Both bearing seats (inner ring of the bearing) [m].
    body_radius : float
        Radius of the two spans between the journals and the hub [m].
    span_a, span_b : float
        Axial lengths of the body spans before / after the hub [m].
    hub_radius, hub_length : float
        Gear hub seat [m]; the gear (not meshed) sits on it.
    tail_radius, tail_length : float
        Stub after journal ``b`` [m]; ``tail_length = 0`` ends the shaft at
        journal ``b``.
    station_width : float
        Axial width of each force-station ring [m].
    station_z : tuple of 6 floats or None
        Local ``z`` of the station mid-planes [m]; ``None`` puts three stations
        evenly in each body span.
    rotor_radius : float
        Radius of the rotor sections [m]: the part of each body span farther than
        ``rotor_gap`` from its ends (the pumping rotors that carry the force
        stations, as a solid cylinder). ``0`` (default): no rotor, the body radius
        over the whole span.
    rotor_gap : float
        Axial length at each end of a body span kept at ``body_radius`` [m] (the
        shoulders between the rotor and the journal or hub seat).
    """

    coupling_radius: float = 0.0125
    coupling_length: float = 0.060
    journal_radius: float = 0.0125
    journal_length: float = 0.015
    body_radius: float = 0.016
    span_a: float = 0.0645
    hub_radius: float = 0.016
    hub_length: float = DEFAULT_GEAR_WIDTH
    span_b: float = 0.0645
    tail_radius: float = 0.0125
    tail_length: float = 0.020
    station_width: float = 0.004
    station_z: tuple[float, ...] | None = None
    rotor_radius: float = 0.0
    rotor_gap: float = 0.0

    def __post_init__(self) -> None:
        if self.station_z is not None and not isinstance(self.station_z, tuple):
            object.__setattr__(self, "station_z", tuple(self.station_z))

    # ---- derived local positions (m, from the coupling end) ----
    @property
    def length(self) -> float:
        """Total shaft length [m]."""
        return (self.coupling_length + 2 * self.journal_length + self.span_a
                + self.hub_length + self.span_b + self.tail_length)

    @property
    def journal_a_z(self) -> tuple[float, float]:
        """Local axial range of journal ``a`` [m]."""
        z0 = self.coupling_length
        return (z0, z0 + self.journal_length)

    @property
    def hub_z(self) -> tuple[float, float]:
        """Local axial range of the hub seat [m]."""
        z0 = self.journal_a_z[1] + self.span_a
        return (z0, z0 + self.hub_length)

    @property
    def journal_b_z(self) -> tuple[float, float]:
        """Local axial range of journal ``b`` [m]."""
        z0 = self.hub_z[1] + self.span_b
        return (z0, z0 + self.journal_length)

    @property
    def station_centres(self) -> tuple[float, ...]:
        """Local ``z`` of the six station mid-planes [m]."""
        if self.station_z is not None:
            return tuple(float(z) for z in self.station_z)
        za0, za1 = self.journal_a_z[1], self.hub_z[0]
        zb0, zb1 = self.hub_z[1], self.journal_b_z[0]
        out = [za0 + (za1 - za0) * k / 4.0 for k in (1, 2, 3)]
        out += [zb0 + (zb1 - zb0) * k / 4.0 for k in (1, 2, 3)]
        return tuple(out)

    def segments(self) -> list[tuple[float, float, float, str]]:
        """Axial segments ``(z0, z1, radius, label)`` in local coordinates [m].

        Labels: ``coupling``, ``bearing_a``, ``body``, ``rotor``, ``station_k``, ``hub``,
        ``bearing_b``, ``tail``; consecutive segments touch.
        """
        segs: list[tuple[float, float, float, str]] = []
        z = 0.0
        plan = [
            (self.coupling_length, self.coupling_radius, "coupling"),
            (self.journal_length, self.journal_radius, "bearing_a"),
            (self.span_a, self.body_radius, "body"),
            (self.hub_length, self.hub_radius, "hub"),
            (self.span_b, self.body_radius, "body"),
            (self.journal_length, self.journal_radius, "bearing_b"),
            (self.tail_length, self.tail_radius, "tail"),
        ]
        hw = 0.5 * self.station_width
        stations = sorted((zc, k + 1) for k, zc in enumerate(self.station_centres))
        for length, radius, label in plan:
            if length <= 0.0:
                continue
            z0, z1 = z, z + length
            if label == "body":
                for b0, b1, r, lab in self._body_parts(z0, z1):
                    cur = b0
                    for zc, k in stations:
                        if b0 <= zc - hw and zc + hw <= b1:
                            if zc - hw > cur:
                                segs.append((cur, zc - hw, r, lab))
                            segs.append((zc - hw, zc + hw, r, f"station_{k}"))
                            cur = zc + hw
                    if b1 > cur:
                        segs.append((cur, b1, r, lab))
            else:
                segs.append((z0, z1, radius, label))
            z = z1
        return segs

    def _body_parts(self, z0: float, z1: float) -> list[tuple[float, float, float, str]]:
        """A body span ``[z0, z1]`` split into shoulder, rotor, shoulder (or whole)."""
        if self.rotor_radius <= 0.0:
            return [(z0, z1, self.body_radius, "body")]
        g = self.rotor_gap
        parts = [(z0, z0 + g, self.body_radius, "body"),
                 (z0 + g, z1 - g, self.rotor_radius, "rotor"),
                 (z1 - g, z1, self.body_radius, "body")]
        return [p for p in parts if p[1] > p[0]]

    @property
    def max_radius(self) -> float:
        """Largest radius of the shaft [m]."""
        return max(s[2] for s in self.segments())

    def validate(self, owner: str = "shaft") -> None:
        """Raise ``ValueError`` naming the field if the shaft is not buildable."""
        for name in ("coupling_radius", "coupling_length", "journal_radius",
                     "journal_length", "body_radius", "span_a", "hub_radius",
                     "hub_length", "span_b", "station_width"):
            _positive(owner, name, getattr(self, name))
        _non_negative(owner, "tail_length", self.tail_length)
        if self.tail_length > 0.0:
            _positive(owner, "tail_radius", self.tail_radius)
        _non_negative(owner, "rotor_radius", self.rotor_radius)
        if self.rotor_radius > 0.0:
            _non_negative(owner, "rotor_gap", self.rotor_gap)
            half = 0.5 * min(self.span_a, self.span_b)
            if self.rotor_gap >= half:
                raise ValueError(f"{owner}.rotor_gap = {self.rotor_gap!r}: must be < half the "
                                 f"shorter body span = {half:g} m (no rotor left)")
        if self.station_z is not None and not all(_is_number(z) for z in self.station_z):
            raise ValueError(f"{owner}.station_z = {self.station_z!r}: must hold "
                             f"{N_STATIONS} numbers (m)")
        centres = self.station_centres
        if len(centres) != N_STATIONS:
            raise ValueError(f"{owner}.station_z = {self.station_z!r}: must hold exactly "
                             f"{N_STATIONS} positions")
        hw = 0.5 * self.station_width
        spans = [(self.journal_a_z[1], self.hub_z[0]), (self.hub_z[1], self.journal_b_z[0])]
        for k, zc in enumerate(centres):
            if not math.isfinite(zc) or not any(a <= zc - hw and zc + hw <= b
                                                for a, b in spans):
                raise ValueError(
                    f"{owner}.station_z[{k}] = {zc!r}: the station ring "
                    f"[z-{hw:g}, z+{hw:g}] must lie inside a body span "
                    f"[{spans[0][0]:g}, {spans[0][1]:g}] or [{spans[1][0]:g}, {spans[1][1]:g}] m")
        if self.rotor_radius > 0.0:
            g = self.rotor_gap
            steps = [spans[0][0] + g, spans[0][1] - g, spans[1][0] + g, spans[1][1] - g]
            ends = ", ".join(f"{v:g}" for v in steps)
            for k, zc in enumerate(centres):
                if any(zc - hw < zs < zc + hw for zs in steps):
                    raise ValueError(f"{owner}.station_z[{k}] = {zc!r}: the station ring "
                                     f"[z-{hw:g}, z+{hw:g}] straddles a rotor end (rotor_gap "
                                     f"= {g:g} m puts them at {ends} m)")
        srt = sorted(centres)
        for z0, z1 in zip(srt[:-1], srt[1:], strict=True):
            if z1 - z0 < self.station_width:
                raise ValueError(f"{owner}.station_z = {tuple(centres)}: stations overlap "
                                 f"(spacing must be >= station_width = {self.station_width:g})")


# ------------------------------------------------------------------------- housing


@dataclass(frozen=True)
class HousingParams:
    """Closed box casing with bearing bosses, feet and optional ribs [m].

    The outer box spans ``x ∈ [a/2 - length_x/2, a/2 + length_x/2]``,
    ``y ∈ [-height_y/2, height_y/2]``, ``z ∈ [0, length_z]`` (``a`` the centre
    distance). The end walls ``z = 0`` (end ``a``) and ``z = length_z`` (end
    ``b``) carry one boss per shaft, protruding outwards by ``boss_length``, with
    a through bore of radius ``bore_radius`` (the bearing outer ring seat).

    Attributes
    ----------
    length_x, height_y, length_z : float
        Outer size of the box [m].
    wall_thickness : float
        Thickness of all six walls [m].
    boss_radius, boss_length : float
        Outer radius and outward protrusion of the bearing bosses [m].
    bore_radius : float
        Bearing bore radius [m] (> journal radius; the bearing is not meshed).
    foot_width, foot_depth, foot_height, foot_overhang : float
        The four corner feet under the bottom face: size along x, along z,
        thickness along y, and how far they stick out sideways past the box [m].
        Their bottom faces are the bolted faces ``housing/feet``.
    rib_count : int
        Number of stiffening ribs on the top face (plates along x), 0 for none.
    rib_thickness, rib_height : float
        Rib thickness along z and height above the top face [m].
    """

    length_x: float = 0.236
    height_y: float = 0.136
    length_z: float = 0.160
    wall_thickness: float = 0.008
    boss_radius: float = 0.038
    boss_length: float = 0.012
    bore_radius: float = 0.026
    foot_width: float = 0.035
    foot_depth: float = 0.030
    foot_height: float = 0.008
    foot_overhang: float = 0.015
    rib_count: int = 2
    rib_thickness: float = 0.006
    rib_height: float = 0.010

    @property
    def bore_length(self) -> float:
        """Axial length of each bore = wall + boss [m]."""
        return self.wall_thickness + self.boss_length

    @property
    def bore_a_z(self) -> tuple[float, float]:
        """Axial range of the bores of end wall ``a`` [m]."""
        return (-self.boss_length, self.wall_thickness)

    @property
    def bore_b_z(self) -> tuple[float, float]:
        """Axial range of the bores of end wall ``b`` [m]."""
        return (self.length_z - self.wall_thickness, self.length_z + self.boss_length)

    def rib_centres(self) -> tuple[float, ...]:
        """``z`` of the rib mid-planes, evenly spread over the top face [m]."""
        n = self.rib_count
        return tuple(self.length_z * (k + 1) / (n + 1) for k in range(n))

    def x_range(self, centre_distance: float) -> tuple[float, float]:
        """Outer ``x`` range of the box for a given centre distance [m]."""
        xc = 0.5 * centre_distance
        return (xc - 0.5 * self.length_x, xc + 0.5 * self.length_x)

    def validate(self, centre_distance: float = DEFAULT_CENTRE_DISTANCE,
                 owner: str = "housing") -> None:
        """Raise ``ValueError`` naming the field if the housing is not buildable."""
        for name in ("length_x", "height_y", "length_z", "wall_thickness", "boss_radius",
                     "boss_length", "bore_radius", "foot_width", "foot_depth",
                     "foot_height"):
            _positive(owner, name, getattr(self, name))
        _non_negative(owner, "foot_overhang", self.foot_overhang)
        if not isinstance(self.rib_count, int) or self.rib_count < 0:
            raise ValueError(f"{owner}.rib_count = {self.rib_count!r}: must be an int >= 0")
        if self.rib_count > 0:
            _positive(owner, "rib_thickness", self.rib_thickness)
            _positive(owner, "rib_height", self.rib_height)
        t = self.wall_thickness
        for name in ("length_x", "height_y", "length_z"):
            if getattr(self, name) <= 2 * t:
                raise ValueError(f"{owner}.wall_thickness = {t:g}: must be < {name}/2 = "
                                 f"{getattr(self, name) / 2:g} m (no cavity left)")
        if self.bore_radius >= self.boss_radius:
            raise ValueError(f"{owner}.bore_radius = {self.bore_radius:g}: must be < "
                             f"boss_radius = {self.boss_radius:g} m")
        x0, x1 = self.x_range(centre_distance)
        half_y = 0.5 * self.height_y
        for xc in (0.0, centre_distance):
            # boss inside the end face outline (no overhang)
            if xc - self.boss_radius < x0 or xc + self.boss_radius > x1 \
                    or self.boss_radius > half_y:
                raise ValueError(f"{owner}.boss_radius = {self.boss_radius:g}: the boss at "
                                 f"x = {xc:g} m sticks out of the end face "
                                 f"(x in [{x0:g}, {x1:g}], |y| <= {half_y:g} m)")
            # bore inside the cavity cross-section (cuts only the end wall)
            if xc - self.bore_radius < x0 + t or xc + self.bore_radius > x1 - t \
                    or self.bore_radius > half_y - t:
                raise ValueError(f"{owner}.bore_radius = {self.bore_radius:g}: the bore at "
                                 f"x = {xc:g} m cuts a side wall (cavity x in "
                                 f"[{x0 + t:g}, {x1 - t:g}], |y| <= {half_y - t:g} m)")
        if 2 * self.boss_radius >= centre_distance:
            raise ValueError(f"{owner}.boss_radius = {self.boss_radius:g}: the two bosses of "
                             f"an end wall overlap; must be < centre_distance/2 = "
                             f"{centre_distance / 2:g} m")
        if 2 * self.foot_width - 2 * self.foot_overhang >= self.length_x \
                or self.foot_width <= self.foot_overhang:
            raise ValueError(f"{owner}.foot_width = {self.foot_width:g}: must be in "
                             f"(foot_overhang = {self.foot_overhang:g}, "
                             f"(length_x/2 + foot_overhang) = "
                             f"{self.length_x / 2 + self.foot_overhang:g}) m")
        if 2 * self.foot_depth >= self.length_z:
            raise ValueError(f"{owner}.foot_depth = {self.foot_depth:g}: must be < "
                             f"length_z/2 = {self.length_z / 2:g} m")
        if self.rib_count > 0:
            pitch = self.length_z / (self.rib_count + 1)
            if self.rib_thickness >= pitch:
                raise ValueError(f"{owner}.rib_thickness = {self.rib_thickness:g}: ribs "
                                 f"overlap each other or the end edges; must be < "
                                 f"length_z/(rib_count+1) = {pitch:g} m")


# ------------------------------------------------------- box housing (any shafts)


@dataclass(frozen=True)
class Bore:
    """One shaft's bearing bores through both end walls and their bosses [m].

    Attributes
    ----------
    shaft : str
        Shaft name: the bores are the groups ``housing/bore_{shaft}_a`` (end wall at the
        smaller z) and ``housing/bore_{shaft}_b``.
    x, y : float
        The bore axis (parallel to z).
    radius : float
        Bore radius (the bearing's outer ring seat).
    boss_radius : float
        Outer radius of the boss around it.
    """

    shaft: str
    x: float
    y: float
    radius: float
    boss_radius: float


@dataclass(frozen=True)
class BoxHousing:
    """The solid :func:`build_box_housing` builds [m].

    Box ``x ∈ x_range``, ``y ∈ [y0, y0 + height_y]``, ``z ∈ [z0, z0 + length_z]``,
    hollowed to ``wall``; each end wall carries one boss per :class:`Bore` protruding
    outwards by ``boss_length``, bored through wall and boss; four corner feet under the
    bottom face (``foot_width`` along x, ``foot_depth`` along z, ``foot_height`` thick,
    ``foot_overhang`` past the side walls); ribs of ``rib_thickness`` x ``rib_height``
    across the top face at the global ``rib_z``.
    """

    x_range: tuple[float, float]
    y0: float
    height_y: float
    z0: float
    length_z: float
    wall: float
    boss_length: float
    bores: tuple[Bore, ...]
    foot_width: float
    foot_depth: float
    foot_height: float
    foot_overhang: float
    rib_z: tuple[float, ...] = ()
    rib_thickness: float = 0.0
    rib_height: float = 0.0

    @property
    def bore_a_z(self) -> tuple[float, float]:
        """Global axial range of the bores of end wall ``a`` [m]."""
        return (self.z0 - self.boss_length, self.z0 + self.wall)

    @property
    def bore_b_z(self) -> tuple[float, float]:
        """Global axial range of the bores of end wall ``b`` [m]."""
        z1 = self.z0 + self.length_z
        return (z1 - self.wall, z1 + self.boss_length)


# ---------------------------------------------------------------------------- pump


@dataclass(frozen=True)
class PumpParams:
    """Two shafts in the housing at the gear pair's centre distance [m].

    Attributes
    ----------
    shaft_in, shaft_out : ShaftParams
        Input (on the z axis) and output (on x = a) shafts.
    housing : HousingParams
    centre_distance : float
        Gear-pair centre distance ``a`` [m] (architecture.md: 0.100 m).
    gear_z : float or None
        Global ``z`` of the gear mid-plane = hub centre [m]; ``None`` puts it at
        the middle of the housing (``length_z / 2``). Each shaft is placed so its
        hub centre is at ``gear_z``.
    gear_tip_radius, gear_width : float
        Gear tip radius and face width [m], only for the clearance checks (the
        gears are lumped later, not meshed).
    min_clearance : float
        Smallest allowed radial gap between any two parts (gear tips included) [m].
    """

    shaft_in: ShaftParams = field(default_factory=ShaftParams)
    shaft_out: ShaftParams = field(default_factory=ShaftParams)
    housing: HousingParams = field(default_factory=HousingParams)
    centre_distance: float = DEFAULT_CENTRE_DISTANCE
    gear_z: float | None = None
    gear_tip_radius: float = DEFAULT_GEAR_TIP_RADIUS
    gear_width: float = DEFAULT_GEAR_WIDTH
    min_clearance: float = 0.001

    def __post_init__(self) -> None:
        # accept nested tables (e.g. from a TOML scene): {"shaft_in": {...}, ...}
        for name, cls in (("shaft_in", ShaftParams), ("shaft_out", ShaftParams),
                          ("housing", HousingParams)):
            value = getattr(self, name)
            if isinstance(value, dict):
                try:
                    object.__setattr__(self, name, cls(**value))
                except TypeError as exc:
                    raise ValueError(f"pump.{name}: {exc}") from exc
            elif not isinstance(value, cls):
                raise ValueError(f"pump.{name} = {value!r}: must be a {cls.__name__} or a "
                                 "table of its fields")

    def shaft(self, name: str) -> ShaftParams:
        """Parameters of shaft ``name`` (``"in"`` or ``"out"``)."""
        if name == "in":
            return self.shaft_in
        if name == "out":
            return self.shaft_out
        raise ValueError(f"shaft name = {name!r}: must be one of {SHAFT_NAMES}")

    @property
    def gear_plane_z(self) -> float:
        """Global ``z`` of the gear mid-plane [m]."""
        return 0.5 * self.housing.length_z if self.gear_z is None else float(self.gear_z)

    def shaft_axis(self, name: str) -> tuple[float, float]:
        """``(x, y)`` of the axis of shaft ``name`` [m]."""
        return (0.0, 0.0) if name == "in" else (self.centre_distance, 0.0)

    def shaft_origin(self, name: str) -> tuple[float, float, float]:
        """Global position of the coupling end centre of shaft ``name`` [m]."""
        s = self.shaft(name)
        x, y = self.shaft_axis(name)
        hub_mid = 0.5 * (s.hub_z[0] + s.hub_z[1])
        return (x, y, self.gear_plane_z - hub_mid)

    def validate(self) -> None:
        """Raise ``ValueError`` naming the field if the assembly is not buildable."""
        _positive("pump", "centre_distance", self.centre_distance)
        _positive("pump", "gear_tip_radius", self.gear_tip_radius)
        _positive("pump", "gear_width", self.gear_width)
        _non_negative("pump", "min_clearance", self.min_clearance)
        if self.gear_z is not None and not (_is_number(self.gear_z) and math.isfinite(self.gear_z)):
            raise ValueError(f"pump.gear_z = {self.gear_z!r}: must be finite or None")
        self.shaft_in.validate("pump.shaft_in")
        self.shaft_out.validate("pump.shaft_out")
        h = self.housing
        h.validate(self.centre_distance, "pump.housing")
        a, c, t = self.centre_distance, self.min_clearance, h.wall_thickness
        x0, x1 = h.x_range(a)
        half_y = 0.5 * h.height_y
        # shafts against each other (and each gear against the other shaft)
        r_in, r_out = self.shaft_in.max_radius, self.shaft_out.max_radius
        if r_in + r_out + c > a:
            raise ValueError(f"pump.centre_distance = {a:g}: shafts collide (max radii "
                             f"{r_in:g} + {r_out:g} + clearance {c:g} m)")
        if self.gear_tip_radius + max(r_in, r_out) + c > a:
            raise ValueError(f"pump.gear_tip_radius = {self.gear_tip_radius:g}: a gear "
                             f"hits the other shaft; must be <= "
                             f"{a - max(r_in, r_out) - c:g} m")
        if self.gear_tip_radius >= a:
            raise ValueError(f"pump.gear_tip_radius = {self.gear_tip_radius:g}: must be < "
                             f"centre_distance = {a:g} m")
        # gears inside the cavity
        room = min(0.0 - (x0 + t), (x1 - t) - a, half_y - t)
        if self.gear_tip_radius + c > room:
            raise ValueError(f"pump.gear_tip_radius = {self.gear_tip_radius:g}: the gear "
                             f"does not fit inside the housing; must be <= {room - c:g} m "
                             f"(or enlarge housing.length_x / housing.height_y)")
        zg = self.gear_plane_z
        zc0, zc1 = t, h.length_z - t
        if zg - 0.5 * self.gear_width < zc0 + c or zg + 0.5 * self.gear_width > zc1 - c:
            raise ValueError(f"pump.gear_z = {zg:g}: the gear (width {self.gear_width:g}) "
                             f"must lie inside the cavity z in [{zc0 + c:g}, {zc1 - c:g}] m")
        for name in SHAFT_NAMES:
            self._validate_shaft_in_housing(name)

    def _validate_shaft_in_housing(self, name: str) -> None:
        s, h = self.shaft(name), self.housing
        field_ = f"pump.shaft_{name}"
        z_org = self.shaft_origin(name)[2]
        c, tol = self.min_clearance, 1e-12
        # journals inside their bores
        for end, (j0, j1), (b0, b1) in (("a", s.journal_a_z, h.bore_a_z),
                                        ("b", s.journal_b_z, h.bore_b_z)):
            g0, g1 = z_org + j0, z_org + j1
            if g0 < b0 - tol or g1 > b1 + tol:
                raise ValueError(
                    f"{field_}.journal_length/span: journal {end} spans z = [{g0:.4g}, "
                    f"{g1:.4g}] m but bore {end} of the housing spans [{b0:.4g}, {b1:.4g}] m "
                    f"(the journal must lie inside its bore; adjust span_a/span_b/"
                    f"hub_length or pump.gear_z)")
        if s.journal_radius + c > h.bore_radius:
            raise ValueError(f"{field_}.journal_radius = {s.journal_radius:g}: the journal "
                             f"does not fit in its bore; must be <= bore_radius - "
                             f"min_clearance = {h.bore_radius - c:g} m")
        # every segment crossing an end wall or boss must clear the bore;
        # every segment inside the cavity must clear the side walls
        x_axis = self.shaft_axis(name)[0]
        x0, x1 = h.x_range(self.centre_distance)
        t = h.wall_thickness
        room = min(x_axis - (x0 + t), (x1 - t) - x_axis, 0.5 * h.height_y - t)
        walls = (h.bore_a_z, h.bore_b_z)
        for z0, z1, r, label in s.segments():
            g0, g1 = z_org + z0, z_org + z1
            crosses_wall = any(g0 < w1 - tol and g1 > w0 + tol for w0, w1 in walls)
            if crosses_wall and r + c > h.bore_radius:
                raise ValueError(f"{field_}: segment '{label}' (radius {r:g} m) at z = "
                                 f"[{g0:.4g}, {g1:.4g}] m collides with a housing end wall "
                                 f"(bore_radius {h.bore_radius:g} m)")
            inside = g1 > t and g0 < h.length_z - t
            if inside and r + c > room:
                raise ValueError(f"{field_}: segment '{label}' (radius {r:g} m) collides "
                                 f"with a housing side wall (room {room:g} m)")
        # layout (docs/geometry.md): the coupling end sticks out of end wall a
        z_start = z_org
        if z_start > h.bore_a_z[0] - tol:
            raise ValueError(f"{field_}.coupling_length = {s.coupling_length:g}: the coupling "
                             f"end (z = {z_start:.4g} m) must stick out of the housing "
                             f"(z < {h.bore_a_z[0]:g} m)")


# ---------------------------------------------------------------------------- mesh


@dataclass(frozen=True)
class MeshOptions:
    """Mesh sizes and quality controls.

    Attributes
    ----------
    size : float
        Target element size on the housing [m].
    shaft_factor : float
        Element size on the shafts = ``size * shaft_factor`` (-).
    bore_factor : float
        Element size on the bearing bores and bosses = ``size * bore_factor`` (-).
    hub_factor : float
        Element size on the journals and hub seats = shaft size ``* hub_factor`` (-).
    curvature_points : int
        Elements per 2π on curved edges (``Mesh.MeshSizeFromCurvature``), 0 = off.
    order : int
        Geometric order of the tetrahedra; 2 (10-node tets) is the contract.
    straighten_sicn : float
        Curved tets whose minimum SICN is below this are made straight-sided
        (their mid-edge nodes moved to the chord midpoints), 0 = never.
    min_sicn : float
        Refuse the mesh (``RuntimeError``) if any element's minimum SICN is
        still below this after straightening and remeshing attempts.
    poor_sicn : float
        Elements with minimum SICN below this are counted as poor in the report.
    seed : int
        ``Mesh.RandomSeed`` (deterministic meshes).
    high_order_optimize : int
        ``Mesh.HighOrderOptimize`` (0 none, 1 optimisation, 2 elastic+optimisation).
    name : str
        Preset name for reports.
    """

    size: float = 0.016
    shaft_factor: float = 0.5
    bore_factor: float = 0.6
    hub_factor: float = 1.0
    curvature_points: int = 10
    order: int = 2
    straighten_sicn: float = 0.05
    min_sicn: float = 0.02
    poor_sicn: float = 0.3
    seed: int = 1
    high_order_optimize: int = 0
    name: str = "custom"

    def validate(self) -> None:
        """Raise ``ValueError`` naming the field if the options are unusable."""
        for name in ("size", "shaft_factor", "bore_factor", "hub_factor"):
            _positive("mesh", name, getattr(self, name))
        if self.order != 2:
            raise ValueError(f"mesh.order = {self.order!r}: must be 2 (10-node tetrahedra)")
        if not isinstance(self.curvature_points, int) or self.curvature_points < 0:
            raise ValueError(f"mesh.curvature_points = {self.curvature_points!r}: must be an "
                             "int >= 0")
        if not (0.0 <= self.min_sicn < 1.0):
            raise ValueError(f"mesh.min_sicn = {self.min_sicn!r}: must be in [0, 1)")
        if not (0.0 <= self.straighten_sicn < 1.0):
            raise ValueError(f"mesh.straighten_sicn = {self.straighten_sicn!r}: must be in "
                             "[0, 1)")
        if not (0.0 <= self.poor_sicn <= 1.0):
            raise ValueError(f"mesh.poor_sicn = {self.poor_sicn!r}: must be in [0, 1]")
        if self.high_order_optimize not in (0, 1, 2, 3, 4):
            raise ValueError(f"mesh.high_order_optimize = {self.high_order_optimize!r}: "
                             "must be in {0, 1, 2, 3, 4}")

    @property
    def shaft_size(self) -> float:
        """Element size on the shafts [m]."""
        return self.size * self.shaft_factor


_PRESETS: dict[str, MeshOptions] = {
    # whole pump under ~40k P2 vector DOF (tests)
    "coarse": MeshOptions(size=0.027, shaft_factor=0.5, bore_factor=0.6, hub_factor=1.0,
                          curvature_points=10, name="coarse"),
    # a few hundred thousand P2 vector DOF (benchmarks)
    "fine": MeshOptions(size=0.007, shaft_factor=0.6, bore_factor=0.6, hub_factor=1.0,
                        curvature_points=16, name="fine"),
    # over a million P2 vector DOF (measured 1 629 168, 1 534 530 after links and clamps;
    # meshing 84-92 s, 1.0 GB; reduced serially in 28 min, 9.7 GiB peak with the LDLT
    # factor out of core, n_CM = 100: docs/scale.md)
    "million": MeshOptions(size=0.0037, shaft_factor=0.6, bore_factor=0.6, hub_factor=1.0,
                           curvature_points=16, name="million"),
}


def preset(name: str, **overrides: object) -> MeshOptions:
    """Named mesh preset (``"coarse"``, ``"fine"`` or ``"million"``), optionally with
    overrides."""
    if name not in _PRESETS:
        raise ValueError(f"mesh preset = {name!r}: must be one of {sorted(_PRESETS)}")
    opts = _PRESETS[name]
    return dataclasses.replace(opts, **overrides) if overrides else opts
