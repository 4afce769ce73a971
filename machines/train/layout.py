"""The layout of a gear train, derived from a scene's ``[[shafts]]``, ``[[gears]]``,
``[[meshes]]``, ``[drive]`` and ``[[loads]]`` (issue 36; /work/plan/TRAIN.md): where the
shafts sit, how fast and which way they turn, each gear's pair geometry and frame, each
mesh's line-of-action vector (eq. 11) in the global frame, its phase (docs/theory.md
§14.5) and its static load from the torque path, and the hunting fundamental of the
train (§14.1). Every bad-input check of issue 36 is made here, before any meshing, as a
:class:`core.errors.InputError` naming the scene field.

Frames. One global frame, z along the shafts (all parallel); each gear body's 6 DOF are
in that frame (translations x, y, z, rotations about x, y, z), so every gear's ``frame``
is the identity. The drive shaft sits at the origin; a mesh's ``angle`` is the direction
of the line of centres from gear 1's shaft to gear 2's (x axis = 0, counter-clockwise
seen from +z), and places gear 2's shaft (or gear 1's, when gear 2's shaft was placed
first) breadth-first from the first shaft of the table.

Senses. The drive shaft turns counter-clockwise seen from +z (sense +1); an external mesh
reverses the sense. A mesh's vector is eq. (11) (:func:`gears.pair.line_of_action_vector`,
sense of gear 1 and helix hand included) in the gear-pair frame of Fig. 1
(:func:`gears.pair.pair_frame` at the working pressure angle) turned by the mesh angle
about z, i.e. rotated into the global frame: ``Δ = vectorᵀ (q_1, q_2)`` with q in global
components.

Torque path. Rigid-body torque balance on the tree of shafts from the drive (the root) to
the loads: the power through a mesh is the sum of the shares of the loads beyond it, so
the torque on its gear on the drive side is ``share T_d / ρ`` (ρ that shaft's speed
ratio) and its static load along the line of action ``F_s = share T_d / (ρ r_b)``. Meshes
joining the same two shafts (a split pair: several meshes of one ratio in parallel)
share their edge's load in proportion to their face widths; any other loop, a shaft not
reached or a load not reachable is refused ("the torque path does not close").

Pure: imports :mod:`core` and :mod:`gears` only (no FE). The FE gearbox machine uses the
same layout.
"""
from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import numpy as np

from core.errors import InputError
from gears.pair import GearPair
from gears.train import mesh_phase

__all__ = ["TrainShaft", "TrainGear", "TrainMesh", "TrainLayout", "STEEL_DENSITY",
           "PLACEMENT_TOLERANCE", "default_n_time", "rotation_z"]

#: Density (kg/m³) of the default gear disks (steel), as :mod:`machines.lumped`.
STEEL_DENSITY = 7800.0
#: A shaft placed by two meshes must land at one centre within this distance (m).
PLACEMENT_TOLERANCE = 1e-6
#: A given centre distance must match the gears' working one within this (m).
CENTRE_TOLERANCE = 1e-6


@dataclass(frozen=True)
class TrainShaft:
    """A shaft of the train.

    Attributes
    ----------
    name : str
        The scene's ``shafts[i].name``.
    centre : (float, float)
        Its axis in the plane normal to the shafts (m), the first shaft of the table at the
        origin.
    speed_ratio : Fraction
        Its speed over the drive shaft's (exact, > 0).
    sense : {1, -1}
        Its sense of rotation about +z (the drive shaft: +1).
    """

    name: str
    centre: tuple[float, float]
    speed_ratio: Fraction
    sense: int


@dataclass(frozen=True, eq=False)
class TrainGear:
    """A gear on a shaft: one rigid body (6 DOF in the global frame).

    Attributes
    ----------
    name : str
        Body name = the scene's ``gears[i].name``.
    shaft : str
        Its shaft.
    position : float
        Axial position of its mid-face on the shaft (m).
    teeth : int
        Tooth count Z.
    module, pressure_angle, helix_angle : float
        Normal module (m), normal pressure angle (rad), signed helix angle (rad; + right
        hand).
    face_width : float
        b (m).
    profile_shift : float
        x.
    pitch_radius, base_radius, tip_radius : float
        r, r_b, r_a (m) of its pair geometry (ISO 21771; for the tip radius the
        rack's ``(h_a + x) m_n``).
    inertia, mass : float
        Polar inertia (kg m²) and mass (kg): given, or a steel disk of the pitch
        diameter and face width.
    frame : numpy.ndarray (3, 3)
        Axes of its 6 DOF: the identity (global frame).
    """

    name: str
    shaft: str
    position: float
    teeth: int
    module: float
    pressure_angle: float
    helix_angle: float
    face_width: float
    profile_shift: float
    addendum_coef: float
    dedendum_coef: float
    pitch_radius: float
    base_radius: float
    tip_radius: float
    inertia: float
    mass: float
    frame: np.ndarray


@dataclass(frozen=True, eq=False)
class TrainMesh:
    """A mesh of the train.

    Attributes
    ----------
    name : str
        The scene's ``meshes[i].name``.
    gears : (str, str)
        Gear 1 (driving) and gear 2, in eq. (11)'s order.
    shafts : (str, str)
        Their shafts.
    pair : gears.pair.GearPair
        The two gears as a pair (face width: the smaller of the two).
    angle : float
        Direction of the line of centres from gear 1's shaft to gear 2's (rad).
    centre_distance : float
        Working centre distance a_w of the pair (m).
    sense : {1, -1}
        Sense of rotation of gear 1 about +z.
    frame : numpy.ndarray (3, 3)
        The gear-pair frame of Fig. 1 in global components (gear 2 along its e_x' turned
        by ``angle``).
    vector : numpy.ndarray (12,)
        Eq. (11) in the global frame on (gear 1's 6 DOF, gear 2's 6 DOF), m per unit.
    frequency_ratio : Fraction
        Mesh frequency over the drive speed, ``Z_1 ρ_1`` (exact).
    speed_ratio : Fraction
        ρ_1, gear 1's shaft's speed ratio.
    phase : float
        Mesh phase at t = 0 (rad, [0, 2π)), the convention of :mod:`gears.train`.
    phase_source : str
        ``"geometry"`` (T.44 from the tooth positions) or ``"given"``.
    static_load : float
        Static load F_s along the line of action (N) from the torque path.
    backlash : float
        Half backlash b (m).
    """

    name: str
    gears: tuple[str, str]
    shafts: tuple[str, str]
    pair: GearPair
    angle: float
    centre_distance: float
    sense: int
    frame: np.ndarray
    vector: np.ndarray
    frequency_ratio: Fraction
    speed_ratio: Fraction
    phase: float
    phase_source: str
    static_load: float
    backlash: float

    @property
    def teeth(self) -> tuple[int, int]:
        """(Z_1, Z_2)."""
        return self.pair.teeth


def rotation_z(angle: float) -> np.ndarray:
    """Rotation by ``angle`` (rad) about +z, (3, 3)."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def default_n_time(max_index: int) -> int:
    """AFT samples a one-dimensional set of largest index ``max_index`` takes by default:
    the smallest power of two >= max(64, 8 H + 4) (the rule of :func:`hbm.basis.default_n_time`,
    docs/theory.md §8, restated here: machines do not import hbm)."""
    need = max(64, 8 * int(max_index) + 4)
    return int(2 ** math.ceil(math.log2(need)))


def _fraction_gcd(values: Sequence[Fraction]) -> Fraction:
    """Largest r with every value an integer multiple of r (values > 0, exact)."""
    den = math.lcm(*(v.denominator for v in values))
    num = math.gcd(*(v.numerator * (den // v.denominator) for v in values))
    return Fraction(num, den)


def _get(obj: Any, name: str, default: Any = None) -> Any:
    return getattr(obj, name, default)


def _where(kind: str, i: int, key: str) -> str:
    return f"{kind}[{i}].{key}"


def _gear(i: int, g: Any, shafts: set[str]) -> TrainGear:
    """One gear of ``scene.gears``, its radii and default inertia."""
    if g.shaft not in shafts:
        raise InputError.of(_where("gears", i, "shaft"), g.shaft,
                            "unknown shaft; known: " + ", ".join(map(repr, sorted(shafts))))
    beta = float(g.helix_angle)
    if not abs(beta) < 0.5 * math.pi:
        raise InputError.of(_where("gears", i, "helix_angle_deg"), math.degrees(beta),
                            "must be > -90 and < 90")
    x = float(_get(g, "profile_shift", 0.0) or 0.0)
    ha = float(_get(g, "addendum_coef", 1.0) or 1.0)
    hf = float(_get(g, "dedendum_coef", 1.25) or 1.25)
    alpha_n = float(g.pressure_angle)
    m_t = g.module / math.cos(beta)
    alpha_t = math.atan(math.tan(alpha_n) / math.cos(beta)) if beta else alpha_n
    r = 0.5 * m_t * g.teeth
    rb = r * math.cos(alpha_t)
    ra = r + (ha + x) * g.module
    rf = r - (hf - x) * g.module
    if rf <= 0.0:
        raise InputError.of(_where("gears", i, "teeth"), g.teeth, f"root radius "
                            f"{rf * 1e3:.4g} mm must be > 0 (too few teeth for module "
                            f"{g.module * 1e3:g} mm and dedendum {hf:g})")
    density = STEEL_DENSITY
    mass = _get(g, "mass")
    inertia = _get(g, "inertia")
    disk_mass = density * math.pi * g.face_width * r * r
    if mass is None:
        mass = disk_mass
    if inertia is None:
        inertia = 0.5 * disk_mass * r * r        # ½ ρ π b r⁴
    return TrainGear(g.name, g.shaft, float(g.position), int(g.teeth), float(g.module),
                     alpha_n, beta, float(g.face_width), x, ha, hf, r, rb, ra, float(inertia),
                     float(mass), np.eye(3))


def _check_gears_on_shafts(gears: Sequence[TrainGear]) -> None:
    """Two gears on one shaft must not overlap axially (face extents)."""
    for i, a in enumerate(gears):
        for j in range(i + 1, len(gears)):
            b = gears[j]
            if a.shaft != b.shaft:
                continue
            gap = abs(a.position - b.position) - 0.5 * (a.face_width + b.face_width)
            if gap < 0.0:
                raise InputError(
                    f"gears[{j}].position_mm = {b.position * 1e3:g}: gear {b.name!r} "
                    f"(face {b.face_width * 1e3:g} mm) intersects gear {a.name!r} "
                    f"(gears[{i}], at {a.position * 1e3:g} mm, face {a.face_width * 1e3:g} "
                    f"mm) on shaft {a.shaft!r} by {-gap * 1e3:.4g} mm: move one of them",
                    field=f"gears[{j}].position_mm", value=b.position * 1e3,
                    allowed=f"faces apart on shaft {a.shaft!r}")


def _pair(i: int, g1: TrainGear, g2: TrainGear) -> GearPair:
    """The GearPair of mesh ``i`` (eq. 11's helix hand from the signed helix angles);
    refuses gears that cannot mesh (module, pressure angle, hands, addendum/dedendum,
    interference, contact ratio), naming ``meshes[i].gears``."""
    where = _where("meshes", i, "gears")
    names = [g1.name, g2.name]
    for what, a, b in (("module_mm", g1.module * 1e3, g2.module * 1e3),
                       ("pressure_angle_deg", math.degrees(g1.pressure_angle),
                        math.degrees(g2.pressure_angle)),
                       ("addendum_coef", g1.addendum_coef, g2.addendum_coef),
                       ("dedendum_coef", g1.dedendum_coef, g2.dedendum_coef)):
        if not math.isclose(a, b, rel_tol=1e-12, abs_tol=0.0):
            raise InputError(f"{where} = {names}: the gears' {what} differ ({a:g} and {b:g});"
                             " meshing gears need the same", field=where, value=names,
                             allowed=f"equal {what}")
    b1, b2 = g1.helix_angle, g2.helix_angle
    if not math.isclose(b1, -b2, rel_tol=1e-12, abs_tol=1e-15):
        raise InputError(f"{where} = {names}: helix_angle_deg {math.degrees(b1):g} and "
                         f"{math.degrees(b2):g}; an external helical pair has opposite hands "
                         "(equal size, opposite signs; both 0 for spur)", field=where,
                         value=names, allowed="opposite helix angles")
    hand = -1 if b1 > 0.0 else 1     # eq. (11): hand = +1 is a left-hand gear 1 (gears.pair)
    try:
        pair = GearPair(teeth=(g1.teeth, g2.teeth), module=g1.module,
                        pressure_angle=g1.pressure_angle,
                        face_width=min(g1.face_width, g2.face_width), helix_angle=abs(b1),
                        hand=hand, profile_shift=(g1.profile_shift, g2.profile_shift),
                        addendum_coef=g1.addendum_coef, dedendum_coef=g1.dedendum_coef)
        pair.check_mesh()
    except InputError as exc:
        raise InputError(f"{where} = {names}: {exc}", field=where, value=names,
                         allowed=exc.allowed) from exc
    return pair


def _global_vector(pair: GearPair, angle: float, sense: int) -> tuple[np.ndarray, np.ndarray]:
    """(frame, vector): the gear-pair frame of Fig. 1 turned by ``angle`` about z, and
    eq. (11) (:meth:`GearPair.line_of_action_vector`) rotated into the global frame
    (each 3-block of translations and rotations by the frame)."""
    frame = rotation_z(angle) @ pair.frame(sense)
    local = pair.line_of_action_vector(sense)
    vector = np.concatenate([frame @ local[3 * j:3 * j + 3] for j in range(4)])
    return frame, vector


@dataclass
class _Graph:
    """The shafts joined by meshes: adjacency in mesh order."""

    shaft_of: dict[str, str]
    edges: list[tuple[int, str, str]]       # (mesh index, shaft of gear 1, of gear 2)

    def around(self, shaft: str) -> list[tuple[int, str, str]]:
        """(mesh index, this shaft, the other shaft) of the meshes at ``shaft``."""
        out = []
        for e, a, b in self.edges:
            if a == shaft:
                out.append((e, a, b))
            elif b == shaft:
                out.append((e, b, a))
        return out


class TrainLayout:
    """Shafts, gears and meshes of a train scene with everything derived from them (see
    the module docstring). Build it with :meth:`from_scene`.

    Attributes
    ----------
    shafts : tuple of TrainShaft
        In the order of the scene's ``[[shafts]]``.
    gears : tuple of TrainGear
        In the order of ``[[gears]]``.
    meshes : tuple of TrainMesh
        In the order of ``[[meshes]]``.
    drive : str
        The drive shaft (speed ratio 1, the reference of ``speed_rpm``).
    drive_torque : float
        Input torque T_d (N m).
    load_torques : dict[str, float]
        Static torque taken out at each load shaft (N m), ``share T_d / ρ``.
    shaft_orders : dict[str, tuple[int, ...]]
        The orders of each shaft that the scene's ``[external]`` loads excite (an
        unbalance: order 1), sorted, shafts in the order of ``[[shafts]]``; empty with
        mesh excitation only.
    """

    def __init__(self, shafts: tuple[TrainShaft, ...], gears: tuple[TrainGear, ...],
                 meshes: tuple[TrainMesh, ...], drive: str, drive_torque: float,
                 load_torques: dict[str, float],
                 shaft_orders: dict[str, tuple[int, ...]] | None = None) -> None:
        self.shafts = shafts
        self.gears = gears
        self.meshes = meshes
        self.drive = drive
        self.drive_torque = drive_torque
        self.load_torques = load_torques
        self.shaft_orders = dict(shaft_orders or {})

    # ------------------------------------------------------------------ access
    def shaft(self, name: str) -> TrainShaft:
        """The shaft called ``name``."""
        for s in self.shafts:
            if s.name == name:
                return s
        raise KeyError(name)

    def gear(self, name: str) -> TrainGear:
        """The gear called ``name``."""
        for g in self.gears:
            if g.name == name:
                return g
        raise KeyError(name)

    def gears_on(self, shaft: str) -> tuple[TrainGear, ...]:
        """The gears of ``shaft``, sorted by axial position."""
        return tuple(sorted((g for g in self.gears if g.shaft == shaft),
                            key=lambda g: g.position))

    # ------------------------------------------------------------------ frequencies
    def order_frequencies(self, orders: dict[str, Sequence[int]] | None = None
                          ) -> dict[tuple[str, int], Fraction]:
        """``{(shaft, k): k ρ_s}``: the frequency (over the drive speed, exact) of each
        excited order ``k`` of each shaft (``orders``, default :attr:`shaft_orders`)."""
        orders = self.shaft_orders if orders is None else orders
        return {(s, int(k)): int(k) * self.shaft(s).speed_ratio
                for s, ks in orders.items() for k in ks}

    def hunting_fundamental(self, orders: dict[str, Sequence[int]] | None = None
                            ) -> Fraction:
        """The train's fundamental over the drive speed (exact): the largest r of which
        every mesh frequency ``Z_1 ρ_1`` and every excited shaft-order frequency ``k ρ_s``
        (``orders``, default :attr:`shaft_orders`) is an integer multiple (docs/theory.md
        §14.1); the response repeats after 2π/(r Ω). With mesh excitation only, the
        meshes' common submultiple."""
        values = [m.frequency_ratio for m in self.meshes]
        values += list(self.order_frequencies(orders).values())
        return _fraction_gcd(values)

    def periodic_indices(self, mesh_harmonics: int, sideband_order: int = 0,
                         orders: dict[str, Sequence[int]] | None = None
                         ) -> tuple[int, ...]:
        """The harmonic indices over :meth:`hunting_fundamental` that the excitations
        need: every ``|Σ_e m_e p_e + c|`` with ``|m_e| <= mesh_harmonics`` (p_e the mesh's
        index ``Z ρ / r``; the combinations the meshes' products create) and ``c`` a
        combination ``Σ ± q_j`` of at most ``max(sideband_order, 1)`` shaft-order indices
        ``q_j = k ρ_s / r`` (the orders themselves and their sidebands around every mesh
        combination; none without shaft orders): the torus set of :func:`hbm.train_basis`
        folded onto one time line, and 0."""
        r = self.hunting_fundamental(orders)
        steps = sorted({int(m.frequency_ratio / r) for m in self.meshes})
        h = int(mesh_harmonics)
        sums = {0}
        for p in steps:
            sums = {s + k * p for s in sums for k in range(-h, h + 1)}
        offsets = {0}
        q = sorted({int(f / r) for f in self.order_frequencies(orders).values()})
        if q:
            frontier = {0}
            for _ in range(max(int(sideband_order), 1)):
                frontier = {c + sign * x for c in frontier for x in q for sign in (1, -1)}
                offsets |= frontier
        return tuple(sorted({abs(s + c) for s in sums for c in offsets}))

    def periodic_aft_samples(self, mesh_harmonics: int, sideband_order: int = 0) -> int:
        """AFT samples per period of the one-dimensional set of :meth:`periodic_indices`
        (:func:`default_n_time` of its largest index)."""
        return default_n_time(max(self.periodic_indices(mesh_harmonics, sideband_order)))

    def check_periodic(self, mesh_harmonics: int, bound: int, sideband_order: int = 0,
                       field: str = "hbm.max_aft_samples") -> int:
        """AFT samples of the periodic set, or an :class:`InputError` naming ``field``
        when they exceed ``bound`` (saying the set size it would need)."""
        idx = self.periodic_indices(mesh_harmonics, sideband_order)
        n = default_n_time(max(idx))
        if n > bound:
            r = self.hunting_fundamental()
            raise InputError(
                f"{field} = {bound}: the hunting period of this train (fundamental "
                f"{r} of the drive speed, {int(self.meshes[0].frequency_ratio / r)} periods "
                f"of mesh {self.meshes[0].name!r}"
                + (", with its shaft orders" if self.shaft_orders else "")
                + ") needs a one-dimensional set of "
                f"{len(idx)} harmonics up to index {max(idx)} and {n} AFT samples per "
                f"period: raise {field} to {n} or use hbm.basis = 'torus'",
                field=field, value=bound, allowed=f">= {n}")
        return n

    # ------------------------------------------------------------------ building
    @classmethod
    def from_scene(cls, scene: Any) -> TrainLayout:
        """The layout of a validated train scene (read by attribute: ``scene.shafts``,
        ``scene.gears``, ``scene.meshes``, ``scene.drive``, ``scene.loads``; SI).

        Raises
        ------
        core.errors.InputError
            Naming the field: an unknown shaft or gear, intersecting gears on one shaft, a
            mesh between gears of one shaft, gears that cannot mesh, a centre distance
            that does not match the gears (both numbers), a shaft placed at two centres
            (both meshes), a torque path that does not close (the shaft).
        """
        shafts_in = list(scene.shafts)
        names = [s.name for s in shafts_in]
        if not names:
            raise InputError.of("shafts", [], "needs at least two [[shafts]]")
        if len(set(names)) != len(names):
            raise InputError.of("shafts", names, "names must be distinct")
        gears = tuple(_gear(i, g, set(names)) for i, g in enumerate(scene.gears))
        gnames = [g.name for g in gears]
        if len(set(gnames)) != len(gnames):
            raise InputError.of("gears", gnames, "names must be distinct")
        _check_gears_on_shafts(gears)
        by_name = {g.name: g for g in gears}
        meshes_in = list(scene.meshes)
        if not meshes_in:
            raise InputError.of("meshes", [], "needs at least one [[meshes]]")
        mnames = [m.name for m in meshes_in]
        if len(set(mnames)) != len(mnames):
            raise InputError.of("meshes", mnames, "names must be distinct")
        pairs, edges = [], []
        for i, m in enumerate(meshes_in):
            where = _where("meshes", i, "gears")
            if len(m.gears) != 2 or any(n not in by_name for n in m.gears):
                raise InputError.of(where, list(m.gears), "must name two gears of [[gears]]: "
                                    + ", ".join(map(repr, gnames)))
            g1, g2 = by_name[m.gears[0]], by_name[m.gears[1]]
            if g1.shaft == g2.shaft:
                raise InputError.of(where, list(m.gears), f"both gears are on shaft "
                                    f"{g1.shaft!r}: a mesh joins gears of two shafts")
            pair = _pair(i, g1, g2)
            given = _get(m, "centre_distance")
            if given is not None and abs(given - pair.centre_distance) > CENTRE_TOLERANCE:
                raise InputError(
                    f"meshes[{i}].centre_distance_mm = {given * 1e3:g}: mesh {m.name!r} of "
                    f"{g1.name!r} ({g1.teeth} teeth) and {g2.name!r} ({g2.teeth} teeth) has "
                    f"the working centre distance a_w = {pair.centre_distance * 1e3:.6g} mm "
                    "(module, teeth, helix, profile shifts); they differ by "
                    f"{abs(given - pair.centre_distance) * 1e3:.4g} mm (allowed 0.001 mm)",
                    field=f"meshes[{i}].centre_distance_mm", value=given * 1e3, unit="mm",
                    allowed=f"{pair.centre_distance * 1e3:.6g} mm")
            pairs.append(pair)
            edges.append((i, g1.shaft, g2.shaft))
        graph = _Graph({g.name: g.shaft for g in gears}, edges)
        drive = scene.drive
        if drive.shaft not in names:
            raise InputError.of("drive.shaft", drive.shaft, "unknown shaft; known: "
                                + ", ".join(map(repr, names)))
        centre, ratio, sense, parent = _place(names, meshes_in, graph, gears, pairs,
                                              drive.shaft)
        shafts = tuple(TrainShaft(n, centre[n], ratio[n], sense[n]) for n in names)
        loads, load_torques = _torque_path(scene, names, meshes_in, graph, pairs, ratio,
                                           parent, by_name)
        tooth = {}
        meshes = []
        for i, m in enumerate(meshes_in):
            g1, g2 = by_name[m.gears[0]], by_name[m.gears[1]]
            pair = pairs[i]
            angle = float(m.angle)
            frame, vector = _global_vector(pair, angle, sense[g1.shaft])
            mode = _get(m, "phase_mode", "geometry")
            if mode == "geometry":
                phase = _geometry_phase(pair, angle, g1, g2, sense, tooth)
            else:
                phase = float(m.phase) % (2.0 * math.pi)
            meshes.append(TrainMesh(
                m.name, (g1.name, g2.name), (g1.shaft, g2.shaft), pair, angle,
                pair.centre_distance, sense[g1.shaft], frame, vector,
                g1.teeth * ratio[g1.shaft], ratio[g1.shaft], phase, mode, loads[i],
                float(m.backlash)))
        return cls(shafts, gears, tuple(meshes), drive.shaft, float(drive.torque),
                   load_torques, _shaft_orders(scene, names))


def _shaft_orders(scene: Any, names: list[str]) -> dict[str, tuple[int, ...]]:
    """The shaft orders ``[external]`` excites (``external.aero[i]``: its ``order``;
    ``external.unbalance[i]``: 1), shafts in table order; an unknown shaft or an order
    < 1 is refused naming the field."""
    ext = _get(scene, "external")
    found: dict[str, set[int]] = {}
    for what, items in (("aero", _get(ext, "aero", ())), ("unbalance",
                                                           _get(ext, "unbalance", ()))):
        for i, item in enumerate(items):
            if item.shaft not in names:
                raise InputError.of(f"external.{what}[{i}].shaft", item.shaft,
                                    "unknown shaft; known: " + ", ".join(map(repr, names)))
            k = _get(item, "order", 1)
            if isinstance(k, bool) or int(k) != k or k < 1:
                raise InputError.of(f"external.{what}[{i}].order", k, "must be an integer "
                                    ">= 1 (an order of the shaft's speed)")
            found.setdefault(item.shaft, set()).add(int(k))
    return {n: tuple(sorted(found[n])) for n in names if n in found}


def _place(names: list[str], meshes: list[Any], graph: _Graph, gears: tuple[TrainGear, ...],
           pairs: list[GearPair], drive: str):
    """Breadth-first from the first shaft: centres (from the mesh angles and working
    centre distances); then from the drive: speed ratios (exact), senses, and the parent
    mesh of each shaft on the torque path. Refuses a shaft placed at two centres
    (naming both meshes), a shaft no mesh reaches, and inconsistent ratios in a loop."""
    by_name = {g.name: g for g in gears}
    centre: dict[str, tuple[float, float]] = {names[0]: (0.0, 0.0)}
    placed_by: dict[str, int] = {}
    queue = deque([names[0]])
    while queue:
        s = queue.popleft()
        for e, here, other in graph.around(s):
            m = meshes[e]
            a = float(m.angle)
            d = pairs[e].centre_distance
            sign = 1.0 if by_name[m.gears[0]].shaft == here else -1.0
            x = centre[here][0] + sign * d * math.cos(a)
            y = centre[here][1] + sign * d * math.sin(a)
            if other not in centre:
                centre[other] = (x, y)
                placed_by[other] = e
                queue.append(other)
            elif math.hypot(x - centre[other][0], y - centre[other][1]) > PLACEMENT_TOLERANCE:
                first = placed_by.get(other)
                who = (f"meshes[{first}] ({meshes[first].name!r})" if first is not None
                       else "being the first shaft")
                raise InputError(
                    f"meshes[{e}].angle_deg = {math.degrees(a):g}: mesh {m.name!r} puts shaft "
                    f"{other!r} at ({x * 1e3:.4f}, {y * 1e3:.4f}) mm, but {who} put it at "
                    f"({centre[other][0] * 1e3:.4f}, {centre[other][1] * 1e3:.4f}) mm "
                    f"({math.hypot(x - centre[other][0], y - centre[other][1]) * 1e3:.4g} mm "
                    "apart; allowed 0.001 mm)", field=f"meshes[{e}].angle_deg",
                    value=math.degrees(a), unit="deg", allowed="a consistent placement")
    for n in names:
        if n not in centre:
            raise InputError(f"shafts: the torque path does not close: shaft {n!r} is not "
                             f"reached by any mesh from shaft {names[0]!r}", field="shafts",
                             value=n, allowed="every shaft joined by meshes")
    ratio: dict[str, Fraction] = {drive: Fraction(1)}
    sense: dict[str, int] = {drive: 1}
    parent: dict[str, list[int]] = {drive: []}
    queue = deque([drive])
    while queue:
        s = queue.popleft()
        for e, here, other in graph.around(s):
            m = meshes[e]
            z_here = by_name[m.gears[0] if by_name[m.gears[0]].shaft == here else m.gears[1]]
            z_other = by_name[m.gears[1] if by_name[m.gears[0]].shaft == here else m.gears[0]]
            r = ratio[here] * Fraction(z_here.teeth, z_other.teeth)
            if other not in ratio:
                ratio[other] = r
                sense[other] = -sense[here]
                parent[other] = [e]
                queue.append(other)
            elif e in parent.get(here, []):
                continue
            elif r != ratio[other] or sense[other] != -sense[here]:
                way = {1: "counter-clockwise", -1: "clockwise"}
                raise InputError(f"meshes[{e}].gears = {list(m.gears)}: the torque path does "
                                 f"not close: mesh {m.name!r} closes a loop at shaft "
                                 f"{other!r}, turning it at {r} of the drive speed "
                                 f"{way[-sense[here]]}, the meshes before at {ratio[other]} "
                                 f"{way[sense[other]]} (the loop locks)",
                                 field=f"meshes[{e}].gears", value=list(m.gears),
                                 allowed="one speed and sense per shaft")
            elif parent[other] and _same_edge(graph, parent[other][0], e):
                if e not in parent[other]:
                    parent[other].append(e)     # a mesh in parallel with the first
            elif e not in parent[other]:
                raise InputError(f"meshes[{e}].gears = {list(m.gears)}: the torque path does "
                                 f"not close: mesh {m.name!r} closes a loop at shaft "
                                 f"{other!r} (the torque split in a loop of shafts is not "
                                 "statically determined)", field=f"meshes[{e}].gears",
                                 value=list(m.gears), allowed="a tree of shafts")
    return centre, ratio, sense, parent


def _same_edge(graph: _Graph, e1: int, e2: int) -> bool:
    """Whether meshes ``e1`` and ``e2`` join the same two shafts."""
    a = {graph.edges[e1][1], graph.edges[e1][2]}
    return a == {graph.edges[e2][1], graph.edges[e2][2]}


def _torque_path(scene: Any, names: list[str], meshes: list[Any], graph: _Graph,
                 pairs: list[GearPair], ratio: dict[str, Fraction],
                 parent: dict[str, list[int]], by_name: dict[str, TrainGear]):
    """Static mesh loads (N) along the tree from the drive (module docstring) and the
    torque at each load shaft (N m)."""
    drive = scene.drive
    loads_in = list(scene.loads)
    if not loads_in:
        raise InputError.of("loads", [], "needs at least one [[loads]] (where the torque "
                            "leaves)")
    share: dict[str, float] = {}
    for i, ld in enumerate(loads_in):
        if ld.shaft not in names:
            raise InputError.of(f"loads[{i}].shaft", ld.shaft, "unknown shaft; known: "
                                + ", ".join(map(repr, names)))
        if ld.shaft == drive.shaft:
            raise InputError.of(f"loads[{i}].shaft", ld.shaft, "is the drive shaft: the "
                                "torque path does not close (a load on another shaft)")
        if ld.shaft in share:
            raise InputError.of(f"loads[{i}].shaft", ld.shaft, "has a load already (one "
                                "[[loads]] per shaft)")
        share[ld.shaft] = float(ld.share)
    total = sum(share.values())
    if abs(total - 1.0) > 1e-9:
        raise InputError.of("loads.share", [float(ld.share) for ld in loads_in],
                            f"the shares sum to {total:g}: must sum to 1")
    children: dict[str, list[str]] = {n: [] for n in names}
    for n in names:
        if n != drive.shaft:
            e = parent[n][0]
            a, b = graph.edges[e][1], graph.edges[e][2]
            children[a if b == n else b].append(n)

    def subtree(n: str) -> float:
        return share.get(n, 0.0) + sum(subtree(c) for c in children[n])

    loads = [0.0] * len(meshes)
    for n in names:
        if n == drive.shaft:
            continue
        carried = subtree(n)
        up = [e for e in parent[n]]
        widths = [pairs[e].face_width for e in up]
        for e, w in zip(up, widths, strict=True):
            m = meshes[e]
            g1, g2 = by_name[m.gears[0]], by_name[m.gears[1]]
            upstream = g1 if g1.shaft != n else g2
            if upstream is not g1 and carried > 0.0:
                raise InputError(f"meshes[{e}].gears = {list(m.gears)}: gear 1 drives gear 2 "
                                 f"(eq. 11 order), but the torque flows from {g2.name!r} "
                                 f"(shaft {g2.shaft!r}) to {g1.name!r}: swap them",
                                 field=f"meshes[{e}].gears", value=list(m.gears),
                                 allowed="[driving gear, driven gear]")
            torque = carried * drive.torque / float(ratio[upstream.shaft]) * w / sum(widths)
            loads[e] = torque / upstream.base_radius
    load_torques = {n: s * drive.torque / float(ratio[n]) for n, s in share.items()}
    return loads, load_torques


def _geometry_phase(pair: GearPair, angle: float, g1: TrainGear, g2: TrainGear,
                    sense: dict[str, int], tooth: dict[str, float]) -> float:
    """Mesh phase at t = 0 from the tooth positions (T.44, :func:`gears.train.mesh_phase`).

    Angles on a gear are measured from the global x axis, positive in its sense of
    rotation. A gear whose teeth no earlier mesh placed has a tooth centreline on the
    global x axis at t = 0 (the assembly datum); the mesh's phase is computed on a gear
    already placed (gear 1 first), and the mate's tooth angle then follows from the mesh
    (the phase grows by Z φ as either gear turns by φ), so a gear in two meshes (an
    idler) carries the phasing of the first into the second (T.45)."""
    two_pi = 2.0 * math.pi
    centre = {1: angle, 2: angle + math.pi}      # line of centres towards the mate
    gear = {1: g1, 2: g2}
    k = 1 if g1.name in tooth or g2.name not in tooth else 2
    g = gear[k]
    s = sense[g.shaft]
    phase = mesh_phase(pair, k, (s * centre[k]) % two_pi, tooth.get(g.name, 0.0))
    tooth.setdefault(g.name, 0.0)
    o = 3 - k
    mate = gear[o]
    if mate.name not in tooth:
        so = sense[mate.shaft]
        base = mesh_phase(pair, o, (so * centre[o]) % two_pi, 0.0)
        tooth[mate.name] = ((phase - base) % two_pi) / mate.teeth
    return phase
