"""FE scenes: validation of the FE sections, the cached mesh → fe → rom stages (a
torque change reuses mesh and ROM), the ROM forcing, and the XDMF housing field
checked with an independent reader (meshio) against the rigid motion of the gear hub."""
from __future__ import annotations

import logging
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
    assert s.load.torque == 3.29 and s.gear.backlash == pytest.approx(40e-6)
    assert s.static_load == pytest.approx(70.0, rel=1e-3)     # the paper's F_s (Sect. 4.2)
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
    ({"rotors": {"inertia_kgm2": 0.05}}, "rotors.torsional_stiffness"),
    ({"rotors": {"lateral_stiffness_N_per_um": -2.0}}, "rotors.lateral_stiffness = -2000000"),
    ({"links": {"hub": "rbe3"}}, "links.hub = 'rbe3': allowed 'rigid', 'distributing'"),
    ({"links": {"seat": "rigid"}}, "links.seat: unknown key; allowed: hub, journal"),
    ({"bearings": {"seat_link": "distributing"}}, "as links.journal"),
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


def test_rotors_enter_the_fe_key_only_when_given(tmp_path):
    from study.pipeline import Pipeline
    from study.scene import load_scene

    base = Pipeline(load_scene(PUMP), tmp_path)
    rot = load_scene(PUMP, {"rotors.inertia_kgm2": 0.05, "rotors.torsional_stiffness": 2.4e6})
    assert rot.fe["rotors"] == {"inertia_kgm2": 0.05, "torsional_stiffness": 2.4e6}
    with_rotors = Pipeline(rot, tmp_path)
    assert with_rotors.mesh_key() == base.mesh_key()
    assert with_rotors.fe_key() != base.fe_key()
    # scenes without [rotors] keep the keys they had before the section existed
    assert "rotors" not in load_scene(PUMP).fe



def test_rom_key_hashes_the_code_that_writes_the_rom_files(tmp_path, monkeypatch):
    """The rom stage writes radiation.h5 and housing.h5 with fem.post: its key hashes
    fem.post's sources (fem's own top-level modules reach it through the fe key; the hbm
    key takes the rom key, so a change there reruns the continuation too)."""
    import study.pipeline.stages as pl
    from study.scene import load_scene

    asked: list[tuple[str, ...]] = []
    real = pl.source_hash
    monkeypatch.setattr(pl, "source_hash", lambda *m: asked.append(m) or real(*m))
    pl.Pipeline(load_scene(PUMP), tmp_path).rom_key()
    rom = next(m for m in asked if "reduction" in m)
    assert {"reduction", "fem.post", "machines.rom", "machines.pump"} <= set(rom)
    assert any("fem" in m for m in asked)                            # via the fe key


def _pump_groups_and_centres() -> tuple[dict, dict]:
    """Every group and centre name pump_spec asks for (values are not used)."""
    names = ["housing/feet"] + [f"{s}/{n}" for s in ("in", "out")
                                for n in ("hub", "gear", "bearing_a", "bearing_b", "coupling",
                                          *(f"station_{k}" for k in range(1, 7)))]
    names += [f"housing/bore_{s}_{e}" for s in ("in", "out") for e in ("a", "b")]
    return {n: (2, i) for i, n in enumerate(names)}, {n: np.zeros(3) for n in names}


def test_links_enter_the_fe_key_only_when_given(tmp_path):
    """[links] reaches the pump's hub and journal-seat links and the fe key (so rom and
    hbm), not the mesh key; scenes without it keep their keys."""
    import fem
    from machines.pump import fe_parameters
    from study.pipeline import Pipeline
    from study.scene import load_scene

    base = Pipeline(load_scene(PUMP), tmp_path)
    sc = load_scene(PUMP, {"links.hub": "distributing", "links.journal": "distributing"})
    p = fe_parameters(sc.fe, sc.gear)
    assert p.links == fem.LinkParams("distributing", "distributing")
    assert p.gears.hub_link == p.bearings.seat_link == "distributing"
    spec = fem.pump_spec(*_pump_groups_and_centres(), p.gears, p.bearings, p.drive)
    kinds = {link.surface: link.kind for link in spec.links}
    assert kinds["in/hub"] == kinds["out/bearing_b"] == "distributing"
    assert kinds["housing/bore_in_a"] == kinds["in/station_1"] == "rigid"
    dist = Pipeline(sc, tmp_path)
    assert dist.mesh_key() == base.mesh_key()
    assert dist.fe_key() != base.fe_key() and dist.rom_key() != base.rom_key()
    assert "links" not in load_scene(PUMP).fe
    assert fe_parameters(load_scene(PUMP).fe, sc.gear).links == fem.LinkParams()


FAST = {"rom.n_cm": 20, "rom.n_check": 6, "continuation.speed_rpm": [600.0, 640.0],
        "hbm.stability": False, "outputs.plots": ["campbell", "rom_error"],
        "outputs.housing_field_rpm": [],
        "outputs.report": False}


ACCELS = [{"name": "top", "position_mm": [50.0, 68.0, 80.0]},
          {"name": "side", "position_mm": [168.0, 0.0, 80.0], "direction": [1.0, 0.0, 0.0]}]


#: The run of :func:`pump_runs`: housing fields at 620 rpm, accelerometers, NVH plots.
R1 = {**FAST, "outputs.housing_field_rpm": [620.0],
      "outputs.plots": ["campbell", "rom_error", "order_maps", "erp", "accelerometers"],
      "outputs.accelerometer": ACCELS}


@pytest.fixture(scope="module")
def pump_runs(tmp_path_factory):
    import study

    tmp = tmp_path_factory.mktemp("pump")
    cache = tmp / "cache"
    r1 = study.run(PUMP, tmp / "a", cache_dir=cache, overrides=R1)
    return tmp, cache, r1


def _fe_model(pump_runs):
    """The FE model of the run, rebuilt from the cached mesh (the independent checks; the
    export itself needs neither the model nor the mesh)."""
    from machines import machine_for
    from study.pipeline import Pipeline

    _, cache, r1 = pump_runs
    mesh_dir = Pipeline(r1.scene, r1.out, cache_dir=cache).run_mesh()
    return machine_for(r1.scene).build_fe_model(mesh_dir)


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


def _dolfinx_field(model, T, q):
    """P2 displacement of the ROM coordinates q through DOLFINx (independent path),
    as (dof coordinates, values) per DOF block."""
    from reduction import reconstruct

    u = model.displacement(reconstruct(T, q))
    return model.V.tabulate_dof_coordinates(), u.x.array.reshape(-1, 3).copy()


def _match(points, coords):
    from scipy.spatial import cKDTree

    d, i = cKDTree(coords).query(points)
    assert d.max() < 1e-9
    return i


def test_housing_fields_read_back(pump_runs):
    """The housing XDMF files read back with meshio: housing cells only (tetra10, part id),
    edge nodes at the VTK positions, frames sampled 49 per mesh period (no aliasing of
    order 924); the time series, per-order amplitudes and surface normal velocity equal an
    independent evaluation through DOLFINx (P, T as PETSc matrices)."""
    import meshio

    from reduction import load_basis
    from study.outputs.points import point_at_speed

    _, _, r1 = pump_runs
    i, pt, _ = point_at_speed(r1, 620.0, "test")        # the export's point (solved there)
    tag = f"{pt.rpm:.0f}rpm"
    model = _fe_model(pump_runs)
    T = load_basis(r1.rom.folder / "rom.h5", row_range=model.K.getOwnershipRange())
    qk = r1.problem.recover(pt)
    hs = r1.problem.harmonics
    idx = np.asarray(hs.indices)
    w0 = hs.fundamental_rad_s(pt.omega)
    z = r1.scene.gear.teeth
    htag = model.fe_mesh.tag("housing", 3)
    n_h_cells = model.fe_mesh.cell_tags.find(htag).size
    with meshio.xdmf.TimeSeriesReader(str(r1.out / f"housing_{tag}.xdmf")) as rd:
        points, cells = rd.read_points_cells()
        frames = [rd.read_data(k) for k in range(rd.num_steps)]
    assert cells[0].type == "tetra10" and len(cells[0].data) == n_h_cells
    nf = int(np.ceil(4 * idx.max() / z))                     # 4 per period of the top order
    assert nf == 49 and len(frames) == 4 * nf                # shipped set: orders 0...924
    t_mesh = 2 * np.pi / (z * pt.omega)
    np.testing.assert_allclose([f[0] for f in frames], np.arange(4 * nf) * t_mesh / nf,
                               rtol=1e-12)
    assert np.all(frames[0][2]["part_id"][0] == htag)
    c = cells[0].data
    p = points[c]
    mid = 0.5 * (p[:, [0, 1, 0, 0, 1, 2]] + p[:, [1, 2, 2, 3, 3, 3]])  # VTK edges
    edge = np.linalg.norm(p[:, [1, 2, 2, 3, 3, 3]] - p[:, [0, 1, 0, 0, 1, 2]], axis=2)
    assert np.median(np.linalg.norm(p[:, 4:] - mid, axis=2) / edge) < 1e-9
    assert np.max(np.linalg.norm(p[:, 4:] - mid, axis=2) / edge) < 0.2  # curved edges
    coords, _ = _dolfinx_field(model, T, np.zeros(qk.shape[0]))
    m = _match(points, coords)
    for k in (1, 7):
        t = frames[k][0]
        q = (qk[:, 1:] * np.exp(1j * idx[1:] * w0 * t)).real.sum(axis=1)  # mean removed
        _, u = _dolfinx_field(model, T, q)
        ref = u[m]
        np.testing.assert_allclose(frames[k][1]["displacement"], ref,
                                   atol=1e-9 * np.abs(ref).max())
    # per-order complex amplitudes (order Z)
    om = meshio.read(r1.out / f"housing_orders_{tag}.xdmf")
    j = int(np.flatnonzero(idx * hs.integer_ratio == z)[0])
    _, ure = _dolfinx_field(model, T, qk[:, j].real.copy())
    _, uim = _dolfinx_field(model, T, qk[:, j].imag.copy())
    mo = _match(om.points, coords)
    scale = np.abs(ure).max() + np.abs(uim).max()
    np.testing.assert_allclose(om.point_data[f"u_o{z}_re"], ure[mo], atol=1e-9 * scale)
    np.testing.assert_allclose(om.point_data[f"u_o{z}_im"], uim[mo], atol=1e-9 * scale)
    np.testing.assert_allclose(om.point_data[f"u_o{z}_mag"],
                               np.abs(ure[mo] + 1j * uim[mo]), atol=1e-9 * scale)
    assert {f"u_o{o}_re" for o in (1, 2, 4, z, 2 * z, 3 * z)} <= set(om.point_data)
    # surface: normal velocity at the facet centres, ERP density against nvh/erp
    sm = meshio.read(r1.out / f"housing_surface_{tag}.xdmf")
    assert sm.cells[0].type == "triangle6"
    vn = sm.cell_data[f"vn_o{z}_re"][0] + 1j * sm.cell_data[f"vn_o{z}_im"][0]
    area = sm.cell_data["area"][0]
    with h5py.File(r1.results, "r") as f:
        erp = f["nvh/erp"][i, j]
    dens = sm.cell_data[f"erp_density_o{z}"][0]
    np.testing.assert_allclose(dens, 0.6 * 343 * np.abs(vn) ** 2, rtol=1e-12)
    centroid_rule = float(np.sum(dens * area))
    print("ERP order Z: centroid rule / exact quadrature =", centroid_rule / erp)
    assert centroid_rule == pytest.approx(erp, rel=0.25)


def _h5_datasets(path: Path) -> dict[str, np.ndarray]:
    out: dict[str, np.ndarray] = {}
    with h5py.File(path, "r") as f:
        f.visititems(lambda k, v: out.__setitem__(k, v[()]) if isinstance(v, h5py.Dataset)
                     else None)
    return out


def test_export_needs_no_mesh_file(pump_runs, caplog):
    """The housing fields come from the cached ROM alone (housing.h5, radiation.h5): with
    the mesh stage's folder deleted from the cache, a run served from the cache writes the
    same housing files and neither meshes nor builds the FE model. The fields are solved
    at the exact requested speed by Newton from the nearest branch point (the in-memory
    branch in one run, the cached one in the other): the same solution to the Newton
    tolerance, so the values agree to 1e-8 relative, not bitwise."""
    import shutil

    import study

    tmp, cache, r1 = pump_runs
    cache2 = tmp / "cache_no_mesh"
    shutil.copytree(cache, cache2)
    shutil.rmtree(cache2 / "mesh")
    caplog.set_level(logging.INFO)
    r = study.run(PUMP, tmp / "no_mesh", cache_dir=cache2, overrides=R1)
    assert r.stages["rom"] == "cached" and r.stages["hbm"] == "cached"
    assert r.stages["mesh"].startswith("skipped") and r.stages["fe"].startswith("skipped")
    assert not (cache2 / "mesh").exists()
    assert "fem.mesh" not in caplog.text and "fem.model" not in caplog.text
    names = sorted(p.name for p in r1.out.glob("housing*rpm.*"))
    assert len(names) == 6 and names == sorted(p.name for p in r.out.glob("housing*rpm.*"))
    for name in names:
        if name.endswith(".xdmf"):
            assert (r.out / name).read_text() == (r1.out / name).read_text(), name
            continue
        a, b = _h5_datasets(r1.out / name), _h5_datasets(r.out / name)
        assert set(a) == set(b), name
        for k in a:
            if np.issubdtype(np.asarray(a[k]).dtype, np.floating) and np.size(a[k]):
                scale = float(np.max(np.abs(a[k]))) or 1.0
                np.testing.assert_allclose(a[k], b[k], rtol=0, atol=1e-8 * scale,
                                           err_msg=f"{name}:{k}")
            else:
                np.testing.assert_array_equal(a[k], b[k], err_msg=f"{name}:{k}")


def test_housing_fields_written_in_blocks(pump_runs, tmp_path, monkeypatch):
    """The export reads housing.h5 in blocks of nodes: with blocks of ~85 nodes (1 MiB)
    instead of one block the files hold the same values (to round-off of the products)."""
    from fem import post
    from fem.post import fields as post_fields
    from study.outputs import fields
    from study.outputs.points import point_at_speed

    _, _, r1 = pump_runs
    _, pt, _ = point_at_speed(r1, 620.0, "test")        # the export's point (solved there)
    hd = post.read_housing(r1.rom.folder / post.HOUSING_FILE)
    monkeypatch.setattr(post_fields, "BLOCK_BYTES", 1 << 20)
    paths = fields.write_housing_fields(tmp_path, pt.rpm, hd, r1.rom.radiation,
                                        r1.problem.recover(pt), r1.problem.harmonics,
                                        pt.omega, r1.scene)
    assert len(paths) == 3 and len(hd.points) > 80 * 85
    for path in paths:
        assert path.read_text() == (r1.out / path.name).read_text()
        a = _h5_datasets(r1.out / path.with_suffix(".h5").name)
        b = _h5_datasets(path.with_suffix(".h5"))
        assert set(a) == set(b)
        for k in a:
            if k.endswith("phase_deg"):  # noise where the amplitude is round-off
                continue
            np.testing.assert_allclose(b[k], a[k], rtol=0, atol=1e-13 * np.abs(a[k]).max(),
                                       err_msg=k)


def test_accelerometers(pump_runs):
    """nvh/accelerometers: snapped to outer facet centres; velocity = i ω_k d·u(x) with u
    evaluated by DOLFINx at that point (Function.eval); level = rms over the orders."""
    from dolfinx import geometry as dgeo

    from reduction import load_basis, reconstruct
    from study.outputs.points import point_at

    _, _, r1 = pump_runs
    with h5py.File(r1.results, "r") as f:
        a = f["nvh/accelerometers"]
        names = [s.decode() for s in a["names"][()]]
        pos, d, vel = a["position"][()], a["direction"][()], a["velocity"][()]
        lv = a["velocity_level_db"][()]
        h = f["continuation/harmonics"][()]
    assert names == ["top", "side"]
    assert pos[0, 1] == pytest.approx(0.068) and d[0] == pytest.approx([0, 1, 0])
    assert pos[1, 0] == pytest.approx(0.168, abs=1e-6) and d[1] == pytest.approx([1, 0, 0])
    model = _fe_model(pump_runs)
    T = load_basis(r1.rom.folder / "rom.h5", row_range=model.K.getOwnershipRange())
    mesh = model.fe_mesh.mesh
    tree = dgeo.BoundingBoxTree(mesh, 3)
    cand = dgeo.compute_collisions(tree, pos)
    hit = dgeo.compute_colliding_cells(mesh, cand, pos)
    hcells = set(model.fe_mesh.cell_tags.find(model.fe_mesh.tag("housing", 3)).tolist())
    cells = [next(c for c in hit.links(k) if c in hcells) for k in range(len(pos))]
    n = vel.shape[1]
    pt = point_at(r1, n - 1)
    qk = r1.problem.recover(pt)
    w0 = r1.problem.harmonics.fundamental_rad_s(pt.omega)
    for j in np.argsort(-np.abs(vel[0, n - 1]))[:3]:
        ure = model.displacement(reconstruct(T, qk[:, j].real.copy())).eval(pos, cells)
        uim = model.displacement(reconstruct(T, qk[:, j].imag.copy())).eval(pos, cells)
        expect = 1j * h[j] * w0 * np.einsum("ij,ij->i", d, ure + 1j * uim)
        np.testing.assert_allclose(vel[:, n - 1, j], expect, rtol=1e-8)
    np.testing.assert_allclose(
        lv, 10 * np.log10(0.5 * np.sum(np.abs(vel) ** 2, axis=2) / 1e-18), rtol=1e-12)
    assert (r1.out / "accelerometers.png").stat().st_size > 10_000
    assert (r1.out / "order_map_erp.png").exists() and (r1.out / "erp.png").exists()


def test_housing_files_pyvista(pump_runs):
    """pyvista (in a child process: VTK must not share a process with DOLFINx) reads the
    per-order and surface files: the tetra10 volume equals the housing's volume from
    DOLFINx, the triangle6 area the outer surface area of nvh/radiation."""
    import json
    import subprocess
    import sys

    from dolfinx import fem as dfem

    from study.outputs.points import nearest_point

    pytest.importorskip("pyvista")
    _, _, r1 = pump_runs
    _, pt = nearest_point(r1, 620.0)
    tag = f"{pt.rpm:.0f}rpm"
    code = (
        "import json, sys, meshio, pyvista as pv\n"
        "v = pv.from_meshio(meshio.read(sys.argv[1]))\n"
        "s = pv.from_meshio(meshio.read(sys.argv[2]))\n"
        "print(json.dumps({'volume': float(v.volume), 'area': float(s.area),\n"
        "                  'n_cells': int(v.n_cells), 'arrays': sorted(v.point_data.keys())}))\n")
    p = subprocess.run([sys.executable, "-c", code, str(r1.out / f"housing_orders_{tag}.xdmf"),
                        str(r1.out / f"housing_surface_{tag}.xdmf")], capture_output=True,
                       text=True, timeout=120)
    assert p.returncode == 0, p.stderr[-2000:]
    got = json.loads(p.stdout.strip().splitlines()[-1])
    model = _fe_model(pump_runs)
    import ufl
    dx = ufl.Measure("dx", domain=model.fe_mesh.mesh, subdomain_data=model.fe_mesh.cell_tags)
    vol = dfem.assemble_scalar(dfem.form(dfem.Constant(model.fe_mesh.mesh, 1.0)
                                         * dx(model.fe_mesh.tag("housing", 3))))
    assert got["volume"] == pytest.approx(vol, rel=2e-3)
    with h5py.File(r1.results, "r") as f:
        area = f["nvh/radiation"].attrs["area"]
    assert got["area"] == pytest.approx(area, rel=5e-3)
    assert "u_o76_re" in got["arrays"]


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
        # every point inside a speed-decreasing segment (between two folds) is unstable
        rpm, stable = f["continuation/rpm"][()], f["continuation/stable"][()]
        d = np.diff(rpm)
        inner = np.flatnonzero(np.r_[False, (d[:-1] < 0) & (d[1:] < 0), False])
        assert inner.size and not np.any(stable[inner])
        assert np.all(f["continuation/floquet_kind"][()][inner] > 0)
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

    from fem import post
    from reduction import load_basis, reconstruct
    from study.outputs.points import point_at

    _, _, r1 = pump_runs
    model = _fe_model(pump_runs)
    T = load_basis(r1.rom.folder / "rom.h5", row_range=model.K.getOwnershipRange())
    facets = post.outer_surface_facets(model.fe_mesh, "housing")
    A = post.normal_gram(model.V, facets)
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
    ds = post.surface_measure(model.fe_mesh.mesh, facets)
    assert float(dfem.assemble_scalar(dfem.form(dfem.Constant(model.fe_mesh.mesh, 1.0) * ds))) \
        == pytest.approx(area, rel=1e-12)
    rows = list(csv.DictReader((r1.out / "curves.csv").open()))
    assert len(rows) == n
    assert float(rows[-1]["erp_dB_re_1pW"]) == pytest.approx(total_db[-1], abs=1e-3)
    assert float(rows[0]["speed_rpm"]) == pytest.approx(r1.branch.rpm[0], abs=1e-5)


def test_report_rewrites_the_housing_fields(pump_runs):
    """`geardyn report` rebuilds every output of the export from results.h5, the housing
    fields included (they were left out, and report.md listed none); the rewritten time
    series equals the export's."""
    import meshio

    from study.pipeline.replay import report_from_results

    def frames(path):
        with meshio.xdmf.TimeSeriesReader(str(path)) as rd:
            rd.read_points_cells()
            return [rd.read_data(k) for k in (0, rd.num_steps // 3)]

    tmp, cache, r1 = pump_runs
    xdmf = sorted(r1.out.glob("housing_[0-9]*rpm.xdmf"))
    assert len(xdmf) == 1
    before = frames(xdmf[0])
    xdmf[0].unlink()
    overrides = {**FAST, "outputs.housing_field_rpm": [620.0],
                 "outputs.plots": ["campbell", "rom_error"], "outputs.report": True,
                 "outputs.accelerometer": ACCELS}
    res = report_from_results(PUMP, r1.out, overrides, cache=str(cache))
    assert xdmf[0] in res.figures
    report = (r1.out / "report.md").read_text()
    assert f"[{xdmf[0].name}]({xdmf[0].name})" in report
    after = frames(xdmf[0])
    for (t0, d0, _), (t1, d1, _) in zip(before, after, strict=True):
        assert t1 == t0 and list(d1) == list(d0)
        for name in d0:
            np.testing.assert_allclose(d1[name], d0[name], rtol=1e-12, atol=1e-20)
