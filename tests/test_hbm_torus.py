"""Multi-frequency harmonic balance on a torus (hbm.torus, docs/hbm.md "Several base
frequencies", docs/theory.md §14, T.36-T.40), issue 36 item 3.

* the d-dimensional AFT against its dense matrices, the Jacobian blocks against
  ``A diag(s) E`` and finite differences (kink correction along the last axis), bad input;
* d = 1: a TorusBasis of one base gives the HarmonicSet's solution;
* a lumped two-stage reducer 20:30 then 15:45 (mesh frequencies 20 and 10 Omega, common
  period one mesh-2 period): the one-dimensional HBM over the common period against the
  torus with the two mesh frequencies as bases, restricted to the time line (a); both
  against an independent time integration (b); the torus average against the average of
  the periodic responses over the relative phase of the meshes (what it equals for
  commensurate bases, T.39);
* a hunting-tooth reducer 23:61 then 19:67 with torque ripples at the input and output
  shaft orders (common period 4087 input turns): the torus of the two meshes and the two
  shafts against the time integration (c).
"""
from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
from hbm_models import sdof_problem
from hbm_train_models import integrate, torus_line_std

import hbm
from hbm.examples import TwoStage
from hbm.post.torus import line_state, line_statistics, torus_statistics
from hbm.torus import TorusBasis, canonical, train_basis

RPM = hbm.RPM_TO_RAD_S


# ---------------------------------------------------------------------- the basis
def test_torus_aft_against_dense_matrices():
    """synthesize/analyse by d-dimensional real FFTs equal the dense synthesis E and
    Galerkin A over the flattened grid (A E = I); the product matrix equals A diag(s) E;
    the synthesis rows at grid points are E's rows."""
    rng = np.random.default_rng(1)
    tb = TorusBasis.build({"a": 3, "b": "5/2", "s": 1}, {"a": 3, "b": 2},
                          sidebands={"s": (1,)})
    e, a = tb.aft_matrices()
    xr = rng.standard_normal((2, tb.n_real))
    x = tb.synthesize(xr)
    assert x.shape == (2, *tb.grid)
    assert np.max(np.abs(x.reshape(2, -1) - xr @ e.T)) < 1e-13
    assert np.max(np.abs(tb.analyse(x) - xr)) < 1e-13
    assert np.max(np.abs(a @ e - np.eye(tb.n_real))) < 1e-13
    s = rng.standard_normal(tb.grid)
    assert np.max(np.abs(tb.multiplication_matrix(s) - a @ (s.ravel()[:, None] * e))) < 1e-13
    nodes = np.array([0, 5, 77, 1000, tb.n_samples - 1])
    assert np.max(np.abs(tb.grid_rows(nodes, tb.grid) - e[nodes])) < 1e-13
    # frequencies: k . r in units of the common fundamental 1/2
    assert tb.ratio == Fraction(1, 2) and tb.multiples == (6, 5, 2)
    k = np.array(tb.indices)
    assert np.array_equal(np.array(tb.frequency_index), k @ np.array([6, 5, 2]))


def test_torus_builders_and_refusals():
    """The carrier box with sidebands; canonical vectors; the aliasing rule; ambiguous
    and explicit lattice vectors of a frequency."""
    tb = train_basis({"m1": 23, "m2": Fraction(437, 61)}, 2,
                     shafts={"in": (1, (1,))}, sideband_order=1)
    # box of 5 x 5 carriers (half of them by conjugacy) times 3 offsets, halved: (75 + 1)/2
    assert tb.n_harmonics == 38 and tb.indices[0] == (0, 0, 0)
    assert all(canonical(k) == k for k in tb.indices)
    assert tb.grid == (32, 32, 16)                 # 8 max|k_j| + 4 rounded up: the periodic rule
    with pytest.raises(ValueError, match="grid"):
        TorusBasis([1, 2], [(0, 0), (3, 1)], grid=(6, 8))
    with pytest.raises(ValueError, match="twice"):
        TorusBasis([1, 2], [(0, 0), (1, -1), (-1, 1)])
    with pytest.raises(ValueError, match="zero vector"):
        TorusBasis([1, 2], [(1, 0)])
    with pytest.raises(ValueError, match="distinct"):
        TorusBasis([2, 2], [(0, 0)])
    amb = TorusBasis.build({"mesh": 23, "shaft": 1}, {"mesh": 2}, sidebands={"shaft": (1,)})
    assert amb.vector_of(23, "mesh") == (1, 0)           # its own base first
    with pytest.raises(ValueError, match="no unique lattice vector"):
        amb.vector_of(92, "a force at 92 Omega")
    exp = TorusBasis(amb.bases, amb.indices, names=amb.names, vectors={92: (4, 0)})
    assert exp.vector_of(92, "x") == (4, 0)
    with pytest.raises(ValueError, match="is not 92"):
        TorusBasis(amb.bases, amb.indices, vectors={92: (3, 0)})


def test_one_base_is_the_harmonic_set():
    """A TorusBasis of one base and the same indices and grid gives the HarmonicSet's
    solution to round-off, in contact loss, and the same branch with the same folds."""
    pb = sdof_problem(harmonics=20)
    hs = pb.harmonics
    tb = TorusBasis([hs.ratio], [(k,) for k in hs.indices], grid=(hs.n_time,))
    pt = hbm.HBMProblem(pb.system, list(pb.elements), pb.excitation, tb)
    a, b = pb.solve(0.9 / RPM), pt.solve(0.9 / RPM)
    assert np.max(np.abs(a.unknowns - b.unknowns)) < 1e-12
    assert hbm.point_stats(pb, a)[0].contact_loss_fraction > 0.3
    assert hbm.full_residual(pt, b) < 1e-12
    br = hbm.trace(pt, 0.3 / RPM, 1.5 / RPM)
    b1 = hbm.trace(pb, 0.3 / RPM, 1.5 / RPM, stability=False)
    assert len(br) == len(b1) and np.allclose(br.folds, b1.folds, rtol=1e-12)
    assert np.all(np.isnan(br.floquet_max_real)) and np.all(br.floquet_kind == -1)
    assert not br.stable.any()


# ---------------------------------------------------------------------- 20:30, 15:45
MODEL = TwoStage(te=(8e-6, 8e-6))


def _one_d(model: TwoStage, harmonics: int) -> hbm.HBMProblem:
    """The periodic HBM over the common period (fundamental 10 Omega, the mesh-2 frequency)."""
    r0 = hbm.common_fundamental(*model.mesh_ratios)
    return model.problem(hbm.HarmonicSet(range(harmonics + 1), ratio=r0))


def _torus(model: TwoStage, harmonics: int, **kw) -> hbm.HBMProblem:
    r1, r2 = model.mesh_ratios
    return model.problem(train_basis({"mesh 1": r1, "mesh 2": r2}, harmonics), **kw)


def _start(problem, point):
    """Coordinates and velocities at t = 0 of a periodic solution."""
    q = problem.recover(point)
    w = problem.kS * problem.harmonics.rate * point.omega
    return q.sum(axis=1).real, (q * (1j * w)).sum(axis=1).real


@pytest.mark.parametrize("rpm,harmonics,tol", [(3000.0, 12, 1e-12), (3631.0, 12, 1e-5)])
def test_two_stage_one_d_against_torus(rpm, harmonics, tol):
    """(a) The torus solution on its time line over the common period gives the periodic
    solution's mesh-load std: 1e-15 in permanent contact (3000 rpm, 625 unknowns per mesh
    against 81), and in contact loss (3631 rpm, mesh 2 loses contact 13 % of the time)
    2.1e-6 at 12 harmonics per mesh on the default 128 x 128 grid (1.6e-4 on 64 x 64;
    1e-5 to 4e-6 from 12 to 32 harmonics on grids of 128 to 512: the torus resolves the
    non-smooth dependence on the meshes' relative phase, which the line does not need)."""
    p1 = _one_d(MODEL, 160)
    a = p1.solve(rpm)
    ref = np.array([s.mesh_load_std for s in hbm.point_stats(p1, a, n_time=8 * 1024)])
    p2 = _torus(MODEL, harmonics)
    b = p2.solve(rpm)
    line = np.array([s["mesh_load_std"] for s in line_statistics(p2, b, 2048)])
    assert np.max(np.abs(line / ref - 1.0)) < tol
    loss = hbm.point_stats(p1, a)[1].contact_loss_fraction
    assert (loss > 0.1) == (rpm > 3500)
    assert hbm.full_residual(p2, b) < 1e-10


def test_torus_average_is_the_phase_average():
    """With commensurate bases the torus holds the periodic responses of every relative
    phase of the meshes (T.39): the torus mean square of each mesh load equals the mean
    over mesh 2's phase of the periodic responses' (16 phases, trapezoidal), to 1e-10;
    the response at one phase (the time line) differs by 3 and 5 %."""
    rpm = 3000.0
    p2 = _torus(MODEL, 12)
    b = p2.solve(rpm)
    torus = np.array([s["mesh_load_std"] for s in torus_statistics(p2, b)])
    stds = []
    for psi in 2 * np.pi * np.arange(16) / 16:
        model = TwoStage(te=MODEL.te, phases=(0.0, psi))
        p1 = _one_d(model, 40)
        stds.append([s.mesh_load_std for s in hbm.point_stats(p1, p1.solve(rpm))])
    phase_avg = np.sqrt(np.mean(np.square(stds), axis=0))
    assert np.max(np.abs(torus / phase_avg - 1.0)) < 1e-10
    assert np.min(np.abs(np.array(stds[0]) / torus - 1.0)) > 0.02


@pytest.mark.parametrize("rpm,tol", [(3000.0, 1e-10), (3631.0, 1e-7)])
def test_two_stage_against_time_integration(rpm, tol):
    """(b) The periodic HBM over the common period against solve_ivp (DOP853, rtol 1e-10)
    of the equations written out, started on the orbit, 20 periods of transient, the
    mesh-load std integrated exactly over the next 10: 3e-13 in permanent contact, 1e-8
    with contact loss (target 1e-4)."""
    p1 = _one_d(MODEL, 160)
    a = p1.solve(rpm)
    hbm_std = np.array([s.mesh_load_std for s in hbm.point_stats(p1, a, n_time=8 * 1024)])
    period = 2 * np.pi / (p1.harmonics.rate * a.omega)
    res = integrate(MODEL, rpm, *_start(p1, a), 20 * period, 10 * period)
    assert np.max(np.abs(hbm_std / res.std - 1.0)) < tol


def test_torus_jacobian_against_finite_differences():
    """The torus Newton matrix (dense: the product matrices and the kink blocks of the
    dead zone along the last axis; matrix-free: the same operator) against central
    differences of the residual at a point with contact loss."""
    rpm = 3631.0
    pd = _torus(MODEL, 5, linear_solver="dense")
    pt = pd.solve(rpm)
    assert torus_statistics(pd, pt)[1]["contact_loss_fraction"] > 0.05
    u = pt.unknowns
    _, ju, jw = pd.evaluate(u, pt.omega)
    rng = np.random.default_rng(3)
    for _ in range(3):
        v = rng.standard_normal(u.size) * pd.x_scale
        h = 1e-7
        fd = (pd.residual(u + h * v, pt.omega) - pd.residual(u - h * v, pt.omega)) / (2 * h)
        assert np.linalg.norm(ju @ v - fd) < 1e-5 * np.linalg.norm(fd)
    fdw = (pd.residual(u, pt.omega * (1 + 1e-7)) - pd.residual(u, pt.omega * (1 - 1e-7))) \
        / (2e-7 * pt.omega)
    assert np.linalg.norm(jw - fdw) < 1e-5 * np.linalg.norm(fdw)
    pk = _torus(MODEL, 5, linear_solver="krylov")
    _, jk, _ = pk.evaluate(u, pt.omega)
    v = rng.standard_normal(u.size)
    assert np.linalg.norm(jk @ v - ju @ v) < 1e-12 * np.linalg.norm(ju @ v)
    assert np.max(np.abs(jk.dense() - ju)) < 1e-12 * np.max(np.abs(ju))


# ---------------------------------------------------------------------- hunting teeth
HUNTING = TwoStage(teeth=(23, 61, 19, 67), te=(4e-6, 4e-6),
                   shaft_forcing=((0, 1, 5.0), (2, 1, 50.0)))


def _hunting(model: TwoStage, harmonics: int, sideband_order: int = 1,
             grid=None) -> hbm.HBMProblem:
    r1, r2 = model.mesh_ratios
    s = model.speeds
    tb = train_basis({"mesh 1": r1, "mesh 2": r2}, harmonics,
                     shafts={"input": (s[0], (1,)), "output": (s[2], (1,))},
                     sideband_order=sideband_order, grid=grid)
    return model.problem(tb)


# in permanent contact the grid of 4 max|k_j| + 4 samples per base gives the default
# grid's solution to 1e-12 (docs/hbm.md) at 1/16 of the samples
COARSE = (32, 32, 8, 8)


def test_hunting_basis():
    """23:61 then 19:67 with input and output shaft orders: the common period is 4087
    input turns (94001 mesh-1 periods), the one-dimensional set over it needs indices up
    to 743767 (an AFT of > 1.5 million samples); the torus holds the same 423 harmonics on
    a 64 x 64 x 16 x 16 grid (the periodic rule along each base), 32 x 32 x 8 x 8 in
    permanent contact, where both give the same solution to 1e-12."""
    pb = _hunting(HUNTING, 6)
    tb = pb.harmonics
    assert tb.ratio == Fraction(1, 4087) and tb.multiples == (94001, 29279, 4087, 437)
    assert tb.n_harmonics == 423 and tb.grid == (64, 64, 16, 16)
    coarse = _hunting(HUNTING, 6, grid=COARSE)
    a, b = pb.solve(2500.0), coarse.solve(2500.0)
    assert np.max(np.abs(a.unknowns - b.unknowns)) < 1e-12 * np.max(np.abs(a.unknowns))
    line = tb.line_set(n_time=2 ** 21)
    assert line.n_harmonics == 423 and line.max_index == 743767
    assert pb.n_unknowns == 2 * (2 * 423 - 1)


def test_hunting_torus_against_time_integration_on_the_same_window():
    """(c) The torus solution along its time line against solve_ivp started on it: the
    bump-weighted mesh-load std over one output-shaft turn (215 mesh-1 periods) after a
    20 ms transient, the same weights on both: 2e-8 and 1e-7 (the window's own error,
    23 and 46 % over one turn, cancels)."""
    rpm = 2500.0
    pb = _hunting(HUNTING, 6, grid=COARSE)
    pt = pb.solve(rpm)
    th0, om0 = line_state(pb, pt, 0.0)
    turn = 2 * np.pi / (float(HUNTING.speeds[2]) * pt.omega)
    res = integrate(HUNTING, rpm, th0[:, 0], om0[:, 0], 0.02, turn, weight="bump")
    line = torus_line_std(pb, pt, 0.02, turn, 215 * 128)
    assert np.max(np.abs(res.std / line - 1.0)) < 1e-6
    torus = np.array([s["mesh_load_std"] for s in torus_statistics(pb, pt)])
    assert np.max(np.abs(res.std / torus - 1.0)) > 1e-2       # one turn is not ergodic


@pytest.mark.slow
def test_hunting_torus_against_long_time_integration():
    """(c) The torus (ergodic) mesh-load std against the time integration's bump-weighted
    average over four output-shaft turns (860 mesh-1 periods): 1.8e-5 and 2.0e-6 (target
    1e-3); the torus is converged (6 and 8 harmonics per mesh agree to 1.2e-8)."""
    rpm = 2500.0
    pb = _hunting(HUNTING, 6, grid=COARSE)
    pt = pb.solve(rpm)
    torus = np.array([s["mesh_load_std"] for s in torus_statistics(pb, pt)])
    th0, om0 = line_state(pb, pt, 0.0)
    turn = 2 * np.pi / (float(HUNTING.speeds[2]) * pt.omega)
    res = integrate(HUNTING, rpm, th0[:, 0], om0[:, 0], 0.02, 4 * turn, weight="bump")
    assert np.max(np.abs(res.std / torus - 1.0)) < 1e-4


@pytest.mark.slow
def test_hunting_torus_with_contact_loss_against_time_integration():
    """(c) with contact loss: TE 8 um, 3950 rpm, mesh 1 out of contact 15 % of the time.
    The impacts couple the shafts' sidebands: with sideband order 2 (4394 unknowns) the
    torus on its time line agrees with the integration on the same window of four output
    turns to 1.4e-3 and 8.7e-4 (order 1: 4.2e-3; order 3: 6.6e-4, 5.5e-4), on a grid of
    32 x 32 x 16 x 16 (64 x 64 x 16 x 16: 1.37e-3 and 7.7e-4)."""
    rpm = 3950.0
    model = TwoStage(teeth=(23, 61, 19, 67), te=(8e-6, 8e-6),
                     shaft_forcing=((0, 1, 5.0), (2, 1, 50.0)))
    pb = _hunting(model, 6, sideband_order=2, grid=(32, 32, 16, 16))
    pt = pb.solve(rpm)
    assert torus_statistics(pb, pt)[0]["contact_loss_fraction"] > 0.1
    th0, om0 = line_state(pb, pt, 0.0)
    turns = 4 * 2 * np.pi / (float(model.speeds[2]) * pt.omega)
    res = integrate(model, rpm, th0[:, 0], om0[:, 0], 0.02, turns, weight="bump")
    line = torus_line_std(pb, pt, 0.02, turns, 4 * 215 * 128)
    assert np.max(np.abs(res.std / line - 1.0)) < 2e-3


# ---------------------------------------------------------------------- contract
def test_torus_refuses_one_period_computations():
    """Floquet stability, shooting, one-period signals are refused on a torus, saying
    why; trace(stability=True) too; excitation keys as lattice vectors."""
    pb = _torus(MODEL, 3)
    pt = pb.solve(3000.0)
    for fn in (hbm.stability.stability, hbm.shooting_error, hbm.time_series, hbm.spectrum,
               hbm.mesh_period_envelope):
        with pytest.raises(ValueError, match="quasi-periodic"):
            fn(pb, pt)
    with pytest.raises(ValueError, match="Floquet theory"):
        hbm.trace(pb, 2000, 2100, stability=True)
    p1 = _one_d(MODEL, 10)
    with pytest.raises(ValueError, match="needs a torus"):
        line_statistics(p1, p1.solve(3000.0))
    # a force at mesh 1's frequency given as a ratio and as its lattice vector
    ex = MODEL.excitation()
    f = np.array([0.0, 1.0, 0.0])
    by_ratio = hbm.Excitation(3, constant={**ex.constant, 20: f})
    by_vector = hbm.Excitation(3, constant={**ex.constant, (1, 0): f})
    tb = pb.harmonics
    p_r = hbm.HBMProblem(pb.system, list(pb.elements), by_ratio, tb)
    p_v = hbm.HBMProblem(pb.system, list(pb.elements), by_vector, tb)
    assert np.array_equal(p_r.Fc, p_v.Fc) and np.any(p_r.Fc != pb.Fc)
    with pytest.raises(ValueError, match="canonical"):
        hbm.HBMProblem(pb.system, list(pb.elements),
                       hbm.Excitation(3, constant={(-1, 0): f}), tb)


def test_torus_branch_with_grazing():
    """The continuation runs unchanged on the torus (it knows only a residual and its
    tangent): the hunting reducer with a larger TE over 3850-4150 rpm, 3 harmonics per
    mesh, finds the contact-loss onset and end on mesh 1 near the resonance (3907 and 4099
    rpm; 3902 and 4101 at 4 harmonics); no stability is written (NaN, kind -1)."""
    model = TwoStage(teeth=(23, 61, 19, 67), te=(6e-6, 6e-6),
                     shaft_forcing=((0, 1, 5.0), (2, 1, 50.0)))
    pb = _hunting(model, 3, grid=(16, 16, 8, 8))
    br = hbm.trace(pb, 3850.0, 4150.0, max_step=0.1)
    assert br.status == "completed"
    graz = [(g.kind, g.side, g.element) for g in br.grazing]
    assert ("onset", "active", 0) in graz and ("end", "active", 0) in graz
    assert np.all(np.isnan(br.floquet_max_real)) and np.all(br.floquet_kind == -1)
    assert np.max(br.element(0).contact_loss_fraction) > 0.0
    assert math.isfinite(float(np.max(br.element(0).impacts_per_mesh_period)))
