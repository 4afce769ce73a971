"""benchmarks/calibrate_pump.py (issue 14 item 1): the calibration iteration and the
error measure, on a synthetic resonance model with a known root (fast, no FE)."""
from __future__ import annotations

import math

import pytest

from benchmarks import calibrate_pump as cp


def _model(amps, linear=(1090.0, 1620.0, 3250.0), soft=(0.01, 0.03, 0.05)):
    """Peak k (H_3Z, H_2Z, H_Z) softens with its own amplitude: f_k = lin_k (1 − c_k a/a0)
    with a the amplitude of that harmonic, a0 = 0.1 µm."""
    a = {0: amps[2], 1: amps[1], 2: amps[0]}
    return {"status": "completed",
            "resonances_rpm": [linear[k] * (1 - soft[k] * a[k] / 0.1) for k in range(3)]}


def _root(linear=(1090.0, 1620.0, 3250.0), soft=(0.01, 0.03, 0.05)):
    """Amplitudes (H_Z, H_2Z, H_3Z) that put every peak on its target, closed form."""
    a = [0.1 * (1 - t / f) / c for t, f, c in zip(cp.TARGETS, linear, soft, strict=True)]
    return a[2], a[1], a[0]


def test_errors_are_relative_to_the_paper_and_need_three_peaks():
    ev = {"status": "completed", "resonances_rpm": [1070.0 * 1.01, 1570.0, 3000.0 * 0.97]}
    assert cp.errors(ev) == pytest.approx([0.01, 0.0, -0.03], abs=1e-12)
    assert cp.errors({"status": "completed", "resonances_rpm": [1070.0, 1570.0]}) is None
    assert cp.errors({"status": "stopped: left_range",
                      "resonances_rpm": [1070.0, 1570.0, 3000.0]}) is None


def test_calibration_reaches_the_closed_form_root_of_a_softening_model():
    root = _root()
    assert all(0.01 < a < 1.0 for a in root)      # the model is a fair test: root inside

    r = cp.calibrate(_model, start=cp.SHIPPED_UM, slope=-0.08, iterations=20, tol=1e-4)
    assert r["converged"]
    assert r["amplitudes_um"] == pytest.approx(root, rel=5e-3)
    assert max(abs(e) for e in r["errors"]) <= 1e-4


def test_calibration_leaves_a_peak_within_tolerance_alone_and_bounds_the_step():
    # H_3Z already within 2 % at the start: its amplitude must not move
    start = (0.3, 0.1, 0.05)
    soft = (1e-4, 0.03, 0.05)
    r = cp.calibrate(lambda a: _model(a, linear=(1075.0, 1620.0, 3250.0), soft=soft),
                     start=start, slope=-0.08, iterations=20, tol=0.02)
    assert r["converged"]
    for h in r["history"]:
        assert h["amplitudes_um"][2] == pytest.approx(start[2], rel=1e-12)
    steps = [abs(math.log(b["amplitudes_um"][j] / a["amplitudes_um"][j]))
             for a, b in zip(r["history"], r["history"][1:], strict=False) for j in range(3)]
    assert max(steps) <= 0.5 + 1e-12


def test_calibration_reports_a_run_without_three_peaks_instead_of_guessing():
    r = cp.calibrate(lambda a: {"status": "stopped: left_range", "resonances_rpm": []},
                     start=cp.SHIPPED_UM, slope=-0.08, iterations=5, tol=0.02)
    assert not r["converged"]
    assert "no complete curve" in r["reason"]


def test_screen_basis_sees_structural_overrides_not_the_continuation():
    # the margin basis must be built on the structure asked for: a --set
    # rotors.inertia_kgm2 (or any scene key) reaches it; only continuation.* (speed
    # range, points per nonlinear run) does not, the basis being linear solves per speed
    extra = {"continuation.speed_rpm": [500.0, 7000.0], "continuation.max_points": 3000,
             "rotors.inertia_kgm2": 0.2977, "hbm.mesh_harmonics": 3,
             "drive.motor_torsional_stiffness": 1e3}
    assert cp.basis_overrides(extra) == {"rotors.inertia_kgm2": 0.2977,
                                         "hbm.mesh_harmonics": 3,
                                         "drive.motor_torsional_stiffness": 1e3}


def test_paper_ipp_shares_are_fig_18s_per_count():
    # Fig. 18, twice per turn: contact 14.5 %, 1-IPP 2 × 4 %, 2-IPP 2 × 5.25 %, 3-IPP 17 %
    assert cp.paper_ipp_shares() == pytest.approx([0.29, 0.16, 0.21, 0.34], abs=1e-12)


def test_table_rows_name_the_scene_overrides_of_a_record():
    # records made on another mesh or n_CM (--set) must not read like the scene's own
    key = {"amplitudes_um": [0.4313, 0.1798, 0.0415], "mesh.size": 0.0108, "rom.n_cm": 200,
           "transmission_error.phases_deg": [215.3, 308.4, 84.7],
           "continuation.speed_rpm": [500.0, 7000.0], "tol": 0.029}
    assert cp.settings_note(key) == " (mesh.size = 0.0108, rom.n_cm = 200)"
    assert cp.settings_note({"amplitudes_um": [0.3], "tol": 0.03}) == ""
    assert cp.settings_note({**key, "scene": "0123456789"}) == \
        " (mesh.size = 0.0108, rom.n_cm = 200; scene 0123456789)"
    assert cp.settings_note({"tol": 0.03, "scene": "0123456789"}) == " (scene 0123456789)"


def test_scene_digest_tells_structures_apart_not_tes(tmp_path):
    # a record made on another version of the scene file (here its rotors) must not be
    # reused: the digest is part of every key; the TE and the speed range are in the key
    # anyway and leave it as it is
    scene = cp.ROOT / "scenes" / "pump-paper.toml"
    d0 = cp.scene_digest(scene, {})
    assert len(d0) == 10 and d0 == cp.scene_digest(scene, {})
    assert cp.scene_digest(scene, {"rotors.gear_mass_kg": 3.0}) != d0
    assert cp.scene_digest(scene, {"links.hub": "distributing"}) != d0
    assert cp.scene_digest(scene, {"transmission_error.amplitudes_um": [0.3, 0.1, 0.05],
                                   "continuation.speed_rpm": [500.0, 4000.0],
                                   "continuation.max_points": 10}) == d0
    # what a key does not always hold counts: the file's TE phases and mean, the steps
    for other in ({"transmission_error.phases_deg": [0.0, 90.0, 0.0]},
                  {"transmission_error.mean_um": 1.0}, {"continuation.step_rpm": 1.0}):
        assert cp.scene_digest(scene, other) != d0
    # the base of the extends chain is part of it: pump-paper.toml beside an edited copy
    # of pump.toml; a comment is no change, a damping ratio is
    text = (cp.ROOT / "scenes" / "pump.toml").read_text()
    (tmp_path / "pump-paper.toml").write_text(scene.read_text())
    (tmp_path / "pump.toml").write_text(text.replace("[damping]", "[damping]\n# edited", 1))
    assert cp.scene_digest(tmp_path / "pump-paper.toml", {}) == d0
    assert "modal_ratio = 0.05" in text
    (tmp_path / "pump.toml").write_text(text.replace("modal_ratio = 0.05", "modal_ratio = 0.04", 1))
    assert cp.scene_digest(tmp_path / "pump-paper.toml", {}) != d0
