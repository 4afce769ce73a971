"""Plain data handed from ``geometry`` to ``fem``."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .params import MeshOptions, PumpParams, ShaftParams


@dataclass(frozen=True)
class QualityReport:
    """Mesh size and quality of a meshed gmsh model.

    Attributes
    ----------
    min_sicn : float
        Smallest minimum signed inverse condition number (gmsh ``minSICN``) over
        all 3D elements (-; 1 = ideal, <= 0 = inverted).
    n_poor : int
        Number of 3D elements with minimum SICN below ``poor_threshold``.
    poor_threshold : float
        Threshold used for ``n_poor`` (-).
    n_elements : int
        Number of 3D elements (10-node tetrahedra).
    n_nodes : int
        Number of mesh nodes (vertices + edge mid-nodes).
    n_dofs : int
        DOF of a P2 vector field on the mesh = ``3 * n_nodes``.
    per_part : dict[str, dict[str, float]]
        ``{part: {"n_elements", "n_nodes", "min_sicn"}}`` for each physical volume.
    n_straightened : int
        Tets whose curved edges made them nearly flat (min SICN below the
        refusal threshold) and which were made straight-sided instead.
    """

    min_sicn: float
    n_poor: int
    poor_threshold: float
    n_elements: int
    n_nodes: int
    n_dofs: int
    per_part: dict[str, dict[str, float]] = field(default_factory=dict)
    n_straightened: int = 0

    def summary(self) -> str:
        """One line for logs and the CLI."""
        return (f"{self.n_elements} tets (10-node), {self.n_nodes} nodes, {self.n_dofs} P2 "
                f"vector DOF, min SICN {self.min_sicn:.3f}, {self.n_poor} elements below "
                f"{self.poor_threshold:g}, {self.n_straightened} straightened")


@dataclass
class PartEntities:
    """OCC entities of one part, before physical groups are created.

    Attributes
    ----------
    volume : int
        OCC volume tag.
    surfaces : dict[str, list[int]]
        Group name (e.g. ``"in/hub"``) -> OCC surface tags.
    centres : dict[str, np.ndarray]
        Group name -> centreline point (3,) [m] the surface is tied to.
    """

    volume: int
    surfaces: dict[str, list[int]] = field(default_factory=dict)
    centres: dict[str, np.ndarray] = field(default_factory=dict)


@dataclass
class MeshedModel:
    """A meshed gmsh model left alive in the gmsh library.

    Attributes
    ----------
    groups : dict[str, tuple[int, int]]
        Physical-group name -> ``(dim, physical tag)``. Volumes: ``shaft_in``,
        ``shaft_out``, ``housing``; surfaces: see docs/architecture.md.
        The physical tags are the values DOLFINx puts in its cell/facet tags.
    centres : dict[str, np.ndarray]
        Surface-group name -> centreline point (3,) [m]; plus ``{s}/gear``.
    quality : QualityReport
    params : PumpParams or ShaftParams
        The parameters the model was built from.
    mesh_options : MeshOptions
    model_name : str
        Name of the gmsh model (``gmsh.model.setCurrent(model_name)``).
    """

    groups: dict[str, tuple[int, int]]
    centres: dict[str, np.ndarray]
    quality: QualityReport
    params: PumpParams | ShaftParams
    mesh_options: MeshOptions
    model_name: str
    part_volumes: dict[str, float] = field(default_factory=dict)

    def tag(self, name: str) -> int:
        """Physical tag of group ``name`` (``KeyError`` lists the known names)."""
        try:
            return self.groups[name][1]
        except KeyError:
            raise KeyError(f"unknown group {name!r}; known: {sorted(self.groups)}") from None


@dataclass
class ImportedModel:
    """A model built from imported parts (CAD files or volume meshes), alive in gmsh.

    It hands to ``fem`` what :class:`MeshedModel` does (``groups`` and ``centres``, read
    by :func:`fem.load_meshed_model`), plus what was found in the files.

    Attributes
    ----------
    groups : dict[str, tuple[int, int]]
        Physical-group name -> ``(dim, physical tag)``: one volume per part (its name),
        one surface per seat (``{part}/bore_{seat}``) and per mount (``{part}/{mount}``
        or ``{part}/{mount}_{k}`` per patch).
    centres : dict[str, np.ndarray]
        Seat group -> seat centre on its axis [m]; mount group -> area centroid [m].
    quality : QualityReport
    parts : dict[str, Any]
        Part name -> :class:`geometry.cad.ImportedSolid` (box, volume, area, notes).
    seats : dict[str, Any]
        Seat name -> :class:`geometry.locate.SeatReport`.
    mounts : dict[str, Any]
        Mount name -> :class:`geometry.locate.MountReport`.
    mesh_options : MeshOptions or None
        The options of a meshed CAD import; None for a mesh file.
    model_name : str
    part_volumes : dict[str, float]
        Part -> volume of the solid [m^3] (CAD) or of its tetrahedra (mesh file).
    estimated_elements : int
        Tetrahedra estimated before meshing (0 for a mesh file).
    """

    groups: dict[str, tuple[int, int]]
    centres: dict[str, np.ndarray]
    quality: QualityReport
    parts: dict[str, Any]
    seats: dict[str, Any]
    mounts: dict[str, Any]
    mesh_options: MeshOptions | None
    model_name: str
    part_volumes: dict[str, float] = field(default_factory=dict)
    estimated_elements: int = 0

    def tag(self, name: str) -> int:
        """Physical tag of group ``name`` (``KeyError`` lists the known names)."""
        try:
            return self.groups[name][1]
        except KeyError:
            raise KeyError(f"unknown group {name!r}; known: {sorted(self.groups)}") from None

    def seat_groups(self) -> dict[str, str]:
        """Seat name -> its surface group."""
        return {k: r.group for k, r in self.seats.items()}

    def mount_groups(self) -> dict[str, list[str]]:
        """Mount name -> its surface group(s)."""
        return {k: list(r.groups) for k, r in self.mounts.items()}

    def report(self) -> str:
        """What was read and found, one line each (for logs and the CLI)."""
        lines = [p.summary() for p in self.parts.values()]
        lines += [n for p in self.parts.values() for n in p.notes]
        lines += [r.summary() for r in self.seats.values()]
        lines += [r.summary() for r in self.mounts.values()]
        lines.append(f"mesh: {self.quality.summary()}")
        return "\n".join(lines)
