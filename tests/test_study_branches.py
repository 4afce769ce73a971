"""The stage ``branches`` of a run (issue 40 item 2): period-2 branches of the SDOF gear
pair written to results.h5 ``/branches``, listed in report.md and drawn on the forced
response; skipped at once without a period doubling or at depth 0; their curves in
curves_branches.csv and their NVH in ``/branches/<name>/nvh`` against independent
projections at the half orders; ``geardyn report`` reads them back; the stage is
cached."""
from __future__ import annotations

import csv
import re
import shutil
from pathlib import Path
from types import SimpleNamespace

import h5py
import numpy as np
import pytest

import study

ROOT = Path(__file__).resolve().parents[1]
SDOF = ROOT / "scenes" / "gear-pair-sdof.toml"
#: the period doubling of the shipped scene near 4055 rpm (docs/hbm.md "Period doubling")
RANGE = {"continuation.speed_rpm": [3700.0, 4500.0],
         "outputs.plots": ["forced_response", "order_maps"], "hbm.mesh_harmonics": 8}
Z = 76


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    return study.run(SDOF, tmp_path_factory.mktemp("branches") / "pd", overrides=RANGE)


def test_period2_branch_is_written_reported_and_drawn(run):
    assert run.stages["branches"] == "ran"
    assert run.secondary and run.secondary[0].period == 2
    s = run.secondary[0]
    with h5py.File(run.results, "r") as f:
        assert list(f["branches"].attrs["names"]) == [x.name for x in run.secondary]
        g = f["branches"][s.name]
        assert g.attrs["parent"] == "main" and g.attrs["period"] == 2
        assert g.attrs["ratio"] == "38"                      # Z/2: the mesh fundamental halved
        np.testing.assert_array_equal(g["continuation/rpm"][()], s.branch.rpm)
        np.testing.assert_array_equal(g["continuation/mesh_load_std"][()],
                                      s.branch.element(0).mesh_load_std)
        assert g["continuation/harmonics"].shape == (2 * 8 + 2,)
        assert abs(g.attrs["doubling_rpm"] - s.doubling.rpm) == 0
        # the main curve is where it was
        assert f["continuation/rpm"].shape == (len(run.branch),)
    text = (run.out / "report.md").read_text()
    assert "## Period doubling" in text and f"| {s.name} | main |" in text
    assert (run.out / "forced_response.png").exists()


def test_stage_skips_without_period_doubling(tmp_path):
    r = study.run(SDOF, tmp_path / "low", overrides={
        "continuation.speed_rpm": [600.0, 900.0], "outputs.plots": [],
        "hbm.mesh_harmonics": 6})
    assert r.stages["branches"].startswith("skipped") and r.secondary == []
    r0 = study.run(SDOF, tmp_path / "off", overrides={
        **RANGE, "outputs.plots": [], "continuation.period_doubling_depth": 0})
    assert r0.stages["branches"].startswith("skipped") and r0.secondary == []
    with h5py.File(r0.results, "r") as f:
        assert "branches" not in f


@pytest.mark.parametrize("order, name", [(38, "Z/2"), (114, "3Z/2"), (75.5, "Z−1/2"),
                                         (76.5, "Z+1/2"), (0.5, "1/2"), (76, "Z"),
                                         (77, "Z+1"), (152, "2Z")])
def test_half_order_labels(order, name):
    from study.outputs.nvh import order_label

    assert order_label(order, 76) == name


# ---------------------------------------------------------------- independent references
def _project(x: np.ndarray, t: np.ndarray, w: float) -> complex:
    """Complex amplitude of the line at ``w`` (rad/s) of the periodic samples ``x(t)`` (``t``
    uniform over whole periods of ``w``): ``(2/N) Σ x e^{-i w t}``, no FFT bins."""
    return complex(2.0 * np.mean(x * np.exp(-1j * w * t)))


def _mesh_rad_s(rpm: float) -> float:
    """The mesh frequency Z Ω (rad/s) from the speed alone."""
    return Z * rpm * np.pi / 30.0


def _signals(s, i):
    from hbm import time_series

    return time_series(s.problem, s.problem.point(s.branch.unknowns[i], s.branch.omega[i]))


def _rows(path: Path) -> list[dict]:
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def test_curves_branches_csv_holds_the_half_orders(run):
    """curves_branches.csv: one row per point of period2_1, its columns equal to
    /branches (speed, std, stable) and /branches/<name>/nvh (Z/2 amplitude), and the half
    orders against projections of the mesh load over two mesh periods: the line at ZΩ/2
    and the RMS of the odd part (f(t) − f(t + T))/2, T = 2π/(ZΩ)."""
    s = run.secondary[0]
    rows = [r for r in _rows(run.out / "curves_branches.csv") if r["branch"] == s.name]
    assert len(rows) == len(s.branch)
    assert {r["period"] for r in rows} == {"2"} and {r["parent"] for r in rows} == {"main"}
    assert {r["fundamental_order"] for r in rows} == {"38"}                  # Z/2
    with h5py.File(run.results, "r") as f:
        g = f["branches"][s.name]
        rpm = g["continuation/rpm"][()]
        std = g["continuation/mesh_load_std"][()]
        stable = g["continuation/stable"][()]
        k = list(g["nvh/harmonics"][()]).index(1)
        assert g["nvh/orders"][k] == 38
        half = g["nvh/mesh_load_amplitude"][:, k]
        assert list(g["nvh/subharmonic"][()]) == [h % 2 == 1 for h in g["nvh/harmonics"][()]]
    np.testing.assert_allclose([float(r["speed_rpm"]) for r in rows], rpm, atol=1e-6)
    np.testing.assert_allclose([float(r["mesh_load_std_N"]) for r in rows], std, rtol=1e-7)
    assert [int(r["stable"]) for r in rows] == [int(bool(x)) for x in stable]
    np.testing.assert_allclose([float(r["fundamental_amplitude_N"]) for r in rows], half,
                               rtol=1e-7, atol=1e-9)
    # the half orders are not small on the branch (it is a period-2 response)
    assert max(half) > 0.05 * max(std)
    for i in (len(s.branch) // 3, int(np.argmax(half))):
        ts = _signals(s, i)
        n = ts.t.size
        assert n % 2 == 0
        w = _mesh_rad_s(s.branch.rpm[i])
        assert ts.t[1] * n == pytest.approx(2 * 2 * np.pi / w, rel=1e-12)   # two mesh periods
        a = abs(_project(ts.load, ts.t, 0.5 * w))
        assert float(rows[i]["fundamental_amplitude_N"]) == pytest.approx(a, rel=1e-6,
                                                                          abs=1e-6)
        odd = 0.5 * (ts.load - np.roll(ts.load, -n // 2))
        rms = np.sqrt(np.mean(odd ** 2))
        # the odd part holds every odd line of the fine grid, the column the set's odd
        # harmonics: equal up to the set's truncation
        assert float(rows[i]["subharmonic_rms_N"]) == pytest.approx(rms, rel=2e-3)
    # a period-1 orbit has no odd part: the check above can fail
    from hbm import time_series

    j = len(run.branch) // 2
    ts1 = time_series(run.problem, run.problem.point(run.branch.unknowns[j],
                                                     run.branch.omega[j]), n_periods=2)
    assert np.max(np.abs(ts1.load - np.roll(ts1.load, -ts1.t.size // 2))) < \
        1e-9 * np.max(np.abs(ts1.load))


def _fake_rom(result, W: np.ndarray):
    """A result with a radiating part whose radiation matrix is ``W`` (n_dof × n_dof):
    the lumped pair's one coordinate (the mesh deflection) radiates through it."""
    rom = SimpleNamespace(radiation={"W": W})
    return SimpleNamespace(problem=result.problem, branch=result.branch, scene=result.scene,
                           rom=rom, secondary=result.secondary)


def _erp_reference(unknowns: np.ndarray, w1: float, a: float, rho: float, c: float):
    """ERP per harmonic of the one-coordinate pair from its unknowns (layout
    ``[x0, Re x1, Im x1, ...]``, harmonic k at ``k w1``): ``½ ρ c (k w1)² a |x̃_k|²``."""
    x = unknowns[1::2] + 1j * unknowns[2::2]
    k = np.arange(1, x.size + 1)
    return 0.5 * rho * c * (k * w1) ** 2 * a * np.abs(x) ** 2


def test_period2_nvh_is_the_linear_housing_recovery(run):
    """The ERP per order of a period-2 point (``secondary_nvh``) against the radiation of
    its harmonics computed here: the deflection's lines projected at kZΩ/2 (the half orders
    at odd k) and ½ρc(kZΩ/2)²a|x̃_k|², for a radiation matrix a = 0.02 m²; the main
    branch's at kZΩ; and the report line of the period-doubling segment from them."""
    from study.outputs.acoustics import power_db
    from study.outputs.branches import erp_lines, secondary_nvh
    from study.outputs.curves import unstable_segments
    from study.outputs.nvh import compute_nvh

    a = 0.02
    fake = _fake_rom(run, np.array([[a]]))
    ac = run.scene.acoustics
    sn = secondary_nvh(fake)
    s = run.secondary[0]
    n = sn[s.name]
    assert list(n.harmonics) == list(range(0, 2 * 8 + 2))
    for i in (5, len(s.branch) // 2, len(s.branch) - 3):
        w = _mesh_rad_s(s.branch.rpm[i])
        ref = _erp_reference(s.branch.unknowns[i], 0.5 * w, a, ac.air_density, ac.sound_speed)
        np.testing.assert_allclose(n.erp[i, 1:], ref, rtol=1e-6, atol=1e-9 * ref.max())
        assert n.erp[i, 0] == 0.0
        # the unknowns' harmonics are the deflection's lines at k ZΩ/2
        ts = _signals(s, i)
        x1 = s.branch.unknowns[i][1] + 1j * s.branch.unknowns[i][2]
        assert _project(ts.delta, ts.t, 0.5 * w) == pytest.approx(x1, rel=1e-6, abs=1e-12)
    main = compute_nvh(SimpleNamespace(problem=run.problem, branch=run.branch,
                                       scene=run.scene, rom=fake.rom))
    w = _mesh_rad_s(run.branch.rpm)
    ref = np.array([_erp_reference(u, wi, a, ac.air_density, ac.sound_speed)
                    for u, wi in zip(run.branch.unknowns, w, strict=True)])
    np.testing.assert_allclose(main.erp[:, 1:], ref, rtol=1e-6, atol=1e-9 * ref.max())
    # the report's comparison over the unstable period-doubling segment
    fake.nvh, fake.secondary_nvh = main, sn
    segs = [u for u in unstable_segments(run.branch.rpm, run.branch.element(0).mesh_load_std,
                                         run.branch.stable, run.branch.floquet_kind)
            if u.kind == "period_doubling"]
    assert segs
    lines = erp_lines(fake, segs)
    assert len(lines) == len(segs)
    u = segs[0]
    tot = power_db(ref.sum(axis=1))
    main_db = float(np.max(tot[u.index[0]:u.index[1] + 1]))
    on = np.flatnonzero((s.branch.rpm >= u.rpm[0]) & (s.branch.rpm <= u.rpm[1])
                        & s.branch.stable.astype(bool))
    p2 = np.array([_erp_reference(s.branch.unknowns[i], 0.5 * _mesh_rad_s(s.branch.rpm[i]),
                                  a, ac.air_density, ac.sound_speed) for i in on])
    j = int(np.argmax(p2.sum(axis=1)))
    half_db = float(power_db(p2[j, 0::2].sum()))     # k = 1, 3, 5, ...: the half orders
    m = re.search(r"radiates up to (-?[\d.]+) dB re 1 pW.*`period2_1` \(period 2, stable at "
                  r"(\d+) of its points there\) up to (-?[\d.]+) dB \(([+-][\d.]+) dB against "
                  r"it\) at ([\d.]+) rpm, (-?[\d.]+) dB of it at the orders of period 2 \(loudest "
                  r"(\S+), ", lines[0])
    assert m, lines[0]
    assert float(m[1]) == pytest.approx(main_db, abs=0.051)
    assert int(m[2]) == on.size
    assert float(m[3]) == pytest.approx(float(power_db(p2[j].sum())), abs=0.051)
    assert float(m[4]) == pytest.approx(float(m[3]) - float(m[1]), abs=0.11)
    assert float(m[5]) == pytest.approx(s.branch.rpm[on[j]], abs=0.051)
    assert float(m[6]) == pytest.approx(half_db, abs=0.051)
    k = 1 + 2 * int(np.argmax(p2[j, 0::2]))
    from study.outputs.nvh import order_label
    assert m[7] == order_label(38 * k, Z)


def test_replay_reads_the_branches_back(run, tmp_path):
    """``geardyn report`` on a copy of the run folder: the secondary branches read back from
    /branches equal the run's, and so do report.md's period-doubling section and unstable
    segments, the attracting levels (order maps ``*_attracting``) and /bifurcation."""
    from study.outputs.branches import attracting_levels
    from study.pipeline.replay import report_from_results

    out = tmp_path / "replay"
    shutil.copytree(run.out, out)
    (out / "report.md").unlink()
    (out / "order_map_mesh_load_attracting.png").unlink()
    with h5py.File(run.results, "r") as f:
        bif = {k: f["bifurcation"][k][()] for k in f["bifurcation"]}
    res = report_from_results(SDOF, out, RANGE, cache=str(tmp_path / "cache"))
    assert [x.name for x in res.secondary] == [x.name for x in run.secondary]
    for a, b in zip(res.secondary, run.secondary, strict=True):
        assert (a.period, a.parent, a.rejoin_rpm == a.rejoin_rpm) == \
            (b.period, b.parent, b.rejoin_rpm == b.rejoin_rpm)
        assert a.problem.harmonics.indices == b.problem.harmonics.indices
        np.testing.assert_array_equal(a.branch.unknowns, b.branch.unknowns)
        np.testing.assert_array_equal(a.branch.stable, b.branch.stable)
        assert a.doubling.rpm == b.doubling.rpm and a.doubling.tau == b.doubling.tau
        np.testing.assert_array_equal(a.doubling.vector, b.doubling.vector)
    assert res.branches_seconds == run.branches_seconds

    def section(text: str) -> str:
        return text.split("## Period doubling")[1].split("\n## ")[0]
    ran, replayed = (run.out / "report.md").read_text(), (out / "report.md").read_text()
    assert section(replayed) == section(ran)
    pd_line = [x for x in ran.splitlines() if "period doubling, a response at half" in x]
    assert pd_line and all(x in replayed for x in pd_line)
    assert "computed: `period2_1`" in pd_line[0]
    la, lb = attracting_levels(run), attracting_levels(res)
    assert la is not None and lb is not None
    for f in ("rpm", "orders", "period", "mesh_load"):
        np.testing.assert_array_equal(getattr(la, f), getattr(lb, f))
    assert 2 in la.period and 38 in la.orders
    assert (out / "order_map_mesh_load_attracting.png").exists()
    with h5py.File(out / "results.h5", "r") as f:
        for k, v in bif.items():
            np.testing.assert_array_equal(f["bifurcation"][k][()], v, err_msg=k)
    # other period-doubling settings: the file's branches are not the scene's
    with pytest.raises(study.SceneError, match="period_doubling"):
        report_from_results(SDOF, out, {**RANGE, "continuation.period_doubling_max_points": 40},
                            cache=str(tmp_path / "cache"))


def _datasets(path: Path, group: str) -> dict:
    out = {}
    with h5py.File(path, "r") as f:
        f[group].visititems(lambda n, o: out.__setitem__(n, o[()])
                            if isinstance(o, h5py.Dataset) else None)
    return out


def test_second_run_reuses_the_cached_branches(run):
    """A second run of the same scene beside the first (same cache) reads the branches
    stage from the cache and writes identical /branches and curves_branches.csv; another
    ``period_doubling_max_points`` is another key and runs the stage again."""
    again = study.run(SDOF, run.out.parent / "again", overrides=RANGE)
    assert again.stages["hbm"] == "cached" and again.stages["branches"] == "cached"
    a, b = _datasets(run.results, "branches"), _datasets(again.results, "branches")
    assert a.keys() == b.keys() and len(a) > 20
    for k in a:
        np.testing.assert_array_equal(a[k], b[k], err_msg=k)
    assert (run.out / "curves_branches.csv").read_text() == \
        (again.out / "curves_branches.csv").read_text()
    assert again.branches_seconds == run.branches_seconds
    other = study.run(SDOF, run.out.parent / "other", overrides={
        **RANGE, "outputs.plots": [], "continuation.period_doubling_max_points": 40})
    assert other.stages["hbm"] == "cached" and other.stages["branches"] == "ran"
    assert sum(len(x.branch) for x in other.secondary) <= 40
