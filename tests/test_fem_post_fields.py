"""The housing field data of fem.post (``housing.h5``) on a housing-like block with
clamped feet and a rigidly linked bore: the rows equal the field DOLFINx rebuilds
(``FEModel.displacement``) at every node, the cells are the part's P2 cells in VTK
order, the blocks written do not change the file, and two ranks write the same file as
one (``mpirun -n 2``, blocks of a few nodes)."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

pytest.importorskip("dolfinx")

import fem_post_mpi_case as case  # noqa: E402

pytestmark = pytest.mark.fem

CASE = Path(case.__file__)
#: Blocks of 7 nodes (3 × N_R float64 per node).
SMALL_BLOCK = 7 * 3 * case.N_R * 8


@pytest.fixture(scope="module")
def block(tmp_path_factory):
    from fem import post

    tmp = tmp_path_factory.mktemp("block")
    model = case.block_model()
    T = case.keyed_basis(model)
    PT = post.field_operator(model, T)
    for name, nbytes in (("default", post.BLOCK_BYTES), ("small", SMALL_BLOCK)):
        (tmp / name).mkdir()
        post.housing_data(model, PT, tmp / name / post.HOUSING_FILE, block_bytes=nbytes)
    PT.destroy()
    return tmp, model, T


def _datasets(path: Path) -> dict[str, np.ndarray]:
    with h5py.File(path, "r") as f:
        return {k: f[k][()] for k in f} | {f"@{k}": f.attrs[k] for k in f.attrs}


def test_rows_equal_the_dolfinx_field(block):
    from scipy.spatial import cKDTree

    from fem import post
    from reduction import reconstruct

    tmp, model, T = block
    hd = post.read_housing(tmp / "default" / post.HOUSING_FILE)
    assert (hd.part, hd.n_r) == ("housing", case.N_R)
    assert hd.part_tag == model.fe_mesh.tag("housing", 3)
    q = np.random.default_rng(0).standard_normal(case.N_R)
    rows = np.concatenate([r for _, _, r in hd.row_blocks()])
    u = model.displacement(reconstruct(T, q))
    coords = model.V.tabulate_dof_coordinates()
    d, i = cKDTree(coords).query(hd.points)
    assert d.max() < 1e-12
    ref = u.x.array.reshape(-1, 3)[i]
    np.testing.assert_allclose(rows @ q, ref, atol=1e-12 * np.abs(ref).max())
    # the clamped feet (y = 0) do not move; the rigidly linked bore moves
    feet = np.abs(hd.points[:, 1]) < 1e-12
    assert feet.any() and np.all(rows[feet] == 0.0)
    # every cell of the part once, tetra10 in VTK order: edge nodes at the mid-edges
    n_cells = model.fe_mesh.cell_tags.find(hd.part_tag).size
    assert hd.cells.shape == (n_cells, 10) and np.unique(hd.cells).size == len(hd.points)
    p = hd.points[hd.cells]
    mid = 0.5 * (p[:, [0, 1, 0, 0, 1, 2]] + p[:, [1, 2, 2, 3, 3, 3]])
    edge = np.linalg.norm(p[:, [1, 2, 2, 3, 3, 3]] - p[:, [0, 1, 0, 0, 1, 2]], axis=2)
    assert np.median(np.linalg.norm(p[:, 4:] - mid, axis=2) / edge) < 1e-12
    with h5py.File(hd.path, "r") as f:
        ids = f["node_ids"][()]
    assert np.all(np.diff(ids) > 0)


def test_blocks_do_not_change_the_file(block):
    from fem import post

    tmp, _, _ = block
    a = _datasets(tmp / "default" / post.HOUSING_FILE)
    b = _datasets(tmp / "small" / post.HOUSING_FILE)
    assert set(a) == set(b)
    for k in a:
        np.testing.assert_array_equal(a[k], b[k], err_msg=k)
    hd = post.read_housing(tmp / "small" / post.HOUSING_FILE)
    got = list(hd.row_blocks(nodes=7))
    assert len(got) == -(-len(hd.points) // 7) > 10
    np.testing.assert_array_equal(np.concatenate([r for _, _, r in got]), a["u_rows"])


def test_missing_file_names_what_to_do(tmp_path):
    from fem import post

    with pytest.raises(FileNotFoundError, match="reduce it again"):
        post.read_housing(tmp_path / post.HOUSING_FILE)


def _run(n: int, out: Path) -> None:
    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1",
               OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    cmd = [sys.executable, str(CASE), str(out), str(SMALL_BLOCK)]
    if n > 1:
        mpirun = shutil.which("mpirun")
        if mpirun is None:
            pytest.skip("mpirun missing")
        cmd = [mpirun, "--allow-run-as-root", "--oversubscribe", "-n", str(n)] + cmd
    out.mkdir()
    res = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr[-3000:]


@pytest.mark.mpi
def test_two_ranks_write_the_same_files(tmp_path):
    """housing.h5 and radiation.h5 of two ranks (each its cells, facets and rows of the
    distributed P T; rank 0 receives the rows block by block) equal the serial ones:
    nodes, cells and facets bit for bit, rows and W to round-off."""
    from fem import post

    _run(1, tmp_path / "one")
    _run(2, tmp_path / "two")
    for name, exact in ((post.HOUSING_FILE, ("points", "node_ids", "cells", "@part",
                                              "@part_tag", "@n_r")),
                        (post.RADIATION_FILE, ("facet_nodes", "points", "facet_area",
                                                "facet_centroid", "facet_normal"))):
        s = _datasets(tmp_path / "one" / name)
        p = _datasets(tmp_path / "two" / name)
        assert set(s) == set(p), name
        for k in exact:
            np.testing.assert_array_equal(s[k], p[k], err_msg=f"{name}:{k}")
        for k in set(s) - set(exact) - {"@part", "@n_facets", "@quadrature_degree"}:
            scale = np.abs(s[k]).max()
            assert np.abs(s[k] - p[k]).max() <= 1e-12 * scale, f"{name}:{k}"
    assert _datasets(tmp_path / "one" / post.HOUSING_FILE)["u_rows"].shape[0] > 100
