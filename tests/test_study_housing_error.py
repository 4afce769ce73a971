"""study.outputs.housing_error: the field u = T q read from rom/basis in row blocks."""
from __future__ import annotations

import h5py
import numpy as np

from study.outputs import housing_error
from study.outputs.housing_error import HousingField, field_error


def _write_rom(folder, T, keys, link) -> None:
    folder.mkdir()
    with h5py.File(folder / "rom.h5", "w") as f:
        f["rom/basis"] = T
        f["rom/row_keys"] = keys
    with h5py.File(folder / "nodes.h5", "w") as f:
        f["rows"] = np.asarray(link, dtype=np.int64)


def _field(folder, q, idx) -> HousingField:
    U, u_max = housing_error._field_by_blocks(folder, q, idx)
    return HousingField(0.0, U.shape[0], {k: U[:, i] for i, k in enumerate(idx)}, u_max)


def test_blocks_match_the_dense_product_and_rows_follow_the_keys(tmp_path, monkeypatch):
    rng = np.random.default_rng(3)
    n_fe, n_r, idx = 103, 7, [0, 1, 3]
    T = rng.standard_normal((n_fe, n_r))
    q = rng.standard_normal((n_r, 3)) + 1j * rng.standard_normal((n_r, 3))
    q[:, 0] = q[:, 0].real
    keys = np.arange(n_fe) * 5 + 11
    link = [2, 40, 101, -1]
    monkeypatch.setattr(housing_error, "ROW_BLOCK", 16)        # 7 blocks, last partial
    _write_rom(tmp_path / "a", T, keys, link)
    U, u_max = housing_error._field_by_blocks(tmp_path / "a", q, idx)
    ref = T @ q                                                 # dense, file order = key order
    ref[[2, 40, 101]] = 0.0
    np.testing.assert_allclose(U, ref, rtol=1e-13, atol=1e-13)
    tau = 2 * np.pi * np.arange(64) / 64
    u_t = sum((ref[:, i:i + 1] * np.exp(1j * k * tau)).real for i, k in enumerate(idx))
    assert abs(u_max - np.abs(u_t).max()) <= 1e-13 * u_max
    # the same ROM written on another partition (rows permuted, keys with them)
    perm = rng.permutation(n_fe)
    inv = np.argsort(perm)
    _write_rom(tmp_path / "b", T[perm], keys[perm], [inv[i] for i in (2, 40, 101)])
    a, b = _field(tmp_path / "a", q, idx), _field(tmp_path / "b", q, idx)
    err, metric = field_error(a, b)
    assert metric == "L2 field" and err < 1e-14
    # a perturbed field: the L2 error over space and period (Parseval weights 1, 1/2)
    q2 = q.copy()
    q2[:, 2] *= 1.1
    c = _field(tmp_path / "b", q2, idx)
    err, _ = field_error(a, c)
    num = 0.5 * np.sum(np.abs(0.1 * ref[:, 2]) ** 2)
    den = np.sum(np.abs(ref[:, 0]) ** 2) + 0.5 * np.sum(np.abs(ref[:, 1:]) ** 2)
    assert abs(err - np.sqrt(num / den)) <= 1e-12
