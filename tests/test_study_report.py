"""report.md lines that say what a run did not check or where its headline is not what
the machine does: the ROM's check against the full FE model beside the mesh frequency,
the largest std when its orbit is unstable, and a run without stability."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from reduction.validate import Validation
from study.outputs.report import _largest_line, _largest_stable, _stability_lines, rom_line


def _result(validation, teeth=76, top=7000.0, n_cm=100):
    scene = SimpleNamespace(continuation=SimpleNamespace(speed=(500.0, top)),
                            gear=SimpleNamespace(teeth=teeth))
    rom = SimpleNamespace(n_cm=n_cm, validation=validation)
    return SimpleNamespace(scene=scene, rom=rom)


def test_rom_line_says_how_far_the_rom_was_checked():
    full = np.array([100.0, 1000.0, 4053.6, 5000.0])
    # every checked mode within tolerance: checked to the last one, below H_Z at 7000 rpm
    ok = Validation(full, full * (1 + 2e-4), np.array([1e-5, 1e-4, 2e-4, 1.5e-4]), 5000.0, 1e-3)
    line = rom_line(_result(ok))[0]
    f_mesh = 76 * 7000.0 / 60.0                      # 8867 Hz
    assert "its 4 lowest coupled frequencies agree with the full FE model's within 2.0e-04 " \
           "(tol 0.001) up to 5000 Hz, where the check stops" in line
    assert f"the mesh frequency reaches {f_mesh:.0f} Hz at 7000 rpm (above the checked " \
           "range, `geardyn convergence --only n_cm`" in line
    # a range whose mesh frequency stays below the check: no pointer to the study
    assert "above the checked" not in rom_line(_result(ok, top=3000.0))[0]
    # the third mode off by 1.79e-3: valid only to the second (the pump's coarse ROM)
    bad = Validation(full, full, np.array([1e-5, 1e-4, 1.79e-3, 1e-4]), 1000.0, 1e-3)
    line = rom_line(_result(bad))[0]
    assert "**valid only to 1000 Hz** (tol 0.001): coupled mode 3 of the 4 checked, 4054 Hz " \
           "in the full FE model, is 1.8e-03 off; raise `rom.n_cm`" in line
    assert "**not checked**" in rom_line(_result(None))[0]
    assert rom_line(SimpleNamespace(rom=None)) == []                 # lumped scene


def test_largest_std_on_an_unstable_orbit_names_the_largest_stable_one():
    rpm = np.linspace(2000.0, 3000.0, 11)
    std = 50.0 - np.abs(rpm - 2600.0) / 20.0          # top 50 N at 2600 rpm
    stable = np.abs(rpm - 2600.0) > 150.0              # 2500-2700 rpm unstable
    def branch(stable):
        mesh = SimpleNamespace(mesh_load_std=std)
        return SimpleNamespace(rpm=rpm, stable=stable, element=lambda e=0: mesh)

    best = _largest_stable(branch(stable))
    assert best == (40.0, 2400.0)                      # 2400 rpm: 50 - 200/20
    s = {"max_mesh_load_std": 50.0, "at_rpm": 2600.0, "max_std_kind": "Neimark–Sacker",
         "max_stable": best}
    assert _largest_line(s, True) == (
        "- largest std of the dynamic mesh load 50 N at 2600.0 rpm, **an unstable orbit** "
        "(Neimark–Sacker): the largest stable one is 40 N at 2400.0 rpm")
    assert _largest_line({**s, "max_std_kind": ""}, True).endswith("at 2600.0 rpm")
    assert _largest_stable(branch(np.zeros(11, bool))) is None
    assert _largest_line({**s, "max_stable": None}, True).endswith(
        "no orbit of the curve is stable")


def test_a_run_without_stability_says_so():
    s = {"unstable_points": 0, "unstable_kinds": {}, "unstable_segments": [],
         "unresolved_rpm": [], "grazing_rpm": [], "nan_exponent_rpm": [],
         "amplification": None}
    assert _stability_lines(s, False, []) == [
        "- stability: **not computed** (`[hbm] stability = false`): every point is listed "
        "as stable without a check"]
    assert _stability_lines(s, True, [])[0].startswith("- unstable points: 0 — Floquet")
    assert len(_stability_lines(s, True, [])) == 1
    # verdicts near grazing, exponents not computed, a large transient amplification
    s = {**s, "grazing_rpm": [2508.73, 2508.9], "nan_exponent_rpm": [2508.8],
         "amplification": (1200.0, 1384.66, True)}
    lines = _stability_lines(s, True, [])
    assert lines[1].startswith("- **verdict unresolved near grazing at 2 points "
                               "(2508.73–2508.90 rpm)**")
    assert lines[2].startswith("- exponent **not computed** (NaN in `floquet_max_real`) at "
                               "1 point (2508.80–2508.80 rpm)")
    assert lines[3].startswith("- largest transient amplification over one period of a stable "
                               "orbit 1.2e+03× at 1384.7 rpm")
    s["amplification"] = (4.6, 1800.0, True)
    assert len(_stability_lines(s, True, [])) == 3          # below 10: not named
    # no 'unstable' flag on the largest std when nothing was checked
    s = {"max_mesh_load_std": 50.0, "at_rpm": 2600.0, "max_std_kind": "fold",
         "max_stable": None}
    assert "unstable" not in _largest_line(s, False)


class _Rpm:
    """A branch with speeds only (what the report reads of a secondary branch)."""

    def __init__(self, rpm):
        self.rpm = np.asarray(rpm, dtype=float)

    def __len__(self):
        return len(self.rpm)


def test_where_the_branch_winds_the_report_gives_one_line():
    """Consecutive unstable segments spanning less than 0.2 % of the speed together
    (the pump's at 2508.7-2510.3 rpm, of three kinds) are one line; the nested folds of
    a wide hysteresis (the single-DOF scene's 1791-2195 and 2090-3004 rpm) stay two."""
    from study.outputs.curves import UnstableSegment
    from study.outputs.report import _folds_text, unstable_lines

    kinds = ("period_doubling", "fold", "period_doubling", "neimark_sacker", "fold")
    pd = [UnstableSegment(k, (2508.7 + 0.1 * j, 2509.0 + 0.1 * j), 3, 87.0 + j,
                          (10 * j, 10 * j + 2)) for j, k in enumerate(kinds)]
    wide = [UnstableSegment("fold", (1791.2, 2195.0), 91, 5377.0, (100, 190)),
            UnstableSegment("fold", (2089.9, 3004.0), 686, 7.788e4, (200, 885))]
    lines = unstable_lines(pd + wide)
    assert lines[1] == (
        "  - 2508.7–2509.4 rpm, where the branch winds: 15 points in 5 segments (period "
        "doubling 6, fold 6, Neimark–Sacker 3), std up to 91 N; period doubling: a response "
        "at half the fundamental frequency takes over (not computed: `[continuation] "
        "period_doubling_depth = 0`, or no period-2 branch found over this range: see section "
        "\"Period doubling\" or the log); fold: the middle part of an amplitude jump; "
        "Neimark–Sacker: a quasi-periodic response or another, coexisting periodic one "
        "takes over (not computed: `[outputs] attractor_transient_turns`)")
    assert lines[2].startswith("  - 1791.2–2195.0 rpm, 91 points, std up to 5377 N: fold")
    assert lines[3].startswith("  - 2089.9–3004.0 rpm, 686 points, std up to 7.788e+04 N")
    assert len(lines) == 4
    # a period-2 branch over the period-doubling speeds is named where it was computed

    sec = SimpleNamespace(name="period2_1", branch=_Rpm([2508.9, 2509.1, 2509.3]))
    far = SimpleNamespace(name="period2_2", branch=_Rpm([4000.0, 4100.0]))
    named = unstable_lines(pd + wide, secondary=[sec, far])[1]
    assert "period doubling: a response at half the fundamental frequency takes over " \
        "(computed: `period2_1`, section \"Period doubling\")" in named
    assert "period2_2" not in named
    assert _folds_text([1452.5, 1450.6, 2195.1, 1791.0]) == "1452.5, 1450.6, 2195.1, 1791.0 rpm"
    assert _folds_text([2505.4, 2507.0, 2510.3, 2506.1, 3000.0]) == \
        "2505.4–2510.3 (4 folds), 3000.0 rpm"
    assert _folds_text([1393.13, 1393.11, 1393.14]) == "1393.1 (3 folds) rpm"
    assert _folds_text([]) == "none"
