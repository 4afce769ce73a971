"""Matrix-free Newton matrices (hbm/krylov.py): the operator equals the dense Jacobian,
GMRES solves to its tolerance, and a continuation gives the dense path's branch."""

import numpy as np
import pytest

import hbm
from hbm.basis import HarmonicSet
from hbm.krylov import LoaJacobian, bordered, gmres
from hbm.newton import solve_checked

Z = 20
RPM = hbm.RPM_TO_RAD_S


def _pair(hs, solver):
    """Unit-mass gear pair with impacts (the pair of test_hbm_harmonic_sets.py)."""
    system = hbm.LinearSystem(M=[[1.0]], C=[[0.1]], K=[[0.0]])
    mesh = hbm.GearMesh(direction=[1.0], n_teeth=Z, stiffness={0: 1.0, 1: 0.2}, te={},
                        backlash=1.0)
    exc = hbm.Excitation(1, constant={0: [0.1], 2: [0.04], 5: [0.06]})
    return hbm.HBMProblem(system, [mesh], exc, hs, "loa", linear_solver=solver)


@pytest.fixture(scope="module")
def impact_point():
    hs = HarmonicSet(range(3 * Z + 11), fundamental="shaft")
    pb = _pair(hs, "krylov")
    br = hbm.trace(pb, 0.3 / Z / RPM, 0.06 / RPM, stability=False, max_points=60)
    i = int(np.argmax(br.element(0).contact_loss_fraction))
    assert br.element(0).contact_loss_fraction[i] > 0.05          # an orbit with impacts
    return pb, br.unknowns[i], br.omega[i]


def test_synthesis_and_analysis_by_fft_equal_the_aft_matrices():
    rng = np.random.default_rng(0)
    hs = HarmonicSet((0, 3, 7, 20, 41), n_time=512)
    for n in (None, 37, 64):                           # 37, 64: aliased grids
        e, a = hs.aft_matrices(n)
        x = rng.standard_normal((2, hs.n_real))
        t = rng.standard_normal((3, e.shape[0]))
        assert np.allclose(hs.synthesize(x, n), x @ e.T, rtol=0, atol=1e-12)
        assert np.allclose(hs.analyse(t), t @ a.T, rtol=0, atol=1e-13)


def test_operator_equals_the_dense_jacobian(impact_point):
    pb, u, w = impact_point
    _, jop, _ = pb.scaled(u / pb.x_scale, w)
    assert isinstance(jop, LoaJacobian)
    pb.matrix_free = False
    try:
        _, jd, _ = pb.scaled(u / pb.x_scale, w)
    finally:
        pb.matrix_free = True
    assert np.allclose(jop.dense(), jd, rtol=0, atol=1e-12 * np.abs(jd).max())
    v = np.random.default_rng(1).standard_normal(jd.shape[0])
    assert np.allclose(jop @ v, jd @ v, rtol=0, atol=1e-12 * np.linalg.norm(jd @ v))


def test_gmres_with_a_stale_factor_solves_to_its_tolerance(impact_point):
    pb, u, w = impact_point
    _, j1, jw = pb.scaled(u / pb.x_scale, w)
    _, j2, _ = pb.scaled(u / pb.x_scale, 1.01 * w)     # another matrix as preconditioner
    import scipy.linalg as sla

    lu = sla.lu_factor(j2.dense())
    b = np.random.default_rng(2).standard_normal(j1.size)
    x, its, ok = gmres(j1.__matmul__, b, lambda r: sla.lu_solve(lu, r), rtol=1e-10)
    assert ok and its < 40
    assert np.linalg.norm(j1.dense() @ x - b) < 2e-10 * np.linalg.norm(b)
    # the bordered operator of the continuation: same against its dense matrix
    row = np.random.default_rng(3).standard_normal(j1.size + 1)
    bop = bordered(j1, jw, row)
    xb, _ = solve_checked(bop, np.append(b, 1.0), "test")
    dense = np.vstack([np.hstack([j1.dense(), jw[:, None]]), row[None, :]])
    assert np.linalg.norm(dense @ xb - np.append(b, 1.0)) < 1e-9 * np.linalg.norm(b)


def test_krylov_and_dense_continuations_give_the_same_branch():
    hs = HarmonicSet(range(3 * Z + 11), fundamental="shaft")
    lo, hi = 0.3 / Z / RPM, 0.06 / RPM
    bk = hbm.trace(_pair(hs, "krylov"), lo, hi, stability=False)
    bd = hbm.trace(_pair(hs, "dense"), lo, hi, stability=False)
    assert bk.status == bd.status == "completed"
    # the step histories differ (the condition estimate is that of a stale factor, which
    # changes when a point is refined), the curve does not
    sk, sd = bk.element(0).mesh_load_std, bd.element(0).mesh_load_std
    assert sk[-1] == pytest.approx(sd[-1], rel=1e-9)
    # (the peak as sampled by each branch's own points)
    assert sk.max() == pytest.approx(sd.max(), rel=2e-3)
    assert len(bk.grazing) == len(bd.grazing) > 0
    assert [g.rpm for g in bk.grazing] == pytest.approx([g.rpm for g in bd.grazing],
                                                        rel=1e-9)
    assert [g.kind for g in bk.grazing] == [g.kind for g in bd.grazing]


def test_unknown_linear_solver_is_refused_by_name():
    hs = HarmonicSet(range(3 * Z + 11), fundamental="shaft")
    with pytest.raises(ValueError, match="linear_solver"):
        _pair(hs, "cg")


def test_fold_parity_from_the_tangent_equals_the_determinant():
    """T.9a: sign det J follows the sign of the tangent's speed component (docs/theory.md)."""
    from hbm.stability import stability

    hs = HarmonicSet(range(3 * Z + 11), fundamental="shaft")
    pb = _pair(hs, "krylov")
    br = hbm.trace(pb, 0.3 / Z / RPM, 0.06 / RPM, stability=False)
    assert len(br.folds) >= 2
    first = stability(pb, pb.point(br.unknowns[0], br.omega[0])).fold_parity
    checked = flipped = 0
    for i in range(len(br)):
        if any(abs(i - f) <= 1 for f in br.fold_index):
            continue                    # at a fold the one-sided tangent may not tell
        guess = first != ((br.tangents[i][-1] > 0) != (br.tangents[0][-1] > 0))
        exact = stability(pb, pb.point(br.unknowns[i], br.omega[i])).fold_parity
        assert guess == exact, f"point {i} at {br.rpm[i]:.6g} rpm"
        checked += 1
        flipped += exact
    assert checked > 100 and flipped > 5


def test_contiguous_preconditioner_matrix_equals_the_gathered_build(impact_point):
    """The strided Toeplitz/Hankel build of I + H S (contiguous sets) against the general
    index-gathering one (HBMProblem.stiffness_matrix), without kink blocks."""
    from hbm.basis import mul_rows
    from hbm.elements import ElementStiffness, KinkCorrection
    from hbm.krylov import contiguous_matrix

    pb, u, w = impact_point
    _, jop, _ = pb.scaled(u / pb.x_scale, w)
    s = jop.stiffness[0].samples
    ref = np.eye(jop.size) + mul_rows(jop.h[0, 0], pb.stiffness_matrix(
        ElementStiffness(s, KinkCorrection.none(s.size))))
    fast = contiguous_matrix(jop.h[0, 0], s)
    assert np.allclose(fast, ref, rtol=0, atol=1e-14 * np.abs(ref).max())
    assert np.array_equal(jop.dense(kinks=False), fast)
    # a non-contiguous set keeps the general build
    hs = HarmonicSet((0, 1, 2, 5, 9), fundamental="shaft", n_time=64)
    pb2 = _pair(hs, "krylov")
    u2 = np.zeros(pb2.n_unknowns)
    u2[0] = 2.0
    _, j2, _ = pb2.scaled(u2 / pb2.x_scale, 0.01)
    s2 = j2.stiffness[0].samples
    ref2 = np.eye(j2.size) + mul_rows(j2.h[0, 0], pb2.stiffness_matrix(
        ElementStiffness(s2, KinkCorrection.none(s2.size))))
    assert np.allclose(j2.dense(kinks=False), ref2, rtol=0, atol=1e-14 * np.abs(ref2).max())
