"""Several nonlinear elements (hbm/elements): the contract, the sum over elements in the
residual, the condensation onto all their deflections, stability and time response with
every element, fractional fundamentals, and a second element kind (a cubic spring).

Numbers against theory (the Duffing frequency response of one harmonic, the exact split
of a mesh into two halves, a fundamental below the natural one) and against the
project's equations integrated independently (scipy solve_ivp, its own dead zone).
"""
from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
import scipy.linalg as sla
from scipy.integrate import solve_ivp

import hbm
from hbm.post.time_response import integrate
from hbm.stability import floquet_exponents, stability

RPM = hbm.RPM_TO_RAD_S


# ------------------------------------------------------------ one mesh split in two halves

def _pair(halves: bool, condensation: str = "loa", solver: str = "auto", h: int = 20):
    """The unit-mass pair of hbm_models.sdof_problem (TE, parametric stiffness): one mesh,
    or two meshes along the same line of action with half its stiffness each (the same
    backlash and transmission error)."""
    k, te = {0: 1.0, 1: 0.2}, {1: 0.3j}
    if halves:
        els = [hbm.GearMesh([1.0], 1, {m: c / 2 for m, c in k.items()}, te=te, backlash=1.0,
                            name=f"half {i}") for i in range(2)]
    else:
        els = [hbm.GearMesh([1.0], 1, k, te=te, backlash=1.0)]
    return hbm.HBMProblem(hbm.LinearSystem([[1.0]], [[0.1]], [[0.0]]), els,
                          hbm.Excitation(1, constant={0: [0.1], 1: [0.05]}),
                          hbm.HarmonicSet.build(1, h), condensation, linear_solver=solver)


@pytest.mark.parametrize("condensation", ["loa", "gear", "none"])
def test_two_half_meshes_carry_the_load_of_one(condensation):
    """Parallel directions (the element Deltas, not an orthonormal span): at speeds with
    impacts on one and on both flanks, the two halves' loads add up to the single mesh's
    load to 1e-10, and the Floquet verdicts (T.10 with two kicks, T.9 with 2 x 2
    receptance blocks) are the single mesh's."""
    one, two = _pair(False, condensation), _pair(True, condensation)
    assert two.n_unknowns == (2 if condensation == "loa" else 1) * one.n_unknowns
    for w in (0.5, 0.9, 1.3):
        a, b = one.solve(w / RPM, tol=1e-12), two.solve(w / RPM, tol=1e-12)
        ref = hbm.time_series(one, a).load
        halves = [hbm.time_series(two, b, element=e).load for e in range(2)]
        assert np.max(np.abs(halves[0] + halves[1] - ref)) < 1e-10 * np.max(np.abs(ref))
        assert np.max(np.abs(halves[0] - halves[1])) < 1e-10 * np.max(np.abs(ref))
        stats = hbm.point_stats(two, b)
        assert stats[0].contact == stats[1].contact == hbm.point_stats(one, a)[0].contact
        if condensation == "loa":
            s1, s2 = stability(one, a), stability(two, b)
            assert (s1.kind, s1.fold_parity) == (s2.kind, s2.fold_parity)
            assert s2.max_real == pytest.approx(s1.max_real, rel=1e-8, abs=1e-12)


@pytest.mark.parametrize("solver", ["dense", "krylov"])
def test_two_half_meshes_trace_the_same_curve(solver):
    """The continuation of the halves (E = 2: dense Newton, or the matrix-free one with a
    block-diagonal S) finds each grazing of the single mesh twice, once per element, at
    the same speed, and the same stability along the curve."""
    one, two = _pair(False, solver=solver), _pair(True, solver=solver)
    b1 = hbm.trace(one, 0.3 / RPM, 1.0 / RPM, stability=False)
    b2 = hbm.trace(two, 0.3 / RPM, 1.0 / RPM, stability=False)
    assert b1.status == b2.status == "completed"
    assert b2.stats["mesh_load_std"].shape == (len(b2), 2)
    assert b2.element(1).name == "half 1"
    g1 = [(g.kind, g.side) for g in b1.grazing]
    for e in range(2):
        ge = b2.element(e).grazing
        assert [(g.kind, g.side) for g in ge] == g1 and all(g.element == e for g in ge)
        assert [g.rpm for g in ge] == pytest.approx([g.rpm for g in b1.grazing], rel=1e-9)
    # the sum of the halves' std along the curve is the single mesh's (a curve, compared
    # where both have points)
    s2 = b2.element(0).mesh_load_std + b2.element(1).mesh_load_std
    sel = (b2.rpm > b1.rpm.min()) & (b2.rpm < 0.35 / RPM)         # before the first turn
    np.testing.assert_allclose(s2[sel], np.interp(b2.rpm[sel], b1.rpm[:20],
                                                  b1.element(0).mesh_load_std[:20]), rtol=1e-4)


# ------------------------------------------------ two masses, two dead-zone meshes, in time

MASS = np.diag([1.0, 0.5])
GA, GB = np.array([1.0, 0.0]), np.array([-1.0, 1.0])
KA, KB = 1.0, 0.8
F0, F1 = np.array([0.0, 0.08]), np.array([0.05, 0.0])


def _damping(zeta: float = 0.05) -> np.ndarray:
    kp = KA * np.outer(GA, GA) + KB * np.outer(GB, GB)
    w2, phi = sla.eigh(kp, MASS)
    return MASS @ phi @ np.diag(2 * zeta * np.sqrt(w2)) @ phi.T @ MASS      # eq. (19)


def _two_meshes(h: int, ratio=1, n_time=None, condensation: str = "loa",
                forcing: bool = True):
    """Two masses: mesh A between mass 1 and the ground (one tooth, Delta_A = x1), mesh B
    between the masses (two teeth: twice the shaft frequency, Delta_B = x2 - x1), each with
    its parametric stiffness, TE and backlash; a static load through both, a harmonic
    force on mass 1."""
    a = hbm.GearMesh(GA, 1, {0: KA, 1: 0.2 * KA}, te={1: 0.05j}, backlash=1.0, name="A")
    b = hbm.GearMesh(GB, 2, {0: KB, 1: 0.25 * KB}, te={1: 0.02}, backlash=0.5, name="B")
    hs = hbm.HarmonicSet(range(h + 1), ratio=ratio, n_time=n_time)
    return hbm.HBMProblem(hbm.LinearSystem(MASS, _damping(), np.zeros((2, 2))), [a, b],
                          hbm.Excitation(2, constant={0: F0, 1: F1} if forcing else {0: F0}),
                          hs, condensation)


def _equations(w: float):
    """The two masses' equations written out with their own dead zone (eq. 12-13)."""
    minv, c = np.linalg.inv(MASS), _damping()

    def dead(p, k, b):
        return k * ((p - b) if p > b else (p + b) if p < -b else 0.0)

    def loads(t, x):
        ph = w * t
        fa = dead(GA @ x - (0.05j * np.exp(1j * ph)).real, KA * (1 + 0.2 * np.cos(ph)), 1.0)
        fb = dead(GB @ x - 0.02 * np.cos(2 * ph), KB * (1 + 0.25 * np.cos(2 * ph)), 0.5)
        return fa, fb

    def rhs(t, y):
        x, v = y[:2], y[2:]
        fa, fb = loads(t, x)
        f = F0 + (F1 * np.exp(1j * w * t)).real - c @ v - GA * fa - GB * fb
        return np.concatenate([v, minv @ f])
    return rhs, loads


def _state(pb, pt) -> np.ndarray:
    """(x, v) at t = 0 of an HBM point."""
    q = pb.recover(pt)
    return np.concatenate([q.real.sum(axis=1), (1j * pb.kS * pt.omega * q).real.sum(axis=1)])


def _integrated_std(pb, pt, periods: int = 400) -> tuple[float, float]:
    """Mesh-load std of both meshes over one period of the steady state reached by DOP853
    (rtol 1e-12) from the HBM state."""
    w = pt.omega
    period = 2 * np.pi / w
    rhs, loads = _equations(w)
    opts = dict(method="DOP853", rtol=1e-12, atol=1e-14)
    y = _state(pb, pt)
    for _ in range(periods):
        y1 = solve_ivp(rhs, (0.0, period), y, **opts).y[:, -1]
        done = np.linalg.norm(y1 - y) < 1e-11 * np.linalg.norm(y1)
        y = y1
        if done:
            break
    assert done, "no periodic steady state"
    t = period * np.arange(4096) / 4096
    x = solve_ivp(rhs, (0.0, period), y, t_eval=t, **opts).y[:2]
    f = np.array([loads(ti, xi) for ti, xi in zip(t, x.T, strict=True)])
    return float(np.std(f[:, 0])), float(np.std(f[:, 1]))


@pytest.mark.parametrize(("w", "contact"), [(0.25, (0, 0)), (0.77, (1, 1))])
def test_two_meshes_against_time_integration(w, contact):
    """Both meshes in permanent contact, and both losing contact: each mesh-load std of
    the harmonic balance (40 harmonics) equals the time integration's to 1e-4."""
    pb = _two_meshes(40)
    pt = pb.solve(w / RPM, tol=1e-12)
    st = hbm.point_stats(pb, pt, n_time=8192)
    assert (st[0].contact, st[1].contact) == contact
    ref = _integrated_std(pb, pt)
    for e in range(2):
        assert st[e].mesh_load_std == pytest.approx(ref[e], rel=1e-4)
    assert hbm.full_residual(pb, pt) < 1e-9
    assert hbm.shooting_error(pb, pt, rtol=1e-10).relative < 1e-3
    # hbm's own time integration with every element (modal form) settles on the same
    # orbit: its load std on 64 samples per mesh period is the HBM's on the same instants
    for e in range(2):
        tr = integrate(pb, pt.rpm, pt, transient=60, window=2, rtol=1e-10, element=e)
        same = hbm.time_series(pb, pt, samples_per_period=64 * (e + 1), element=e).load
        assert tr.std == pytest.approx(np.std(same), rel=1e-5)
        assert tr.envelope.peak_load.size == 2 * (e + 1)        # base periods of 2 turns


def test_two_meshes_quasi_static_limit():
    """Omega -> 0 with the static load only: the harmonic balance is the pointwise
    statics of both meshes (hbm.quasi_static_delta, Newton on the two equations)."""
    pb = _two_meshes(20, forcing=False)
    qs = hbm.quasi_static_delta(pb)
    assert qs.shape == (2, pb.harmonics.n_time)
    pt = pb.solve(1e-8 / RPM, tol=1e-13)
    d = (pb.E @ pb.delta_real(pt.unknowns).T).T
    assert np.max(np.abs(d - qs)) < 1e-9 * np.max(np.abs(qs))


def _fd_exponent(pb, pt, eps: float = 1e-6) -> tuple[float, np.ndarray]:
    """Largest Floquet exponent (1/s) and the multipliers of a finite-difference monodromy
    of the integrated equations about the HBM orbit (central differences)."""
    w = pt.omega
    period = 2 * np.pi / w
    rhs, _ = _equations(w)
    y0 = _state(pb, pt)
    scale = np.maximum(np.abs(y0), 1e-3 * np.max(np.abs(y0)))
    cols = []
    for j in range(4):
        d = np.zeros(4)
        d[j] = eps * scale[j]
        ends = [solve_ivp(rhs, (0.0, period), y0 + s * d, method="DOP853", rtol=1e-12,
                          atol=1e-14).y[:, -1] for s in (1, -1)]
        cols.append((ends[0] - ends[1]) / (2 * d[j]))
    mu = np.linalg.eigvals(np.array(cols).T)
    return float(np.log(np.max(np.abs(mu))) / period), mu


def test_two_meshes_floquet_verdict_against_a_monodromy_of_the_time_integration():
    """Along a branch through the first resonances (folds, period doubling, a
    Neimark-Sacker point): at every eighth point the verdict of hbm.stability (T.10 with
    both meshes, T.9 with the 2 x 2 receptances) is the finite-difference monodromy's, and
    so is the largest exponent (to 5 %, to 1e-3 1/s near zero)."""
    pb = _two_meshes(30)
    br = hbm.trace(pb, 0.2 / RPM, 0.9 / RPM, stability=True, stability_process=False)
    assert br.status == "completed" and len(br.folds) >= 4
    kinds = set()
    for i in range(0, len(br), 8):
        lam, mu = _fd_exponent(pb, pb.point(br.unknowns[i], br.omega[i]))
        assert bool(br.stable[i]) == (lam < 0), (br.omega[i], lam, br.floquet_max_real[i])
        assert br.floquet_max_real[i] == pytest.approx(lam, rel=0.05, abs=1e-3)
        if not br.stable[i]:
            kinds.add(int(br.floquet_kind[i]))
            top = mu[np.argmax(np.abs(mu))]
            if br.floquet_kind[i] == 2:             # period doubling: a multiplier < -1
                assert top.real < 0 and abs(top.imag) < 1e-3 * abs(top)
    assert {1, 2} <= kinds
    # Hill's method with both meshes (T.9 exact root added) at a stable impacting point
    i = int(np.flatnonzero(br.stable & (br.element(1).contact > 0))[0])
    pt = pb.point(br.unknowns[i], br.omega[i])
    assert floquet_exponents(pb, pt, method="hill")[0] == pytest.approx(
        br.floquet_max_real[i], rel=0.05)


# ------------------------------------------------------------- a fundamental below the shaft

def test_a_half_fundamental_gives_the_natural_solution():
    """w0 = Omega / 2 (the basis of a period-2 response) on the two-mesh model: the same
    periodic solution as with w0 = Omega, every odd index zero, to 1e-10; the elements'
    base frequencies are indices 2 and 4, the forcing index 2."""
    w = 0.77
    nat = _two_meshes(30)
    half = _two_meshes(60, ratio=Fraction(1, 2), n_time=2 * nat.harmonics.n_time)
    assert half.harmonics.fundamental == "subharmonic" and half.steps == (2, 4)
    assert half.harmonics.index_of(1) == 2 and half.harmonics.index_of(Fraction(1, 2)) == 1
    a, b = nat.solve(w / RPM, tol=1e-12), half.solve(w / RPM, tol=1e-12)
    ca, cb = a.coefficients, b.coefficients                      # (2, nS) each
    scale = np.max(np.abs(ca))
    assert np.max(np.abs(cb[:, 1::2])) < 1e-10 * scale
    assert np.max(np.abs(cb[:, 0::2] - ca)) < 1e-10 * scale
    sa, sb = hbm.point_stats(nat, a), hbm.point_stats(half, b)
    for e in range(2):
        assert sb[e].mesh_load_std == pytest.approx(sa[e].mesh_load_std, rel=1e-10)
        assert sb[e].ipp.size == 2 * sa[e].ipp.size           # mesh periods in 2 Omega-periods
    s_a, s_b = stability(nat, a), stability(half, b)
    # the exponents modulo the fundamental: the same largest real part, the same verdict
    assert s_b.max_real == pytest.approx(s_a.max_real, rel=1e-6, abs=1e-9)
    assert (s_a.kind == "stable") == (s_b.kind == "stable")


def test_common_fundamental_and_ratios():
    assert hbm.common_fundamental(2, 3) == 1
    assert hbm.common_fundamental(Fraction(3, 2), 2) == Fraction(1, 2)
    # a 23:61 pair on the reference shaft: its mesh (23), both shafts' first orders
    assert hbm.common_fundamental(23, 1, Fraction(23, 61)) == Fraction(1, 61)
    hs = hbm.HarmonicSet(range(5), ratio="1/3")
    assert hs.index_of(1) == 3 and hs.index_of(Fraction(1, 2)) is None
    assert hs.fundamental_rad_s(3.0) == pytest.approx(1.0, rel=1e-15)
    with pytest.raises(ValueError, match="harmonics.ratio"):
        _ = hs.integer_ratio
    with pytest.raises(ValueError, match="does not divide"):
        hs.step_of(Fraction(1, 2), "mesh")
    # excitation keys are frequency ratios: a shaft order of a shaft at 23/61 Omega
    exc = hbm.Excitation(1, constant={Fraction(23, 61): [1.0]})
    assert list(exc.constant) == [Fraction(23, 61)]


# ------------------------------------------------------------------- a second element kind

def test_the_registry_builds_elements_by_kind():
    assert {"gear_mesh", "cubic_spring"} <= set(hbm.elements.ELEMENT_KINDS)
    spring = hbm.make_element("cubic_spring", direction=[1.0, 0.0], linear=2.0, cubic=0.5)
    assert isinstance(spring, hbm.CubicSpring) and spring.linear_stiffness == 2.0
    with pytest.raises(ValueError, match="element kind = 'spring'"):
        hbm.make_element("spring", direction=[1.0])

    class Other(hbm.CubicSpring):
        kind = "gear_mesh"
    with pytest.raises(ValueError, match="registered already"):
        hbm.elements.register(Other)


def test_a_mesh_and_a_spring_in_one_table():
    """Elements of different kinds: the branch's table holds the union of their
    statistics (NaN, or -1 for integers, where a kind has none), each element's curve
    only its own; the events are the mesh's."""
    springs = hbm.CubicSpring(GB, linear=KB, cubic=0.3, name="spring")
    mesh = hbm.GearMesh(GA, 1, {0: KA, 1: 0.2 * KA}, te={1: 0.05j}, backlash=1.0,
                        name="mesh")
    pb = hbm.HBMProblem(hbm.LinearSystem(MASS, _damping(), np.zeros((2, 2))),
                        [mesh, springs], hbm.Excitation(2, constant={0: F0, 1: F1}),
                        hbm.HarmonicSet(range(21)))
    br = hbm.trace(pb, 0.2 / RPM, 1.5 / RPM, stability=False)
    assert br.status == "completed"
    assert np.all(np.isnan(br.stats["mesh_load_std"][:, 1]))
    assert np.all(np.isnan(br.stats["force_std"][:, 0]))
    assert np.all(br.stats["contact"][:, 1] == -1) and np.all(br.stats["ipp"][:, 1] == -1)
    assert set(br.element(1)) == {"force_std", "force_max", "deflection_max", "coefficients"}
    assert "force_std" not in br.element(0) and "mesh_load_std" in br.element(0)
    assert br.grazing and all(g.element == 0 for g in br.grazing)
    pt = pb.point(br.unknowns[-1], br.omega[-1])
    d = (pb.E @ pb.delta_real(pt.unknowns).T).T[1]
    assert br.element(1).deflection_max[-1] == pytest.approx(np.abs(d).max(), rel=1e-2)


def _duffing(h: int, k3: float = 0.5, zeta: float = 0.05, force: float = 0.1):
    """x'' + 2 zeta x' + x + k3 x^3 = F cos(Omega t): a cubic spring (k1 = 1 moved into K')
    on a free unit mass."""
    spring = hbm.CubicSpring([1.0], linear=1.0, cubic=k3)
    return hbm.HBMProblem(hbm.LinearSystem([[1.0]], [[2 * zeta]], [[0.0]]), [spring],
                          hbm.Excitation(1, constant={1: [force]}),
                          hbm.HarmonicSet(range(h + 1), n_time=64 if h == 1 else None))


def test_cubic_spring_one_harmonic_is_the_duffing_frequency_response():
    """With one harmonic the balance is the classic one, (1 - w^2 + 3/4 k3 A^2)^2 A^2 +
    (2 zeta w A)^2 = F^2, exact (the AFT of a cubic of one harmonic has no aliasing): every
    point of the hardening branch, through both folds, satisfies it to 1e-10."""
    k3, zeta, force = 0.5, 0.05, 0.1
    pb = _duffing(1, k3, zeta, force)
    br = hbm.trace(pb, 0.5 / RPM, 2.0 / RPM, stability=False, tol=1e-12)
    assert br.status == "completed" and len(br.folds) == 2
    c = br.element(0).coefficients                     # (n_points, 2): indices 0 and 1
    a2, w = np.abs(c[:, 1]) ** 2, br.omega
    lhs = ((1 - w ** 2 + 0.75 * k3 * a2) ** 2 + (2 * zeta * w) ** 2) * a2
    assert np.max(np.abs(lhs / force ** 2 - 1)) < 1e-10
    assert np.all(np.abs(c[:, 0]) < 1e-12 * np.sqrt(a2.max()))
    assert br.stats["force_std"].shape == (len(br), 1)


def test_cubic_spring_against_time_integration():
    """Eleven harmonics on the upper branch near its fold: the force std and the
    stability equal the time integration's (std to 1e-6; the upper and lower orbits
    stable, the middle one a fold)."""
    pb = _duffing(11)
    br = hbm.trace(pb, 0.5 / RPM, 2.0 / RPM)
    i = int(np.argmax(br.element(0).force_std))
    assert br.stable[i] and np.any(br.floquet_kind[~br.stable] == 1)
    pt = pb.point(br.unknowns[i], br.omega[i])
    w, period = pt.omega, 2 * np.pi / pt.omega

    def rhs(t, y):
        return [y[1], 0.1 * np.cos(w * t) - 0.1 * y[1] - y[0] - 0.5 * y[0] ** 3]

    q = pb.recover(pt)
    y = [q.real.sum(), (1j * pb.kS * w * q).real.sum()]
    for _ in range(300):
        y = solve_ivp(rhs, (0, period), y, method="DOP853", rtol=1e-12, atol=1e-14).y[:, -1]
    t = period * np.arange(2048) / 2048
    x = solve_ivp(rhs, (0, period), y, t_eval=t, method="DOP853", rtol=1e-12, atol=1e-14).y[0]
    assert br.element(0).force_std[i] == pytest.approx(np.std(x + 0.5 * x ** 3), rel=1e-6)
