"""benchmarks/verdict_check_ti.py on the SDOF pair traced with 3 mesh harmonics over
1700-2200 rpm (the run rechecks its verdicts in and next to its tangles on 4): every
checked point is integrated, and a stable verdict on an orbit the richer set confirms
(coefficients within 1e-3) is one the integration stays on."""
from __future__ import annotations

import json

from benchmarks import verdict_check_ti


def test_checked_verdicts_against_the_integration(sdof3_run, tmp_path):
    scene, sets, out, cache = sdof3_run
    got = verdict_check_ti.main(["--scene", str(scene), "--set", *sets, "--run", str(out),
                                 "--cache", str(cache), "--turns", "2", "--max-points", "3",
                                 "--out", str(tmp_path / "v.json")])
    recs = got["records"]
    assert len(recs) == 3
    for r in recs:
        if r["after"] and r["same_orbit"] and r["orbit_change"] < 1e-3:
            assert r["ti_stays"], r
    assert json.loads((tmp_path / "v.json").read_text())["headline"][
        "verdicts checked against time integration"] == 3
