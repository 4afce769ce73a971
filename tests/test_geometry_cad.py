"""CAD import (geometry.cad, locate, cadfaces, imported): units, checks before work,
healing, bearing seats and mounts found on STEP faces, meshing with an estimated count.

Files: the parametric pump housing written as STEP (mm) and the gearbox housing of
scripts/gearbox_housing_step.py; small BREP files with defects made here."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

gmsh = pytest.importorskip("gmsh")

import cad_support as cs  # noqa: E402

from core.errors import InputError  # noqa: E402
from geometry import (  # noqa: E402
    BearingSeat,
    CadPart,
    HealOptions,
    HousingParams,
    Mount,
    build_housing,
    finalize_gmsh,
    gmsh_session,
    import_cad,
    import_part,
    preset,
    write_step,
)
from geometry.cad import declared_unit, iges_global_parameters, open_edges  # noqa: E402
from geometry.imported import estimate_elements  # noqa: E402
from geometry.params import DEFAULT_CENTRE_DISTANCE  # noqa: E402

pytestmark = pytest.mark.fem


@pytest.fixture(autouse=True)
def _gmsh_finalised():
    """A builder called outside a session leaves gmsh initialised: close it after each
    test, so that no model outlives it."""
    yield
    finalize_gmsh()

GEARBOX = cs.gearbox_script()
COARSE = preset("coarse", size=0.03, curvature_points=6)


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("cad")
    return {"pump": cs.write_pump_housing_step(d / "pump_housing.step"),
            "gearbox": GEARBOX.write(d / "gearbox_housing.step"), "dir": d}


def _brep(path: Path, build) -> Path:
    with gmsh_session():
        gmsh.model.add("brep")
        build()
        gmsh.model.occ.synchronize()
        gmsh.write(str(path))
        gmsh.model.remove()
    return path


def _read(part: CadPart):
    with gmsh_session():
        gmsh.model.add("read")
        try:
            return import_part(part, "parts[0]")
        finally:
            gmsh.model.remove()


# --- units and the round trip of the geometry ------------------------------------------


def test_step_round_trip_keeps_the_exact_solid(files: dict[str, Path]) -> None:
    """Written in mm, read with unit mm: the same solid (planes and cylinders stay
    analytic; volume to 1e-14), and the file declares mm and holds mm."""
    text = files["pump"].read_text()
    assert "SI_UNIT(.MILLI.,.METRE.)" in text
    assert declared_unit(files["pump"]) == ("mm", 1.0)
    with gmsh_session():
        gmsh.model.add("param")
        vol = build_housing(HousingParams(), DEFAULT_CENTRE_DISTANCE).volume
        v_ref = gmsh.model.occ.getMass(3, vol)
        types_ref = sorted(gmsh.model.getType(2, t) for _, t in gmsh.model.getEntities(2))
        gmsh.model.remove()
        gmsh.model.add("read")
        solid = import_part(CadPart("housing", files["pump"], unit="mm"))
        types = sorted(gmsh.model.getType(2, t) for _, t in gmsh.model.getEntities(2))
        gmsh.model.remove()
    assert solid.volume == pytest.approx(v_ref, rel=1e-14)  # measured 4e-15
    assert types == types_ref  # 44 planes, 8 cylinders
    h = HousingParams()
    assert solid.bbox[1, 2] - solid.bbox[0, 2] == pytest.approx(
        h.length_z + 2 * h.boss_length, abs=1e-6)
    assert not solid.healed and solid.notes == []


def test_declared_unit_is_read_and_the_callers_unit_wins(files: dict[str, Path]) -> None:
    """A file declaring metres is read by OpenCASCADE x1000; unit = 'mm' keeps the
    numbers as millimetres, with a note naming both units."""
    text = files["pump"].read_text().replace("SI_UNIT(.MILLI.,.METRE.)", "SI_UNIT($,.METRE.)")
    path = files["dir"] / "declared_m.step"
    path.write_text(text)
    assert declared_unit(path) == ("m", 1000.0)
    solid = _read(CadPart("housing", path, unit="mm"))
    ref = _read(CadPart("housing", files["pump"], unit="mm"))
    assert np.allclose(solid.bbox, ref.bbox, rtol=0, atol=1e-12)
    assert "declares its lengths in 'm'" in solid.notes[0]


def test_declared_unit_parsers(tmp_path: Path) -> None:
    inch = ("#7 = ( CONVERSION_BASED_UNIT('INCH',#8) LENGTH_UNIT() NAMED_UNIT(#9) );\n"
            "#8 = LENGTH_MEASURE_WITH_UNIT(LENGTH_MEASURE(25.4),#10);\n"
            "#10 = ( LENGTH_UNIT() NAMED_UNIT(*) SI_UNIT(.MILLI.,.METRE.) );\n")

    def unit(text: str) -> tuple:
        (tmp_path / "u.step").write_text(text)
        return declared_unit(tmp_path / "u.step")

    assert unit(inch) == (None, None)  # two length units declared: unknown
    assert unit(inch.split("\n")[0]) == ("in", 25.4)
    assert unit("#1 = ( LENGTH_UNIT() NAMED_UNIT(*) SI_UNIT(.CENTI.,.METRE.) );") == (
        "cm", 10.0)
    # IGES global section: Hollerith strings may hold the delimiters; parameter 14 = 2 (mm)
    fields = "1H,,1H;,4HA,;B,5Hx.igs,,,32,38,6,308,15,,1.0,2,2HMM,1,0.01;"
    lines = [fields[i:i + 72].ljust(72) + f"G{i // 72 + 1:7d}"
             for i in range(0, len(fields), 72)]
    params = iges_global_parameters("\n".join(lines))
    assert params[2] == "A,;B" and params[13] == "2" and params[14] == "MM"


def test_implausible_size_names_the_unit_and_prints_the_box(files: dict[str, Path]) -> None:
    with pytest.raises(InputError) as err:
        _read(CadPart("housing", files["pump"], unit="m"))
    msg = str(err.value)
    assert err.value.field == "parts[0].unit"
    assert "266 x 154 x 184 m" in msg and "would fit as 'cm' or 'mm' or 'in'" in msg


@pytest.mark.parametrize("name, content, expect", [
    ("missing.step", None, "no such file"),
    ("empty.step", "", "the file is empty"),
    ("junk.step", "hello\n", "OpenCASCADE cannot read it"),
    ("housing.txt", "x", "must end in one of"),
])
def test_unreadable_files_are_refused(tmp_path: Path, name: str, content: str | None,
                                      expect: str) -> None:
    path = tmp_path / name
    if content is not None:
        path.write_text(content)
    with pytest.raises(InputError, match=expect) as err:
        _read(CadPart("housing", path, unit="mm"))
    assert err.value.field == "parts[0].path"


def test_open_shell_is_not_a_closed_solid(tmp_path: Path) -> None:
    def five_faces() -> None:
        box = gmsh.model.occ.addBox(0, 0, 0, 0.1, 0.1, 0.1)
        gmsh.model.occ.synchronize()
        faces = gmsh.model.getBoundary([(3, box)])
        gmsh.model.occ.remove([(3, box)])
        gmsh.model.occ.remove([(2, abs(faces[0][1]))])

    path = _brep(tmp_path / "open.brep", five_faces)
    with pytest.raises(InputError, match="not a closed solid: no solid in the file "
                       r"\(5 free surfaces"):
        _read(CadPart("housing", path, unit="m"))


def test_closed_shell_is_healed_into_a_solid(tmp_path: Path) -> None:
    def six_faces() -> None:
        box = gmsh.model.occ.addBox(0, 0, 0, 0.1, 0.2, 0.3)
        gmsh.model.occ.remove([(3, box)])

    path = _brep(tmp_path / "shell.brep", six_faces)
    solid = _read(CadPart("housing", path, unit="m"))
    assert solid.healed and solid.volume == pytest.approx(0.006, rel=1e-12)
    assert "no solid in the file (6 free surfaces" in solid.notes[0]
    with pytest.raises(InputError, match="heal.mode = 'never'"):
        _read(CadPart("housing", path, unit="m", heal=HealOptions(mode="never")))


def test_touching_solids_become_one_conformal_part(tmp_path: Path) -> None:
    def two_boxes() -> None:
        gmsh.model.occ.addBox(0, 0, 0, 0.1, 0.1, 0.1)
        gmsh.model.occ.addBox(0.1, 0, 0, 0.1, 0.1, 0.1)

    solid = _read(CadPart("housing", _brep(tmp_path / "two.brep", two_boxes), unit="m"))
    assert len(solid.volumes) == 2 and "fragmented" in solid.notes[0]
    assert solid.volume == pytest.approx(0.002, rel=1e-12)


def test_open_edges_of_a_valid_solid(files: dict[str, Path]) -> None:
    with gmsh_session():
        gmsh.model.add("read")
        solid = import_part(CadPart("housing", files["gearbox"], unit="mm"))
        assert open_edges(solid.volumes[0]) == (0, 0)
        gmsh.model.remove()


# --- seats and mounts on CAD faces ---------------------------------------------------


@pytest.fixture(scope="module")
def gearbox(files: dict[str, Path]):
    """The gearbox housing imported at the coarse test size, with its seats and feet."""
    p = GEARBOX.GearboxHousing()
    with gmsh_session():
        model = import_cad([CadPart("housing", files["gearbox"], unit="mm")],
                           GEARBOX.seats(p), [GEARBOX.feet_mount(p, per_patch=True)], COARSE)
        types = {int(t) for _, v in gmsh.model.getEntities(3)
                 for t in gmsh.model.mesh.getElementTypes(3, v)}
        seat_nodes, edges = {}, {}
        for name, (dim, tag) in model.groups.items():
            if dim == 2:
                ents = gmsh.model.getEntitiesForPhysicalGroup(dim, tag)
                xyz = [gmsh.model.mesh.getNodes(2, int(e), includeBoundary=True)[1]
                       for e in ents]
                seat_nodes[name] = np.concatenate(xyz).reshape(-1, 3)
                edges[name] = _edge_lengths(ents)
    return model, p, types, (seat_nodes, edges)


def _edge_lengths(surfaces) -> np.ndarray:
    """Corner-to-corner edge lengths of the triangles on the given surfaces."""
    out = []
    for e in surfaces:
        for et, en in zip(*gmsh.model.mesh.getElements(2, int(e))[::2], strict=True):
            n = gmsh.model.mesh.getElementProperties(int(et))[3]
            tri = np.asarray(en).reshape(-1, n)[:, :3]
            x = np.array([gmsh.model.mesh.getNode(int(t))[0] for t in tri.ravel()])
            x = x.reshape(-1, 3, 3)
            out.append(np.linalg.norm(x - np.roll(x, 1, axis=1), axis=2).ravel())
    return np.concatenate(out)


def test_gearbox_seats_and_feet_are_found(gearbox) -> None:
    model, p, types, (nodes, _) = gearbox
    assert types == {11}  # 10-node tetrahedra only
    assert len(model.seats) == 6 and set(model.mounts) == {"feet"}
    bore = p.wall + p.boss_length  # every bore runs through wall and boss
    for seat in GEARBOX.seats(p):
        rep = model.seats[seat.name]
        assert rep.group == f"housing/bore_{seat.name}"
        assert rep.radius_measured == pytest.approx(seat.radius, abs=1e-12)
        assert rep.axis_offset < 1e-12 and rep.tilt_deg < 1e-6
        assert rep.area == pytest.approx(2 * math.pi * seat.radius * bore, rel=1e-9)
        assert rep.axial_range == pytest.approx((-bore / 2, bore / 2), abs=1e-9)
        assert np.allclose(model.centres[rep.group], seat.point, atol=0)
        # the seat's mesh nodes (mid-edge ones included) lie on the bore
        x = nodes[rep.group] - np.asarray(seat.point)
        assert np.allclose(np.hypot(x[:, 0], x[:, 1]), seat.radius, atol=1e-9)
    feet = model.mounts["feet"]
    assert feet.groups == [f"housing/feet_{k}" for k in range(1, 5)]
    fx, _, fz = p.foot_size
    foot_area = fx * fz - math.pi * p.foot_bolt_radius ** 2
    assert feet.areas == pytest.approx([foot_area] * 4, rel=1e-9)
    keys = [tuple(np.round(c, 9)) for c in feet.centres]
    assert keys == sorted(keys)  # numbered in the order of x, then y, then z
    assert keys[0][0] == keys[1][0] < keys[2][0] == keys[3][0]


def test_gearbox_mesh_is_refined_at_the_seats(gearbox) -> None:
    model, _, _, (_, edges) = gearbox
    seat = COARSE.size * COARSE.bore_factor
    for rep in model.seats.values():  # the seats at size * bore_factor (18 mm), where
        # size (30 mm) and curvature (6 per turn: 27-42 mm) alone would be coarser
        assert edges[rep.group].mean() < 1.1 * seat, rep.name
    q = model.quality
    assert q.min_sicn >= COARSE.min_sicn and q.n_elements > 1000
    # estimated before meshing within the measured factor 0.5-2.5 of the mesh made
    assert 0.4 < q.n_elements / model.estimated_elements < 3.0
    assert model.part_volumes["housing"] == pytest.approx(2.1224e-3, rel=1e-3)


def test_seat_refused_with_the_nearest_faces(files: dict[str, Path]) -> None:
    """A wrong radius: nothing fits, the message names the bores nearby with their real
    radius; an axis off the housing misses the solid (its box is printed)."""
    p = GEARBOX.GearboxHousing()
    good = GEARBOX.seats(p)[4]  # out_a, radius 40 mm
    wrong = BearingSeat("out_a", point=good.point, direction=good.direction, radius=0.0375,
                        width=good.width)
    with pytest.raises(InputError) as err:
        import_cad([CadPart("housing", files["gearbox"], unit="mm")], [wrong], [], COARSE)
    msg = str(err.value)
    assert err.value.field == "seats[0].point"
    assert "no bore face of radius 0.0375 m" in msg
    assert "nearest candidates: face" in msg and "cylinder of radius 40.000 mm, its axis " \
        "0.000 mm from the point and 0.00 deg off" in msg
    far = BearingSeat("x", point=(0.0, 0.0, 0.5), direction=(0, 0, 1), radius=0.026,
                      width=0.015)
    with pytest.raises(InputError, match=r"misses part 'housing', whose bounding box is "
                       r"\[-0\.0.*\] \.\. \[.*\] m"):
        import_cad([CadPart("housing", files["gearbox"], unit="mm")], [far], [], COARSE)


def test_mount_refused_and_faces_claimed_twice(files: dict[str, Path]) -> None:
    p = GEARBOX.GearboxHousing()
    feet = GEARBOX.feet_mount(p)
    (px, py, pz), n = feet.plane
    off = Mount("feet", plane=((px, py + 0.002, pz), n))
    with pytest.raises(InputError, match="no face of part 'housing' lies in the plane "
                       "given.*2.000 mm from the plane"):
        import_cad([CadPart("housing", files["gearbox"], unit="mm")], [], [off], COARSE)
    seat = GEARBOX.seats(p)[0]
    twice = [seat, BearingSeat("again", point=seat.point, direction=seat.direction,
                               radius=seat.radius, width=seat.width)]
    with pytest.raises(InputError, match="housing/bore_again and housing/bore_in_a both "
                       "hold face"):
        import_cad([CadPart("housing", files["gearbox"], unit="mm")], twice, [], COARSE)


def test_requests_are_checked_before_any_file_is_read(files: dict[str, Path],
                                                       tmp_path: Path) -> None:
    missing = tmp_path / "nothing.step"
    part = CadPart("housing", missing, unit="mm")
    with pytest.raises(InputError, match=r"seats\[0\]: width missing"):
        import_cad([CadPart("housing", files["gearbox"])],
                   [BearingSeat("a", point=(0, 0, 0), direction=(0, 0, 1), radius=0.01)])
    with pytest.raises(InputError, match=r"seats\[0\].part = 'shaft'"):
        import_cad([CadPart("housing", files["gearbox"])],
                   [BearingSeat("a", group="x", part="shaft")])
    with pytest.raises(InputError, match=r"parts\[0\].path = .*no such file"):
        import_cad([part])
    with pytest.raises(InputError, match=r"parts\[0\].unit = 'furlong'"):
        import_cad([CadPart("housing", missing, unit="furlong")])
    with pytest.raises(InputError, match=r"mounts\[0\]: give group, or plane and/or box"):
        Mount("feet").validate("mounts[0]")
    with pytest.raises(InputError, match=r"seats\[0\].direction = .*non-zero direction"):
        BearingSeat("a", point=(0, 0, 0), direction=(0, 0, 0), radius=0.01,
                    width=0.01).validate("seats[0]")


def test_element_count_refused_before_meshing(files: dict[str, Path]) -> None:
    """0.5 mm on the gearbox housing: ~1e8 tetrahedra estimated, refused at once."""
    with pytest.raises(InputError, match=r"mesh.size = 0.0005 m: about .* tetrahedra "
                       r"estimated .* before meshing, more than the 3e\+06 allowed"):
        import_cad([CadPart("housing", files["gearbox"], unit="mm")], [], [],
                   preset("coarse", size=0.0005))


def test_estimate_terms_on_a_box(tmp_path: Path) -> None:
    """Volume term 6 sqrt(2) V/h^3; surface term A/(sqrt(3)/4 h^2) for flat faces."""
    with gmsh_session():
        gmsh.model.add("box")
        v = gmsh.model.occ.addBox(0, 0, 0, 0.1, 0.1, 0.1)
        gmsh.model.occ.synchronize()
        n_vol, n_tri = estimate_elements([v], 0.01, 10)
        gmsh.model.remove()
    assert n_vol == pytest.approx(6 * math.sqrt(2) * 1000, rel=1e-12)
    assert n_tri == pytest.approx(0.06 / (math.sqrt(3) / 4 * 1e-4), rel=1e-12)


def test_step_writer_restores_the_current_model(tmp_path: Path) -> None:
    with gmsh_session():
        gmsh.model.add("mine")
        write_step(tmp_path / "b.step", lambda: gmsh.model.occ.addBox(0, 0, 0, .1, .1, .1))
        assert gmsh.model.getCurrent() == "mine"
        assert "_write_step_m" not in gmsh.model.list()
        gmsh.model.remove()


def test_housing_and_shaft_parts_with_journal_seats(files: dict[str, Path],
                                                    tmp_path: Path) -> None:
    """Two parts, one physical volume each; journal seats (convex) on the shaft, bores on
    the housing; a construction line beside the shaft's solid is not read."""
    from geometry import ShaftParams, build_shaft

    def shaft_and_line() -> None:
        build_shaft(ShaftParams(), "in")
        a, b = gmsh.model.occ.addPoint(0.1, 0, 0), gmsh.model.occ.addPoint(0.2, 0, 0)
        gmsh.model.occ.addLine(a, b)

    with gmsh_session():
        shaft = write_step(tmp_path / "shaft.step", shaft_and_line)
    journals = [BearingSeat(f"in_{e}", point=(0.0, 0.0, z), direction=(0, 0, 1),
                            radius=0.0125, width=0.015, part="shaft_in", surface="journal")
                for e, z in (("a", 0.0675), ("b", 0.2315))]
    bore = cs.pump_seats()[0]
    with gmsh_session():
        model = import_cad([CadPart("housing", files["pump"]),
                            CadPart("shaft_in", shaft, size=0.01)],
                           [bore, *journals], [], preset("coarse"))
        line = gmsh.model.getEntitiesInBoundingBox(0.099, -1e-6, -1e-6, 0.201, 1e-6, 1e-6,
                                                   dim=1)
        assert line == []  # the construction line was not read
    assert {k: v for k, v in model.groups.items() if v[0] == 3} == {"housing": (3, 1),
                                                                    "shaft_in": (3, 2)}
    for e in "ab":
        rep = model.seats[f"in_{e}"]
        assert rep.group == f"shaft_in/journal_in_{e}"
        assert rep.area == pytest.approx(2 * math.pi * 0.0125 * 0.015, rel=1e-9)
    wrong = BearingSeat("in_a", point=(0.0, 0.0, 0.0675), direction=(0, 0, 1),
                        radius=0.0125, width=0.015, part="shaft_in")  # a bore: none
    with pytest.raises(InputError, match="no bore face.*facing away from the axis"):
        import_cad([CadPart("shaft_in", shaft)], [wrong], [], preset("coarse"))
