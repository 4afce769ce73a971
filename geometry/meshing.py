"""Meshing of the current gmsh model in 10-node tetrahedra, and its quality."""

from __future__ import annotations

import dataclasses
import logging

import gmsh
import numpy as np

from .model import PartEntities, QualityReport
from .params import MeshOptions

log = logging.getLogger(__name__)

TET10 = 11  # gmsh element type of the 10-node tetrahedron
# Thin cylinders meshed coarsely get a few "cap" tets whose four vertices lie on
# the lateral surface; curving their edges onto the CAD makes them nearly flat.
# Their mid-edge nodes are pulled towards the chord midpoints in successive
# passes, keeping these fractions of the curvature (0 = straight-sided tet):
STRAIGHTEN_BLENDS = (0.5, 0.0)
# If the quality is still below MeshOptions.min_sicn, the model is remeshed
# with, in turn, another 2D algorithm (Frontal-Delaunay, Delaunay, MeshAdapt)
# and the next random seed. Deterministic: same parameters, same sequence.
ALGORITHMS_2D = (6, 5, 1)
MAX_RETRIES = 5

# Element-count estimate before meshing: a regular tetrahedron of edge h has volume
# h^3 / (6 sqrt 2), so a part of volume V meshed at size h holds about
# TETS_PER_SIZE_CUBED * V / h^3 tets (~8.5; gmsh's Delaunay meshes are close to it in the
# bulk, and more where thin walls or curvature force smaller elements, so the estimate
# is a lower bound). Meshing is refused above MAX_ELEMENTS (a P2 mesh of 3e6 tets has
# ~1.3e7 DOF, beyond what the FE and Craig-Bampton stages hold in 24 GB).
TETS_PER_SIZE_CUBED = 6.0 * 2.0 ** 0.5
MAX_ELEMENTS = 3_000_000


def check_sizes(parts: dict[str, tuple[float, float, float, str, str]],
                max_elements: int = MAX_ELEMENTS) -> int:
    """Refuse element sizes that cannot mesh a part, before any meshing.

    Parameters
    ----------
    parts : dict
        Part name -> ``(volume [m^3], element size [m], largest allowed size [m], field,
        reason)``: ``field`` is the scene/MeshOptions field that sets the size, ``reason``
        names the feature that bounds it (e.g. its thinnest wall).
    max_elements : int
        Largest estimated element count of all parts together.

    Returns
    -------
    int
        The estimated element count (``TETS_PER_SIZE_CUBED * V / h^3`` summed).

    Raises
    ------
    ValueError
        Naming the field, the size, and the allowed range or the estimate.
    """
    total = 0.0
    for name, (vol, h, h_max, fld, reason) in parts.items():
        if h > h_max:
            raise ValueError(f"{fld} = {h:g} m gives an element size on part '{name}' above "
                             f"{h_max:g} m ({reason}): too coarse to mesh it; allowed "
                             f"element sizes there are (0, {h_max:g}] m")
        total += TETS_PER_SIZE_CUBED * vol / h ** 3
    if total > max_elements:
        detail = ", ".join(f"{k} {TETS_PER_SIZE_CUBED * v / h ** 3:.3g}"
                           for k, (v, h, *_r) in parts.items())
        first, (_, h0, _, f0, _) = next(iter(parts.items()))
        grow = (total / max_elements) ** (1 / 3)
        raise ValueError(f"{f0} = {h0:g} m: about {total:.3g} tetrahedra estimated "
                         f"({TETS_PER_SIZE_CUBED:.2f} V/h^3 per part: {detail}), more than "
                         f"the {max_elements:.3g} allowed; element sizes must be at least "
                         f"{grow:.3g} x larger ({f0} >= {h0 * grow:.3g} m on part '{first}')")
    return int(round(total))


#: Surface physical tags are numbered from here, in group order (:func:`add_groups`).
SURFACE_TAG0 = 101


def add_groups(volumes: dict[str, PartEntities], volume_tags: dict[str, int]
               ) -> dict[str, tuple[int, int]]:
    """Create one physical volume per part (tag ``volume_tags[name]``) and the parts'
    named surface groups (tags from :data:`SURFACE_TAG0` in the order of the parts and
    their surfaces); returns name -> ``(dim, tag)``."""
    groups: dict[str, tuple[int, int]] = {}
    for vname, part in volumes.items():
        tag = gmsh.model.addPhysicalGroup(3, [part.volume], volume_tags[vname])
        gmsh.model.setPhysicalName(3, tag, vname)
        groups[vname] = (3, tag)
    next_tag = SURFACE_TAG0
    for part in volumes.values():
        for sname, faces in part.surfaces.items():
            tag = gmsh.model.addPhysicalGroup(2, list(faces), next_tag)
            gmsh.model.setPhysicalName(2, tag, sname)
            groups[sname] = (2, tag)
            next_tag += 1
    return groups


def configure(opts: MeshOptions) -> None:
    """Set the gmsh options that make meshing deterministic and second order."""
    set_ = gmsh.option.setNumber
    set_("General.NumThreads", 1)
    set_("Mesh.MaxNumThreads1D", 1)
    set_("Mesh.MaxNumThreads2D", 1)
    set_("Mesh.MaxNumThreads3D", 1)
    set_("Mesh.Algorithm", 6)  # Frontal-Delaunay 2D
    set_("Mesh.Algorithm3D", 1)  # Delaunay 3D (serial, deterministic)
    set_("Mesh.RandomSeed", opts.seed)
    set_("Mesh.Optimize", 1)
    # generate() meshes at order 1, then calls setOrder(order) and the optimiser
    # itself (the built-in HighOrderOptimize raises on partial failure)
    set_("Mesh.ElementOrder", 1)
    set_("Mesh.SecondOrderLinear", 0)  # curved boundaries: mid-nodes on the CAD
    set_("Mesh.HighOrderOptimize", 0)
    set_("Mesh.MeshSizeMin", 0.0)
    set_("Mesh.MeshSizeMax", opts.size)
    set_("Mesh.MeshSizeFromPoints", 1)
    set_("Mesh.MeshSizeExtendFromBoundary", 1)
    set_("Mesh.MeshSizeFromCurvature", opts.curvature_points)
    set_("Mesh.SaveAll", 0)


def points_of(dim_tags: list[tuple[int, int]]) -> list[tuple[int, int]]:
    """The geometry points ``(0, tag)`` on the closure of the given entities, sorted."""
    pts = gmsh.model.getBoundary(dim_tags, combined=False, oriented=False, recursive=True)
    return sorted({(d, abs(t)) for d, t in pts if d == 0})


def set_part_size(part: PartEntities, size: float,
                  local: dict[str, float] | None = None) -> None:
    """Prescribe ``size`` [m] at every point of a part, then ``local[group]`` [m]
    at the points of the named surface groups (local refinement)."""
    pts = set(points_of([(3, part.volume)]))
    embedded = [(d, t) for d, t in gmsh.model.mesh.getEmbedded(3, part.volume) if d <= 1]
    if embedded:
        pts |= {p for p in embedded if p[0] == 0}
        pts |= set(points_of([p for p in embedded if p[0] == 1]))
    gmsh.model.mesh.setSize(sorted(pts), size)
    for name, s in (local or {}).items():
        tags = part.surfaces.get(name, [])
        if tags:
            gmsh.model.mesh.setSize(points_of([(2, t) for t in tags]), s)


def _sicn_per_element() -> dict[int, float]:
    """Minimum SICN of every 3D element (gmsh plugin ``AnalyseMeshQuality``)."""
    plugin = "AnalyseMeshQuality"
    for option, value in (("ICNMeasure", 1), ("JacobianDeterminant", 0), ("IGEMeasure", 0),
                          ("CreateView", 1), ("Recompute", 1), ("DimensionOfElements", 3)):
        gmsh.plugin.setNumber(plugin, option, value)
    before = set(gmsh.view.getTags())
    gmsh.plugin.run(plugin)
    new = [v for v in gmsh.view.getTags() if v not in before]
    if len(new) != 1:
        raise RuntimeError(f"mesh quality: plugin {plugin} created {len(new)} views")
    try:
        _, etags, data, _, _ = gmsh.view.getModelData(new[0], 0)
    finally:
        gmsh.view.remove(new[0])
    values = np.asarray(data, dtype=float).reshape(len(etags), -1)[:, 0]
    return dict(zip(np.asarray(etags, dtype=np.int64).tolist(), values.tolist(), strict=True))


def quality(parts: dict[str, int], poor_threshold: float) -> QualityReport:
    """Quality report of the current (meshed) model.

    Parameters
    ----------
    parts : dict[str, int]
        Part name -> gmsh volume entity tag.
    poor_threshold : float
        Elements with minimum SICN below this count as poor (-).

    Returns
    -------
    QualityReport
        gmsh's minimum SICN (plugin ``AnalyseMeshQuality``), poor-element count,
        element / node counts and P2 vector DOF (``3 * nodes``).
    """
    sicn_of = _sicn_per_element()
    per_part: dict[str, dict[str, float]] = {}
    all_sicn: list[float] = []
    all_nodes: list[np.ndarray] = []
    for name, vol in parts.items():
        types, etag_lists, enode_lists = gmsh.model.mesh.getElements(3, vol)
        etags_p = [int(e) for arr in etag_lists for e in arr]
        s = np.array([sicn_of[e] for e in etags_p]) if etags_p else np.zeros(0)
        nodes = np.unique(np.concatenate([np.asarray(a, dtype=np.int64) for a in enode_lists])
                          if enode_lists else np.zeros(0, dtype=np.int64))
        all_nodes.append(nodes)
        per_part[name] = {"n_elements": len(etags_p),
                          "n_nodes": int(nodes.size),
                          "min_sicn": float(s.min()) if s.size else float("nan")}
        all_sicn.extend(s.tolist())
    sicn = np.asarray(all_sicn)
    n_nodes = int(np.unique(np.concatenate(all_nodes)).size) if all_nodes else 0
    return QualityReport(
        min_sicn=float(sicn.min()) if sicn.size else float("nan"),
        n_poor=int(np.count_nonzero(sicn < poor_threshold)),
        poor_threshold=float(poor_threshold),
        n_elements=int(sicn.size),
        n_nodes=n_nodes,
        n_dofs=3 * n_nodes,
        per_part=per_part,
    )


# gmsh 10-node tet: mid-edge node 4 + k sits on the edge TET10_EDGES[k]
TET10_EDGES = ((0, 1), (1, 2), (2, 0), (3, 0), (3, 2), (3, 1))


def straighten(elements: list[int], blend: float,
               curved: dict[int, np.ndarray] | None = None) -> int:
    """Pull the mid-edge nodes of the given 10-node tets towards their chord midpoints.

    Each mid-edge node is put at ``chord_mid + blend * (curved - chord_mid)``,
    ``curved`` its position on the CAD: ``blend = 0`` makes the edge straight.
    Used on the few tets whose curved edges make them nearly flat or inverted;
    neighbours sharing an edge get the same edge.

    Parameters
    ----------
    elements : list of int
        gmsh element tags (10-node tets).
    blend : float
        Fraction of the curvature kept, in [0, 1].
    curved : dict, optional
        Node tag -> original curved position, filled on first move and reused
        so that successive calls blend from the CAD position.

    Returns
    -------
    int
        Number of mid-edge nodes moved.
    """
    curved = {} if curved is None else curved
    moved = 0
    done: set[int] = set()
    for e in elements:
        nodes = gmsh.model.mesh.getElement(int(e))[1]
        xyz = [np.asarray(gmsh.model.mesh.getNode(int(n))[0]) for n in nodes[:4]]
        for k, (i, j) in enumerate(TET10_EDGES):
            mid = int(nodes[4 + k])
            if mid in done:
                continue
            done.add(mid)
            chord = 0.5 * (xyz[i] + xyz[j])
            if mid not in curved:
                curved[mid] = np.asarray(gmsh.model.mesh.getNode(mid)[0])
            target = chord + blend * (curved[mid] - chord)
            if np.linalg.norm(curved[mid] - chord) > 0.0:
                gmsh.model.mesh.setNode(mid, target.tolist(), [])
                moved += 1
    return moved


def _bad_elements(threshold: float) -> list[int]:
    return sorted(e for e, q in _sicn_per_element().items() if q < threshold)


def generate(parts: dict[str, int], opts: MeshOptions) -> QualityReport:
    """Mesh the current model in 10-node tets and check its quality.

    If the minimum SICN is below ``opts.min_sicn`` the model is remeshed with
    another 2D algorithm / random seed (deterministically, at most
    ``MAX_RETRIES`` times, see ``ALGORITHMS_2D``).

    Raises
    ------
    RuntimeError
        Naming the part, if gmsh fails, an element is not a 10-node tet, or the
        quality stays below ``opts.min_sicn``.
    """
    report: QualityReport | None = None
    for attempt in range(MAX_RETRIES + 1):
        configure(opts)
        algo2d = ALGORITHMS_2D[attempt % len(ALGORITHMS_2D)]
        seed = opts.seed + attempt // len(ALGORITHMS_2D)
        gmsh.option.setNumber("Mesh.Algorithm", algo2d)
        gmsh.option.setNumber("Mesh.RandomSeed", seed)
        gmsh.model.mesh.clear()
        try:
            gmsh.model.mesh.generate(3)
            gmsh.model.mesh.setOrder(opts.order)
        except Exception as exc:  # noqa: BLE001 - gmsh raises a bare Exception
            log.warning("gmsh meshing failed (attempt %d): %s", attempt, exc)
            if attempt == MAX_RETRIES:
                raise RuntimeError(f"meshing of parts {sorted(parts)} failed: {exc}") from exc
            continue
        if opts.high_order_optimize:
            gmsh.option.setNumber("Mesh.HighOrderOptimize", opts.high_order_optimize)
            try:
                gmsh.model.mesh.optimize("HighOrderElastic" if opts.high_order_optimize == 2
                                         else "HighOrder")
            except Exception as exc:  # noqa: BLE001 - partial failure is checked below
                log.info("high-order optimisation incomplete: %s", exc)
        for name, vol in parts.items():
            types, etags, _ = gmsh.model.mesh.getElements(3, vol)
            if not any(len(e) for e in etags):
                raise RuntimeError(f"meshing of part '{name}' produced no tetrahedra")
            if list(types) != [TET10]:
                raise RuntimeError(f"part '{name}': element types {list(types)}, expected "
                                   f"[{TET10}] (10-node tetrahedra)")
        report = quality(parts, opts.poor_sicn)
        curved: dict[int, np.ndarray] = {}
        fixed: set[int] = set()
        for blend in STRAIGHTEN_BLENDS:
            if report.min_sicn >= opts.straighten_sicn:
                break
            bad = _bad_elements(opts.straighten_sicn)
            n = straighten(bad, blend, curved)
            fixed |= set(bad)
            log.info("%d curved tets below min SICN %.3g: kept %.0f%% of their curvature "
                     "(%d nodes moved)", len(bad), opts.straighten_sicn, 100 * blend, n)
            report = dataclasses.replace(quality(parts, opts.poor_sicn),
                                         n_straightened=len(fixed))
        if report.min_sicn >= opts.min_sicn:
            break
        worst = min(report.per_part, key=lambda k: report.per_part[k]["min_sicn"])
        log.info("min SICN %.3g < %.3g in part '%s' (2D algorithm %d, seed %d); remeshing",
                 report.min_sicn, opts.min_sicn, worst, algo2d, seed)
    assert report is not None
    if report.min_sicn < opts.min_sicn:
        worst = min(report.per_part, key=lambda k: report.per_part[k]["min_sicn"])
        raise RuntimeError(f"mesh quality too low in part '{worst}': min SICN "
                           f"{report.min_sicn:.3g} < mesh.min_sicn = {opts.min_sicn:g} after "
                           f"{MAX_RETRIES + 1} attempts; refine mesh.size or change the "
                           "geometry")
    return report


def mesh_volume(vol: int) -> float:
    """Volume [m³] of the 10-node tets of volume entity ``vol`` (Gauss rule of
    degree 4, exact for the cubic Jacobian determinant of a quadratic tet)."""
    local, weights = gmsh.model.mesh.getIntegrationPoints(TET10, "Gauss4")
    _, dets, _ = gmsh.model.mesh.getJacobians(TET10, local, vol)
    dets = np.asarray(dets).reshape(-1, len(weights))
    return float(np.sum(dets @ np.asarray(weights))) if dets.size else 0.0
