"""A parallel-shaft gearbox meshed and tagged: N shafts in a box housing whose bores
follow the shafts (:class:`geometry.gearbox_params.GearboxParams`).

Physical groups (the FE layer's names, ``fem.gearbox``), for each shaft ``s``:

| kind | name | meaning |
|---|---|---|
| volume | ``shaft_{s}``, ``housing`` | one per part (material by part) |
| surface | ``{s}/bearing_a``, ``{s}/bearing_b`` | journals; ``a`` at the smaller z |
| surface | ``{s}/seat_{g}`` | seat of gear ``g`` (its body node links here) |
| surface | ``{s}/start``, ``{s}/end`` | the shaft's end faces (drive, loads) |
| surface | ``housing/bore_{s}_a``, ``housing/bore_{s}_b`` | bearing bores |
| surface | ``housing/feet`` | bolted faces, clamped |

``centres`` holds the centreline point of every surface group but the feet, and
``{s}/gear_{g}``, the centre of gear ``g`` (its seat's centre). Quadratic tetrahedra,
sizes checked before meshing (:func:`geometry.meshing.check_sizes`), finer at the
journals, seats and bores (``MeshOptions.hub_factor``, ``bore_factor``), as the pump.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from pathlib import Path

import gmsh
import numpy as np

from core.errors import InputError

from .gearbox_params import GearboxParams, GearboxShaftParams
from .housing import build_box_housing
from .meshfile import refuse_flat_elements
from .meshing import add_groups, check_sizes, generate, mesh_volume, quality, set_part_size
from .model import MeshedModel, PartEntities
from .params import MeshOptions, preset
from .session import ensure_initialized, new_model
from .shaft import build_revolved, end_face

log = logging.getLogger(__name__)

__all__ = ["CadHousing", "MeshHousing", "build_gearbox", "gear_node", "volume_tags"]

#: As for the pump (:mod:`geometry.pump`): the coarsest sizes that still mesh a part.
HOUSING_SIZE_PER_WALL = 8.0
SHAFT_SIZE_PER_DIAMETER = 2.0


@dataclass(frozen=True)
class CadHousing:
    """A housing read from a CAD file in place of the parametric box (issue 37).

    Attributes
    ----------
    path : str or Path
        STEP, IGES or BREP file (:func:`geometry.cad.import_part`: checked, healed).
    unit : str
        The file's length unit (``"mm"``).
    offset : (float, float, float)
        Translation of the CAD into the gearbox's frame [m] (the first shaft on the z
        axis, the shafts' starts at z = 0).
    bore_radii : tuple of float
        Bore radius of each shaft's bearings [m], in the order of the shafts; empty: the
        shaft radius plus ``GearboxHousingParams.bearing_section``.
    feet_y : float
        y of the feet's bolted faces in the gearbox's frame [m] (plane normal -y).

    The bores are found by their axes (:func:`geometry.cadfaces.find_seat`: point at
    each bearing's centre, direction z, the bore radius, the bearing width), the feet
    by their plane (:func:`geometry.cadfaces.find_mount`); what was found is logged.
    """

    path: str | Path
    unit: str = "mm"
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    bore_radii: tuple[float, ...] = ()
    feet_y: float = math.nan


def _cad_housing(cad: CadHousing, params: GearboxParams) -> PartEntities:
    """Read the CAD housing into the current model, moved by ``cad.offset``, and find its
    bores and feet (groups ``housing/bore_{s}_{a|b}``, ``housing/feet``)."""
    from .cad import CadPart, import_part
    from .cadfaces import face_candidates, find_mount, find_seat
    from .locate import Mount

    _check_housing_keys(cad, params)
    solid = import_part(CadPart("housing", str(cad.path), unit=cad.unit), "housing")
    if len(solid.volumes) != 1:
        raise InputError.of("housing.file", str(cad.path), f"holds {len(solid.volumes)} "
                            "solids; the housing must be one")
    vol = solid.volumes[0]
    if any(cad.offset):
        gmsh.model.occ.translate([(3, vol)], *cad.offset)
        gmsh.model.occ.synchronize()
    bbox = np.array(gmsh.model.getBoundingBox(3, vol)).reshape(2, 3)
    cands = face_candidates([vol])
    part = PartEntities(volume=vol)
    for group, seat, where in _bore_seats(cad, params):
        faces, rep = find_seat(seat, cands, bbox, where)
        log.info("%s", rep.summary())
        part.surfaces[group] = faces
        part.centres[group] = np.asarray(seat.point)
    groups, rep = find_mount(Mount("feet", plane=((0.0, cad.feet_y, 0.0), (0.0, -1.0, 0.0))),
                             cands, "housing.feet_y")
    log.info("%s", rep.summary())
    part.surfaces["housing/feet"] = groups[0]
    return part


@dataclass(frozen=True)
class MeshHousing:
    """A housing read from an existing volume mesh in place of the parametric box.

    Attributes
    ----------
    path : str or Path
        ``.msh`` (gmsh), ``.inp`` (Abaqus) or ``.bdf`` / ``.nas`` / ``.fem`` (NASTRAN) of
        ten-node tetrahedra (:func:`geometry.meshfile.read_volume_mesh`).
    unit, offset, bore_radii, feet_y
        As :class:`CadHousing`; the bores and the feet are found on the mesh's boundary
        facets (:class:`geometry.meshsurface.MeshBoundary`).
    first_order : str
        ``"refuse"`` a mesh of 4-node tetrahedra, or ``"upgrade"`` it (straight edges).
    """

    path: str | Path
    unit: str = "mm"
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    bore_radii: tuple[float, ...] = ()
    feet_y: float = math.nan
    first_order: str = "refuse"


@dataclass
class _MeshedHousing:
    """The housing's mesh and its seat and feet facets, found before any meshing."""

    mesh: object                      # geometry.meshfile.VolumeMesh
    facets: dict[str, np.ndarray]     # group -> 6-node boundary triangles (node indices)
    centres: dict[str, np.ndarray]


def _check_housing_keys(h: CadHousing | MeshHousing, params: GearboxParams) -> None:
    if h.bore_radii and len(h.bore_radii) != len(params.shafts):
        raise InputError.of("housing.bore_radii", list(h.bore_radii), f"must give one "
                            f"radius per shaft ({len(params.shafts)})", unit="m")
    if not math.isfinite(h.feet_y):
        raise InputError.of("housing.feet_y", h.feet_y, "the y of the feet's bolted "
                            "faces is needed to find them", unit="m")


def _bore_seats(h: CadHousing | MeshHousing, params: GearboxParams):
    """(group name, seat, where) of every bearing bore, found by its axis from the
    shafts."""
    from .locate import BearingSeat

    for i, s in enumerate(params.shafts):
        radius = h.bore_radii[i] if h.bore_radii else params.bore_radius(s)
        for name, b in s.sorted_bearings():
            x, y = s.centre
            centre = (float(x), float(y), float(s.start + b.position))
            seat = BearingSeat(f"{s.name}_{name}", point=centre, direction=(0.0, 0.0, 1.0),
                               radius=float(radius), width=float(b.width))
            yield f"housing/bore_{s.name}_{name}", seat, f"shafts[{i}].bearings ({name})"


def _read_mesh_housing(h: MeshHousing, params: GearboxParams) -> _MeshedHousing:
    """Read the housing's mesh, move it by ``h.offset`` and find its bores and feet on
    its boundary facets (before the shafts are meshed: a bad file fails first)."""
    from .locate import Mount
    from .meshfile import MeshPart, read_volume_mesh
    from .meshsurface import MeshBoundary

    _check_housing_keys(h, params)
    try:
        m = read_volume_mesh(MeshPart("housing", h.path, h.unit, h.first_order), "housing")
    except InputError as exc:      # the file's field is housing.file in a scene
        if exc.field != "housing.path":
            raise
        raise InputError(str(exc).replace("housing.path", "housing.file", 1),
                         field="housing.file", value=exc.value, unit=exc.unit,
                         allowed=exc.allowed) from exc
    if any(h.offset):
        m.nodes = m.nodes + np.asarray(h.offset, dtype=float)
    b = MeshBoundary(m.nodes, m.tets, m.face_sets, m.node_sets)
    facets: dict[str, np.ndarray] = {}
    centres: dict[str, np.ndarray] = {}
    for group, seat, where in _bore_seats(h, params):
        sel, rep = b.find_seat(seat, where)
        log.info("%s", rep.summary())
        facets[group] = b.facets[sel]
        centres[group] = np.asarray(seat.point, dtype=float)
    sels, rep = b.find_mount(Mount("feet", plane=((0.0, h.feet_y, 0.0), (0.0, -1.0, 0.0))),
                             "housing.feet_y")
    log.info("%s", rep.summary())
    facets["housing/feet"] = b.facets[sels[0]]
    return _MeshedHousing(m, facets, centres)


def _add_mesh_housing(mh: _MeshedHousing) -> PartEntities:
    """Add the housing's mesh to the current model after the shafts' (node tags going on
    from theirs, contiguous) with its bore and feet surfaces."""
    from .meshfile import add_facet_surface, add_volume_mesh

    gmsh.model.mesh.renumberNodes()
    tags = gmsh.model.mesh.getNodes()[0]
    offset = int(tags.max()) if tags.size else 0
    if offset != tags.size:
        raise RuntimeError(f"the shafts' node tags are not contiguous ({tags.size} nodes, "
                           f"largest tag {offset})")
    part = PartEntities(volume=add_volume_mesh(mh.mesh, offset))
    for group, facets in mh.facets.items():
        part.surfaces[group] = [add_facet_surface(facets, offset)]
    part.centres.update({k: v.copy() for k, v in mh.centres.items()})
    return part


def gear_node(shaft: str, gear: str) -> str:
    """Name of gear ``gear``'s centre (its body node in the FE model)."""
    return f"{shaft}/gear_{gear}"


def volume_tags(params: GearboxParams) -> dict[str, int]:
    """Physical volume tags: the shafts 1..N in their order, the housing N + 1."""
    tags = {f"shaft_{s.name}": i + 1 for i, s in enumerate(params.shafts)}
    tags["housing"] = len(params.shafts) + 1
    return tags


def build_gearbox_shaft(s: GearboxShaftParams) -> PartEntities:
    """Add one shaft to the current OCC model: journals, seats, end faces tagged."""
    x0, y0 = (float(c) for c in s.centre)
    z0 = float(s.start)
    segs = s.segments()
    inset = 0.5 * min(segs[0][1] - segs[0][0], segs[-1][1] - segs[-1][0])
    part, bboxes = build_revolved(segs, s.name, (x0, y0, z0), inset, ("body",))
    for label, z, r in (("start", z0, segs[0][2]), ("end", z0 + s.length, segs[-1][2])):
        part.surfaces[f"{s.name}/{label}"] = end_face(bboxes, s.name, z, r, x0)
        part.centres[f"{s.name}/{label}"] = np.array([x0, y0, z])
    for g in s.gears:
        part.centres[gear_node(s.name, g.name)] = \
            part.centres[f"{s.name}/seat_{g.name}"].copy()
    return part


def _check_gearbox_sizes(params: GearboxParams, opts: MeshOptions,
                         volumes: dict[str, PartEntities]) -> None:
    """Element sizes against the thinnest plates of the housing (its parameters; for a
    CAD housing its wall thickness as stated) and the shafts' diameters."""
    h = params.housing
    plates = [h.wall_thickness, h.foot_height] + ([h.rib_thickness] if h.rib_count else [])
    parts = {} if "housing" not in volumes else {   # a housing mesh is as it was given
        "housing": (float(gmsh.model.occ.getMass(3, volumes["housing"].volume)),
                    opts.size, HOUSING_SIZE_PER_WALL * min(plates), "mesh.size",
                    f"{HOUSING_SIZE_PER_WALL:g} x its thinnest plate {min(plates):g} m")}
    for s in params.shafts:
        lim = SHAFT_SIZE_PER_DIAMETER * 2.0 * min(s.radius, s.seat_r)
        parts[f"shaft_{s.name}"] = (
            float(gmsh.model.occ.getMass(3, volumes[f"shaft_{s.name}"].volume)),
            opts.shaft_size, lim, "mesh.size * mesh.shaft_factor",
            f"{SHAFT_SIZE_PER_DIAMETER:g} x its smallest diameter "
            f"{lim / SHAFT_SIZE_PER_DIAMETER:g} m")
    n = check_sizes(parts)
    log.info("gearbox mesh sizes checked: about %d tets estimated", n)


def build_gearbox(params: GearboxParams, mesh_options: MeshOptions | None = None, *,
                  cad: CadHousing | None = None, mesh_housing: MeshHousing | None = None,
                  model_name: str = "gearbox", verbose: bool = False) -> MeshedModel:
    """Build and mesh the gearbox (shafts and housing, one gmsh model; parts not
    conformal to each other, as the pump's).

    Parameters
    ----------
    params : GearboxParams
        Validated here, before any gmsh work.
    mesh_options : MeshOptions, optional
        Default ``preset("coarse")``.
    cad : CadHousing, optional
        The housing from a CAD file (its bores found from the shafts' axes) in place of
        the parametric box; the shafts stay parametric.
    mesh_housing : MeshHousing, optional
        The housing from an existing volume mesh (its bores and feet found on its
        boundary facets), kept as it is: the shafts are meshed, then the housing's
        elements are added with their own nodes (not conformal to the shafts, as the
        other housings).
    model_name, verbose
        As :func:`geometry.build_pump`.

    Returns
    -------
    MeshedModel
        The groups and centres of the module docstring; the gmsh model stays current.

    Raises
    ------
    core.errors.InputError
        Bad parameters (the field named) or element sizes too coarse (ValueError).
    RuntimeError
        Meshing failed or its quality stayed too low.
    """
    opts = preset("coarse") if mesh_options is None else mesh_options
    if cad is not None and mesh_housing is not None:
        raise ValueError("build_gearbox: give cad or mesh_housing, not both")
    if cad is None and mesh_housing is None:
        params.validate()
    else:  # the file's own bores and walls: the shafts alone are checked here
        for i, s in enumerate(params.shafts):
            s.validate(f"shafts[{i}]")
    opts.validate()
    ensure_initialized(verbose)
    given = _read_mesh_housing(mesh_housing, params) if mesh_housing is not None else None
    new_model(model_name)
    volumes: dict[str, PartEntities] = {}
    housing = _cad_housing(cad, params) if cad is not None else None
    for s in params.shafts:
        volumes[f"shaft_{s.name}"] = build_gearbox_shaft(s)
    if given is None:
        volumes["housing"] = housing if housing is not None else \
            build_box_housing(params.box())
    gmsh.model.occ.synchronize()
    _check_gearbox_sizes(params, opts, volumes)
    if given is None:
        housing = volumes["housing"]
        bore = opts.size * opts.bore_factor
        set_part_size(housing, opts.size, {k: bore for k in housing.surfaces if "/bore_" in k})
    local = opts.shaft_size * opts.hub_factor
    for s in params.shafts:
        part = volumes[f"shaft_{s.name}"]
        set_part_size(part, opts.shaft_size,
                      {k: local for k in part.surfaces if "/bearing_" in k or "/seat_" in k})
    if given is None:
        groups = add_groups(volumes, volume_tags(params))
    report = generate({v: p.volume for v, p in volumes.items()}, opts)
    part_volumes = {v: float(gmsh.model.occ.getMass(3, p.volume)) for v, p in volumes.items()}
    if given is not None:       # the housing's elements after the shafts', as they are
        volumes["housing"] = _add_mesh_housing(given)
        part_volumes["housing"] = mesh_volume(volumes["housing"].volume)
        groups = add_groups(volumes, volume_tags(params))
        report = quality({v: p.volume for v, p in volumes.items()}, opts.poor_sicn)
        refuse_flat_elements(report.per_part["housing"]["min_sicn"], "housing.file",
                             mesh_housing.path)
    centres: dict[str, np.ndarray] = {}
    for part in volumes.values():
        centres.update({k: np.asarray(c, dtype=float).copy() for k, c in part.centres.items()})
    log.info("%s meshed (%s): %s", model_name, opts.name, report.summary())
    return MeshedModel(groups=groups, centres=centres, quality=report, params=params,
                       mesh_options=opts, model_name=model_name, part_volumes=part_volumes)
