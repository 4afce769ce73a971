"""The gearbox's FE sections -> the FE packages' parameters.

``[housing]`` holds :class:`geometry.GearboxHousingParams` fields (the parametric box)
and the :class:`HousingOptions` (where the housing comes from, the seat links, the
bearing width); ``[mesh]`` a preset and :class:`geometry.MeshOptions` overrides;
``[materials]`` :class:`fem.MaterialParams`. Keys in SI or with a unit suffix
(:mod:`machines.sections`). The shafts, gears and bearings come from the train sections
through :class:`machines.train.layout.TrainLayout`: :func:`gearbox_geometry` places them.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

from core.errors import InputError
from core.units import FE_SUFFIXES
from machines.sections import FEParameterError, convert_section

__all__ = ["HousingOptions", "GearboxFEParams", "gearbox_parameters", "gearbox_geometry",
           "bearing_names", "cad_housing", "mesh_housing"]

#: Housing sources: the parametric box, a CAD file (issue 37's geometry.cad) or an
#: existing volume mesh (geometry.meshfile).
SOURCES = ("parametric", "cad", "mesh")
#: What a housing mesh of 4-node tetrahedra gets (geometry.meshfile.FIRST_ORDER).
FIRST_ORDER = ("refuse", "upgrade")
LINKS = ("rigid", "distributing")


@dataclass(frozen=True)
class HousingOptions:
    """``[housing]`` keys besides the box's dimensions.

    Attributes
    ----------
    source : str
        ``"parametric"`` (the box of :mod:`geometry.gearbox` that follows the shafts),
        ``"cad"`` (``file`` read by :func:`geometry.import_cad`, the seats found by their
        axes from the shafts) or ``"mesh"`` (``file`` an existing volume mesh of ten-node
        tetrahedra, ``.msh``, ``.inp`` or ``.bdf``/``.nas``/``.fem``, kept as it is, the
        seats found the same way on its boundary facets).
    file : str
        The CAD or mesh file (``source = "cad"`` or ``"mesh"``), relative to the working
        directory or absolute.
    unit : str
        Its length unit (``"mm"``).
    first_order : str
        ``source = "mesh"``: ``"refuse"`` a mesh of 4-node tetrahedra, or ``"upgrade"`` it
        with straight mid-edge nodes.
    bore_link, journal_link, hub_link : str
        Links of the bores, the journals and the gear seats to their nodes: ``"rigid"``
        (RBE2) or ``"distributing"`` (RBE3-type).
    bearing_width : float
        Width of every bearing (m): the journal's and the seat's axial extent.
    bore_radii : tuple of float
        CAD or mesh: the bore radius of each shaft's bearings (m), in the order of
        ``[[shafts]]``; default shaft radius + ``bearing_section``.
    feet_y : float
        CAD or mesh: y of the feet's bolted faces (plane normal -y) in the gearbox's
        frame, m.
    offset : tuple of 3 floats
        CAD or mesh: translation of the file's geometry into the gearbox's frame (the first
        shaft on the z axis, the shafts' starts at z = 0), m; empty: none.
    """

    source: str = "parametric"
    file: str = ""
    unit: str = "mm"
    bore_link: str = "rigid"
    journal_link: str = "rigid"
    hub_link: str = "rigid"
    bearing_width: float = 0.015
    bore_radii: tuple[float, ...] = ()
    feet_y: float = math.nan
    offset: tuple[float, ...] = ()
    first_order: str = "refuse"

    def __post_init__(self) -> None:
        if self.source not in SOURCES:
            raise FEParameterError(f"housing.source = {self.source!r}: allowed "
                                   f"{', '.join(map(repr, SOURCES))}")
        for name in ("bore_link", "journal_link", "hub_link"):
            if getattr(self, name) not in LINKS:
                raise FEParameterError(f"housing.{name} = {getattr(self, name)!r}: allowed "
                                       f"{', '.join(map(repr, LINKS))}")
        if not self.bearing_width > 0:
            raise FEParameterError(f"housing.bearing_width = {self.bearing_width!r}: must be "
                                   "> 0 (m)")
        if self.first_order not in FIRST_ORDER:
            raise FEParameterError(f"housing.first_order = {self.first_order!r}: allowed "
                                   f"{', '.join(map(repr, FIRST_ORDER))}")
        if self.source in ("cad", "mesh"):
            what = {"cad": "CAD file (STEP, IGES, BREP)",
                    "mesh": "mesh file (.msh, .inp, .bdf, .nas, .fem)"}[self.source]
            if not self.file:
                raise FEParameterError(f"housing.file = '': source = '{self.source}' needs "
                                       f"the {what}")
            if self.offset and len(self.offset) != 3:
                raise FEParameterError(f"housing.offset = {list(self.offset)}: must be 3 "
                                       "lengths (x, y, z)")
            if not math.isfinite(self.feet_y):
                raise FEParameterError(f"housing.feet_y: source = '{self.source}' needs the "
                                       "y of the feet's bolted faces (feet_y_mm)")


@dataclass(frozen=True)
class GearboxFEParams:
    """The FE parameters of a gearbox scene (geometry's and fem's dataclasses)."""

    housing: Any      # geometry.GearboxHousingParams
    options: HousingOptions
    mesh: Any         # geometry.MeshOptions
    materials: Any    # fem.MaterialParams


def _base(key: str) -> str:
    for suf in sorted(FE_SUFFIXES, key=len, reverse=True):
        if key.endswith("_" + suf):
            return key[: -len(suf) - 1]
    return key


def gearbox_parameters(fe: dict[str, dict]) -> GearboxFEParams:
    """``[housing]``, ``[mesh]``, ``[materials]`` as dataclasses (raises
    :class:`FEParameterError` naming the key). Imports geometry and fem."""
    import fem
    import geometry

    unknown = sorted(set(fe) - {"housing", "mesh", "materials"})
    if unknown:
        raise FEParameterError(f"[{unknown[0]}]: not a section of a gearbox scene (its FE "
                               "sections: [housing], [mesh], [materials])")
    table = dict(fe.get("housing", {}))
    names = {f.name for f in dataclasses.fields(HousingOptions)}
    own = {k: v for k, v in table.items() if _base(k) in names or k in names}
    box = {k: v for k, v in table.items() if k not in own}
    try:
        options = HousingOptions(**convert_section("housing", own, HousingOptions))
        housing = geometry.GearboxHousingParams(
            **convert_section("housing", box, geometry.GearboxHousingParams))
        housing.validate()
        m = dict(fe.get("mesh", {}))
        name = m.pop("preset", "coarse")
        if not isinstance(name, str):
            raise FEParameterError(f"mesh.preset = {name!r}: must be a string")
        opts = geometry.preset(name, **convert_section("mesh", m, geometry.MeshOptions))
        opts.validate()
        mats = fem.MaterialParams(**convert_section("materials", fe.get("materials", {}),
                                                    fem.MaterialParams))
    except FEParameterError:
        raise
    except InputError:
        raise
    except (TypeError, ValueError) as exc:
        raise FEParameterError(f"FE parameters: {exc}") from exc
    return GearboxFEParams(housing, options, opts, mats)


def _placement(options: HousingOptions) -> tuple:
    """(file, unit, offset (m), bore radii (m), feet y (m)) of a CAD or mesh housing."""
    return (options.file, options.unit,
            tuple(options.offset) if options.offset else (0.0, 0.0, 0.0),
            tuple(options.bore_radii), options.feet_y)


def cad_housing(options: HousingOptions) -> Any:
    """The :class:`geometry.CadHousing` of ``[housing]`` with ``source = "cad"``; the file
    is relative to the working directory (or absolute)."""
    import geometry

    return geometry.CadHousing(*_placement(options))


def mesh_housing(options: HousingOptions) -> Any:
    """The :class:`geometry.MeshHousing` of ``[housing]`` with ``source = "mesh"``; the
    file is relative to the working directory (or absolute)."""
    import geometry

    return geometry.MeshHousing(*_placement(options), options.first_order)


def bearing_names(shaft: Any) -> list[str]:
    """``a``/``b`` of each ``[[shafts.bearings]]`` entry (in the table's order), ``a`` at
    the smaller position."""
    order = sorted(range(len(shaft.bearings)), key=lambda j: shaft.bearings[j].position)
    names = [""] * len(order)
    for k, j in enumerate(order):
        names[j] = "ab"[k] if k < 2 else str(k)
    return names


def gearbox_geometry(scene: Any, layout: Any, p: GearboxFEParams) -> Any:
    """:class:`geometry.GearboxParams` of the scene: each shaft at its layout centre, its
    ``length_mm`` and ``diameter_mm``, a journal per bearing (width
    ``housing.bearing_width``), a seat per gear (face width, tip radius of the layout)."""
    import geometry

    shafts = []
    for i, s in enumerate(scene.shafts):
        for key, value in (("length_mm", s.length), ("diameter_mm", s.diameter)):
            if value is None:
                raise InputError.of(f"shafts[{i}].{key}", None, "a gearbox shaft needs its "
                                    "length and diameter (FE)")
        gears = tuple(geometry.GearSeatParams(g.name, g.position, g.face_width, g.tip_radius)
                      for g in layout.gears_on(s.name))
        bearings = tuple(geometry.JournalParams(b.position, p.options.bearing_width)
                         for b in s.bearings)
        shafts.append(geometry.GearboxShaftParams(
            s.name, tuple(layout.shaft(s.name).centre), s.length, 0.5 * s.diameter,
            bearings, gears))
    return geometry.GearboxParams(tuple(shafts), p.housing)
