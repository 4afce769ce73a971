"""core.files.atomic_write: all or nothing, no temporary file left behind."""
from __future__ import annotations

import os
import stat

import h5py
import numpy as np
import pytest

from core.files import atomic_write


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def test_text_written_whole_with_usual_permissions(tmp_path):
    path = tmp_path / "sub" / "report.md"          # missing folder is created
    with atomic_write(path, "w") as f:
        f.write("µ-line\n")
        assert not path.exists()                    # nothing visible before the rename
    assert path.read_text(encoding="utf-8") == "µ-line\n"
    assert stat.S_IMODE(path.stat().st_mode) == 0o666 & ~_umask()
    assert [p.name for p in path.parent.iterdir()] == ["report.md"]


def test_binary_replaces_an_existing_file(tmp_path):
    path = tmp_path / "x.bin"
    path.write_bytes(b"old")
    with atomic_write(path, "wb") as f:
        f.write(bytes(range(256)))
    assert path.read_bytes() == bytes(range(256))
    assert list(tmp_path.iterdir()) == [path]


def test_path_mode_with_h5py_and_target_suffix(tmp_path):
    path = tmp_path / "results.h5"
    data = np.arange(12.0).reshape(3, 4)
    with atomic_write(path) as tmp:
        assert tmp.parent == tmp_path and tmp.name.endswith(".h5")   # writers keyed on suffix
        with h5py.File(tmp, "w") as f:
            f["a/b"] = data
            f["a"].attrs["unit"] = "m"
    with h5py.File(path, "r") as f:
        np.testing.assert_array_equal(f["a/b"][()], data)
        assert f["a"].attrs["unit"] == "m"
    assert list(tmp_path.iterdir()) == [path]


@pytest.mark.parametrize("mode", [None, "w", "wb"])
def test_error_keeps_the_old_file_and_leaves_no_temp(tmp_path, mode):
    path = tmp_path / "out.h5"
    path.write_bytes(b"previous")
    with pytest.raises(RuntimeError, match="half way"):
        with atomic_write(path, mode) as target:
            if mode is None:
                with h5py.File(target, "w") as f:
                    f["x"] = np.ones(1000)
            else:
                target.write("partial" if mode == "w" else b"partial")
            raise RuntimeError("half way")
    assert path.read_bytes() == b"previous"
    assert list(tmp_path.iterdir()) == [path]


def test_error_on_a_new_file_creates_nothing(tmp_path):
    path = tmp_path / "new.txt"
    with pytest.raises(KeyboardInterrupt):
        with atomic_write(path, "w") as f:
            f.write("partial")
            raise KeyboardInterrupt
    assert list(tmp_path.iterdir()) == []


def test_unknown_mode_refused(tmp_path):
    with pytest.raises(ValueError, match="mode = 'a'"):
        with atomic_write(tmp_path / "x", "a"):
            pass
    assert list(tmp_path.iterdir()) == []
