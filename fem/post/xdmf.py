"""Minimal XDMF 3 + HDF5 writer for ParaView: one mesh, point and cell data, optionally
a temporal collection. Written atomically (both files go to temporary files beside
their final names, then the ``.h5`` and last the ``.xdmf`` are renamed into place).

Data may be given whole (:func:`write_xdmf`) or filled block by block
(:func:`xdmf_writer`: declare a dataset, write row ranges of it), so that a field far
larger than memory can be written from blocks of a basis (``fem.post.fields``).

meshio's own XDMF time-series writer puts its ``.h5`` in the current working
directory, and DOLFINx's ``XDMFFile`` writes its own mesh (P2 geometry of the whole
mesh, not a part's nodes in input order), hence this writer. Cell connectivity must
already be in XDMF/VTK node order (``Tetrahedron_10``: vertices, then edges 01, 12, 02,
03, 13, 23; ``Triangle_6``: vertices, then edges 01, 12, 20).
"""
from __future__ import annotations

import contextlib
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from core.files import atomic_write

__all__ = ["TOPOLOGY", "XdmfFile", "write_xdmf", "xdmf_writer"]

#: meshio-style cell type -> (XDMF topology name, nodes per cell).
TOPOLOGY = {"tetra10": ("Tetrahedron_10", 10), "triangle6": ("Triangle_6", 6),
            "tetra": ("Tetrahedron", 4), "triangle": ("Triangle", 3)}
_CENTERS = ("Node", "Cell")


def _item(h5name: str, path: str, dtype: np.dtype, shape: tuple[int, ...]) -> str:
    kind = "Int" if np.issubdtype(dtype, np.integer) else "Float"
    dims = " ".join(str(d) for d in shape)
    return (f'<DataItem Dimensions="{dims}" NumberType="{kind}" Precision="{dtype.itemsize}" '
            f'Format="HDF">{h5name}:{path}</DataItem>')


def _attr_type(shape: tuple[int, ...]) -> str:
    if len(shape) == 1:
        return "Scalar"
    if len(shape) == 2 and shape[1] == 3:
        return "Vector"
    raise ValueError(f"data of shape {shape}: must be (n,) or (n, 3)")


class XdmfFile:
    """An XDMF file being written (made by :func:`xdmf_writer`): declare datasets with
    :meth:`add` (whole array) or :meth:`create` (filled by the caller), static or per
    frame. The attributes appear in the XML in the order they were declared, static ones
    before a frame's own in every frame."""

    def __init__(self, h5: Any, h5name: str, n_points: int, n_cells: int,
                 times: Sequence[float] | None) -> None:
        self._h5 = h5
        self._h5name = h5name
        self._n = {"Node": n_points, "Cell": n_cells}
        self.times = None if times is None else [float(t) for t in times]
        self._static: list[str] = []
        self._frames: list[list[str]] = [[] for _ in (self.times or [])]

    def _declare(self, name: str, center: str, frame: int | None, shape: tuple[int, ...],
                 dtype: np.dtype) -> str:
        if center not in _CENTERS:
            raise ValueError(f"center = {center!r}: must be one of {_CENTERS}")
        if shape[0] != self._n[center]:
            raise ValueError(f"{center.lower()} data {name!r}: {shape[0]} rows, "
                             f"expected {self._n[center]}")
        if frame is not None and not 0 <= frame < len(self._frames):
            raise ValueError(f"frame = {frame}: the file has {len(self._frames)} frames")
        prefix = "static" if frame is None else f"frame_{frame}"
        key = f"{prefix}/{center.lower()}/{name}"
        xml = (f'<Attribute Name="{name}" AttributeType="{_attr_type(shape)}" '
               f'Center="{center}">{_item(self._h5name, "/" + key, np.dtype(dtype), shape)}'
               "</Attribute>")
        (self._static if frame is None else self._frames[frame]).append(xml)
        return key

    def add(self, name: str, data: np.ndarray, center: str = "Node",
            frame: int | None = None) -> None:
        """Write ``data`` ((n,) or (n, 3)) as attribute ``name`` (static, or of ``frame``)."""
        arr = np.asarray(data)
        key = self._declare(name, center, frame, arr.shape, arr.dtype)
        self._h5[key] = arr

    def create(self, name: str, width: int | None = 3, center: str = "Node",
               frame: int | None = None, dtype: Any = np.float64) -> Any:
        """An empty dataset for attribute ``name`` of shape (n,) (``width=None``) or
        (n, width), to be filled by row ranges (``ds[a:b] = block``)."""
        shape = (self._n[center],) if width is None else (self._n[center], int(width))
        key = self._declare(name, center, frame, shape, np.dtype(dtype))
        return self._h5.create_dataset(key, shape=shape, dtype=dtype)

    def xml(self, mesh_xml: str) -> str:
        """The XDMF document (once every dataset is declared)."""
        static = "".join(self._static)
        if self.times is None:
            grids = f'<Grid Name="mesh" GridType="Uniform">{mesh_xml}{static}</Grid>'
        else:
            inner = [f'<Grid Name="mesh" GridType="Uniform">{mesh_xml}'
                     f'<Time Value="{t!r}"/>' + static + "".join(own) + "</Grid>"
                     for t, own in zip(self.times, self._frames, strict=True)]
            grids = ('<Grid Name="TimeSeries" GridType="Collection" '
                     'CollectionType="Temporal">' + "\n".join(inner) + "</Grid>")
        return ('<?xml version="1.0"?>\n<Xdmf Version="3.0" '
                'xmlns:xi="http://www.w3.org/2001/XInclude">\n<Domain>\n'
                + grids + "\n</Domain>\n</Xdmf>\n")


@contextlib.contextmanager
def xdmf_writer(path: str | Path, points: np.ndarray, cell_type: str, cells: np.ndarray,
                times: Sequence[float] | None = None) -> Iterator[XdmfFile]:
    """Write ``path`` (``.xdmf``) and its ``.h5`` atomically: the mesh is written on
    entry, the caller adds the data (:class:`XdmfFile`), the XML is written last.

    Parameters
    ----------
    points : (n_p, 3) float
        Node coordinates [m].
    cell_type : str
        ``tetra10``, ``triangle6``, ``tetra`` or ``triangle``.
    cells : (n_c, k) int
        Connectivity in XDMF node order.
    times : sequence of float, optional
        Times [s] of a temporal collection (frames ``0 … len(times) − 1``); static data
        are repeated in every frame.
    """
    import h5py

    path = Path(path)
    if path.suffix != ".xdmf":
        raise ValueError(f"path = {str(path)!r}: must end with .xdmf")
    if cell_type not in TOPOLOGY:
        raise ValueError(f"cell_type = {cell_type!r}: must be one of {sorted(TOPOLOGY)}")
    topo, k = TOPOLOGY[cell_type]
    cells = np.asarray(cells, dtype=np.int64)
    points = np.asarray(points, dtype=float)
    if cells.ndim != 2 or cells.shape[1] != k:
        raise ValueError(f"cells.shape = {cells.shape}: must be (n, {k}) for {cell_type}")
    if cells.size and (cells.min() < 0 or cells.max() >= len(points)):
        raise ValueError("cells: node index out of range")
    h5name = path.with_suffix(".h5").name
    mesh_xml = (f'<Topology TopologyType="{topo}" NumberOfElements="{len(cells)}">'
                f'{_item(h5name, "/mesh/topology", cells.dtype, cells.shape)}</Topology>'
                f'<Geometry GeometryType="XYZ">'
                f'{_item(h5name, "/mesh/geometry", points.dtype, points.shape)}</Geometry>')
    with atomic_write(path.with_suffix(".h5")) as tmp, h5py.File(tmp, "w") as f:
        f["mesh/geometry"] = points
        f["mesh/topology"] = cells
        out = XdmfFile(f, h5name, len(points), len(cells), times)
        yield out
    with atomic_write(path, "w") as fx:  # after the .h5 it points into
        fx.write(out.xml(mesh_xml))


def write_xdmf(path: str | Path, points: np.ndarray, cell_type: str, cells: np.ndarray,
               point_data: dict[str, np.ndarray] | None = None,
               cell_data: dict[str, np.ndarray] | None = None,
               frames: list[tuple[float, dict[str, np.ndarray]]] | None = None) -> Path:
    """Write ``path`` (``.xdmf``) and its ``.h5`` atomically, all data given whole.

    Parameters
    ----------
    points, cell_type, cells
        As :func:`xdmf_writer`.
    point_data, cell_data : dict name -> (n,) or (n, 3) array
        Static fields (cell data e.g. part ids).
    frames : list of (time [s], {name: (n_p,) or (n_p, 3)}), optional
        A temporal collection of point data; static data are repeated in every frame.
    """
    times = None if frames is None else [t for t, _ in frames]
    with xdmf_writer(path, points, cell_type, cells, times) as w:
        for center, data in (("Node", point_data or {}), ("Cell", cell_data or {})):
            for name, arr in data.items():
                w.add(name, arr, center)
        for i, (_, data) in enumerate(frames or []):
            for name, arr in data.items():
                w.add(name, arr, "Node", frame=i)
    return Path(path)
