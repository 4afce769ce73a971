"""Parametric gmsh (OpenCASCADE) models of the pump: shafts and housing, meshed in
10-node tetrahedra with every region a later stage needs tagged.

Never imports dolfinx. See docs/geometry.md for the frame, parameters, group
names and presets, and :mod:`geometry.pump` for the hand-over to DOLFINx.
"""

from .housing import build_housing
from .io import write_msh
from .meshing import mesh_volume
from .model import MeshedModel, PartEntities, QualityReport
from .params import (
    SHAFT_NAMES,
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

__all__ = [
    "SHAFT_NAMES",
    "HousingParams",
    "MeshOptions",
    "MeshedModel",
    "PartEntities",
    "PumpParams",
    "QualityReport",
    "ShaftParams",
    "build_housing",
    "build_pump",
    "build_shaft",
    "build_single_shaft",
    "finalize_gmsh",
    "gmsh_session",
    "housing_volume",
    "mesh_volume",
    "part_volumes",
    "preset",
    "shaft_volume",
    "write_msh",
]
