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
Everything here runs on one process (the export stage is serial).
"""
from __future__ import annotations

import logging
import math

import numpy as np

logger = logging.getLogger(__name__)

__all__ = ["AIR_DENSITY", "SOUND_SPEED", "P_REF", "QUADRATURE_DEGREE", "outer_surface_facets",
           "normal_gram", "surface_area", "fe_basis", "reduced_radiation_matrix", "erp_harmonics",
           "power_db", "facet_normal_velocity_rows", "facet_geometry_nodes",
           "facet_centroid_rows", "node_blocks", "sphere_erp",
           "radiation_data", "RADIATION_FILE"]

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

def outer_surface_facets(fe_mesh, part: str = "housing") -> np.ndarray:
    """Local indices of the facets of the outer skin of volume ``part``.

    The boundary facets of the part's cells, minus its named surface groups
    (bearing seats ``housing/bore_*`` and the bolted ``housing/feet``, which face a
    bearing or the foundation, not the air), split into connected pieces (shared
    vertices); the outer skin is the piece with the largest bounding box (the
    inner skin of a closed casing lies strictly inside it).
    """
    import scipy.sparse as sp
    from dolfinx import mesh as dmesh
    from scipy.sparse.csgraph import connected_components

    m = fe_mesh.mesh
    if m.comm.size != 1:
        raise RuntimeError("outer_surface_facets: serial only (the export stage runs on one "
                           "process)")
    top = m.topology
    top.create_connectivity(2, 3)
    top.create_connectivity(2, 0)
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
    if facets.size == 0:
        raise ValueError(f"part = {part!r}: has no free boundary facets")
    f2v = top.connectivity(2, 0)
    verts = np.stack([f2v.links(f) for f in facets])              # (n_f, 3)
    n_v = top.index_map(0).size_local + top.index_map(0).num_ghosts
    inc = sp.csr_matrix((np.ones(verts.size), (np.repeat(np.arange(facets.size), 3),
                                               verts.ravel())), shape=(facets.size, n_v))
    n_comp, lab = connected_components(inc @ inc.T, directed=False)
    x = m.geometry.x
    from dolfinx.cpp.mesh import entities_to_geometry
    gnodes = entities_to_geometry(getattr(m, "_mesh", m), 2, facets, False)
    pts = x[gnodes]                                                 # (n_f, 3, 3) vertices
    best, size = -1, -1.0
    for c in range(n_comp):
        p = pts[lab == c].reshape(-1, 3)
        s = float(np.prod(np.ptp(p, axis=0) + 1e-12))
        if s > size:
            best, size = c, s
    out = np.sort(facets[lab == best]).astype(np.int32)
    logger.info("outer surface of %r: %d of %d free boundary facets (%d connected pieces)",
                part, out.size, facets.size, n_comp)
    return out


def _ds(mesh, facets):
    import ufl
    from dolfinx import mesh as dmesh

    f = np.asarray(facets, dtype=np.int32)
    order = np.argsort(f)
    mt = dmesh.meshtags(mesh, 2, f[order], np.ones(f.size, dtype=np.int32))
    return ufl.Measure("ds", domain=mesh, subdomain_data=mt,
                       metadata={"quadrature_degree": QUADRATURE_DEGREE})(1)


def surface_area(mesh, facets) -> float:
    """Area of the facets [m²] (P2 geometry)."""
    from dolfinx import fem

    one = fem.Constant(mesh, 1.0)
    return float(fem.assemble_scalar(fem.form(one * _ds(mesh, facets))))


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


def fe_basis(model, T: np.ndarray) -> np.ndarray:
    """``P T``: the reduction basis on the P2 DOF of ``model.V`` (n_fe × n_r), serial."""
    if model.comm.size != 1:
        raise RuntimeError("fe_basis: serial only")
    n_fe = 3 * model.V.dofmap.index_map.size_local
    return _csr(model.P)[:n_fe] @ np.asarray(T, dtype=float)


def reduced_radiation_matrix(model, T: np.ndarray, facets: np.ndarray,
                             PT: np.ndarray | None = None) -> np.ndarray:
    """``W = (P T)ᵀ A (P T)`` (n_r × n_r) [m²] for the FE model's outer facets.

    Parameters
    ----------
    model : fem.FEModel
        Serial FE model (``P`` maps its reduced unknowns to the P2 DOF of ``V``).
    T : (n_red, n_r) float
        Reduction basis (``rom/basis``).
    facets : int array
        Facets of the radiating surface (:func:`outer_surface_facets`).
    PT : (n_fe, n_r) float, optional
        :func:`fe_basis` when already computed.
    """
    if PT is None:
        PT = fe_basis(model, T)
    A = _csr(normal_gram(model.V, facets))
    W = PT.T @ (A @ PT)
    return 0.5 * (W + W.T)


#: Edges of the reference tetrahedron (DOLFINx/basix P2 layout: geometry node 4 + e
#: sits on edge e).
_TET_EDGES = ((2, 3), (1, 3), (1, 2), (0, 3), (0, 2), (0, 1))


def facet_geometry_nodes(mesh, facets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The 6 geometry nodes of each exterior P2 facet in VTK/XDMF ``triangle6`` order
    (vertices a, b, c, then the edge nodes of ab, bc, ca) and the cell of each facet.

    Facet ``i`` of a tetrahedron is opposite its vertex ``i``; the edge node of the
    cell's edge ``e`` (``_TET_EDGES``) is its geometry node ``4 + e``.
    """
    top = mesh.topology
    top.create_connectivity(2, 3)
    top.create_connectivity(3, 2)
    f2c, c2f = top.connectivity(2, 3), top.connectivity(3, 2)
    cg = mesh.geometry.dofmap
    cells = f2c.array[f2c.offsets[facets]]
    edge_of = {frozenset(p): 4 + e for e, p in enumerate(_TET_EDGES)}
    out = np.empty((len(facets), 6), dtype=np.int64)
    for j, (f, c) in enumerate(zip(facets, cells, strict=True)):
        i = int(np.flatnonzero(c2f.links(c) == f)[0])
        nodes = cg.links(c)
        a, b, d = (v for v in range(4) if v != i)
        out[j] = nodes[[a, b, d, edge_of[frozenset((a, b))], edge_of[frozenset((b, d))],
                        edge_of[frozenset((d, a))]]]
    return out, cells


def node_blocks(mesh, V, cells: np.ndarray) -> np.ndarray:
    """Geometry node -> DOF block of the P2 vector space ``V`` (−1 off ``cells``).

    The P2 geometry and the P2 Lagrange space share the reference layout cell by
    cell, so the node at local position j of a cell carries the cell's j-th block.
    """
    cg = mesh.geometry.dofmap
    out = np.full(mesh.geometry.x.shape[0], -1, dtype=np.int64)
    for c in np.unique(cells):
        out[cg.links(c)] = V.dofmap.cell_dofs(c)
    return out


def facet_centroid_rows(mesh, V, facets: np.ndarray):
    """Sparse rows giving u and ``n·u`` at the centroid of each facet from the P2 DOF of V.

    Returns ``(Rc, Rn, area, centroid, normal)``: ``Rc`` a list of 3 scipy CSR
    (n_f × n_V), ``(Rc[i] u)_f = u_i(centroid_f)`` (P2 triangle: vertex weights
    −1/9, edge weights 4/9), ``Rn = Σ_i n_i Rc[i]`` (``n·u``); flat facet areas
    [m²], centroids [m] and unit normals (flat facet, pointing out of the cell).
    """
    import scipy.sparse as sp

    x = mesh.geometry.x
    g, cells = facet_geometry_nodes(mesh, facets)                  # (n_f, 6)
    p = x[g]
    nrm = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    area = 0.5 * np.linalg.norm(nrm, axis=1)
    nrm /= np.linalg.norm(nrm, axis=1)[:, None]
    cen = p[:, :3].mean(axis=1)
    # orient outwards: away from the centroid of the (single) adjacent cell
    cg = mesh.geometry.dofmap
    cell_cen = np.stack([x[cg.links(c)[:4]].mean(axis=0) for c in cells])
    flip = np.einsum("ij,ij->i", nrm, cen - cell_cen) < 0
    nrm[flip] *= -1
    blocks = node_blocks(mesh, V, cells)[g]
    if np.any(blocks < 0):
        raise RuntimeError("facet_centroid_rows: facet node without a DOF block")
    w = np.array([-1 / 9] * 3 + [4 / 9] * 3)
    n_v = 3 * (V.dofmap.index_map.size_local + V.dofmap.index_map.num_ghosts)
    rows = np.repeat(np.arange(facets.size), 6)
    Rc = [sp.csr_matrix((np.tile(w, facets.size), (rows, (3 * blocks + i).ravel())),
                        shape=(facets.size, n_v)) for i in range(3)]
    Rn = sum(sp.diags(nrm[:, i]) @ Rc[i] for i in range(3)).tocsr()
    return Rc, Rn, area, cen, nrm


def facet_normal_velocity_rows(mesh, V, facets: np.ndarray):
    """``(Rn, area, centroid, normal)`` of :func:`facet_centroid_rows` (``n·u`` rows)."""
    _, Rn, area, cen, nrm = facet_centroid_rows(mesh, V, facets)
    return Rn, area, cen, nrm


def sphere_erp(radius: float, u0: float, omega: float, rho: float = AIR_DENSITY,
               c: float = SOUND_SPEED) -> float:
    """Closed form: ERP of a sphere pulsating with radial amplitude ``u0`` [W]."""
    return 0.5 * rho * c * (omega * u0) ** 2 * 4.0 * math.pi * radius ** 2


#: File of the radiation data in a cached ROM entry.
RADIATION_FILE = "radiation.h5"


def radiation_data(model, T: np.ndarray, path, part: str = "housing") -> None:
    """Write the ROM's radiation data of ``part``'s outer surface to ``path`` (HDF5).

    Datasets: ``W`` (n_r × n_r, m²), ``facet_rows`` (n_f × n_r: n·u at each facet
    centroid per unit ROM coordinate), ``facet_u_rows`` (n_f × 3 × n_r: u there),
    ``facet_area`` (m², flat), ``facet_centroid``, ``facet_normal`` (n_f × 3),
    ``facet_nodes`` (n_f × 6 indices into ``points``, ``triangle6`` order),
    ``points`` (geometry nodes of those facets, m); attributes ``area`` (P2 area,
    m²), ``n_facets``, ``part``, ``quadrature_degree``.
    """
    import h5py

    mesh = model.fe_mesh.mesh
    facets = outer_surface_facets(model.fe_mesh, part)
    PT = fe_basis(model, T)
    W = reduced_radiation_matrix(model, T, facets, PT)
    Rc, Rn, fa, cen, nrm = facet_centroid_rows(mesh, model.V, facets)
    g, _ = facet_geometry_nodes(mesh, facets)
    used, inv = np.unique(g, return_inverse=True)
    n_fe = PT.shape[0]
    with h5py.File(path, "w") as f:
        f["W"] = W
        f["facet_rows"] = Rn[:, :n_fe] @ PT
        f["facet_u_rows"] = np.stack([R[:, :n_fe] @ PT for R in Rc], axis=1)
        f["facet_area"] = fa
        f["facet_centroid"] = cen
        f["facet_normal"] = nrm
        f["facet_nodes"] = inv.reshape(g.shape).astype(np.int64)
        f["points"] = mesh.geometry.x[used]
        f.attrs["area"] = surface_area(mesh, facets)
        f.attrs["n_facets"] = int(facets.size)
        f.attrs["part"] = part
        f.attrs["quadrature_degree"] = QUADRATURE_DEGREE
    logger.info("radiation matrix of the %s outer surface: %d facets, %.4g m²", part,
                facets.size, float(np.sum(fa)))
