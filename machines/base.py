"""The machine contract: what a machine is to the rest of geardyn.

A *machine* is what a scene describes: its gear bodies, the gear meshes between them,
its shafts and their speeds, the named nodes where external loads act and its named
parts; and what it builds for the pipeline — an FE machine (:class:`machines.fe.FEMachine`)
its mesh, FE model, ROM and the forcing on the reduced coordinates, a lumped machine
(:class:`LumpedMachine`) its linear system directly. Everything downstream (the hbm
problem, the cache keys, the outputs) asks the machine instead of knowing the pump.

One class per kind of machine behind this one contract, chosen by the scene's
``scene.kind`` through :mod:`machines.registry` (sfepy's one class per term or solver
kind behind one interface, pyHarm's factory per concept keyed by a type string).

Frames and DOF (docs/architecture.md "Units and frames"): each gear body has 6 DOF,
translations then rotations, expressed in the body's ``frame`` (a rotation whose
columns are the local axes in the global frame). A mesh's ``vector`` is eq. (11) on the
12 DOF of its two bodies (body 1's six, then body 2's), in their frames: the relative
approach along the line of action is ``Δ = vectorᵀ (q_1, q_2)``. Speeds are exact
ratios (:class:`fractions.Fraction`) to the reference shaft's speed Ω.

A machine is built from a validated scene (``study.scene.data.Scene``, read by attribute:
this package imports nothing of :mod:`study`) and refuses bad input with
:class:`core.errors.InputError`.
"""
from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any, ClassVar

import numpy as np

from core.errors import InputError

__all__ = ["Shaft", "GearBody", "GearMeshSpec", "Part", "LinearModel", "Machine",
           "LumpedMachine", "check_contract"]


@dataclass(frozen=True)
class Shaft:
    """A shaft and its speed.

    Attributes
    ----------
    name : str
        Name used by the scene (``in``, ``out``) and in node names (``in/gear``).
    speed_ratio : Fraction
        Its speed over the reference shaft's (exact, > 0; magnitudes: the sense of
        rotation is in the bodies' frames and the meshes' vectors).
    """

    name: str
    speed_ratio: Fraction


@dataclass(frozen=True, eq=False)
class GearBody:
    """A gear on a shaft, one rigid body with 6 DOF.

    Attributes
    ----------
    name : str
        The body's name (for an FE machine, the name of its 6-DOF node in the FE model).
    shaft : str
        The shaft it turns with.
    node : str or None
        Its 6-DOF node of the FE model (None for a lumped body without one).
    teeth : int
        Tooth count Z.
    base_radius : float
        Base radius r_b (m).
    frame : numpy.ndarray (3, 3)
        Rotation whose columns are the axes its 6 DOF are expressed in (global frame);
        for the pump the gear-pair frame of Fig. 1 (:func:`gears.pair.pair_frame`).
    """

    name: str
    shaft: str
    node: str | None
    teeth: int
    base_radius: float
    frame: np.ndarray


@dataclass(frozen=True, eq=False)
class GearMeshSpec:
    """A gear mesh between two bodies, as the machine defines it (the hbm element, with
    the scene's stiffness, transmission error and backlash, is built from it).

    Attributes
    ----------
    name : str
        Label of the mesh (outputs, messages).
    bodies : (str, str)
        Gear 1 (driving) and gear 2, in the order of eq. (11).
    vector : numpy.ndarray (12,)
        Line-of-action vector of eq. (11) on (body 1's 6 DOF, body 2's 6 DOF), in their
        frames (:func:`gears.pair.line_of_action_vector`), m per unit DOF.
    teeth : int
        Tooth count of gear 1.
    speed_ratio : Fraction
        Speed of gear 1's shaft over the reference speed.
    """

    name: str
    bodies: tuple[str, str]
    vector: np.ndarray
    teeth: int
    speed_ratio: Fraction

    @property
    def frequency_ratio(self) -> Fraction:
        """Mesh frequency over the reference shaft frequency, ``Z_1 ρ_1`` (exact)."""
        return self.teeth * Fraction(self.speed_ratio)


@dataclass(frozen=True)
class Part:
    """A named volume of the machine (its material, its field).

    Attributes
    ----------
    name : str
        Volume (physical group) name.
    radiates : bool
        True for the one part whose outer surface radiates (ERP, radiation matrix) and
        whose displacement field is written (the pump's housing).
    """

    name: str
    radiates: bool = False


@dataclass
class LinearModel:
    """The linear part hbm solves: ``M q̈ + C q̇ + K q + Σ_e g_e f_e = f(t)``.

    Attributes
    ----------
    M, C, K : numpy.ndarray (n, n)
        Mass, damping and stiffness (without the meshes), SI.
    G : numpy.ndarray (n, E)
        One direction per gear mesh of the machine, in the order of
        :attr:`Machine.gear_meshes` (eq. 11 in these coordinates).
    constant : dict[int or Fraction, numpy.ndarray]
        Forcing per frequency ratio of the reference speed (complex (n,) vectors, N):
        an order of the reference shaft, or ``k ρ_s`` (exact) for order k of a shaft
        turning at ``ρ_s Ω``; 0 the static load.
    omega_squared : dict[int or Fraction, numpy.ndarray]
        Forcing proportional to Ω² per frequency ratio (N s²), e.g. unbalance.
    """

    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    G: np.ndarray
    constant: dict[int, np.ndarray]
    omega_squared: dict[int, np.ndarray] = field(default_factory=dict)

    @property
    def n_dof(self) -> int:
        """Number of coordinates."""
        return self.M.shape[0]


class Machine(ABC):
    """A machine of a scene (see the module docstring).

    Class attributes
    ----------------
    kind : str
        The ``scene.kind`` that selects this class (:mod:`machines.registry`).
    model : str or None
        For a kind with several models, the model name the scene section named after
        the kind gives (``[lumped] model = "sdof"``); None otherwise.
    summary : str
        One line for the scene schema's documentation of ``scene.kind``.
    stages : tuple of str
        The cached stages it runs before hbm (``("mesh", "fe", "rom")`` for an FE
        machine, none for a lumped one).
    linear_stage : str
        The stage whose key the hbm stage's key takes (``"rom"`` or ``"linear"``).

    Parameters
    ----------
    scene : study.scene.data.Scene
        A validated scene (read by attribute).
    """

    kind: ClassVar[str]
    model: ClassVar[str | None] = None
    summary: ClassVar[str] = ""
    stages: ClassVar[tuple[str, ...]] = ()
    linear_stage: ClassVar[str]

    def __init__(self, scene: Any) -> None:
        self.scene = scene

    # ------------------------------------------------------------------ what it is
    @property
    @abstractmethod
    def shafts(self) -> tuple[Shaft, ...]:
        """The shafts; one has speed ratio 1 (the reference, the scene's speed)."""

    @property
    @abstractmethod
    def gear_bodies(self) -> tuple[GearBody, ...]:
        """The gear bodies, in the order of their DOF in the model (6 each)."""

    @property
    @abstractmethod
    def gear_meshes(self) -> tuple[GearMeshSpec, ...]:
        """The gear meshes, in the order of the model's directions (columns of G)."""

    @property
    @abstractmethod
    def load_nodes(self) -> tuple[str, ...]:
        """Named nodes where external loads act (their basis rows are kept with the ROM)."""

    @property
    @abstractmethod
    def parts(self) -> tuple[Part, ...]:
        """Named volumes (empty for a lumped machine)."""

    @abstractmethod
    def static_mesh_loads(self) -> tuple[float, ...]:
        """Static load F_s (N) transmitted by each mesh (the torque path), in the order
        of :attr:`gear_meshes`."""

    @abstractmethod
    def mean_mesh_stiffness(self) -> tuple[float, ...]:
        """Mean stiffness k̄ (N/m) of each mesh (eq. 17), in the order of
        :attr:`gear_meshes`."""

    # ------------------------------------------------------------------ cache keys
    @abstractmethod
    def stage_inputs(self, stage: str) -> dict[str, Any]:
        """Exactly the scene values stage ``stage`` depends on (hashed into its key,
        besides the key of the stage before it)."""

    @abstractmethod
    def stage_code(self, stage: str) -> tuple[str, ...]:
        """The modules/packages whose source computes stage ``stage`` (hashed too)."""

    def check(self) -> None:
        """Refuse what the schema cannot see (raises :class:`core.errors.InputError`);
        called when the scene is loaded. Default: nothing to add."""
        return None

    # ------------------------------------------------------------------ derived
    @property
    def reference_shaft(self) -> Shaft:
        """The first shaft turning at the reference speed (ratio 1)."""
        return next(s for s in self.shafts if s.speed_ratio == 1)

    @property
    def radiating_part(self) -> str | None:
        """Name of the part whose surface radiates and whose field is written, or None."""
        return next((p.name for p in self.parts if p.radiates), None)

    def shaft(self, name: str) -> Shaft:
        """The shaft called ``name``."""
        for s in self.shafts:
            if s.name == name:
                return s
        raise InputError.of("shaft", name, "unknown shaft; known: "
                            + ", ".join(repr(s.name) for s in self.shafts))

    def body(self, name: str) -> GearBody:
        """The gear body called ``name``."""
        for b in self.gear_bodies:
            if b.name == name:
                return b
        raise InputError.of("gear body", name, "unknown gear body; known: "
                            + ", ".join(repr(b.name) for b in self.gear_bodies))

    def directions(self) -> np.ndarray:
        """``(6 n_bodies, E)``: each mesh's ``vector`` placed on the rows of its two
        bodies (6 per body, in the order of :attr:`gear_bodies`), zero elsewhere — the G
        of the physical gear DOF q_c that an FE model gets (eq. 11 per mesh)."""
        index = {b.name: i for i, b in enumerate(self.gear_bodies)}
        G = np.zeros((6 * len(index), len(self.gear_meshes)))
        for e, m in enumerate(self.gear_meshes):
            for j, name in enumerate(m.bodies):
                i = index[name]
                G[6 * i:6 * i + 6, e] = m.vector[6 * j:6 * j + 6]
        return G


class LumpedMachine(Machine):
    """A machine whose linear system is written down directly (no mesh, FE or ROM)."""

    linear_stage: ClassVar[str] = "linear"

    @abstractmethod
    def linear_model(self) -> LinearModel:
        """M, C, K, the meshes' directions and the forcing from the scene's loads."""


def _field(machine: Machine, what: str) -> str:
    return f"{type(machine).__name__}.{what}"


def check_contract(machine: Machine) -> Machine:
    """Refuse a machine whose description does not hold together (names unique and
    known, frames orthonormal, vectors of 12 finite entries, a reference shaft, the
    kinematics of each mesh ``Z_1 ρ_1 = Z_2 ρ_2``, at most one radiating part); returns
    ``machine``. Raises :class:`core.errors.InputError` naming the field."""
    shafts = machine.shafts
    names = [s.name for s in shafts]
    if not names or len(set(names)) != len(names):
        raise InputError.of(_field(machine, "shafts"), names, "must be distinct names, "
                            "at least one")
    for s in shafts:
        if not isinstance(s.speed_ratio, Fraction) or not s.speed_ratio > 0:
            raise InputError.of(_field(machine, f"shafts[{s.name!r}].speed_ratio"),
                                s.speed_ratio, "must be an exact Fraction > 0")
    if not any(s.speed_ratio == 1 for s in shafts):
        raise InputError.of(_field(machine, "shafts"), names, "one shaft must turn at the "
                            "reference speed (speed_ratio 1)")
    bodies = {}
    for b in machine.gear_bodies:
        where = _field(machine, f"gear_bodies[{b.name!r}]")
        if b.name in bodies:
            raise InputError.of(where, b.name, "must be a distinct name")
        if b.shaft not in names:
            raise InputError.of(f"{where}.shaft", b.shaft, "unknown shaft; known: "
                                + ", ".join(map(repr, names)))
        if isinstance(b.teeth, bool) or int(b.teeth) != b.teeth or b.teeth < 1:
            raise InputError.of(f"{where}.teeth", b.teeth, "must be an integer >= 1")
        if not (np.isfinite(b.base_radius) and b.base_radius > 0):
            raise InputError.of(f"{where}.base_radius", b.base_radius, "must be > 0",
                                unit="m")
        R = np.asarray(b.frame, dtype=float)
        if R.shape != (3, 3) or not np.allclose(R.T @ R, np.eye(3), rtol=0, atol=1e-12):
            raise InputError.of(f"{where}.frame", R.tolist(), "must be a 3x3 rotation")
        bodies[b.name] = b
    meshes = set()
    for m in machine.gear_meshes:
        where = _field(machine, f"gear_meshes[{m.name!r}]")
        if m.name in meshes:
            raise InputError.of(where, m.name, "must be a distinct name")
        meshes.add(m.name)
        if len(m.bodies) != 2 or any(n not in bodies for n in m.bodies):
            raise InputError.of(f"{where}.bodies", m.bodies, "must name two gear bodies of "
                                "the machine: " + ", ".join(map(repr, bodies)))
        b1, b2 = (bodies[n] for n in m.bodies)
        if b1.shaft == b2.shaft:
            raise InputError.of(f"{where}.bodies", m.bodies, f"both on shaft {b1.shaft!r}: "
                                "a mesh joins gears of two shafts")
        v = np.asarray(m.vector, dtype=float)
        if v.shape != (12,) or not np.all(np.isfinite(v)):
            raise InputError.of(f"{where}.vector", v.tolist(), "must be 12 finite numbers "
                                "(eq. 11)")
        r1 = machine.shaft(b1.shaft).speed_ratio
        r2 = machine.shaft(b2.shaft).speed_ratio
        if m.teeth != b1.teeth or Fraction(m.speed_ratio) != r1:
            raise InputError.of(f"{where}.teeth", (m.teeth, m.speed_ratio), f"must be gear "
                                f"1's ({b1.teeth}, {r1})")
        if b1.teeth * r1 != b2.teeth * r2:
            raise InputError.of(f"{where}.bodies", m.bodies, f"mesh frequencies differ: "
                                f"{b1.teeth} x {r1} != {b2.teeth} x {r2} (Z1 rho1 = Z2 rho2)")
    nodes = machine.load_nodes
    if len(set(nodes)) != len(nodes):
        raise InputError.of(_field(machine, "load_nodes"), list(nodes), "must be distinct")
    parts = [p.name for p in machine.parts]
    if len(set(parts)) != len(parts):
        raise InputError.of(_field(machine, "parts"), parts, "must be distinct names")
    if sum(p.radiates for p in machine.parts) > 1:
        raise InputError.of(_field(machine, "parts"), parts, "at most one part radiates")
    n_e = len(machine.gear_meshes)
    for what, values in (("static_mesh_loads", machine.static_mesh_loads()),
                         ("mean_mesh_stiffness", machine.mean_mesh_stiffness())):
        if len(values) != n_e:
            raise InputError.of(_field(machine, what), list(values), f"must give one value "
                                f"per gear mesh ({n_e})")
    return machine
