"""Scene keys of the mesh excitation sources (issue 38): ``source = "fourier" | "ltca" |
"table"`` in [mesh_stiffness] / [transmission_error], [micro_geometry], [ltca]."""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import gears
from study.scene import SceneError, load_scene, parse_scene
from study.scene.excitation import scene_pair, set_mesh_harmonics

ROOT = Path(__file__).resolve().parent.parent
LTCA = (ROOT / "scenes" / "gear-pair-ltca.toml").read_text()
SDOF = (ROOT / "scenes" / "gear-pair-sdof.toml").read_text()


def _without_micro(text: str) -> str:
    return text.replace("[micro_geometry.both]\ntip_relief_um = 12.0\n"
                        "tip_relief_start_diameter_mm = 100.3\ntip_relief_shape = \"linear\"\n"
                        "crowning_um = 4.0\n", "")


def test_the_shipped_fourier_scenes_have_no_source():
    for name in ("gear-pair-sdof.toml", "pump.toml"):
        s = load_scene(ROOT / "scenes" / name)
        assert s.mesh_source is None


def test_the_ltca_scene_carries_the_ltca_series_bitwise():
    s = load_scene(ROOT / "scenes" / "gear-pair-ltca.toml")
    src = s.mesh_source
    assert (src.stiffness, src.te, src.harmonics) == ("ltca", "ltca", 16)
    case = src.case
    assert case.torque == 150.0 and case.n_positions == 64 and case.n_slices == 100
    assert case.bore_radii == (0.016, 0.016)
    f1, f2 = case.flanks
    assert f1 == f2
    assert f1.tip_relief == gears.Relief(12e-6, 0.1003, "linear")
    assert f1.crowning == pytest.approx(4e-6, rel=1e-15)
    (k0, ka, kp), (q0, qa, qp) = gears.mesh_series(gears.solve_ltca(case), 16)
    ms, te = s.mesh_stiffness, s.transmission_error
    assert (ms.mean, ms.amplitudes, ms.phases) == (k0, ka, kp)
    assert (te.mean, te.amplitudes, te.phases) == (q0, qa, qp)
    assert te.kind == "loaded" and len(ms.amplitudes) == 16
    # the numbers of this design (docs/gears.md): k̄ ≈ 393 N/µm, STE ptp < 1 µm at 150 N·m
    res = gears.solve_ltca(case)
    assert 380e6 < ms.mean < 405e6
    assert np.ptp(res.ste) < 1.0e-6
    unmodified = gears.solve_ltca(dataclasses.replace(case, flanks=(gears.Flank(),) * 2))
    assert np.ptp(unmodified.ste) > 5e-6


def test_the_harmonics_follow_the_hbm_set():
    s = parse_scene(LTCA.replace("mesh_harmonics = 16", "mesh_harmonics = 5"))
    assert len(s.mesh_stiffness.amplitudes) == len(s.transmission_error.amplitudes) == 5
    assert set_mesh_harmonics({"harmonics": (0, 76, 152, 228), "mesh_harmonics": 3}, 76,
                              True) == 3
    assert set_mesh_harmonics({"harmonics": (0, 1, 2), "mesh_harmonics": 3}, 76, False) == 2


def test_a_fourier_stiffness_beside_an_ltca_te():
    text = LTCA.replace('[mesh_stiffness]\nsource = "ltca"',
                        '[mesh_stiffness]\nmean_N_per_um = 220.0\n'
                        'amplitudes_N_per_um = [41.0, 35.0, 25.0]\nphases_deg = [0.0, 180.0, 0.0]')
    s = parse_scene(text)
    assert s.mesh_stiffness.mean == 220e6 and s.mesh_source.stiffness == "fourier"
    assert len(s.transmission_error.amplitudes) == 16


def test_a_fourier_scene_switched_to_ltca_by_set_ignores_its_harmonics(caplog):
    s = load_scene(ROOT / "scenes" / "gear-pair-sdof.toml",
                   {"mesh_stiffness.source": "ltca", "transmission_error.source": "ltca"})
    assert s.mesh_source.uses_ltca and s.mesh_stiffness.mean != 220e6
    assert "mesh_stiffness.mean_N_per_um, mesh_stiffness.amplitudes_N_per_um, " \
        "mesh_stiffness.phases_deg ignored" in caplog.text
    # the pump (FE) takes it too: its machine check passes
    p = load_scene(ROOT / "scenes" / "pump.toml",
                   {"mesh_stiffness.source": "ltca", "transmission_error.source": "ltca",
                    "ltca.bore_diameter_mm": [32.0, 32.0]})
    assert p.mesh_source.case.torque == 3.29 and p.mesh_source.harmonics == 12
    # docs/gears.md: 413.8 N/µm at 1440 positions; 64 positions sample the steps of k_m
    assert p.mesh_stiffness.mean == pytest.approx(413.8e6, rel=5e-3)


def test_a_helical_pair_keeps_the_scene_base_radius():
    s = load_scene(ROOT / "scenes" / "gear-pair-helical.toml")
    pair = scene_pair(s.gear)
    assert pair.helix_angle == s.gear.helix_angle > 0
    assert pair.base_radii[0] == pytest.approx(s.gear.base_radius, rel=1e-13)
    assert s.mesh_source.case.slices == s.mesh_source.case.n_slices


def test_a_table_source_is_fitted(tmp_path):
    n = 48
    x = np.arange(n) / n
    te = 1.0 + 0.4 * np.cos(2 * np.pi * x + 0.3) + 0.1 * np.cos(4 * np.pi * x - 1.0)
    k = 300.0 + 50.0 * np.cos(2 * np.pi * x)
    csv = "mesh_position,te_um,stiffness_N_per_um\n" + "".join(
        f"{a!r},{b!r},{c!r}\n" for a, b, c in zip(x, te, k, strict=True))
    (tmp_path / "mesh.csv").write_text(csv)
    text = SDOF.replace('[mesh_stiffness]\nmean_N_per_um = 220.0\n'
                        'amplitudes_N_per_um = [41.0, 35.0, 25.0]\nphases_deg = [0.0, 180.0, 0.0]',
                        '[mesh_stiffness]\nsource = "table"\nfile = "mesh.csv"')
    text = text.replace('kind = "loaded"\nmean_um = 14.0\namplitudes_um = [20.0, 2.0, 0.5]\n'
                        'phases_deg = [0.0, 90.0, 0.0]',
                        'kind = "loaded"\nsource = "table"\nfile = "mesh.csv"')
    text = text.replace("mesh_harmonics = 16", "mesh_harmonics = 4")
    (tmp_path / "s.toml").write_text(text)
    s = load_scene(tmp_path / "s.toml")
    te_s, ms = s.transmission_error, s.mesh_stiffness
    assert te_s.mean == pytest.approx(1e-6, rel=1e-12)
    assert te_s.amplitudes[:2] == pytest.approx((0.4e-6, 0.1e-6), rel=1e-10)
    assert te_s.phases[:2] == pytest.approx((0.3, -1.0), abs=1e-10)
    assert te_s.amplitudes[2:] == pytest.approx((0.0, 0.0), abs=1e-18)
    assert ms.mean == pytest.approx(300e6, rel=1e-12)
    assert ms.amplitudes[0] == pytest.approx(50e6, rel=1e-12)
    assert s.mesh_source.tables["te"].periods == 1


BAD = [
    # relief deeper / longer than the addendum
    (lambda t: t.replace("tip_relief_um = 12.0", "tip_relief_um = 2000.0"),
     "micro_geometry.gear1.tip_relief_um: flanks[1].tip_relief.amount = 0.002 m: must be < "
     "the addendum"),
    (lambda t: t.replace("tip_relief_start_diameter_mm = 100.3",
                         "tip_relief_start_diameter_mm = 99.0"),
     "micro_geometry.gear1.tip_relief_start_diameter_mm"),
    (lambda t: t.replace("tip_relief_start_diameter_mm = 100.3\n", ""),
     "micro_geometry.gear1.tip_relief_start_diameter_mm: missing"),
    (lambda t: t.replace("crowning_um = 4.0",
                         "crowning_um = 4.0\npitch_deviations_um = [1.0, -1.0]"),
     "micro_geometry.gear1.pitch_deviations_um: flanks[1].pitch_deviations: 2 values; must be "
     "one per tooth (76)"),
    (lambda t: t.replace("[micro_geometry.both]", "[micro_geometry.gear3]"),
     "micro_geometry.gear3: unknown key"),
    (lambda t: t.replace("crowning_um = 4.0", "crowning = 4.0"),
     "micro_geometry.both.crowning: unknown key (did you mean 'crowning_um'?)"),
    (lambda t: t.replace("face_width_mm = 20.0", "face_width_mm = 0.0"),
     "gear.face_width_mm = 0.0: must be > 0"),
    (lambda t: t.replace("torque_Nm = 150.0", "torque_Nm = 0.0"),
     "load.torque_Nm = 0: source = 'ltca' needs a torque > 0"),
    (lambda t: t.replace("n_positions = 64", "n_positions = 32"),
     "ltca.n_positions = 32: must be > 33 to resolve the 16 mesh harmonics"),
    (lambda t: t.replace('[transmission_error]\nsource = "ltca"',
                         '[transmission_error]\nsource = "ltca"\nkind = "unloaded"'),
     "transmission_error.kind = 'unloaded': source = 'ltca' gives the loaded STE"),
    (lambda t: t.replace('[mesh_stiffness]\nsource = "ltca"',
                         '[mesh_stiffness]\nsource = "ltca"\nfile = "x.csv"'),
     "mesh_stiffness.file = 'x.csv': only with mesh_stiffness.source = 'table'"),
    (lambda t: t.replace('[mesh_stiffness]\nsource = "ltca"', '[mesh_stiffness]\nsource = "table"'),
     "mesh_stiffness.file: missing (required with mesh_stiffness.source = 'table'"),
    (lambda t: t.replace('[mesh_stiffness]\nsource = "ltca"', '[mesh_stiffness]\nsource = "LTCA"'),
     "mesh_stiffness.source = 'LTCA': must be one of 'fourier', 'ltca', 'table'"),
    (lambda t: t.replace("bore_diameter_mm = [32.0, 32.0]", "bore_diameter_mm = [132.0, 32.0]"),
     "ltca.bore_diameter_mm = [132.0, 32.0]: gear 1's must be < its root diameter"),
]


@pytest.mark.parametrize("edit, message", BAD)
def test_bad_ltca_input_is_refused_naming_the_field(edit, message):
    with pytest.raises(SceneError) as e:
        parse_scene(edit(LTCA))
    assert message in str(e.value)


def test_interference_is_refused_before_any_work():
    z = 10
    text = _without_micro(LTCA).replace("teeth = 76", f"teeth = {z}").replace(
        "base_radius_mm = 46.984", f"base_radius_mm = {46.984 * z / 76!r}").replace(
        "bore_diameter_mm = [32.0, 32.0]\n", "")
    with pytest.raises(SceneError, match="gear: interference: the tip of gear 2"):
        parse_scene(text)


def test_micro_geometry_needs_the_ltca_source():
    text = SDOF + "\n[micro_geometry.both]\ncrowning_um = 3.0\n"
    with pytest.raises(SceneError, match=r"\[micro_geometry\]: used only with source = 'ltca'"):
        parse_scene(text)
    with pytest.raises(SceneError, match="mesh_stiffness.file = 'a.csv': only with"):
        parse_scene(SDOF.replace("[mesh_stiffness]\n", '[mesh_stiffness]\nfile = "a.csv"\n'))


@pytest.mark.parametrize("csv, message", [
    ("mesh_position,te_um\n0,1\n0.25,2\n0.5,1\n0.75,0\n1.0,1.5\n",
     "transmission_error.file = 'm.csv': m.csv: te is not periodic over the mesh period"),
    ("mesh_position,te_um\n0,1\n0.25,2\n0.5,1\n0.75,0\n",
     "transmission_error.file = 'm.csv': n_harmonics = 16: needs at least 33 samples per mesh "
     "period; m.csv has 4"),
    ("mesh_position,stiffness_N_per_um\n0,1\n0.5,2\n",
     "transmission_error.file = 'm.csv': m.csv: has no te column"),
])
def test_bad_tables_are_refused_naming_the_file(tmp_path, csv, message):
    (tmp_path / "m.csv").write_text(csv)
    text = SDOF.replace('kind = "loaded"\nmean_um = 14.0\namplitudes_um = [20.0, 2.0, 0.5]\n'
                        'phases_deg = [0.0, 90.0, 0.0]', 'source = "table"\nfile = "m.csv"')
    (tmp_path / "s.toml").write_text(text)
    with pytest.raises(SceneError) as e:
        load_scene(tmp_path / "s.toml")
    assert message in str(e.value)


def test_one_mesh_of_a_train_uses_the_same_function():
    # the [[meshes]] tables of a train: the same keys, named by the mesh in messages
    from study.scene.check import check_table
    from study.scene.excitation import mesh_source, source_series
    from study.scene.schema import SCHEMA

    pair = gears.GearPair((23, 61), 2e-3, np.radians(20.0), 0.02)
    raw_ms, raw_te = {"source": "ltca"}, {"source": "ltca"}
    micro = {"gear1": {"tip_relief_um": 10.0, "tip_relief_start_diameter_mm": 48.0}}
    names = ("meshes[1].mesh_stiffness", "meshes[1].transmission_error",
             "meshes[1].micro_geometry", "meshes[1].ltca")
    ms = check_table(names[0], raw_ms, SCHEMA["mesh_stiffness"])
    te = check_table(names[1], raw_te, SCHEMA["transmission_error"])
    lt = check_table(names[3], {}, SCHEMA["ltca"])
    src = mesh_source(ms, te, raw_ms, raw_te, micro, lt, pair=pair, torque=50.0,
                      harmonics=4, names=names)
    assert src.case.flanks[0].tip_relief.amount == pytest.approx(10e-6)
    assert src.case.flanks[1] == gears.Flank()
    mean, amps, _ = source_series(src, "stiffness")
    assert len(amps) == 4 and mean > 0
    bad = {"gear1": {"tip_relief_um": 10.0, "tip_relief_start_diameter_mm": 60.0}}
    with pytest.raises(SceneError, match=r"meshes\[1\].micro_geometry.gear1."
                                         "tip_relief_start_diameter_mm"):
        mesh_source(ms, te, raw_ms, raw_te, bad, lt, pair=pair, torque=50.0, harmonics=4,
                    names=names)


def test_pitch_deviations_reach_the_dynamics_over_the_hunting_period():
    """The helical scene (eccentricity on gear 1): k_m and the STE are the LTCA's over the
    hunting period (40 mesh periods), its harmonics q = 1 … 40 H; those at q = 40 m are
    the mesh-period series' m-th (the synchronous average keeps exactly them, to 1e-12);
    the HBM set holds every shaft order up to the top mesh harmonic and the element
    repeats every 40 mesh periods. ``[ltca] hunting = false`` gives back the mesh-period
    series and set."""
    from study.pipeline.model import scene_problem

    path = ROOT / "scenes" / "gear-pair-helical.toml"
    s = load_scene(path)
    res = gears.solve_ltca(s.mesh_source.case)
    c, h = res.periods, s.mesh_source.harmonics
    assert c == 40 and s.mesh_source.cycles == c
    ms, te = s.mesh_stiffness, s.transmission_error
    assert ms.cycles == te.cycles == c and len(ms.amplitudes) == c * h
    (k0, ka, kp), (q0, qa, qp) = gears.mesh_series(res, h)
    for series, (mean, amps, phases) in ((ms, (k0, ka, kp)), (te, (q0, qa, qp))):
        assert series.mean == pytest.approx(mean, rel=1e-12)
        hunt = np.array(series.amplitudes) * np.exp(1j * np.array(series.phases))
        mesh = np.array(amps) * np.exp(1j * np.array(phases))
        assert np.max(np.abs(hunt[c - 1::c] - mesh)) < 1e-12 * np.max(np.abs(mesh))
    # the sidebands carry the eccentricity: order 1 of the STE is of its 4 µm amplitude
    assert 1e-6 < te.amplitudes[0] < 8e-6
    pb, _ = scene_problem(s)
    assert pb.elements[0].cycles == c and pb.elements[0].base_ratio == 1
    assert list(pb.harmonics.indices) == list(range(h * 40 + 1))
    flat = load_scene(path, {"ltca.hunting": False})
    assert flat.mesh_stiffness.cycles == 1 and len(flat.mesh_stiffness.amplitudes) == h
    assert scene_problem(flat)[0].elements[0].cycles == 1


def test_a_train_mesh_takes_its_ltca_with_its_own_micro_geometry():
    """[[meshes]] of the lumped two-stage train: stage 2 from the LTCA of its own pair
    (19:67) at its own torque F_s r_b1 (from the torque path), with tip relief on the
    wheel in [meshes.micro_geometry.gear2]; stage 1 keeps the ISO estimate. The series are those of
    gears.mesh_series on that case (bitwise) and the problem builds one element per mesh
    with them; bad micro-geometry is named by the mesh."""
    from machines.train.layout import TrainLayout
    from study.pipeline.model import scene_problem

    text = (ROOT / "scenes" / "two-stage-lumped.toml").read_text()
    stage2 = ('[meshes.mesh_stiffness]\nestimate = true\nn_harmonics = 5\n'
              '[meshes.transmission_error]\nestimate = true\n')
    assert text.count(stage2) == 2
    head, tail = text.rsplit(stage2, 1)
    ltca = ('[meshes.mesh_stiffness]\nsource = "ltca"\n[meshes.transmission_error]\n'
            'source = "ltca"\nkind = "loaded"\n[meshes.micro_geometry.gear2]\n'
            'tip_relief_um = 8.0\ntip_relief_start_diameter_mm = {d}\n')
    s = parse_scene(head + ltca.format(d=135.5) + tail)
    m1, m2 = s.meshes
    assert m1.source is None and m1.mesh_stiffness.estimated
    src = m2.source
    assert (src.stiffness, src.te) == ("ltca", "ltca") and src.cycles == 1
    lm = TrainLayout.from_scene(s).meshes[1]
    assert src.case.pair.teeth == (19, 67)
    assert src.case.torque == pytest.approx(lm.static_load * lm.pair.base_radii[0], rel=1e-14)
    (k0, ka, kp), (q0, qa, qp) = gears.mesh_series(gears.solve_ltca(src.case),
                                                   s.hbm.mesh_harmonics)
    assert (m2.mesh_stiffness.mean, m2.mesh_stiffness.amplitudes) == (k0, ka)
    assert (m2.transmission_error.mean, m2.transmission_error.amplitudes) == (q0, qa)
    assert m2.transmission_error.kind == "loaded"
    pb, _ = scene_problem(s)
    assert pb.elements[1].mean_stiffness == k0 and pb.elements[0].mean_stiffness == \
        m1.mesh_stiffness.mean
    assert src.case.flanks[1].tip_relief.amount == pytest.approx(8e-6)
    with pytest.raises(SceneError, match=r"meshes\[1\].micro_geometry.gear2."
                                         "tip_relief_start_diameter_mm"):
        parse_scene(head + ltca.format(d=300.0) + tail)
    with pytest.raises(SceneError, match=r"meshes\[1\].micro_geometry"):
        parse_scene(head + stage2 + "[meshes.micro_geometry.both]\ntip_relief_um = 8.0\n"
                    + tail)
