"""Radiation data of a part's outer surface: the reduced radiation matrix ``W`` of the
equivalent radiated power (ERP) and the rows that give ``u`` and ``n·u`` at the outer
facets' centroids, per unit ROM coordinate.

ERP is the sound power a surface would radiate if every element radiated as a plane
wave (radiation efficiency 1), ``P = ½ ρ c ∫_Γ |v_n|² dA``. For a harmonic
``ũ = P T q̃`` (eq. 8) of angular frequency ω, ``P = ½ ρ c ω² q̃ᴴ W q̃`` with

    W = (P T)ᵀ A (P T),      A_ij = ∫_Γ (φ_i·n)(φ_j·n) dA       (P2 shape functions φ)

(n_r × n_r, m²): built once per ROM, the ERP of a continuation point is then a few
n_r² products (``study.outputs.acoustics.erp_harmonics``).

Quadrature: on a flat (affine) facet ``(φ_i·n)(φ_j·n)`` is a polynomial of degree 4,
so a degree-4 rule is exact; on the curved P2 facets of bosses and bores the integrand
is rational and degree 6 is used (the sphere test in ``tests/test_fem_post_radiation.py``
shows it converged to the geometry error).

Every function here is collective on the mesh communicator: each rank integrates and
projects on its own facets with its rows of the distributed ``P T``; only the small
outputs (W, the facet rows) are summed or gathered on rank 0, ordered by the input
mesh's node numbers, so they do not depend on the partition.
"""
from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import numpy as np

from core.files import atomic_write
from fem.dense import dense_projection
from fem.post.operator import on_p_layout, point_rows
from fem.post.surface import (
    CENTROID_WEIGHTS,
    facet_frames,
    gather_on_root,
    input_ids,
    node_blocks,
    outer_surface_facets,
)

logger = logging.getLogger(__name__)

__all__ = ["QUADRATURE_DEGREE", "RADIATION_FILE", "surface_measure", "surface_area",
           "normal_gram", "reduced_radiation_matrix", "radiation_data", "read_radiation"]

#: Quadrature degree of the surface integrals (exact for affine P2 facets: degree 4).
QUADRATURE_DEGREE = 6
#: File of the radiation data in a cached ROM entry.
RADIATION_FILE = "radiation.h5"


def surface_measure(mesh: Any, facets: np.ndarray) -> Any:
    """UFL surface measure ``ds`` restricted to ``facets`` (degree ``QUADRATURE_DEGREE``)."""
    import ufl
    from dolfinx import mesh as dmesh

    f = np.asarray(facets, dtype=np.int32)
    order = np.argsort(f)
    mt = dmesh.meshtags(mesh, 2, f[order], np.ones(f.size, dtype=np.int32))
    return ufl.Measure("ds", domain=mesh, subdomain_data=mt,
                       metadata={"quadrature_degree": QUADRATURE_DEGREE})(1)


def surface_area(mesh: Any, facets: np.ndarray) -> float:
    """Area of the facets [m²] (P2 geometry); collective: each rank's ``facets`` are its
    own, the sum over the ranks is returned on every rank."""
    from dolfinx import fem

    one = fem.Constant(mesh, 1.0)
    return float(mesh.comm.allreduce(fem.assemble_scalar(fem.form(
        one * surface_measure(mesh, facets)))))


def normal_gram(V: Any, facets: np.ndarray) -> Any:
    """PETSc matrix ``A_ij = ∫_Γ (φ_i·n)(φ_j·n) dA`` on the facets (vector space V) [m²]."""
    import ufl
    from dolfinx import fem
    from dolfinx.fem.petsc import assemble_matrix

    mesh = V.mesh
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    n = ufl.FacetNormal(mesh)
    A = assemble_matrix(fem.form(ufl.dot(u, n) * ufl.dot(v, n) * surface_measure(mesh, facets)))
    A.assemble()
    return A


def reduced_radiation_matrix(model: Any, PT: Any, facets: np.ndarray) -> np.ndarray:
    """``W = (P T)ᵀ A (P T)`` (n_r × n_r) [m²] for the FE model's outer facets (collective;
    the same W on every rank).

    Parameters
    ----------
    model : fem.FEModel
        FE model (``P`` maps its reduced unknowns to the P2 DOF of ``V``), serial or
        distributed.
    PT : PETSc dense Mat
        ``P T`` (:func:`fem.post.operator.field_operator`).
    facets : int array
        This rank's facets of the radiating surface (:func:`outer_surface_facets`).
    """
    A = normal_gram(model.V, facets)
    Ap = on_p_layout(A, model.P)
    A.destroy()
    W = dense_projection(Ap, PT)
    Ap.destroy()
    return W


def _centroid_u_rows(model: Any, PT: Any, g: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """``u`` at each local facet's centroid per unit ROM coordinate (n_f × 3 × n_r)."""
    n_f = g.shape[0]
    blocks = (node_blocks(model.fe_mesh.mesh, model.V, cells)[g] if n_f
              else np.zeros((0, 6), dtype=np.int64))
    return point_rows(model, PT, blocks, CENTROID_WEIGHTS)


def radiation_data(model: Any, PT: Any, path: str | Path, part: str = "housing") -> None:
    """Write the ROM's radiation data of ``part``'s outer surface to ``path`` (HDF5);
    collective on ``model.comm``, rank 0 writes.

    Each rank computes its facets' part (``P T`` stays distributed, no rank builds a
    serial FE model or the dense basis); W is summed and the facet rows are gathered
    on rank 0 and sorted by the facets' input-mesh vertex numbers, so the file does
    not depend on the number of ranks or the partition.

    Parameters
    ----------
    model : fem.FEModel
    PT : PETSc dense Mat
        ``P T`` (:func:`fem.post.operator.field_operator`).
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

    comm = model.comm
    mesh = model.fe_mesh.mesh
    facets = outer_surface_facets(model.fe_mesh, part)
    W = reduced_radiation_matrix(model, PT, facets)
    g, cells, fa, cen, nrm = facet_frames(mesh, facets)
    urows = _centroid_u_rows(model, PT, g, cells)
    area = surface_area(mesh, facets)
    ids = input_ids(mesh, g)
    parts = {"ids": ids, "x": mesh.geometry.x[g], "urows": urows, "area": fa, "cen": cen,
             "nrm": nrm}
    got = {k: gather_on_root(comm, v) for k, v in parts.items()}
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


def read_radiation(path: str | Path) -> dict | None:
    """Datasets and attributes of a radiation file (:func:`radiation_data`) as one dict;
    None when the file is absent."""
    import h5py

    p = Path(path)
    if not p.exists():
        return None
    with h5py.File(p, "r") as f:
        out = {k: f[k][()] for k in f}
        out.update({k: f.attrs[k] for k in f.attrs})
    return out
