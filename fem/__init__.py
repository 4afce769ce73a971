"""DOLFINx (0.5) linear structural model of geared machines, eq. (4).

P2 elasticity with a material per volume, extra 6-DOF nodes, rigid links (RBE2),
distributing links (RBE3-type) and clamps eliminated exactly by a prolongation P
(K_bar = P^T K P), lumped masses and springs, the pump's named nodes, and the seats and
mounts of any housing (:mod:`fem.housing`). Matrices stay distributed PETSc ``Mat``
objects. The gear-pair frame and the line-of-action
vector G (Fig. 1, eq. 11) come from :mod:`gears.pair`. See docs/fem.md.
"""

from .dense import dense_projection
from .eigen import eigenfrequencies
from .gearbox import (
    GearboxBearing,
    GearboxDrive,
    GearboxGear,
    GearboxLoad,
    build_gearbox_model,
    gearbox_materials,
    gearbox_spec,
)
from .housing import (
    MountSupport,
    SurfaceWeights,
    add_mounts,
    add_seats,
    housing_spec,
    surface_weights,
)
from .lumped import axial_spring, disk_mass, rigid_body_mass, two_node
from .materials import ALUMINIUM, CAST_IRON, STEEL, Material
from .mesh import FEMesh, gmsh_physical_groups, load_gmsh_mesh, load_meshed_model
from .model import FEModel, build_model
from .prolongation import Prolongation, build_prolongation
from .pump import (
    BearingParams,
    DriveParams,
    GearParams,
    LinkParams,
    MaterialParams,
    RotorParams,
    build_pump_model,
    pump_spec,
)
from .spec import Link, Lumped, ModelSpec, Node

__all__ = [
    "ALUMINIUM",
    "CAST_IRON",
    "STEEL",
    "BearingParams",
    "DriveParams",
    "FEMesh",
    "GearboxBearing",
    "GearboxDrive",
    "GearboxGear",
    "GearboxLoad",
    "FEModel",
    "GearParams",
    "Link",
    "LinkParams",
    "Lumped",
    "Material",
    "MaterialParams",
    "ModelSpec",
    "MountSupport",
    "Node",
    "Prolongation",
    "RotorParams",
    "SurfaceWeights",
    "add_mounts",
    "add_seats",
    "axial_spring",
    "build_gearbox_model",
    "build_model",
    "build_prolongation",
    "build_pump_model",
    "dense_projection",
    "disk_mass",
    "eigenfrequencies",
    "gearbox_materials",
    "gearbox_spec",
    "gmsh_physical_groups",
    "housing_spec",
    "load_gmsh_mesh",
    "load_meshed_model",
    "pump_spec",
    "rigid_body_mass",
    "surface_weights",
    "two_node",
]
