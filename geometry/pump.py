"""Assembly builders: the whole pump, or a single shaft, meshed and tagged.

The gmsh model is left alive and current after a build, so the caller can
convert it with DOLFINx 0.5 (only the rank that built the model reads it)::

    import gmsh
    from mpi4py import MPI
    from dolfinx.io import gmshio
    from geometry import PumpParams, build_pump, gmsh_session, preset

    comm = MPI.COMM_WORLD
    with gmsh_session():
        model = build_pump(PumpParams(), preset("coarse")) if comm.rank == 0 else None
        mesh, cell_tags, facet_tags = gmshio.model_to_mesh(gmsh.model, comm, 0, gdim=3)
    groups = comm.bcast(model.groups if comm.rank == 0 else None, root=0)

``cell_tags`` / ``facet_tags`` values are the physical tags of
``MeshedModel.groups`` (broadcast groups and centres to the other ranks).
"""

from __future__ import annotations

import logging

import gmsh
import numpy as np

from .housing import build_housing
from .meshing import add_groups, check_sizes, generate, set_part_size
from .model import MeshedModel, PartEntities
from .params import SHAFT_NAMES, MeshOptions, PumpParams, ShaftParams, preset
from .session import ensure_initialized, new_model
from .shaft import build_shaft

log = logging.getLogger(__name__)

VOLUME_TAGS = {"shaft_in": 1, "shaft_out": 2, "housing": 3}
# Coarsest element sizes that still mesh a part (docs/geometry.md): the housing at most
# HOUSING_SIZE_PER_WALL times its thinnest plate (wall, rib, foot), a shaft at most
# SHAFT_SIZE_PER_DIAMETER times its smallest diameter. Measured on the default pump:
# housing sizes up to 25 walls mesh (sizes above ~8 walls give the same mesh, set by
# the curvature), a shaft at 3 diameters fails (flat tets, SICN 0), at 1.5 meshes.
HOUSING_SIZE_PER_WALL = 8.0
SHAFT_SIZE_PER_DIAMETER = 2.0


def _shaft_size_limit(p: ShaftParams) -> float:
    radii = [r for r in (p.coupling_radius, p.journal_radius, p.body_radius, p.hub_radius,
                         p.tail_radius) if r > 0]
    return SHAFT_SIZE_PER_DIAMETER * 2.0 * min(radii)


def _check_pump_sizes(params: PumpParams, opts: MeshOptions,
                      volumes: dict[str, PartEntities]) -> None:
    """Element sizes against the thinnest features and the element-count bound
    (:func:`geometry.meshing.check_sizes`); raises ``ValueError`` naming the field."""
    h = params.housing
    plates = [h.wall_thickness, h.foot_height] + ([h.rib_thickness] if h.rib_count else [])
    parts = {"housing": (float(gmsh.model.occ.getMass(3, volumes["housing"].volume)),
                         opts.size, HOUSING_SIZE_PER_WALL * min(plates), "mesh.size",
                         f"{HOUSING_SIZE_PER_WALL:g} x its thinnest plate {min(plates):g} m")}
    for s in SHAFT_NAMES:
        sp = params.shaft(s)
        lim = _shaft_size_limit(sp)
        parts[f"shaft_{s}"] = (float(gmsh.model.occ.getMass(3, volumes[f"shaft_{s}"].volume)),
                               opts.shaft_size, lim, "mesh.size * mesh.shaft_factor",
                               f"{SHAFT_SIZE_PER_DIAMETER:g} x its smallest diameter "
                               f"{lim / SHAFT_SIZE_PER_DIAMETER:g} m")
    n = check_sizes(parts)
    log.info("mesh sizes checked: about %d tets estimated", n)


def _shaft_local_sizes(name: str, opts: MeshOptions) -> dict[str, float]:
    s = opts.shaft_size * opts.hub_factor
    return {f"{name}/bearing_a": s, f"{name}/bearing_b": s, f"{name}/hub": s}


def _finish(volumes: dict[str, PartEntities], opts: MeshOptions,
            params: PumpParams | ShaftParams, model_name: str) -> MeshedModel:
    groups = add_groups(volumes, VOLUME_TAGS)
    cad = {v: float(gmsh.model.occ.getMass(3, p.volume)) for v, p in volumes.items()}
    report = generate({v: p.volume for v, p in volumes.items()}, opts)
    centres: dict[str, np.ndarray] = {}
    for part in volumes.values():
        centres.update({k: np.asarray(c, dtype=float).copy() for k, c in part.centres.items()})
    for name, (dim, _) in groups.items():
        if dim == 2 and name != "housing/feet" and name not in centres:
            raise RuntimeError(f"group '{name}' has no centre")
    log.info("%s meshed (%s): %d tets, %d nodes, %d P2 DOF, min SICN %.3f, %d poor",
             model_name, opts.name, report.n_elements, report.n_nodes, report.n_dofs,
             report.min_sicn, report.n_poor)
    return MeshedModel(groups=groups, centres=centres, quality=report, params=params,
                       mesh_options=opts, model_name=model_name, part_volumes=cad)


def build_pump(params: PumpParams | None = None, mesh_options: MeshOptions | None = None,
               *, model_name: str = "pump", verbose: bool = False) -> MeshedModel:
    """Build and mesh the pump: two shafts in the housing, one gmsh model.

    Parts are meshed independently (not conformal to each other); each is one
    physical volume (``shaft_in``, ``shaft_out``, ``housing``).

    Parameters
    ----------
    params : PumpParams, optional
        Geometry [m]; default the paper's pump scale. Validated before meshing.
    mesh_options : MeshOptions, optional
        Default ``preset("coarse")``.
    model_name : str
        gmsh model name; an existing model of that name is replaced.
    verbose : bool
        gmsh terminal output.

    Returns
    -------
    MeshedModel
        Groups, centres, quality; the gmsh model stays current and initialised
        (finalise with :func:`geometry.gmsh_session` or ``gmsh.finalize()``).

    Raises
    ------
    ValueError
        Bad parameters (message names the field).
    RuntimeError
        Meshing failed or min SICN below ``mesh_options.min_sicn`` (names the part).
    """
    params = PumpParams() if params is None else params
    opts = preset("coarse") if mesh_options is None else mesh_options
    params.validate()
    opts.validate()
    ensure_initialized(verbose)
    new_model(model_name)
    volumes: dict[str, PartEntities] = {}
    for s in SHAFT_NAMES:
        volumes[f"shaft_{s}"] = build_shaft(params.shaft(s), s, params.shaft_origin(s))
    volumes["housing"] = build_housing(params.housing, params.centre_distance)
    gmsh.model.occ.synchronize()
    _check_pump_sizes(params, opts, volumes)
    housing = volumes["housing"]
    bore = opts.size * opts.bore_factor
    set_part_size(housing, opts.size, {k: bore for k in housing.surfaces if "/bore_" in k})
    for s in SHAFT_NAMES:
        set_part_size(volumes[f"shaft_{s}"], opts.shaft_size, _shaft_local_sizes(s, opts))
    return _finish(volumes, opts, params, model_name)


def build_single_shaft(params: ShaftParams | None = None,
                       mesh_options: MeshOptions | None = None, *, name: str = "in",
                       origin: tuple[float, float, float] = (0.0, 0.0, 0.0),
                       model_name: str = "shaft", verbose: bool = False) -> MeshedModel:
    """Build and mesh one shaft alone, with all its groups (for fem tests).

    Parameters
    ----------
    params : ShaftParams, optional
        Default ``ShaftParams()``.
    mesh_options : MeshOptions, optional
        Default ``preset("coarse")``; the shaft uses ``mesh_options.shaft_size``.
    name : str
        ``"in"`` or ``"out"``: group prefix (``{name}/hub``, …) and volume
        ``shaft_{name}``.
    origin : tuple of 3 floats
        Coupling end centre [m]; the axis is parallel to ``z``.
    model_name, verbose
        As in :func:`build_pump`.

    Returns
    -------
    MeshedModel
        Groups ``shaft_{name}``, ``{name}/coupling``, ``{name}/bearing_a``,
        ``{name}/bearing_b``, ``{name}/hub``, ``{name}/station_1..6``; centres of
        those plus ``{name}/gear``.
    """
    if name not in SHAFT_NAMES:
        raise ValueError(f"name = {name!r}: must be one of {SHAFT_NAMES}")
    params = ShaftParams() if params is None else params
    opts = preset("coarse") if mesh_options is None else mesh_options
    params.validate(f"shaft_{name}")
    opts.validate()
    ensure_initialized(verbose)
    new_model(model_name)
    part = build_shaft(params, name, origin)
    set_part_size(part, opts.shaft_size, _shaft_local_sizes(name, opts))
    return _finish({f"shaft_{name}": part}, opts, params, model_name)
