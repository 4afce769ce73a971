"""Load a gmsh model into DOLFINx and share the physical-group names on every rank."""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Any

import numpy as np
from mpi4py import MPI

log = logging.getLogger(__name__)


@dataclass
class FEMesh:
    """A DOLFINx mesh with its tags and physical-group names.

    Attributes
    ----------
    mesh : dolfinx.mesh.Mesh
        Distributed tetrahedral mesh (coordinates in m).
    cell_tags, facet_tags : dolfinx.mesh.MeshTags
        Physical volume / surface tags of the local cells / facets.
    groups : dict[str, tuple[int, int]]
        Physical-group name -> (dimension, tag), identical on every rank.
    centres : dict[str, numpy.ndarray]
        Optional named points (m), identical on every rank (e.g. the
        ``MeshedModel.centres`` of the geometry package).
    """

    mesh: Any
    cell_tags: Any
    facet_tags: Any
    groups: dict[str, tuple[int, int]]
    centres: dict[str, np.ndarray]

    @property
    def comm(self) -> MPI.Comm:
        """The mesh communicator."""
        return self.mesh.comm

    def tag(self, name: str, dim: int) -> int:
        """Tag of physical group ``name`` of dimension ``dim``; ValueError if absent."""
        if name not in self.groups:
            raise ValueError(
                f"group name = {name!r}: not a physical group of the mesh "
                f"(known: {sorted(self.groups)})"
            )
        gdim, tag = self.groups[name]
        if gdim != dim:
            raise ValueError(f"group {name!r} has dimension {gdim}, expected {dim}")
        return int(tag)


def gmsh_physical_groups(model: Any) -> dict[str, tuple[int, int]]:
    """Read every named physical group of a live gmsh model.

    Parameters
    ----------
    model : gmsh.model
        The live model (only meaningful on the rank that holds it).

    Returns
    -------
    dict[str, tuple[int, int]]
        name -> (dimension, tag); unnamed groups are skipped.
    """
    groups: dict[str, tuple[int, int]] = {}
    for dim, tag in model.getPhysicalGroups():
        name = model.getPhysicalName(dim, tag)
        if name:
            groups[name] = (int(dim), int(tag))
    return groups


def load_gmsh_mesh(
    model: Any = None,
    comm: MPI.Comm = MPI.COMM_WORLD,
    rank: int = 0,
    groups: dict[str, tuple[int, int]] | None = None,
    centres: dict[str, np.ndarray] | None = None,
) -> FEMesh:
    """Distribute the live gmsh model held by ``rank`` as a DOLFINx mesh.

    Parameters
    ----------
    model : gmsh.model, optional
        The live gmsh model on ``rank`` (default: ``gmsh.model``); ignored elsewhere.
    comm : MPI communicator
    rank : int
        Rank holding the gmsh model.
    groups : dict, optional
        name -> (dim, tag) on ``rank``; read from the gmsh model when omitted.
    centres : dict, optional
        name -> point (m) on ``rank``; broadcast as is.

    Returns
    -------
    FEMesh
        Mesh, cell and facet tags, and the name maps broadcast to all ranks.
    """
    import gmsh
    from dolfinx.io import gmshio

    if model is None:
        model = gmsh.model
    if comm.rank == rank and groups is None:
        groups = gmsh_physical_groups(model)
    groups = comm.bcast(groups if comm.rank == rank else None, root=rank)
    centres = comm.bcast(centres if comm.rank == rank else None, root=rank) or {}
    mesh, cell_tags, facet_tags = gmshio.model_to_mesh(model, comm, rank, gdim=3)
    if mesh.topology.cell_name() != "tetrahedron":
        raise ValueError(f"mesh cell type = {mesh.topology.cell_name()!r}: must be tetrahedron")
    mesh.topology.create_connectivity(2, 3)
    centres = {k: np.asarray(v, dtype=float).reshape(3) for k, v in centres.items()}
    n_cells = comm.allreduce(mesh.topology.index_map(3).size_local, op=MPI.SUM)
    log.info("loaded gmsh mesh: %d cells, %d groups", n_cells, len(groups))
    return FEMesh(mesh, cell_tags, facet_tags, dict(groups), centres)


def load_meshed_model(meshed: Any, comm: MPI.Comm = MPI.COMM_WORLD, rank: int = 0) -> FEMesh:
    """Distribute a ``geometry.MeshedModel`` (its gmsh model must still be alive).

    Parameters
    ----------
    meshed : geometry.MeshedModel or None
        Needs ``groups`` (name -> (dim, tag)) and ``centres`` (name -> xyz, m) on
        ``rank``; other ranks may pass None.
    comm, rank : see :func:`load_gmsh_mesh`.
    """
    groups = centres = None
    if comm.rank == rank:
        groups = {k: (int(v[0]), int(v[1])) for k, v in meshed.groups.items()}
        centres = dict(meshed.centres)
    return load_gmsh_mesh(None, comm, rank, groups=groups, centres=centres)
