"""An imported housing as an FE model (fem.housing) against CalculiX on the same mesh.

The gearbox housing of scripts/gearbox_housing_step.py, read from STEP and meshed coarse
(5 812 tetrahedra, 35 172 DOF), feet clamped, a 2 kg point mass on each of its six seat
nodes: DOLFINx (quadrature degree 2) and CalculiX C3D10 give the same first 10
frequencies to 4.3e-7 (the 7 digits CalculiX prints) with the seats linked rigidly
(RBE2, ``*RIGID BODY``) and distributing (RBE3, ``*DISTRIBUTING COUPLING`` with the
nodal area weights, node at the area centroid). Also: distributing seats add no
stiffness, spring mounts against CalculiX, the STEP round trip of the pump housing, and
the same model from the mesh file as from the CAD."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("dolfinx")
gmsh = pytest.importorskip("gmsh")

import cad_support as cs  # noqa: E402
import fem_support as fs  # noqa: E402
from mpi4py import MPI  # noqa: E402

import fem  # noqa: E402
from fem import calculix  # noqa: E402
from geometry import (  # noqa: E402
    CadPart,
    MeshPart,
    PumpParams,
    build_pump,
    finalize_gmsh,
    gmsh_session,
    import_cad,
    import_mesh,
    preset,
    write_msh,
)

pytestmark = pytest.mark.fem


@pytest.fixture(autouse=True)
def _gmsh_finalised():
    """A builder called outside a session leaves gmsh initialised: close it after each
    test, so that no model outlives it."""
    yield
    finalize_gmsh()
needs_ccx = pytest.mark.skipif(shutil.which("ccx") is None, reason="CalculiX missing")

GEARBOX = cs.gearbox_script()
COARSE = preset("coarse", size=0.03, curvature_points=6)
MATERIALS = {"housing": fem.CAST_IRON}
SEAT_MASS = 2.0  # kg on each seat node (a share of shaft, gears and bearing)
N_MODES = 10
CLAMPED = {"housing/feet": fem.MountSupport()}


def _ccx(model, couplings: list, clamps: list[str], tmp: Path) -> np.ndarray:
    if shutil.which("ccx") is None:
        return np.full(N_MODES, np.nan)
    return calculix.run_frequency(gmsh.model, MATERIALS, model.groups, clamps, N_MODES,
                                  tmp, couplings=couplings)


@pytest.fixture(scope="module")
def gearbox(tmp_path_factory: pytest.TempPathFactory) -> dict:
    """Mesh, seat weights, and the CalculiX frequencies of both seat links (computed while
    the gmsh model is alive)."""
    d = tmp_path_factory.mktemp("housing")
    p = GEARBOX.GearboxHousing()
    step = GEARBOX.write(d / "gearbox.step", p)
    with gmsh_session():
        model = import_cad([CadPart("housing", step, unit="mm")], GEARBOX.seats(p),
                           [GEARBOX.feet_mount(p)], COARSE)
        fe_mesh = fem.load_meshed_model(model, MPI.COMM_WORLD)
        seats = list(model.seat_groups().values())
        weights = {s: fem.surface_weights(fe_mesh, s) for s in seats}
        ccx = {}
        for kind in ("rigid", "distributing"):
            cps = [calculix.Coupling(
                s, tuple(weights[s].centroid), kind, mass=SEAT_MASS,
                weights=weights[s].by_gmsh_tag() if kind == "distributing" else None)
                for s in seats]
            ccx[kind] = _ccx(model, cps, ["housing/feet"], d)
        write_msh(d / "gearbox.msh")
    return {"model": model, "fe_mesh": fe_mesh, "seats": seats, "weights": weights,
            "ccx": ccx, "params": p, "dir": d}


def _modes(fe_mesh: fem.FEMesh, seats: dict[str, str], mounts: dict, mass: float = 0.0,
           centres: dict | None = None, n: int = N_MODES, sigma: float = 0.0) -> np.ndarray:
    spec = fem.housing_spec(fe_mesh, seats, mounts, centres=centres)
    for s in seats:
        if mass:
            spec.add_mass(s, fem.rigid_body_mass(mass, [0.0, 0.0, 0.0]))
    model = fem.build_model(fe_mesh, MATERIALS, spec, quadrature_degree=2)
    return fem.eigenfrequencies(model.K, model.M, n, sigma=sigma)


@needs_ccx
@pytest.mark.parametrize("kind", ["rigid", "distributing"])
def test_seat_links_match_calculix(gearbox: dict, kind: str) -> None:
    """RBE2 and RBE3 seats with their masses: 10 frequencies within 1e-6 of CalculiX
    (measured 3.2e-7 rigid, 4.3e-7 distributing)."""
    centres = {s: gearbox["weights"][s].centroid for s in gearbox["seats"]}
    f = _modes(gearbox["fe_mesh"], dict.fromkeys(gearbox["seats"], kind), CLAMPED,
               SEAT_MASS, centres)
    rel = np.abs(f / gearbox["ccx"][kind] - 1)
    assert rel.max() < 1e-6, (f, gearbox["ccx"][kind])


def test_distributing_seats_add_no_stiffness(gearbox: dict) -> None:
    """Unloaded seat nodes: distributing links leave the clamped housing's spectrum as it
    is (1e-9), rigid ones stiffen the bores (the first mode +5.4 %, the next +15-35 %)."""
    fe_mesh, seats = gearbox["fe_mesh"], gearbox["seats"]
    spec = fem.housing_spec(fe_mesh, {}, CLAMPED)
    bare = fem.build_model(fe_mesh, MATERIALS, spec, quadrature_degree=2)
    f0 = fem.eigenfrequencies(bare.K, bare.M, 6)
    f_dist = _modes(fe_mesh, dict.fromkeys(seats, "distributing"), CLAMPED, n=6)
    f_rigid = _modes(fe_mesh, dict.fromkeys(seats, "rigid"), CLAMPED, n=6)
    assert np.abs(f_dist / f0 - 1).max() < 1e-9
    assert np.all(f_rigid > f0 * (1 + 1e-3))
    assert f_rigid[0] / f0[0] - 1 == pytest.approx(0.0544, abs=2e-3)


def test_seat_weights_and_centroid(gearbox: dict) -> None:
    """Nodal area weights of a bore: their sum is the bore's area (the P2 surface of the
    curved facets, 0.2 % short of the cylinder's 2 pi r L on this coarse mesh), the area
    centroid lies on the axis at the seat centre."""
    model = gearbox["model"]
    for name, rep in model.seats.items():
        w = gearbox["weights"][rep.group]
        assert w.area == pytest.approx(rep.area, rel=3e-3)
        assert w.weights.sum() == pytest.approx(w.area, rel=1e-12)
        assert np.linalg.norm(w.centroid - rep.centre) < 1e-6, name
        assert np.all(np.isin(w.nodes + 1, _group_node_tags(gearbox, rep.group)))


def _group_node_tags(gearbox: dict, group: str) -> np.ndarray:
    with gmsh_session():
        gmsh.merge(str(gearbox["dir"] / "gearbox.msh"))
        dim, tag = gearbox["model"].groups[group]
        tags, _ = gmsh.model.mesh.getNodesForPhysicalGroup(dim, tag)
        gmsh.model.remove()
    return np.asarray(tags)


@needs_ccx
def test_spring_mounts_match_calculix(gearbox: dict, tmp_path: Path) -> None:
    """Each foot on its own spring node (per-patch mount, rigid link): the housing on four
    rubber mounts, against CalculiX's *RIGID BODY feet on SPRING1 elements (1e-6;
    measured 2.6e-7)."""
    p = gearbox["params"]
    k = (2e7, 5e7, 2e7, 2e3, 2e3, 2e3)
    with gmsh_session():
        model = import_cad([CadPart("housing", gearbox["dir"] / "gearbox.step", unit="mm")],
                           [], [GEARBOX.feet_mount(p, per_patch=True)], COARSE)
        feet = model.mount_groups()["feet"]
        fe_mesh = fem.load_meshed_model(model, MPI.COMM_WORLD)
        cps = [calculix.Coupling(g, tuple(model.centres[g]), "rigid", stiffness=k)
               for g in feet]
        f_ccx = _ccx(model, cps, [], tmp_path)
    support = fem.MountSupport("springs", stiffness=k)
    f = _modes(fe_mesh, {}, dict.fromkeys(feet, support), sigma=-1e2)
    assert len(feet) == 4 and f[0] > 10.0  # held by the springs: no rigid-body mode
    assert np.abs(f / f_ccx - 1).max() < 1e-6, (f, f_ccx)


def test_mesh_file_gives_the_cad_model(gearbox: dict) -> None:
    """The .msh written from the CAD import, read back with the same seats and feet (found
    on its facets): the same FE model, frequencies to 1e-10."""
    p = gearbox["params"]
    with gmsh_session():
        model = import_mesh(MeshPart("housing", gearbox["dir"] / "gearbox.msh", unit="m"),
                            GEARBOX.seats(p), [GEARBOX.feet_mount(p)])
        fe_mesh = fem.load_meshed_model(model, MPI.COMM_WORLD)
    seats = dict.fromkeys(model.seat_groups().values(), "distributing")
    f_mesh = _modes(fe_mesh, seats, CLAMPED, SEAT_MASS, n=6)
    f_cad = _modes(gearbox["fe_mesh"], seats, CLAMPED, SEAT_MASS, n=6)
    assert np.abs(f_mesh / f_cad - 1).max() < 1e-10


def test_step_round_trip_of_the_pump_housing(tmp_path: Path) -> None:
    """The parametric pump housing written as STEP and read back: the same modes to mesh
    tolerance (feet clamped; coarse preset: 7.4e-4 apart, while coarse and fine meshes of
    either differ by 4 %; fine preset: 1.9e-4, docs/cad-import.md)."""
    step = cs.write_pump_housing_step(tmp_path / "pump_housing.step")
    with gmsh_session():
        meshed = build_pump(PumpParams(), preset("coarse"))
        fs.keep_only_housing(meshed)
        fe_param = fem.load_meshed_model(meshed, MPI.COMM_WORLD)
    with gmsh_session():
        model = import_cad([CadPart("housing", step, unit="mm")], cs.pump_seats(),
                           [cs.pump_feet()], preset("coarse"))
        fe_step = fem.load_meshed_model(model, MPI.COMM_WORLD)
    assert set(model.groups) == set(meshed.groups)  # the pump's housing group names
    f_param = _modes(fe_param, {}, CLAMPED, n=8)
    f_step = _modes(fe_step, {}, CLAMPED, n=8)
    assert np.abs(f_step / f_param - 1).max() < 1.5e-3


@pytest.mark.mpi
def test_two_ranks_equal_serial(gearbox: dict, tmp_path: Path) -> None:
    """Read on rank 0 and distributed by model_to_mesh: the same seat weights (1e-12) and
    frequencies (1e-8) under mpirun -n 2 as in this (serial) process."""
    import json
    import os
    import subprocess
    import sys

    mpirun = shutil.which("mpirun")
    if mpirun is None:
        pytest.skip("mpirun missing")
    case = Path(__file__).with_name("fem_cad_mpi_case.py")
    out = tmp_path / "mpi2.json"
    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    cmd = [mpirun, "--allow-run-as-root", "--oversubscribe", "-n", "2", sys.executable,
           str(case), str(gearbox["dir"] / "gearbox.step"), str(out)]
    res = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr[-3000:]
    par = json.loads(out.read_text())
    seats = sorted(gearbox["seats"])
    w = [gearbox["weights"][s] for s in seats]
    f = _modes(gearbox["fe_mesh"], dict.fromkeys(seats, "distributing"), CLAMPED,
               SEAT_MASS, n=6)
    assert par["size"] == 2
    assert np.allclose(par["areas"], [x.area for x in w], rtol=1e-12, atol=0)
    assert np.allclose(par["centroids"], [x.centroid for x in w], rtol=0, atol=1e-14)
    assert np.abs(np.array(par["f"]) / f - 1).max() < 1e-8
