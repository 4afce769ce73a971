"""A gearbox housing from an existing volume mesh (``[housing] source = "mesh"``): the
demo scene's parametric housing, written out as an Abaqus ``.inp`` in mm (ten-node
tetrahedra, no groups) and read back as the housing of the same scene, gives the same
model: its bores and feet are found on the mesh's boundary facets from the shafts' axes
and the feet plane, the shafts are meshed as before, and the ROM's coupled frequencies
equal the parametric model's (measured 9.6e-13). Bad input is refused naming the scene
key."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("dolfinx")

from core.errors import InputError  # noqa: E402
from machines import machine_for  # noqa: E402
from study import load_scene  # noqa: E402

pytestmark = pytest.mark.fem

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "scenes" / "two-stage-gearbox-demo.toml"
BASE = {"rom.n_cm": 10, "rom.n_check": 10}


def _housing_inp(msh: Path, out: Path) -> float:
    """Write the housing volume of a gearbox ``.msh`` as an Abaqus ``.inp`` in mm (its
    nodes only, renumbered from 0); returns the y of its feet group (m)."""
    import meshio

    m = meshio.read(msh)
    phys = m.cell_data_dict["gmsh:physical"]
    tets = m.cells_dict["tetra10"][phys["tetra10"] == m.field_data["housing"][0]]
    feet = m.cells_dict["triangle6"][phys["triangle6"] == m.field_data["housing/feet"][0]]
    used, inv = np.unique(tets, return_inverse=True)
    meshio.write(out, meshio.Mesh(m.points[used] * 1e3, [("tetra10", inv.reshape(tets.shape))]))
    ys = np.unique(np.round(m.points[feet.ravel(), 1], 12))
    assert ys.size == 1
    return float(ys[0])


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """The parametric demo gearbox (mesh, FE, ROM of 10 component modes), its housing as
    an ``.inp`` and the same scene with that file as its housing, built alike."""
    tmp = tmp_path_factory.mktemp("mesh_housing")
    par = machine_for(load_scene(SCENE, BASE))
    a = tmp / "parametric"
    a.mkdir()
    par.build_mesh(a)
    par.build_rom(par.build_fe_model(a), a)
    inp = tmp / "housing.inp"
    feet_y = _housing_inp(a / par.mesh_file, inp)
    radii = [par.geometry.bore_radius(s) * 1e3 for s in par.geometry.shafts]
    over = {**BASE, "housing.source": "mesh", "housing.file": str(inp),
            "housing.bore_radii_mm": radii, "housing.feet_y_mm": feet_y * 1e3}
    mesh = machine_for(load_scene(SCENE, over))
    b = tmp / "mesh"
    b.mkdir()
    mesh.build_mesh(b)
    mesh.build_rom(mesh.build_fe_model(b), b)
    return par.load_rom(a), mesh.load_rom(b), over, tmp


def test_the_housing_read_from_an_inp_gives_the_parametric_model(built):
    rom_par, rom_mesh, _, _ = built
    f0, f1 = (np.asarray(r.frequencies_hz) for r in (rom_par, rom_mesh))
    assert f0.shape == f1.shape and f0[0] > 10.0
    assert np.max(np.abs(f1 / f0 - 1.0)) < 1e-9
    np.testing.assert_allclose(rom_mesh.mesh_energy, rom_par.mesh_energy, rtol=1e-7,
                               atol=1e-9)


def test_the_mesh_file_is_part_of_the_mesh_stage_key(built, tmp_path):
    """The mesh stage's key hashes the file's content, not its name."""
    over = built[2]
    copy = tmp_path / "renamed.inp"
    copy.write_bytes(Path(over["housing.file"]).read_bytes())
    key = machine_for(load_scene(SCENE, over)).stage_inputs("mesh")["cad_sha256"]
    moved = machine_for(load_scene(SCENE, {**over, "housing.file": str(copy)}))
    assert moved.stage_inputs("mesh")["cad_sha256"] == key
    copy.write_text(copy.read_text() + "** edited\n")      # an Abaqus comment line
    assert machine_for(load_scene(SCENE, {**over, "housing.file": str(copy)})) \
        .stage_inputs("mesh")["cad_sha256"] != key


@pytest.mark.parametrize("edit,field,words", [
    ({"housing.bore_radii_mm": [20.0, 28.5, 33.5]}, "shafts[0].bearings",
     ("no bore facets of radius 0.02 m",)),
    ({"housing.feet_y_mm": -80.0}, "housing.feet_y", ("no boundary facet",)),
    ({"housing.file": "missing.inp"}, "housing.file", ("missing.inp",)),
    ({"housing.first_order": "maybe"}, "housing.first_order", ("'refuse', 'upgrade'",)),
])
def test_bad_mesh_housing_input_is_refused_naming_the_key(built, tmp_path, edit, field,
                                                          words):
    _, _, over, _ = built
    with pytest.raises((InputError, ValueError)) as err:
        m = machine_for(load_scene(SCENE, {**over, **edit}))
        m.build_mesh(tmp_path)
    msg = str(err.value)
    assert field in msg, msg
    for w in words:
        assert w in msg, msg
