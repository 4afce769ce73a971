"""The reduced linear structural model of eq. (4): K_bar = P^T K P, M_bar = P^T M P."""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from mpi4py import MPI

from .elasticity import assemble_elasticity
from .materials import Material
from .mesh import FEMesh
from .prolongation import Prolongation, build_prolongation
from .spec import ModelSpec

log = logging.getLogger(__name__)


@dataclass
class FEModel:
    """Linear model after rigid links and clamps were eliminated.

    Attributes
    ----------
    M, K : PETSc.Mat
        Reduced mass (kg) and stiffness (N/m) matrices, distributed AIJ, symmetric.
    node_dofs : dict[str, numpy.ndarray]
        6 global reduced indices per named node (translations then rotations, in
        the node's local frame; -1 for a fixed DOF).
    gear_nodes : tuple of str
        The gear bodies' 6-DOF nodes (their names are the bodies' names), in the order
        of ``gear_dofs``; empty for a model without gears.
    gear_dofs : numpy.ndarray or None
        6 indices per gear body, in the order of ``gear_nodes`` (translations then
        rotations, in the node's frame); for the pump the paper's order
        q_c = (u1..u3, th1..th3, u4..u6, th4..th6).
    G : numpy.ndarray or None
        ``(n_c, E)``: the line-of-action vector of each of the E gear meshes on q_c
        (eq. 11 placed on the two bodies of the mesh), m per unit DOF.
    P : PETSc.Mat
        Prolongation from reduced unknowns to (P2 FE DOF, then 6 global-frame DOF per
        node owned by the last rank).
    V : dolfinx.fem.FunctionSpace
    fe_mesh : FEMesh
        Mesh, cell and facet tags, group names.
    spec : ModelSpec
    prolongation : Prolongation
        Numbering details (ranges, counts).
    """

    M: Any
    K: Any
    node_dofs: dict[str, np.ndarray]
    gear_dofs: np.ndarray | None
    G: np.ndarray | None
    P: Any
    V: Any
    fe_mesh: FEMesh
    spec: ModelSpec
    prolongation: Prolongation
    info: dict[str, Any] = field(default_factory=dict)
    gear_nodes: tuple[str, ...] = ()

    @property
    def gear_body_dofs(self) -> dict[str, np.ndarray]:
        """The 6 reduced indices of each gear body, by body (node) name, in the order of
        :attr:`gear_nodes`."""
        return {n: self.node_dofs[n] for n in self.gear_nodes}

    @property
    def n_meshes(self) -> int:
        """Number of gear meshes (columns of :attr:`G`; 0 without gears)."""
        return 0 if self.G is None else self.G.shape[1]

    @property
    def comm(self) -> MPI.Comm:
        """Communicator of the model."""
        return self.fe_mesh.comm

    @property
    def cell_tags(self) -> Any:
        """Volume tags of the local cells."""
        return self.fe_mesh.cell_tags

    @property
    def n_red(self) -> int:
        """Number of reduced unknowns (global)."""
        return self.prolongation.n_red

    def row_keys(self) -> np.ndarray:
        """Partition-independent key of each owned reduced unknown (int64, reduced order).

        The reduced numbering follows DOLFINx's, which depends on the mesh partition
        (and the partitioner is not deterministic between runs under mpirun). The key of
        a free FE DOF is ``3 * i + c``, ``i`` the node's index in the input mesh file and
        ``c`` the component; the k-th node DOF (last rank) has ``3 * n_nodes + k``. Keys
        are unique and the same for every partition: a basis stored with its keys can be
        read back onto another partition (``reduction.load_basis``).
        """
        pro = self.prolongation
        if pro.free_dofs is None:
            raise ValueError("prolongation.free_dofs = None: model built without it")
        mesh = self.fe_mesh.mesh
        geo = mesh.geometry
        igi = np.asarray(geo.input_global_indices, dtype=np.int64)
        n_nodes = self.comm.allreduce(int(igi.max(initial=-1)) + 1, op=MPI.MAX)
        cmap = mesh.topology.index_map(3)
        n_cells = cmap.size_local + cmap.num_ghosts
        dofs = np.asarray(self.V.dofmap.list.array).reshape(n_cells, -1)
        gdofs = np.asarray(geo.dofmap.array).reshape(n_cells, -1)
        if gdofs.shape != dofs.shape:
            raise ValueError("V and the mesh geometry differ in nodes per cell: "
                             "row keys need P2 displacements on a P2 mesh")
        im = self.V.dofmap.index_map
        geo_of_block = np.full(im.size_local + im.num_ghosts, -1, dtype=np.int64)
        geo_of_block[dofs.ravel()] = gdofs.ravel()
        blocks = pro.free_dofs // 3
        g = geo_of_block[blocks]
        if np.any(g < 0):
            raise ValueError("row keys: a free DOF block is in no local cell")
        # V and the geometry share the P2 cell layout: the DOF sit on the nodes
        xb = self.V.tabulate_dof_coordinates()[blocks]
        if blocks.size and not np.allclose(geo.x[g], xb, rtol=0, atol=1e-12):
            raise ValueError("row keys: V's DOF do not sit on the geometry nodes")
        keys = 3 * igi[g] + pro.free_dofs % 3
        r0, r1 = pro.red_range
        n_node_local = (r1 - r0) - keys.size
        if n_node_local:
            n_free = pro.n_red - sum(int(np.count_nonzero(v >= 0))
                                     for v in pro.node_red.values())
            k0 = (r0 + keys.size) - n_free
            keys = np.concatenate([keys, 3 * n_nodes + k0 + np.arange(n_node_local)])
        return keys.astype(np.int64)

    def reduced_vector(self, q: Any, root: int | None = None) -> Any:
        """A PETSc Vec of the reduced layout from a Vec or a NumPy array.

        Parameters
        ----------
        q : PETSc.Vec or numpy.ndarray
            A NumPy array must hold all n_red values on every rank, or only on
            rank ``root`` when ``root`` is given (other ranks may pass None).
        """
        from petsc4py import PETSc

        if isinstance(q, PETSc.Vec):
            if q.getSize() != self.n_red:
                raise ValueError(f"q size = {q.getSize()}: must be n_red = {self.n_red}")
            return q
        if root is not None:
            q = self.comm.bcast(q if self.comm.rank == root else None, root=root)
        arr = np.asarray(q, dtype=float).reshape(-1)
        if arr.size != self.n_red:
            raise ValueError(f"q size = {arr.size}: must be n_red = {self.n_red}")
        if not np.all(np.isfinite(arr)):
            raise ValueError("q: must be finite")
        v = self.K.createVecRight()
        lo, hi = v.getOwnershipRange()
        v.getArray()[:] = arr[lo:hi]
        return v

    def displacement(self, q: Any, root: int | None = None) -> Any:
        """Displacement field u = P q of the mesh (m) as a dolfinx Function.

        Parameters
        ----------
        q : PETSc.Vec or numpy.ndarray
            Reduced unknowns (see :meth:`reduced_vector`).
        root : int, optional
            Rank holding the NumPy array when it is not on every rank.
        """
        from dolfinx import fem

        qv = self.reduced_vector(q, root)
        full = self.P.createVecLeft()
        self.P.mult(qv, full)
        u = fem.Function(self.V, name="displacement")
        n = 3 * self.V.dofmap.index_map.size_local
        u.x.array[:n] = full.getArray(readonly=True)[:n]
        u.x.scatter_forward()
        return u

    def rigid_motion(self, translation: np.ndarray, rotation: np.ndarray,
                     origin: np.ndarray) -> Any:
        """Reduced Vec of the small rigid motion u(x) = a + theta x (x - origin).

        Parameters
        ----------
        translation : array_like (3,), m
        rotation : array_like (3,), rad
        origin : array_like (3,), m

        Notes
        -----
        Only meaningful with no clamp and no fixed node DOF (otherwise the motion is
        not admissible); those DOF are simply absent.
        """
        a, th, o = (np.asarray(v, dtype=float).reshape(3) for v in (translation, rotation, origin))
        pro = self.prolongation
        v = self.K.createVecRight()
        arr = v.getArray()
        n_free = pro.free_comp.size
        field_ = a + np.cross(th, pro.free_coords - o)
        arr[:n_free] = field_[np.arange(n_free), pro.free_comp]
        if pro.free_relative is not None:  # deviations from a node's rigid motion
            arr[:n_free][pro.free_relative] = 0.0
        if self.comm.rank == self.comm.size - 1:
            lo = v.getOwnershipRange()[0]
            for node in self.spec.nodes:
                red = pro.node_red[node.name]
                u_loc = node.frame.T @ (a + np.cross(th, node.centre - o))
                t_loc = node.frame.T @ th
                vals = np.concatenate([u_loc, t_loc])
                arr[red[red >= 0] - lo] = vals[red >= 0]
        return v


def project(A: Any, P: Any, Pt: Any = None) -> Any:
    """Galerkin projection P^T A P of a distributed AIJ matrix.

    Computed as P^T (A P) with an explicit transpose: the same product as PETSc's
    ``MatPtAP`` (its ``rap`` variant), measured 4x faster than petsc4py's default
    ``PtAP`` algorithm on P2 elasticity with a near-identity P.
    """
    from petsc4py import PETSc

    own_pt = Pt is None
    if own_pt:
        Pt = P.transpose(PETSc.Mat())
    AP = A.matMult(P)
    out = Pt.matMult(AP)
    release_product(out)  # else out keeps AP, and AP keeps A, alive
    AP.destroy()
    if own_pt:
        Pt.destroy()
    return out


def release_product(C: Any) -> None:
    """Drop the product data PETSc keeps in a ``MatMatMult`` result ``C``.

    PETSc (3.13 on) stores in ``C`` the operands of the product, with a reference to
    each, so that ``MAT_REUSE_MATRIX`` can recompute it. A projected ``K̄ = Pᵀ (K P)``
    therefore kept ``K P`` alive, and that one the full P2 ``K``: 4 matrices of the size of
    ``K̄`` held by the model for nothing (measured: 1.1 GiB at 304k DOF, docs/scale.md).
    petsc4py 3.18 has no binding of ``MatProductClear``; it is called from the PETSc
    library the petsc4py extension is linked to.
    """
    import ctypes

    from petsc4py import PETSc

    err = ctypes.CDLL(PETSc.__file__).MatProductClear(ctypes.c_void_p(C.handle))
    if err:
        raise RuntimeError(f"MatProductClear failed with PETSc error code {err}")


def _add_lumped(K: Any, M: Any, spec: ModelSpec, node_red: dict[str, np.ndarray]) -> None:
    """Add the lumped matrices T^T A T of ``spec`` (one rank inserts, all assemble)."""
    from petsc4py import PETSc

    for A in (K, M):
        A.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, False)
    comm = K.getComm().tompi4py()
    if comm.rank == comm.size - 1:
        it = PETSc.IntType
        all_red = np.concatenate([node_red[n.name] for n in spec.nodes] or [np.zeros(0, int)])
        all_red = all_red[all_red >= 0].astype(it)
        for A in (K, M):  # explicit diagonal entries for every node DOF
            for i in all_red:
                A.setValue(int(i), int(i), 0.0, addv=PETSc.InsertMode.ADD_VALUES)
        for item in spec.lumped:
            nodes = [spec.nodes[spec.node_index(n)] for n in item.nodes]
            T = np.zeros((6 * len(nodes), 6 * len(nodes)))
            for j, node in enumerate(nodes):
                T[6 * j:6 * j + 3, 6 * j:6 * j + 3] = node.frame
                T[6 * j + 3:6 * j + 6, 6 * j + 3:6 * j + 6] = node.frame
            red = np.concatenate([node_red[n.name] for n in nodes])
            keep = red >= 0
            Ar = (T.T @ item.matrix @ T)[np.ix_(keep, keep)]
            target = K if item.kind == "K" else M
            idx = red[keep].astype(it)
            target.setValues(idx, idx, Ar, addv=PETSc.InsertMode.ADD_VALUES)
    for A in (K, M):
        A.assemble()


def build_model(
    fe_mesh: FEMesh,
    materials: dict[str, Material],
    spec: ModelSpec,
    degree: int = 2,
    quadrature_degree: int | None = None,
    gear_nodes: Sequence[str] | None = None,
    G: np.ndarray | None = None,
) -> FEModel:
    """Assemble K, M and eliminate links and clamps: K_bar = P^T K P (see :func:`project`).

    Parameters
    ----------
    fe_mesh : FEMesh
    materials : dict[str, Material]
        Volume name -> material.
    spec : ModelSpec
        Extra nodes, rigid links, clamps and lumped matrices.
    degree, quadrature_degree : int
        See :func:`fem.elasticity.assemble_elasticity`.
    gear_nodes : sequence of str, optional
        Names of the gear bodies' centre nodes (any number, each with 6 free DOF); sets
        ``gear_dofs`` (6 per node, in this order).
    G : numpy.ndarray, optional
        ``(6 n_bodies, E)``: one line-of-action vector per gear mesh on ``gear_dofs``
        (eq. 11); a 1-D ``(6 n_bodies,)`` array is one mesh.

    Returns
    -------
    FEModel
    """
    import time

    in_lumped = {n for item in spec.lumped for n in item.nodes}
    linked = {link.node for link in spec.links}
    for node in spec.nodes:
        if node.name not in in_lumped and node.name not in linked and not node.fixed.all():
            raise ValueError(f"node {node.name!r}: neither linked nor carrying a lumped matrix")
    gear_nodes = tuple(gear_nodes or ())
    if len(set(gear_nodes)) != len(gear_nodes):
        raise ValueError(f"gear_nodes = {list(gear_nodes)}: names must be distinct")
    for n in gear_nodes:
        if spec.nodes[spec.node_index(n)].fixed.any():
            raise ValueError(f"gear_nodes: node {n!r} has fixed DOF; gear DOF must be free")
    if G is not None:
        G = np.asarray(G, dtype=float)
        G = G.reshape(-1, 1) if G.ndim == 1 else G
        n_c = 6 * len(gear_nodes)
        if G.ndim != 2 or G.shape[0] != n_c or G.shape[1] < 1 or not np.all(np.isfinite(G)):
            raise ValueError(f"G shape = {G.shape}: must be ({n_c}, n_meshes) finite floats "
                             f"(6 rows per gear node, {len(gear_nodes)} nodes)")
    t0 = time.perf_counter()
    V, K, M = assemble_elasticity(fe_mesh, materials, degree, quadrature_degree)
    t1 = time.perf_counter()
    pro = build_prolongation(V, fe_mesh, spec)
    for name, n_dof in pro.node_links.items():
        if name in linked and n_dof == 0 and name not in in_lumped:
            raise ValueError(f"node {name!r}: all DOF of its surfaces went to other links")
    from petsc4py import PETSc

    Pt = pro.P_fe.transpose(PETSc.Mat())  # one transpose for both projections
    Kr = project(K, pro.P_fe, Pt)
    K.destroy()  # each full P2 matrix goes once projected: one less in the peak
    Mr = project(M, pro.P_fe, Pt)
    M.destroy()
    Pt.destroy()
    pro.P_fe.destroy()  # P (all rows) is kept for reconstruction
    pro.P_fe = None
    _add_lumped(Kr, Mr, spec, pro.node_red)
    t2 = time.perf_counter()
    gear_dofs = None
    if gear_nodes:
        gear_dofs = np.concatenate([pro.node_red[n] for n in gear_nodes])
    info = {"t_assemble_s": t1 - t0, "t_reduce_s": t2 - t1, "n_fe": pro.n_fe,
            "n_red": pro.n_red, **pro.counts}  # fmt: skip
    log.info("FE model: %s", info)
    return FEModel(
        M=Mr, K=Kr, node_dofs=dict(pro.node_red), gear_dofs=gear_dofs, G=G, P=pro.P, V=V,
        fe_mesh=fe_mesh, spec=spec, prolongation=pro, info=info, gear_nodes=gear_nodes,
    )  # fmt: skip
