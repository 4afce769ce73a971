"""gears.te_table: measured or third-party TE and stiffness tables resampled to Fourier
series (the ``table`` source), and the refusals of tables that do not describe a mesh
period."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import gears as g
from core.errors import InputError

MEAN, AMPS, PHASES = 0.4e-6, (0.3e-6, 0.1e-6, 0.05e-6), (0.2, -1.3, 2.5)


def te(x: np.ndarray) -> np.ndarray:
    """A three-harmonic TE (m) at mesh positions x."""
    return MEAN + sum(a * np.cos(2 * np.pi * k * x + p)
                      for k, (a, p) in enumerate(zip(AMPS, PHASES, strict=True), start=1))


def write(path: Path, header: str, rows: np.ndarray, comment: str = "") -> Path:
    lines = ([f"# {comment}"] if comment else []) + [header]
    lines += [",".join(f"{v:.17g}" for v in row) for row in rows]
    path.write_text("\n".join(lines) + "\n")
    return path


def test_a_closed_table_gives_back_its_harmonics(tmp_path):
    # 33 samples over one mesh period with the end point repeating the first; TE in µm,
    # stiffness in N/µm: the series are the ones the samples were made of (1e-12)
    x = np.linspace(0.0, 1.0, 33)
    k = 200e6 + 30e6 * np.cos(2 * np.pi * x)
    path = write(tmp_path / "te.csv", "mesh_position,te_um,stiffness_N_per_um",
                 np.column_stack([x, te(x) * 1e6, k * 1e-6]), "measured on the rig")
    table = g.read_mesh_table(path)
    assert table.periods == 1 and len(table.position) == 32
    mean, amps, phases = g.table_series(table, "te", 3)
    assert mean == pytest.approx(MEAN, rel=1e-12)
    np.testing.assert_allclose(amps, AMPS, rtol=1e-10)
    np.testing.assert_allclose(phases, PHASES, atol=1e-10)
    k0, ka, kp = g.table_series(table, "stiffness", 2)
    assert k0 == pytest.approx(200e6, rel=1e-12)
    np.testing.assert_allclose(ka, [30e6, 0.0], atol=1e-4)
    assert kp[0] == pytest.approx(0.0, abs=1e-12)


def test_roll_angle_over_two_mesh_periods_without_the_end_point(tmp_path):
    # gear 1 of 25 teeth: one mesh period is 14.4° of its rotation; 40 samples over 28.8°
    z1 = 25
    angle = np.arange(40) * (2 * 360.0 / z1) / 40
    x = angle * z1 / 360.0
    path = write(tmp_path / "te.csv", "roll_angle_deg,te_m", np.column_stack([angle, te(x)]))
    table = g.read_mesh_table(path, teeth=z1)
    assert table.periods == 2
    mean, amps, phases = g.table_series(table, "te", 3)
    np.testing.assert_allclose(amps, AMPS, rtol=1e-10)
    np.testing.assert_allclose(phases, PHASES, atol=1e-10)
    with pytest.raises(InputError, match=r"te.csv: teeth = None: must be z_1"):
        g.read_mesh_table(path)


def test_uneven_samples_along_the_line_of_action():
    # roll distance in mm over one base pitch, uneven steps, end point included: least
    # squares recovers a trigonometric polynomial exactly
    pb = 5.904e-3
    rng = np.random.default_rng(3)
    x = np.sort(np.concatenate([[0.0, 1.0], rng.uniform(0.0, 1.0, 30)]))
    values = te(x)
    values[-1] = values[0]
    table = g.mesh_table(x * pb * 1e3, te=values, abscissa="roll_distance_mm", base_pitch=pb)
    mean, amps, phases = g.table_series(table, "te", 3)
    assert mean == pytest.approx(MEAN, rel=1e-9)
    np.testing.assert_allclose(amps, AMPS, rtol=1e-8)


def test_the_ltca_written_as_a_table_reads_back_as_its_mesh_series(tmp_path):
    """A third-party STE in the table format: the LTCA's own q_s and k_m written to CSV
    give back mesh_series (1e-9)."""
    p = g.GearPair((30, 45), 2e-3, math.radians(20.0), 30e-3)
    res = g.solve_ltca(g.LtcaCase(p, 50.0, (0.5 * p.root_radii[0], 0.5 * p.root_radii[1])))
    path = write(tmp_path / "ltca.csv", "mesh_position,te_um,stiffness_N_per_m",
                 np.column_stack([res.t, res.ste * 1e6, res.stiffness]))
    table = g.read_mesh_table(path)
    (k0, ka, kp), (q0, qa, qp) = g.mesh_series(res, 5)
    for got, want in ((g.table_series(table, "te", 5), (q0, qa, qp)),
                      (g.table_series(table, "stiffness", 5), (k0, ka, kp))):
        assert got[0] == pytest.approx(want[0], rel=1e-9)
        np.testing.assert_allclose(got[1], want[1], rtol=1e-9, atol=1e-9 * want[0])


# ---------------------------------------------------------------------- bad tables

def test_a_table_not_periodic_over_the_mesh_period_is_refused(tmp_path):
    x = np.linspace(0.0, 1.0, 21)
    ramp = te(x) + 0.2e-6 * x                   # the end point does not repeat the first
    path = write(tmp_path / "drift.csv", "mesh_position,te_m", np.column_stack([x, ramp]))
    with pytest.raises(InputError, match=r"drift.csv: te is not periodic over the mesh "
                                         r"period: the samples at 0 and 1 mesh periods differ"):
        g.read_mesh_table(path)
    short = np.linspace(0.0, 0.8, 17)           # 0.8 mesh periods, end point included
    path = write(tmp_path / "short.csv", "mesh_position,te_m",
                 np.column_stack([short, te(short)]))
    with pytest.raises(InputError, match=r"short.csv: the samples span 0.8 mesh periods: a "
                                         r"table must cover a whole number of mesh periods"):
        g.read_mesh_table(path)
    with pytest.raises(InputError, match=r"unevenly"):
        g.mesh_table([0.0, 0.1, 0.5, 0.7], te=[0.0, 1.0, 2.0, 3.0])


def test_fewer_samples_than_the_harmonics_asked_are_refused(tmp_path):
    x = np.arange(6) / 6                        # 6 samples: at most 2 harmonics
    table = g.mesh_table(x, te=te(x))
    g.table_series(table, "te", 2)
    with pytest.raises(InputError, match=r"n_harmonics = 3: needs at least 7 samples per "
                                         r"mesh period; table has 6 \(at most 2 harmonics\)"):
        g.table_series(table, "te", 3)
    with pytest.raises(InputError, match=r"table: has no stiffness column"):
        g.table_series(table, "stiffness", 1)


@pytest.mark.parametrize(("text", "message"), [
    ("mesh_position,te_mm\n0,1\n0.5,2\n", r"bad.csv: column = 'te_mm': must be one of"),
    ("te_um\n1\n2\n", r"bad.csv: 0 abscissa columns \(\): must be exactly one of"),
    ("mesh_position,te_um,te_m\n0,1,1\n0.5,2,2\n", r"a quantity is given twice"),
    ("mesh_position,te_um\n0,1\n0,2\n", r"mesh_position must increase strictly from "
     r"sample to sample; sample 2 does not"),
    ("mesh_position,stiffness_N_per_um\n0,100\n0.5,-1\n", r"stiffness = -1000000.0 N/m: "
     r"must be > 0"),
    ("mesh_position,te_um\n0,a\n", r"not a number in the samples"),
    ("mesh_position\n0\n0.5\n", r"no value column"),
])
def test_malformed_files_are_refused_naming_the_column(tmp_path, text, message):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(InputError, match=message):
        g.read_mesh_table(path)
