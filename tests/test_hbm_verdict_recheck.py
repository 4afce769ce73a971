"""Verdicts checked on a richer harmonic set (hbm.stability.recheck) against our own time
integration (scipy DOP853 of the modal equations, hbm.post.time_response), on the SDOF
gear pair of scenes/gear-pair-sdof.toml traced with a deliberately poor set (3 mesh
harmonics) and rechecked with 4.

Where the two sets disagree the richer one is what the machine does: a point that was
"stable" but has no orbit near it on the richer set, or whose better resolved orbit is
unstable, is left by the integration started on it (it goes to the other attractor,
relative distance ~0.6 after 40 periods); a point that was "unstable" but is stable on the
richer set is not left (the integration settles within the 3-harmonic orbit's own error,
a few per cent, of where it started)."""

from pathlib import Path

import numpy as np
import pytest
from hbm_models import orbit_departure

import hbm
from hbm.basis import embed_coefficients, index_positions
from hbm.stability.recheck import (
    recheck_candidates,
    recheck_verdicts,
    richer_mesh_harmonics,
)
from study.pipeline.model import scene_problem
from study.scene.load import load_scene

SCENE = Path(__file__).resolve().parents[1] / "scenes" / "gear-pair-sdof.toml"


@pytest.fixture(scope="module")
def pair3():
    pb, _ = scene_problem(load_scene(SCENE, {"hbm.mesh_harmonics": 3}))
    rich, _ = scene_problem(load_scene(SCENE, {"hbm.mesh_harmonics": richer_mesh_harmonics(3)}))
    br = hbm.trace(pb, 1000.0, 6000.0, stability=True, stability_process=False, tol=1e-10)
    assert br.status == "completed"
    return pb, rich, br


def test_richer_set_and_transfer():
    assert [richer_mesh_harmonics(n) for n in (1, 3, 8, 12)] == [2, 4, 11, 16]
    pb, _ = scene_problem(load_scene(SCENE, {"hbm.mesh_harmonics": 3}))
    rich, _ = scene_problem(load_scene(SCENE, {"hbm.mesh_harmonics": 5}))
    u = np.random.default_rng(1).normal(size=pb.n_unknowns)
    up = embed_coefficients(u.reshape(-1, pb.nr), pb.harmonics, rich.harmonics).ravel()
    assert up.size == rich.n_unknowns
    back = rich.harmonics.to_complex(up.reshape(-1, rich.nr))
    back = pb.harmonics.to_real(back[:, index_positions(pb.harmonics, rich.harmonics)])
    np.testing.assert_array_equal(back.ravel(), u)                      # exact round trip
    assert np.count_nonzero(up) == np.count_nonzero(u)                   # the rest is zero


def test_flipped_verdicts_agree_with_the_time_integration(pair3):
    pb, rich, br = pair3
    checks = recheck_verdicts(pb, rich, br.rpm, br.unknowns, np.arange(len(br)), tol=1e-10)
    flips = [c for c in checks if (c.stable and c.same_orbit) != bool(br.stable[c.index])]
    # 1450.9 rpm (2 points, unstable -> stable), 1790.2-1790.3 (4, stable -> no orbit),
    # 2089.2 (stable -> no orbit), 3003.8 (unstable -> stable): measured 2026-11-27
    assert len(flips) >= 6
    kinds = set()
    for c in flips:
        d = orbit_departure(pb, pb.point(br.unknowns[c.index], br.omega[c.index]))
        if c.stable and c.same_orbit:
            assert d < 0.1 and d < 2 * c.change + 0.02, (c, d)     # settles where it started
            kinds.add("now stable")
        else:
            assert d > 0.3, (c, d)                                 # leaves for the other one
            kinds.add("now unstable" if c.same_orbit else "no orbit")
    assert {"now stable", "no orbit"} <= kinds
    # where the sets agree the verdict stands and the orbits are close
    same = [c for c in checks if c.same_orbit and c.stable == bool(br.stable[c.index])]
    assert len(same) > 0.9 * len(checks)


def test_candidates_are_the_doubtful_and_the_tangles():
    class T:
        first, last = 20, 30
    stable = np.zeros(60, dtype=bool)
    stable[[5, 12, 25, 38, 45]] = True
    consistent = np.ones(60, dtype=bool)
    consistent[50] = False
    grazing = np.zeros(60, dtype=bool)
    grazing[55] = True
    got = recheck_candidates(stable, consistent, grazing, [T()], neighbours=10)
    np.testing.assert_array_equal(got, [12, 25, 38, 50, 55])


def test_a_run_writes_and_replays_its_verdict_checks(tmp_path):
    """The pipeline rechecks the points in and next to the near-grazing tangles of the
    3-harmonic pair (1700-2200 rpm), writes them to /verdict_checks with the verdicts it
    wrote into /continuation, and `geardyn report` reads them back into report.md."""
    import h5py

    from study.pipeline import Pipeline
    from study.pipeline.replay import report_from_results

    over = {"hbm.mesh_harmonics": 3, "continuation.speed_rpm": [1700.0, 2200.0],
            "outputs.plots": []}
    out = tmp_path / "out"
    Pipeline(load_scene(SCENE, over), out, cache_dir=tmp_path / "cache",
             progress=False).run()
    with h5py.File(out / "results.h5", "r") as f:
        g = f["verdict_checks"]
        assert g.attrs["mesh_harmonics"] == 4 and g["index"].size > 0
        idx = g["index"][:]
        np.testing.assert_array_equal(f["continuation/stable"][:][idx].astype(bool),
                                      g["stable"][:])
        assert np.all(g["same_orbit"][:] | ~g["stable"][:])
    line = "verdicts in doubt checked with 4 instead of 3 mesh harmonics"
    assert line in (out / "report.md").read_text()
    (out / "report.md").unlink()
    report_from_results(SCENE, out, over, cache=str(tmp_path / "cache"))
    assert line in (out / "report.md").read_text()
