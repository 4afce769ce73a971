"""Existing volume meshes read as parts: gmsh ``.msh``, Abaqus ``.inp``, NASTRAN ``.bdf``.

A ``.msh`` file is merged into a scratch gmsh model (its physical surface names become
face sets); Abaqus and NASTRAN files are read with meshio (``*NSET`` node sets of an
``.inp`` become node sets). The tetrahedra are checked before any work:

* 10-node tetrahedra are kept. Each element's six mid-edge nodes are matched to its
  edges geometrically (nearest chord midpoint), so any file convention (gmsh's edge order
  ``01 12 20 03 23 13``, Abaqus/NASTRAN/VTK's ``01 12 20 03 13 23``) ends in gmsh order;
* 4-node tetrahedra are refused (``first_order = "refuse"``, the default), or upgraded
  (``"upgrade"``) with a mid node on each straight edge: curved surfaces stay faceted, a
  note says so (a linear mesh of a curved bore is stiffer and lighter than the CAD);
* other 3-D elements (hexahedra, prisms, pyramids) or none at all are refused;
* tetrahedra of negative volume are turned over (noted).

Coordinates are scaled from the caller's ``unit`` to metres and the bounding box checked
as for CAD parts (:func:`geometry.cad.check_size`). Never imports meshio at module level
(an optional dependency: ``pip install meshio``).
"""

from __future__ import annotations

import logging
import os
from dataclasses import dataclass, field
from pathlib import Path

import gmsh
import numpy as np

from core.errors import InputError

from .cad import LENGTH_UNITS, PLAUSIBLE_SIZE, check_file, check_size
from .session import ensure_initialized

log = logging.getLogger(__name__)

#: Mesh file suffixes -> reader.
MESH_SUFFIXES = {".msh": "gmsh", ".inp": "abaqus", ".bdf": "nastran", ".nas": "nastran",
                 ".fem": "nastran"}
FIRST_ORDER = ("refuse", "upgrade")
GMSH_TET4, GMSH_TET10 = 4, 11
GMSH_TRI3, GMSH_TRI6 = 2, 9
GMSH_OTHER_3D = {5: "hexahedron", 6: "prism", 7: "pyramid", 12: "hexahedron27",
                 13: "prism18", 14: "pyramid14", 17: "hexahedron20", 18: "prism15",
                 19: "pyramid13", 29: "tetrahedron20"}
# corners of the six edges, in the gmsh order of the 10-node tetrahedron's mid nodes
TET_EDGES = np.array([[0, 1], [1, 2], [2, 0], [3, 0], [3, 2], [3, 1]])
# largest distance of a mid node from its chord midpoint, in edge lengths
MID_NODE_TOL = 0.25


@dataclass(frozen=True)
class MeshPart:
    """One existing volume mesh read as one part.

    Attributes
    ----------
    name : str
        Physical volume name (``"housing"``).
    path : str or Path
        ``.msh`` (gmsh), ``.inp`` (Abaqus), ``.bdf`` / ``.nas`` / ``.fem`` (NASTRAN).
    unit : str
        Unit of the node coordinates in the file (:data:`geometry.cad.LENGTH_UNITS`).
    first_order : str
        ``"refuse"`` a mesh of 4-node tetrahedra, or ``"upgrade"`` it (straight edges).
    plausible_size : (float, float)
        Allowed range of the bounding-box diagonal [m].
    """

    name: str
    path: str | os.PathLike[str]
    unit: str = "mm"
    first_order: str = "refuse"
    plausible_size: tuple[float, float] = PLAUSIBLE_SIZE

    def validate(self, where: str = "part") -> None:
        """Check the fields and the file (:class:`InputError` naming the field)."""
        import re

        if not isinstance(self.name, str) or not re.fullmatch(r"[A-Za-z][\w-]*", self.name):
            raise InputError.of(f"{where}.name", self.name,
                                "must be a name of letters, digits, '_' or '-'")
        if self.unit not in LENGTH_UNITS:
            raise InputError.of(f"{where}.unit", self.unit,
                                f"must be one of {', '.join(map(repr, LENGTH_UNITS))}")
        if self.first_order not in FIRST_ORDER:
            raise InputError.of(f"{where}.first_order", self.first_order,
                                f"must be one of {', '.join(map(repr, FIRST_ORDER))}")
        check_file(self.path, f"{where}.path", MESH_SUFFIXES)


@dataclass
class VolumeMesh:
    """A tetrahedral volume mesh in metres, 10-node tetrahedra in gmsh order.

    Attributes
    ----------
    nodes : numpy.ndarray, shape (n, 3)
        [m]
    tets : numpy.ndarray of int64, shape (m, 10)
        0-based node indices.
    face_sets : dict[str, numpy.ndarray]
        Named face sets, (k, 3 or 6) node indices.
    node_sets : dict[str, numpy.ndarray]
        Named node sets (0-based).
    notes : list[str]
        What was done (upgrade, reordering, turned elements, unused nodes).
    """

    nodes: np.ndarray
    tets: np.ndarray
    face_sets: dict[str, np.ndarray] = field(default_factory=dict)
    node_sets: dict[str, np.ndarray] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)


def _read_gmsh(path: Path, fld: str) -> tuple[np.ndarray, dict[int, np.ndarray],
                                               dict[str, np.ndarray], dict[str, np.ndarray]]:
    """Nodes, 3-D elements by gmsh type (0-based), face sets, node sets of a ``.msh``."""
    ensure_initialized()
    current = gmsh.model.getCurrent() if gmsh.model.list() else None
    scratch = "_read_msh"
    if scratch in gmsh.model.list():
        gmsh.model.setCurrent(scratch)
        gmsh.model.remove()
    gmsh.model.add(scratch)
    try:
        try:
            gmsh.merge(str(path))
        except Exception as exc:  # noqa: BLE001 - gmsh raises a bare Exception
            raise InputError.of(fld, str(path), f"gmsh cannot read it ({exc})") from exc
        tags, xyz, _ = gmsh.model.mesh.getNodes()
        tags = np.asarray(tags, dtype=np.int64)
        index = np.full(int(tags.max(initial=0)) + 1, -1, dtype=np.int64)
        index[tags] = np.arange(tags.size)
        nodes = np.asarray(xyz, dtype=float).reshape(-1, 3)
        elems: dict[int, np.ndarray] = {}
        for et in gmsh.model.mesh.getElementTypes(3):
            _, enodes = gmsh.model.mesh.getElementsByType(int(et))
            n = gmsh.model.mesh.getElementProperties(int(et))[3]
            elems[int(et)] = index[np.asarray(enodes, dtype=np.int64).reshape(-1, n)]
        face_sets: dict[str, np.ndarray] = {}
        node_sets: dict[str, np.ndarray] = {}
        for dim, ptag in gmsh.model.getPhysicalGroups():
            name = gmsh.model.getPhysicalName(dim, ptag)
            if not name or dim not in (0, 1, 2):
                continue
            if dim == 2:
                rows = []
                for ent in gmsh.model.getEntitiesForPhysicalGroup(dim, ptag):
                    types, _, enodes = gmsh.model.mesh.getElements(2, int(ent))
                    for et, en in zip(types, enodes, strict=True):
                        n = gmsh.model.mesh.getElementProperties(int(et))[3]
                        if int(et) in (GMSH_TRI3, GMSH_TRI6):
                            rows.append(index[np.asarray(en, np.int64).reshape(-1, n)[:, :3]])
                if rows:
                    face_sets[name] = np.vstack(rows)
            ntags, _ = gmsh.model.mesh.getNodesForPhysicalGroup(dim, ptag)
            node_sets[name] = index[np.asarray(ntags, dtype=np.int64)]
    finally:
        gmsh.model.setCurrent(scratch)
        gmsh.model.remove()
        if current is not None and current in gmsh.model.list():
            gmsh.model.setCurrent(current)
    return nodes, elems, face_sets, node_sets


_MESHIO_3D = {"tetra": GMSH_TET4, "tetra10": GMSH_TET10, "hexahedron": 5, "wedge": 6,
              "pyramid": 7, "hexahedron20": 17, "hexahedron27": 12, "wedge15": 18,
              "pyramid13": 19, "tetra20": 29}


def _read_meshio(path: Path, fmt: str, fld: str) -> tuple[np.ndarray, dict[int, np.ndarray],
                                                          dict[str, np.ndarray],
                                                          dict[str, np.ndarray]]:
    try:
        import meshio
    except ImportError as exc:
        raise InputError.of(fld, str(path), "reading Abaqus or NASTRAN meshes needs meshio "
                            "(pip install meshio)") from exc
    try:
        mesh = meshio.read(str(path), file_format=fmt)
    except Exception as exc:  # noqa: BLE001 - meshio raises many kinds
        raise InputError.of(fld, str(path), f"meshio cannot read it as {fmt} "
                            f"({type(exc).__name__}: {exc})") from exc
    elems: dict[int, list[np.ndarray]] = {}
    for block in mesh.cells:
        et = _MESHIO_3D.get(block.type)
        if et is not None:
            elems.setdefault(et, []).append(np.asarray(block.data, dtype=np.int64))
    node_sets = {k: np.asarray(v, dtype=np.int64).reshape(-1)
                 for k, v in (mesh.point_sets or {}).items()}
    return (np.asarray(mesh.points, dtype=float)[:, :3],
            {k: np.vstack(v) for k, v in elems.items()}, {}, node_sets)


def order_mid_nodes(nodes: np.ndarray, tets: np.ndarray, block: int = 65536
                    ) -> tuple[np.ndarray, int]:
    """Put each 10-node tetrahedron's mid nodes in gmsh's edge order, by position.

    Parameters
    ----------
    nodes : numpy.ndarray, shape (n, 3)
    tets : numpy.ndarray of int, shape (m, 10)
    block : int
        Elements handled at once (bounds the memory: 36 distances per element).

    Returns
    -------
    (tets, n_reordered)
        The reordered connectivity and the number of elements changed.

    Raises
    ------
    ValueError
        If an element's mid nodes are not one per edge, near its chord midpoint.
    """
    out = tets.copy()
    n_changed = 0
    for b0 in range(0, len(tets), block):
        t = tets[b0:b0 + block]
        corners = nodes[t[:, :4]]
        a, b = corners[:, TET_EDGES[:, 0]], corners[:, TET_EDGES[:, 1]]
        chord, length = 0.5 * (a + b), np.linalg.norm(a - b, axis=2)  # (m, 6)
        mids = nodes[t[:, 4:]]
        dist = np.linalg.norm(chord[:, :, None, :] - mids[:, None, :, :], axis=3)
        pick = np.argmin(dist, axis=2)  # the mid node of each edge
        best = np.take_along_axis(dist, pick[:, :, None], axis=2)[:, :, 0]
        ok = ((np.sort(pick, axis=1) == np.arange(6)).all(axis=1)
              & (best <= MID_NODE_TOL * length).all(axis=1))
        if not ok.all():
            bad = b0 + int(np.flatnonzero(~ok)[0])
            raise ValueError(f"element {bad}: its mid-edge nodes are not one per edge near "
                             "the edge midpoints (not a 10-node tetrahedron of a known node "
                             "order)")
        out[b0:b0 + block, 4:] = np.take_along_axis(t[:, 4:], pick, axis=1)
        n_changed += int(np.count_nonzero((pick != np.arange(6)).any(axis=1)))
    return out, n_changed


def upgrade_to_tet10(nodes: np.ndarray, tets4: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """10-node tetrahedra with a new node at the middle of every (straight) edge."""
    edges = tets4[:, TET_EDGES].reshape(-1, 2)
    key = np.sort(edges, axis=1)
    uniq, inv = np.unique(key, axis=0, return_inverse=True)
    mids = 0.5 * (nodes[uniq[:, 0]] + nodes[uniq[:, 1]])
    tets = np.hstack([tets4, len(nodes) + inv.reshape(-1, 6)])
    return np.vstack([nodes, mids]), tets


def _turn_inverted(nodes: np.ndarray, tets: np.ndarray) -> tuple[np.ndarray, int]:
    x = nodes[tets[:, :4]]
    vol = np.einsum("ij,ij->i", np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]), x[:, 3] - x[:, 0])
    bad = vol < 0
    if bad.any():  # swap corners 1, 2: edges 01<->02 (mid 4<->6), 13<->23 (mid 9<->8)
        tets = tets.copy()
        tets[bad] = tets[bad][:, [0, 2, 1, 3, 6, 5, 4, 7, 9, 8]]
    if np.any(vol == 0):
        raise ValueError(f"{int(np.count_nonzero(vol == 0))} tetrahedra have zero volume")
    return tets, int(bad.sum())


def read_volume_mesh(part: MeshPart, where: str = "part") -> VolumeMesh:
    """Read, check and convert one mesh part (see the module docstring).

    Raises
    ------
    core.errors.InputError
        Naming the field: the file (missing, unreadable, no or other 3-D elements,
        malformed tetrahedra), ``first_order``, or the unit (implausible size).
    """
    part.validate(where)
    path = Path(part.path)
    fld = f"{where}.path"
    fmt = MESH_SUFFIXES[path.suffix.lower()]
    if fmt == "gmsh":
        nodes, elems, face_sets, node_sets = _read_gmsh(path, fld)
    else:
        nodes, elems, face_sets, node_sets = _read_meshio(path, fmt, fld)
    notes: list[str] = []
    other = sorted(GMSH_OTHER_3D.get(t, str(t)) for t in elems if t not in (GMSH_TET4,
                                                                               GMSH_TET10))
    if other:
        raise InputError.of(fld, str(path), f"holds {', '.join(other)} elements: only "
                            "tetrahedra (4 or 10 nodes) are read")
    if GMSH_TET10 in elems and GMSH_TET4 in elems:
        raise InputError.of(fld, str(path), "mixes 4-node and 10-node tetrahedra")
    if GMSH_TET10 in elems:
        try:
            tets, n_re = order_mid_nodes(nodes, elems[GMSH_TET10])
        except ValueError as exc:
            raise InputError.of(fld, str(path), str(exc)) from exc
        if n_re:
            notes.append(f"mid-edge nodes of {n_re} of {len(tets)} tetrahedra put in gmsh "
                         "order (the file's order differs)")
    elif GMSH_TET4 in elems:
        if part.first_order == "refuse":
            raise InputError.of(f"{where}.first_order", part.first_order,
                                f"{path.name} holds 4-node tetrahedra; geardyn needs "
                                "10-node ones: remesh at second order, or set first_order "
                                "= 'upgrade' (mid nodes on straight edges: curved surfaces "
                                "stay faceted)")
        nodes, tets = upgrade_to_tet10(nodes, elems[GMSH_TET4])
        notes.append(f"{len(tets)} 4-node tetrahedra upgraded to 10 nodes on straight edges:"
                     " curved surfaces stay faceted (stiffer and lighter than the CAD)")
    else:
        raise InputError.of(fld, str(path), "holds no tetrahedra (a surface mesh?)")
    try:
        tets, n_turned = _turn_inverted(nodes, tets)
    except ValueError as exc:
        raise InputError.of(fld, str(path), str(exc)) from exc
    if n_turned:
        notes.append(f"{n_turned} tetrahedra of negative volume turned over")
    used = np.unique(tets)
    if used.size < len(nodes):  # drop nodes in no tetrahedron, renumber
        notes.append(f"{len(nodes) - used.size} nodes in no tetrahedron dropped")
        new = np.full(len(nodes), -1, dtype=np.int64)
        new[used] = np.arange(used.size)
        nodes, tets = nodes[used], new[tets]
        face_sets = {k: new[v] for k, v in face_sets.items()}
        node_sets = {k: new[v][new[v] >= 0] for k, v in node_sets.items()}
    nodes = nodes * LENGTH_UNITS[part.unit]
    check_size(np.array([nodes.min(axis=0), nodes.max(axis=0)]), part.unit,
               part.plausible_size, f"{where}.unit", path.name)
    for note in notes:
        log.info("%s: %s", path.name, note)
    return VolumeMesh(nodes=nodes, tets=np.asarray(tets, dtype=np.int64),
                      face_sets=face_sets, node_sets=node_sets, notes=notes)


def refuse_flat_elements(min_sicn: float, field: str, path: str | os.PathLike[str]) -> None:
    """Refuse a file's mesh whose quality report has inverted or flat curved elements
    (minimum SICN <= 0), naming ``field`` and the file."""
    if not min_sicn > 0:
        raise InputError.of(field, str(path), f"holds inverted or flat elements (min SICN "
                            f"{min_sicn:.3g} <= 0): fix the mesh")


def add_volume_mesh(mesh: VolumeMesh, node_offset: int = 0) -> int:
    """Add the mesh to the current gmsh model as a discrete volume; returns its tag.

    Node tags are ``node_offset + 1 ..``; the caller keeps them contiguous over parts
    (DOLFINx's ``model_to_mesh`` takes node tag - 1 as the node index).
    """
    vol = gmsh.model.addDiscreteEntity(3)
    n = len(mesh.nodes)
    gmsh.model.mesh.addNodes(3, vol, np.arange(node_offset + 1, node_offset + n + 1),
                             mesh.nodes.ravel())
    gmsh.model.mesh.addElementsByType(vol, GMSH_TET10, [],
                                      (mesh.tets + node_offset + 1).ravel())
    return vol


def add_facet_surface(facets: np.ndarray, node_offset: int = 0) -> int:
    """Add 6-node triangles (0-based node indices) as a discrete surface; its tag."""
    surf = gmsh.model.addDiscreteEntity(2)
    gmsh.model.mesh.addElementsByType(surf, GMSH_TRI6, [], (facets + node_offset + 1).ravel())
    return surf

