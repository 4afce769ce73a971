"""The bifurcation diagram (study.outputs.bifurcation, study.plots.bifurcation) and the
time responses over a whole unstable segment (``[outputs] attractor_speeds_per_segment``,
``attractor_sweep``, ``attractor_max_integrations``): on the single-DOF scene's
period-doubling segment (4073-4500 rpm) and, for the secondary-branch interface, on the
two-mode gear model with a period-2 harmonic set (issue 40 item 4)."""

from pathlib import Path

import h5py
import numpy as np
import pytest
from hbm_models import RPM, neimark_sacker_problem

import hbm
import study
from hbm.post.poincare import orbit_section
from study.outputs.bifurcation import SOURCES, branch_samples, diagram
from study.scene.load import load_scene

SDOF = Path(__file__).resolve().parents[1] / "scenes" / "gear-pair-sdof.toml"
OVERRIDES = {"continuation.speed_rpm": [3950.0, 4500.0],
             "outputs.attractor_transient_turns": 2, "outputs.attractor_window_turns": 2,
             "outputs.attractor_speeds_per_segment": 3, "outputs.attractor_sweep": True,
             "outputs.attractor_max_integrations": 2, "outputs.plots": ["bifurcation"]}


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("bifurcation")
    return study.run(load_scene(SDOF, OVERRIDES), out / "run", cache_dir=out / "cache")


def test_speeds_spread_over_the_segment_as_a_sweep_within_the_bound(run):
    from study.outputs.report import summary

    (seg,) = [u for u in summary(run)["unstable_segments"] if u.kind == "period_doubling"]
    atts = [a for a in run.attractors if a.segment == seg]
    assert len(atts) == 3
    first, last = seg.index
    assert [a.rpm for a in atts] == sorted(a.rpm for a in atts)
    assert atts[0].rpm == pytest.approx(seg.rpm[0]) and atts[-1].rpm == pytest.approx(seg.rpm[1])
    assert all(a.rpm in run.branch.rpm[first:last + 1] for a in atts)
    assert atts[0].start == "orbit"
    assert atts[1].start == f"sweep from {atts[0].rpm:.1f} rpm"
    assert atts[2].skipped and atts[2].response is None        # the bound of 2
    assert atts[2].outcome == "not integrated"


def test_period_doubling_segment_reaches_a_period_2_response(run):
    """Floquet says period doubling; the Poincaré section of the time response (once per
    mesh period, 76 per turn) alternates between two values of Delta: period-2. At the
    segment's onset (growth 28 1/s) the period-2 part has only begun to grow over 2 + 2
    turns (std the orbit's within 0.1 %, strongest line still the mesh order); at the
    middle speed, reached by the sweep (growth 959 1/s), it has taken over: strongest
    line at half the mesh order (Z/2 = 38), std 1.6 times the orbit's. The load alone
    would not show it: it is zero at every section instant of one parity (contact
    lost), so the section is classified on (Delta, load)."""
    z = run.scene.gear.teeth
    onset, middle = run.attractors[:2]
    for a in (onset, middle):
        sec = a.section
        assert sec.samples == 2 * z
        assert (sec.kind, sec.period) == ("periodic", 2) and a.outcome == "period-2"
    assert onset.response.std == pytest.approx(onset.orbit_std, rel=1e-3)
    assert onset.response.lines[0][0] == pytest.approx(z)
    r = middle.response
    assert r.lines[0][0] == pytest.approx(z / 2)
    assert r.std > 1.5 * middle.orbit_std
    x = r.section_delta
    assert abs(x[0] - x[1]) > 0.1 * r.delta_std          # two distinct samples
    assert np.allclose(x[::2], x[0], atol=1e-3 * r.delta_std)
    assert np.allclose(x[1::2], x[1], atol=1e-3 * r.delta_std)


def test_diagram_in_results_plot_and_report(run):
    d = run.bifurcation
    main = d.of(SOURCES[0])
    assert main.sum() == len(run.branch)
    for i in (0, len(run.branch) // 2, len(run.branch) - 1):   # the load at t = 0
        from study.outputs.points import point_at
        assert d.load[main][i] == pytest.approx(
            orbit_section(run.problem, point_at(run, i))[0], rel=1e-12)
    assert np.array_equal(d.stable[main], run.branch.stable.astype(np.int8))
    ti = d.of(SOURCES[2])
    assert ti.sum() == 2 * 2 * run.scene.gear.teeth            # two integrations' sections
    with h5py.File(run.results, "r") as f:
        g = f["bifurcation"]
        assert np.array_equal(g["load"][()], d.load)
        assert np.array_equal(g["source"][()], d.source)
        assert g.attrs["sources"].startswith("periodic branch")
        assert f["attractors/0"].attrs["outcome"] == "period-2"
        assert f["attractors/0/section"].shape == (2 * run.scene.gear.teeth,)
    assert (run.out / "bifurcation.png").stat().st_size > 10_000
    text = (run.out / "report.md").read_text()
    assert "## What the machine does in the unstable segments" in text
    assert "| period doubling | 3 | **period-2** at " in text
    assert "**not integrated** at " in text


def _doubled(problem):
    """The problem on the harmonic set of half its fundamental (its indices doubled and
    the odd ones between): a period-2 problem as hbm.branching builds it."""
    hs = problem.harmonics
    idx = sorted({2 * k for k in hs.indices} | {abs(2 * k + s) for k in hs.indices
                                                 for s in (1, -1)})
    return hbm.HBMProblem(problem.system, list(problem.elements), problem.excitation,
                          hbm.HarmonicSet(idx, ratio=hs.ratio / 2, n_time=2 * hs.n_time),
                          problem.condensation)


def test_secondary_branch_gives_two_samples_per_point():
    """A branch of the period-2 problem holds the period-1 orbit where that is the only
    solution: its two samples per point are the main branch's one (the interface the
    period-2 branches of the pipeline are drawn through: (problem, branch) pairs)."""
    p = neimark_sacker_problem(harmonics=8)
    p2 = _doubled(p)
    kw = dict(step=0.01, max_step=0.02, stability=False)
    br = hbm.trace(p, 2.0 / RPM, 2.2 / RPM, **kw)
    br2 = hbm.trace(p2, 2.0 / RPM, 2.2 / RPM, **kw)
    rpm, load, _, _, k = branch_samples(p, br, p)
    rpm2, load2, _, _, k2 = branch_samples(p2, br2, p)
    assert (k, k2) == (1, 2)
    ref = np.interp(rpm2, rpm, load[:, 0])
    assert load2[:, 0] == pytest.approx(ref, rel=1e-3)
    assert load2[:, 1] == pytest.approx(load2[:, 0], rel=1e-8)

    class Result:                     # what diagram() reads of a run
        problem, branch, attractors = p, br, []
    d = diagram(Result, secondary=[(p2, br2)])
    sec = d.of(SOURCES[1])
    assert sec.sum() == 2 * len(br2) and set(d.periods[sec]) == {2}
    assert np.array_equal(d.load[sec], load2.ravel())


def test_segment_points_spread_over_the_segment():
    from types import SimpleNamespace

    from study.outputs.attractors import segment_points
    from study.outputs.curves import UnstableSegment

    rpm = np.array([100.0, 101.0, 102.0, 103.5, 104.0, 106.0, 110.0])
    rate = np.array([-1.0, 0.5, 2.0, 7.0, 3.0, 1.0, -1.0])
    br = SimpleNamespace(rpm=rpm, floquet_max_real=rate)
    seg = UnstableSegment("neimark_sacker", (101.0, 106.0), 5, 1.0, (1, 5))
    assert segment_points(br, seg, 1) == [3]               # the largest growth rate
    assert segment_points(br, seg, 3) == [1, 3, 5]         # nearest 101, 103.5, 106
    assert segment_points(br, seg, 50) == [1, 2, 3, 4, 5]  # each point once
    with pytest.raises(ValueError, match="attractor_speeds_per_segment"):
        segment_points(br, seg, 0)


def test_outcome_words():
    """What report.md says a response is: from its Poincaré section, its std against the
    orbit's and whether the turns left out let a disturbance of the orbit grow."""
    from types import SimpleNamespace

    from hbm.post.poincare import Section
    from study.outputs.attractors import Attractor
    from study.outputs.curves import UnstableSegment

    seg = UnstableSegment("neimark_sacker", (100.0, 101.0), 2, 1.0, (0, 1))
    qp = Section("quasi-periodic", 0, 0.31, 0.9999, 1.0, 1024)
    one = Section("periodic", 1, float("nan"), float("nan"), 1e-5, 1024)

    def att(sec, std, growth, transient=100, eps=1e-6, start="orbit"):
        r = SimpleNamespace(poincare=sec, std=std, transient=transient, periodic=None)
        return Attractor(seg, 100.0, 1.0, r, growth=growth, perturbation=eps, start=start)

    # 100 turns at 100 rpm = 60 s: growth 1 1/s gives 60 e-folds (> ln 1e6 = 13.8)
    assert att(qp, 3.0, 1.0).outcome == "quasi-periodic"
    assert att(qp, 1.0, 0.1).outcome == "not settled"             # 6 e-folds
    assert att(qp, 1.0, 0.1, start="sweep from 99.0 rpm").outcome == "quasi-periodic"
    assert att(one, 1.005, 1.0).outcome == "orbit kept"
    assert att(one, 1.5, 1.0).outcome == "another period-1 orbit"
    assert att(qp, 1.0, 0.1).left_orbit is False
    assert att(qp, 1.0, 0.1).transient_folds == pytest.approx(6.0)
