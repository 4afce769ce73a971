"""The XDMF 3 + HDF5 writer of fem.post: data given whole or filled block by block give
the same files; meshio reads them back (static grid and temporal collection); bad input
is refused and a failed write leaves no file behind."""
from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest

pytest.importorskip("dolfinx")  # fem/__init__ loads the FE stack


def _tet10() -> tuple[np.ndarray, np.ndarray]:
    """Two P2 tetrahedra sharing a face (VTK node order), 14 nodes."""
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]], dtype=float)
    edges = [(0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3), (1, 4), (2, 4), (3, 4)]
    pts = np.vstack([v] + [0.5 * (v[a] + v[b]) for a, b in edges])
    mid = {e: 5 + i for i, e in enumerate(edges)}

    def cell(a, b, c, d):
        e = [mid[tuple(sorted(p))] for p in ((a, b), (b, c), (a, c), (a, d), (b, d), (c, d))]
        return [a, b, c, d, *e]
    return pts, np.array([cell(0, 1, 2, 3), cell(1, 2, 3, 4)], dtype=np.int64)


def _datasets(path: Path) -> dict[str, np.ndarray]:
    out = {}
    with h5py.File(path, "r") as f:
        f.visititems(lambda k, v: out.__setitem__(k, v[()]) if isinstance(v, h5py.Dataset)
                     else None)
    return out


def test_blocks_equal_whole_arrays(tmp_path: Path) -> None:
    """The XML text is the same and every dataset equal when the data are written whole
    or in row blocks; the time series reads back with meshio."""
    meshio = pytest.importorskip("meshio")
    from fem.post.xdmf import write_xdmf, xdmf_writer

    pts, cells = _tet10()
    rng = np.random.default_rng(3)
    frames = [(0.1 * j, {"displacement": rng.standard_normal((len(pts), 3))})
              for j in range(4)]
    part = np.array([7, 7], dtype=np.int64)
    write_xdmf(tmp_path / "whole.xdmf", pts, "tetra10", cells, cell_data={"part_id": part},
               frames=frames)
    with xdmf_writer(tmp_path / "blocks.xdmf", pts, "tetra10", cells,
                     [t for t, _ in frames]) as w:
        w.add("part_id", part, "Cell")
        ds = [w.create("displacement", frame=j) for j in range(len(frames))]
        for a in range(0, len(pts), 5):               # blocks of 5 nodes, the last shorter
            for j, (_, d) in enumerate(frames):
                ds[j][a:a + 5] = d["displacement"][a:a + 5]
    whole = (tmp_path / "whole.xdmf").read_text()
    assert (tmp_path / "blocks.xdmf").read_text() == whole.replace("whole.h5", "blocks.h5")
    a, b = _datasets(tmp_path / "whole.h5"), _datasets(tmp_path / "blocks.h5")
    assert set(a) == set(b)
    for k in a:
        np.testing.assert_array_equal(a[k], b[k], err_msg=k)
        assert a[k].dtype == b[k].dtype
    with meshio.xdmf.TimeSeriesReader(str(tmp_path / "blocks.xdmf")) as rd:
        p, c = rd.read_points_cells()
        got = [rd.read_data(k) for k in range(rd.num_steps)]
    np.testing.assert_array_equal(p, pts)
    assert c[0].type == "tetra10"
    np.testing.assert_array_equal(c[0].data, cells)
    for (t, d), (t2, pd, cd) in zip(frames, got, strict=True):
        assert t2 == t
        np.testing.assert_array_equal(pd["displacement"], d["displacement"])
        np.testing.assert_array_equal(cd["part_id"][0], part)
    assert sorted(x.name for x in tmp_path.iterdir()) == ["blocks.h5", "blocks.xdmf",
                                                          "whole.h5", "whole.xdmf"]


def test_static_grid_reads_back(tmp_path: Path) -> None:
    meshio = pytest.importorskip("meshio")
    from fem.post.xdmf import write_xdmf

    pts = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0.5, 0, 0], [0.5, 0.5, 0], [0, 0.5, 0]],
                   dtype=float)
    tri = np.array([[0, 1, 2, 3, 4, 5]])
    write_xdmf(tmp_path / "s.xdmf", pts, "triangle6", tri,
               point_data={"u": np.arange(18.0).reshape(6, 3), "s": np.arange(6.0)},
               cell_data={"area": np.array([0.5])})
    m = meshio.read(tmp_path / "s.xdmf")
    assert m.cells[0].type == "triangle6"
    np.testing.assert_array_equal(m.point_data["u"], np.arange(18.0).reshape(6, 3))
    np.testing.assert_array_equal(m.point_data["s"], np.arange(6.0))
    assert m.cell_data["area"][0][0] == 0.5


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"cells": np.array([[0, 1, 2]])}, "cells.shape"),
    ({"cells": np.array([[0, 1, 9, 3, 4, 5]])}, "out of range"),
    ({"point_data": {"u": np.zeros(5)}}, "5 rows, expected 6"),
    ({"point_data": {"u": np.zeros((6, 2))}}, "must be (n,) or (n, 3)"),
    ({"cell_type": "hexahedron"}, "cell_type"),
])
def test_bad_input_is_refused_and_leaves_no_file(tmp_path: Path, kwargs, message) -> None:
    from fem.post.xdmf import write_xdmf

    args = {"points": np.zeros((6, 3)), "cell_type": "triangle6",
            "cells": np.array([[0, 1, 2, 3, 4, 5]])}
    args.update(kwargs)
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")):
        write_xdmf(tmp_path / "bad.xdmf", **args)
    assert list(tmp_path.iterdir()) == []


def test_failure_while_filling_keeps_the_old_files(tmp_path: Path) -> None:
    """An error in the caller's block loop removes the temporary files; files written
    before under the same name stay as they were."""
    from fem.post.xdmf import write_xdmf, xdmf_writer

    pts, cells = _tet10()
    write_xdmf(tmp_path / "f.xdmf", pts, "tetra10", cells, point_data={"s": np.ones(14)})
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    with pytest.raises(RuntimeError, match="block failed"), \
            xdmf_writer(tmp_path / "f.xdmf", pts, "tetra10", cells) as w:
        ds = w.create("s", width=None)
        ds[:3] = 2.0
        raise RuntimeError("block failed")
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before
