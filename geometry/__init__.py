"""gmsh (OpenCASCADE) models meshed in 10-node tetrahedra with every region a later
stage needs tagged: the parametric pump (shafts and housing), the parametric gearbox of N
parallel shafts in a housing whose bores follow them (:mod:`geometry.gearbox`, also with
a CAD housing), and imported parts (CAD files or existing volume meshes) with their
bearing seats and mounts found from what a scene states about them.

Never imports dolfinx. See docs/geometry.md for the frame, parameters, group names and
presets, docs/gearbox.md for the gearbox, docs/cad-import.md for imported parts, and
:mod:`geometry.pump` for the hand-over to DOLFINx.

The public names are resolved on first use (PEP 562), so importing the package or
one of its light modules (``geometry.params``) does not load gmsh.
"""
from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

#: public name -> submodule defining it
_WHERE = {
    "CadPart": "cad", "HealOptions": "cad", "LENGTH_UNITS": "cad", "ImportedSolid": "cad",
    "import_part": "cad", "write_step": "cad",
    "build_housing": "housing", "build_box_housing": "housing",
    "build_gearbox": "gearbox", "gear_node": "gearbox", "CadHousing": "gearbox",
    "MeshHousing": "gearbox",
    "GearboxParams": "gearbox_params", "GearboxShaftParams": "gearbox_params",
    "GearboxHousingParams": "gearbox_params", "GearSeatParams": "gearbox_params",
    "JournalParams": "gearbox_params", "Bore": "params", "BoxHousing": "params",
    "import_cad": "imported", "import_mesh": "imported",
    "BearingSeat": "locate", "Mount": "locate", "MountReport": "locate",
    "SeatReport": "locate",
    "MeshPart": "meshfile",
    "write_msh": "io",
    "mesh_volume": "meshing",
    "ImportedModel": "model", "MeshedModel": "model", "PartEntities": "model",
    "QualityReport": "model",
    "SHAFT_NAMES": "params", "HousingParams": "params", "MeshOptions": "params",
    "PumpParams": "params", "ShaftParams": "params", "preset": "params",
    "build_pump": "pump", "build_single_shaft": "pump",
    "finalize_gmsh": "session", "gmsh_session": "session",
    "build_shaft": "shaft",
    "housing_volume": "volumes", "part_volumes": "volumes", "shaft_volume": "volumes",
}

__all__ = [
    "LENGTH_UNITS",
    "Bore",
    "BoxHousing",
    "CadHousing",
    "MeshHousing",
    "GearSeatParams",
    "GearboxHousingParams",
    "GearboxParams",
    "GearboxShaftParams",
    "JournalParams",
    "build_box_housing",
    "build_gearbox",
    "gear_node",
    "BearingSeat",
    "CadPart",
    "HealOptions",
    "HousingParams",
    "ImportedModel",
    "ImportedSolid",
    "MeshPart",
    "Mount",
    "MountReport",
    "SeatReport",
    "MeshOptions",
    "MeshedModel",
    "PartEntities",
    "PumpParams",
    "QualityReport",
    "SHAFT_NAMES",
    "ShaftParams",
    "build_housing",
    "build_pump",
    "build_shaft",
    "build_single_shaft",
    "finalize_gmsh",
    "gmsh_session",
    "housing_volume",
    "import_cad",
    "import_mesh",
    "import_part",
    "mesh_volume",
    "part_volumes",
    "preset",
    "shaft_volume",
    "write_msh",
    "write_step",
]

if TYPE_CHECKING:  # static analysers see the names eagerly
    from .cad import LENGTH_UNITS, CadPart, HealOptions, ImportedSolid, import_part, write_step
    from .gearbox import CadHousing, MeshHousing, build_gearbox, gear_node
    from .gearbox_params import (
        GearboxHousingParams,
        GearboxParams,
        GearboxShaftParams,
        GearSeatParams,
        JournalParams,
    )
    from .housing import build_box_housing, build_housing
    from .imported import import_cad, import_mesh
    from .io import write_msh
    from .locate import BearingSeat, Mount, MountReport, SeatReport
    from .meshfile import MeshPart
    from .meshing import mesh_volume
    from .model import ImportedModel, MeshedModel, PartEntities, QualityReport
    from .params import (
        SHAFT_NAMES,
        Bore,
        BoxHousing,
        HousingParams,
        MeshOptions,
        PumpParams,
        ShaftParams,
        preset,
    )
    from .pump import build_pump, build_single_shaft
    from .session import finalize_gmsh, gmsh_session
    from .shaft import build_shaft
    from .volumes import housing_volume, part_volumes, shaft_volume


def __getattr__(name: str) -> Any:
    module = _WHERE.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{module}", __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_WHERE))
