"""The FE gearbox machine (machines.gearbox): its description from the train sections,
its FE model's statics against the torque path, its bad input before meshing."""

from __future__ import annotations

import dataclasses
from fractions import Fraction
from pathlib import Path

import gearbox_support as gs
import numpy as np
import pytest

from core.errors import InputError
from machines import check_contract
from machines.gearbox import Gearbox

ROOT = Path(__file__).resolve().parents[1]


def test_description_of_the_two_stage_gearbox() -> None:
    m = check_contract(Gearbox(gs.two_stage_scene()))
    ratios = {s.name: s.speed_ratio for s in m.shafts}
    assert ratios == {"in": 1, "mid": Fraction(23, 61), "out": Fraction(23 * 19, 61 * 67)}
    assert 1 / float(ratios["out"]) == pytest.approx(9.3524, abs=1e-4)
    assert [b.node for b in m.gear_bodies] == ["in/gear_p1", "mid/gear_w1", "mid/gear_p2",
                                               "out/gear_w2"]
    assert [mm.frequency_ratio for mm in m.gear_meshes] == [23, Fraction(23 * 19, 61)]
    G = m.directions()
    assert G.shape == (24, 2)
    # the static loads: T / r_b1 and T (61/23) / r_b(p2)
    rb = {b.name: b.base_radius for b in m.gear_bodies}
    np.testing.assert_allclose(m.static_mesh_loads(),
                               [50.0 / rb["p1"], 50.0 * 61 / 23 / rb["p2"]], rtol=1e-12)
    m.check()
    box = m.geometry.box()
    assert box.bores[1].x == pytest.approx(0.084, abs=1e-12)
    assert box.bores[2].x == pytest.approx(0.170, abs=1e-12)


@pytest.mark.parametrize("fe, field", [
    ({"housing": {"bearing_section_mm": 45.0}}, "housing.bearing_section"),
    ({"housing": {"source": "cadd"}}, None),
    ({"housing": {"walls_mm": 3.0}}, None),
])
def test_bad_fe_sections_refused(fe: dict, field: str | None) -> None:
    m = Gearbox(gs.two_stage_scene(**fe))
    with pytest.raises(InputError) as err:
        m.check()
    if field:
        assert err.value.field == field, str(err.value)


def test_bearing_outside_its_shaft_refused() -> None:
    s = gs.two_stage_scene()
    sh = list(s.shafts)
    sh[1] = dataclasses.replace(sh[1], bearings=(gs.Bearing(0.020), gs.Bearing(0.158)))
    with pytest.raises(InputError, match=r"^shafts\[1\]\.bearings\[1\]\.position"):
        Gearbox(dataclasses.replace(s, shafts=tuple(sh))).check()


@pytest.mark.fem
def test_fe_statics_carry_the_torque_path(tmp_path) -> None:
    """The FE model with every mesh as its mean spring k̄ g gᵀ under the load torque: the
    mesh forces k̄ gᵀ q equal the layout's static loads (torque balance on each shaft;
    measured within 1e-9)."""
    pytest.importorskip("dolfinx")
    m = Gearbox(gs.two_stage_scene())
    m.build_mesh(tmp_path)
    model, km, _, q = _statics(m, tmp_path)
    qc = q.getArray()[model.gear_dofs] if q.getComm().size == 1 else None
    forces = km * (model.G.T @ qc)
    np.testing.assert_allclose(forces, m.static_mesh_loads(), rtol=1e-9)


@pytest.mark.fem
def test_cad_housing_scene_finds_the_bores_from_the_shafts(tmp_path) -> None:
    """scenes/two-stage-gearbox-cad.toml with the STEP housing of
    scripts/gearbox_housing_step.py: the six bores found by the shafts' axes (radius
    measured = given), the feet by their plane; the mesh holds every group the FE model
    needs."""
    pytest.importorskip("dolfinx")
    import json

    import cad_support as cs

    from machines import machine_for
    from study import load_scene

    step = cs.gearbox_script().write(tmp_path / "housing.step")
    scene = load_scene("scenes/two-stage-gearbox-cad.toml", {"housing.file": str(step)})
    m = machine_for(scene)
    m.check()
    m.build_mesh(tmp_path)
    info = json.loads((tmp_path / "mesh.json").read_text())
    for s in ("input", "intermediate", "output"):
        for e in ("a", "b"):
            assert f"housing/bore_{s}_{e}" in info["groups"]
            assert f"{s}/bearing_{e}" in info["groups"]
            np.testing.assert_allclose(info["centres"][f"housing/bore_{s}_{e}"],
                                       info["centres"][f"{s}/bearing_{e}"], atol=1e-9)
    assert "housing/feet" in info["groups"]


@pytest.mark.parametrize("path", ["scenes/two-stage-gearbox.toml",
                                  "scenes/two-stage-gearbox-demo.toml",
                                  "scenes/two-stage-gearbox-cad.toml"])
def test_shipped_gearbox_scenes_load(path: str) -> None:
    """The shipped scenes load, their machine checks them (geometry before meshing), the
    overall ratio is 4087/437 = 9.35 and the static loads follow the torque path."""
    pytest.importorskip("gmsh")
    from machines import machine_for
    from study import load_scene

    m = machine_for(load_scene(path))
    m.check()
    assert m.kind == "gearbox"
    assert 1 / m.shaft("output").speed_ratio == Fraction(4087, 437)
    np.testing.assert_allclose(m.static_mesh_loads(), [2313.43, 7427.33], rtol=1e-5)
    assert m.radiating_part == "housing"


def _statics(m, folder):
    """The FE model with every mesh as its mean spring k̄ g gᵀ under the load torques:
    (model, k̄, f, q) with K q = f (one LU)."""
    from petsc4py import PETSc

    model = m.build_fe_model(folder)
    K = model.K.copy()
    km = np.asarray(m.mean_mesh_stiffness())
    idx = model.gear_dofs.astype(PETSc.IntType)
    K.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, False)
    K.setValues(idx, idx, (model.G * km) @ model.G.T, addv=PETSc.InsertMode.ADD_VALUES)
    K.assemble()
    f = K.createVecLeft()
    for node, t in m.load_torques().items():
        dofs = model.node_dofs[node]
        for j in range(6):
            if dofs[j] >= 0 and t[j]:
                f.setValue(int(dofs[j]), t[j], addv=PETSc.InsertMode.ADD_VALUES)
    f.assemble()
    ksp = PETSc.KSP().create(K.getComm())
    ksp.setOperators(K)
    ksp.setType("preonly")
    ksp.getPC().setType("lu")
    q = K.createVecRight()
    ksp.solve(f, q)
    return model, km, f, q


def _compliance(m, folder) -> float:
    """fᵀ K⁻¹ f of :func:`_statics`."""
    _, _, f, q = _statics(m, folder)
    return float(f.dot(q))


def test_bore_link_per_bearing_reaches_the_fe_parts() -> None:
    """``[[shafts.bearings]] bore_link``/``journal_link``: 'distributing' on every
    bearing gives the FE parts of ``[housing] bore_link = "distributing"``; 'housing'
    (the default) takes [housing]'s; a bad value names the bearing."""
    from study import load_scene
    from study.scene.errors import SceneError

    scene = ROOT / "scenes" / "two-stage-gearbox-demo.toml"
    base = load_scene(scene)
    every = {f"shafts.{s.name}.bearings[{j}].bore_link": "distributing"
             for s in base.shafts for j in range(len(s.bearings))}
    parts = Gearbox(load_scene(scene, every)).fe_parts()[1]
    assert parts == Gearbox(load_scene(scene, {"housing.bore_link": "distributing"})
                            ).fe_parts()[1]
    one = Gearbox(load_scene(scene, {"shafts.output.bearings[1].journal_link":
                                     "distributing"})).fe_parts()[1]
    assert [(b.bore_link, b.journal_link) for b in one] == [("rigid", "rigid")] * 5 + \
        [("rigid", "distributing")]
    with pytest.raises(SceneError, match=r"shafts\[2\].bearings\[1\].bore_link = 'glued'"):
        load_scene(scene, {"shafts.output.bearings[1].bore_link": "glued"})


@pytest.mark.fem
def test_one_distributing_bore_softens_between_rigid_and_all(tmp_path) -> None:
    """The FE model with one bore linked 'distributing' (RBE3-type: no stiffness added):
    its compliance under the load torques lies between the all-rigid model's and the
    all-distributing one's."""
    pytest.importorskip("dolfinx")
    from study import load_scene

    scene = ROOT / "scenes" / "two-stage-gearbox-demo.toml"
    rigid = Gearbox(load_scene(scene))
    rigid.build_mesh(tmp_path)                 # the links do not change the mesh
    c = {name: _compliance(Gearbox(load_scene(scene, over)), tmp_path) for name, over in
         (("rigid", {}), ("one", {"shafts.output.bearings[1].bore_link": "distributing"}),
          ("every", {"housing.bore_link": "distributing"}))}
    assert c["rigid"] * (1 + 1e-6) < c["one"] < c["every"] * (1 - 1e-6), c
