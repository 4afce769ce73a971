"""benchmarks/pump_structure.py (docs/theory.md §13.4): the mesh-energy spectrum and the
dynamic-factor peak against the closed form of two gears on springs (fast, no FE)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from benchmarks import pump_structure as ps


def _two_gears(m=0.8, k_s=3.0e8):
    """Two equal masses m on supports k_s, the mesh k̄ on x1 + x2 (G = [1, 1]): the mode
    x1 = x2 has ω² = (k_s + 2k̄)/m and eq. (31) ρ = 2k̄/(2k̄ + k_s); x1 = −x2 has none."""
    return np.diag([m, m]), np.diag([k_s, k_s]), np.array([1.0, 1.0])


def test_spectrum_and_dynamic_factor_match_the_two_gear_closed_form():
    M, K, G = _two_gears()
    m, k_s = M[0, 0], K[0, 0]
    km = 2.0e8
    f_n = math.sqrt((k_s + 2 * km) / m) / (2 * math.pi)
    rho = 2 * km / (2 * km + k_s)
    modes = ps.spectrum(M, K, G, km, fmax=1e5)
    assert len(modes) == 1
    assert modes[0][0] == pytest.approx(f_n, rel=1e-10)
    assert modes[0][1] == pytest.approx(rho, rel=1e-10)
    # the D peak against the closed form of the one mode that strains the mesh:
    # D = |2k̄ / (k_s + 2k̄ − mω² + 2iξω_n mω) − 1| (the other mode does not see G)
    xi = 0.01
    grid = np.arange(0.9 * f_n, 1.05 * f_n, 0.25)
    w, wn = 2 * np.pi * grid, 2 * np.pi * f_n
    d = np.abs(2 * km / (k_s + 2 * km - m * w**2 + 2j * xi * wn * m * w) - 1.0)
    fp, dp = ps.dynamic_factor_peak(M, K, G, km, grid, xi=xi)
    assert fp == grid[np.argmax(d)]
    assert dp == pytest.approx(d.max(), rel=1e-9)
    assert fp == pytest.approx(f_n, rel=1e-3)          # near the natural frequency
    # halving k̄ moves the mode by √(1 − ρ/2), the relation ρ_½ rests on
    f_half = math.sqrt((k_s + km) / m) / (2 * math.pi)
    assert f_half / f_n == pytest.approx(math.sqrt(1 - rho / 2), rel=1e-12)
    fh, _ = ps.dynamic_factor_peak(M, K, G, 0.5 * km, np.arange(0.9 * f_half, 1.05 * f_half,
                                                                   0.25), xi=xi)
    assert fh / fp == pytest.approx(math.sqrt(1 - rho / 2), rel=1e-3)


def test_mesh_softening_is_the_single_mode_shift():
    """reduction.mesh_softening on the two gears: the D peak at the mode's natural
    frequency and, under k̄/2, the ratio √(1 − ρ/2) of T.33 (grid step 0.125 % of f)."""
    from reduction import mesh_softening

    M, K, G = _two_gears()
    km = 2.0e8
    f_n = math.sqrt((K[0, 0] + 2 * km) / M[0, 0]) / (2 * math.pi)
    rho = 2 * km / (2 * km + K[0, 0])
    f_peak, ratio = mesh_softening(M, K, G, km, xi=0.01)
    assert f_peak == pytest.approx(f_n, rel=2e-3)
    assert ratio == pytest.approx(math.sqrt(1 - rho / 2), rel=3e-3)


def test_paper_md_measures_of_a_cached_rom():
    """study.studies.paper.measure.rom_measures on a cached ROM's data
    (machines.rom.RomData): the top mode of eq. (31) and the T.33 shift of the two-gear
    closed form."""
    from machines.rom import RomData
    from reduction import coupled_modes, mesh_energy
    from study.studies.paper.measure import rom_measures

    M, K, G = _two_gears()
    km = 2.0e8
    rom = RomData(None, M, K, None, G, coupled_modes(M, K, G, km).frequencies_hz,
                  mesh_energy(M, K, G, km), km, 0, None, {})
    (f, rho), reached, (f_peak, ratio) = rom_measures(rom, 0.01)
    f_n = math.sqrt((K[0, 0] + 2 * km) / M[0, 0]) / (2 * math.pi)
    rho_n = 2 * km / (2 * km + K[0, 0])
    assert (f, rho) == pytest.approx((f_n, rho_n), rel=1e-10) and reached == (f, rho)
    assert f_peak == pytest.approx(f_n, rel=2e-3)
    assert ratio == pytest.approx(math.sqrt(1 - rho_n / 2), rel=3e-3)


def test_paper_md_measures_only_the_modes_the_mesh_harmonics_reach():
    """A low mode with more mesh energy than the mesh mode (a heavy rotor on each gear,
    T.35) is reported, but the T.33 shift is taken at the mode at or above f_min."""
    from machines.rom import RomData
    from reduction import coupled_modes, mesh_energy
    from study.studies.paper.measure import rom_measures

    m, ks, mr, kt, km = 0.8, 1.0e6, 40.0, 6.0e8, 2.0e8
    M = np.diag([m, m, mr, mr])  # the two gears, then a heavy body on each
    K = np.array([[ks + kt, 0, -kt, 0], [0, ks + kt, 0, -kt], [-kt, 0, kt, 0],
                  [0, -kt, 0, kt]])
    G = np.array([1.0, 1.0, 0.0, 0.0])
    f_all = coupled_modes(M, K, G, km).frequencies_hz
    rho = mesh_energy(M, K, G, km)
    rom = RomData(None, M, K, None, G, f_all, rho, km, 0, None, {})
    top, reached, (f_peak, _) = rom_measures(rom, 0.01, f_min=1000.0)
    j = int(np.argmax(np.where(f_all >= 1000.0, rho, 0.0)))
    assert top[0] < 1000.0 and top[1] > reached[1]
    assert reached == pytest.approx((f_all[j], rho[j]), rel=1e-12)
    assert f_peak == pytest.approx(f_all[j], rel=5e-3)


def test_summary_of_a_spectrum():
    s = ps.summary([(3600.0, 0.2), (4000.0, 0.32), (5000.0, 0.05)])
    assert (s["top_hz"], s["top_rho"], s["n"], s["highest_hz"]) == (4000.0, 0.32, 3, 5000.0)
    assert s["sum_rho"] == pytest.approx(0.57)
    assert ps.summary([])["n"] == 0


def test_grounded_gears_adds_the_flywheel_and_lateral_ground_of_its_closed_forms():
    from benchmarks.grounded_gears import ROTATIONS, TRANSLATIONS, ground_gears

    # 12 uncoupled unit DOF (the two gears of the ROM, Fig. 1 frame), no stiffness
    J, m = 2.0e-3, 1.5
    M = np.diag([m, m, m, 1e-3, 1e-3, J] * 2)
    K = np.zeros((12, 12))
    G = np.zeros(12)
    G[[1, 5, 7, 11]] = [1.0, 0.047, -1.0, 0.047]
    dI, Ir, kt, dm, ky = 1.0e-3, 0.05, 2.0e6, 0.5, 1.0e9
    Me, Ke, Ge = ground_gears(M, K, G, dI, Ir, kt, dm, ky)
    assert Me.shape == Ke.shape == (14, 14) and np.array_equal(Ge[:12], G) and not Ge[12:].any()
    w2 = np.sort(np.linalg.eigvals(np.linalg.solve(Me, Ke)).real)
    # each gear on its flywheel: 0 and kt (1/(J + dI) + 1/Ir); each translation: ky/(m + dm)
    expected = sorted([0.0, 0.0, kt * (1 / (J + dI) + 1 / Ir), kt * (1 / (J + dI) + 1 / Ir)]
                      + [ky / (m + dm)] * len(TRANSLATIONS) + [0.0] * 6)
    assert w2 == pytest.approx(expected, rel=1e-10, abs=1e-6)
    assert len(ROTATIONS) == 2
    # no static torque reaches ground through the flywheel: K has the rigid rotation of
    # gear + flywheel in its null space
    v = np.zeros(14)
    v[[5, 12]] = 1.0
    assert np.allclose(Ke @ v, 0.0)


def test_benchmark_set_options_parse_as_geardyn_set():
    from benchmarks.common import scene_overrides
    from study.scene.errors import SceneError

    ov = scene_overrides(["mesh_stiffness.mean_N_per_um=235.3",
                          "mesh_stiffness.amplitudes_N_per_um=[44.35,37.37,27.2]",
                          "rotors.inertia_kgm2 = 0.18632"])
    assert ov == {"mesh_stiffness.mean_N_per_um": 235.3,
                  "mesh_stiffness.amplitudes_N_per_um": [44.35, 37.37, 27.2],
                  "rotors.inertia_kgm2": 0.18632}
    assert scene_overrides([]) == {}
    with pytest.raises(SceneError, match="one value per key"):
        scene_overrides(["load.torque_Nm=1,2"])
    with pytest.raises(SceneError, match="section.key"):
        scene_overrides(["torque=1"])
