"""A parallel-shaft gearbox as an FE model: gear bodies on their seats, bearings
between journals and bores, the drive and the loads, the housing's feet clamped.

The groups and centres are :mod:`geometry.gearbox`'s (or, for a CAD housing, the seats
found by :func:`geometry.import_cad` with the same names). Node names, for each shaft
``s``, bearing ``e`` (``a``, ``b``) and gear ``g``:

* ``{s}/gear_{g}`` — the gear body (6 DOF in the global frame), linked to its seat
  ``{s}/seat_{g}`` (rigid, RBE2, by default), carrying the gear's mass and inertia;
  the gear mesh's eq. (11) vector acts on it;
* ``{s}/bearing_{e}`` — linked to the journal ``{s}/bearing_{e}``, joined by the
  bearing's springs (radial, axial; tilting optional) to ``housing/bore_{s}_{e}``, the
  bore's node, linked to the bore rigidly (RBE2) or distributing (RBE3-type, no added
  stiffness), per bearing, through :func:`fem.housing.housing_spec`;
* ``{s}/start``, ``{s}/end`` — the end faces, where the drive and the loads act: the
  drive shaft's ``start`` carries the motor inertia and the motor's torsional stiffness
  to ground (the speed control, as the pump's motor), each load shaft's ``end`` is
  joined by the load's torsional stiffness to the load node ``{s}/load`` (its inertia,
  rotation about the shaft axis only), where the load torque acts;
* ``housing/feet`` clamped.

Everything in SI. The model is singular by no mode: the train's rotation is held by the
meshes (``reduction`` adds ``Σ k̄_e g_e g_eᵀ``) and the motor spring.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from .housing import MountSupport, housing_spec
from .lumped import axial_spring, disk_mass, rigid_body_mass
from .materials import Material
from .mesh import FEMesh
from .model import FEModel, build_model
from .spec import ModelSpec, check_link_kind

log = logging.getLogger(__name__)

__all__ = ["GearboxBearing", "GearboxGear", "GearboxDrive", "GearboxLoad", "gearbox_spec",
           "gearbox_materials", "build_gearbox_model", "gear_body_mass"]


def _check(owner: str, name: str, value: float, lo: float = 0.0, lo_open: bool = False,
           unit: str = "") -> None:
    if isinstance(value, bool) or not isinstance(value, (int, float)) \
            or not math.isfinite(value) or (value <= lo if lo_open else value < lo):
        raise ValueError(f"{owner}.{name} = {value!r}{' ' + unit if unit else ''}: must be a "
                         f"finite number {'>' if lo_open else '>='} {lo:g}")


@dataclass(frozen=True)
class GearboxBearing:
    """A bearing of shaft ``shaft`` (name ``a`` or ``b``): springs on the relative motion
    of journal and bore nodes (N/m, N m/rad), shaft axis z.

    ``journal_link``: link of the journal to its node; ``bore_link``: of the bore to its
    node, ``"rigid"`` (RBE2) or ``"distributing"`` (RBE3-type).
    """

    shaft: str
    name: str
    radial: float
    axial: float
    tilting: float = 0.0
    journal_link: str = "rigid"
    bore_link: str = "rigid"

    def __post_init__(self) -> None:
        owner = f"bearings[{self.shaft}/{self.name}]"
        _check(owner, "radial", self.radial, lo_open=True, unit="N/m")
        _check(owner, "axial", self.axial, lo_open=True, unit="N/m")
        _check(owner, "tilting", self.tilting, unit="N m/rad")
        check_link_kind(f"{owner}.journal_link", self.journal_link)
        check_link_kind(f"{owner}.bore_link", self.bore_link)

    @property
    def journal(self) -> str:
        """The journal's group and node ``{shaft}/bearing_{name}``."""
        return f"{self.shaft}/bearing_{self.name}"

    @property
    def bore(self) -> str:
        """The bore's group and node ``housing/bore_{shaft}_{name}``."""
        return f"housing/bore_{self.shaft}_{self.name}"

    def matrix(self) -> np.ndarray:
        """6x6 stiffness on the relative motion (global frame)."""
        return axial_spring(self.radial, self.axial, self.tilting, 0.0, axis=2)


@dataclass(frozen=True)
class GearboxGear:
    """A gear body: node ``node`` linked to seat ``seat``, with its 6x6 ``mass`` (global
    frame, kg and kg m^2) and the seat link's kind."""

    node: str
    seat: str
    mass: np.ndarray
    link: str = "rigid"

    def __post_init__(self) -> None:
        check_link_kind(f"gears[{self.node}].link", self.link)


def gear_body_mass(mass: float, polar_inertia: float, diametral_inertia: float
                   ) -> np.ndarray:
    """6x6 mass of a gear body about its centre, axis z (kg, kg m^2)."""
    return rigid_body_mass(mass, [diametral_inertia, diametral_inertia, polar_inertia])


def steel_disk_mass(pitch_radius: float, bore_radius: float, width: float,
                    density: float = 7850.0) -> np.ndarray:
    """6x6 mass of a solid steel disk of the pitch radius on its bore (the default gear
    body, :func:`fem.lumped.disk_mass`)."""
    return disk_mass(pitch_radius, bore_radius, width, density)


@dataclass(frozen=True)
class GearboxDrive:
    """The motor on shaft ``shaft``'s start face: its inertia (kg m^2, about z) and its
    torsional stiffness to ground (N m/rad, > 0: it holds the train's rotation)."""

    shaft: str
    motor_inertia: float
    motor_torsional_stiffness: float

    def __post_init__(self) -> None:
        _check("drive", "motor_inertia", self.motor_inertia, unit="kg m^2")
        _check("drive", "motor_torsional_stiffness", self.motor_torsional_stiffness,
               lo_open=True, unit="N m/rad")

    @property
    def node(self) -> str:
        """``{shaft}/start``."""
        return f"{self.shaft}/start"


@dataclass(frozen=True)
class GearboxLoad:
    """A load on shaft ``shaft``'s end face: its inertia (kg m^2) on the node
    ``{shaft}/load``, joined by ``torsional_stiffness`` (N m/rad) to the end face."""

    shaft: str
    inertia: float
    torsional_stiffness: float

    def __post_init__(self) -> None:
        _check(f"loads[{self.shaft}]", "inertia", self.inertia, lo_open=True,
               unit="kg m^2")
        _check(f"loads[{self.shaft}]", "torsional_stiffness", self.torsional_stiffness,
               lo_open=True, unit="N m/rad")

    @property
    def end(self) -> str:
        """``{shaft}/end``."""
        return f"{self.shaft}/end"

    @property
    def node(self) -> str:
        """``{shaft}/load``."""
        return f"{self.shaft}/load"


def gearbox_spec(fe_mesh: FEMesh, gears: Sequence[GearboxGear],
                 bearings: Sequence[GearboxBearing], drive: GearboxDrive | None,
                 loads: Sequence[GearboxLoad] = (),
                 mounts: Mapping[str, MountSupport] | None = None) -> ModelSpec:
    """Nodes, links, springs, masses and clamps of the gearbox (module docstring).

    Parameters
    ----------
    fe_mesh : FEMesh
        With the groups and centres of :mod:`geometry.gearbox`.
    gears, bearings, drive, loads
        See their dataclasses; ``drive`` None for a model without one (tests).
    mounts : mapping, optional
        Mount group -> support; default ``{"housing/feet": clamped}``.
    """
    spec = ModelSpec(shared="first")

    def centre(name: str) -> np.ndarray:
        if name not in fe_mesh.centres:
            raise ValueError(f"centres: missing {name!r} (known: {sorted(fe_mesh.centres)})")
        return np.asarray(fe_mesh.centres[name], dtype=float)

    for g in gears:  # first: their links keep shared DOF
        fe_mesh.tag(g.seat, 2)
        spec.add_node(g.node, centre(g.node))
        spec.add_link(g.seat, g.node, kind=g.link)
        spec.add_mass(g.node, g.mass)
    mounts = {"housing/feet": MountSupport("clamped")} if mounts is None else mounts
    housing_spec(fe_mesh, {b.bore: b.bore_link for b in bearings}, mounts, spec=spec)
    for b in bearings:
        fe_mesh.tag(b.journal, 2)
        c_j, c_b = centre(b.journal), centre(b.bore)
        gap = float(np.linalg.norm(c_j - c_b))
        if gap > 1e-3:
            log.warning("bearing %s: journal and bore centres %.3g m apart", b.journal, gap)
        spec.add_node(b.journal, c_j)
        spec.add_link(b.journal, b.journal, kind=b.journal_link)
        spec.add_spring(b.journal, b.matrix(), other=b.bore)
    z = np.array([0.0, 0.0, 1.0])
    if drive is not None:
        spec.add_node(drive.node, centre(drive.node))
        spec.add_link(drive.node, drive.node)
        spec.add_torsion_to_ground(drive.node, drive.motor_torsional_stiffness, z)
        if drive.motor_inertia > 0:
            spec.add_mass(drive.node, rigid_body_mass(0.0, [0.0, 0.0, drive.motor_inertia]))
    for ld in loads:
        spec.add_node(ld.end, centre(ld.end))
        spec.add_link(ld.end, ld.end)
        spec.add_node(ld.node, centre(ld.end), fixed=np.array([True] * 5 + [False]))
        spec.add_mass(ld.node, rigid_body_mass(0.0, [0.0, 0.0, ld.inertia]))
        spec.add_spring(ld.end, axial_spring(0.0, 0.0, torsional=ld.torsional_stiffness),
                        other=ld.node)
    return spec


def gearbox_materials(groups: Mapping[str, tuple[int, int]], shaft: Material,
                      housing: Material) -> dict[str, Material]:
    """Volume group -> material: every ``shaft_*`` volume ``shaft``, ``housing``
    ``housing``."""
    out = {}
    for name, (dim, _) in groups.items():
        if dim != 3:
            continue
        if name.startswith("shaft_"):
            out[name] = shaft
        elif name == "housing":
            out[name] = housing
        else:
            raise ValueError(f"volume group {name!r}: no material (shaft_* or housing)")
    return out


def build_gearbox_model(fe_mesh: FEMesh, materials: Mapping[str, Material],
                        gears: Sequence[GearboxGear], bearings: Sequence[GearboxBearing],
                        drive: GearboxDrive | None, loads: Sequence[GearboxLoad] = (),
                        G: np.ndarray | None = None, quadrature_degree: int | None = None,
                        mounts: Mapping[str, MountSupport] | None = None) -> FEModel:
    """The gearbox's :class:`FEModel`: :func:`gearbox_spec` on ``fe_mesh``, gear nodes
    the gears' nodes in their order, ``G`` one eq. (11) column per mesh on them."""
    spec = gearbox_spec(fe_mesh, gears, bearings, drive, loads, mounts)
    return build_model(fe_mesh, dict(materials), spec, quadrature_degree=quadrature_degree,
                       gear_nodes=[g.node for g in gears], G=G)


