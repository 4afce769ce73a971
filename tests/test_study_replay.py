"""``geardyn report`` (study.pipeline.replay) rewrites ``/checks`` of results.h5 with the
checks of its own export, so that the file and report.md's banner say the same."""
from __future__ import annotations

import math
from pathlib import Path

import h5py

SDOF = Path(__file__).resolve().parents[1] / "scenes" / "gear-pair-sdof.toml"
#: a short curve; stability off, so that one check fails and report.md has a banner
QUICK = {"continuation.speed_rpm": [600.0, 1500.0], "hbm.stability": False,
         "outputs.plots": ["forced_response"]}


def _same(a, b) -> bool:
    return (isinstance(a, float) and isinstance(b, float) and math.isnan(a)
            and math.isnan(b)) or bool(a == b)


def test_report_replaces_the_checks_of_results_h5(tmp_path):
    import study
    from study.pipeline.replay import report_from_results

    cache = tmp_path / "cache"
    run = study.run(SDOF, tmp_path / "run", cache_dir=cache, overrides=QUICK)
    with h5py.File(run.results, "r") as f:
        before = {k: (v.item() if hasattr(v, "item") else v)
                  for k, v in f["checks"].attrs.items()}
    assert before["stability_passed"] is False or before["stability_passed"] == 0
    # a results.h5 whose /checks no longer matches its export (older code, edited file)
    with h5py.File(run.results, "r+") as f:
        g = f["checks"]
        g.attrs["n_failed"] = 7
        g.attrs["bogus_passed"] = False
        g.attrs["residual_passed"] = not bool(before["residual_passed"])
    (run.out / "report.md").unlink()
    res = report_from_results(SDOF, run.out, QUICK, cache=str(cache))
    with h5py.File(run.results, "r") as f:
        after = {k: (v.item() if hasattr(v, "item") else v)
                 for k, v in f["checks"].attrs.items()}
    assert set(after) == set(before)
    assert all(_same(after[k], before[k]) for k in before), (before, after)
    # the banner of report.md names exactly the checks the file marks failed
    failed = [c.name for c in res.checks if not c.passed]
    assert "stability" in failed and after["n_failed"] == len(failed)
    assert sorted(k[:-len("_passed")] for k, v in after.items()
                  if k.endswith("_passed") and not v) == sorted(failed)
    text = (run.out / "report.md").read_text()
    banner = text.split("\n## ")[0]
    assert f"fails {len(failed)} check" in banner
    for name in failed:
        assert f"> - `{name}`:" in banner
