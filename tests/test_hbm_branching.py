"""Branch switching at period doubling (hbm.branching) on the Kahraman-Singh pair of
tests/hbm_models.py: the doubled problem, the period doubling located on the harmonic
balance against the monodromy's multiplier -1, the period-2 branch against the suite's
own time integration (DOP853), its rejoin, and a second doubling (period 4)."""

import numpy as np
import pytest
from hbm_models import RPM, sdof_problem
from scipy.integrate import solve_ivp

import hbm
from hbm.branching import (
    doubled_problem,
    doubled_set,
    doubling_brackets,
    embed,
    odd_mask,
    period_doubling_branches,
)
from hbm.post.time_response import (
    element_load,
    equations,
    initial_state,
    modal_model,
    state_atol,
)

LO, HI = 0.45 / RPM, 0.62 / RPM          # rpm; the pair's w_n = 1 rad/s, one tooth
SPAN = HI - LO
STEPS = (0.02 * SPAN, 1e-6 * SPAN, 0.05 * SPAN)


@pytest.fixture(scope="module")
def main():
    pb = sdof_problem(harmonics=40, fa=0.1, b=0.2)
    br = hbm.trace(pb, HI, LO, step=0.02, max_step=0.05)
    assert br.status == "completed"
    return pb, br


@pytest.fixture(scope="module")
def period2(main):
    pb, br = main
    return period_doubling_branches(pb, br, (LO, HI), depth=1, step_rpm=STEPS, tol=1e-9)


def test_doubled_problem_holds_the_period1_solution():
    pb = sdof_problem(harmonics=8, fa=0.1, b=0.2)
    ch = doubled_problem(pb)
    hs = doubled_set(pb.harmonics)
    assert hs.ratio == pb.harmonics.ratio / 2 and hs.indices == tuple(range(18))
    assert hs.n_time == 2 * pb.harmonics.n_time
    pt = pb.solve(0.55 / RPM, tol=1e-12)
    u2 = embed(pb, ch, pt.unknowns)
    assert ch.relative_residual(ch.residual(u2, pt.omega), u2) < 1e-12
    # the Jacobian does not couple the half orders with the whole ones (time shift by T)
    _, j, _ = ch.evaluate(u2, pt.omega)
    odd = odd_mask(ch)
    assert np.max(np.abs(j[np.ix_(odd, ~odd)])) < 1e-12 * np.max(np.abs(j))
    assert np.max(np.abs(j[np.ix_(~odd, odd)])) < 1e-12 * np.max(np.abs(j))
    # the even block is the period-1 Jacobian
    _, j1, _ = pb.evaluate(pt.unknowns, pt.omega)
    assert np.allclose(j[np.ix_(~odd, ~odd)], j1, rtol=0, atol=1e-12 * np.max(np.abs(j1)))


def test_doubled_set_of_a_sparse_set_holds_the_half_orders():
    hs = hbm.HarmonicSet((0, 1, 3, 20), ratio=1)
    d = doubled_set(hs)
    assert d.ratio == hbm.basis.as_ratio("1/2", "r")
    assert d.indices == (0, 1, 2, 3, 5, 6, 7, 39, 40, 41)


def test_doubling_speed_against_the_floquet_multiplier(main, period2):
    """Where det J_odd changes sign the monodromy (T.10) of the period-1 orbit has a
    multiplier -1: an exponent with Im = w0/2 and a real part ~0."""
    pb, br = main
    assert len(period2) >= 2
    for s in period2:
        pd = s.doubling
        i = pd.index
        assert min(br.rpm[i], br.rpm[i + 1]) <= pd.rpm <= max(br.rpm[i], br.rpm[i + 1])
        lam, ex = hbm.floquet_exponents(pb, pb.point(pd.unknowns, pd.omega))
        on = np.abs(np.abs(ex.imag) - pd.omega / 2) < 1e-6 * pd.omega
        assert np.any(on)
        assert np.min(np.abs(ex[on].real)) < 1e-4        # 1/s, against zeta w_n = 0.05
        if np.isfinite(pd.floquet_rpm):                   # the branch's own verdict
            assert abs(pd.rpm - pd.floquet_rpm) < 2e-3 * pd.rpm


def _time_integration(problem, rpm, unknowns, periods=60):
    """Mesh-load std over 4 periods after ``periods`` of the doubled problem's period,
    from its HBM orbit (DOP853, rtol 1e-11), and the largest |Delta(t + T) - Delta(t)|
    over the ptp (0 for a T-periodic response)."""
    mm = modal_model(problem, rpm)
    y0 = initial_state(problem, problem.point(unknowns, rpm * RPM), mm)
    fun, period = equations(mm), mm.period
    atol = state_atol(mm, y0, 1e-11)
    y = solve_ivp(fun, (0, periods * period), y0, method="DOP853", rtol=1e-11,
                  atol=atol).y[:, -1]
    n = 2048
    t = np.arange(4 * n) * period / n
    sol = solve_ivp(fun, (0, 4 * period), y, method="DOP853", rtol=1e-11, atol=atol,
                    t_eval=t)
    d = mm.gamma[0] @ sol.y[:mm.n_modes]
    shift = np.max(np.abs(d[:n // 2] - d[n // 2:n])) / np.ptp(d)
    return element_load(mm, d, t).std(), shift


def test_period2_branch_against_time_integration(period2):
    s = next(s for s in period2 if np.sum(s.branch.stable) >= 10)
    br = s.branch
    assert s.problem.harmonics.ratio == hbm.basis.as_ratio("1/2", "r")
    assert np.all(br.residual < 1e-9)
    std = br.element(0).mesh_load_std
    stable = np.flatnonzero(br.stable)
    for i in stable[[len(stable) // 3, 2 * len(stable) // 3]]:
        ti, shift = _time_integration(s.problem, br.rpm[i], br.unknowns[i])
        assert abs(ti - std[i]) < 1e-4 * std[i]
        assert shift > 1e-2                               # not the period-1 orbit


def test_period2_branch_rejoins_at_the_other_doubling(period2):
    s = next(s for s in period2 if s.branch.status == "rejoined")
    others = [t.doubling.rpm for t in period2 if t is not s]
    assert s.rejoin_rpm != s.doubling.rpm
    # the period doubling it met again is not switched at a second time
    assert all(abs(r - s.rejoin_rpm) > 1e-9 for r in others)
    lo, hi = sorted((s.doubling.rpm, s.rejoin_rpm))
    assert lo - 1e-3 * hi <= np.min(s.branch.rpm) and np.max(s.branch.rpm) <= hi * 1.001


def test_second_doubling_gives_a_period4_branch(main):
    pb, br = main
    found = period_doubling_branches(pb, br, (LO, HI), depth=2, step_rpm=STEPS, tol=1e-9)
    four = [s for s in found if s.period == 4]
    assert four, "no period-4 branch"
    s = four[0]
    parent = next(p for p in found if p.name == s.parent)
    assert parent.period == 2
    assert s.problem.harmonics.ratio == pb.harmonics.ratio / 4
    # born where its parent's own verdict has a period doubling
    assert s.doubling.index in doubling_brackets(parent.branch)
    assert np.all(s.branch.residual < 1e-9)


def test_depth_zero_and_refusals(main):
    pb, br = main
    assert period_doubling_branches(pb, br, (LO, HI), depth=0, step_rpm=STEPS) == []
    with pytest.raises(ValueError, match="period_doubling_depth"):
        period_doubling_branches(pb, br, (LO, HI), depth=-1, step_rpm=STEPS)
