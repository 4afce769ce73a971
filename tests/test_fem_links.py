"""Rigid links, clamps and lumped parts of fem: rigid-body modes, rigid motions,
mass properties and small spring-mass systems against closed forms."""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("dolfinx")

import fem_support as fs  # noqa: E402
from mpi4py import MPI  # noqa: E402

import fem  # noqa: E402
from gears.pair import pair_frame  # noqa: E402

pytestmark = pytest.mark.fem

L, R = 0.2, 0.01


@pytest.fixture(scope="module")
def shaft() -> fem.FEModel:
    return fs.free_shaft_model(h=0.01, length=L, radius=R)


def test_free_shaft_has_six_rigid_modes(shaft: fem.FEModel) -> None:
    f = fem.eigenfrequencies(shaft.K, shaft.M, 8, sigma=-1e2)
    # Double precision floor: the stored K has element entries rounded at
    # eps |K_ij| ~ 1e-16 * E h, so a rigid field has a Rayleigh quotient of order
    # eps * sqrt(nnz) |K_ij| / m, i.e. |f| ~ 1e-3 Hz for this 0.2 m steel shaft
    # (the exact rigid subspace itself gives 1.4e-3 Hz). We demand
    # lambda_rigid / lambda_7 < 2.5e-11, i.e. |f| < 5e-6 f_7 (~1e-2 Hz here).
    assert f[6] > 500.0
    assert np.all(np.abs(f[:6]) < 5e-6 * f[6]), f
    # first elastic modes: the bending pair
    assert f[7] / f[6] - 1 < 1e-3


def test_reduced_matrices_symmetric(shaft: fem.FEModel) -> None:
    from petsc4py import PETSc

    for A in (shaft.K, shaft.M):
        At = A.transpose(PETSc.Mat())
        At.axpy(-1.0, A)
        assert At.norm() < 1e-14 * A.norm()


def test_rigid_motion_strains_nothing(shaft: fem.FEModel) -> None:
    a, th, o = np.array([1e-3, -2e-3, 5e-4]), np.array([0.01, -0.03, 0.02]), np.array([0.1, 0, 0])
    # K q vanishes and the prolongation rebuilds the rigid field exactly at every P2 DOF
    q, strain, err = fs.rigid_motion_residuals(shaft, a, th, o)
    assert strain < 1e-14 and err < 1e-15
    # the gear-frame node carries the motion in its local frame
    red = shaft.node_dofs["b"]
    lo, hi = q.getOwnershipRange()
    if lo <= red[0] < hi:
        R_b = shaft.spec.nodes[shaft.spec.node_index("b")].frame
        got = q.getArray()[red - lo]
        np.testing.assert_allclose(got[:3], R_b.T @ (a + np.cross(th, [0, 0, L] - o)), atol=1e-18)
        np.testing.assert_allclose(got[3:], R_b.T @ th, atol=1e-18)


def test_mass_and_inertia_of_linked_shaft(shaft: fem.FEModel) -> None:
    import ufl
    from dolfinx import fem as dfem

    rho = fs.STEEL_TEST.rho
    disk = fem.disk_mass(0.05, 0.016, 0.02, 7850.0)
    msh = shaft.fe_mesh.mesh
    x = ufl.SpatialCoordinate(msh)
    vol, jz = (msh.comm.allreduce(dfem.assemble_scalar(dfem.form(e * ufl.dx(domain=msh))))
               for e in (1.0, x[0] ** 2 + x[1] ** 2))  # fmt: skip
    mx = shaft.M.createVecLeft()
    qx = shaft.rigid_motion([1, 0, 0], [0, 0, 0], [0, 0, 0])
    shaft.M.mult(qx, mx)
    # q^T M q of a rigid translation = rho * (mesh volume) + disk mass
    assert abs(qx.dot(mx) / (rho * vol + disk[0, 0]) - 1) < 1e-12
    # and the P2 mesh volume is the cylinder's to the chordal error ~ 3e-4
    assert abs(vol / (math.pi * R**2 * L) - 1) < 1e-3
    qz = shaft.rigid_motion([0, 0, 0], [0, 0, 1], [0, 0, 0])
    shaft.M.mult(qz, mx)
    assert abs(qz.dot(mx) / (rho * jz + disk[5, 5]) - 1) < 1e-12
    assert abs(jz / (math.pi * R**4 * L / 2) - 1) < 2e-3


def _chain_model(alpha: float) -> tuple[fem.FEModel, dict]:
    """Clamped stiff cylinder plus two free lumped nodes: ground -k1- n1 -k2- n2."""
    with fs.gmsh_session() as model:
        fs.build_cylinder(0.05, 0.01, 0.01, MPI.COMM_WORLD.rank)
        fe_mesh = fem.load_gmsh_mesh(model)
    p = {"m1": 2.0, "m2": 0.5, "J1": 1e-3, "J2": 4e-4, "k1": 3e5, "k2": 1e5, "kt1": 50.0,
         "kt2": 20.0}
    spec = fem.ModelSpec()
    spec.add_clamp("end_a")
    spec.add_node("n1", [0.3, 0.1, 0.0])
    spec.add_node("n2", [0.3, 0.2, 0.0], frame=pair_frame(alpha))
    spec.add_mass("n1", fem.rigid_body_mass(p["m1"], [p["J1"]] * 3))
    spec.add_mass("n2", fem.rigid_body_mass(p["m2"], [p["J2"]] * 3))
    spec.add_spring("n1", fem.axial_spring(p["k1"], p["k1"], p["kt1"], p["kt1"]))
    spec.add_spring("n1", fem.axial_spring(p["k2"], p["k2"], p["kt2"], p["kt2"]), other="n2")
    return fem.build_model(fe_mesh, {"shaft": fs.STEEL_TEST}, spec), p


def test_two_node_spring_chain_in_rotated_frame() -> None:
    model, p = _chain_model(alpha=math.radians(20))
    f = fem.eigenfrequencies(model.K, model.M, 12, sigma=0.0)

    def chain(m1: float, m2: float, k1: float, k2: float) -> np.ndarray:
        from scipy.linalg import eigh

        K = np.array([[k1 + k2, -k2], [-k2, k2]])
        return np.sqrt(eigh(K, np.diag([m1, m2]), eigvals_only=True)) / (2 * math.pi)

    ft = chain(p["m1"], p["m2"], p["k1"], p["k2"])
    fr = chain(p["J1"], p["J2"], p["kt1"], p["kt2"])
    expected = np.sort(np.concatenate([np.repeat(ft, 3), np.repeat(fr, 3)]))
    np.testing.assert_allclose(f, expected, rtol=1e-9)


def test_shared_dof_between_links_is_refused_or_resolved() -> None:
    with fs.gmsh_session() as model:
        fs.build_cylinder(0.05, 0.01, 0.01, MPI.COMM_WORLD.rank)
        fe_mesh = fem.load_gmsh_mesh(model)
    spec = fem.ModelSpec(shared="error")
    spec.add_node("a", [0, 0, 0])
    spec.add_node("s", [0, 0, 0.025])
    spec.add_link("end_a", "a")
    spec.add_link("side", "s")  # shares the rim circle of end_a
    with pytest.raises(ValueError, match="shares"):
        fem.build_model(fe_mesh, {"shaft": fs.STEEL_TEST}, spec)
    spec.shared = "first"
    m = fem.build_model(fe_mesh, {"shaft": fs.STEEL_TEST}, spec)
    # rim DOF stay with "a": the two links together still move rigidly with a rigid motion
    q = m.rigid_motion([0, 1e-3, 0], [0.02, 0, 0.01], [0, 0, 0])
    r = m.K.createVecLeft()
    m.K.mult(q, r)
    assert r.norm() / (m.K.norm() * q.norm()) < 1e-14


def test_clamp_removes_exactly_the_face_dofs() -> None:
    with fs.gmsh_session() as model:
        fs.build_cylinder(0.05, 0.01, 0.01, MPI.COMM_WORLD.rank)
        n_face = None
        if MPI.COMM_WORLD.rank == 0:
            import gmsh

            tags = set()
            for ent in gmsh.model.getEntitiesForPhysicalGroup(2, 10):
                for en in gmsh.model.mesh.getElements(2, ent)[2]:
                    tags.update(int(t) for t in en)
            n_face = len(tags)
        fe_mesh = fem.load_gmsh_mesh(model)
    n_face = MPI.COMM_WORLD.bcast(n_face)
    spec = fem.ModelSpec()
    spec.add_clamp("end_a")
    m = fem.build_model(fe_mesh, {"shaft": fs.STEEL_TEST}, spec)
    assert m.info["clamped"] == 3 * n_face
    assert m.n_red == m.info["n_fe"] - 3 * n_face


def test_bad_inputs_raise_value_error() -> None:
    with pytest.raises(ValueError, match="nu"):
        fem.Material(E=1e9, nu=0.5, rho=1.0)
    spec = fem.ModelSpec()
    spec.add_node("a", [0, 0, 0])
    with pytest.raises(ValueError, match="already"):
        spec.add_node("a", [0, 0, 1])
    with pytest.raises(ValueError, match="no such node"):
        spec.add_link("side", "zz")
    with pytest.raises(ValueError, match="symmetric"):
        spec.add_mass("a", np.triu(np.ones((6, 6))))
    with pytest.raises(ValueError, match="bore_radius"):
        fem.disk_mass(0.01, 0.02, 0.02, 7800.0)
    with pytest.raises(ValueError, match="radial"):
        fem.BearingParams(radial=-1.0)


def test_displacement_from_numpy_equals_from_vec(shaft: fem.FEModel) -> None:
    q = shaft.rigid_motion([1e-3, 0, 0], [0, 0.01, 0], [0, 0, 0])
    from petsc4py import PETSc

    scatter, q0 = PETSc.Scatter.toAll(q)
    scatter.scatter(q, q0)
    arr = q0.getArray().copy()
    u_vec = shaft.displacement(q)
    u_all = shaft.displacement(arr)
    u_root = shaft.displacement(arr if shaft.comm.rank == 0 else None, root=0)
    assert np.array_equal(u_vec.x.array, u_all.x.array)
    assert np.array_equal(u_vec.x.array, u_root.x.array)
    with pytest.raises(ValueError, match="n_red"):
        shaft.displacement(arr[:-1])


def test_projection_keeps_no_operand_alive():
    """``fem.model.project`` gives ``Pᵀ A P`` and drops PETSc's product data: afterwards
    ``A`` and ``P`` are referenced only by the caller (before, ``K̄`` held ``K P`` and,
    through it, the full P2 ``K``: docs/scale.md)."""
    from petsc4py import PETSc

    from fem.model import project

    rng = np.random.default_rng(4)
    n, m = 30, 12
    Ad = rng.standard_normal((n, n))
    Ad = Ad + Ad.T
    Pd = np.zeros((n, m))
    Pd[np.arange(n), rng.integers(0, m, n)] = rng.standard_normal(n)
    A, P = (PETSc.Mat().createAIJ(D.shape, csr=_csr_of(D)) for D in (Ad, Pd))
    for X in (A, P):
        X.assemble()
    out = project(A, P)
    assert A.getRefCount() == 1 and P.getRefCount() == 1
    ia, ja, va = out.getValuesCSR()
    got = np.zeros((m, m))
    for i in range(m):
        got[i, ja[ia[i]:ia[i + 1]]] = va[ia[i]:ia[i + 1]]
    np.testing.assert_allclose(got, Pd.T @ Ad @ Pd, rtol=1e-13, atol=1e-13 * np.abs(Ad).max())


def _csr_of(D):
    nz = D != 0
    ia = np.concatenate([[0], np.cumsum(nz.sum(axis=1))]).astype(np.int32)
    ja = np.nonzero(nz)[1].astype(np.int32)
    return ia, ja, D[nz]
