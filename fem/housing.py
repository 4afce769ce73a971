"""A housing's bearing seats and mounts as FE nodes, links, clamps and springs.

What a machine adds for an imported (or parametric) housing, given its surface groups
and centres (``geometry.ImportedModel.groups`` / ``.centres``, through :class:`FEMesh`):

* a 6-DOF node at each seat centre named like the seat's surface group
  (``housing/bore_in_a``, the pump's names), linked to the seat **rigidly** (RBE2: the
  bore ring moves as a rigid body with the node) or **distributing** (RBE3: the node
  follows the area-weighted rigid fit of the bore, which adds no stiffness;
  :mod:`fem.distributing`). Bearing springs join these nodes to the shafts' nodes;
* each mount group **clamped**, or joined to a node at its area centroid (rigidly or
  distributing) that carries a 6x6 diagonal **spring to ground** (rubber mounts, one per
  foot: use ``geometry.Mount(per_patch=True)``).

The distributing link and CalculiX's ``*DISTRIBUTING COUPLING``. For a node at the area
centroid ``x_c = int x dA / A`` of its surface, the translation of the rigid fit is the
area mean of the displacement: with the P2 surface mass ``M_S`` of :mod:`fem.distributing`
the translation rows of ``N^-1 A^T M_S u`` are ``sum_j w_j u_j / sum_j w_j`` with
``w_j = int N_j dA`` (the rows of ``M_S`` sum to ``int N_j dA`` because the shape
functions sum to one, and the translation-rotation block of ``N`` vanishes at ``x_c``).
That is the equation CalculiX imposes on the reference node of a ``*DISTRIBUTING
COUPLING`` with the weights ``w_j``; :func:`surface_weights` gives them and ``x_c``, and
``tests/test_fem_housing.py`` compares the housing modes of both codes (rotations of the
node, which CalculiX leaves to a mean-rotation MPC, are not loaded there).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from mpi4py import MPI

from .mesh import FEMesh
from .spec import ModelSpec, check_link_kind

log = logging.getLogger(__name__)

#: Mount support kinds.
MOUNT_KINDS = ("clamped", "springs")


@dataclass(frozen=True)
class MountSupport:
    """How a mount group is held.

    Attributes
    ----------
    kind : str
        ``"clamped"`` (every FE DOF of the group fixed) or ``"springs"`` (a node at the
        group's centre, linked to it, with a spring to ground).
    stiffness : tuple of 6 floats
        Spring to ground, global frame: ``(k_x, k_y, k_z)`` [N/m], ``(k_rx, k_ry, k_rz)``
        [N m/rad]; ``"springs"`` only, each >= 0 and one > 0.
    link : str
        ``"rigid"`` or ``"distributing"``: the link of the group to its spring node.
    """

    kind: str = "clamped"
    stiffness: tuple[float, float, float, float, float, float] = (0.0,) * 6
    link: str = "rigid"

    def __post_init__(self) -> None:
        if self.kind not in MOUNT_KINDS:
            raise ValueError(f"mount.kind = {self.kind!r}: allowed "
                             f"{', '.join(map(repr, MOUNT_KINDS))}")
        check_link_kind("mount.link", self.link)
        k = tuple(self.stiffness)
        if len(k) != 6 or not all(isinstance(v, (int, float)) and math.isfinite(v) and v >= 0
                                  for v in k):
            raise ValueError(f"mount.stiffness = {self.stiffness!r}: must be 6 finite "
                             "numbers >= 0 (N/m x 3, N m/rad x 3)")
        if self.kind == "springs" and not any(v > 0 for v in k):
            raise ValueError(f"mount.stiffness = {self.stiffness!r}: springs need one > 0")
        if self.kind == "clamped" and any(v > 0 for v in k):
            raise ValueError(f"mount.stiffness = {self.stiffness!r}: a clamped mount has "
                             "no springs (kind = 'springs' for a spring mount)")

    def matrix(self) -> np.ndarray:
        """The 6x6 diagonal stiffness to ground (global frame)."""
        return np.diag(np.asarray(self.stiffness, dtype=float))


def _centre(fe_mesh: FEMesh, name: str, centres: Mapping[str, np.ndarray] | None) -> np.ndarray:
    if centres is not None and name in centres:
        return np.asarray(centres[name], dtype=float)
    if name not in fe_mesh.centres:
        raise ValueError(f"group {name!r}: no centre (known: {sorted(fe_mesh.centres)})")
    return np.asarray(fe_mesh.centres[name], dtype=float)


def add_seats(spec: ModelSpec, fe_mesh: FEMesh, seats: Mapping[str, str],
              centres: Mapping[str, np.ndarray] | None = None) -> None:
    """A node per seat group, linked to it.

    Parameters
    ----------
    spec : ModelSpec
        Extended in place.
    fe_mesh : FEMesh
    seats : mapping str -> str
        Seat surface group -> link kind (``"rigid"`` or ``"distributing"``). The node
        takes the group's name.
    centres : mapping, optional
        Node positions [m] overriding ``fe_mesh.centres`` (e.g. the area centroids of
        :func:`surface_weights`).
    """
    for group, kind in seats.items():
        check_link_kind(f"seats[{group!r}]", kind)
        fe_mesh.tag(group, 2)
        spec.add_node(group, _centre(fe_mesh, group, centres))
        spec.add_link(group, group, kind=kind)


def add_mounts(spec: ModelSpec, fe_mesh: FEMesh, mounts: Mapping[str, MountSupport],
               centres: Mapping[str, np.ndarray] | None = None) -> None:
    """Clamp each mount group, or give it a spring node (see :class:`MountSupport`).

    Parameters
    ----------
    spec : ModelSpec
        Extended in place.
    fe_mesh : FEMesh
    mounts : mapping str -> MountSupport
        Mount surface group -> support. A spring node takes the group's name.
    centres : mapping, optional
        Spring node positions [m] overriding ``fe_mesh.centres``.
    """
    for group, support in mounts.items():
        if not isinstance(support, MountSupport):
            raise ValueError(f"mounts[{group!r}] = {support!r}: must be a MountSupport")
        fe_mesh.tag(group, 2)
        if support.kind == "clamped":
            spec.add_clamp(group)
            continue
        spec.add_node(group, _centre(fe_mesh, group, centres))
        spec.add_link(group, group, kind=support.link)
        spec.add_spring(group, support.matrix())


def housing_spec(fe_mesh: FEMesh, seats: Mapping[str, str],
                 mounts: Mapping[str, MountSupport],
                 centres: Mapping[str, np.ndarray] | None = None,
                 spec: ModelSpec | None = None) -> ModelSpec:
    """:func:`add_seats` then :func:`add_mounts` on ``spec`` (a new one by default).

    The seats come first: a clamp always wins over a link (a seat face touching a clamped
    face loses the shared DOF to the clamp), and links added first keep shared DOF.
    """
    spec = ModelSpec(shared="first") if spec is None else spec
    add_seats(spec, fe_mesh, seats, centres)
    add_mounts(spec, fe_mesh, mounts, centres)
    return spec


@dataclass
class SurfaceWeights:
    """Nodal area weights of a surface group, on every rank.

    Attributes
    ----------
    nodes : numpy.ndarray of int64, shape (n,)
        Input-mesh node indices (gmsh node tag - 1), sorted.
    weights : numpy.ndarray, shape (n,)
        ``int N_j dA`` [m^2] of the P2 shape function of each node over the surface (0 at
        the corners of flat 6-node triangles).
    area : float
        [m^2]
    centroid : numpy.ndarray, shape (3,)
        ``int x dA / A`` [m].
    """

    nodes: np.ndarray
    weights: np.ndarray
    area: float
    centroid: np.ndarray

    def by_gmsh_tag(self) -> dict[int, float]:
        """Weight by gmsh node tag (input index + 1), e.g. for ``calculix.Coupling``."""
        return dict(zip((self.nodes + 1).tolist(), self.weights.tolist(), strict=True))


def surface_weights(fe_mesh: FEMesh, surface: str) -> SurfaceWeights:
    """Nodal area weights and area centroid of surface group ``surface`` (collective).

    The weights are those of the distributing link's translation at the area centroid
    (module docstring): CalculiX's ``*DISTRIBUTING COUPLING`` with them imposes the same
    equation.
    """
    import ufl
    from dolfinx import fem
    from dolfinx.fem.petsc import assemble_vector
    from petsc4py import PETSc

    msh = fe_mesh.mesh
    V = fem.FunctionSpace(msh, ("CG", 2))
    ds = ufl.Measure("ds", domain=msh, subdomain_data=fe_mesh.facet_tags)
    b = assemble_vector(fem.form(ufl.TestFunction(V) * ds(fe_mesh.tag(surface, 2))))
    b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    n_own = V.dofmap.index_map.size_local
    w = b.array_r[:n_own].copy()
    b.destroy()
    geo = msh.geometry
    cmap = msh.topology.index_map(3)
    n_cells = cmap.size_local + cmap.num_ghosts
    dofs = np.asarray(V.dofmap.list.array).reshape(n_cells, -1)
    gdofs = np.asarray(geo.dofmap.array).reshape(n_cells, -1)
    node_of = np.full(n_own + V.dofmap.index_map.num_ghosts, -1, dtype=np.int64)
    node_of[dofs.ravel()] = gdofs.ravel()
    igi = np.asarray(geo.input_global_indices, dtype=np.int64)
    x = V.tabulate_dof_coordinates()[:n_own]
    on = np.flatnonzero(w != 0.0)
    comm = fe_mesh.comm
    nodes = np.concatenate(comm.allgather(igi[node_of[on]]))
    weights = np.concatenate(comm.allgather(w[on]))
    moment = comm.allreduce((w[on, None] * x[on]).sum(axis=0), op=MPI.SUM)
    order = np.argsort(nodes)
    area = float(weights.sum())
    if not area > 0:
        raise ValueError(f"surface {surface!r}: area {area:.3g} m^2 on exterior facets; "
                         "must be > 0")
    return SurfaceWeights(nodes=nodes[order], weights=weights[order], area=area,
                          centroid=np.asarray(moment, dtype=float) / area)

