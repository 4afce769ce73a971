"""The pump of the paper as an FEModel: named nodes, links, bearings, gears, drive.

Node names (the contract with ``reduction`` and ``study``), for s in ("in", "out"):
``{s}/gear`` (linked to ``{s}/hub``; DOF in the gear-pair frame of Fig. 1),
``{s}/bearing_a|b`` (linked to the journal seats), ``housing/bore_{s}_a|b``
(linked to the bores, joined to the shaft bearing nodes by bearing springs),
``{s}/station_1..6`` and ``{s}/coupling``; with lumped rotors (:class:`RotorParams`)
also ``{s}/rotor`` (rotation about the shaft axis only), and with a rim on a web
``{s}/body`` (linked to ``{s}/hub`` in place of ``{s}/gear``, which is then the rim).
``housing/feet`` is clamped.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from mpi4py import MPI

from gears.pair import line_of_action_vector, pair_frame

from .lumped import axial_spring, disk_mass, rigid_body_mass
from .materials import Material
from .mesh import FEMesh, load_meshed_model
from .model import FEModel, build_model
from .spec import ModelSpec, check_link_kind

log = logging.getLogger(__name__)

SHAFTS = ("in", "out")
N_STATIONS = 6
#: The gear bodies' nodes, gear 1 (driving) then gear 2: the order of ``gear_dofs``.
GEAR_NODES = tuple(f"{s}/gear" for s in SHAFTS)
#: The :class:`RotorParams` fields of a rim on a web (all set or none).
WEB_FIELDS = ("rim_inertia", "rim_mass", "web_torsional_stiffness", "web_radial_stiffness")


def _check(cls: str, name: str, value: float, lo: float, hi: float = math.inf,
           lo_open: bool = True) -> None:
    ok = math.isfinite(value) and (value > lo if lo_open else value >= lo) and value < hi
    if not ok:
        rng = f"{'(' if lo_open else '['}{lo}, {hi})"
        raise ValueError(f"{cls}.{name} = {value}: must be in {rng}")


@dataclass(frozen=True)
class MaterialParams:
    """Shaft and housing materials (Pa, -, kg/m^3). Defaults: steel, cast iron."""

    shaft_E: float = 210e9
    shaft_nu: float = 0.3
    shaft_rho: float = 7850.0
    housing_E: float = 110e9
    housing_nu: float = 0.28
    housing_rho: float = 7200.0

    def __post_init__(self) -> None:
        for part in ("shaft", "housing"):
            _check("materials", f"{part}_E", getattr(self, f"{part}_E"), 0.0)
            _check("materials", f"{part}_nu", getattr(self, f"{part}_nu"), -1.0, 0.5)
            _check("materials", f"{part}_rho", getattr(self, f"{part}_rho"), 0.0)

    def by_volume(self) -> dict[str, Material]:
        """Volume group name -> Material."""
        shaft = Material(self.shaft_E, self.shaft_nu, self.shaft_rho)
        housing = Material(self.housing_E, self.housing_nu, self.housing_rho)
        return {"shaft_in": shaft, "shaft_out": shaft, "housing": housing}


@dataclass(frozen=True)
class GearParams:
    """Gear pair of Table 1 (SI: m, rad, kg/m^3); blanks are rigid disks.

    ``outer_radius`` defaults to the tip radius rb / cos(alpha) + 100/76 mm,
    ``bore_radius`` to the hub seat radius of the geometry (16 mm). ``hub_link``: kind
    of the link of hub seat ``{s}/hub`` to the gear node, ``"rigid"`` (RBE2, the
    paper's) or ``"distributing"`` (RBE3-type, no added stiffness; fem.distributing).
    """

    base_radius_1: float = 46.984e-3
    base_radius_2: float = 46.984e-3
    pressure_angle: float = math.radians(20.0)
    helix_angle: float = 0.0
    face_width: float = 0.020
    bore_radius: float = 0.016
    outer_radius: float = 0.0
    density: float = 7850.0
    hub_link: str = "rigid"

    def __post_init__(self) -> None:
        check_link_kind("gears.hub_link", self.hub_link)
        _check("gears", "base_radius_1", self.base_radius_1, 0.0)
        _check("gears", "base_radius_2", self.base_radius_2, 0.0)
        _check("gears", "pressure_angle", self.pressure_angle, 0.0, 0.5 * math.pi, False)
        _check("gears", "helix_angle", self.helix_angle, -0.5 * math.pi, 0.5 * math.pi)
        _check("gears", "face_width", self.face_width, 0.0)
        _check("gears", "bore_radius", self.bore_radius, 0.0, lo_open=False)
        _check("gears", "outer_radius", self.outer_radius, 0.0, lo_open=False)
        _check("gears", "density", self.density, 0.0)
        for i in (1, 2):
            if self.blank_outer_radius(i) <= self.bore_radius:
                raise ValueError(f"gears.bore_radius = {self.bore_radius}: must be < the "
                                 f"outer radius {self.blank_outer_radius(i)} of gear {i}")

    def blank_outer_radius(self, gear: int) -> float:
        """Outer radius (m) of blank ``gear`` (1 or 2)."""
        if self.outer_radius > 0:
            return self.outer_radius
        rb = self.base_radius_1 if gear == 1 else self.base_radius_2
        return rb / math.cos(self.pressure_angle) + 0.100 / 76.0

    def G(self) -> np.ndarray:
        """Projection vector on q_c, eq. (11) (:func:`gears.pair.line_of_action_vector`)."""
        return line_of_action_vector(self.pressure_angle, self.helix_angle,
                                     self.base_radius_1, self.base_radius_2)  # fmt: skip


@dataclass(frozen=True)
class BearingParams:
    """Ball-bearing stiffness between shaft and bore nodes (N/m, N m/rad).

    ``seat_link``: kind of the link of the journal seats ``{s}/bearing_a|b`` to the
    shaft bearing nodes, ``"rigid"`` (RBE2, the paper's) or ``"distributing"``
    (RBE3-type; fem.distributing). The bores stay rigidly linked.
    """

    radial: float = 1.0e8
    axial: float = 2.0e7
    tilting: float = 0.0
    seat_link: str = "rigid"

    def __post_init__(self) -> None:
        check_link_kind("bearings.seat_link", self.seat_link)
        _check("bearings", "radial", self.radial, 0.0)
        _check("bearings", "axial", self.axial, 0.0)
        _check("bearings", "tilting", self.tilting, 0.0, lo_open=False)

    def matrix(self) -> np.ndarray:
        """6x6 stiffness on the relative motion, shaft axis z."""
        return axial_spring(self.radial, self.axial, self.tilting, 0.0, axis=2)


@dataclass(frozen=True)
class LinkParams:
    """Scene section ``[links]``: kinds of the gear-hub and journal-seat links,
    ``"rigid"`` (default) or ``"distributing"``; they reach the model as
    :attr:`GearParams.hub_link` and :attr:`BearingParams.seat_link` (:meth:`apply`).
    Bores, stations and couplings stay rigid."""

    hub: str = "rigid"
    journal: str = "rigid"

    def __post_init__(self) -> None:
        check_link_kind("links.hub", self.hub)
        check_link_kind("links.journal", self.journal)

    def apply(self, gears: GearParams, bearings: BearingParams
              ) -> tuple[GearParams, BearingParams]:
        """``gears`` and ``bearings`` with these link kinds."""
        return (dataclasses.replace(gears, hub_link=self.hub),
                dataclasses.replace(bearings, seat_link=self.journal))


@dataclass(frozen=True)
class DriveParams:
    """Motor torsional stiffness on ``in/coupling`` (to ground, about z, N m/rad) and
    impeller polar inertia (kg m^2) and mass (kg) on ``out/coupling``."""

    motor_torsional_stiffness: float = 2.0e3
    impeller_inertia: float = 2.0e-3
    impeller_mass: float = 0.0

    def __post_init__(self) -> None:
        _check("drive", "motor_torsional_stiffness", self.motor_torsional_stiffness, 0.0)
        _check("drive", "impeller_inertia", self.impeller_inertia, 0.0, lo_open=False)
        _check("drive", "impeller_mass", self.impeller_mass, 0.0, lo_open=False)


@dataclass(frozen=True)
class RotorParams:
    """Lumped rotor parts on each gear (both shafts alike; all zero: none).

    An idealised stand-in for heavy, stiffly held bodies beside the gears, which the
    shaft and housing geometry does not model (docs/theory.md §13.5):

    * ``inertia`` (kg m^2): a rotor on its own node ``{s}/rotor`` that turns about the
      shaft axis only, joined to the gear's rotation by ``torsional_stiffness``
      (N m/rad). It is not grounded, so it carries no static torque (F_s = T/r_b);
    * ``gear_inertia`` (kg m^2) and ``gear_mass`` (kg): polar inertia and mass added
      rigidly on the gear node (hub and rotor end next to the gear);
    * ``lateral_stiffness`` (N/m): a radial spring from the gear node to ground (a
      bearing beside the gear on a rigid seat);
    * ``rim_inertia`` (kg m^2), ``rim_mass`` (kg), ``web_torsional_stiffness`` (N m/rad),
      ``web_radial_stiffness`` (N/m): the teeth on a rim joined to the gear body by a
      web (all four > 0, or all 0: a solid gear). The rim is then the gear node
      ``{s}/gear``, where the mesh acts (a thin ring: polar ``rim_inertia``, half of it
      about a diameter); the web joins it to the body node ``{s}/body``, which the hub
      surface is linked to and which carries ``gear_inertia``, ``gear_mass``, the rotor's
      spring and ``lateral_stiffness``. The solid blank's disk mass is then left out: a
      webbed gear is its rim, its web (massless) and the body parts given. The web's
      axial and tilting stiffness equal its radial and torsional ones; a spur mesh does
      not load them.
    """

    inertia: float = 0.0
    torsional_stiffness: float = 0.0
    gear_inertia: float = 0.0
    gear_mass: float = 0.0
    lateral_stiffness: float = 0.0
    rim_inertia: float = 0.0
    rim_mass: float = 0.0
    web_torsional_stiffness: float = 0.0
    web_radial_stiffness: float = 0.0

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            _check("rotors", f.name, getattr(self, f.name), 0.0, lo_open=False)
        if (self.inertia > 0) != (self.torsional_stiffness > 0):
            raise ValueError(f"rotors.inertia = {self.inertia} and rotors.torsional_stiffness"
                             f" = {self.torsional_stiffness}: both > 0 (a rotor on its "
                             "spring) or both 0 (no rotor)")
        web = [getattr(self, n) > 0 for n in WEB_FIELDS]
        if any(web) and not all(web):
            given = ", ".join(f"rotors.{n} = {getattr(self, n)}" for n in WEB_FIELDS)
            raise ValueError(f"{given}: all > 0 (a rim on a web) or all 0 (a solid gear)")

    @property
    def webbed(self) -> bool:
        """True when the teeth sit on a rim joined to the gear body by a web."""
        return self.web_torsional_stiffness > 0

    def rim_mass_matrix(self) -> np.ndarray:
        """6x6 mass of the rim (kg, kg m^2): a thin ring, half its polar inertia about a
        diameter."""
        j = self.rim_inertia
        return rigid_body_mass(self.rim_mass, [j / 2, j / 2, j])

    def web_stiffness_matrix(self) -> np.ndarray:
        """6x6 stiffness of the web (N/m, N m/rad): axial as radial, tilting as torsional."""
        return axial_spring(self.web_radial_stiffness, self.web_radial_stiffness,
                            tilting=self.web_torsional_stiffness,
                            torsional=self.web_torsional_stiffness)

    def body_node(self, shaft: str) -> str:
        """The node the hub is linked to and the gear parts sit on: ``{shaft}/body``
        with a web, else the gear node ``{shaft}/gear``."""
        return f"{shaft}/body" if self.webbed else f"{shaft}/gear"

    @property
    def active(self) -> bool:
        """True when any part is added."""
        return any(getattr(self, f.name) > 0 for f in dataclasses.fields(self))


def add_rotors(spec: ModelSpec, shaft: str, centre: np.ndarray, rotors: RotorParams) -> None:
    """Add the lumped rotor parts of :class:`RotorParams` (SI) to ``spec`` on node
    ``{shaft}/gear``, or with a web (:attr:`RotorParams.webbed`) on the body node
    ``{shaft}/body`` (added by :func:`pump_spec`) with the rim on ``{shaft}/gear``; the
    rotor node ``{shaft}/rotor`` is placed at ``centre`` (m, the gear centre) and turns
    about the shaft axis z only."""
    gear = rotors.body_node(shaft)
    if rotors.webbed:
        spec.add_mass(f"{shaft}/gear", rotors.rim_mass_matrix())
        spec.add_spring(f"{shaft}/gear", rotors.web_stiffness_matrix(), other=gear)
    if rotors.gear_mass > 0 or rotors.gear_inertia > 0:
        spec.add_mass(gear, rigid_body_mass(rotors.gear_mass, [0.0, 0.0, rotors.gear_inertia]))
    if rotors.lateral_stiffness > 0:
        spec.add_spring(gear, axial_spring(rotors.lateral_stiffness, 0.0))
    if rotors.inertia > 0:
        node = f"{shaft}/rotor"
        spec.add_node(node, centre, fixed=np.array([True] * 5 + [False]))
        spec.add_mass(node, rigid_body_mass(0.0, [0.0, 0.0, rotors.inertia]))
        spec.add_spring(gear, axial_spring(0.0, 0.0, torsional=rotors.torsional_stiffness),
                        other=node)


def pump_spec(
    groups: dict[str, tuple[int, int]],
    centres: dict[str, np.ndarray],
    gears: GearParams,
    bearings: BearingParams,
    drive: DriveParams,
    rotors: RotorParams | None = None,
) -> ModelSpec:
    """Nodes, links, clamp and lumped parts of the pump (see module docstring); the
    hub and journal-seat links of the kinds ``gears.hub_link``, ``bearings.seat_link``."""
    for name in ("housing/feet", *(f"{s}/hub" for s in SHAFTS)):
        if name not in groups:
            raise ValueError(f"groups: missing surface group {name!r}")
    spec = ModelSpec(shared="first")
    frame = pair_frame(gears.pressure_angle)

    def centre(name: str) -> np.ndarray:
        if name not in centres:
            raise ValueError(f"centres: missing {name!r}")
        return np.asarray(centres[name], dtype=float)

    rotors = RotorParams() if rotors is None else rotors
    for i, s in enumerate(SHAFTS, start=1):
        spec.add_node(f"{s}/gear", centre(f"{s}/gear"), frame=frame)
        body = rotors.body_node(s)
        if rotors.webbed:  # the hub carries the gear body; the rim (gear node) is on its web
            spec.add_node(body, centre(f"{s}/gear"), frame=frame)
        spec.add_link(f"{s}/hub", body, kind=gears.hub_link)
        if not rotors.webbed:
            spec.add_mass(f"{s}/gear", disk_mass(gears.blank_outer_radius(i),
                                                 gears.bore_radius, gears.face_width,
                                                 gears.density))
        for end in ("a", "b"):
            shaft_node, bore_node = f"{s}/bearing_{end}", f"housing/bore_{s}_{end}"
            c_shaft, c_bore = centre(shaft_node), centre(bore_node)
            gap = float(np.linalg.norm(c_shaft - c_bore))
            if gap > 1e-3:
                log.warning("bearing %s: shaft and bore centres %.3g m apart", shaft_node, gap)
            spec.add_node(shaft_node, c_shaft)
            spec.add_node(bore_node, c_bore)
            spec.add_link(shaft_node, shaft_node, kind=bearings.seat_link)
            spec.add_link(bore_node, bore_node)
            spec.add_spring(shaft_node, bearings.matrix(), other=bore_node)
        for k in range(1, N_STATIONS + 1):
            name = f"{s}/station_{k}"
            spec.add_node(name, centre(name))
            spec.add_link(name, name)
        spec.add_node(f"{s}/coupling", centre(f"{s}/coupling"))
        spec.add_link(f"{s}/coupling", f"{s}/coupling")
        if rotors.active:
            add_rotors(spec, s, centre(f"{s}/gear"), rotors)
    spec.add_clamp("housing/feet")
    spec.add_torsion_to_ground("in/coupling", drive.motor_torsional_stiffness, [0, 0, 1.0])
    if drive.impeller_inertia > 0 or drive.impeller_mass > 0:
        spec.add_mass("out/coupling", rigid_body_mass(drive.impeller_mass,
                                                      [0.0, 0.0, drive.impeller_inertia]))
    return spec


def build_pump_model(
    meshed: Any,
    materials: MaterialParams | None = None,
    gears: GearParams | None = None,
    bearings: BearingParams | None = None,
    drive: DriveParams | None = None,
    comm: MPI.Comm = MPI.COMM_WORLD,
    quadrature_degree: int | None = None,
    fe_mesh: FEMesh | None = None,
    rotors: RotorParams | None = None,
) -> FEModel:
    """Build the pump's FEModel from a ``geometry.MeshedModel`` (gmsh model alive).

    Parameters
    ----------
    meshed : geometry.MeshedModel or None
        On rank 0 (other ranks may pass None); ignored when ``fe_mesh`` is given.
    materials, gears, bearings, drive : parameter dataclasses (SI units)
    comm : MPI communicator
    quadrature_degree : int, optional
        See :func:`fem.elasticity.assemble_elasticity`.
    fe_mesh : FEMesh, optional
        An already distributed mesh (with ``groups`` and ``centres``).
    rotors : RotorParams, optional
        Lumped rotor parts on the gears (default: none).

    Returns
    -------
    FEModel
        With ``gear_nodes`` = (in/gear, out/gear), ``gear_dofs`` their DOF in the frame
        of Fig. 1 and G of eq. (11) as its one column (one mesh). K is singular by one
        mode: the output shaft's rotation is held only by the gear mesh, which
        ``reduction`` adds (k_m G G^T).
    """
    materials = MaterialParams() if materials is None else materials
    gears = GearParams() if gears is None else gears
    bearings = BearingParams() if bearings is None else bearings
    drive = DriveParams() if drive is None else drive
    if fe_mesh is None:
        fe_mesh = load_meshed_model(meshed, comm)
    spec = pump_spec(fe_mesh.groups, fe_mesh.centres, gears, bearings, drive, rotors)
    mats = {k: v for k, v in materials.by_volume().items() if k in fe_mesh.groups}
    return build_model(fe_mesh, mats, spec, quadrature_degree=quadrature_degree,
                       gear_nodes=GEAR_NODES, G=gears.G()[:, None])  # fmt: skip
