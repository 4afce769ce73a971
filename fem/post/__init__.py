"""FE post-processing of a reduced model, computed once with the ROM (docs/fem.md).

* :mod:`fem.post.surface` — a part's exterior and outer-skin P2 facets, their
  ``triangle6`` nodes and frames, geometry node → DOF block;
* :mod:`fem.post.operator` — the reduced-to-field operator ``P T`` and its rows at nodes
  or points;
* :mod:`fem.post.radiation` — the ERP radiation matrix ``W = (PT)ᵀ A (PT)`` and the
  outer-facet rows (``radiation.h5``);
* :mod:`fem.post.fields` — the housing's nodes, cells and rows of ``P T``
  (``housing.h5``), read back in blocks by the export;
* :mod:`fem.post.xdmf` — the XDMF 3 + HDF5 writer (atomic, whole or block by block).

Every function taking DOLFINx objects is collective on the mesh communicator; the files
are written by rank 0 in an order that does not depend on the partition.
"""

from .fields import BLOCK_BYTES, HOUSING_FILE, TET10_VTK, HousingData, housing_data, read_housing
from .operator import field_operator, point_rows
from .radiation import (
    QUADRATURE_DEGREE,
    RADIATION_FILE,
    normal_gram,
    radiation_data,
    read_radiation,
    reduced_radiation_matrix,
    surface_area,
    surface_measure,
)
from .surface import (
    facet_frames,
    facet_geometry_nodes,
    facet_normal_velocity_rows,
    node_blocks,
    outer_surface_facets,
)
from .xdmf import write_xdmf, xdmf_writer

__all__ = [
    "BLOCK_BYTES",
    "HOUSING_FILE",
    "QUADRATURE_DEGREE",
    "RADIATION_FILE",
    "TET10_VTK",
    "HousingData",
    "facet_frames",
    "facet_geometry_nodes",
    "facet_normal_velocity_rows",
    "field_operator",
    "housing_data",
    "node_blocks",
    "normal_gram",
    "outer_surface_facets",
    "point_rows",
    "radiation_data",
    "read_housing",
    "read_radiation",
    "reduced_radiation_matrix",
    "surface_area",
    "surface_measure",
    "write_xdmf",
    "xdmf_writer",
]
