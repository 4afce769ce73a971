"""``scenes/pump-paper.toml`` (docs/theory.md §13.5): the pump with its gears on lumped
rotors calibrated against Fig. 8 (ρ, f½/f) and the H_3Z resonance (the frequency), and
its TE calibrated against the paper's five grazing speeds and its 1-IPP share at
1700 rpm, with contact kept at 1070 rpm. The H_2Z and H_Z resonance speeds are a
prediction and come out within issue 14's 3 % of Fig. 14 (1570, 3000 rpm); H_3Z is on
1070 rpm by calibration; the grazings, the two permanent-contact windows and the IPP at
1700 and 1070 rpm are the calibration's, checked here so that a change of the model
that moves them is seen. All excitations, the scene's converged mesh, the calibration's
n_CM = 200 and 12/3 set, 900–3300 rpm (the five grazings and the three resonances), no stability."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytestmark = pytest.mark.fem

SCENE = Path(__file__).resolve().parents[2] / "scenes" / "pump-paper.toml"
#: the calibration's ROM (200 component modes, valid to 5.2 kHz): the scene now keeps the
#: modes below 2 × 26.6 kHz, and its calibrated rows are keyed to this one (the scene's
#: [rom] comment), checked on its 50 lowest modes as then (a check up to 26.6 kHz on this
#: mesh costs minutes and depends on each case's excitation, so each case rebuilt the ROM)
RANGE = {"rom.n_cm": 200, "rom.n_check": 50, "hbm.stability": False,
         "continuation.speed_rpm": [900.0, 3300.0], "outputs.plots": [],
         "outputs.housing_field_rpm": [], "outputs.report": False}


@pytest.fixture(scope="module")
def work(tmp_path_factory):
    return tmp_path_factory.mktemp("pump-paper")


@pytest.fixture(scope="module")
def result(work):
    import study

    r = study.run(SCENE, work / "run", cache_dir=work / "cache", overrides=RANGE)
    assert r.branch.status == "completed"
    return r


@pytest.fixture(scope="module")
def summary(result):
    from study.outputs.curves import summarize_branch

    return summarize_branch(result.branch)


def test_resonances_are_the_papers_within_3_percent(summary):
    from study.studies.paper.findings import PAPER, TOLERANCE

    peaks = [p.rpm for p in summary.strongest(3)]
    paper = PAPER["resonances"].value
    # H_3Z is calibrated (the gears' added mass and inertia put the mode there, session
    # 12); H_2Z and H_Z, whose distance from it is the contact loss, are predicted
    assert peaks[0] == pytest.approx(paper[0], rel=0.005)
    assert peaks == pytest.approx(paper, rel=TOLERANCE)
    # the prediction free of the calibrated frequency: the ratios 1.47 and 2.80
    assert peaks[1] / peaks[0] == pytest.approx(paper[1] / paper[0], rel=TOLERANCE)
    assert peaks[2] / peaks[0] == pytest.approx(paper[2] / paper[0], rel=TOLERANCE)
    # the converged reference: the same scene on 0.3 x the coarse preset's size (297k
    # P2 DOF, n_CM = 200) puts them at 1071.6, 1550.4, 2925.7 rpm (this mesh: 1072.2,
    # 1551.2, 2927.7)
    assert peaks == pytest.approx([1071.6, 1550.4, 2925.7], rel=0.004)
    # the H_Z peak is softened by contact loss by a few per cent (the paper's 5 %: 3000
    # against 60 f/Z = 3158 rpm), not the shipped pump's 21 %: 60 f/Z of the 4028 Hz
    # mesh mode is 3180 rpm (7.9 % here, 8.0 % over 500-7000 rpm: more than the paper)
    assert 0.02 < 1.0 - peaks[2] / 3180.0 < 0.10


def test_grazings_and_windows_are_the_calibrated_ones(summary):
    from study.studies.paper.findings import PAPER, TOLERANCE

    assert summary.grazing == pytest.approx(PAPER["grazing"].value, rel=TOLERANCE)
    assert len(summary.windows) == 2
    for (lo, hi), (p_lo, p_hi) in zip(summary.windows, PAPER["windows"].value, strict=True):
        assert lo < p_hi and hi > p_lo  # each window overlaps the paper's


def _ipp_at(result, rpm):
    """Impacts per mesh period of the solution at ``rpm`` (solved there, as paper.md)."""
    from hbm import point_stats
    from study.studies.paper.measure import solution_at

    pt, how = solution_at(result, rpm)
    assert how != "nearest branch point"            # solved at that speed
    return point_stats(result.problem, pt)[0].ipp


def test_ipp_at_1700_rpm_is_the_calibrated_one(result):
    """The TE's third criterion (``calibrate_pump refine-nl --nl-ipp 1700=0,0.2,0.8,0``):
    Fig. 17's 1-IPP on ~20 % of the turn and 2-IPP on the rest, measured as paper.md
    measures it; the two 1-IPP runs per turn (the H_2 modulation) were not asked for."""
    from study.outputs.curves import ipp_runs

    ipp = _ipp_at(result, 1700.0)
    shares = np.bincount(ipp, minlength=4) / ipp.size
    assert shares[0] == 0.0 and shares[3:].sum() == 0.0
    assert shares[1] == pytest.approx(0.2, abs=0.03)
    runs = [f for n, f in ipp_runs(ipp) if n == 1]
    assert len(runs) == 2 and runs[0] == pytest.approx(runs[1], abs=0.03)


def test_contact_phases_at_1070_rpm_are_kept(result):
    """The calibration's lower bounds at 1070 rpm (``--nl-ipp-min 1070=0.03,0.015,0.1,0``,
    a constraint of the calibration, checked here so that a model change that breaks it
    is seen): contact, 1-IPP and 2-IPP mesh periods in one turn."""
    ipp = _ipp_at(result, 1070.0)
    shares = np.bincount(ipp, minlength=4) / ipp.size
    assert shares[0] >= 0.03 and shares[1] >= 0.015 and shares[2] >= 0.1


def test_internal_only_impacts_reach_the_end_of_the_range(work):
    """The TE's second criterion: with the internal excitation alone the teeth keep
    losing contact from the H_Z region to 7000 rpm, so the span change comes from the
    grazings near 1000 and 1300 rpm spreading (Sect. 4.2), not from the high-speed end
    (the session-7 TE stopped impacting at 5290 rpm there: span change +56 %)."""
    import numpy as np

    import study
    from study.scene.load import load_scene
    from study.studies.excitations import case_scenes

    scene = load_scene(SCENE, {**RANGE, "continuation.speed_rpm": [2600.0, 7000.0]})
    r = study.run(case_scenes(scene)["internal"], work / "internal", cache_dir=work / "cache")
    br = r.branch
    assert br.status == "completed" and br.rpm.max() == pytest.approx(7000.0)
    assert np.all(br.element(0).contact > 0), br.rpm[br.element(0).contact == 0]


def test_the_orbit_at_the_primary_peak_is_left_for_the_rotor_mode(work):
    """docs/theory.md §13.5, "Stability along the curves": near the H_Z resonance the
    contact loss softens the rotor-against-rotor mode (288 Hz, ρ 0.61) and the periodic
    orbit loses stability by a Neimark–Sacker pair. Time integration from the orbit
    (an independent method) leaves it for a response with a line of that softened mode:
    std up by ≥ 10 %, its strongest low-order line between half the linear mode and the
    mode (session 13: 119.6 against 104.6 N, 100 N at 201 Hz, order 4.125)."""
    import study
    from benchmarks.ti_attractor import orbit_std
    from hbm.post.time_response import integrate
    from study.scene.load import load_scene
    from study.studies.excitations import case_scenes

    scene = load_scene(SCENE, {**RANGE, "hbm.stability": True,
                               "continuation.speed_rpm": [2850.0, 2925.0]})
    r = study.run(case_scenes(scene)["internal"], work / "internal-peak",
                  cache_dir=work / "cache")
    br = r.branch
    assert br.status == "completed"
    i = int(np.argmax(br.rpm))
    assert not br.stable[i] and br.floquet_kind[i] == 3, (br.stable[i], br.floquet_kind[i])
    rom = r.rom
    top = rom.frequencies_hz[int(np.argmax(rom.mesh_energy))]
    assert 280.0 < top < 300.0 and rom.mesh_energy.max() > 0.55
    point = r.problem.solve(float(br.rpm[i]), x0=br.unknowns[i], tol=1e-10)
    rpm = float(br.rpm[i])
    tr = integrate(r.problem, rpm, point, transient=20, window=4)
    hbm_std = orbit_std(r.problem, point)
    assert tr.std > 1.1 * hbm_std, (tr.std, hbm_std)
    low = [order * rpm / 60.0 for order, _ in tr.lines if order * rpm / 60.0 < 1000.0]
    assert low and 0.5 * top < low[0] < top, tr.lines[:5]
