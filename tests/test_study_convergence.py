"""`geardyn convergence`: error against run time, one knob at a time.

The comparison functions are checked against curves and grazing sets whose errors
are known exactly; the study itself runs on the single-DOF scene (harmonics
4, 8, 16: ~20 s, then the CLI reuses the cached stages) and once on the coarse
pump (``slow``).
"""
from __future__ import annotations

import csv
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from hbm import GrazingPoint
from study.scene import SceneError, load_scene
from study.studies.convergence.knobs import Setting, plan
from study.studies.convergence.measures import (
    ConvergenceResult,
    Row,
    curve_error,
    grazing_error,
    recommend,
)
from study.studies.convergence.report import recommendation_text
from study.studies.convergence.sweep import run_convergence

ROOT = Path(__file__).resolve().parents[1]
SDOF = ROOT / "scenes" / "gear-pair-sdof.toml"
PUMP = ROOT / "scenes" / "pump.toml"
ENV = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1",
       "PYTHONPATH": str(ROOT)}
HARMONICS = [4, 8, 16]


# --------------------------------------------------------------------------- comparisons

def _s_curve(n: int, shift: float = 0.0, scale: float = 1.0):
    """A response with two folds: rpm(s) = 1000 + 300 s − 200 s³ (s in [−1.6, 1.6]),
    value(s) = scale (2 + s); multi-valued between the folds at s = ±1/√2."""
    s = np.linspace(-1.6, 1.6, n)
    return 1000 + 300 * s - 200 * s**3 + shift, scale * (2 + s)


def test_curve_error_follows_branches_across_folds():
    r_ref, v_ref = _s_curve(4001)
    r, v = _s_curve(1203)                       # same curve, other sampling
    e_same = curve_error(r_ref, v_ref, r, v)
    # linear interpolation of a smooth segment: error O(h²), far below the branch gap;
    # the default speed slack (0.2 %) covers the fold tips, which the coarser sampling
    # misses by ~1e-3 rpm (without any slack they are compared with the other branch)
    assert e_same < 2e-3
    assert curve_error(r_ref, v_ref, r, v, slack=0.0) > 0.5
    # a wrong branch choice (no segmenting) would give errors of order 1
    r2, v2 = _s_curve(1203, scale=1.01)          # 1 % larger everywhere
    assert curve_error(r_ref, v_ref, r2, v2) == pytest.approx(0.01, abs=2e-3)


def test_curve_error_slack_absorbs_small_speed_shifts_only():
    r_ref, v_ref = _s_curve(4001)
    r, v = _s_curve(4001, shift=1.0)             # whole curve 1 rpm faster
    big = curve_error(r_ref, v_ref, r, v, slack=0.0)
    small = curve_error(r_ref, v_ref, r, v, slack=2e-3)   # 2 rpm at 1000 rpm
    assert big > 0.05          # near the folds the branches no longer overlap
    assert small < 2e-3


def test_grazing_matching():
    ref = [GrazingPoint(1000.0, "onset", "active"), GrazingPoint(2000.0, "end", "active"),
           GrazingPoint(2100.0, "onset", "reverse")]
    got = [GrazingPoint(1005.0, "onset", "active"), GrazingPoint(2050.0, "end", "active"),
           GrazingPoint(2600.0, "onset", "reverse"), GrazingPoint(2101.0, "onset", "active")]
    m = grazing_error(ref, got)
    # 1000 -> 1005 (0.5 %), 2000 -> 2050 (2.5 %, outside Fig. 11's band), reverse 2100
    # has no reverse partner within 5 %; 2101 (active) must not be taken for it
    assert [(a, b) for a, b, _ in m.pairs] == [(1000.0, 1005.0), (2000.0, 2050.0)]
    assert m.fig11 == 1
    assert m.max_rel == pytest.approx(0.025)
    assert m.max_abs_rpm == pytest.approx(50.0)
    assert m.missing == [2100.0] and m.extra == [2101.0, 2600.0]


def test_plan_defaults_and_errors():
    sc = load_scene(SDOF)
    st = plan(sc)
    knobs = {s.knob for s, _ in st}
    assert knobs == {"harmonics", "aft", "step"}      # lumped: no mesh, n_cm; no sidebands
    h = [s.value for s, _ in st if s.knob == "harmonics"]
    assert h == [8, 16, 32]                            # ×0.5, ×1, ×2 of the scene's 16
    steps = [(s.value, c.continuation.max_step, c.continuation.step)
             for s, c in st if s.knob == "step"]
    assert [v for v, *_ in steps] == pytest.approx([156.0, 78.0, 39.0])
    assert all(m == v and s0 <= m for v, m, s0 in steps)
    with pytest.raises(SceneError, match="n_cm"):
        plan(sc, only=["n_cm"])
    with pytest.raises(SceneError, match="unknown knob"):
        plan(sc, knobs={"harmonic": [1, 2]})
    with pytest.raises(SceneError, match="at least 2"):
        plan(sc, knobs={"harmonics": [8]}, only=["harmonics"])


def _rows(errors: dict, ref) -> list:
    """Rows of knob ``h`` with the given curve errors (value -> error), ``ref`` the
    reference value, cost = value seconds."""
    out = []
    for v, e in errors.items():
        r = Row(Setting("h", v, {"hbm.mesh_harmonics": v}), seconds=float(v),
                curve_err=e, reference=v == ref)
        out.append(r)
    return out


def test_recommend_needs_three_values_and_never_the_reference():
    """Two values: the finest is its own reference, so even a coarser value within the
    tolerance of it cannot be called converged; with three, the cheapest within it is
    recommended; the reference alone never is."""
    best, why = recommend(_rows({4: 1e-4, 8: 0.0}, 8), 1e-2)
    assert best is None
    assert "too few values to judge (2 ran, at least 3 needed)" in why
    assert "h = 8, is its own reference" in why
    rows = _rows({4: 0.2, 8: 1e-3, 16: 0.0}, 16)
    assert recommend(rows, 1e-2) == (rows[1], "within tolerance")
    best, why = recommend(_rows({4: 0.2, 8: 0.05, 16: 0.0}, 16), 1e-2)
    assert best is None and why.startswith("not converged over the values tried")
    # one failed value leaves two: too few again
    rows = _rows({4: None, 8: 1e-3, 16: 0.0}, 16)
    rows[0].status = "solver failure"
    assert recommend(rows, 1e-2)[0] is None
    res = ConvergenceResult(rows, {}, 1e-2, verdicts={"h": recommend(rows, 1e-2)[1]})
    text = recommendation_text(res)
    assert "- h: **no recommendation** — too few values to judge" in text


# --------------------------------------------------------------------------- SDOF study

@pytest.fixture(scope="module")
def sdof_study(tmp_path_factory):
    base = tmp_path_factory.mktemp("conv")
    res = run_convergence(SDOF, base / "api", knobs={"harmonics": HARMONICS},
                          only=["harmonics"], tol=1e-2, cache_dir=base / "cache")
    return base, res


def test_sdof_table(sdof_study):
    base, res = sdof_study
    out = base / "api"
    for name in ("convergence.csv", "convergence.md", "pareto.png"):
        assert (out / name).stat().st_size > 0
    with open(out / "convergence.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert [(r["knob"], int(r["value"])) for r in rows] == [("harmonics", h) for h in HARMONICS]
    for col in ("seconds", "curve_err", "grazing_rel_err", "grazing_fig11", "max_err",
                "within_tol", "recommended"):
        assert col in rows[0]
    assert rows[0]["rom_freq_err"] == "" and rows[0]["housing_err"] == ""   # lumped
    ref = [r for r in rows if r["reference"] == "1"]
    assert len(ref) == 1 and ref[0]["value"] == "16"
    assert float(ref[0]["curve_err"]) == 0.0 and float(ref[0]["max_err"]) == 0.0
    md = (out / "convergence.md").read_text()
    assert md.count("| harmonics |") == len(HARMONICS) and "Recommendation" in md


def test_sdof_errors_decrease_with_harmonics(sdof_study):
    _, res = sdof_study
    e = {r.setting.value: r for r in res.rows}
    # the reference's five grazings (docs/scenes.md) are found by every setting
    assert len(e[16].grazing.pairs) == 5
    for h in HARMONICS:
        assert e[h].grazing.unmatched == 0
        assert e[h].grazing.fig11 == 5          # all within ±1 % (Fig. 11)
    c = [e[h].curve_err for h in HARMONICS]
    g = [e[h].grazing.max_rel for h in HARMONICS]
    # truncation error falls steeply from 4 to 8 harmonics; from 8 on the curve error
    # is at the comparison floor (sampling near folds, ~1e-3: measured 1.3e-3 at 8)
    assert c[0] > 10 * c[1]
    assert c[1] < 5e-3
    assert g[0] > g[1] >= 0.0 and g[1] < 1e-3
    assert e[4].max_err > 0.05                    # measured 0.16 (near 600 rpm)


def test_sdof_recommendation_is_cheapest_within_tol(sdof_study):
    _, res = sdof_study
    rows = res.rows
    rec = res.recommendation["harmonics"]
    assert rec.recommended and rec.within(res.tol)
    cheaper = [r for r in rows if r.seconds is not None and r.seconds < rec.seconds
               and not r.reference]          # the reference is never recommended
    assert all(not r.within(res.tol) for r in cheaper)
    assert recommend(rows, res.tol) == (rec, "within tolerance")
    # a tolerance no setting but the reference meets: no recommendation (the reference is
    # unchecked), and the verdict says so
    best, why = recommend(rows, 1e-12)
    assert best is None and "not converged" in why and "harmonics = 16" in why


def test_sdof_cli(sdof_study):
    base, _ = sdof_study
    out = base / "cli"
    p = subprocess.run([sys.executable, "-m", "study", "convergence", str(SDOF), "--out",
                        str(out), "--cache", str(base / "cache"), "--no-progress",
                        "--set", "hbm.mesh_harmonics=" + ",".join(map(str, HARMONICS))],
                       cwd=ROOT, env=ENV, capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr[-3000:]
    for name in ("convergence.csv", "convergence.md", "pareto.png"):
        assert (out / name).stat().st_size > 0
    stages = [ln for ln in p.stderr.splitlines() if "stage hbm" in ln]
    # the API run above filled the cache: no continuation reruns
    assert len(stages) == len(HARMONICS) and all("cached" in ln for ln in stages), stages
    assert "recommended harmonics" in p.stderr
    bad = subprocess.run([sys.executable, "-m", "study", "convergence", str(SDOF), "--out",
                          str(out), "--only", "n_cm"], cwd=ROOT, env=ENV,
                         capture_output=True, text=True, timeout=60)
    assert bad.returncode == 2 and "n_cm" in bad.stderr


def test_a_stage_cached_by_a_plain_run_keeps_its_cost(tmp_path):
    """The hbm entry of a plain run records its wall time in its manifest, so a later
    study that finds it cached still has its cost (and can recommend it)."""
    import json

    import study
    from study.pipeline.cache import StageCache

    cache = tmp_path / "cache"
    r = study.run(SDOF, tmp_path / "plain", cache_dir=cache,
                  overrides={"hbm.mesh_harmonics": 4, "outputs.plots": [],
                             "outputs.report": False})
    (entry,) = (cache / "hbm").iterdir()
    key = json.loads((entry / "manifest.json").read_text())["key"]
    assert key == r.keys["hbm"]
    seconds = StageCache(cache).seconds("hbm", key)
    # the continuation, not only the writing of its file (the run has no plots)
    assert seconds is not None and 0.5 * r.seconds < seconds <= r.seconds
    res = run_convergence(SDOF, tmp_path / "conv", knobs={"harmonics": [4, 8]},
                          only=["harmonics"], cache_dir=cache)
    row = next(r for r in res.rows if r.setting.value == 4)
    assert row.seconds == pytest.approx(seconds, rel=1e-12)


# --------------------------------------------------------------------------- pump

def test_failed_settings_are_said_with_their_points(tmp_path):
    """Settings whose continuation stops early keep their partial points in the table,
    and convergence.md says why each failed and that the knob has no recommendation
    (the row read 'points 0', the Recommendation section was empty)."""
    from study.pipeline.runs import SolverError

    with pytest.raises(SolverError, match="settings failed: harmonics=4, harmonics=8"):
        run_convergence(SDOF, tmp_path / "o", knobs={"harmonics": [4, 8]}, only=["harmonics"],
                        overrides={"continuation.max_points": 10}, cache_dir=tmp_path / "c")
    md = (tmp_path / "o" / "convergence.md").read_text()
    assert "- harmonics: **no recommendation** — its reference setting failed" in md
    for h in (4, 8):
        assert f"- harmonics={h}: solver failure, 10 points: continuation stopped" in md
        assert f"| harmonics | {h} | n/a | 10 |" in md


@pytest.mark.slow
@pytest.mark.fem
def test_pump_convergence(tmp_path):
    # the study's machinery on the pump, on the sideband set the measurements below were
    # made with (combinations, sideband 1), not the shipped converged contiguous 12/3 set:
    # a contiguous 2/3 set stalls in the 1365 rpm spiral (corrector at 5e-8 > tol 1e-8)
    base = {"hbm.harmonic_set": "combinations", "hbm.sideband_order": 1}
    res = run_convergence(PUMP, tmp_path / "out", knobs={"n_cm": [50, 100],
                                                         "harmonics": [2, 3]},
                          only=["n_cm", "harmonics"], overrides=base,
                          cache_dir=tmp_path / "cache")
    rows = {(r.setting.knob, r.setting.value): r for r in res.rows}
    assert rows[("n_cm", 100)].reference and rows[("harmonics", 3)].reference
    for r in res.rows:
        assert r.rom_freq_err is not None and r.housing_err is not None
    assert rows[("harmonics", 2)].rom_freq_err == 0.0          # same ROM
    assert rows[("n_cm", 50)].rom_freq_err > 0.0
    # measured 2026-11: n_cm=50 moves the coupled modes by 0.7 % and the housing field at
    # 2700 rpm by 0.14 % (L2); 2 mesh harmonics lose the H_3Z resonance and with it the
    # reference's grazing near 938 rpm
    assert rows[("n_cm", 50)].rom_freq_err < 0.05
    assert rows[("n_cm", 50)].housing_err < 1e-2
    assert rows[("harmonics", 2)].grazing.missing
    assert res.recommendation["harmonics"].reference
    assert (tmp_path / "out" / "pareto.png").exists()
