"""Curve features (study.outputs.curves) and the paper table (study.studies.paper) on
synthetic curves whose peaks, impact intervals and IPP sequences are known in closed
form."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from hbm import MeshPeriodEnvelope
from study.outputs.curves import (
    FoldPair,
    class_intervals,
    contact_windows,
    fold_pairs,
    impact_intervals,
    impact_span,
    ipp_fractions,
    ipp_runs,
    primary_peak,
    resonance_peaks,
    summarize_curve,
    unstable_segments,
)
from study.studies.paper.measure import IppAt, PaperInputs, SpectrumAt
from study.studies.paper.report import paper_markdown, write_paper

CENTRES = (1000.0, 1480.0, 2800.0)
WIDTHS = (60.0, 80.0, 150.0)
HEIGHTS = (40.0, 55.0, 90.0)


def _std(r):
    r = np.asarray(r, dtype=float)
    y = 5.0 + 1e-3 * r  # a rising background, so that the maxima are off the centres
    for c, w, a in zip(CENTRES, WIDTHS, HEIGHTS, strict=True):
        y = y + a / np.sqrt(1.0 + ((r - c) / w) ** 2)
    return y


def _true_maxima():
    """Maxima of _std on a 0.001 rpm grid around each centre (independent of the code)."""
    out = []
    for c in CENTRES:
        r = np.arange(c - 50.0, c + 50.0, 1e-3)
        y = _std(r)
        out.append((float(r[np.argmax(y)]), float(y.max())))
    return out


RPM = np.arange(600.0, 4000.0 + 1e-9, 20.0)
REGIONS = ((1000.0, 1240.0), (1320.0, 2180.0), (2400.0, 4000.0))


def _contact(regions):
    c = np.zeros(RPM.size, dtype=int)
    for a, b in regions:
        c[(RPM >= a) & (RPM <= b)] = 1
    return c


def test_peaks_are_the_local_maxima_refined():
    std = _std(RPM) + 0.05 * np.sin(RPM / 7.0)  # wiggles below the prominence threshold
    peaks = resonance_peaks(RPM, std)
    assert len(peaks) == 3
    for p, (r, y) in zip(peaks, _true_maxima(), strict=True):
        assert p.rpm == pytest.approx(r, abs=1.0)      # 20 rpm grid, parabola vertex
        assert p.std == pytest.approx(y, abs=0.06)  # wiggle amplitude 0.05
    s = summarize_curve(RPM, _std(RPM), _contact(REGIONS), [1000.0], (600.0, 4000.0))
    assert [round(p.rpm, 6) for p in s.strongest(2)] == \
        sorted(round(p.rpm, 6) for p in s.peaks if p.rpm > 1200)
    assert primary_peak(s).rpm == pytest.approx(_true_maxima()[2][0], abs=2.0)
    assert primary_peak(s, near=1500.0).rpm == pytest.approx(_true_maxima()[1][0], abs=2.0)
    assert primary_peak(s, near=2000.0) is None


def test_peak_on_a_fold_counted_once():
    # a branch that turns back (fold): speeds go up, back, up again; one maximum
    r = np.r_[np.linspace(900, 1100, 21), np.linspace(1095, 1050, 10), np.linspace(1055, 1300, 25)]
    y = np.r_[np.linspace(10, 50, 21), np.linspace(48, 20, 10), np.linspace(19, 5, 25)]
    peaks = resonance_peaks(r, y)
    assert len(peaks) == 1 and peaks[0].std == pytest.approx(50.0)


def test_fold_pairs_of_a_softening_s_curve():
    # up to 2900, back to 2860, up again: one hysteresis between the two turning points
    r = np.r_[np.linspace(2500, 2900, 41), np.linspace(2895, 2860, 8), np.linspace(2865, 3200, 30)]
    y = np.r_[np.linspace(40, 110, 41), np.linspace(108, 80, 8), np.linspace(79, 30, 30)]
    turns = [i for i in range(1, r.size - 1) if (r[i] - r[i - 1]) * (r[i + 1] - r[i]) < 0]
    assert turns == [40, 48]
    (f,) = fold_pairs(r, y, turns)
    assert f.rpm == (2900.0, 2860.0) and f.std == (110.0, 80.0)
    assert (f.width, f.height, f.centre) == (40.0, 30.0, 2880.0)
    # a fold whose partner lies beyond the range, and an index from no branch: no pair
    assert fold_pairs(r, y, [40]) == [] and fold_pairs(r, y, [-(10 ** 9), 40]) == []
    s = summarize_curve(r, y, np.zeros(r.size, int), [], (2500.0, 3200.0), fold_index=turns)
    assert s.folds == (f,)


def test_unstable_segments_split_by_kind_in_branch_order():
    r = np.arange(10, dtype=float) * 100.0
    y = np.arange(10, dtype=float)
    stable = np.array([1, 0, 0, 0, 1, 0, 0, 1, 0, 1], bool)
    kind = np.array([0, 3, 3, 2, 0, 1, 1, 0, 7, 0])       # 7: not a kind (an old file)
    segs = unstable_segments(r, y, stable, kind)
    assert [(u.kind, u.rpm, u.points, u.peak_std) for u in segs] == [
        ("neimark_sacker", (100.0, 200.0), 2, 2.0), ("period_doubling", (300.0, 300.0), 1, 3.0),
        ("fold", (500.0, 600.0), 2, 6.0), ("unclassified", (800.0, 800.0), 1, 8.0)]
    assert [u.index for u in segs] == [(1, 2), (3, 3), (5, 6), (8, 8)]
    assert unstable_segments(r, y, np.ones(10, bool), np.zeros(10, int)) == []
    # a segment that folds back: its speed interval is that of its points
    (u,) = unstable_segments([1.0, 3.0, 2.0], [0, 0, 0], [False] * 3, [1] * 3)
    assert u.rpm == (1.0, 3.0) and u.contains(2.5) and not u.contains(3.5)
    s = summarize_curve(r, y, np.zeros(10, int), [], (0.0, 900.0), stable=stable, kind=kind)
    assert s.unstable == tuple(segs) and s.unstable_at(150.0) == [segs[0]]
    assert [u.label for u in segs] == ["Neimark–Sacker", "period doubling", "fold",
                                       "unclassified"]
    assert summarize_curve(r, y, np.zeros(10, int), [], (0.0, 900.0)).unstable == ()
    with pytest.raises(ValueError, match="shapes"):
        unstable_segments(r, y, stable[:5], kind)


def test_peaks_of_a_branch_winding_at_one_speed_count_once():
    # the pump's branch at 1393 rpm: the speed oscillates by +-0.03 rpm over loops while
    # the std goes 58 -> 62 -> 58 -> 63 N; one resonance, its highest point
    t = np.linspace(0.0, 4 * np.pi, 160)
    r = np.r_[np.linspace(1300, 1393, 30), 1393.13 + 0.03 * np.sin(3 * t),
              np.linspace(1393, 1380, 10), np.linspace(1381, 1500, 30)]
    y = np.r_[np.linspace(30, 58, 30), 60.5 + 2.5 * np.sin(t) + 0.01 * t,
              np.linspace(62, 70, 10), np.linspace(69, 20, 30)]
    peaks = resonance_peaks(r, y)
    assert len(peaks) == 2                      # the top at 1380, the loops' highest
    assert (peaks[0].rpm, peaks[0].std) == (pytest.approx(1380.0, abs=1.0),
                                            pytest.approx(70.0, abs=0.5))
    assert (peaks[1].rpm, peaks[1].std) == (pytest.approx(1393.13, abs=0.05),
                                            pytest.approx(y[30:190].max(), rel=1e-3))


def test_impact_intervals_span_and_windows():
    iv = impact_intervals(RPM, _contact(REGIONS))
    # a segment with impacts at one end counts: one grid step on each side
    assert iv == [(980.0, 1260.0), (1300.0, 2200.0), (2380.0, 4000.0)]
    assert impact_span(iv) == pytest.approx(280.0 + 900.0 + 1620.0)
    assert contact_windows(iv) == [(1260.0, 1300.0), (2200.0, 2380.0)]
    # with the grazing speeds the continuation located, each interval ends there
    graz = [993.0, 1251.5, 1311.0, 2187.25, 2390.0]
    iv = impact_intervals(RPM, _contact(REGIONS), graz)
    assert iv == [(993.0, 1251.5), (1311.0, 2187.25), (2390.0, 4000.0)]
    assert contact_windows(iv) == [(1251.5, 1311.0), (2187.25, 2390.0)]
    # a transition without its grazing (not located) keeps the whole segment
    assert impact_intervals(RPM, _contact(REGIONS), graz[1:])[0] == (980.0, 1251.5)
    # per class: double-sided impacts 1500-1600 rpm, their grazings at 1490 and 1605
    c = _contact(REGIONS)
    c[(RPM >= 1500.0) & (RPM <= 1600.0)] = 2
    per = class_intervals(RPM, c, [*graz, 1490.0, 1605.0])
    assert per[2] == [(1490.0, 1605.0)]
    assert per[1] == [(993.0, 1251.5), (1311.0, 1490.0), (1605.0, 2187.25), (2390.0, 4000.0)]
    assert impact_intervals(RPM, c, [*graz, 1490.0, 1605.0])[1] == (1311.0, 2187.25)


def test_ipp_runs_cyclic():
    seq = np.roll(np.array([2] * 30 + [1] * 8 + [2] * 30 + [1] * 8), 5)
    runs = ipp_runs(seq)
    assert [n for n, _ in runs] == [2, 1, 2, 1] or [n for n, _ in runs] == [1, 2, 1, 2]
    assert sorted(f for _, f in runs) == pytest.approx(sorted([30 / 76, 8 / 76] * 2))
    assert ipp_fractions(seq) == pytest.approx({1: 16 / 76, 2: 60 / 76})
    assert ipp_runs(np.full(76, 3)) == [(3, 1.0)]


#: Twice per turn: impact loads 200 ± 40 N, the DTE's mean 3.1 ± 0.05 µm.
_TURN = 2 * np.pi * np.arange(76) / 76
_ENVELOPE = MeshPeriodEnvelope(200.0 + 40.0 * np.cos(2 * _TURN),
                               3.1e-6 + 5e-8 * np.cos(2 * _TURN))


def _inputs():
    s_all = summarize_curve(RPM, _std(RPM), _contact(REGIONS), [990, 1250, 1310, 2190, 2390],
                            (600.0, 4000.0))
    s_int = summarize_curve(RPM, 1.1 * _std(RPM), _contact(REGIONS[:2]), [990, 1250, 1310, 2190],
                            (600.0, 4000.0))
    inp = PaperInputs("synthetic", 2.5, 53.21, cases={"internal": s_int, "all": s_all})
    inp.primary = {"internal": primary_peak(s_int),
                   "all": primary_peak(s_all, near=primary_peak(s_int).rpm)}
    seq = np.roll(np.array([2] * 30 + [1] * 8 + [2] * 30 + [1] * 8), 5)
    inp.ipp = {1700.0: IppAt(1700.0, 1700.0, seq, "branch point"),
               1070.0: "outside the computed range",
               6875.0: IppAt(6875.0, 6875.0, np.array(([0] * 17 + [1] * 21) * 2), "branch point")}
    orders = np.array([0, 2, 4, 76, 152])
    inp.spectra = {
        6875.0: SpectrumAt(6875.0, orders, np.array([300.0, 40.0, 10.0, 20.0, 5.0]), 76,
                           np.array([9e-6, 5e-8, 4e-9, 3e-8, 4e-9]), 150.0),
        2970.0: SpectrumAt(2971.5, orders, np.array([300.0, 5.0, 2.0, 100.0, 50.0]), 76,
                           np.array([9e-6, 3e-8, 4e-8, 7e-7, 4e-8]), 300.0, _ENVELOPE)}
    inp.softening = (4070.0, 0.70)
    return inp


def _row(md: str, start: str) -> str:
    """The line of the table that starts with ``start``."""
    return next(ln for ln in md.splitlines() if ln.startswith(start))


def test_paper_table_rows_from_the_curves(tmp_path):
    inp = _inputs()
    md = paper_markdown(inp)
    true = [r for r, _ in _true_maxima()]
    found = [p.rpm for p in inp.cases["all"].strongest(3)]
    assert found == pytest.approx(true, abs=2.0)
    row = _row(md, "| resonance speeds")
    assert ", ".join(f"{x:.0f}" for x in found) in row
    errs = [(a - b) / b for a, b in zip(found, (1070.0, 1570.0, 3000.0), strict=True)]
    assert ", ".join(f"{100 * e:+.1f} %" for e in errs) in row
    assert "within 3 %: no" in row          # 1000 vs 1070 is -6.5 %
    shift = _row(md, "| resonance shift")
    # paper side: √(1 − 0.32/2) = 0.917, the single-mode shift of T.33
    assert "| 0.92 if its ρ = 0.32 mode were alone" in shift
    assert "| 0.70 (dynamic-factor peak 4070 Hz) |" in shift
    ratio = _row(md, "| resonance ratios")
    assert f"1.00 : {found[1] / found[0]:.2f} : {found[2] / found[0]:.2f}" in ratio
    assert "1.00 : 1.47 : 2.80" in ratio
    g = _row(md, "| grazing speeds")
    assert "5: 990, 1250, 1310, 2190, 2390 (within 3 %: yes)" in g
    w = _row(md, "| permanent-contact")
    assert "| 1250–1310, 2190–2390 |" in w         # bounded by the grazings
    pk = _row(md, "| primary peak")
    assert "93 → 88 N (-5.4 %)" in pk
    top = _true_maxima()[2][1]
    assert f"{1.1 * top:.1f} → {top:.1f} N (-9.1 %" in pk
    big = float(_std(RPM).max())
    assert f"largest std of each curve {1.1 * big:.1f} → {big:.1f} N (-9.1 %" in pk
    assert _row(md, "| amplitude jumps").endswith(
        f"| internal only: none within ±15 % of {primary_peak(inp.cases['internal']).rpm:.0f} "
        f"rpm; all: none within ±15 % of {inp.primary['all'].rpm:.0f} rpm | Sect. 4.2, "
        "Fig. 12 ('smaller amplitude-jump instabilities') |")
    near, far = FoldPair((2810.0, 2790.0), (100.0, 80.0)), FoldPair((1500.0, 1490.0), (9.0, 8.0))
    jumped = replace(inp, cases={**inp.cases, "internal": replace(inp.cases["internal"],
                                                                  folds=(far, near))})
    assert "| internal only: 2790–2810 rpm (20.0 rpm wide, std 100.0 / 80.0 N); all: none" \
        in _row(paper_markdown(jumped), "| amplitude jumps")
    assert "unstable" not in pk                      # no stability computed: no note
    pi = inp.primary["internal"].rpm
    ns = unstable_segments(RPM, _std(RPM), np.abs(RPM - pi) > 45.0, np.full(RPM.size, 3))
    shaky = replace(inp, cases={**inp.cases, "internal": replace(inp.cases["internal"],
                                                                 unstable=tuple(ns))})
    # the segment alone is no verdict on the peak: its own point's orbit decides
    assert "unstable" not in _row(paper_markdown(shaky), "| primary peak")
    shaky.primary = {**inp.primary, "internal": replace(inp.primary["internal"],
                                                        kind="neimark_sacker")}
    assert f"**the periodic orbit at the peak is unstable** (internal: Neimark–Sacker " \
           f"{ns[0].rpm[0]:.0f}–{ns[0].rpm[1]:.0f} rpm): the machine leaves it" \
        in _row(paper_markdown(shaky), "| primary peak")
    assert "time integration" not in _row(paper_markdown(shaky), "| primary peak")
    timed = replace(shaky, machine={"internal": (3022.8, 145.9), "all": (3019.0, 145.8)})
    assert _row(paper_markdown(timed), "| primary peak").endswith(
        "; time integration from the most unstable orbit there: 145.9 → 145.8 N (-0.1 %; "
        "from 3023 → 3019 rpm) | Sect. 4.2, Fig. 12 (internal only → all excitations) |")
    span = _row(md, "| vibro-impact span")
    # from grazing to grazing: 990-1250, 1310-2190 (and 2390-4000 with all excitations)
    assert f"1140 → 2750 rpm ({100 * (2750 / 1140 - 1):+.1f} %)" in span
    ipp = _row(md, "| IPP sequence at 1700")
    assert "1-IPP 21.1 %, 2-IPP 78.9 %" in ipp and "2-IPP 39.5 %" in ipp
    assert "outside the computed range" in _row(md, "| IPP sequence at 1070")
    for start, want in (
            ("| IPP sequence at 6875", "| contact 22 % → 1-IPP 28 % → contact 22 % → 1-IPP 28 % "
             "(per count: contact 44 %, 1-IPP 56 %) | contact 22.4 % → 1-IPP 27.6 % → contact "
             "22.4 % → 1-IPP 27.6 % (per count: contact 44.7 %, 1-IPP 55.3 %;"),
            ("| gear response (DTE", "largest H_2, 0.05 µm; H_2 0.05 µm, H_Z 0.03 µm"),
            ("| mesh-load harmonics at 6875", "largest H_2; H_2 = 40 N, H_Z = 20 N (H_2/H_Z = "
             "2.00; at 2972 rpm 0.05)"),
            ("| mesh-load peak-to-peak", "| 275 → 160 N (×0.58) | 300 → 150 N (×0.50; at 2972 "
             "→ 6875 rpm) |"),
            ("| impact loads at 2970", "| 180 → 260 N (+44 %), 2 cycles per turn | 160 → 240 N "
             "(+50 %), 2 cycles per turn (at 2972 rpm) | Sect. 4.3, Fig. 15b"),
            ("| low-frequency DTE modulation at 2970", "| 4 µm (H_2) | 0.1 µm (H_2 amplitude "
             "0.03 µm; at 2972 rpm) | Sect. 4.3, Fig. 15d")):
        assert want in _row(md, start), start
    assert "53.2 N at T = 2.5 N·m" in md
    assert "unstable orbit" not in md                  # no stability computed: no note
    # Floquet verdicts of the solved points: a note on every row that uses an unstable one
    # 8 turns of 76 mesh periods whose impact loads swing 27 times: 3.375 cycles per turn
    k = np.arange(8 * 76)
    swing = MeshPeriodEnvelope(303.5 - 303.5 * np.cos(2 * np.pi * 27 * k / k.size),
                               np.where(k == 5, 3.5e-6, 0.0))
    lo = replace(inp.spectra[2970.0], stability="neimark_sacker", machine=(30, 8, swing))
    hi = replace(inp.spectra[6875.0], stability="stable")
    shaky = replace(inp, ipp={**inp.ipp, 1700.0: replace(inp.ipp[1700.0], stability="stable"),
                              6875.0: replace(inp.ipp[6875.0], stability="period_doubling")},
                    spectra={2970.0: lo, 6875.0: hi})
    md2 = paper_markdown(shaky)
    note = "; **unstable orbit** at 2972 rpm (Neimark–Sacker): the machine leaves it, so " \
           "this compares orbits as the paper computes them (docs/theory.md §13.5) |"
    for start in ("| mesh-load peak-to-peak", "| mesh-load harmonics at 6875"):
        assert note in _row(md2, start), start
    machine = "; the machine (time integration from that orbit, 30 turns left out, 8 analysed):"
    assert f"{note[:-2]}{machine} 0 → 607 N, 3.375 cycles per turn |" \
        in _row(md2, "| impact loads at 2970")
    assert f"{note[:-2]}{machine} 3.5 µm |" in _row(md2, "| low-frequency DTE modulation")
    idle = replace(lo, envelope=MeshPeriodEnvelope(np.array([0.0, 300.0]), np.zeros(2)),
                   stability="stable", machine=None)       # a mesh period without load
    assert "| 0 → 300 N (no load in some mesh period), 1 cycle per fundamental period (at " \
           "2972 rpm) |" in _row(paper_markdown(replace(shaky, spectra={2970.0: idle,
                                                                          6875.0: hi})),
                                 "| impact loads at 2970")
    assert "unstable" not in _row(md2, "| gear response (DTE")      # 6875 rpm only: stable
    assert "unstable" not in _row(md2, "| IPP sequence at 1700")
    assert "mesh periods); **unstable orbit** at 6875 rpm (period doubling)" \
        in _row(md2, "| IPP sequence at 6875")
    p = write_paper(tmp_path, inp)
    assert p.read_text() == md
    # a range that reaches 6875 rpm but not 2970 rpm, and one that reaches neither
    inp.spectra[2970.0] = "outside the computed range 3000–7000 rpm"
    md = paper_markdown(inp)
    assert "| outside the computed range 3000–7000 rpm |" in _row(md, "| impact loads at 2970")
    assert "(H_2/H_Z = 2.00)" in _row(md, "| mesh-load harmonics at 6875")
    assert "| outside the computed range 3000–7000 rpm (at 2970 rpm); 150 N at 6875 rpm |" \
        in _row(md, "| mesh-load peak-to-peak")
    inp.spectra = {6875.0: "outside the computed range 500–4000 rpm"}
    assert "| outside the computed range 500–4000 rpm |" in _row(paper_markdown(inp),
                                                               "| response at 6875")


def test_calibrated_rows_are_marked_and_every_row_has_a_calibration_key():
    """The scene's ``[calibration]`` adds a last column: the rows it names say what was
    fitted, every other row says ``not fitted``; without it the table keeps four columns
    and a sentence says the scene declares no fits. Every row compares one finding whose
    key a scene may name (``CALIBRATION_ROWS``, each a key of ``PAPER``)."""
    from study.scene.schema import CALIBRATION_ROWS
    from study.studies.paper.findings import PAPER
    from study.studies.paper.report import _ipp_rows, _mode_rows, _spectrum_rows

    assert set(CALIBRATION_ROWS) <= set(PAPER)
    inp = _inputs()
    inp.mesh_mode, inp.reached_mode, inp.reached_from = (288.0, 0.61), (4028.0, 0.35), 633.0
    plain = paper_markdown(inp)
    table = plain.split("\n\n")[2].splitlines()       # title, preamble, table
    assert table[0] == "| quantity | paper | this run | paper source |"
    assert "not fitted" not in plain and "calibrated**" not in plain
    assert "does not say which findings its parameters were fitted to" in plain
    fits = {"grazing": "TE against these speeds", "ipp_1700": "TE refined"}
    md = paper_markdown(replace(inp, calibration=fits))
    rows = md.split("\n\n")[2].splitlines()
    assert rows[0].endswith("| paper source | in this scene |") and rows[1] == "|---" * 5 + "|"
    assert len(rows) == len(table)
    assert _row(md, "| grazing speeds").endswith(
        "| Sect. 4.3, Fig. 14 | **calibrated**: TE against these speeds |")
    assert _row(md, "| IPP sequence at 1700").endswith("| **calibrated**: TE refined |")
    marked = [ln for ln in rows[2:] if "**calibrated**" in ln]
    assert len(marked) == 2
    assert all(ln.endswith("| not fitted |") for ln in rows[2:] if ln not in marked)
    used = {r.key for f in (_mode_rows, _ipp_rows, _spectrum_rows) for r in f(inp)}
    assert used <= set(CALIBRATION_ROWS) and "h2_speed" in used and "mesh_mode" in used


def test_a_peak_is_flagged_by_its_own_orbit_not_by_a_segment_beside_it():
    """On a fold the stable top of the upper branch lies inside the speed range of the
    unstable middle branch: the peak's and the largest std's verdicts are those of their
    own points, and excitations.md flags only an unstable one."""
    from study.studies.excitations import CaseCurves, comparison_table

    # a branch going up to 1000 rpm, back to 950 (middle, unstable) and on over its top
    # at 980 rpm to 1100 rpm: the top lies inside the middle's 950-990 rpm
    rpm = np.r_[np.linspace(800.0, 1000.0, 9), np.linspace(990.0, 950.0, 5),
                np.linspace(960.0, 1100.0, 8)]
    std = np.r_[np.linspace(10.0, 30.0, 9), np.linspace(32.0, 40.0, 5),
                [42.0, 50.0, 45.0, 38.0, 30.0, 22.0, 15.0, 8.0]]
    stable = np.r_[np.ones(9, bool), np.zeros(5, bool), np.ones(8, bool)]
    kind = np.where(stable, 0, 1)
    s = summarize_curve(rpm, std, np.zeros(rpm.size, int), [], (800.0, 1100.0),
                        stable=stable, kind=kind)
    top = primary_peak(s)
    assert s.unstable and s.unstable[0].contains(top.rpm)      # the segment covers it
    assert top.index == 15 and top.kind == "" and s.max_std_kind == ""
    inp = CaseCurves(cases={"internal": s}, primary={"internal": top})
    assert "unstable" not in comparison_table(inp)
    # the same curve with its top point unstable (Neimark-Sacker there)
    stable[15], kind[15] = False, 3
    s = summarize_curve(rpm, std, np.zeros(rpm.size, int), [], (800.0, 1100.0),
                        stable=stable, kind=kind)
    assert primary_peak(s).kind == "neimark_sacker" and s.max_std_kind == "neimark_sacker"
    inp = CaseCurves(cases={"internal": s}, primary={"internal": primary_peak(s)})
    row = comparison_table(inp).splitlines()[2]
    assert row.count("(**unstable**: Neimark–Sacker)") == 2, row
