"""The radiation data of fem.post (equivalent radiated power) against closed forms on
small gmsh/DOLFINx meshes:
uniform translation of a box (ERP = ½ρc v² Σ A n_x² = ½ρc v² · 2 A_yz), a pulsating
sphere (½ρc v² 4πR², converging with the mesh), a plate mode (∫ sin² = ab/4 per
face, converging with the mesh), the outer skin of a hollow casing, and the reduced
form W = (PT)ᵀ A (PT) equal to the direct integral."""
from __future__ import annotations

import math

import numpy as np
import pytest

pytestmark = pytest.mark.fem

RHO, C = 1.2, 343.0


def _mesh(build, h: float):
    """Second-order tetrahedral DOLFINx mesh of the OCC solid made by ``build()``."""
    import gmsh
    from dolfinx.io import gmshio
    from mpi4py import MPI

    from geometry import gmsh_session

    with gmsh_session():
        gmsh.clear()
        gmsh.model.add("t")
        vols = build(gmsh.model.occ)
        gmsh.model.occ.synchronize()
        for i, v in enumerate(vols, start=1):
            gmsh.model.addPhysicalGroup(3, [v], i)
            gmsh.model.setPhysicalName(3, i, "housing" if i == 1 else f"part{i}")
        gmsh.option.setNumber("Mesh.MeshSizeMax", h)
        gmsh.option.setNumber("Mesh.MeshSizeMin", 0.2 * h)
        gmsh.model.mesh.generate(3)
        gmsh.model.mesh.setOrder(2)
        groups = {gmsh.model.getPhysicalName(d, t): (d, t)
                  for d, t in gmsh.model.getPhysicalGroups()}
        mesh, ct, ft = gmshio.model_to_mesh(gmsh.model, MPI.COMM_WORLD, 0, gdim=3)
        gmsh.clear()
    from fem import FEMesh
    return FEMesh(mesh, ct, ft, groups, {})


def _space_and_field(fe_mesh, fun):
    from dolfinx import fem

    V = fem.VectorFunctionSpace(fe_mesh.mesh, ("CG", 2))
    u = fem.Function(V)
    u.interpolate(fun)
    return V, u


def _direct_erp(V, u, facets, omega):
    from fem.post import normal_gram

    A = normal_gram(V, facets)
    x = u.vector
    y = A.createVecLeft()
    A.mult(x, y)
    return 0.5 * RHO * C * omega ** 2 * x.dot(y)


def _all_exterior(fe_mesh):
    from dolfinx import mesh as dmesh

    top = fe_mesh.mesh.topology
    top.create_connectivity(2, 3)
    return np.asarray(dmesh.exterior_facet_indices(top), dtype=np.int32)


def test_box_translation_closed_form():
    a, b, c = 0.3, 0.2, 0.1
    fm = _mesh(lambda occ: [occ.addBox(0, 0, 0, a, b, c)], 0.06)
    v, omega = 2e-3, 2 * math.pi * 500.0
    u0 = v / omega
    V, u = _space_and_field(fm, lambda x: np.vstack([np.full(x.shape[1], u0),
                                                     np.zeros(x.shape[1]),
                                                     np.zeros(x.shape[1])]))
    facets = _all_exterior(fm)
    expect = 0.5 * RHO * C * v ** 2 * 2 * b * c
    assert _direct_erp(V, u, facets, omega) == pytest.approx(expect, rel=1e-10)
    # face-centroid rows: n_x on every facet, Σ A (n·u)² the same integral
    from fem.post import facet_geometry_nodes, facet_normal_velocity_rows, surface_area

    g, _ = facet_geometry_nodes(fm.mesh, facets)
    p = fm.mesh.geometry.x[g]        # flat facets: edge nodes at the mid-points of the edges
    mids = 0.5 * (p[:, [0, 1, 2]] + p[:, [1, 2, 0]])   # triangle6: ab, bc, ca
    np.testing.assert_allclose(p[:, 3:], mids, atol=1e-12)
    R, area, cen, nrm = facet_normal_velocity_rows(fm.mesh, V, facets)
    vn = R @ u.x.array
    np.testing.assert_allclose(vn, u0 * nrm[:, 0], atol=1e-12 * u0)
    assert 0.5 * RHO * C * omega ** 2 * np.sum(area * vn ** 2) == pytest.approx(expect, rel=1e-10)
    assert surface_area(fm.mesh, facets) == pytest.approx(2 * (a * b + b * c + c * a), rel=1e-12)
    # normals point outwards: (centroid - box centre) · n > 0
    assert np.all(np.einsum("ij,ij->i", cen - [a / 2, b / 2, c / 2], nrm) > 0)


def test_pulsating_sphere_converges():
    R0, u0, omega = 1.0, 1e-6, 2 * math.pi * 200.0
    from study.outputs.acoustics import sphere_erp

    errs = []
    for h in (0.5, 0.25, 0.125):
        fm = _mesh(lambda occ: [occ.addSphere(0, 0, 0, R0)], h)
        V, u = _space_and_field(fm, lambda x: u0 * x / np.linalg.norm(x, axis=0))
        erp = _direct_erp(V, u, _all_exterior(fm), omega)
        errs.append(abs(erp / sphere_erp(R0, u0, omega, RHO, C) - 1))
    print("sphere relative ERP errors", errs)
    assert errs[0] < 1e-3 and errs[2] < errs[1] < errs[0], errs
    assert errs[2] < errs[0] / 4, errs


def test_plate_mode_converges():
    """Thin plate a × b × t moving along z as the (1, 1) mode w = w0 sin(πx/a) sin(πy/b):
    top and bottom faces each give ∫ w² dA = w0² ab/4; the side faces none (n_z = 0)."""
    a, b, t = 0.4, 0.3, 0.01
    w0, omega = 1e-6, 2 * math.pi * 300.0
    expect = 0.5 * RHO * C * omega ** 2 * w0 ** 2 * 2 * a * b / 4
    errs = []
    for h in (0.05, 0.025):
        fm = _mesh(lambda occ: [occ.addBox(0, 0, 0, a, b, t)], h)
        V, u = _space_and_field(fm, lambda x: np.vstack([
            np.zeros(x.shape[1]), np.zeros(x.shape[1]),
            w0 * np.sin(np.pi * x[0] / a) * np.sin(np.pi * x[1] / b)]))
        errs.append(abs(_direct_erp(V, u, _all_exterior(fm), omega) / expect - 1))
    print("plate relative ERP errors", errs)
    assert errs[0] < 1e-3 and errs[1] < errs[0] / 4, errs  # P2: ~h^4


def test_outer_skin_of_hollow_casing():
    """Closed casing (box minus an inner box): the outer skin is found, not the cavity."""
    from fem.post import outer_surface_facets, surface_area

    a, b, c, t = 0.3, 0.2, 0.15, 0.02

    def build(occ):
        outer = occ.addBox(0, 0, 0, a, b, c)
        inner = occ.addBox(t, t, t, a - 2 * t, b - 2 * t, c - 2 * t)
        res, _ = occ.cut([(3, outer)], [(3, inner)])
        return [res[0][1]]

    fm = _mesh(build, 0.05)
    f = outer_surface_facets(fm, "housing")
    assert surface_area(fm.mesh, f) == pytest.approx(2 * (a * b + b * c + c * a), rel=1e-10)
    assert surface_area(fm.mesh, _all_exterior(fm)) > 1.5 * surface_area(fm.mesh, f)


def test_reduced_matrix_equals_direct_integral():
    """W = (PT)ᵀ A (PT) with a random basis T and P = I: qᵀ W q = ∫ (n·Tq)² dA."""
    import types

    from petsc4py import PETSc

    from fem.post import field_operator, reduced_radiation_matrix

    fm = _mesh(lambda occ: [occ.addBox(0, 0, 0, 0.2, 0.1, 0.1)], 0.08)
    V, u = _space_and_field(fm, lambda x: np.vstack([x[1] ** 2, x[0] * x[2], x[2] + x[0]]))
    n = u.vector.getSize()
    P = PETSc.Mat().createAIJ((n, n), nnz=1)
    P.setUp()
    P.setDiagonal(_ones(P))
    P.assemble()
    rng = np.random.default_rng(1)
    T = np.column_stack([u.x.array, rng.standard_normal((n, 3))])
    model = types.SimpleNamespace(comm=fm.mesh.comm, V=V, P=P)
    facets = _all_exterior(fm)
    W = reduced_radiation_matrix(model, field_operator(model, T), facets)
    q = np.array([1.0, 0, 0, 0])
    assert q @ W @ q == pytest.approx(_direct_erp(V, u, facets, 1.0) / (0.5 * RHO * C), rel=1e-10)
    assert np.all(np.linalg.eigvalsh(W) > -1e-12 * np.abs(W).max())


def _ones(P):
    v = P.createVecLeft()
    v.set(1.0)
    return v
