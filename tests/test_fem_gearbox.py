"""The parametric gearbox (geometry.gearbox, fem.gearbox): its groups, its bad input
refused before meshing naming the field, and its modes against CalculiX on the same mesh.

CalculiX check: the whole coarse two-stage gearbox (three shafts, housing; 9 393 tets),
feet clamped, each shaft clamped at its start face, each gear seat linked rigidly to a
node carrying the gear's mass (RBE2, ``*RIGID BODY``), each bore linked distributing to a
node with a 1 kg mass (RBE3, ``*DISTRIBUTING COUPLING``): DOLFINx (quadrature degree 2)
and CalculiX C3D10 give the first 12 frequencies (592-1257 Hz) within 1e-6: measured
2.8e-7, the 7 digits CalculiX prints; 17 s."""

from __future__ import annotations

import dataclasses
import shutil

import numpy as np
import pytest

pytest.importorskip("dolfinx")
gmsh = pytest.importorskip("gmsh")

import gearbox_support as gs  # noqa: E402
from mpi4py import MPI  # noqa: E402

import fem  # noqa: E402
from core.errors import InputError  # noqa: E402
from fem import calculix  # noqa: E402
from fem.gearbox import GearboxBearing, GearboxGear, build_gearbox_model  # noqa: E402
from geometry import build_gearbox, finalize_gmsh, gmsh_session, preset  # noqa: E402

pytestmark = pytest.mark.fem

COARSE = preset("coarse", size=0.02)
N_MODES = 12
BORE_MASS = 1.0  # kg on each bore node


@pytest.fixture(autouse=True)
def _gmsh_finalised():
    yield
    finalize_gmsh()


def _gears(params) -> list[tuple[str, str, float]]:
    """(seat group, node, mass kg) per gear: a steel disk of the tip radius, 20 mm bore."""
    out = []
    for s in params.shafts:
        for g in s.gears:
            m = 7850.0 * np.pi * (g.tip_radius ** 2 - s.seat_r ** 2) * g.width
            out.append((f"{s.name}/seat_{g.name}", f"{s.name}/gear_{g.name}", float(m)))
    return out


def test_groups_and_centres() -> None:
    p = gs.two_stage()
    with gmsh_session():
        m = build_gearbox(p, COARSE)
    for s in ("in", "mid", "out"):
        for e in ("a", "b"):
            assert m.groups[f"{s}/bearing_{e}"][0] == 2
            np.testing.assert_allclose(m.centres[f"housing/bore_{s}_{e}"],
                                       m.centres[f"{s}/bearing_{e}"], atol=1e-12)
        assert m.groups[f"shaft_{s}"][0] == 3
    np.testing.assert_allclose(m.centres["mid/gear_p2"], [0.084, 0.0, 0.105], atol=1e-12)
    assert m.groups["housing/feet"][0] == 2


def _shaft(p, i: int, **changes):
    shafts = list(p.shafts)
    shafts[i] = dataclasses.replace(shafts[i], **changes)
    return dataclasses.replace(p, shafts=tuple(shafts))


@pytest.mark.parametrize("change, field", [
    # a bearing outside its shaft
    (lambda p: _shaft(p, 0, bearings=(gs.JournalParams(0.155), p.shafts[0].bearings[1])),
     "shafts[0].bearings[0].position"),
    # a gear outside its shaft
    (lambda p: _shaft(p, 1, gears=(p.shafts[1].gears[0],
                                   gs.GearSeatParams("p2", 0.158, 0.025, gs.tip(19)))),
     "shafts[1].gears[1].position"),
    # two gears intersecting on one shaft
    (lambda p: _shaft(p, 1, gears=(p.shafts[1].gears[0],
                                   gs.GearSeatParams("p2", 0.070, 0.025, gs.tip(19)))),
     "shafts[1]"),
    # a bore that does not fit the housing (cuts a side wall)
    (lambda p: dataclasses.replace(p, housing=dataclasses.replace(
        p.housing, bearing_section=0.045)), "housing.bearing_section"),
    # a bearing out of its end wall
    (lambda p: _shaft(p, 2, bearings=(gs.JournalParams(0.040), p.shafts[2].bearings[1])),
     "shafts[2].bearings[0].position"),
    # a gear that hits another shaft
    (lambda p: _shaft(p, 0, gears=(gs.GearSeatParams("p1", 0.060, 0.020, 0.080),)),
     "shafts[0].gears[0].tip_radius"),
])
def test_bad_input_refused_before_meshing(change, field: str) -> None:
    p = change(gs.two_stage())
    with pytest.raises(InputError) as err:
        build_gearbox(p, COARSE)  # validated before gmsh starts
    assert err.value.field == field, str(err.value)
    assert str(err.value).startswith(field)


@pytest.mark.skipif(shutil.which("ccx") is None, reason="CalculiX (calculix-ccx) missing")
def test_gearbox_modes_match_calculix(tmp_path) -> None:
    p = gs.two_stage()
    mats = {"shaft_in": fem.STEEL, "shaft_mid": fem.STEEL, "shaft_out": fem.STEEL,
            "housing": fem.CAST_IRON}
    clamps = ["housing/feet", "in/start", "mid/start", "out/start"]
    gears = _gears(p)
    bores = [f"housing/bore_{s.name}_{e}" for s in p.shafts for e in ("a", "b")]
    comm = MPI.COMM_WORLD
    with gmsh_session():
        meshed = build_gearbox(p, COARSE) if comm.rank == 0 else None
        fe_mesh = fem.load_meshed_model(meshed, comm)
        weights = {b: fem.surface_weights(fe_mesh, b) for b in bores}
        f_ccx = None
        if comm.rank == 0:
            cps = [calculix.Coupling(seat, tuple(meshed.centres[node]), "rigid", mass=m)
                   for seat, node, m in gears]
            cps += [calculix.Coupling(b, tuple(weights[b].centroid), "distributing",
                                      weights=weights[b].by_gmsh_tag(), mass=BORE_MASS)
                    for b in bores]
            f_ccx = calculix.run_frequency(gmsh.model, mats, meshed.groups, clamps, N_MODES,
                                           tmp_path, couplings=cps)
    f_ccx = comm.bcast(f_ccx)
    spec = fem.ModelSpec(shared="first")
    for seat, node, m in gears:
        spec.add_node(node, fe_mesh.centres[node])
        spec.add_link(seat, node)
        spec.add_mass(node, fem.rigid_body_mass(m, [0.0, 0.0, 0.0]))
    for b in bores:
        spec.add_node(b, weights[b].centroid)
        spec.add_link(b, b, kind="distributing")
        spec.add_mass(b, fem.rigid_body_mass(BORE_MASS, [0.0, 0.0, 0.0]))
    for c in clamps:
        spec.add_clamp(c)
    model = fem.build_model(fe_mesh, mats, spec, quadrature_degree=2)
    f = fem.eigenfrequencies(model.K, model.M, N_MODES, sigma=0.0)
    rel = np.abs(f / f_ccx - 1)
    print(f"gearbox vs CalculiX: f = {np.round(f, 2).tolist()} Hz, max rel {rel.max():.2e}")
    assert rel.max() < 1e-6, (rel.max(), f, f_ccx)


def test_gearbox_fe_model_holds_the_train() -> None:
    """The assembled model (bearings, gear bodies, motor spring; no meshes): K's lowest
    modes are the free rotations of the shafts not held by the motor (mid, out: two zero
    modes), and every gear body has 6 free DOF."""
    p = gs.two_stage()
    comm = MPI.COMM_WORLD
    with gmsh_session():
        meshed = build_gearbox(p, COARSE) if comm.rank == 0 else None
        fe_mesh = fem.load_meshed_model(meshed, comm)
    gears = [GearboxGear(node, seat, fem.rigid_body_mass(m, [1e-4, 1e-4, 2e-4]))
             for seat, node, m in _gears(p)]
    bearings = [GearboxBearing(s.name, e, 2e8, 5e7) for s in p.shafts for e in ("a", "b")]
    from fem.gearbox import GearboxDrive, GearboxLoad, gearbox_materials
    model = build_gearbox_model(
        fe_mesh, gearbox_materials(fe_mesh.groups, fem.STEEL, fem.CAST_IRON), gears,
        bearings, GearboxDrive("in", 0.01, 2e4), [GearboxLoad("out", 0.5, 5e4)],
        G=np.zeros((6 * len(gears), 2)))
    assert model.gear_dofs.shape == (6 * len(gears),) and np.all(model.gear_dofs >= 0)
    f = fem.eigenfrequencies(model.K, model.M, 4, sigma=-1.0)
    assert np.sum(f < 1.0) == 2, f
    assert f[2] > 10.0, f
