"""Writing the current gmsh model to disk."""

from __future__ import annotations

import logging
import os
from pathlib import Path

import gmsh

from core.files import atomic_write

log = logging.getLogger(__name__)


def write_msh(path: str | os.PathLike[str], *, binary: bool = False) -> Path:
    """Write the current meshed gmsh model as a ``.msh`` (format 4.1), atomically.

    Only elements in physical groups are saved, with the group names.

    Parameters
    ----------
    path : str or PathLike
        Target file; must end in ``.msh``. Its folder is created if missing.
    binary : bool
        Binary instead of ASCII MSH.

    Returns
    -------
    Path
        The written file.
    """
    target = Path(path)
    if target.suffix != ".msh":
        raise ValueError(f"path = {str(target)!r}: must end in '.msh'")
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.option.setNumber("Mesh.Binary", 1 if binary else 0)
    gmsh.option.setNumber("Mesh.SaveAll", 0)
    # gmsh picks the format from the extension: the temporary name ends in .msh too
    with atomic_write(target) as tmp:
        gmsh.write(str(tmp))
    log.info("wrote %s", target)
    return target
