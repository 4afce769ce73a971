"""FE machines: a machine that is meshed (gmsh), assembled (DOLFINx) and reduced
(Craig–Bampton) before hbm solves it.

:class:`FEMachine` adds to the contract of :class:`machines.base.Machine` what the
cached stages build: the mesh folder (``mesh`` stage, rank 0), the ``fem.FEModel``
(``fe`` stage, collective under mpirun), the ROM with what the export needs of the FE
model (``rom`` stage, collective; :mod:`machines.rom`) and the forcing on the reduced
coordinates from the scene's loads. The mesh folder holds the machine's mesh file and
``mesh.json`` (physical groups, centres, quality), written and read here for every FE
machine.

Everything that needs gmsh, dolfinx, petsc4py or slepc4py is imported inside the
methods, so that importing this module (or running a lumped scene) loads none of them.
"""
from __future__ import annotations

import dataclasses
import json
from abc import abstractmethod
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from machines.base import LinearModel, Machine

__all__ = ["FEMachine", "MESH_INFO", "write_mesh_info", "load_mesh"]

#: The mesh folder's description of the mesh (groups, centres, quality).
MESH_INFO = "mesh.json"


def write_mesh_info(meshed: Any, folder: Path) -> None:
    """Write ``mesh.json``: the physical groups, the centres of the linked surfaces and
    the scalar quality figures of a ``geometry.MeshedModel``."""
    q = meshed.quality
    info = {"groups": {k: [int(v[0]), int(v[1])] for k, v in meshed.groups.items()},
            "centres": {k: [float(x) for x in np.asarray(v).ravel()]
                        for k, v in meshed.centres.items()},
            "quality": {k: (float(v) if isinstance(v, (int, float, np.number)) else str(v))
                        for k, v in dataclasses.asdict(q).items()
                        if not isinstance(v, (dict, list, tuple))}}
    (Path(folder) / MESH_INFO).write_text(json.dumps(info, indent=1))


def mesh_quality(mesh_dir: Path) -> dict[str, Any]:
    """The quality figures of a mesh folder (``mesh.json``)."""
    return json.loads((Path(mesh_dir) / MESH_INFO).read_text())["quality"]


def load_mesh(mesh_dir: Path, mesh_file: str, comm: Any = None) -> Any:
    """The ``fem.FEMesh`` of a mesh folder, distributed over ``comm`` (default
    ``MPI.COMM_WORLD``; collective): rank 0 reads the mesh file, DOLFINx partitions it."""
    import gmsh
    from mpi4py import MPI

    from fem import load_gmsh_mesh
    from geometry import gmsh_session

    info = json.loads((Path(mesh_dir) / MESH_INFO).read_text())
    groups = {k: (int(v[0]), int(v[1])) for k, v in info["groups"].items()}
    centres = {k: np.asarray(v, dtype=float) for k, v in info["centres"].items()}
    comm = MPI.COMM_WORLD if comm is None else comm
    with gmsh_session():
        gmsh.clear()
        if comm.rank == 0:  # the other ranks receive their cells from rank 0
            gmsh.merge(str(Path(mesh_dir) / mesh_file))
        return load_gmsh_mesh(None, comm, 0, groups=groups, centres=centres)


class FEMachine(Machine):
    """A machine built as an FE model and reduced by Craig–Bampton.

    Class attributes
    ----------------
    mesh_file : str
        Name of the mesh file in the mesh folder (``pump.msh``).

    Subclasses give the description (:class:`machines.base.Machine`), the stage inputs
    and code, and :meth:`build_mesh`, :meth:`build_fe_model`, :meth:`rom_forcing`,
    :attr:`mesh_size`; the rom stage, reading the ROM back and the linear model on it
    are the same for every FE machine (:mod:`machines.rom`).
    """

    stages: ClassVar[tuple[str, ...]] = ("mesh", "fe", "rom")
    linear_stage: ClassVar[str] = "rom"
    mesh_file: ClassVar[str]

    @property
    @abstractmethod
    def mesh_size(self) -> float:
        """Global element size of the mesh (m), the convergence study's knob."""

    @abstractmethod
    def build_mesh(self, folder: Path) -> None:
        """Mesh the machine into ``folder``: :attr:`mesh_file` and ``mesh.json``
        (:func:`write_mesh_info`). Runs on rank 0 only (gmsh)."""

    @abstractmethod
    def build_fe_model(self, mesh_dir: Path, comm: Any = None) -> Any:
        """The ``fem.FEModel`` from a mesh folder, its ``gear_nodes`` the gear bodies'
        nodes (in the order of :attr:`gear_bodies`) and its ``G`` one column per mesh
        (:meth:`directions`); collective on ``comm`` (default ``MPI.COMM_WORLD``)."""

    @abstractmethod
    def rom_forcing(self, rows: dict[str, np.ndarray], n_r: int
                    ) -> tuple[dict[int, np.ndarray], dict[int, np.ndarray]]:
        """External forcing on the reduced coordinates per shaft order: the constant part
        and the Ω²-proportional part ({order: complex (n_r,)}), from the scene's loads
        and the basis rows ``rows[node]`` (6, n_r) of the :attr:`load_nodes`."""

    # ------------------------------------------------------------------ the rom stage
    def build_rom(self, model: Any, folder: Path) -> None:
        """The rom stage into ``folder`` (:func:`machines.rom.reduce_and_store`)."""
        from machines.rom import reduce_and_store

        reduce_and_store(self, model, Path(folder))

    def load_rom(self, rom_dir: Path) -> Any:
        """The cached ROM as :class:`machines.rom.RomData` (dense, no PETSc), with C,
        coupled frequencies and mesh energies for the scene's k̄ and ξ."""
        from machines.rom import load_rom_data

        return load_rom_data(self, Path(rom_dir))

    def linear_model(self, rom: Any) -> LinearModel:
        """The ROM's M, C, K, G and the forcing of :meth:`rom_forcing` on it."""
        const, om2 = self.rom_forcing(rom.node_rows, rom.M.shape[0])
        return LinearModel(rom.M, rom.C, rom.K, rom.G, const, om2)
