"""Minimal XDMF 3 + HDF5 writer for ParaView: one mesh, point and cell data, optionally
a temporal collection. Written atomically (both files go to a temporary folder under
their final names, then the ``.h5`` and last the ``.xdmf`` are renamed into place).

meshio's own XDMF time-series writer puts its ``.h5`` in the current working
directory, hence this writer. Cell connectivity must already be in XDMF/VTK node
order (``Tetrahedron_10``: vertices, then edges 01, 12, 02, 03, 13, 23;
``Triangle_6``: vertices, then edges 01, 12, 20).
"""
from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np

from core.files import atomic_write

__all__ = ["write_xdmf", "TOPOLOGY"]

#: meshio-style cell type -> (XDMF topology name, nodes per cell).
TOPOLOGY = {"tetra10": ("Tetrahedron_10", 10), "triangle6": ("Triangle_6", 6),
            "tetra": ("Tetrahedron", 4), "triangle": ("Triangle", 3)}


def _item(h5name: str, path: str, arr: np.ndarray) -> str:
    kind = "Int" if np.issubdtype(arr.dtype, np.integer) else "Float"
    prec = arr.dtype.itemsize
    dims = " ".join(str(d) for d in arr.shape)
    return (f'<DataItem Dimensions="{dims}" NumberType="{kind}" Precision="{prec}" '
            f'Format="HDF">{h5name}:{path}</DataItem>')


def _attr_type(arr: np.ndarray) -> str:
    if arr.ndim == 1:
        return "Scalar"
    if arr.shape[1] == 3:
        return "Vector"
    raise ValueError(f"data of shape {arr.shape}: must be (n,) or (n, 3)")


def write_xdmf(path: str | Path, points: np.ndarray, cell_type: str, cells: np.ndarray,
               point_data: dict[str, np.ndarray] | None = None,
               cell_data: dict[str, np.ndarray] | None = None,
               frames: list[tuple[float, dict[str, np.ndarray]]] | None = None) -> Path:
    """Write ``path`` (``.xdmf``) and its ``.h5`` atomically.

    Parameters
    ----------
    points : (n_p, 3) float
        Node coordinates [m].
    cell_type : str
        ``tetra10``, ``triangle6``, ``tetra`` or ``triangle``.
    cells : (n_c, k) int
        Connectivity in XDMF node order.
    point_data, cell_data : dict name -> (n,) or (n, 3) array
        Static fields (cell data e.g. part ids).
    frames : list of (time [s], {name: (n_p,) or (n_p, 3)}), optional
        A temporal collection; static point/cell data are repeated in every frame.
    """
    path = Path(path)
    if path.suffix != ".xdmf":
        raise ValueError(f"path = {str(path)!r}: must end with .xdmf")
    topo, k = TOPOLOGY[cell_type]
    cells = np.asarray(cells, dtype=np.int64)
    points = np.asarray(points, dtype=float)
    if cells.ndim != 2 or cells.shape[1] != k:
        raise ValueError(f"cells.shape = {cells.shape}: must be (n, {k}) for {cell_type}")
    if cells.size and (cells.min() < 0 or cells.max() >= len(points)):
        raise ValueError("cells: node index out of range")
    point_data, cell_data = point_data or {}, cell_data or {}
    h5name = path.with_suffix(".h5").name
    grids = []
    with atomic_write(path.with_suffix(".h5")) as tmp, h5py.File(tmp, "w") as f:
        f["mesh/geometry"] = points
        f["mesh/topology"] = cells

        def attrs(prefix: str, pdata: dict, cdata: dict) -> list[str]:
            out = []
            for center, data in (("Node", pdata), ("Cell", cdata)):
                for name, arr in data.items():
                    arr = np.asarray(arr)
                    n = len(points) if center == "Node" else len(cells)
                    if arr.shape[0] != n:
                        raise ValueError(f"{center.lower()} data {name!r}: "
                                         f"{arr.shape[0]} rows, expected {n}")
                    key = f"{prefix}/{center.lower()}/{name}"
                    if key not in f:
                        f[key] = arr
                    out.append(f'<Attribute Name="{name}" AttributeType="{_attr_type(arr)}" '
                               f'Center="{center}">{_item(h5name, "/" + key, arr)}'
                               "</Attribute>")
            return out

        mesh_xml = (f'<Topology TopologyType="{topo}" NumberOfElements="{len(cells)}">'
                    f'{_item(h5name, "/mesh/topology", cells)}</Topology>'
                    f'<Geometry GeometryType="XYZ">'
                    f'{_item(h5name, "/mesh/geometry", points)}</Geometry>')
        static = attrs("static", point_data, cell_data)
        if frames is None:
            grids.append(f'<Grid Name="mesh" GridType="Uniform">{mesh_xml}'
                         + "".join(static) + "</Grid>")
        else:
            inner = []
            for i, (t, data) in enumerate(frames):
                a = attrs(f"frame_{i}", data, {})
                inner.append(f'<Grid Name="mesh" GridType="Uniform">{mesh_xml}'
                             f'<Time Value="{float(t)!r}"/>' + "".join(static + a)
                             + "</Grid>")
            grids.append('<Grid Name="TimeSeries" GridType="Collection" '
                         'CollectionType="Temporal">' + "\n".join(inner) + "</Grid>")
    text = ('<?xml version="1.0"?>\n<Xdmf Version="3.0" '
            'xmlns:xi="http://www.w3.org/2001/XInclude">\n<Domain>\n'
            + "\n".join(grids) + "\n</Domain>\n</Xdmf>\n")
    with atomic_write(path, "w") as fx:  # after the .h5 it points into
        fx.write(text)
    return path
