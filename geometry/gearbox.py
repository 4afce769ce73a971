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

import gmsh
import numpy as np

from .gearbox_params import GearboxParams, GearboxShaftParams
from .housing import build_box_housing
from .meshing import add_groups, check_sizes, generate, set_part_size
from .model import MeshedModel, PartEntities
from .params import MeshOptions, preset
from .session import ensure_initialized, new_model
from .shaft import build_revolved, end_face

log = logging.getLogger(__name__)

__all__ = ["build_gearbox", "gear_node", "volume_tags"]

#: As for the pump (:mod:`geometry.pump`): the coarsest sizes that still mesh a part.
HOUSING_SIZE_PER_WALL = 8.0
SHAFT_SIZE_PER_DIAMETER = 2.0


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
    h = params.housing
    plates = [h.wall_thickness, h.foot_height] + ([h.rib_thickness] if h.rib_count else [])
    parts = {"housing": (float(gmsh.model.occ.getMass(3, volumes["housing"].volume)),
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
                  model_name: str = "gearbox", verbose: bool = False) -> MeshedModel:
    """Build and mesh the gearbox (shafts and housing, one gmsh model; parts not
    conformal to each other, as the pump's).

    Parameters
    ----------
    params : GearboxParams
        Validated here, before any gmsh work.
    mesh_options : MeshOptions, optional
        Default ``preset("coarse")``.
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
    params.validate()
    opts.validate()
    ensure_initialized(verbose)
    new_model(model_name)
    volumes: dict[str, PartEntities] = {}
    for s in params.shafts:
        volumes[f"shaft_{s.name}"] = build_gearbox_shaft(s)
    volumes["housing"] = build_box_housing(params.box())
    gmsh.model.occ.synchronize()
    _check_gearbox_sizes(params, opts, volumes)
    housing = volumes["housing"]
    bore = opts.size * opts.bore_factor
    set_part_size(housing, opts.size, {k: bore for k in housing.surfaces if "/bore_" in k})
    local = opts.shaft_size * opts.hub_factor
    for s in params.shafts:
        part = volumes[f"shaft_{s.name}"]
        set_part_size(part, opts.shaft_size,
                      {k: local for k in part.surfaces if "/bearing_" in k or "/seat_" in k})
    groups = add_groups(volumes, volume_tags(params))
    report = generate({v: p.volume for v, p in volumes.items()}, opts)
    centres: dict[str, np.ndarray] = {}
    for part in volumes.values():
        centres.update({k: np.asarray(c, dtype=float).copy() for k, c in part.centres.items()})
    log.info("%s meshed (%s): %s", model_name, opts.name, report.summary())
    return MeshedModel(groups=groups, centres=centres, quality=report, params=params,
                       mesh_options=opts, model_name=model_name,
                       part_volumes={v: float(gmsh.model.occ.getMass(3, p.volume))
                                     for v, p in volumes.items()})
