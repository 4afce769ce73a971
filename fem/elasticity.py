"""P2 vector elasticity: stiffness and consistent mass matrices (PETSc, distributed)."""

from __future__ import annotations

import logging
from typing import Any

import numpy as np
from mpi4py import MPI

from .materials import Material
from .mesh import FEMesh

log = logging.getLogger(__name__)


def cellwise_material(fe_mesh: FEMesh, materials: dict[str, Material]) -> tuple[Any, Any, Any]:
    """DG0 fields (lambda, mu, rho) from a material per volume name.

    Parameters
    ----------
    fe_mesh : FEMesh
    materials : dict[str, Material]
        Volume physical-group name -> material. Every cell of the mesh must carry
        one of these volume tags.

    Returns
    -------
    (lam, mu, rho) : dolfinx.fem.Function
        Lamé parameters (Pa) and density (kg/m^3), piecewise constant.
    """
    from dolfinx import fem

    mesh = fe_mesh.mesh
    Q = fem.FunctionSpace(mesh, ("DG", 0))
    lam, mu, rho = fem.Function(Q), fem.Function(Q), fem.Function(Q)
    n_local = mesh.topology.index_map(3).size_local
    covered = np.zeros(n_local + mesh.topology.index_map(3).num_ghosts, dtype=bool)
    dofs_of_cell = Q.dofmap.list.array.reshape(-1)
    for name, mat in materials.items():
        if not isinstance(mat, Material):
            raise ValueError(f"materials[{name!r}] = {mat!r}: must be a fem.Material")
        tag = fe_mesh.tag(name, 3)
        cells = fe_mesh.cell_tags.find(tag)
        if np.any(covered[cells]):
            raise ValueError(f"materials[{name!r}]: its cells already have a material")
        covered[cells] = True
        l_, m_ = mat.lame
        dofs = dofs_of_cell[cells]
        lam.x.array[dofs] = l_
        mu.x.array[dofs] = m_
        rho.x.array[dofs] = mat.rho
    n_missing = mesh.comm.allreduce(int(np.count_nonzero(~covered[:n_local])), op=MPI.SUM)
    if n_missing:
        raise ValueError(
            f"materials = {sorted(materials)}: {n_missing} cells carry no listed volume tag"
        )
    for f in (lam, mu, rho):
        f.x.scatter_forward()
    return lam, mu, rho


def assemble_elasticity(
    fe_mesh: FEMesh,
    materials: dict[str, Material],
    degree: int = 2,
    quadrature_degree: int | None = None,
) -> tuple[Any, Any, Any]:
    """Assemble K and the consistent M of linear elasticity, no boundary conditions.

    Parameters
    ----------
    fe_mesh : FEMesh
    materials : dict[str, Material]
        Volume name -> material.
    degree : int
        Lagrange degree of the displacement (2 for 10-node tetrahedra).
    quadrature_degree : int, optional
        Quadrature degree of both forms. ``None`` lets UFL choose (exact for
        straight cells); 2 reproduces CalculiX C3D10 (4-point rule).

    Returns
    -------
    V : dolfinx.fem.FunctionSpace
        Vector space (block size 3), global DOF ``3*block + component``.
    K, M : petsc4py.PETSc.Mat
        Stiffness (N/m) and mass (kg), distributed AIJ, rows in V's ownership ranges.
    """
    import ufl
    from dolfinx import fem
    from dolfinx.fem.petsc import assemble_matrix

    if degree not in (1, 2, 3):
        raise ValueError(f"degree = {degree}: must be 1, 2 or 3")
    if quadrature_degree is not None and not (1 <= quadrature_degree <= 12):
        raise ValueError(f"quadrature_degree = {quadrature_degree}: must be in [1, 12] or None")
    mesh = fe_mesh.mesh
    V = fem.VectorFunctionSpace(mesh, ("CG", degree))
    lam, mu, rho = cellwise_material(fe_mesh, materials)
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)

    def eps(w: Any) -> Any:
        return ufl.sym(ufl.grad(w))

    md = {} if quadrature_degree is None else {"quadrature_degree": int(quadrature_degree)}
    dx = ufl.dx(domain=mesh, metadata=md)
    sigma = 2.0 * mu * eps(u) + lam * ufl.tr(eps(u)) * ufl.Identity(3)
    a_k = fem.form(ufl.inner(sigma, eps(v)) * dx)
    a_m = fem.form(rho * ufl.inner(u, v) * dx)
    K = assemble_matrix(a_k)
    K.assemble()
    M = assemble_matrix(a_m)
    M.assemble()
    n = V.dofmap.index_map.size_global * V.dofmap.index_map_bs
    log.info("assembled P%d elasticity: %d DOF", degree, n)
    return V, K, M
