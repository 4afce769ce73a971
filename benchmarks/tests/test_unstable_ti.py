"""benchmarks/unstable_ti.py: the runs of unstable points and the stable orbits of a branch
at a speed (exact on a constructed branch), and the whole script on a short run of the
SDOF pair: from the middle of a jump the integration leaves the unstable orbit."""
from __future__ import annotations

import numpy as np
import pytest

from benchmarks import unstable_ti


def test_runs_and_stable_orbits_of_a_constructed_branch():
    # an S-shaped branch: lower sheet up to 10, middle sheet back to 8, upper sheet on
    rpm = np.array([6, 7, 8, 9, 10, 9.5, 9, 8.5, 8, 9, 10, 11], dtype=float)
    std = np.array([1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12], dtype=float)
    stable = np.array([1, 1, 1, 1, 1, 0, 0, 0, 1, 1, 1, 1], dtype=bool)
    assert unstable_ti.unstable_runs(stable) == [(5, 7)]
    assert unstable_ti.unstable_runs(stable, min_points=4) == []
    # at 9 rpm: the lower sheet (std 4) and the upper one (std 10); the middle is unstable
    got = sorted(unstable_ti.stable_orbits_at(rpm, std, stable, 9.0))
    assert got == pytest.approx([4.0, 4.0, 10.0, 10.0])     # each bracketing segment once
    assert unstable_ti.stable_orbits_at(rpm, std, stable, 8.75) == pytest.approx([3.75, 9.75])


def test_the_script_on_a_short_run(sdof3_run, tmp_path):
    scene, sets, out, cache = sdof3_run
    got = unstable_ti.main(["--scene", str(scene), "--set", *sets, "--run", str(out),
                            "--cache", str(cache), "--turns", "4", "--settled", "1",
                            "--max-runs", "1", "--out", str(tmp_path / "u.json")])
    recs = got["records"]
    assert 1 <= len(recs) <= 3
    for r in recs:
        assert r["ti_std"] > 0 and np.isfinite(r["ti_std"])
        if r["on_a_stable_orbit"]:
            assert r["nearest_rel_diff"] <= 1e-3
    assert any(r["left_orbit"] for r in recs)
