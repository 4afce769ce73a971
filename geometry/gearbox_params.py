"""Parameter dataclasses of a parallel-shaft gearbox's geometry (SI units, metres).

N shafts parallel to ``z`` (docs/architecture.md "Units and frames"), each a cylinder of
one radius with a journal at each bearing and a seat at each gear, in a box housing
whose end walls carry one bored boss per shaft (:func:`geometry.gearbox.build_gearbox`).
The housing follows the shafts: its end walls sit at the shafts' first and last
bearings, its cavity encloses every gear's tip circle with ``clearance``, each bore is
the journal radius plus the bearing's radial section.

Every ``validate()`` refuses bad geometry with a :class:`core.errors.InputError` (a
``ValueError``) naming the field, its value and the allowed range, before any gmsh
work: a bearing or gear outside its shaft, two seats of one shaft overlapping, a bore
that does not fit the housing, a gear that hits another shaft or the end walls.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

from core.errors import InputError

from .params import Bore, BoxHousing

__all__ = ["BEARING_NAMES", "GearSeatParams", "GearboxHousingParams", "GearboxParams",
           "GearboxShaftParams", "JournalParams"]

#: Names of the bearings of a shaft, in the order of their positions (end wall a, b).
BEARING_NAMES = ("a", "b")
_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_-]*")
_TOL = 1e-9  # m, positions compared with this slack


def _number(owner: str, name: str, value: object, lo: float = 0.0, lo_open: bool = True,
            unit: str = "m") -> float:
    ok = (isinstance(value, (int, float)) and not isinstance(value, bool)
          and math.isfinite(value) and (value > lo if lo_open else value >= lo))
    if not ok:
        raise InputError.of(f"{owner}.{name}", value,
                            f"must be a finite number {'>' if lo_open else '>='} {lo:g}",
                            unit=unit)
    return float(value)


def _name(owner: str, value: object) -> str:
    if not isinstance(value, str) or not _NAME.fullmatch(value):
        raise InputError.of(f"{owner}.name", value, "must be a name of letters, digits, "
                            "'_' or '-', starting with a letter")
    return value


@dataclass(frozen=True)
class JournalParams:
    """A bearing on a shaft: the journal (inner ring seat) at ``position``.

    Attributes
    ----------
    position : float
        Axial position of the bearing centre from the shaft's start [m].
    width : float
        Bearing width along the axis [m] (the journal's length).
    """

    position: float
    width: float = 0.015


@dataclass(frozen=True)
class GearSeatParams:
    """A gear on a shaft: the seat its hub sits on (the gear itself is lumped in the FE
    model, not meshed).

    Attributes
    ----------
    name : str
        Gear name (unique in the gearbox).
    position : float
        Axial position of the gear's mid-face from the shaft's start [m].
    width : float
        Face width = the seat's length [m].
    tip_radius : float
        Tip radius [m], for the clearance checks and the housing's cavity.
    """

    name: str
    position: float
    width: float
    tip_radius: float


@dataclass(frozen=True)
class GearboxShaftParams:
    """A shaft of the gearbox: a cylinder along ``+z`` from ``(x, y, start)`` [m].

    Attributes
    ----------
    name : str
    centre : (float, float)
        ``(x, y)`` of the axis [m].
    length : float
        Shaft length [m].
    radius : float
        Journal and body radius [m] (half the scene's diameter).
    bearings : tuple of JournalParams
        Exactly two (one per end wall), in any order; named ``a`` (smaller position)
        and ``b``.
    gears : tuple of GearSeatParams
        At least one.
    seat_radius : float
        Radius of the gear seats [m]; 0: the shaft radius.
    start : float
        Global ``z`` of the shaft's start [m].
    """

    name: str
    centre: tuple[float, float]
    length: float
    radius: float
    bearings: tuple[JournalParams, ...]
    gears: tuple[GearSeatParams, ...]
    seat_radius: float = 0.0
    start: float = 0.0

    @property
    def seat_r(self) -> float:
        """Radius of the gear seats [m]."""
        return self.seat_radius if self.seat_radius > 0 else self.radius

    def sorted_bearings(self) -> tuple[tuple[str, JournalParams], ...]:
        """``(name, bearing)`` in the order of their positions (``a`` first)."""
        order = sorted(self.bearings, key=lambda b: b.position)
        return tuple(zip(BEARING_NAMES, order, strict=False))

    def features(self) -> list[tuple[float, float, float, str]]:
        """The journals and seats as ``(z0, z1, radius, label)`` (local z), sorted;
        labels ``bearing_{a|b}`` and ``seat_{gear}``."""
        out = [(b.position - 0.5 * b.width, b.position + 0.5 * b.width, self.radius,
                f"bearing_{n}") for n, b in self.sorted_bearings()]
        out += [(g.position - 0.5 * g.width, g.position + 0.5 * g.width, self.seat_r,
                 f"seat_{g.name}") for g in self.gears]
        return sorted(out)

    def segments(self) -> list[tuple[float, float, float, str]]:
        """Consecutive axial segments ``(z0, z1, radius, label)`` from 0 to ``length``
        (local z): the features with ``body`` segments between them."""
        segs: list[tuple[float, float, float, str]] = []
        z = 0.0
        for z0, z1, r, label in self.features():
            if z0 > z + _TOL:
                segs.append((z, z0, self.radius, "body"))
            segs.append((max(z0, z), z1, r, label))
            z = z1
        if self.length > z + _TOL:
            segs.append((z, self.length, self.radius, "body"))
        return segs

    def validate(self, owner: str) -> None:
        """Raise :class:`InputError` naming ``{owner}.<field>`` if not buildable."""
        _name(owner, self.name)
        _number(owner, "length", self.length)
        _number(owner, "radius", self.radius)
        _number(owner, "seat_radius", self.seat_radius, lo_open=False)
        if len(self.centre) != 2 or not all(isinstance(c, (int, float))
                                            and math.isfinite(c) for c in self.centre):
            raise InputError.of(f"{owner}.centre", self.centre, "must be two finite "
                                "numbers (x, y)", unit="m")
        if len(self.bearings) != 2:
            raise InputError.of(f"{owner}.bearings", len(self.bearings), "the parametric "
                                "housing holds exactly two bearings per shaft, one in each "
                                "end wall")
        if not self.gears:
            raise InputError.of(f"{owner}.gears", [], "a shaft carries at least one gear")
        for j, b in enumerate(self.bearings):
            w = _number(f"{owner}.bearings[{j}]", "width", b.width)
            p = _number(f"{owner}.bearings[{j}]", "position", b.position, lo=-math.inf)
            if p - 0.5 * w < -_TOL or p + 0.5 * w > self.length + _TOL:
                raise InputError.of(f"{owner}.bearings[{j}].position", p,
                                    f"the bearing [{p - w / 2:g}, {p + w / 2:g}] m lies "
                                    f"outside its shaft [0, {self.length:g}] m; allowed "
                                    f"[{w / 2:g}, {self.length - w / 2:g}] m", unit="m")
        for j, g in enumerate(self.gears):
            where = f"{owner}.gears[{j}]"
            _name(where, g.name)
            w = _number(where, "width", g.width)
            _number(where, "tip_radius", g.tip_radius)
            p = _number(where, "position", g.position, lo=-math.inf)
            if p - 0.5 * w < -_TOL or p + 0.5 * w > self.length + _TOL:
                raise InputError.of(f"{where}.position", p,
                                    f"the gear [{p - w / 2:g}, {p + w / 2:g}] m lies outside "
                                    f"its shaft [0, {self.length:g}] m; allowed "
                                    f"[{w / 2:g}, {self.length - w / 2:g}] m", unit="m")
            if g.tip_radius <= self.seat_r:
                raise InputError.of(f"{where}.tip_radius", g.tip_radius, f"must be > the "
                                    f"seat radius {self.seat_r:g} m", unit="m")
        feats = self.features()
        for (a0, a1, _, la), (b0, b1, _, lb) in zip(feats[:-1], feats[1:], strict=True):
            if b0 < a1 - _TOL:
                raise InputError.of(f"{owner}", self.name, f"{la} [{a0:g}, {a1:g}] m and {lb} "
                                    f"[{b0:g}, {b1:g}] m overlap on the shaft (intersecting "
                                    "seats: move a gear or a bearing)")


@dataclass(frozen=True)
class GearboxHousingParams:
    """The box housing that follows the shafts [m].

    Attributes
    ----------
    wall_thickness : float
        All six walls.
    clearance : float
        Radial gap from each gear's tip circle to the cavity's side walls, and axial
        gap from each gear's faces to the end walls.
    boss_length : float
        Outward protrusion of the bosses; bore length = wall + boss.
    boss_thickness : float
        Radial thickness of each boss around its bore.
    bearing_section : float
        Radial section of the bearings: bore radius = shaft radius + this.
    foot_width, foot_depth, foot_height, foot_overhang : float
        The four corner feet (along x, along z, thickness along y, overhang past the
        side walls); their bottom faces are clamped.
    rib_count : int
        Ribs across the top face (plates along x), 0 for none.
    rib_thickness, rib_height : float
    """

    wall_thickness: float = 0.008
    clearance: float = 0.012
    boss_length: float = 0.012
    boss_thickness: float = 0.012
    bearing_section: float = 0.0135
    foot_width: float = 0.050
    foot_depth: float = 0.040
    foot_height: float = 0.012
    foot_overhang: float = 0.020
    rib_count: int = 2
    rib_thickness: float = 0.008
    rib_height: float = 0.010

    def validate(self, owner: str = "housing") -> None:
        """Raise :class:`InputError` naming the field if not usable."""
        for name in ("wall_thickness", "clearance", "boss_length", "boss_thickness",
                     "bearing_section", "foot_width", "foot_depth", "foot_height"):
            _number(owner, name, getattr(self, name))
        _number(owner, "foot_overhang", self.foot_overhang, lo_open=False)
        if isinstance(self.rib_count, bool) or not isinstance(self.rib_count, int) \
                or self.rib_count < 0:
            raise InputError.of(f"{owner}.rib_count", self.rib_count, "must be an int >= 0")
        if self.rib_count:
            _number(owner, "rib_thickness", self.rib_thickness)
            _number(owner, "rib_height", self.rib_height)
        if self.foot_width <= self.foot_overhang:
            raise InputError.of(f"{owner}.foot_width", self.foot_width, f"must be > "
                                f"foot_overhang = {self.foot_overhang:g} m", unit="m")


@dataclass(frozen=True)
class GearboxParams:
    """Shafts in their housing [m].

    Attributes
    ----------
    shafts : tuple of GearboxShaftParams
    housing : GearboxHousingParams
    min_clearance : float
        Smallest radial gap between a gear's tip and another shaft, and between two
        bores of one end wall [m].
    """

    shafts: tuple[GearboxShaftParams, ...]
    housing: GearboxHousingParams = field(default_factory=GearboxHousingParams)
    min_clearance: float = 0.001

    def shaft(self, name: str) -> GearboxShaftParams:
        """The shaft called ``name``."""
        for s in self.shafts:
            if s.name == name:
                return s
        raise InputError.of("shaft", name, "unknown shaft; known: "
                            + ", ".join(repr(s.name) for s in self.shafts))

    def bore_radius(self, shaft: GearboxShaftParams) -> float:
        """Bore radius of a shaft's bearings [m]."""
        return shaft.radius + self.housing.bearing_section

    def wall_z(self) -> tuple[float, float]:
        """Global ``z`` of the outer faces of end walls a and b [m]: bore a (wall plus
        boss) centred on the first shaft's bearing a, bore b on its bearing b."""
        h, s = self.housing, self.shafts[0]
        (_, ba), (_, bb) = s.sorted_bearings()
        za = s.start + ba.position - 0.5 * (h.wall_thickness - h.boss_length)
        zb = s.start + bb.position + 0.5 * (h.wall_thickness - h.boss_length)
        return za, zb

    def box(self) -> BoxHousing:
        """The housing solid that follows the shafts (:class:`geometry.housing.BoxHousing`)."""
        h = self.housing
        c = h.clearance
        gears = [(s.centre, g.tip_radius) for s in self.shafts for g in s.gears]
        xs = [(x - r, x + r) for (x, _), r in gears]
        ys = [(y - r, y + r) for (_, y), r in gears]
        t = h.wall_thickness
        x0 = min(v[0] for v in xs) - c - t
        x1 = max(v[1] for v in xs) + c + t
        y0 = min(v[0] for v in ys) - c - t
        y1 = max(v[1] for v in ys) + c + t
        za, zb = self.wall_z()
        lz = zb - za
        ribs = tuple(za + lz * (k + 1) / (h.rib_count + 1) for k in range(h.rib_count))
        bores = tuple(Bore(s.name, float(s.centre[0]), float(s.centre[1]),
                           self.bore_radius(s), self.bore_radius(s) + h.boss_thickness)
                      for s in self.shafts)
        return BoxHousing(x_range=(x0, x1), y0=y0, height_y=y1 - y0, z0=za, length_z=lz,
                          wall=t, boss_length=h.boss_length, bores=bores,
                          foot_width=h.foot_width, foot_depth=h.foot_depth,
                          foot_height=h.foot_height, foot_overhang=h.foot_overhang,
                          rib_z=ribs, rib_thickness=h.rib_thickness,
                          rib_height=h.rib_height)

    def validate(self) -> None:
        """Raise :class:`InputError` naming the field if the gearbox is not buildable."""
        if not self.shafts:
            raise InputError.of("shafts", [], "at least one shaft")
        _number("gearbox", "min_clearance", self.min_clearance, lo_open=False)
        self.housing.validate()
        names = [s.name for s in self.shafts]
        if len(set(names)) != len(names):
            raise InputError.of("shafts.name", names, "must be distinct")
        gears = [g.name for s in self.shafts for g in s.gears]
        if len(set(gears)) != len(gears):
            raise InputError.of("gears.name", gears, "must be distinct")
        for i, s in enumerate(self.shafts):
            s.validate(f"shafts[{i}]")
        self._check_walls()
        self._check_bores()
        self._check_gears()

    def _check_walls(self) -> None:
        h = self.housing
        za, zb = self.wall_z()
        bore_len = h.wall_thickness + h.boss_length
        if zb - za < 2 * bore_len + 2 * h.clearance:
            raise InputError.of("shafts[0].bearings", [b.position for b in
                                                      self.shafts[0].bearings],
                                f"the bearings are {zb - za - bore_len:g} m apart: too close "
                                f"for two end walls ({bore_len:g} m bores) and a cavity",
                                unit="m")
        walls = {"a": (za - h.boss_length, za + h.wall_thickness),
                 "b": (zb - h.wall_thickness, zb + h.boss_length)}
        for i, s in enumerate(self.shafts):
            for name, b in s.sorted_bearings():
                w0, w1 = walls[name]
                g0 = s.start + b.position - 0.5 * b.width
                g1 = s.start + b.position + 0.5 * b.width
                if g0 < w0 - 1e-6 or g1 > w1 + 1e-6:
                    j = s.bearings.index(b)
                    raise InputError.of(
                        f"shafts[{i}].bearings[{j}].position", b.position,
                        f"bearing {name} of shaft {s.name!r} spans z = [{g0:.4g}, {g1:.4g}] m "
                        f"but the bore of end wall {name} spans [{w0:.4g}, {w1:.4g}] m (the "
                        f"end walls sit at shaft {self.shafts[0].name!r}'s bearings; every "
                        "shaft's bearings must lie in them)", unit="m")

    def _check_bores(self) -> None:
        box = self.box()
        h, c = self.housing, self.min_clearance
        t = box.wall
        x0, x1 = box.x_range
        y0, y1 = box.y0, box.y0 + box.height_y
        for i, (s, b) in enumerate(zip(self.shafts, box.bores, strict=True)):
            room = min(b.x - (x0 + t), (x1 - t) - b.x, b.y - (y0 + t), (y1 - t) - b.y)
            if b.radius > room:
                raise InputError.of("housing.bearing_section", h.bearing_section,
                                    f"the bore of shaft {s.name!r} (radius {b.radius:g} m = "
                                    f"shafts[{i}].radius + bearing_section) cuts a side wall: "
                                    f"the cavity leaves {room:g} m around its axis (enlarge "
                                    "housing.clearance or use a smaller bearing)", unit="m")
            if b.boss_radius > room + t:
                raise InputError.of("housing.boss_thickness", h.boss_thickness,
                                    f"the boss of shaft {s.name!r} (radius {b.boss_radius:g} "
                                    f"m) sticks out of the end face ({room + t:g} m around "
                                    "its axis)", unit="m")
        for i, bi in enumerate(box.bores):
            for bj in box.bores[i + 1:]:
                d = math.hypot(bi.x - bj.x, bi.y - bj.y)
                if bi.radius + bj.radius + c > d:
                    raise InputError.of("housing.bearing_section", h.bearing_section,
                                        f"the bores of shafts {bi.shaft!r} and {bj.shaft!r} "
                                        f"overlap: radii {bi.radius:g} + {bj.radius:g} + "
                                        f"clearance {c:g} > axis distance {d:g} m", unit="m")

    def _check_gears(self) -> None:
        h, c = self.housing, self.min_clearance
        za, zb = self.wall_z()
        z_lo, z_hi = za + h.wall_thickness + h.clearance, zb - h.wall_thickness - h.clearance
        for i, s in enumerate(self.shafts):
            for j, g in enumerate(s.gears):
                g0 = s.start + g.position - 0.5 * g.width
                g1 = s.start + g.position + 0.5 * g.width
                if g0 < z_lo - 1e-9 or g1 > z_hi + 1e-9:
                    raise InputError.of(f"shafts[{i}].gears[{j}].position", g.position,
                                        f"gear {g.name!r} spans z = [{g0:.4g}, {g1:.4g}] m, "
                                        f"outside the cavity less the clearance "
                                        f"[{z_lo:.4g}, {z_hi:.4g}] m", unit="m")
                for o in self.shafts:
                    if o is s:
                        continue
                    d = math.hypot(s.centre[0] - o.centre[0], s.centre[1] - o.centre[1])
                    if g.tip_radius + o.radius + c > d:
                        raise InputError.of(f"shafts[{i}].gears[{j}].tip_radius", g.tip_radius,
                                            f"gear {g.name!r} hits shaft {o.name!r}: tip "
                                            f"{g.tip_radius:g} + shaft radius {o.radius:g} + "
                                            f"clearance {c:g} > axis distance {d:g} m",
                                            unit="m")
