"""The housing's displacement field data, computed once with the ROM: its second-order
nodes and cells in input-mesh order and the rows of ``P T`` at its nodes, written to
``housing.h5`` beside ``rom.h5`` so that the export writes the housing fields
(``study.outputs.fields``) from the file alone, without the mesh or the FE model.

``housing.h5`` (all lengths in m, ``u = u_rows @ q`` per node):

========================  ===================================================
``points``                (n_p, 3) float64, geometry nodes of the part's cells
``node_ids``              (n_p,) int64, their input-mesh (gmsh) node numbers, ascending
``cells``                 (n_c, 10) int64, ``Tetrahedron_10`` (XDMF/VTK order) into
                          ``points``, sorted by their vertices' input numbers
``u_rows``                (n_p, 3, n_r) float64, displacement per unit ROM coordinate
attributes                ``part``, ``part_tag`` (volume tag), ``n_r``
========================  ===================================================

Nodes and cells are ordered by input-mesh numbers, so the file is the same whatever
the number of ranks that reduced the model (DOLFINx's own checkpoints use the input
numbering the same way). ``u_rows`` is written and read in blocks of nodes
(:data:`BLOCK_BYTES`): at 1.5 M DOF it is about 1 GB for n_r = 112, so neither the rom
stage's rank 0 nor the export holds it whole.
"""
from __future__ import annotations

import contextlib
import logging
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from core.files import atomic_write
from fem.post.operator import point_rows
from fem.post.surface import cell_geometry_nodes, gather_on_root, input_ids, node_blocks

logger = logging.getLogger(__name__)

__all__ = ["BLOCK_BYTES", "HOUSING_FILE", "TET10_VTK", "HousingData", "housing_data",
           "nodes_per_block", "read_housing"]

#: File of the housing field data in a cached ROM entry.
HOUSING_FILE = "housing.h5"
#: Bytes of ``u_rows`` per block written (rom stage) or read (export).
BLOCK_BYTES = 64 << 20
#: XDMF/VTK order of the 10 nodes of a P2 tetrahedron from the DOLFINx (basix) order:
#: vertices, then the edge nodes of edges 01, 12, 02, 03, 13, 23 (basix edges 5, 2, 4, 3, 1, 0).
TET10_VTK = np.array([0, 1, 2, 3, 9, 6, 8, 7, 5, 4])


def nodes_per_block(n_r: int, block_bytes: int = BLOCK_BYTES) -> int:
    """Nodes of ``u_rows`` (3 × n_r float64 each) in a block of ``block_bytes``."""
    return max(1, int(block_bytes) // (3 * max(int(n_r), 1) * 8))


def _owned_part_cells(fe_mesh: Any, tag: int) -> np.ndarray:
    """This rank's owned cells of the volume ``tag``, ascending."""
    cells = np.sort(fe_mesh.cell_tags.find(tag))
    return cells[cells < fe_mesh.mesh.topology.index_map(3).size_local]


def _global_numbering(comm: Any, ids: np.ndarray, x: np.ndarray, cell_ids: np.ndarray):
    """On rank 0: the part's nodes merged over the ranks (ascending input numbers), their
    positions, the cells in VTK order and sorted, and for every rank the output position
    of each of its nodes that it supplies (−1 where a lower rank has the node). Each
    rank gets its positions; the other outputs are None off rank 0."""
    all_ids = comm.gather(ids, root=0)
    all_x = gather_on_root(comm, x)
    all_cells = gather_on_root(comm, cell_ids)
    parts = uid = points = conn = None
    if comm.rank == 0:
        cat = np.concatenate(all_ids)
        uid, first = np.unique(cat, return_index=True)     # first: the lowest rank's copy
        points = all_x[first].copy()
        pos = np.full(cat.size, -1, dtype=np.int64)
        pos[first] = np.arange(uid.size)
        parts = np.split(pos, np.cumsum([a.size for a in all_ids])[:-1])
        order = np.lexsort(np.sort(all_cells[:, :4], axis=1).T[::-1])
        conn = np.searchsorted(uid, all_cells[order])[:, TET10_VTK]
    return comm.scatter(parts, root=0), uid, points, conn


def housing_data(model: Any, PT: Any, path: str | Path, part: str = "housing",
                 block_bytes: int = BLOCK_BYTES) -> None:
    """Write ``part``'s field data (module docstring) to ``path``; collective on
    ``model.comm``, rank 0 writes.

    Each rank takes its owned cells of ``part``; rank 0 numbers their nodes by their
    input numbers (a node on several ranks is supplied by the lowest). Then, block of
    nodes by block, each rank takes the rows of the distributed ``P T`` at its nodes of
    the block (:func:`fem.post.operator.point_rows`) and rank 0 receives and writes
    them: no rank holds more than a block of rows.

    Parameters
    ----------
    model : fem.FEModel
    PT : PETSc dense Mat
        ``P T`` (:func:`fem.post.operator.field_operator`).
    path : path of the HDF5 file.
    part : str
        Volume group.
    block_bytes : int
        Size of the blocks of ``u_rows`` gathered on rank 0.
    """
    import h5py

    fm = model.fe_mesh
    mesh = fm.mesh
    comm = mesh.comm
    tag = fm.tag(part, 3)
    cells = _owned_part_cells(fm, tag)
    conn = cell_geometry_nodes(mesh, cells)                           # DOLFINx order
    used = np.unique(conn)
    ids = input_ids(mesh, used)
    order = np.argsort(ids)
    used, ids = used[order], ids[order]
    pos, uid, points, vtk_cells = _global_numbering(comm, ids, mesh.geometry.x[used],
                                                    input_ids(mesh, conn))
    mine = pos >= 0                                     # ascending positions (ids sorted)
    pos = pos[mine]
    blocks = node_blocks(mesh, model.V, cells)[used[mine]][:, None]       # (n_s, 1)
    n_r = int(PT.getSize()[1])
    n_p = comm.bcast(None if uid is None else int(uid.size), root=0)
    per = nodes_per_block(n_r, block_bytes)
    with contextlib.ExitStack() as rank0:
        ds = None
        if comm.rank == 0:
            f = rank0.enter_context(h5py.File(rank0.enter_context(atomic_write(Path(path))),
                                              "w"))
            f["points"] = points
            f["node_ids"] = uid
            f["cells"] = vtk_cells.astype(np.int64)
            ds = f.create_dataset("u_rows", shape=(n_p, 3, n_r), dtype=np.float64)
            f.attrs.update({"part": part, "part_tag": tag, "n_r": n_r})
        for a in range(0, n_p, per):
            b = min(a + per, n_p)
            lo, hi = np.searchsorted(pos, [a, b])
            rows = point_rows(model, PT, blocks[lo:hi], np.ones(1))     # collective
            got = comm.gather((pos[lo:hi], rows), root=0)
            if ds is not None:
                buf = np.empty((b - a, 3, n_r))
                for p, r in got:
                    buf[p - a] = r
                ds[a:b] = buf
    if comm.rank == 0:
        logger.info("housing field data of %r: %d nodes, %d cells, rows %.1f MB (%d ranks)",
                    part, n_p, vtk_cells.shape[0], n_p * 3 * n_r * 8 / 1e6, comm.size)


@dataclass(frozen=True)
class HousingData:
    """A part's field data of ``housing.h5`` (:func:`housing_data`): the mesh in memory,
    the rows ``u_rows`` read in blocks on demand.

    Attributes
    ----------
    path : Path
        The file.
    points : (n_p, 3) float
        Geometry nodes [m].
    cells : (n_c, 10) int
        ``Tetrahedron_10`` connectivity (XDMF/VTK order) into ``points``.
    part : str
        Volume group name.
    part_tag : int
        Its volume tag (``part_id`` of the cells).
    n_r : int
        ROM coordinates.
    """

    path: Path
    points: np.ndarray
    cells: np.ndarray
    part: str
    part_tag: int
    n_r: int

    def row_blocks(self, nodes: int | None = None) -> Iterator[tuple[int, int, np.ndarray]]:
        """``(a, b, u_rows[a:b])`` over consecutive blocks of ``nodes`` nodes (default:
        :data:`BLOCK_BYTES` of rows), each (b − a, 3, n_r): displacement per unit ROM
        coordinate [m]."""
        import h5py

        per = nodes_per_block(self.n_r) if nodes is None else max(1, int(nodes))
        with h5py.File(self.path, "r") as f:
            ds = f["u_rows"]
            for a in range(0, ds.shape[0], per):
                b = min(a + per, ds.shape[0])
                yield a, b, ds[a:b]


def read_housing(path: str | Path) -> HousingData:
    """The :class:`HousingData` of ``path``; FileNotFoundError naming what to do when the
    file is absent (a ROM reduced before the file existed)."""
    import h5py

    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(f"{p}: no housing field data in the cached ROM; reduce it "
                                "again (geardyn reduce --no-cache)")
    with h5py.File(p, "r") as f:
        return HousingData(p, f["points"][()], f["cells"][()], str(f.attrs["part"]),
                           int(f.attrs["part_tag"]), int(f.attrs["n_r"]))
