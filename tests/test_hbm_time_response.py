"""hbm.post.time_response: the problem's equations integrated in time, against the
harmonic balance on the Kahraman–Singh softening pair (tests/hbm_models.py)."""

import numpy as np
import pytest
from hbm_models import RPM, sdof_problem

import hbm
from hbm.post.time_response import integrate


@pytest.fixture(scope="module")
def softening():
    pb = sdof_problem(harmonics=30, fa=0.05, b=1.0)
    return pb, hbm.trace(pb, 0.3 / RPM, 1.6 / RPM)


def _std_at(pb, br, piece, rpm):
    """Mesh-load std of the orbit of the branch piece (index array) at ``rpm``, by Newton
    from the piece's nearest point."""
    k = piece[np.argmin(np.abs(br.rpm[piece] - rpm))]
    point = pb.solve(rpm, x0=br.unknowns[k], tol=1e-12)
    return float(hbm.time_series(pb, point, 1, 4096).load.std())


def test_a_stable_orbit_is_its_own_time_response(softening):
    """From a stable point, 40 turns reproduce the orbit: the same std every turn and
    the harmonic balance's std (30 harmonics) to 1e-5, its strongest line at order 1."""
    pb, br = softening
    i = int(np.argmin(np.abs(br.rpm - 1.2 / RPM)))
    assert br.stable[i]
    point = pb.solve(float(br.rpm[i]), x0=br.unknowns[i], tol=1e-12)
    tr = integrate(pb, float(br.rpm[i]), point, transient=20, window=20)
    assert tr.periodic and tr.lines[0][0] == pytest.approx(1.0)
    assert tr.std == pytest.approx(float(br.element(0).mesh_load_std[i]), rel=1e-5)
    assert np.ptp(tr.std_per_turn) < 1e-6 * tr.std
    # its envelope, mesh period by mesh period (64 samples each, as the harmonic balance's
    # on the same instants), is the orbit's in every analysed turn
    z = pb.elements[0].n_teeth
    ref = hbm.mesh_period_envelope(pb, point, n_time=64 * pb.steps[0])
    assert tr.envelope.peak_load.shape == (z * 20,)
    reps = 20 * z // ref.peak_load.size
    assert tr.envelope.peak_load == pytest.approx(np.tile(ref.peak_load, reps), rel=1e-5)
    scale = np.abs(ref.mean_dte).max()
    assert np.abs(tr.envelope.mean_dte - np.tile(ref.mean_dte, reps)).max() < 1e-5 * scale


def test_from_the_unstable_middle_orbit_it_lands_on_a_stable_one(softening):
    """Inside the hysteresis the middle orbit (between the folds) is unstable; from it
    the time integration settles on the lower or the upper orbit, whose std the
    harmonic balance gives, and not on the middle one's."""
    pb, br = softening
    i1, i2 = br.fold_index
    s = 0.5 * (min(br.folds) + max(br.folds))
    middle = np.arange(i1 + 1, i2 + 1)
    j = middle[np.argmin(np.abs(br.rpm[middle] - s))]
    assert not br.stable[j]
    rpm = float(br.rpm[j])
    point = pb.solve(rpm, x0=br.unknowns[j], tol=1e-12)
    tr = integrate(pb, rpm, point, transient=150, window=10)
    mid = _std_at(pb, br, middle, rpm)
    lower = _std_at(pb, br, np.arange(i1 + 1), rpm)
    upper = _std_at(pb, br, np.arange(i2, len(br)), rpm)
    assert tr.periodic
    off = min(abs(tr.std / lower - 1), abs(tr.std / upper - 1))
    assert off < 1e-3, (tr.std, lower, upper)      # 2.5e-4: 30 harmonics with impacts
    # the middle orbit is 0.7 % from the upper one here, 29 times the landing error
    assert abs(tr.std / mid - 1) > 10 * off, (tr.std, mid)


def test_integrate_refuses_bad_input(softening):
    pb, br = softening
    point = pb.solve(float(br.rpm[0]), x0=br.unknowns[0])
    with pytest.raises(ValueError, match="window = 0"):
        integrate(pb, float(br.rpm[0]), point, window=0)
    with pytest.raises(ValueError, match="rpm = -1"):
        integrate(pb, -1.0, point)
    with pytest.raises(ValueError, match="start: modal state of shape"):
        integrate(pb, float(br.rpm[0]), np.zeros(3))
