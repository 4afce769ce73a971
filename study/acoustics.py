"""Equivalent radiated power (ERP) of the housing's outer surface.

ERP is the sound power a surface would radiate if every element radiated as a
plane wave (radiation efficiency 1)::

    P = ½ ρ c ∫_Γ |v_n|² dA        (time average of one harmonic, amplitude v_n)

For the harmonic k of the HBM solution (``x(t) = Re Σ_k x̃_k e^{i k ω₀ t}``) the
normal velocity is ``ṽ_n = i k ω₀ n·ũ_k`` with ``ũ_k = P T q̃_k`` (the P2
displacement rebuilt from the ROM coordinates, eq. 8), so

    P_k = ½ ρ c (k ω₀)² q̃_kᴴ W q̃_k,      W = (P T)ᵀ A (P T),
    A_ij = ∫_Γ (φ_i·n)(φ_j·n) dA       (P2 shape functions φ, outer normal n).

``W`` (n_r × n_r) is built once per ROM (cached with it); per continuation point
the ERP of every harmonic is then a few n_r² products. Harmonics are orthogonal
over the period, so the total ERP is ``Σ_k P_k``.

Quadrature: on a flat (affine) facet ``(φ_i·n)(φ_j·n)`` is a polynomial of
degree 4, so a degree-4 rule is exact; on the curved P2 facets of bosses and
bores the integrand is rational and degree 6 is used (the sphere test in
``tests/test_study_acoustics.py`` shows it converged to the geometry error).

The functions taking DOLFINx objects import dolfinx lazily; the rest is NumPy.
:func:`radiation_data` (and :func:`outer_surface_facets`, :func:`surface_area`,
:func:`reduced_radiation_matrix`) are collective on the mesh communicator: each rank
integrates and projects on its own facets with its rows of the distributed basis,
and only the small outputs (W, the facet rows) are summed or gathered on rank 0,
ordered by the input mesh's node numbers, so they do not depend on the partition.
:func:`block_u_rows` gives basis rows at any nodes from the distributed ``P T``
(the housing fields, :mod:`study.fields`).
"""
from __future__ import annotations

import logging
import math
from pathlib import Path

import numpy as np

from .surface_facets import CENTROID_WEIGHTS, facet_frames, facet_geometry_nodes, node_blocks

logger = logging.getLogger(__name__)

__all__ = ["AIR_DENSITY", "SOUND_SPEED", "P_REF", "QUADRATURE_DEGREE", "outer_surface_facets",
           "normal_gram", "surface_area", "block_u_rows", "reduced_radiation_matrix",
           "erp_harmonics", "power_db", "sphere_erp", "radiation_data", "RADIATION_FILE"]

#: Default air density [kg/m³] and speed of sound [m/s] (20 °C, sea level).
AIR_DENSITY = 1.2
SOUND_SPEED = 343.0
#: Reference sound power for dB [W].
P_REF = 1e-12
#: Quadrature degree of the surface integrals (exact for affine P2 facets: degree 4).
QUADRATURE_DEGREE = 6
#: Floor of the dB values (a zero power, e.g. of the mean k = 0, reads as this) [dB].
DB_FLOOR = -100.0


def power_db(power_w: np.ndarray) -> np.ndarray:
    """Sound power level ``10 log10(P / 1e-12 W)`` [dB], floored at ``DB_FLOOR``."""
    p = np.asarray(power_w, dtype=float)
    floor = P_REF * 10 ** (DB_FLOOR / 10)
    return 10.0 * np.log10(np.maximum(p, floor) / P_REF)


def erp_harmonics(W: np.ndarray, qk: np.ndarray, omega_k: np.ndarray,
                  rho: float = AIR_DENSITY, c: float = SOUND_SPEED) -> np.ndarray:
    """ERP of every harmonic, ``P_k = ½ ρ c ω_k² q̃_kᴴ W q̃_k`` [W].

    Parameters
    ----------
    W : (n_r, n_r) float
        Radiation matrix of :func:`reduced_radiation_matrix` [m²].
    qk : (n_r, n_h) complex
        ROM coordinates per harmonic (complex amplitudes, ``x = Re Σ q̃_k e^{iω_k t}``).
    omega_k : (n_h,) float
        Angular frequency of each harmonic [rad/s].
    rho, c : float
        Air density [kg/m³] and speed of sound [m/s].
    """
    qk = np.asarray(qk)
    quad = np.einsum("ik,ik->k", qk.conj(), W @ qk).real
    return 0.5 * rho * c * np.asarray(omega_k, dtype=float) ** 2 * np.maximum(quad, 0.0)


# --------------------------------------------------------------------------- DOLFINx side

def _part_boundary_facets(fe_mesh, part: str) -> np.ndarray:
    """This rank's exterior facets of volume ``part`` minus its named surface groups."""
    from dolfinx import mesh as dmesh

    top = fe_mesh.mesh.topology
    top.create_connectivity(2, 3)
    top.create_connectivity(2, 0)
    # owned facets with one cell in the whole mesh (no inter-process facets)
    ext = np.asarray(dmesh.exterior_facet_indices(top), dtype=np.int32)
    f2c = top.connectivity(2, 3)
    cells = f2c.array[f2c.offsets[ext]]
    is_part = np.zeros(top.index_map(3).size_local + top.index_map(3).num_ghosts, dtype=bool)
    is_part[fe_mesh.cell_tags.find(fe_mesh.tag(part, 3))] = True
    facets = ext[is_part[cells]]
    named = [fe_mesh.facet_tags.find(t) for name, (d, t) in fe_mesh.groups.items()
             if d == 2 and name.startswith(part + "/")]
    if named:
        facets = np.setdiff1d(facets, np.concatenate(named))
    return facets.astype(np.int32)


def _input_ids(mesh, geometry_nodes: np.ndarray) -> np.ndarray:
    """Input-mesh (gmsh) node numbers of local geometry nodes: the same on any partition."""
    ids = np.asarray(mesh.geometry.input_global_indices, dtype=np.int64)
    return ids[geometry_nodes]


def _gather(comm, a: np.ndarray) -> np.ndarray | None:
    """The ranks' arrays stacked along axis 0 on rank 0 (None elsewhere)."""
    parts = comm.gather(np.ascontiguousarray(a), root=0)
    return np.concatenate(parts, axis=0) if comm.rank == 0 else None


def outer_surface_facets(fe_mesh, part: str = "housing") -> np.ndarray:
    """Local indices of this rank's facets of the outer skin of volume ``part``
    (collective on the mesh communicator).

    The boundary facets of the part's cells, minus its named surface groups
    (bearing seats ``housing/bore_*`` and the bolted ``housing/feet``, which face a
    bearing or the foundation, not the air), split into connected pieces (shared
    vertices); the outer skin is the piece with the largest bounding box (the
    inner skin of a closed casing lies strictly inside it). Under MPI the facets'
    vertex numbers (input mesh) and positions are gathered on rank 0, which finds the
    pieces and sends each rank its selection.
    """
    import scipy.sparse as sp
    from scipy.sparse.csgraph import connected_components

    m = fe_mesh.mesh
    comm = m.comm
    facets = _part_boundary_facets(fe_mesh, part)
    n_total = comm.allreduce(int(facets.size))
    if n_total == 0:
        raise ValueError(f"part = {part!r}: has no free boundary facets")
    g, _ = facet_geometry_nodes(m, facets)
    verts = _input_ids(m, g[:, :3])                                # (n_f, 3)
    pts = m.geometry.x[g[:, :3]]                                   # (n_f, 3, 3)
    all_v, all_p = _gather(comm, verts), _gather(comm, pts)
    counts = comm.gather(int(facets.size), root=0)
    keep_parts = None
    if comm.rank == 0:
        _, vidx = np.unique(all_v, return_inverse=True)
        vidx = vidx.reshape(all_v.shape)
        n_f = all_v.shape[0]
        inc = sp.csr_matrix((np.ones(vidx.size), (np.repeat(np.arange(n_f), 3), vidx.ravel())),
                            shape=(n_f, int(vidx.max()) + 1))
        n_comp, lab = connected_components(inc @ inc.T, directed=False)
        best, size = -1, -1.0
        for c in range(n_comp):
            p = all_p[lab == c].reshape(-1, 3)
            s = float(np.prod(np.ptp(p, axis=0) + 1e-12))
            if s > size:
                best, size = c, s
        keep = lab == best
        logger.info("outer surface of %r: %d of %d free boundary facets (%d connected pieces)",
                    part, int(keep.sum()), n_f, n_comp)
        keep_parts = np.split(keep, np.cumsum(counts)[:-1])
    keep_local = comm.scatter(keep_parts, root=0)
    return np.sort(facets[keep_local]).astype(np.int32)


def _ds(mesh, facets):
    import ufl
    from dolfinx import mesh as dmesh

    f = np.asarray(facets, dtype=np.int32)
    order = np.argsort(f)
    mt = dmesh.meshtags(mesh, 2, f[order], np.ones(f.size, dtype=np.int32))
    return ufl.Measure("ds", domain=mesh, subdomain_data=mt,
                       metadata={"quadrature_degree": QUADRATURE_DEGREE})(1)


def surface_area(mesh, facets) -> float:
    """Area of the facets [m²] (P2 geometry); collective: each rank's ``facets`` are its
    own, the sum over the ranks is returned on every rank."""
    from dolfinx import fem

    one = fem.Constant(mesh, 1.0)
    return float(mesh.comm.allreduce(fem.assemble_scalar(fem.form(one * _ds(mesh, facets)))))


def normal_gram(V, facets):
    """PETSc matrix ``A_ij = ∫_Γ (φ_i·n)(φ_j·n) dA`` on the facets (vector space V) [m²]."""
    import ufl
    from dolfinx import fem
    from dolfinx.fem.petsc import assemble_matrix

    mesh = V.mesh
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    n = ufl.FacetNormal(mesh)
    A = assemble_matrix(fem.form(ufl.dot(u, n) * ufl.dot(v, n) * _ds(mesh, facets)))
    A.assemble()
    return A


def _csr(A):
    import scipy.sparse as sp

    ip, ix, vals = A.getValuesCSR()
    return sp.csr_matrix((vals, ix, ip), shape=A.getSize())


def _dense_mat(T, comm):
    """``T`` as a PETSc dense matrix: a PETSc Mat is returned as is, a NumPy array (the
    whole basis, one process only) is copied into a sequential dense matrix."""
    from petsc4py import PETSc

    if isinstance(T, PETSc.Mat):
        return T
    if comm.size != 1:
        raise RuntimeError("a NumPy basis is serial only: give the distributed PETSc basis")
    T = np.asarray(T, dtype=float)
    out = PETSc.Mat().createDense(T.shape, comm=PETSc.COMM_SELF)
    out.setUp()
    out.getDenseArray()[:] = T
    out.assemble()
    return out


def _aij(P, n_rows_local: int, csr: tuple):
    """AIJ matrix with ``n_rows_local`` rows here and the columns of ``P``'s row layout
    (the P2 DOF of V, then the 6-DOF node rows on the last rank)."""
    from petsc4py import PETSc

    it = PETSc.IntType
    ip, ix, vals = csr
    A = PETSc.Mat().createAIJ(
        size=((n_rows_local, PETSc.DETERMINE), (P.getLocalSize()[0], P.getSize()[0])),
        csr=(np.asarray(ip, dtype=it), np.asarray(ix, dtype=it),
             np.asarray(vals, dtype=PETSc.ScalarType)), comm=P.getComm())
    A.assemble()
    return A


def _on_p_rows(A, P):
    """The V-layout matrix ``A`` (n_V × n_V) on ``P``'s row layout (square): the V DOF
    keep their global numbers, the node rows of P get empty rows and columns."""
    ip, ix, vals = A.getValuesCSR()
    n_pad = P.getLocalSize()[0] - (ip.size - 1)
    ip = np.concatenate([ip, np.full(n_pad, ip[-1], dtype=ip.dtype)])
    return _aij(P, P.getLocalSize()[0], (ip, ix, vals))


def reduced_radiation_matrix(model, T, facets: np.ndarray, PT=None) -> np.ndarray:
    """``W = (P T)ᵀ A (P T)`` (n_r × n_r) [m²] for the FE model's outer facets (collective;
    the same W on every rank).

    Parameters
    ----------
    model : fem.FEModel
        FE model (``P`` maps its reduced unknowns to the P2 DOF of ``V``), serial or
        distributed.
    T : PETSc dense Mat (rows on ``model.K``'s layout), or (n_red, n_r) float (serial)
        Reduction basis (``rom/basis``).
    facets : int array
        This rank's facets of the radiating surface (:func:`outer_surface_facets`).
    PT : PETSc dense Mat, optional
        ``P T`` when already computed.
    """
    from reduction import dense_projection

    if PT is None:
        PT = model.P.matMult(_dense_mat(T, model.comm))
    A = normal_gram(model.V, facets)
    Ap = _on_p_rows(A, model.P)
    A.destroy()
    W = dense_projection(Ap, PT)
    Ap.destroy()
    return W


def block_u_rows(model, PT, blocks: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """``u`` per unit ROM coordinate at points given as weighted sums of DOF blocks
    (n × 3 × n_r; m per unit of the ROM coordinate, the basis' own units), from the
    distributed ``P T``: one AIJ row per point and component
    (global P2 DOF numbers as columns) times ``P T``, so ghost DOF come through PETSc
    (collective on ``model.comm``).

    Parameters
    ----------
    model : fem.FEModel
    PT : PETSc dense Mat
        ``P T`` on the P2 DOF of ``model.V`` (rows on ``model.P``'s layout).
    blocks : (n, k) int
        Local DOF blocks of ``model.V`` (ghosts allowed) of each point's nodes.
    weights : (k,) float
        Weight of each node (the shape-function values at the point).
    """
    V = model.V
    n, k = blocks.shape
    if np.any(blocks < 0):
        raise RuntimeError("basis rows: a node without a DOF block")
    gblocks = np.asarray(V.dofmap.index_map.local_to_global(
        np.ascontiguousarray(blocks.ravel(), dtype=np.int32)), dtype=np.int64).reshape(n, k)
    order = np.argsort(gblocks, axis=1)                            # sorted columns per row
    cols = np.take_along_axis(gblocks, order, axis=1)
    w = np.asarray(weights, dtype=float)[order]
    ip = np.arange(0, k * n + 1, k, dtype=np.int64)
    out = np.empty((n, 3, PT.getSize()[1]))
    for i in range(3):
        R = _aij(model.P, n, (ip, (3 * cols + i).ravel(), w.ravel()))
        X = R.matMult(PT)
        out[:, i, :] = X.getDenseArray()
        X.destroy()
        R.destroy()
    return out


def _centroid_u_rows(model, PT, g: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """``u`` at each local facet's centroid per unit ROM coordinate (n_f × 3 × n_r)."""
    n_f = g.shape[0]
    blocks = (node_blocks(model.fe_mesh.mesh, model.V, cells)[g] if n_f
              else np.zeros((0, 6), dtype=np.int64))
    return block_u_rows(model, PT, blocks, CENTROID_WEIGHTS)


def sphere_erp(radius: float, u0: float, omega: float, rho: float = AIR_DENSITY,
               c: float = SOUND_SPEED) -> float:
    """Closed form: ERP of a sphere pulsating with radial amplitude ``u0`` [W]."""
    return 0.5 * rho * c * (omega * u0) ** 2 * 4.0 * math.pi * radius ** 2


#: File of the radiation data in a cached ROM entry.
RADIATION_FILE = "radiation.h5"


def radiation_data(model, T, path, part: str = "housing") -> None:
    """Write the ROM's radiation data of ``part``'s outer surface to ``path`` (HDF5);
    collective on ``model.comm``, rank 0 writes.

    Each rank computes its facets' part (``P T`` stays distributed, no rank builds a
    serial FE model or the dense basis); W is summed and the facet rows are gathered
    on rank 0 and sorted by the facets' input-mesh vertex numbers, so the file does
    not depend on the number of ranks or the partition.

    Parameters
    ----------
    model : fem.FEModel
    T : PETSc dense Mat (rows on ``model.K``'s layout), or (n_red, n_r) float (serial)
        Reduction basis.
    path : path of the HDF5 file.
    part : str
        Volume whose outer surface radiates.

    Datasets: ``W`` (n_r × n_r, m²), ``facet_rows`` (n_f × n_r: n·u at each facet
    centroid per unit ROM coordinate), ``facet_u_rows`` (n_f × 3 × n_r: u there),
    ``facet_area`` (m², flat), ``facet_centroid``, ``facet_normal`` (n_f × 3),
    ``facet_nodes`` (n_f × 6 indices into ``points``, ``triangle6`` order),
    ``points`` (geometry nodes of those facets, m); attributes ``area`` (P2 area,
    m²), ``n_facets``, ``part``, ``quadrature_degree``.
    """
    import h5py

    from core.files import atomic_write

    comm = model.comm
    mesh = model.fe_mesh.mesh
    facets = outer_surface_facets(model.fe_mesh, part)
    PT = model.P.matMult(_dense_mat(T, comm))
    W = reduced_radiation_matrix(model, T, facets, PT)
    g, cells, fa, cen, nrm = facet_frames(mesh, facets)
    urows = _centroid_u_rows(model, PT, g, cells)
    PT.destroy()
    area = surface_area(mesh, facets)
    ids = _input_ids(mesh, g)
    parts = {"ids": ids, "x": mesh.geometry.x[g], "urows": urows, "area": fa, "cen": cen,
             "nrm": nrm}
    got = {k: _gather(comm, v) for k, v in parts.items()}
    if comm.rank != 0:
        return
    # partition-independent order: by the sorted input numbers of the facet's vertices
    key = np.sort(got["ids"][:, :3], axis=1)
    order = np.lexsort(key.T[::-1])
    got = {k: v[order] for k, v in got.items()}
    used, first, inv = np.unique(got["ids"], return_index=True, return_inverse=True)
    n_f = order.size
    with atomic_write(Path(path)) as tmp, h5py.File(tmp, "w") as f:
        f["W"] = W
        f["facet_rows"] = np.einsum("fi,fir->fr", got["nrm"], got["urows"])
        f["facet_u_rows"] = got["urows"]
        f["facet_area"] = got["area"]
        f["facet_centroid"] = got["cen"]
        f["facet_normal"] = got["nrm"]
        f["facet_nodes"] = inv.reshape(n_f, 6).astype(np.int64)
        f["points"] = got["x"].reshape(-1, 3)[first]
        f.attrs["area"] = area
        f.attrs["n_facets"] = int(n_f)
        f.attrs["part"] = part
        f.attrs["quadrature_degree"] = QUADRATURE_DEGREE
    logger.info("radiation matrix of the %s outer surface: %d facets, %.4g m² (%d ranks)",
                part, n_f, float(np.sum(got["area"])), comm.size)
