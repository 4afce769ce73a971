"""Atomic file writing: a temporary file in the target's folder, renamed onto the target.

The one helper every package that writes files uses (``geometry`` for the mesh, ``fem``
for CalculiX decks, ``reduction`` for the ROM, ``study`` for results, plots and reports,
``benchmarks``). It lives in :mod:`core`, the bottom layer that imports nothing of the
project; standard library only.
"""
from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

__all__ = ["atomic_write"]


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


@contextlib.contextmanager
def atomic_write(path: str | os.PathLike, mode: str | None = None, *,
                 encoding: str | None = "utf-8") -> Iterator[Any]:
    """Write ``path`` all at once: to a temporary file in its folder, then ``os.replace``.

    A reader (or a killed run) never sees a half-written ``path``; on an exception the
    temporary file is removed and ``path`` is left as it was.

    Parameters
    ----------
    path : str or PathLike
        Target file. Its folder is created if missing.
    mode : {None, "w", "wb"}
        ``None`` yields the temporary :class:`~pathlib.Path` for the caller to write
        (``h5py.File(tmp, "w")``, ``fig.savefig(tmp)``, ``gmsh.write(str(tmp))``; the
        temporary name ends with the target's suffix, so writers that pick the format
        from the extension work); ``"w"`` / ``"wb"`` yield an open text / binary file.
    encoding : str, optional
        Encoding of a text file (``mode="w"``).

    Yields
    ------
    Path or file object
        Where to write. Files opened here are closed before the rename.

    Notes
    -----
    The target gets the usual permissions ``0666 & ~umask`` (``mkstemp`` makes 0600).
    """
    if mode not in (None, "w", "wb"):
        raise ValueError(f"mode = {mode!r}: must be None, 'w' or 'wb'")
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, name = tempfile.mkstemp(prefix=f".{target.name}.", suffix=f".tmp{target.suffix}",
                                dir=target.parent)
    tmp = Path(name)
    try:
        if mode is None:
            os.close(fd)
            yield tmp
        else:
            fh: IO = os.fdopen(fd, mode, encoding=encoding if mode == "w" else None)
            with fh:
                yield fh
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, target)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
