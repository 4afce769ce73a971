"""benchmarks/external_sensitivity.py: variant scenes with scaled external tables, and the
span of the excitation cases per speed band (hand-computed interval lengths)."""
from __future__ import annotations

import math
from pathlib import Path

import pytest

from benchmarks import external_sensitivity as es
from study.scene.load import load_scene

BASE = Path(__file__).resolve().parents[2] / "scenes" / "pump-paper.toml"


def test_band_length_clips_intervals_by_hand():
    iv = es.intervals("996.9-1280.7;1310.7-2233.7;2323.5-7000.0")
    # 500-1500: (1280.7-996.9) + (1500-1310.7) = 283.8 + 189.3
    assert es.band_length(iv, 500, 1500) == pytest.approx(473.1, abs=1e-9)
    assert es.band_length(iv, 1500, 3500) == pytest.approx(733.7 + 1176.5, abs=1e-9)
    assert es.band_length(iv, 3500, 7000) == pytest.approx(3500.0, abs=1e-9)
    assert es.band_length(iv, 8000, 9000) == 0.0
    total = sum(b - a for a, b in iv)
    assert sum(es.band_length(iv, lo, hi) for lo, hi in es.BANDS) == pytest.approx(total)
    with pytest.raises(ValueError, match="end before start"):
        es.intervals("1200-1100")


def test_span_table_change_per_band(tmp_path):
    (tmp_path / "excitations.csv").write_text(
        "case,impacts_rpm,span_rpm\n"
        "internal,1000-1200;2400-5300,3100\n"
        "all,1000-1300;2300-7000,5000\n")
    t = es.span_table(tmp_path)
    assert t["cases"]["internal"]["500-1500"] == pytest.approx(200.0)
    assert t["cases"]["all"]["1500-3500"] == pytest.approx(1200.0)
    assert t["change"]["500-1500"] == pytest.approx(0.5)
    assert t["change"]["3500-7000"] == pytest.approx(3500 / 1800 - 1)
    assert t["change"]["all"] == pytest.approx(5000 / 3100 - 1)
    assert "200 → 300 (+50.0 %)" in es.spans_markdown([tmp_path])


def test_identity_variant_loads_the_same_external_tables(tmp_path):
    out = es.write_variant(BASE, tmp_path / "v" / "same.toml", es.Scaling())
    assert load_scene(out).external == load_scene(BASE).external


def test_scaled_variant_changes_only_what_it_says(tmp_path):
    base = load_scene(BASE).external
    s = es.Scaling(force=0.0, torque=0.5, unbalance=0.0, drop_orders=(4,),
                   phase_deg=30.0, phase_orders=(2,))
    ext = load_scene(es.write_variant(BASE, tmp_path / "v.toml", s)).external
    assert ext.unbalance == ()
    kept = [a for a in base.aero if a.order != 4]
    assert len(ext.aero) == len(kept) > 0
    for a, b in zip(ext.aero, kept, strict=True):
        assert (a.shaft, a.station, a.order) == (b.shaft, b.station, b.order)
        assert a.force == (0.0, 0.0, 0.0)
        assert a.torque == pytest.approx(tuple(0.5 * x for x in b.torque))
        d = math.degrees(a.phase - b.phase)
        assert math.remainder(d - 30.0, 360.0) == pytest.approx(0.0, abs=1e-9)


def test_negative_scale_is_refused(tmp_path):
    with pytest.raises(ValueError, match="torque scale"):
        es.variant_text(BASE, tmp_path / "v.toml", es.Scaling(torque=-1.0))
