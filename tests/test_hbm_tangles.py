"""Near-grazing tangles of a branch (hbm/post/tangles.py): a cluster of three or more
folds within 0.1 % of the speed, told apart from a resonance's two folds.

The trace is built with known turning points: a monotone run-up, a nearly vertical flank
that winds as ``1391.2 + 0.02 sin(7 pi s)`` (seven interior extrema of the sine, so
seven folds within 0.04 rpm), the jump-down fold 8 rpm lower (a resonance's second
fold, not a tangle), and the run-up again."""
from __future__ import annotations

import numpy as np
import pytest

from hbm.post.tangles import Tangle, find_tangles, turning_points


def _trace():
    up = np.linspace(1300.0, 1391.18, 40)
    s = np.linspace(0.0, 1.0, 141)[1:]
    flank = 1391.2 + 0.02 * np.sin(7 * np.pi * s) - 0.02 * s   # ends just below 1391.2
    down = np.linspace(flank[-1] - 0.5, 1383.0, 20)           # back to the jump-down fold
    again = np.linspace(1383.5, 1500.0, 40)
    rpm = np.concatenate([up, flank, down, again])
    stable = np.ones(rpm.size, dtype=bool)
    stable[40:200] = False
    stable[60:63] = True                                       # a stable sliver inside
    losses = np.concatenate([np.full(40, 76.0), np.linspace(76, 152, 140).round(),
                             np.full(60, 152.0)])
    return rpm, stable, losses


def test_turning_points_are_the_extrema_of_the_trace():
    rpm, _, _ = _trace()
    t = turning_points(rpm)
    # 7 extrema of the sine on the flank plus the jump-down fold at 1383 rpm
    assert t.size == 8
    assert rpm[t[-1]] == pytest.approx(1383.0)
    assert np.all(np.abs(rpm[t[:-1]] - 1391.2) < 0.04)


def test_one_tangle_of_seven_folds_and_not_the_resonance_fold():
    rpm, stable, losses = _trace()
    found = find_tangles(rpm, stable, losses)
    assert len(found) == 1
    t = found[0]
    assert isinstance(t, Tangle)
    assert t.n_folds == 7
    assert 1391.15 < t.rpm_min < t.rpm_max < 1391.23
    assert t.n_stable == 3
    turns = turning_points(rpm)
    assert t.first == turns[0] - 1 and t.last == turns[6] + 1
    assert t.contact_changes == int(losses[t.last] - losses[t.first])
    # two folds alone (a resonance's hysteresis) are no tangle, nor folds 0.2 % apart
    assert find_tangles(rpm, stable, min_folds=8) == []
    assert len(find_tangles(rpm, stable, rel_width=1e-5)) == 0


def test_bad_definitions_are_refused():
    rpm, stable, _ = _trace()
    with pytest.raises(ValueError, match="rel_width"):
        find_tangles(rpm, stable, rel_width=0.0)
    with pytest.raises(ValueError, match="min_folds"):
        find_tangles(rpm, stable, min_folds=1)
