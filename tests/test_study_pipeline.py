"""End-to-end runs of the single-DOF scene: CLI, results.h5 contents checked against an
independent evaluation of the equations from the file alone, lazy FE imports, cache
reuse, corrupted cache entries, kill-and-resume."""
from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from hbm.elements.contact_law import kink_correction

ROOT = Path(__file__).resolve().parents[1]
SDOF = ROOT / "scenes" / "gear-pair-sdof.toml"
PY = sys.executable
ENV = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1",
       "PYTHONPATH": str(ROOT)}


def _geardyn(*args, check=True, timeout=240):
    p = subprocess.run([PY, "-m", "study", *args], cwd=ROOT, env=ENV, capture_output=True,
                       text=True, timeout=timeout)
    if check and p.returncode != 0:
        raise AssertionError(f"geardyn {args} -> {p.returncode}\n{p.stderr[-3000:]}")
    return p


@pytest.fixture(scope="module")
def sdof_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("sdof") / "run"
    t = time.perf_counter()
    p = _geardyn("run", str(SDOF), "--out", str(out), "--no-progress")
    return out, p, time.perf_counter() - t


def test_cli_runs_sdof_in_seconds(sdof_run):
    out, p, seconds = sdof_run
    assert seconds < 90, seconds
    for name in ("results.h5", "forced_response.png", "report.md"):
        assert (out / name).stat().st_size > 0
    assert list(out.glob("time_series_*rpm.png")) and list(out.glob("spectrum_*rpm.png"))
    assert "stage hbm    ran" in p.stderr and "stage mesh   skipped" in p.stderr


def _signals(f, i, n=4096):
    """Δ(t), k_m(t), e(t) over one fundamental period, from the file alone (eq. 12–16)."""
    h = f["continuation/harmonics"][()]
    c = f["continuation/coefficients"][i]
    z = int(f["gear_mesh/n_teeth"][()])
    div = int(f["excitation/harmonics"].attrs["divisor"])
    step = z // div  # harmonic index of mesh harmonic 1
    tau = 2 * np.pi * np.arange(n) / n
    delta = (c[None, :] * np.exp(1j * np.outer(tau, h))).real.sum(axis=1)
    ks = f["gear_mesh/stiffness"][()]
    km = (ks[None, :] * np.exp(1j * np.outer(tau * step, f["gear_mesh/stiffness_harmonics"][()]))
          ).real.sum(axis=1)
    te = f["gear_mesh/te"][()]
    e = (te[None, :] * np.exp(1j * np.outer(tau * step, f["gear_mesh/te_harmonics"][()]))
         ).real.sum(axis=1)
    if f["gear_mesh"].attrs["te_kind"] == "loaded":
        e = e - f["gear_mesh/static_load"][()] / km  # eq. (12)
    return tau, delta, km, e


def test_results_file_contents(sdof_run):
    out, _, _ = sdof_run
    with h5py.File(out / "results.h5", "r") as f:
        c = f["continuation"]
        assert c.attrs["status"] == "completed"
        tol = c.attrs["tolerance"]
        rpm = c["rpm"][()]
        n = rpm.size
        assert n > 50
        assert rpm[0] == pytest.approx(600.0) and rpm[-1] == pytest.approx(4500.0)
        assert np.all(c["residual"][()] < tol)
        assert set(np.unique(c["contact"][()])) == {0, 1, 2}
        assert c["coefficients"].shape == (n, c["harmonics"].size)
        assert c["harmonics"][0] == 0
        assert f["grazing/rpm"].size >= 3
        assert {s.decode() for s in f["grazing/side"][()]} == {"active", "reverse"}
        assert f["excitation/forces"].shape[0] == c["harmonics"].size
        assert "gear-pair-sdof" in f["scene/text"][()].decode()
        assert f["versions"].attrs["numpy"] == np.__version__
        b = f["gear_mesh/backlash"][()]
        assert b == pytest.approx(40e-6)
        # independent recomputation of the mesh-load std and of the contact class
        b = f["gear_mesh/backlash"][()]
        for i in np.linspace(0, n - 1, 15).astype(int):
            _, delta, km, e = _signals(f, i)
            p = delta - e
            fl = km * (np.where(p > b, p - b, 0) + np.where(p < -b, p + b, 0))  # eq. (13)
            assert np.std(fl) == pytest.approx(c["mesh_load_std"][i], rel=2e-3, abs=1e-6)
            cls = 0 if np.all(p > b) else (2 if np.any(p < -b) else 1)
            if min(abs(c["margin_active"][i]), abs(c["margin_reverse"][i])) > 1e-3 * b:
                assert cls == c["contact"][i]


def test_residual_rebuilt_from_file(sdof_run):
    """Harmonic balance of m Δ'' + c Δ' + f_LoA = F from the file's M, C, forcing,
    mesh data and coefficients alone, with the file's AFT sampling (and its kink
    correction, attribute ``aft``): the residual is at the solver's tolerance; with 32x
    finer sampling it stays below 1e-4."""
    out, _, _ = sdof_run
    with h5py.File(out / "results.h5", "r") as f:
        m, cd = f["system/M"][0, 0], f["system/C"][0, 0]
        h = f["continuation/harmonics"][()]
        force = f["excitation/forces"][()][:, 0]
        div = int(f["excitation/harmonics"].attrs["divisor"])
        n_aft = int(f["excitation/harmonics"].attrs["n_time"])
        corrected = f["excitation/harmonics"].attrs["aft"] == "corrected"
        b = f["gear_mesh/backlash"][()]
        rpm = f["continuation/rpm"][()]
        for i in np.linspace(0, rpm.size - 1, 12).astype(int):
            w0 = div * rpm[i] * 2 * np.pi / 60
            c = f["continuation/coefficients"][i]
            for n, rel in ((n_aft, 1e-7), (32 * n_aft, 1e-4)):
                _, delta, km, e = _signals(f, i, n)
                p = delta - e
                fl = km * (np.where(p > b, p - b, 0) + np.where(p < -b, p + b, 0))
                if corrected:            # the file's AFT: samples with the T.13a term
                    fl = fl + kink_correction(p, km, b).values
                fk = np.fft.fft(fl)[h] / n * np.where(h == 0, 1, 2)
                r = (-(h * w0) ** 2 * m + 1j * h * w0 * cd) * c + fk - force
                scale = np.abs(fk).max()
                assert np.abs(r).max() < rel * scale, (i, n, np.abs(r).max() / scale)


def test_lumped_run_never_imports_fe_stack(tmp_path):
    code = (
        "import sys, study\n"
        f"r = study.run({str(SDOF)!r}, {str(tmp_path / 'o')!r}, "
        "overrides={'continuation.speed_rpm': [600.0, 1500.0], 'outputs.plots': []})\n"
        "assert r.branch.status == 'completed'\n"
        "bad = [m for m in ('dolfinx', 'gmsh', 'petsc4py', 'slepc4py', 'mpi4py') "
        "if m in sys.modules]\n"
        "print('FE_MODULES', bad)\n")
    p = subprocess.run([PY, "-c", code], cwd=ROOT, env=ENV, capture_output=True, text=True,
                       timeout=120)
    assert p.returncode == 0, p.stderr[-2000:]
    assert "FE_MODULES []" in p.stdout


def test_progress_bars_only_on_a_terminal(tmp_path, monkeypatch):
    import argparse

    from study.cli import _progress

    p = _geardyn("run", str(SDOF), "--out", str(tmp_path / "o"), "--set",
                 "continuation.speed_rpm=[600,1500]", "--set", "outputs.plots=[]")
    assert "continuation" in p.stderr          # the log lines are there …
    assert "%|" not in p.stderr and "\r" not in p.stderr   # … but no bar in a pipe
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)
    args = argparse.Namespace(no_progress=False, quiet=False)
    assert _progress(args)
    assert not _progress(argparse.Namespace(no_progress=False, quiet=True))
    assert not _progress(argparse.Namespace(no_progress=True, quiet=False))


def _short(**extra):
    ov = {"continuation.speed_rpm": [600.0, 1600.0], "outputs.plots": ["forced_response"]}
    ov.update(extra)
    return ov



def test_stage_keys_hash_modules_that_exist():
    """Every module a stage key hashes exists (a moved module would silently drop out of
    the key otherwise), and a name that is no module is refused."""
    from study.pipeline.cache import source_hash

    with pytest.raises(ModuleNotFoundError, match="study.no_such_module"):
        source_hash("hbm", "study.no_such_module")
    root = Path(__file__).resolve().parents[1]
    text = (root / "study" / "pipeline" / "stages.py").read_text()
    names = {n for call in re.findall(r"source_hash\(([^)]*)\)", text)
             for n in re.findall(r'"([\w.]+)"', call)}
    assert names >= {"hbm", "study.pipeline.model", "study.outputs.results"}
    for name in sorted(names):    # found without importing them (fem.post loads dolfinx)
        path = root.joinpath(*name.split("."))
        assert path.with_suffix(".py").is_file() or (path / "__init__.py").is_file(), name

def test_cache_reuse_and_rebuild(tmp_path, caplog):
    import logging

    import study

    caplog.set_level(logging.INFO)
    cache = tmp_path / "cache"
    r1 = study.run(SDOF, tmp_path / "a", overrides=_short(), cache_dir=cache)
    assert r1.stages["hbm"] == "ran"
    # only an output option changed: the continuation comes from the cache, same curve
    r2 = study.run(SDOF, tmp_path / "b", overrides=_short(**{"outputs.report": False}),
                   cache_dir=cache)
    assert r2.stages["hbm"] == "cached"
    np.testing.assert_array_equal(r1.branch.rpm, r2.branch.rpm)
    np.testing.assert_array_equal(r1.branch.unknowns, r2.branch.unknowns)
    assert "stage hbm    cached" in caplog.text
    # torque changed: the hbm stage reruns, and its curve differs
    r3 = study.run(SDOF, tmp_path / "c", overrides=_short(**{"load.torque_Nm": 120.0}),
                   cache_dir=cache)
    assert r3.stages["hbm"] == "ran"
    assert r3.keys["hbm"] != r1.keys["hbm"]
    assert r3.keys["linear"] == r1.keys["linear"]  # the linear model's key is untouched
    # a corrupted entry is detected (checksum) and rebuilt, not trusted
    entry = next((cache / "hbm").glob(r1.keys["hbm"][:24]))
    data = bytearray((entry / "branch.h5").read_bytes())
    data[len(data) // 2] ^= 0xFF
    (entry / "branch.h5").write_bytes(bytes(data))
    caplog.clear()
    r4 = study.run(SDOF, tmp_path / "d", overrides=_short(), cache_dir=cache)
    assert r4.stages["hbm"] == "ran"
    assert "corrupted" in caplog.text
    np.testing.assert_allclose(r4.branch.rpm, r1.branch.rpm, rtol=0, atol=0)
    # a foreign manifest (other format) is not trusted either
    man = json.loads((entry / "manifest.json").read_text())
    man["format"] = 999
    (entry / "manifest.json").write_text(json.dumps(man))
    r5 = study.run(SDOF, tmp_path / "e", overrides=_short(), cache_dir=cache)
    assert r5.stages["hbm"] == "ran"


_KILLABLE = """
import sys, time
import study.outputs.results as R
orig = R.Checkpointer.__call__
def slow(self, branch):
    n = self.n_written
    orig(self, branch)
    if self.n_written > n:
        print('CHECKPOINT', len(branch), flush=True)
        time.sleep(0.3)
R.Checkpointer.__call__ = slow
from study.cli import main
sys.exit(main(sys.argv[1:]))
"""


def test_kill_and_resume_gives_the_same_curve(tmp_path):
    sets = ["--set", "continuation.speed_rpm=[600,2300]", "--set",
            "continuation.checkpoint_every=25", "--set", "outputs.plots=[]", "--no-progress"]
    ref = tmp_path / "ref"
    _geardyn("run", str(SDOF), "--out", str(ref), *sets)
    out = tmp_path / "killed"
    proc = subprocess.Popen([PY, "-c", _KILLABLE, "run", str(SDOF), "--out", str(out),
                             "--cache", str(tmp_path / "c2"), *sets],
                            cwd=ROOT, env=ENV, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    saved = 0
    for line in proc.stdout:
        if line.startswith("CHECKPOINT"):
            saved = int(line.split()[1])
            if saved >= 50:
                break
    proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=30)
    assert saved >= 50
    with h5py.File(out / "results.h5", "r") as f:
        assert f["continuation"].attrs["status"] == "running"
        n_saved = f["continuation/rpm"].size
    assert n_saved == saved
    p = _geardyn("run", str(SDOF), "--out", str(out), "--cache", str(tmp_path / "c2"),
                 "--resume", *sets)
    assert "resuming from point" in p.stderr and "ran: hbm (resumed), export" in p.stderr
    with h5py.File(ref / "results.h5", "r") as a, h5py.File(out / "results.h5", "r") as b:
        assert b["continuation"].attrs["status"] == "completed"
        for k in ("rpm", "mesh_load_std", "contact"):
            np.testing.assert_allclose(b["continuation"][k][()], a["continuation"][k][()],
                                       rtol=1e-9, atol=0)
        np.testing.assert_allclose(b["grazing/rpm"][()], a["grazing/rpm"][()], rtol=1e-9)
    # the resumed curve is the uninterrupted one, so it is cached, but its cost is unknown
    # (a convergence study must not take the resumed part's seconds for the whole)
    man = [json.loads(m.read_text()) for m in (tmp_path / "c2" / "hbm").glob("*/manifest.json")]
    assert len(man) == 1 and man[0]["seconds"] is None
    p = _geardyn("run", str(SDOF), "--out", str(tmp_path / "again"), "--cache",
                 str(tmp_path / "c2"), *sets)
    assert "stage hbm    cached" in p.stderr


def test_exit_codes(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(SDOF.read_text().replace("backlash_um = 40.0", "backlash_um = -3"))
    p = _geardyn("run", str(bad), "--out", str(tmp_path / "o"), check=False)
    assert p.returncode == 2
    assert "gear.backlash_um = -3" in p.stderr
    p = _geardyn("run", str(SDOF), "--out", str(tmp_path / "o"), "--set", "gear.backlsh_um=3",
                 check=False)
    assert p.returncode == 2 and "did you mean 'backlash_um'" in p.stderr
    p = _geardyn("mesh", str(SDOF), "--out", str(tmp_path / "o"), check=False)
    assert p.returncode == 2
    p = _geardyn("run", str(SDOF), "--out", str(tmp_path / "o"), "--knob", "n_cm=5",
                 check=False)
    assert p.returncode == 2 and "--knob, --only and --tol are options of `geardyn " \
        "convergence` only" in p.stderr
    # a continuation that cannot reach the end (too few points) is a solver failure
    p = _geardyn("run", str(SDOF), "--out", str(tmp_path / "m"), "--set",
                 "continuation.max_points=5", "--no-progress", check=False)
    assert p.returncode == 3
    with h5py.File(tmp_path / "m" / "results.h5", "r") as f:
        assert f["continuation/rpm"].size == 5
        assert f["continuation"].attrs["status"] == "max_points"


def test_lumped_external_torque_matches_linear_frf(tmp_path):
    """Constant mesh stiffness, no TE, an aerodynamic torque on the input gear at shaft
    order 2: in permanent contact the order-2 coefficient of Δ equals the linear FRF
    m_e (r_b/I1) A / (k̄ − m_e ω² + i c ω), ω = 2Ω (machines/lumped.py)."""
    import study
    from machines.lumped import equivalent_mass, gear_inertias

    ov = {"mesh_stiffness.amplitudes_N_per_um": [], "mesh_stiffness.phases_deg": [],
          "transmission_error.amplitudes_um": [], "transmission_error.phases_deg": [],
          "external.aero": [{"shaft": "in", "order": 2, "torque_Nm": [0.0, 0.0, 0.4],
                             "phase_deg": 30.0}],
          "hbm.mesh_harmonics": 1, "hbm.sideband_order": 1,
          "continuation.speed_rpm": [600.0, 700.0], "outputs.plots": []}
    r = study.run(SDOF, tmp_path / "o", overrides=ov, cache_dir=tmp_path / "c")
    sc, br = r.scene, r.branch
    assert r.problem.harmonics.fundamental == "shaft"
    assert np.all(br.element(0).contact == 0)
    m = equivalent_mass(sc)
    i1, _ = gear_inertias(sc)
    k = sc.mesh_stiffness.mean
    c = 2 * sc.damping.modal_ratio * np.sqrt(k * m)
    h = list(br.harmonics).index(2)
    for j in (0, len(br) // 2, len(br) - 1):
        w = 2 * br.omega[j]
        expect = m * sc.gear.base_radius / i1 * 0.4 * np.exp(1j * np.pi / 6) / (
            k - m * w**2 + 1j * c * w)
        assert br.element(0).coefficients[j, h] == pytest.approx(expect, rel=1e-9)
    # mean: b + F_s/k̄ + mean of e = q_s − F_s/k̄ (loaded STE, eq. 12) = b + mean q_s
    assert sc.transmission_error.kind == "loaded"
    assert br.element(0).coefficients[0, 0].real == pytest.approx(
        sc.gear.backlash + sc.transmission_error.mean, rel=1e-9)


def test_set_variants_overlay_and_table(tmp_path):
    out = tmp_path / "study"
    p = _geardyn("run", str(SDOF), "--out", str(out), "--set", "load.torque_Nm=120,150",
                 "--set", "continuation.speed_rpm=[600,1600]", "--set", "outputs.plots=[]",
                 "--no-progress")
    assert (out / "variants_forced_response.png").stat().st_size > 0
    rows = [ln for ln in (out / "variants.md").read_text().splitlines()
            if ln.startswith("| torque_Nm=")]
    assert len(rows) == 2
    # each variant has its own results; the grazing onset moves with the load
    g = []
    for sub in sorted(out.iterdir()):
        if sub.is_dir() and (sub / "results.h5").exists():
            with h5py.File(sub / "results.h5", "r") as f:
                g.append((float(f["gear_mesh/torque"][()]), float(f["grazing/rpm"][0])))
    assert [t for t, _ in sorted(g)] == [120.0, 150.0]
    assert sorted(g)[0][1] != sorted(g)[1][1]
    assert "variant load.torque_Nm=150" in p.stderr


def test_report_from_existing_results(sdof_run):
    out, _, _ = sdof_run
    (out / "report.md").unlink()
    for png in out.glob("*.png"):
        png.unlink()
    p = _geardyn("report", str(SDOF), "--out", str(out), "-q")
    assert p.returncode == 0
    text = (out / "report.md").read_text()
    with h5py.File(out / "results.h5", "r") as f:
        n = f["continuation/rpm"].size
        g = f["grazing/rpm"][()]
        rpm, std = f["continuation/rpm"][()], f["continuation/mesh_load_std"][()]
        stable, kind = f["continuation/stable"][()], f["continuation/floquet_kind"][()]
    assert f"{n} points" in text
    for r in g:
        assert f"{r:.2f}" in text
    # unstable segments: runs of unstable points of one kind, found here by diff
    bad = ~stable.astype(bool)
    key = np.where(bad, kind, -1)
    starts = np.flatnonzero(bad & np.r_[True, key[1:] != key[:-1]])
    assert starts.size, "the SDOF curve has jumps: their middle parts are unstable"
    names = {1: "fold", 2: "period doubling", 3: "Neimark–Sacker"}
    for i in starts:
        j = i
        while j + 1 < n and key[j + 1] == key[i]:
            j += 1
        r = rpm[i:j + 1]
        pts = f"{j - i + 1} point" + ("" if i == j else "s")
        assert (f"  - {r.min():.1f}–{r.max():.1f} rpm, {pts}, std up to "
                f"{std[i:j + 1].max():.4g} N: {names[int(kind[i])]}, ") in text
    assert (out / "forced_response.png").exists()


def test_nvh_group_and_curves_csv(sdof_run):
    """/nvh mesh-load amplitudes and peak-to-peak against the file's own equations
    (eq. 13 sampled 32x finer than the AFT grid); curves.csv has one row per point."""
    import csv

    out, _, _ = sdof_run
    with h5py.File(out / "results.h5", "r") as f:
        g = f["nvh"]
        assert "erp" not in g  # lumped scene: no housing
        h = f["continuation/harmonics"][()]
        np.testing.assert_array_equal(g["harmonics"][()], h)
        div = int(f["excitation/harmonics"].attrs["divisor"])
        np.testing.assert_array_equal(g["orders"][()], h * div)
        amp, ptp = g["mesh_load_amplitude"][()], g["mesh_load_ptp"][()]
        n_aft = int(f["excitation/harmonics"].attrs["n_time"])
        b = f["gear_mesh/backlash"][()]
        n = f["continuation/rpm"].size
        for i in np.linspace(0, n - 1, 8).astype(int):
            m = 32 * n_aft
            _, delta, km, e = _signals(f, i, m)
            p = delta - e
            fl = km * (np.where(p > b, p - b, 0) + np.where(p < -b, p + b, 0))
            fk = np.abs(np.fft.rfft(fl)[h]) / m * np.where(h == 0, 1, 2)
            np.testing.assert_allclose(amp[i], fk, atol=2e-3 * fk.max())
            assert ptp[i] == pytest.approx(np.ptp(fl), rel=2e-2)
        std = f["continuation/mesh_load_std"][()]
        contact = f["continuation/contact"][()]
    rows = list(csv.DictReader((out / "curves.csv").open()))
    assert len(rows) == n
    for i in (0, n // 2, n - 1):
        assert float(rows[i]["mesh_load_std_N"]) == pytest.approx(std[i], rel=1e-6)
        assert int(rows[i]["contact_class"]) == contact[i]
        assert rows[i]["erp_dB_re_1pW"] == ""
        assert float(rows[i]["mesh_load_peak_to_peak_N"]) == pytest.approx(ptp[i], rel=1e-6)


def test_stopped_continuation_keeps_curves_csv(tmp_path):
    """A continuation stopped early (max_points) exits with code 3 and still leaves
    results.h5 and curves.csv with the points so far."""
    import csv

    out = tmp_path / "stopped"
    p = _geardyn("run", str(SDOF), "--out", str(out), "--no-progress",
                 "--set", "continuation.max_points=6", "--set", "outputs.plots=[]", check=False)
    assert p.returncode == 3, p.stderr[-2000:]
    with h5py.File(out / "results.h5", "r") as f:
        n = f["continuation/rpm"].size
        std = f["continuation/mesh_load_std"][()]
    rows = list(csv.DictReader((out / "curves.csv").open()))
    assert len(rows) == n > 0
    assert float(rows[-1]["mesh_load_std_N"]) == pytest.approx(std[-1], rel=1e-6)


def test_incomplete_curve_is_plotted_and_resumed_after_a_step_change(tmp_path):
    """A run that stops early keeps and plots its points (report says why); --resume with
    other continuation steps/tolerance continues from its last point; another physics
    input starts over."""
    out = tmp_path / "r"
    base = ["--set", "continuation.speed_rpm=[600,2300]", "--set", "outputs.plots="
            "['forced_response']", "--no-progress", "--cache", str(tmp_path / "c")]
    p = _geardyn("run", str(SDOF), "--out", str(out), *base, "--set",
                 "continuation.max_points=30", check=False)
    assert p.returncode == 3 and "continues from its last point" in p.stderr
    assert (out / "forced_response.png").stat().st_size > 0
    report = (out / "report.md").read_text()
    assert "**incomplete curve**" in report and "max_points = 30" in report
    with h5py.File(out / "results.h5", "r") as f:
        first = f["continuation/rpm"][()]
    assert first.size == 30
    p = _geardyn("run", str(SDOF), "--out", str(out), *base, "--resume", "--set",
                 "continuation.step_rpm=4", "--set", "continuation.tolerance=1e-9")
    assert "resuming from point 30" in p.stderr, p.stderr[-2000:]
    with h5py.File(out / "results.h5", "r") as f:
        rpm = f["continuation/rpm"][()]
        assert f["continuation"].attrs["status"] == "completed"
        assert np.max(f["continuation/residual"][()]) < 1e-9
    np.testing.assert_array_equal(rpm[:30], first)
    assert rpm[-1] == pytest.approx(2300.0)
    assert "incomplete" not in (out / "report.md").read_text()
    # steps changed on resume: this call's step is used, and the curve is not cached under
    # the new settings (a fresh run with them traces other points)
    assert "going on with continuation.step_rpm = 4" in p.stderr
    fresh = _geardyn("run", str(SDOF), "--out", str(tmp_path / "fresh"), *base, "--set",
                     "continuation.step_rpm=4", "--set", "continuation.tolerance=1e-9")
    assert "stage hbm    ran" in fresh.stderr, fresh.stderr[-2000:]
    # a changed physical input is not resumed
    p = _geardyn("run", str(SDOF), "--out", str(out), *base, "--resume", "--set",
                 "load.torque_Nm=3.0")
    assert "not resuming from it" in p.stderr and "resuming from point" not in p.stderr


def test_report_without_matching_results_names_the_cause(sdof_run, tmp_path):
    """`geardyn report` on a folder without results.h5 is a file error (exit 5); on
    results of other inputs it is invalid input (exit 2), not a solver failure."""
    out, _, _ = sdof_run
    p = _geardyn("report", str(SDOF), "--out", str(tmp_path / "empty"), check=False)
    assert p.returncode == 5, p.stderr[-2000:]
    assert "results.h5: no such file; run `geardyn run`" in p.stderr
    p = _geardyn("report", str(SDOF), "--out", str(out), "--set", "damping.modal_ratio=0.04",
                 check=False)
    assert p.returncode == 2, p.stderr[-2000:]
    assert "holds no continuation of this scene's inputs" in p.stderr
    assert "not resuming" not in p.stderr          # a report resumes nothing
    assert "Traceback" not in p.stderr
