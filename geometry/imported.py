"""Imported parts as a tagged gmsh model: CAD files meshed here, or existing meshes.

:func:`import_cad` reads STEP/IGES/BREP parts (:mod:`geometry.cad`), finds the bearing
seats and mounts on their faces (:mod:`geometry.cadfaces`), estimates the element count
against a bound, and meshes in 10-node tetrahedra with the global size and a finer size
at the seats (:func:`geometry.meshing.generate`: seeded, quality-checked, as the pump).
:func:`import_mesh` reads existing volume meshes (:mod:`geometry.meshfile`) and finds the
seats and mounts on their boundary facets (:mod:`geometry.meshsurface`). Both return an
:class:`geometry.model.ImportedModel` whose gmsh model stays alive and current, with one
physical volume per part and one physical surface per seat and mount, the form
``fem.load_meshed_model`` reads::

    with gmsh_session():
        model = import_cad([CadPart("housing", "gearbox.step", unit="mm")], seats, mounts,
                           preset("coarse", size=0.02)) if comm.rank == 0 else None
        fe_mesh = fem.load_meshed_model(model, comm)     # distributed from rank 0

Every request is checked before any file is read; everything found is logged
(``ImportedModel.report()``).
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Sequence

import gmsh
import numpy as np

from core.errors import InputError

from .cad import CadPart, ImportedSolid, import_part
from .cadfaces import face_candidates, find_mount, find_seat, part_faces
from .locate import BearingSeat, Mount
from .meshfile import (
    MeshPart,
    add_facet_surface,
    add_volume_mesh,
    read_volume_mesh,
    refuse_flat_elements,
)
from .meshing import MAX_ELEMENTS, TETS_PER_SIZE_CUBED, generate, mesh_volume, points_of, quality
from .meshsurface import MeshBoundary
from .model import ImportedModel
from .params import MeshOptions, preset
from .session import ensure_initialized, new_model

log = logging.getLogger(__name__)

SURFACE_TAG0 = 101  # surface physical tags are numbered from here, seats then mounts
#: Points sampled per face direction for its curvature in the element-count estimate.
N_CURVATURE = 5


def check_requests(parts: Sequence[CadPart | MeshPart], seats: Sequence[BearingSeat],
                   mounts: Sequence[Mount]) -> None:
    """Validate every part, seat and mount, and their names, before any work.

    Raises
    ------
    core.errors.InputError
        Naming the field (``parts[1].unit``, ``seats[0].radius``, ``mounts[2].part``).
    """
    if not parts:
        raise InputError.of("parts", list(parts), "must name at least one part")
    names: dict[str, str] = {}
    for i, p in enumerate(parts):
        p.validate(f"parts[{i}]")
        if p.name in names:
            raise InputError.of(f"parts[{i}].name", p.name, f"already used by {names[p.name]}")
        names[p.name] = f"parts[{i}]"
    groups: dict[str, str] = {}
    for kind, items in (("seats", seats), ("mounts", mounts)):
        for i, s in enumerate(items):
            where = f"{kind}[{i}]"
            s.validate(where)
            if s.part not in names:
                raise InputError.of(f"{where}.part", s.part,
                                    f"must be one of the parts {sorted(names)}")
            if s.group_name in groups or s.group_name in names:
                raise InputError.of(f"{where}.name", s.name, f"its group {s.group_name!r} "
                                    f"is already made by {groups.get(s.group_name, 'a part')}")
            groups[s.group_name] = where


def _unused(name: str, made: dict, where: str) -> None:
    """Refuse a group name made twice (a per-patch mount ``feet_1`` beside ``feet``)."""
    if name in made:
        raise InputError.of(f"{where}.name", name, "this group is already made by "
                            "another seat or mount: rename one")


def _disjoint(claims: dict[str, set], kind: str) -> None:
    """Refuse two groups that claim the same face or facet."""
    seen: dict[object, str] = {}
    for name, items in claims.items():
        for it in items:
            if it in seen:
                raise InputError(f"{name} and {seen[it]} both hold {kind} {it}: a face "
                                 "belongs to one seat or mount only; narrow the width, "
                                 "plane or box", field=name)
            seen[it] = name


def _add_groups(volumes: dict[str, list[int]], surfaces: dict[str, list[int]]
                ) -> dict[str, tuple[int, int]]:
    groups: dict[str, tuple[int, int]] = {}
    for i, (name, vols) in enumerate(volumes.items(), start=1):
        tag = gmsh.model.addPhysicalGroup(3, vols, i)
        gmsh.model.setPhysicalName(3, tag, name)
        groups[name] = (3, tag)
    for i, (name, ents) in enumerate(surfaces.items()):
        tag = gmsh.model.addPhysicalGroup(2, ents, SURFACE_TAG0 + i)
        gmsh.model.setPhysicalName(2, tag, name)
        groups[name] = (2, tag)
    return groups


def estimate_elements(volumes: list[int], size: float, curvature_points: int,
                      face_sizes: dict[int, float] | None = None) -> tuple[float, float]:
    """Tetrahedra that meshing the volumes at ``size`` [m] will make, before meshing.

    ``6 sqrt(2) V / h^3`` regular tetrahedra fill the volume; every boundary triangle
    adds about one more: a face of area ``A`` gets ``A / (sqrt(3)/4 h_f^2)`` triangles,
    ``h_f`` the smallest of ``size``, its own size in ``face_sizes`` and the curvature
    size ``2 pi / (curvature_points k_max)``, ``k_max`` the largest principal curvature
    sampled on the face (thin walls and small holes are what make a housing's mesh).
    Measured against the meshes made (pump housing, gearbox housing; sizes 7-30 mm):
    the mesh has 0.55 to 2.5 times the estimate, the higher ratios for the coarsest
    meshes, whose refinement around holes reaches into the volume.

    Returns
    -------
    (volume term, surface term) : float
    """
    face_sizes = face_sizes or {}
    vol = sum(gmsh.model.occ.getMass(3, v) for v in volumes)
    n_tri = 0.0
    g = (np.arange(N_CURVATURE) + 0.5) / N_CURVATURE
    for f in part_faces(volumes):
        (u0, v0), (u1, v1) = gmsh.model.getParametrizationBounds(2, f)
        uu, vv = np.meshgrid(u0 + g * (u1 - u0), v0 + g * (v1 - v0))
        uv = np.column_stack([uu.ravel(), vv.ravel()]).ravel()
        k = float(np.abs(np.asarray(gmsh.model.getCurvature(2, f, uv))).max())
        h = min(size, face_sizes.get(f, size))
        if curvature_points > 0 and k > 0:
            h = min(h, 2.0 * np.pi / (curvature_points * k))
        n_tri += gmsh.model.occ.getMass(2, f) / (0.25 * np.sqrt(3.0) * h * h)
    return TETS_PER_SIZE_CUBED * vol / size ** 3, n_tri


def _check_count(solids: dict[str, ImportedSolid], sizes: dict[str, float],
                 face_sizes: dict[int, float], curvature_points: int,
                 max_elements: int) -> int:
    """The element-count estimate of every part, refused above ``max_elements``."""
    per = {k: estimate_elements(s.volumes, sizes[k], curvature_points, face_sizes)
           for k, s in solids.items()}
    total = sum(a + b for a, b in per.values())
    log.info("about %d tetrahedra estimated (%s)", total, ", ".join(
        f"{k}: {a:.0f} in the volume, {b:.0f} along the boundary" for k, (a, b) in per.items()))
    if total > max_elements:
        detail = ", ".join(f"{k} {a + b:.3g}" for k, (a, b) in per.items())
        raise InputError.of("mesh.size", min(sizes.values()),
                            f"about {total:.3g} tetrahedra estimated ({detail}) before "
                            f"meshing, more than the {max_elements:.3g} allowed: choose a "
                            "larger size (or fewer curvature points)", unit="m")
    return int(round(total))


def import_cad(parts: Sequence[CadPart], seats: Sequence[BearingSeat] = (),
               mounts: Sequence[Mount] = (), mesh_options: MeshOptions | None = None, *,
               max_elements: int = MAX_ELEMENTS, model_name: str = "imported",
               verbose: bool = False) -> ImportedModel:
    """Read CAD parts, find their seats and mounts, mesh them in 10-node tetrahedra.

    Parameters
    ----------
    parts : sequence of CadPart
        One physical volume each (name = part name).
    seats : sequence of BearingSeat
        Found on the faces of their part; each becomes the surface group
        ``BearingSeat.group_name`` and a centre.
    mounts : sequence of Mount
        Each becomes one surface group (or one per patch) with its centroid.
    mesh_options : MeshOptions, optional
        ``size`` is the global element size [m] (a part's ``CadPart.size`` overrides it),
        ``size * bore_factor`` the size at the seats; ``curvature_points``, the quality
        thresholds and ``seed`` as for the pump. Default ``preset("coarse")``.
    max_elements : int
        Bound on the element count estimated before meshing (:func:`estimate_elements`).
    model_name : str
        gmsh model name; an existing model of that name is replaced.
    verbose : bool
        gmsh terminal output.

    Returns
    -------
    ImportedModel

    Raises
    ------
    core.errors.InputError
        A request, a file, a unit, a seat or mount that fits nothing (the nearest faces
        are named), two requests on one face, or too many elements estimated.
    RuntimeError
        Meshing failed or its quality stayed below ``mesh_options.min_sicn``.
    """
    opts = preset("coarse") if mesh_options is None else mesh_options
    opts.validate()
    check_requests(parts, seats, mounts)
    ensure_initialized(verbose)
    new_model(model_name)
    solids = {p.name: import_part(p, f"parts[{i}]") for i, p in enumerate(parts)}
    cands = {k: face_candidates(s.volumes) for k, s in solids.items()}
    surfaces: dict[str, list[int]] = {}
    centres: dict[str, np.ndarray] = {}
    seat_reports, mount_reports = {}, {}
    for i, seat in enumerate(seats):
        faces, rep = find_seat(seat, cands[seat.part], solids[seat.part].bbox, f"seats[{i}]")
        surfaces[rep.group] = faces
        centres[rep.group] = rep.centre
        seat_reports[seat.name] = rep
        log.info("%s", rep.summary())
    for i, mount in enumerate(mounts):
        face_groups, rep = find_mount(mount, cands[mount.part], f"mounts[{i}]")
        for name, faces, c in zip(rep.groups, face_groups, rep.centres, strict=True):
            _unused(name, surfaces, f"mounts[{i}]")
            surfaces[name] = faces
            centres[name] = np.asarray(c, dtype=float)
        mount_reports[mount.name] = rep
        log.info("%s", rep.summary())
    _disjoint({k: set(v) for k, v in surfaces.items()}, "face")
    sizes = {p.name: (p.size if p.size is not None else opts.size) for p in parts}
    seat_sizes = {f: sizes[s.part] * opts.bore_factor for s in seats
                  for f in surfaces[s.group_name]}
    n_est = _check_count(solids, sizes, seat_sizes, opts.curvature_points, max_elements)
    for name, s in solids.items():
        pts = points_of([(3, v) for v in s.volumes])
        gmsh.model.mesh.setSize(pts, sizes[name])
    for seat in seats:
        faces = surfaces[seat.group_name]
        gmsh.model.mesh.setSize(points_of([(2, f) for f in faces]),
                                sizes[seat.part] * opts.bore_factor)
    groups = _add_groups({k: s.volumes for k, s in solids.items()}, surfaces)
    vols = {(k if len(s.volumes) == 1 else f"{k}[{j}]"): v
            for k, s in solids.items() for j, v in enumerate(s.volumes)}
    # generate() caps every size at its options' size: the largest part size
    report = generate(vols, dataclasses.replace(opts, size=max(sizes.values())))
    log.info("%s meshed: %s (estimated %d tets)", model_name, report.summary(), n_est)
    return ImportedModel(groups=groups, centres=centres, quality=report, parts=solids,
                         seats=seat_reports, mounts=mount_reports, mesh_options=opts,
                         model_name=model_name,
                         part_volumes={k: s.volume for k, s in solids.items()},
                         estimated_elements=n_est)


def import_mesh(parts: MeshPart | Sequence[MeshPart], seats: Sequence[BearingSeat] = (),
                mounts: Sequence[Mount] = (), *, model_name: str = "imported",
                poor_sicn: float = 0.3, verbose: bool = False) -> ImportedModel:
    """Read existing volume meshes, find their seats and mounts on the boundary facets.

    Parameters
    ----------
    parts : MeshPart or sequence of MeshPart
    seats, mounts : see :func:`import_cad`
    model_name : str
    poor_sicn : float
        Elements below this minimum SICN are counted as poor in the quality report.
    verbose : bool

    Returns
    -------
    ImportedModel
        ``mesh_options`` is None; the quality is that of the file's mesh.

    Raises
    ------
    core.errors.InputError
        As :func:`import_cad`, and a mesh with inverted or flat curved elements (minimum
        SICN <= 0).
    """
    parts = [parts] if isinstance(parts, MeshPart) else list(parts)
    check_requests(parts, seats, mounts)
    ensure_initialized(verbose)
    meshes = {p.name: read_volume_mesh(p, f"parts[{i}]") for i, p in enumerate(parts)}
    bounds = {k: MeshBoundary(m.nodes, m.tets, m.face_sets, m.node_sets)
              for k, m in meshes.items()}
    facet_sets: dict[str, tuple[str, np.ndarray]] = {}
    centres: dict[str, np.ndarray] = {}
    seat_reports, mount_reports = {}, {}
    for i, seat in enumerate(seats):
        sel, rep = bounds[seat.part].find_seat(seat, f"seats[{i}]")
        facet_sets[rep.group] = (seat.part, sel)
        centres[rep.group] = rep.centre
        seat_reports[seat.name] = rep
        log.info("%s", rep.summary())
    for i, mount in enumerate(mounts):
        sels, rep = bounds[mount.part].find_mount(mount, f"mounts[{i}]")
        for name, sel, c in zip(rep.groups, sels, rep.centres, strict=True):
            _unused(name, facet_sets, f"mounts[{i}]")
            facet_sets[name] = (mount.part, sel)
            centres[name] = np.asarray(c, dtype=float)
        mount_reports[mount.name] = rep
        log.info("%s", rep.summary())
    _disjoint({k: {(p, int(i)) for i in sel} for k, (p, sel) in facet_sets.items()},
              "boundary facet")
    new_model(model_name)
    offsets, vols, solids = {}, {}, {}
    offset = 0
    for p in parts:
        m = meshes[p.name]
        offsets[p.name] = offset
        vols[p.name] = add_volume_mesh(m, offset)
        offset += len(m.nodes)
    surfaces = {name: [add_facet_surface(bounds[part].facets[sel], offsets[part])]
                for name, (part, sel) in facet_sets.items()}
    groups = _add_groups({k: [v] for k, v in vols.items()}, surfaces)
    for p in parts:
        b = bounds[p.name]
        solids[p.name] = ImportedSolid(
            name=p.name, volumes=[vols[p.name]], bbox=b.bbox,
            volume=mesh_volume(vols[p.name]), area=float(b.areas.sum()),
            notes=[f"{p.path}: {len(meshes[p.name].tets)} tetrahedra, "
                   f"{len(meshes[p.name].nodes)} nodes"] + meshes[p.name].notes)
        log.info("%s", solids[p.name].summary())
    report = quality(vols, poor_sicn)
    if not report.min_sicn > 0:
        worst = min(report.per_part, key=lambda k: report.per_part[k]["min_sicn"])
        i = [p.name for p in parts].index(worst)
        refuse_flat_elements(report.min_sicn, f"parts[{i}].path", parts[i].path)
    log.info("%s: %s", model_name, report.summary())
    return ImportedModel(groups=groups, centres=centres, quality=report, parts=solids,
                         seats=seat_reports, mounts=mount_reports, mesh_options=None,
                         model_name=model_name,
                         part_volumes={k: s.volume for k, s in solids.items()})

