"""Existing volume meshes as parts (geometry.meshfile, meshsurface, import_mesh): gmsh
.msh, Abaqus .inp and NASTRAN .bdf read to the very same 10-node mesh, node orders
matched by position, 4-node meshes refused or upgraded, seats and mounts found on the
boundary facets as on the CAD faces they were meshed from."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

gmsh = pytest.importorskip("gmsh")
meshio = pytest.importorskip("meshio")

import cad_support as cs  # noqa: E402

from core.errors import InputError  # noqa: E402
from geometry import (  # noqa: E402
    BearingSeat,
    CadPart,
    MeshPart,
    Mount,
    finalize_gmsh,
    gmsh_session,
    import_cad,
    import_mesh,
    preset,
    write_msh,
)
from geometry.meshfile import (  # noqa: E402
    order_mid_nodes,
    read_volume_mesh,
    upgrade_to_tet10,
)
from geometry.meshsurface import boundary_facets, facet_areas  # noqa: E402

pytestmark = pytest.mark.fem


@pytest.fixture(autouse=True)
def _gmsh_finalised():
    """A builder called outside a session leaves gmsh initialised: close it after each
    test, so that no model outlives it."""
    yield
    finalize_gmsh()

# gmsh 10-node tetrahedron -> meshio/VTK/Abaqus/NASTRAN order (last two mid nodes swapped)
GMSH_TO_VTK = [0, 1, 2, 3, 4, 5, 6, 7, 9, 8]


def _arrays() -> tuple[np.ndarray, np.ndarray]:
    """Nodes (0-based by tag) and 10-node tets of the live model."""
    tags, xyz, _ = gmsh.model.mesh.getNodes()
    order = np.argsort(tags)
    nodes = np.asarray(xyz).reshape(-1, 3)[order]
    _, enodes = gmsh.model.mesh.getElementsByType(11)
    return nodes, np.asarray(enodes, dtype=np.int64).reshape(-1, 10) - 1


@pytest.fixture(scope="module")
def source(tmp_path_factory: pytest.TempPathFactory) -> dict:
    """The pump housing from STEP, meshed coarse: its .msh, groups, arrays, facet counts."""
    d = tmp_path_factory.mktemp("meshes")
    step = cs.write_pump_housing_step(d / "pump_housing.step")
    with gmsh_session():
        model = import_cad([CadPart("housing", step, unit="mm")], cs.pump_seats(),
                           [cs.pump_feet()], preset("coarse"))
        write_msh(d / "housing.msh")
        nodes, tets = _arrays()
        counts = {name: sum(len(gmsh.model.mesh.getElements(2, int(e))[1][0])
                            for e in gmsh.model.getEntitiesForPhysicalGroup(dim, tag))
                  for name, (dim, tag) in model.groups.items() if dim == 2}
    return {"dir": d, "msh": d / "housing.msh", "nodes": nodes, "tets": tets,
            "counts": counts, "model": model}


def _import(parts, seats=(), mounts=()):
    with gmsh_session():
        return import_mesh(parts, seats, mounts)


def test_msh_seats_and_feet_match_the_cad_faces(source: dict) -> None:
    """The seats by axis and the feet by plane hold exactly the facets of the CAD groups
    the mesh was made with; the measured radius is the bore's."""
    model = _import(MeshPart("housing", source["msh"], unit="m"), cs.pump_seats(),
                    [cs.pump_feet()])
    for seat in cs.pump_seats():
        rep = model.seats[seat.name]
        assert rep.found == [f"{source['counts'][rep.group]} facets"]
        assert rep.radius_measured == pytest.approx(0.026, abs=1e-12)
        assert rep.area == pytest.approx(source["model"].seats[seat.name].area, rel=2e-3)
    assert model.mounts["feet"].found == [f"{source['counts']['housing/feet']} facets"]
    assert model.mounts["feet"].area == pytest.approx(4 * 0.035 * 0.030, rel=1e-12)
    assert model.quality.n_elements == len(source["tets"])
    assert model.part_volumes["housing"] == pytest.approx(
        source["model"].part_volumes["housing"], rel=2e-3)


def test_seats_by_group_name_fit_their_axis(source: dict) -> None:
    """By the .msh group name, without a point: axis and centre fitted (the bore middle);
    with a wrong radius given: refused with the measured one."""
    seats = [BearingSeat("in_a", group="housing/bore_in_a"),
             BearingSeat("out_b", group="housing/bore_out_b", point=(0.1, 0.0, 0.162),
                         radius=0.026)]
    model = _import(MeshPart("housing", source["msh"], unit="m"), seats,
                    [Mount("feet", group="housing/feet")])
    a = model.seats["in_a"]  # axis from the facet normals, refined on the nodes: 1e-14
    assert a.radius_measured == pytest.approx(0.026, abs=1e-12)
    assert np.allclose(a.centre, [0.0, 0.0, -0.002], atol=1e-12)
    assert abs(abs(a.axis[2]) - 1) < 1e-12
    assert model.seats["out_b"].axis_offset < 1e-12
    bad = [BearingSeat("in_a", group="housing/bore_in_a", radius=0.025)]
    with pytest.raises(InputError, match=r"seats\[0\].radius = 0.025 m: group "
                       "'housing/bore_in_a' is a cylinder of radius 0.026"):
        _import(MeshPart("housing", source["msh"], unit="m"), bad)
    with pytest.raises(InputError, match=r"mounts\[0\].group = 'foot': no face set.*"
                       "'housing/feet'"):
        _import(MeshPart("housing", source["msh"], unit="m"), [],
                [Mount("feet", group="foot")])


def test_mesh_seat_refused_with_the_nearest_patches(source: dict) -> None:
    seat = cs.pump_seats()[0]
    wrong = BearingSeat("in_a", point=seat.point, direction=seat.direction, radius=0.030,
                        width=seat.width)
    with pytest.raises(InputError) as err:
        _import(MeshPart("housing", source["msh"], unit="m"), [wrong])
    msg = str(err.value)
    assert "no bore facets of radius 0.03 m" in msg
    assert "nearest candidates: patch" in msg and "cylinder of radius 26.000 mm, its axis " \
        "0.000 mm from the point" in msg


@pytest.mark.parametrize("fmt, suffix, unit, scale", [("abaqus", ".inp", "mm", 1e3),
                                                      ("nastran", ".bdf", "m", 1.0)])
def test_abaqus_and_nastran_give_the_same_mesh(source: dict, fmt: str, suffix: str,
                                               unit: str, scale: float) -> None:
    """Written by meshio in its (VTK) node order, in mm for Abaqus: read back to the very
    nodes (m) and gmsh-ordered tetrahedra of the source; an Abaqus node set is a seat."""
    nodes, tets = source["nodes"], source["tets"]
    if fmt == "nastran":  # meshio's NASTRAN writer fails on 2-digit exponents
        nodes = np.round(nodes, 9)
    bore = np.flatnonzero(np.isclose(np.hypot(nodes[:, 0], nodes[:, 1]), 0.026, atol=1e-9)
                          & (nodes[:, 2] < 0.01))
    path = source["dir"] / f"housing{suffix}"
    mesh = meshio.Mesh(nodes * scale, [("tetra10", tets[:, GMSH_TO_VTK])],
                       point_sets={"BORE_IN_A": bore} if fmt == "abaqus" else None)
    kw = {"point_format": "free"} if fmt == "nastran" else {}  # fixed fields: 8 digits
    meshio.write(str(path), mesh, file_format=fmt, **kw)
    vm = read_volume_mesh(MeshPart("housing", path, unit=unit))
    assert np.allclose(vm.nodes, nodes, rtol=1e-12, atol=1e-15)
    assert np.array_equal(vm.tets, tets)
    assert any("put in gmsh order" in n for n in vm.notes)
    if fmt == "abaqus":
        model = _import(MeshPart("housing", path, unit=unit),
                        [BearingSeat("in_a", group="BORE_IN_A")])
        assert model.seats["in_a"].found == [
            f"{source['counts']['housing/bore_in_a']} facets"]
        assert model.seats["in_a"].radius_measured == pytest.approx(0.026, abs=1e-12)


def test_first_order_refused_or_upgraded(tmp_path: Path, source: dict) -> None:
    nodes, tets = source["nodes"], source["tets"]
    used = np.unique(tets[:, :4])
    new = np.full(len(nodes), -1)
    new[used] = np.arange(used.size)
    path = tmp_path / "linear.inp"
    meshio.write(str(path), meshio.Mesh(nodes[used], [("tetra", new[tets[:, :4]])]),
                 file_format="abaqus")
    with pytest.raises(InputError, match=r"parts\[0\].first_order = 'refuse': linear.inp "
                       "holds 4-node tetrahedra"):
        read_volume_mesh(MeshPart("housing", path, unit="m"), "parts[0]")
    vm = read_volume_mesh(MeshPart("housing", path, unit="m", first_order="upgrade"))
    assert vm.tets.shape == (len(tets), 10)
    assert "upgraded to 10 nodes on straight edges" in vm.notes[0]
    x = vm.nodes[vm.tets]
    ref = 0.5 * (x[:, [0, 1, 2, 3, 3, 3]] + x[:, [1, 2, 0, 0, 2, 1]])
    assert np.allclose(x[:, 4:], ref, rtol=0, atol=1e-15)  # straight edges, gmsh order
    # the upgraded mesh keeps its volume, and its seats are found (corners on the bore)
    model = _import(MeshPart("housing", path, unit="m", first_order="upgrade"),
                    cs.pump_seats()[:1])
    assert model.seats["in_a"].radius_measured == pytest.approx(0.026, rel=2e-2)


def test_other_elements_and_bad_files_are_refused(tmp_path: Path) -> None:
    hexa = tmp_path / "hex.inp"
    pts = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1],
                    [1, 1, 1], [0, 1, 1]], dtype=float) * 0.1
    meshio.write(str(hexa), meshio.Mesh(pts, [("hexahedron", [list(range(8))])]),
                 file_format="abaqus")
    with pytest.raises(InputError, match="holds hexahedron elements: only tetrahedra"):
        read_volume_mesh(MeshPart("housing", hexa, unit="m"))
    junk = tmp_path / "junk.msh"
    junk.write_text("not a mesh\n")
    with pytest.raises(InputError, match=r"part.path = .*gmsh cannot read it"):
        read_volume_mesh(MeshPart("housing", junk, unit="m"))
    with pytest.raises(InputError, match=r"part.first_order = 'maybe'"):
        MeshPart("housing", hexa, first_order="maybe").validate()


def test_mid_nodes_matched_to_their_edges() -> None:
    """Any permutation of the six mid nodes is put back in gmsh's edge order."""
    rng = np.random.default_rng(3)
    corners = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    edges = [(0, 1), (1, 2), (2, 0), (3, 0), (3, 2), (3, 1)]
    mids = np.array([0.5 * (corners[a] + corners[b]) for a, b in edges])
    nodes = np.vstack([corners, mids])
    tets = np.vstack([np.r_[0:4, 4 + rng.permutation(6)] for _ in range(5)])
    out, n = order_mid_nodes(nodes, tets)
    assert n == 5 and np.array_equal(out, np.tile(np.arange(10), (5, 1)))
    bad = tets.copy()
    bad[0, 4] = 0  # a corner as mid node
    with pytest.raises(ValueError, match="element 0: its mid-edge nodes"):
        order_mid_nodes(nodes, bad)


def test_boundary_of_a_box_and_its_areas() -> None:
    """Upgraded tetrahedra of a box: the boundary facets face outwards, their areas add
    up to the box's."""
    with gmsh_session():
        gmsh.model.add("box")
        gmsh.model.occ.addBox(0, 0, 0, 0.1, 0.2, 0.3)
        gmsh.model.occ.synchronize()
        gmsh.option.setNumber("Mesh.MeshSizeMax", 0.08)
        gmsh.model.mesh.generate(3)
        tags, xyz, _ = gmsh.model.mesh.getNodes()
        nodes = np.asarray(xyz).reshape(-1, 3)[np.argsort(tags)]
        _, en = gmsh.model.mesh.getElementsByType(4)
        tets4 = np.asarray(en, dtype=np.int64).reshape(-1, 4) - 1
        gmsh.model.remove()
    nodes, tets = upgrade_to_tet10(nodes, tets4)
    facets = boundary_facets(tets, nodes)
    assert facet_areas(nodes, facets).sum() == pytest.approx(0.22, rel=1e-12)
    centre = np.array([0.05, 0.1, 0.15])
    x0, x1, x2 = (nodes[facets[:, i]] for i in range(3))
    n = np.cross(x1 - x0, x2 - x0)
    assert np.all(np.einsum("ij,ij->i", n, x0 - centre) > 0)
    assert math.isclose(len(facets) % 2, 0)  # a closed triangulated surface: even count
