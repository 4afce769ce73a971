"""benchmarks/te_ipp.py: the nonlinear IPP of TE candidates at fixed speeds, checked on
the single-DOF scene (no FE, seconds) against problems built from the scene with that TE
and against the counts of :func:`hbm.point_stats`."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from benchmarks import te_ipp
from benchmarks import te_margin as tm

ROOT = Path(__file__).resolve().parents[2]
SDOF = ROOT / "scenes" / "gear-pair-sdof.toml"
OV = {"hbm.mesh_harmonics": 8, "hbm.stability": False}
#: another TE than the scene's 20, 2, 0.5 µm at 0, 90, 0 deg
TE = ([17.0, 3.5, 1.2], [25.0, 140.0, 300.0])
#: single-sided impacts of the scene's branch (grazing at 1416 rpm, two-sided from 1791)
RPM = 1600.0


def _problem(cache: Path, amps=None, phases=None):
    from study.pipeline import Pipeline
    from study.scene.load import load_scene

    ov = dict(OV)
    if amps is not None:
        ov.update({"transmission_error.amplitudes_um": list(amps),
                   "transmission_error.phases_deg": list(phases)})
    return Pipeline(load_scene(SDOF, ov), cache / "p", cache_dir=cache,
                    progress=False).problem()[0]


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return tmp_path_factory.mktemp("te_ipp")


def test_with_te_is_the_problem_of_the_scene_with_that_te(cache):
    base, ref = _problem(cache), _problem(cache, *TE)
    prob = te_ipp.with_te(base, *TE)
    u = np.random.default_rng(0).standard_normal(prob.n_unknowns) * 1e-5
    w = RPM * np.pi / 30.0
    r, r_ref = prob.residual(u, w), ref.residual(u, w)
    assert np.abs(r - r_ref).max() <= 1e-12 * np.abs(r_ref).max()
    assert prob.elements[0].te == pytest.approx(ref.elements[0].te, rel=1e-14)


def test_with_te_refuses_bad_input(cache):
    base = _problem(cache)
    with pytest.raises(ValueError, match="amps_um"):
        te_ipp.with_te(base, [1.0, 2.0], [0.0])
    with pytest.raises(ValueError, match=">= 0"):
        te_ipp.with_te(base, [-1.0], [0.0])
    nl = te_ipp.NonlinearIPP(base, {RPM: np.zeros(base.n_unknowns)}, n_te=2)
    with pytest.raises(ValueError, match="n_te = 2"):
        nl.solve([1.0, 2.0, 3.0], [0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="starts"):
        te_ipp.NonlinearIPP(base, {RPM: np.zeros(3)})


def test_homotopy_solve_is_a_fresh_solve_and_counts_like_point_stats(cache):
    from hbm import impacts_per_mesh_period, point_stats

    base = _problem(cache)
    start = base.solve(RPM)
    assert point_stats(base, start)[0].contact == 1              # single-sided impacts
    nl = te_ipp.NonlinearIPP(base, {RPM: start.unknowns}, tol=1e-10)
    prob, pts = nl.solve(*TE)
    fresh = _problem(cache, *TE).solve(RPM, tol=1e-10)        # its own initial guess
    u, v = pts[RPM].unknowns, fresh.unknowns
    assert np.abs(u - v).max() <= 1e-7 * np.abs(v).max()
    st = point_stats(prob, pts[RPM])[0]
    assert st.contact == 1
    # impacts per mesh period of the sampled gap, as point_stats counts its loss samples
    gap = te_ipp.gap_signal(prob, u)
    assert np.array_equal(impacts_per_mesh_period(gap < 0.0, prob.steps[0]), st.ipp)
    # the smooth shares tend to the exact ones (one loss interval per minimum here)
    exact = tm.cumulative(tm.ipp_fraction_vector(st.ipp))
    assert tm.soft_ipp(gap, prob.steps[0], 1e-13) == pytest.approx(exact, abs=1e-9)


def test_targets_refuse_shares_that_are_not_a_partition():
    with pytest.raises(ValueError, match=r"shares\[1700"):
        te_ipp.IPPTargets(shares={1700.0: [0.0, 0.2, 0.7, 0.0]})
    with pytest.raises(ValueError, match="tol"):
        te_ipp.IPPTargets(shares={1700.0: [0.0, 0.2, 0.8, 0.0]}, tol=0.0)


def test_fractions_from_cumulative_invert_cumulative_and_bounds_are_checked():
    f = np.array([0.1, 0.2, 0.6, 0.1])
    assert tm.fractions_from_cumulative(tm.cumulative(f)) == pytest.approx(f, abs=1e-15)
    with pytest.raises(ValueError, match="minimum"):
        te_ipp.IPPTargets(shares={}, minimum={1070.0: [0.5, 0.5, 0.5, 0.0]})


def test_the_store_keeps_the_scenes_entry_and_the_latest_candidates(cache):
    base = _problem(cache)
    nl = te_ipp.NonlinearIPP(base, {RPM: base.solve(RPM).unknowns}, tol=1e-10, keep=3)
    scene_x = nl._store[0][0].copy()
    amps = [[a, 4.5, 1.5] for a in (6.0, 6.5, 7.0, 7.5, 8.0)]
    for a in amps:
        assert nl.solve(a, TE[1]) is not None
    # keep = 3: the scene's entry and the two latest of five candidates
    assert np.array_equal(nl._store[0][0], scene_x)
    kept = sorted(round(float(np.exp(x[0])), 6) for x, _ in nl._store[1:])
    assert kept == [7.5, 8.0]


def test_targets_refuse_weights_of_other_speeds_and_negative_depths():
    with pytest.raises(ValueError, match="weights"):
        te_ipp.IPPTargets(shares={1700.0: [0.0, 0.2, 0.8, 0.0]}, weights={1070.0: 1.0})
    with pytest.raises(ValueError, match="min_depth"):
        te_ipp.IPPTargets(shares={}, min_depth=-1e-9)


def test_sensitivity_changes_one_harmonic_at_a_time(cache):
    from hbm import point_stats

    base = _problem(cache)
    nl = te_ipp.NonlinearIPP(base, {RPM: base.solve(RPM).unknowns}, tol=1e-10)
    rows = te_ipp.sensitivity(nl, *TE, rel=0.02, deg=2.0)
    assert len(rows) == 1 + 2 * 3 + 2 * 3
    prob, pts = nl.solve(*TE)
    exact = tm.ipp_fraction_vector(point_stats(prob, pts[RPM])[0].ipp).tolist()
    assert rows[0]["change"] == "TE" and rows[0]["fractions"][str(RPM)] == exact
    assert rows[2]["amplitudes_um"] == pytest.approx([17.0 * 1.02, 3.5, 1.2])
    assert rows[-1]["phases_deg"] == pytest.approx([25.0, 140.0, 302.0])
    with pytest.raises(ValueError, match="rel = 0"):
        te_ipp.sensitivity(nl, *TE, rel=0.0)
