"""FE scenes: validation of the FE sections, the cached mesh → fe → rom stages (a
torque change reuses mesh and ROM), the ROM forcing, and the XDMF housing field
checked with an independent reader (meshio) against the rigid motion of the gear hub."""
from __future__ import annotations

import logging
import math
from pathlib import Path

import h5py
import numpy as np
import pytest

pytestmark = pytest.mark.fem

ROOT = Path(__file__).resolve().parents[1]
PUMP = ROOT / "scenes" / "pump.toml"


def test_pump_scene_loads():
    from study.scene import load_scene

    s = load_scene(PUMP)
    assert s.scene.kind == "fe"
    assert s.load.torque == 2.5 and s.gear.backlash == pytest.approx(40e-6)
    assert {u.m_unb for u in s.external.unbalance} == {30e-6, 20e-6}
    assert s.external.orders == (1, 2, 4)
    assert s.damping.modal_ratio == 0.05


@pytest.mark.parametrize(("patch", "message"), [
    ({"geometry.housing": {"wall_thicknes_mm": 8.0}}, "geometry.housing.wall_thicknes_mm"),
    ({"geometry.housing": {"wall_thickness_mm": -8.0}}, "wall_thickness"),
    ({"materials": {"shaft_E_GPa": -1.0}}, "shaft_E"),
    ({"mesh": {"preset": "medium"}}, "preset"),
    ({"bearings": {"radiall": 1e8}}, "did you mean 'radial'"),
    ({"drive": {"impeller_inertia": "big"}}, "impeller_inertia"),
])
def test_broken_fe_sections(patch, message):
    import tomllib

    from study.scene import SceneError, scene_from_dict

    raw = tomllib.loads(PUMP.read_text())
    for dotted, table in patch.items():
        node = raw
        for p in dotted.split("."):
            node = node.setdefault(p, {})
        node.update(table)
    with pytest.raises(SceneError) as err:
        scene_from_dict(raw)
    assert message in str(err.value)


FAST = {"rom.n_cm": 20, "rom.n_check": 6, "continuation.speed_rpm": [600.0, 640.0],
        "hbm.stability": False, "outputs.plots": ["campbell", "rom_error"],
        "outputs.housing_field_rpm": [],
        "outputs.report": False}


@pytest.fixture(scope="module")
def pump_runs(tmp_path_factory):
    import study

    tmp = tmp_path_factory.mktemp("pump")
    cache = tmp / "cache"
    r1 = study.run(PUMP, tmp / "a", cache_dir=cache,
                   overrides={**FAST, "outputs.housing_field_rpm": [620.0]})
    return tmp, cache, r1


def test_stages_and_results(pump_runs):
    _, _, r1 = pump_runs
    assert r1.stages["mesh"] == "ran" and r1.stages["fe"] == "ran" and r1.stages["rom"] == "ran"
    assert r1.branch.status == "completed"
    n_r = r1.rom.M.shape[0]
    assert n_r == 12 + 20
    with h5py.File(r1.results, "r") as f:
        assert f["rom/M"].shape == (n_r, n_r) and "basis" not in f["rom"]
        assert f["excitation/forces"].shape == (f["continuation/harmonics"].size, n_r)
        # static load: the impeller torque T about z, balanced through the mesh:
        # G^T K_coupled^-1 f_0 * k_m = F_s = T / r_b (static equilibrium of eq. 17)
        K = f["rom/K"][()] + f["gear_mesh/stiffness"][0].real * np.outer(f["rom/G"], f["rom/G"])
        f0 = f["excitation/forces"][0].real
        delta0 = f["rom/G"][()] @ np.linalg.solve(K, f0)
        fs = f["gear_mesh/static_load"][()]
        assert delta0 * f["gear_mesh/stiffness"][0].real == pytest.approx(fs, rel=1e-6)
    assert (r1.out / "campbell.png").exists() and (r1.out / "rom_error.png").exists()


def test_torque_change_reuses_mesh_and_rom(pump_runs, caplog):
    import study

    tmp, cache, r1 = pump_runs
    caplog.set_level(logging.INFO)
    r2 = study.run(PUMP, tmp / "b", cache_dir=cache,
                   overrides={**FAST, "load.torque_Nm": 3.0})
    assert r2.stages["rom"] == "cached"
    assert r2.stages["mesh"].startswith("skipped") and r2.stages["fe"].startswith("skipped")
    assert r2.stages["hbm"] == "ran"
    assert r2.keys["rom"] == r1.keys["rom"] and r2.keys["hbm"] != r1.keys["hbm"]
    assert "stage rom    cached" in caplog.text
    # a wall thickness change re-meshes
    from study.pipeline import Pipeline
    from study.scene import load_scene

    s3 = load_scene(PUMP, {**FAST, "geometry.housing.wall_thickness_mm": 9.0})
    assert Pipeline(s3, tmp / "c", cache_dir=cache).mesh_key() != r1.keys["mesh"]


def test_housing_xdmf_read_back(pump_runs):
    """meshio reads the XDMF: all P2 nodes, tetra10 cells, and on the input hub seat
    (rigidly linked to the gear node) frame 0 equals the rigid motion of the gear DOF."""
    import meshio

    from study.export import nearest_point

    _, _, r1 = pump_runs
    xdmf = sorted(r1.out.glob("housing_*rpm.xdmf"))
    assert xdmf
    with meshio.xdmf.TimeSeriesReader(str(xdmf[0])) as rd:
        points, cells = rd.read_points_cells()
        t0, pdata, _ = rd.read_data(0)
        n_steps = rd.num_steps
    assert n_steps == 32 and t0 == 0.0
    assert cells[0].type == "tetra10"
    import json
    info = json.loads((r1.mesh_dir / "mesh.json").read_text())
    assert points.shape[0] == int(info["quality"]["n_nodes"])
    u = next(iter(pdata.values()))
    # ROM gear DOF at t = 0 (frame 0): q(0) = Re sum_k q_k
    _, pt = nearest_point(r1, 620.0)
    q0 = r1.problem.recover(pt).real.sum(axis=1)
    a = r1.scene.gear.pressure_angle
    R = np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])
    ug, th = R @ q0[:3], R @ q0[3:6]
    c = np.asarray(info["centres"]["in/hub"])
    r = np.hypot(points[:, 0] - c[0], points[:, 1] - c[1])
    hub = (np.abs(r - 0.016) < 1e-7) & (np.abs(points[:, 2] - c[2]) <= 0.01 - 1e-6)
    assert hub.sum() > 20
    expect = ug + np.cross(th, points[hub] - c)
    scale = np.abs(expect).max()
    assert scale > 0
    np.testing.assert_allclose(u[hub], expect, atol=1e-6 * scale)


@pytest.mark.slow
def test_pump_demo_end_to_end(tmp_path):
    """`make demo` scene: the coarse pump end to end in under 10 minutes, all outputs
    present; a second run with only the torque changed skips meshing and reduction."""
    import subprocess
    import sys
    import time

    env = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "PYTHONPATH": str(ROOT)}
    import os
    env = {**os.environ, **env}
    t = time.perf_counter()
    out = tmp_path / "pump"
    p = subprocess.run([sys.executable, "-m", "study", "run", str(PUMP), "--out", str(out),
                        "--no-progress"], cwd=ROOT, env=env, capture_output=True, text=True,
                       timeout=900)
    assert p.returncode == 0, p.stderr[-3000:]
    assert time.perf_counter() - t < 600
    for name in ("results.h5", "forced_response.png", "campbell.png", "rom_error.png",
                 "report.md"):
        assert (out / name).stat().st_size > 0
    assert list(out.glob("housing_*rpm.xdmf")) and list(out.glob("time_series_*rpm.png"))
    with h5py.File(out / "results.h5", "r") as f:
        assert f["continuation"].attrs["status"] == "completed"
        i = int(np.argmax(f["rom/mesh_energy"][()]))
        assert 3500 < f["rom/frequencies_hz"][i] < 4500  # most mesh energy near 4 kHz
        assert np.any(f["continuation/contact"][()] > 0)  # vibro-impacts appear
    p2 = subprocess.run([sys.executable, "-m", "study", "run", str(PUMP), "--out",
                         str(tmp_path / "pump2"), "--set", "load.torque_Nm=3.0",
                         "--set", "outputs.housing_field_rpm=[]", "--no-progress"],
                        cwd=ROOT, env=env, capture_output=True, text=True, timeout=900)
    assert p2.returncode == 0, p2.stderr[-3000:]
    assert "stage rom    cached" in p2.stderr
    assert "stage mesh   skipped (rom cached)" in p2.stderr


def test_erp_matches_direct_surface_integral(pump_runs):
    """nvh/erp of results.h5 against an independent evaluation: the displacement of each
    harmonic rebuilt through DOLFINx (P, T as PETSc matrices) and ½ρc ω² ∫ |n·u|² dA
    assembled on the housing's outer facets; total = Σ_k, dB re 1 pW; curves.csv agrees."""
    import csv

    from dolfinx import fem as dfem

    from reduction import load_basis, reconstruct
    from study import acoustics, fe_stages
    from study.export import point_at

    _, _, r1 = pump_runs
    model = fe_stages.fe_stage(r1.scene, r1.mesh_dir)
    T = load_basis(r1.rom.folder / "rom.h5", row_range=model.K.getOwnershipRange())
    facets = acoustics.outer_surface_facets(model.fe_mesh, "housing")
    A = acoustics.normal_gram(model.V, facets)
    rho, c = 1.2, 343.0
    with h5py.File(r1.results, "r") as f:
        g = f["nvh"]
        erp, total_db = g["erp"][()], g["erp_total_db"][()]
        assert g.attrs["air_density"] == rho and g.attrs["sound_speed"] == c
        assert g["radiation/W"].shape == (r1.rom.M.shape[0],) * 2
        area = g["radiation"].attrs["area"]
        h = f["continuation/harmonics"][()]
    # the outer skin: more than the plain box (bosses, ribs, feet), less than box + cavity
    box = 2 * (0.236 * 0.136 + 0.136 * 0.160 + 0.160 * 0.236)
    assert box < area < 1.3 * box
    n = erp.shape[0]
    for i in (0, n - 1):
        pt = point_at(r1, i)
        qk = r1.problem.recover(pt)
        w0 = r1.problem.harmonics.fundamental_rad_s(pt.omega)
        for j in np.argsort(erp[i])[-3:]:
            re, im = reconstruct(T, qk[:, j])
            val = 0.0
            for part in (re, im):
                uf = model.displacement(part)  # keep the Function alive while using its Vec
                u = uf.vector
                y = A.createVecLeft()
                A.mult(u, y)
                val += u.dot(y)
            direct = 0.5 * rho * c * (h[j] * w0) ** 2 * val
            assert erp[i, j] == pytest.approx(direct, rel=1e-8)
        assert total_db[i] == pytest.approx(10 * np.log10(erp[i].sum() / 1e-12), abs=1e-9)
    assert float(dfem.assemble_scalar(dfem.form(
        dfem.Constant(model.fe_mesh.mesh, 1.0) * acoustics._ds(model.fe_mesh.mesh, facets)))) \
        == pytest.approx(area, rel=1e-12)
    rows = list(csv.DictReader((r1.out / "curves.csv").open()))
    assert len(rows) == n
    assert float(rows[-1]["erp_dB_re_1pW"]) == pytest.approx(total_db[-1], abs=1e-3)
    assert float(rows[0]["speed_rpm"]) == pytest.approx(r1.branch.rpm[0], abs=1e-5)
