"""``geardyn excitations`` on a lumped gear pair with internal and external excitation
(tests/data/gear-pair-excitations.toml): the three case scenes, the linear response
of the constant-stiffness case against a closed-form FRF, grazing counts against the
sign changes of the contact margin rebuilt from results.h5, spans against the grazing
speeds, and refusals."""
from __future__ import annotations

import csv
import math
import os
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from study.scene import SceneError, load_scene

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "tests" / "data" / "gear-pair-excitations.toml"
PY = sys.executable
ENV = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1",
       "PYTHONPATH": str(ROOT)}
CASES = ("internal", "external", "all")


def _geardyn(*args, check=True):
    p = subprocess.run([PY, "-m", "study", *args], cwd=ROOT, env=ENV, capture_output=True,
                       text=True, timeout=600)
    if check and p.returncode != 0:
        raise AssertionError(f"geardyn {args} -> {p.returncode}\n{p.stderr[-3000:]}")
    return p


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("exc") / "run"
    p = _geardyn("excitations", str(SCENE), "--out", str(out), "--no-progress")
    with open(out / "excitations.csv", newline="") as f:
        rows = {r["case"]: r for r in csv.DictReader(f)}
    return out, p, rows


def test_case_scenes():
    from study.studies.excitations import case_scenes

    base = load_scene(SCENE)
    sc = case_scenes(base)
    assert list(sc) == list(CASES)
    assert not sc["internal"].external.present and sc["all"].external == base.external
    assert sc["internal"].mesh_stiffness == base.mesh_stiffness
    assert sc["external"].external == base.external
    assert sc["external"].mesh_stiffness.mean == pytest.approx(base.mesh_stiffness.mean)
    assert all(a == 0 for a in sc["external"].mesh_stiffness.amplitudes)
    te, te0 = sc["external"].transmission_error, base.transmission_error
    assert te.kind == te0.kind and te.mean == pytest.approx(te0.mean)
    assert te.amplitudes == pytest.approx(te0.amplitudes)
    assert te.phases == pytest.approx(te0.phases)
    assert sc["all"].mesh_stiffness == base.mesh_stiffness
    assert sc["all"].transmission_error == base.transmission_error


def test_refuses_scenes_without_both_excitations(tmp_path):
    from study.studies.excitations import case_scenes

    p = _geardyn("excitations", str(ROOT / "scenes" / "gear-pair-sdof.toml"), "--out",
                 str(tmp_path / "o"), check=False)
    assert p.returncode == 2 and "no external excitation" in p.stderr
    assert not (tmp_path / "o" / "excitations.csv").exists()
    sc = load_scene(SCENE, {"mesh_stiffness.amplitudes_N_per_um": [0.0, 0.0, 0.0],
                            "transmission_error.amplitudes_um": [0.0, 0.0, 0.0]})
    with pytest.raises(SceneError, match="no internal excitation"):
        case_scenes(sc)


def test_outputs(run):
    out, p, rows = run
    assert list(rows) == list(CASES)
    for name in ("excitations_forced_response.png", "excitations.md", "paper.md"):
        assert (out / name).stat().st_size > 0
    for c in CASES:
        assert (out / c / "results.h5").exists() and (out / c / "report.md").exists()
        assert rows[c]["complete"] == "True"
    assert "excitation case 'all'" in p.stderr
    # time series at the paper's speeds within the range (1200-1900 rpm: 1700 only)
    assert sorted(f.name for f in out.glob("paper_*rpm.png")) == ["paper_1700rpm.png"]
    assert (out / "paper_1700rpm.png").stat().st_size > 0
    md = (out / "paper.md").read_text()
    assert "![1700 rpm, cf. the paper's Fig. 17](paper_1700rpm.png)" in md


def _linear_std(f, omega):
    """Std of the mesh force of m Δ'' + c Δ' + k̄ (Δ − e − b) = F_s + Σ F_k cos(kΩt + φ_k)
    (permanent contact, constant stiffness), per harmonic in closed form; m_e and c from
    the Table 1 steel disks and ξ (machines/lumped.py, eq. 18), forcing from the scene."""
    sc = load_scene(SCENE)
    rb, rp = sc.gear.base_radius, sc.gear.pitch_radius
    inertia = 0.5 * 7800.0 * math.pi * sc.gear.face_width * rp**4
    m = inertia / (2 * rb**2)
    k = float(f["gear_mesh/stiffness"][0].real)
    c = 2 * sc.damping.modal_ratio * math.sqrt(k * m)
    z = sc.gear.teeth
    forcing = {}  # shaft order -> (force coefficient on Δ, TE coefficient)
    for a in sc.external.aero:
        forcing[a.order] = (m * rb / inertia * a.torque[2] * np.exp(1j * a.phase), 0.0)
    for j, te in zip(f["gear_mesh/te_harmonics"][()], f["gear_mesh/te"][()], strict=True):
        if j > 0:
            forcing[int(j) * z] = (0.0, te)  # loaded STE, constant k: e = q_s − F_s/k̄
    var = 0.0
    for order, (force, e) in forcing.items():
        w = order * omega
        delta = (force + k * e) / (k - m * w**2 + 1j * c * w)
        var += abs(k * (delta - e)) ** 2 / 2
    return math.sqrt(var)


def test_constant_stiffness_case_is_the_linear_response(run):
    out, _, _ = run
    with h5py.File(out / "external" / "results.h5", "r") as f:
        ks = f["gear_mesh/stiffness"][()]
        assert np.all(ks[1:] == 0) and ks[0].real == pytest.approx(220e6)
        contact = f["continuation/contact"][()]
        idx = np.flatnonzero(contact == 0)
        assert idx.size > 10
        std = f["continuation/mesh_load_std"][()]
        om = f["continuation/omega"][()]
        for i in idx[:: max(1, idx.size // 8)]:
            assert std[i] == pytest.approx(_linear_std(f, om[i]), rel=1e-6)


def _margins(f, i, n=4096):
    """min_t (Δ − e − b) and max_t (e − Δ − b) at point i from the file alone (eq. 12)."""
    h = f["continuation/harmonics"][()]
    cf = f["continuation/coefficients"][i]
    z = int(f["gear_mesh/n_teeth"][()])
    step = z // int(f["excitation/harmonics"].attrs["divisor"])
    tau = 2 * np.pi * np.arange(n) / n
    delta = (cf[None, :] * np.exp(1j * np.outer(tau, h))).real.sum(axis=1)

    def mesh_signal(coef, harm):
        return (coef[None, :] * np.exp(1j * np.outer(tau * step, harm))).real.sum(axis=1)

    km = mesh_signal(f["gear_mesh/stiffness"][()], f["gear_mesh/stiffness_harmonics"][()])
    e = mesh_signal(f["gear_mesh/te"][()], f["gear_mesh/te_harmonics"][()])
    e = e - float(f["gear_mesh/static_load"][()]) / km  # loaded STE (eq. 12)
    b = float(f["gear_mesh/backlash"][()])
    return float(np.min(delta - e - b)), float(np.max(e - delta - b))


@pytest.mark.parametrize("case", CASES)
def test_grazings_are_the_sign_changes_of_the_contact_margin(run, case):
    out, _, rows = run
    with h5py.File(out / case / "results.h5", "r") as f:
        n = f["continuation/rpm"].size
        m = np.array([_margins(f, i) for i in range(n)])
        sides = [s.decode() if isinstance(s, bytes) else s for s in f["grazing/side"][()]]
        g = np.sort(f["grazing/rpm"][()])
        rpm = f["continuation/rpm"][()]
    for col, side in ((0, "active"), (1, "reverse")):
        changes = int(np.sum((m[:-1, col] > 0) != (m[1:, col] > 0)))
        assert changes == sides.count(side), (case, side)
    assert sides.count("active") >= 2  # onset and end of the impacts inside the range
    got = [float(x) for x in rows[case]["grazing_rpm"].split(";")]
    assert got == pytest.approx(g, abs=0.051)
    # the impact intervals start and end within one continuation step of a grazing
    ends = [float(x) for iv in rows[case]["impacts_rpm"].split(";") for x in iv.split("-")]
    steps = np.max(np.abs(np.diff(rpm)))
    for x in ends:
        if 1200.0 < x < 1900.0:
            assert np.min(np.abs(g - x)) <= steps + 1e-6, (case, x)


def test_changes_against_internal(run):
    out, _, rows = run
    span = {c: float(rows[c]["span_rpm"]) for c in CASES}
    peak = {c: float(rows[c]["primary_peak_N"]) for c in CASES}
    unstable = {}
    for c in CASES:
        assert float(rows[c]["span_change"]) == pytest.approx(span[c] / span["internal"] - 1)
        assert float(rows[c]["primary_peak_change"]) == pytest.approx(
            peak[c] / peak["internal"] - 1)
        with h5py.File(out / c / "results.h5", "r") as f:
            std = f["continuation/mesh_load_std"][()]
            rpm = f["continuation/rpm"][()]
            stable = f["continuation/stable"][()].astype(bool)
        assert float(rows[c]["max_std_N"]) == pytest.approx(std.max())
        assert float(rows[c]["max_std_rpm"]) == pytest.approx(rpm[np.argmax(std)])
        # flagged unstable exactly when the file's verdict at that point is
        assert bool(rows[c]["max_std_unstable"]) == (not stable[np.argmax(std)])
        unstable[c] = rows[c]["max_std_unstable"]
    md = (out / "excitations.md").read_text()
    for c in CASES:
        line = next(ln for ln in md.splitlines() if ln.startswith(f"| {c}:"))
        assert ("(**unstable**: " in line) == bool(unstable[c]), line
    # the primary peak is the largest std of the internal-only curve
    with h5py.File(out / "internal" / "results.h5", "r") as f:
        std = f["continuation/mesh_load_std"][()]
    assert peak["internal"] == pytest.approx(std.max(), rel=1e-3)
    md = (out / "paper.md").read_text()
    row = next(ln for ln in md.splitlines() if ln.startswith("| primary peak"))
    assert f"{peak['internal']:.1f} → {peak['all']:.1f} N" in row
