"""The checks of a result and the banner of report.md (study.outputs.checks; issue 39
item 2), and solutions at exactly the requested speed (study.outputs.points)."""
from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import h5py
import numpy as np
import pytest

import study
from study.outputs.checks import (
    TRUNCATION_LIMIT,
    banner_lines,
    highest_excitation_hz,
    rom_limit_hz,
    run_checks,
    truncation_share,
)
from study.outputs.points import point_at, point_at_speed
from study.scene import load_scene

ROOT = Path(__file__).resolve().parents[1]
SDOF = ROOT / "scenes" / "gear-pair-sdof.toml"
#: around the first grazing (1416 rpm) and the fold at 1451 rpm: impacts
RANGE = {"continuation.speed_rpm": [1380.0, 1480.0], "outputs.plots": ["time_series"],
         "outputs.time_series_rpm": [1430.0]}


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    out = tmp_path_factory.mktemp("checks")
    return {h: study.run(SDOF, out / f"h{h}", overrides={**RANGE, "hbm.mesh_harmonics": h})
            for h in (4, 16)}


def test_truncation_share_against_the_fine_signal(runs):
    """The share is the power of the rebuilt mesh load outside the set over its whole
    dynamic power: recomputed here from hbm.time_series on a grid 8× the AFT's (the check
    uses 4×; the two agree to 0.12 % of the share: the grid is fine enough)."""
    from hbm import time_series

    r = runs[4]
    i = int(np.argmax(r.branch.element(0).mesh_load_std))
    pt = point_at(r, i)
    share = truncation_share(r.problem, pt)
    ts = time_series(r.problem, pt, samples_per_period=8 * r.problem.harmonics.n_time)
    c = np.fft.rfft(ts.load) / ts.load.size
    k = np.arange(c.size)
    kept = np.isin(k, r.problem.harmonics.indices)
    ref = np.sum(np.abs(c[(k >= 1) & ~kept]) ** 2) / np.sum(np.abs(c[k >= 1]) ** 2)
    assert share == pytest.approx(ref, rel=3e-3)
    assert share > 5e-3          # 4 mesh harmonics miss the impacts' higher harmonics
    # with 16 mesh harmonics the same speed keeps all but a trace
    r16 = runs[16]
    j = int(np.argmin(np.abs(r16.branch.rpm - r.branch.rpm[i])))
    assert truncation_share(r16.problem, point_at(r16, j)) < 1e-3


def test_checks_and_banner_of_a_truncated_run(runs):
    c4 = {c.name: c for c in runs[4].checks}
    c16 = {c.name: c for c in runs[16].checks}
    assert c4["harmonic_truncation"].value > TRUNCATION_LIMIT
    assert not c4["harmonic_truncation"].passed
    assert c16["harmonic_truncation"].passed and c16["harmonic_truncation"].value < 1e-3
    assert c16["residual"].passed and c16["stability"].passed and c16["inputs"].passed
    # peak load over static load, the dynamic-to-static post-check (< 10 here)
    br = runs[16].branch
    ratio = np.max(br.element(0).mesh_load_max) / runs[16].scene.static_load
    assert c16["dynamic_ratio"].value == pytest.approx(ratio) and ratio < 10
    report4 = (runs[4].out / "report.md").read_text().splitlines()
    assert report4[2].startswith("> **⚠ This result fails")
    assert any(line.startswith("> - `harmonic_truncation`:") for line in report4[:8])
    report16 = (runs[16].out / "report.md").read_text()
    assert "⚠" not in report16 and "## Checks" in report16
    with h5py.File(runs[4].results, "r") as f:
        g = f["checks"]
        assert not g.attrs["harmonic_truncation_passed"]
        assert g.attrs["harmonic_truncation_value"] == pytest.approx(
            c4["harmonic_truncation"].value)
        assert g.attrs["n_failed"] == sum(not c.passed for c in runs[4].checks)


def test_time_series_at_exactly_the_requested_speed(runs):
    r = runs[16]
    uses = [u for u in r.speed_uses if u.what == "time series and spectrum"]
    assert [u.requested for u in uses] == [1430.0]
    u = uses[0]
    assert u.how == "solved" and u.used == 1430.0 and u.start != 1430.0
    assert (r.out / "time_series_1430rpm.png").exists()
    # the solved point lies on the branch: its std between the neighbours'
    _, pt, _ = point_at_speed(r, 1430.0, "test")
    from hbm import point_stats

    std = point_stats(r.problem, pt)[0]["mesh_load_std"]
    br = r.branch
    near = np.argsort(np.abs(br.rpm - 1430.0))[:2]
    lo, hi = sorted(br.element(0).mesh_load_std[near])
    assert lo - 1e-6 * hi <= std <= hi + 1e-6 * hi
    assert pt.residual < r.scene.continuation.tolerance


def test_failed_solve_falls_back_and_is_flagged(runs, monkeypatch):
    from hbm import ConvergenceError

    r = runs[16]

    def fail(*a, **k):
        raise ConvergenceError("no convergence (test)")
    monkeypatch.setattr(r.problem, "solve", fail)
    r.speed_uses.clear()
    i, pt, use = point_at_speed(r, 1430.0, "housing field")
    assert not use.exact and use.used == pt.rpm == r.branch.rpm[i] != 1430.0
    chk = {c.name: c for c in run_checks(r)}["speeds"]
    assert not chk.passed and "**shown at" in chk.text
    assert any("`speeds`" in line for line in banner_lines(run_checks(r)))
    r.speed_uses.clear()


def test_rom_validity_check_against_the_excitation():
    from study.outputs.checks import _rom_check

    sc = load_scene(ROOT / "scenes" / "pump.toml")
    f, label = highest_excitation_hz(sc)
    assert f == pytest.approx(3 * 76 * 7000 / 60) and label == "3 Z at 7000 rpm"
    val = SimpleNamespace(full_hz=np.array([100.0, 3997.0, 4100.0]), validity_hz=3997.0,
                          tol=1e-3, relative_error=np.array([1e-5, 1e-4, 2e-3]))
    res = SimpleNamespace(rom=SimpleNamespace(validation=val), scene=sc)
    assert rom_limit_hz(res.rom) == 3997.0 and rom_limit_hz(None) is None
    c = _rom_check(res)
    assert not c.passed and c.value == 3997.0 and c.limit == pytest.approx(26600.0)
    assert "does not cover" in c.text and "raise `rom.cutoff_factor`" in c.text
    # every checked mode passes: the check stops at its last mode, raise n_check
    res.rom.validation = SimpleNamespace(full_hz=np.array([100.0, 6903.0]), validity_hz=6903.0,
                                         tol=1e-3, relative_error=np.array([1e-5, 7e-4]))
    assert "raise it" in _rom_check(res).text and "`rom.n_check` unset" in _rom_check(res).text
    res.rom.validation = SimpleNamespace(full_hz=np.array([]), validity_hz=0.0, tol=1e-3,
                                         relative_error=np.array([]))
    assert not _rom_check(res).passed and "not checked" in _rom_check(res).text
    res.rom.validation = SimpleNamespace(full_hz=np.array([3e4]), validity_hz=3e4, tol=1e-3,
                                         relative_error=np.array([1e-4]))
    assert _rom_check(res).passed


def test_highest_excitation_counts_train_shaft_orders():
    """A gearbox's top excitation frequency: the highest mesh harmonic, unless an
    ``[[external.aero]]`` order of some shaft lies higher (order k of shaft s at
    k ρ_s times the drive speed)."""
    import tomllib

    from study.scene import scene_from_dict

    path = ROOT / "scenes" / "two-stage-gearbox-demo.toml"
    raw = tomllib.loads(path.read_text())
    f, label = highest_excitation_hz(scene_from_dict(raw, "demo"))
    # 3 harmonics of stage 1's mesh frequency, 23 teeth on the input shaft, 4000 rpm
    assert f == pytest.approx(3 * 23 * 4000 / 60) and "`stage1`" in label
    raw["external"] = {"aero": [{"shaft": "output", "order": 150, "torque_Nm": [0, 0, 1.0]}]}
    f, _ = highest_excitation_hz(scene_from_dict(raw, "demo"))
    assert f == pytest.approx(3 * 23 * 4000 / 60)      # 150 × 437/4087 × 4000/60 Hz: lower
    raw["external"]["aero"].append({"shaft": "input", "order": 150,
                                    "torque_Nm": [0, 0, 1.0]})
    f, label = highest_excitation_hz(scene_from_dict(raw, "demo"))
    assert f == pytest.approx(150 * 4000 / 60) and label == "order 150 of shaft `input` at " \
        "4000 rpm"


def test_rom_range_follows_the_excitation():
    """Without n_cm and cutoff_Hz the loader keeps every component mode below
    cutoff_factor × the highest excitation frequency and checks every mode up to it;
    given n_cm or cutoff_Hz it keeps them (and still checks up to the excitation)."""
    import tomllib

    from study.scene import scene_from_dict

    raw = tomllib.loads((ROOT / "scenes" / "two-stage-gearbox-demo.toml").read_text())
    raw["rom"] = {}
    r = scene_from_dict(raw, "demo").rom
    f = 3 * 23 * 4000 / 60
    assert r.auto and r.n_cm is None and r.n_check is None
    assert r.cutoff == pytest.approx(3.0 * f) and r.check_hz == pytest.approx(f)
    raw["rom"] = {"cutoff_factor": 2.0}
    assert scene_from_dict(raw, "demo").rom.cutoff == pytest.approx(2.0 * f)
    raw["rom"] = {"n_cm": 40, "n_check": 12}
    r = scene_from_dict(raw, "demo").rom
    assert not r.auto and r.cutoff is None and r.n_cm == 40 and r.n_check == 12
    raw["rom"] = {"cutoff_Hz": 5000.0}
    r = scene_from_dict(raw, "demo").rom
    assert not r.auto and r.cutoff == 5000.0 and r.check_hz == pytest.approx(f)
    assert load_scene(SDOF).rom.check_hz is None        # nothing to reduce


def test_spectrum_stops_at_20_khz_and_shades_beyond_the_rom(runs, monkeypatch, tmp_path):
    import study.plots.point as point_plots

    figs = []
    monkeypatch.setattr(point_plots, "save_figure", lambda fig, path: figs.append(fig) or path)
    r = runs[16]
    _, pt, _ = point_at_speed(r, 1430.0, "test")
    point_plots.spectrum_plot(r.problem, pt, tmp_path / "s.png", rom_valid_hz=2000.0)
    ax = figs[0].axes[0]
    f1 = 1430.0 / 60.0
    # the set reaches 16 Z = order 1216 (29 kHz): the axis stops at 20 kHz
    assert ax.get_xlim()[1] == pytest.approx(20_000.0 / f1)
    band = [p for p in ax.patches if p.get_label() == "ROM not validated above 2000 Hz"][0]
    x, _ = band.get_xy()
    assert x == pytest.approx(2000.0 / f1) and x + band.get_width() == pytest.approx(20_000 / f1)
