"""The machine contract and registry (machines/): lookup by scene kind, refusals, the
lumped gear pair and the pump against the constants the pipeline had before them."""
from __future__ import annotations

import subprocess
import sys
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest

import machines
from core.errors import InputError
from gears.pair import line_of_action_vector, pair_frame
from machines import (
    FEMachine,
    GearBody,
    GearMeshSpec,
    LinearModel,
    LumpedGearPair,
    LumpedMachine,
    Part,
    Pump,
    Shaft,
    check_contract,
    machine_class,
    machine_for,
)

ROOT = Path(__file__).resolve().parents[1]
SDOF = ROOT / "scenes" / "gear-pair-sdof.toml"
PUMP = ROOT / "scenes" / "pump.toml"


@pytest.fixture(scope="module")
def sdof_scene():
    from study.scene import load_scene

    return load_scene(SDOF)


@pytest.fixture(scope="module")
def pump_scene():
    pytest.importorskip("dolfinx")
    from study.scene import load_scene

    return load_scene(PUMP)


# ------------------------------------------------------------------ registry

def test_registry_picks_the_machine_of_the_scene_kind(sdof_scene, pump_scene):
    assert {"fe", "lumped", "train"} <= set(machines.kinds())
    assert machines.models("lumped") == ("sdof",)
    assert machine_class("fe") is Pump
    assert machine_class("lumped") is machine_class("lumped", "sdof") is LumpedGearPair
    assert type(machine_for(sdof_scene)) is LumpedGearPair
    pump = machine_for(pump_scene)
    assert type(pump) is Pump and isinstance(pump, FEMachine)
    assert pump.stages == ("mesh", "fe", "rom") and pump.linear_stage == "rom"
    lumped = machine_for(sdof_scene)
    assert isinstance(lumped, LumpedMachine)
    assert lumped.stages == () and lumped.linear_stage == "linear"


def test_the_scene_schema_offers_the_registered_kinds():
    from study.scene.schema import SCHEMA

    assert set(SCHEMA["scene"]["kind"].choices) == set(machines.kinds())
    assert set(SCHEMA["lumped"]["model"].choices) == set(machines.models("lumped"))


def test_unknown_kind_or_model_is_refused_naming_the_field_and_the_known_ones():
    known = ", ".join(repr(k) for k in machines.kinds())
    with pytest.raises(InputError, match=r"^scene\.kind = 'zzz': unknown machine kind; "
                       rf"known: {known}$") as err:
        machine_class("zzz")
    assert err.value.field == "scene.kind"
    with pytest.raises(InputError, match=r"did you mean 'lumped'\?"):
        machine_class("lumpd")
    with pytest.raises(InputError, match=r"^lumped\.model = 'xyz': unknown lumped model; "
                       r"known: 'sdof'$"):
        machine_class("lumped", "xyz")


def test_register_refuses_a_second_class_for_one_kind(monkeypatch):
    monkeypatch.setattr("machines.registry._REGISTRY", {})

    class One(LumpedGearPair):
        kind = "test-kind"
        model = None

    class Other(One):
        pass

    assert machines.register(One) is One and machine_class("test-kind") is One
    with pytest.raises(TypeError, match="already registered"):
        machines.register(Other)
    assert machines.kinds() == ("test-kind",)


def test_a_lumped_scene_imports_no_fe_stack():
    """machines (every machine module registered) and the lumped machine's linear model
    load neither dolfinx, gmsh, petsc4py, slepc4py nor mpi4py."""
    code = ("import sys\n"
            "from study.scene import load_scene\n"
            "import machines\n"
            f"m = machines.machine_for(load_scene({str(SDOF)!r}))\n"
            "lin = m.linear_model()\n"
            "assert lin.G.shape == (1, 1)\n"
            "bad = [x for x in ('dolfinx', 'gmsh', 'petsc4py', 'slepc4py', 'mpi4py', 'ufl') "
            "if x in sys.modules]\n"
            "print('FE_MODULES', bad)\n")
    p = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True,
                       text=True, timeout=120, env={"PYTHONPATH": str(ROOT), "PATH": ""})
    assert p.returncode == 0, p.stderr[-2000:]
    assert "FE_MODULES []" in p.stdout


# ------------------------------------------------------------------ the two machines

def test_lumped_gear_pair_is_the_sdof_model(sdof_scene):
    from machines.lumped import sdof_forcing, sdof_matrices

    m = machine_for(sdof_scene)
    lin = m.linear_model()
    M, C, K, G = sdof_matrices(sdof_scene)
    assert isinstance(lin, LinearModel) and lin.n_dof == 1
    for a, b in ((lin.M, M), (lin.C, C), (lin.K, K), (lin.G, G.reshape(1, 1))):
        np.testing.assert_array_equal(a, b)
    assert lin.constant.keys() == sdof_forcing(sdof_scene).keys() and lin.omega_squared == {}
    assert m.static_mesh_loads() == (sdof_scene.static_load,)
    assert m.mean_mesh_stiffness() == (sdof_scene.mesh_stiffness.mean,)
    assert m.parts == () and m.radiating_part is None
    assert m.stage_inputs("linear")["mean_stiffness"] == sdof_scene.mesh_stiffness.mean
    assert m.stage_code("linear") == ("machines.lumped",)
    with pytest.raises(ValueError, match="stage = 'rom'"):
        m.stage_inputs("rom")


#: Today's (pre-machines) constants of study/fe_stages.py.
NODE_NAMES = tuple(f"{s}/station_{k}" for s in ("in", "out") for k in range(1, 7)) + \
    ("in/coupling", "out/coupling", "in/gear", "out/gear")


def test_pump_bodies_meshes_and_load_nodes_are_the_constants_it_had(pump_scene):
    m = machine_for(pump_scene)
    g = pump_scene.gear
    assert [(s.name, s.speed_ratio) for s in m.shafts] == [("in", 1), ("out", 1)]
    assert m.reference_shaft.name == "in"
    assert [(b.name, b.shaft, b.node, b.teeth, b.base_radius) for b in m.gear_bodies] == \
        [("in/gear", "in", "in/gear", 76, g.base_radius),
         ("out/gear", "out", "out/gear", 76, g.base_radius)]
    for b in m.gear_bodies:
        np.testing.assert_array_equal(b.frame, pair_frame(g.pressure_angle))
    (mesh,) = m.gear_meshes
    assert mesh.bodies == ("in/gear", "out/gear") and mesh.teeth == 76
    assert mesh.speed_ratio == 1 and mesh.frequency_ratio == Fraction(76)
    G = line_of_action_vector(g.pressure_angle, g.helix_angle, g.base_radius, g.base_radius)
    np.testing.assert_array_equal(mesh.vector, G)
    np.testing.assert_array_equal(m.directions(), G[:, None])
    assert m.load_nodes == NODE_NAMES
    assert [p.name for p in m.parts] == ["shaft_in", "shaft_out", "housing"]
    assert m.radiating_part == "housing"
    assert m.mesh_file == "pump.msh" and m.mesh_size == pytest.approx(0.027)
    assert m.static_mesh_loads() == (pump_scene.static_load,)
    from reduction import gear_body_dof_names

    assert gear_body_dof_names(len(m.gear_bodies)) == (
        "u1", "u2", "u3", "theta1", "theta2", "theta3",
        "u4", "u5", "u6", "theta4", "theta5", "theta6")


def test_pump_stage_keys_hash_the_inputs_they_hashed_before(pump_scene, tmp_path):
    """The mesh/fe/rom keys hash the same scene values as before the machines (only the
    code modules differ: the machine's instead of study/fe_stages.py)."""
    import dataclasses

    from study.pipeline import Pipeline
    from study.pipeline.cache import source_hash, stage_key

    s = pump_scene
    old_mesh = {"geometry": s.fe.get("geometry", {}), "mesh": s.fe.get("mesh", {}),
                "gear": {"face_width": s.gear.face_width, "tip_radius": s.gear.tip_radius,
                         "centre_distance": s.gear.centre_distance}}
    old_fe = {**{k: s.fe.get(k, {}) for k in ("materials", "bearings", "drive")},
              "gear": {"base_radius": s.gear.base_radius,
                       "pressure_angle": s.gear.pressure_angle,
                       "helix_angle": s.gear.helix_angle, "face_width": s.gear.face_width}}
    m = machine_for(s)
    assert m.stage_inputs("mesh") == old_mesh
    assert m.stage_inputs("fe") == old_fe
    # the rom stage hashes what it builds from: the check frequency only when it sets
    # the check (no n_check), not the cut-off factor nor the auto flag themselves
    rom_in = {k: v for k, v in dataclasses.asdict(s.rom).items()
              if k not in ("cutoff_factor", "auto") and (k != "check_hz" or s.rom.n_check is None)}
    assert m.stage_inputs("rom") == {"rom": rom_in}
    pl = Pipeline(s, tmp_path)
    mesh_key = stage_key("mesh", old_mesh, source_hash(*m.stage_code("mesh")))
    assert pl.mesh_key() == mesh_key
    fe_key = stage_key("fe", {"mesh": mesh_key, **old_fe}, source_hash(*m.stage_code("fe")))
    assert pl.fe_key() == fe_key
    assert pl.rom_key() == stage_key("rom", {"fe": fe_key, "rom": rom_in},
                                     source_hash(*m.stage_code("rom")))


def test_pump_fe_sections_are_refused_as_scene_errors(pump_scene):
    """The machine refuses a bad FE key (core InputError); the scene loader reports it as
    a SceneError with the same message (exit code 2)."""
    from machines.pump import FEParameterError, fe_parameters
    from study.scene import load_scene
    from study.scene.errors import SceneError

    with pytest.raises(FEParameterError, match=r"^materials\.housing_EE: unknown key "
                       r"\(did you mean 'housing_E'\?\)"):
        fe_parameters({"materials": {"housing_EE": 1.0}}, pump_scene.gear)
    with pytest.raises(SceneError, match=r"^materials\.housing_EE: unknown key"):
        load_scene(PUMP, {"materials.housing_EE": 1.0})
    with pytest.raises(SceneError, match=r"^FE parameters: materials\.housing_nu = 0\.7"):
        load_scene(PUMP, {"materials.housing_nu": 0.7})


# ------------------------------------------------------------------ the contract

class ThreeGears(LumpedMachine):
    """A test machine: gears A (in), B (idler) and C (out), meshes A-B and B-C."""

    kind = "test-three"

    def __init__(self, scene=None, teeth=(20, 40, 30), shafts=None) -> None:
        super().__init__(scene)
        self.teeth = teeth
        z = teeth
        self._shafts = shafts or (Shaft("a", Fraction(1)), Shaft("b", Fraction(z[0], z[1])),
                                  Shaft("c", Fraction(z[0], z[2])))

    @property
    def shafts(self):
        return self._shafts

    @property
    def gear_bodies(self):
        return tuple(GearBody(n, s, n, z, 0.01 * z, np.eye(3))
                     for n, s, z in zip("ABC", "abc", self.teeth, strict=True))

    @property
    def gear_meshes(self):
        z = self.teeth
        return (GearMeshSpec("A-B", ("A", "B"), line_of_action_vector(0.35, 0, 0.2, 0.4),
                             z[0], Fraction(1)),
                GearMeshSpec("B-C", ("B", "C"), line_of_action_vector(0.35, 0, 0.4, 0.3),
                             z[1], Fraction(z[0], z[1])))

    load_nodes = ("A",)
    parts = (Part("case", radiates=True),)

    def static_mesh_loads(self):
        return (10.0, 10.0)

    def mean_mesh_stiffness(self):
        return (1e8, 2e8)

    def stage_inputs(self, stage):
        return {}

    def stage_code(self, stage):
        return ()

    def linear_model(self):
        raise NotImplementedError


def test_directions_place_each_mesh_on_its_two_bodies():
    m = check_contract(ThreeGears())
    G = m.directions()
    assert G.shape == (18, 2)
    v1, v2 = (s.vector for s in m.gear_meshes)
    np.testing.assert_array_equal(G[:12, 0], v1)
    np.testing.assert_array_equal(G[12:, 0], 0.0)
    np.testing.assert_array_equal(G[6:, 1], v2)
    np.testing.assert_array_equal(G[:6, 1], 0.0)
    assert [s.frequency_ratio for s in m.gear_meshes] == [20, 20]
    assert m.radiating_part == "case" and m.body("B").shaft == "b"
    with pytest.raises(InputError, match="unknown gear body; known: 'A', 'B', 'C'"):
        m.body("D")


def test_contract_refuses_inconsistent_kinematics_and_names():
    with pytest.raises(InputError, match=r"mesh frequencies differ: 20 x 1 != 40 x 1"):
        check_contract(ThreeGears(shafts=(Shaft("a", Fraction(1)), Shaft("b", Fraction(1)),
                                          Shaft("c", Fraction(2, 3)))))
    with pytest.raises(InputError, match="one shaft must turn at the reference speed"):
        check_contract(ThreeGears(shafts=(Shaft("a", Fraction(2)), Shaft("b", Fraction(1, 2)),
                                          Shaft("c", Fraction(4, 3)))))
    with pytest.raises(InputError, match=r"gear_bodies\['A'\]\.shaft = 'a': unknown shaft"):
        check_contract(ThreeGears(shafts=(Shaft("x", Fraction(1)),)))
