"""``[outputs] attractor_transient_turns``: time integration at the unstable segments of
a run, in report.md (study.outputs.attractors), on the single-DOF scene whose curve has amplitude
jumps (folds) and a period-doubling segment."""

from pathlib import Path

import h5py
import numpy as np
import pytest

import study
from study.scene.load import load_scene

SDOF = Path(__file__).resolve().parents[1] / "scenes" / "gear-pair-sdof.toml"
OVERRIDES = {"outputs.attractor_transient_turns": 2, "outputs.attractor_window_turns": 2,
             "outputs.plots": []}


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    scene = load_scene(SDOF, OVERRIDES)
    out = tmp_path_factory.mktemp("attractors")
    return study.run(scene, out / "run", cache_dir=out / "cache")


def test_each_unstable_segment_has_its_time_response_in_the_report(run):
    from study.outputs.report import summary

    segs = summary(run)["unstable_segments"]
    kinds = {u.kind for u in segs}
    assert {"fold", "period_doubling"} <= kinds
    assert [a.segment for a in run.attractors] == segs
    text = (run.out / "report.md").read_text()
    for a in run.attractors:
        first, last = a.segment.index          # started from a point of the segment
        assert a.rpm in run.branch.rpm[first:last + 1]
        assert f"time integration from the orbit at {a.rpm:.1f} rpm (2 turns left out, 2 " \
               f"analysed): mesh-load std {a.response.std:.4g} N" in text
    import csv

    with open(run.out / "attractors.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert [(r["kind"], float(r["speed_rpm"])) for r in rows] == [
        (a.segment.kind, pytest.approx(a.rpm, abs=1e-6)) for a in run.attractors]
    for r, a in zip(rows, run.attractors, strict=True):
        assert float(r["response_std_N"]) == pytest.approx(a.response.std, rel=1e-7)
        assert float(r["top_order"]) == pytest.approx(a.response.lines[0][0], rel=1e-5)
        assert r["periodic"] == str(int(a.response.periodic)) and r["error"] == ""
    with h5py.File(run.out / "results.h5", "r") as f:   # the same in results.h5
        g = f["attractors"]
        assert g.attrs["count"] == len(run.attractors)
        for i, a in enumerate(run.attractors):
            h, r = g[str(i)], a.response
            assert h.attrs["kind"] == a.segment.kind and h.attrs["rpm"] == a.rpm
            assert h.attrs["std"] == r.std and h.attrs["turns_analysed"] == 2
            assert np.array_equal(h["std_per_turn"][()], r.std_per_turn)
            assert np.array_equal(h["lines"][()], np.array(r.lines))
            assert np.array_equal(h["peak_load"][()], r.envelope.peak_load)
            # the envelope is the analysed turns': its largest peak is their largest load
            assert h["peak_load"][()].max() == pytest.approx(r.max_load, rel=1e-12)
            assert h["peak_load"].shape == (2 * run.scene.gear.teeth,)
        assert f["continuation/rpm"].shape == run.branch.rpm.shape  # the rest is kept


def test_period_doubling_leads_to_a_half_mesh_order_response(run):
    """Floquet says period doubling; the time integration from that orbit (an independent
    method) settles on a response whose strongest line is half the mesh order, Z/2,
    which the mesh-fundamental harmonic set cannot hold."""
    (a,) = [a for a in run.attractors if a.segment.kind == "period_doubling"]
    z = run.scene.gear.teeth
    assert a.response.lines[0][0] == pytest.approx(z / 2)
    assert a.response.periodic and a.response.std > 1.2 * a.orbit_std


def test_from_a_jump_the_response_lands_on_a_stable_orbit_of_the_curve(run):
    """From the most unstable point of the middle of a jump the machine settles on a
    stable orbit of the same curve at that speed (another branch piece), not on the one
    it started from."""
    br = run.branch
    stable = br.stable.astype(bool)
    landed = 0
    for a in run.attractors:
        if a.segment.kind != "fold" or not a.response.periodic:
            continue
        near = stable & (np.abs(br.rpm / a.rpm - 1) < 5e-3)
        assert near.any()
        off = np.min(np.abs(br.element(0).mesh_load_std[near] / a.response.std - 1))
        assert off < 1e-2, (a.rpm, a.response.std, br.element(0).mesh_load_std[near])
        assert abs(a.response.std / a.orbit_std - 1) > 0.1
        landed += 1
    assert landed >= 1


def test_a_failed_integration_is_said_in_the_report(run, monkeypatch):
    import study.outputs.attractors as sa
    from study.outputs.report import summary, unstable_lines

    def fail(*args, **kwargs):
        raise RuntimeError("solve_ivp failed after 3 turns: step size too small")

    monkeypatch.setattr(sa, "integrate", fail)
    found = sa.attractors(run)
    assert found and all(a.response is None for a in found)
    text = "\n".join(unstable_lines(summary(run)["unstable_segments"], found))
    assert text.count("failed: RuntimeError: solve_ivp failed after 3 turns") == len(found)


def test_report_from_results_gives_the_same_time_responses(run):
    """``geardyn report`` (report_from_results) integrates again from the saved branch:
    the same attractors.csv, bitwise, and the same ``/attractors`` in results.h5, whose
    branch it leaves as it was."""
    from study.pipeline.replay import report_from_results

    def stored():
        with h5py.File(run.out / "results.h5", "r") as f:
            return ({k: f["attractors"][k]["std_per_turn"][()].tolist() for k in f["attractors"]},
                    f["continuation/unknowns"][()].tobytes())

    before, h5_before = (run.out / "attractors.csv").read_text(), stored()
    (run.out / "attractors.csv").unlink()
    report_from_results(SDOF, run.out, OVERRIDES, cache=str(run.out.parent / "cache"))
    assert (run.out / "attractors.csv").read_text() == before
    assert stored() == h5_before        # /attractors rewritten the same, the branch kept


def test_time_responses_are_kept_without_report(run, tmp_path):
    """``[outputs] report = false``: no report.md, but attractors.csv and ``/attractors``
    are still written (the time responses were asked for)."""
    import dataclasses
    import shutil

    from study.pipeline.export import _figures

    out = tmp_path / "run"
    shutil.copytree(run.out, out)
    for name in ("report.md", "attractors.csv"):
        (out / name).unlink()
    quiet = dataclasses.replace(run.scene, outputs=dataclasses.replace(run.scene.outputs,
                                                                       report=False))
    res = dataclasses.replace(run, out=out, results=out / "results.h5", scene=quiet,
                              attractors=[], figures=[])
    _figures(res)
    assert not (out / "report.md").exists()
    assert (out / "attractors.csv").read_text() == (run.out / "attractors.csv").read_text()
    with h5py.File(out / "results.h5", "r") as f:
        assert f["attractors"].attrs["count"] == len(run.attractors)
