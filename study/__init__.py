"""study: scene files, the cached pipeline (mesh → fe → rom → hbm → export), its results
files and plots, studies of many runs and the ``geardyn`` command line.

Subpackages, each importing only those before it (docs/architecture.md):
:mod:`study.scene` → :mod:`study.outputs` → :mod:`study.plots` → :mod:`study.pipeline`
→ :mod:`study.studies`, then :mod:`study.cli` on top.

Python API (same as ``geardyn run``)::

    import study
    res = study.run("scenes/gear-pair-sdof.toml", "out/sdof")
    res.branch.rpm, res.branch.element(0).mesh_load_std, res.stages

Importing this package loads neither dolfinx, gmsh nor petsc4py.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

try:
    from importlib.metadata import PackageNotFoundError, version

    __version__ = version("geardyn")
except (ImportError, PackageNotFoundError):  # pragma: no cover
    __version__ = "0+unknown"

__all__ = ["run", "load_scene", "SceneError", "__version__"]

from study.scene.errors import SceneError  # noqa: E402
from study.scene.load import load_scene  # noqa: E402


def run(scene: str | Path | Any, out: str | Path, *, overrides: dict | None = None,
        cache_dir: str | Path | None = None, resume: bool = False, refresh: bool = False,
        progress: bool = False, until: str = "export"):
    """Run a scene (path or :class:`study.scene.Scene`) into ``out``.

    Parameters
    ----------
    scene
        Scene file path, or an already validated :class:`~study.scene.Scene`.
    out
        Output folder (``results.h5``, PNGs, ``report.md``).
    overrides
        ``{"section.key": value}`` applied to the file before validation.
    cache_dir
        Stage cache folder (default ``<out>/../.geardyn-cache``).
    resume
        Continue an interrupted continuation from ``<out>/results.h5``.
    refresh
        Ignore cached stages (recompute and overwrite them).
    progress
        tqdm progress bars.
    until
        Last stage: ``"mesh"``, ``"rom"``, ``"hbm"`` (results.h5 only) or ``"export"``.

    Returns
    -------
    study.pipeline.RunResult
    """
    from study.pipeline.stages import run_scene
    from study.scene.data import Scene

    sc = scene if isinstance(scene, Scene) else load_scene(scene, overrides)
    if isinstance(scene, Scene) and overrides:
        from study.scene.load import scene_from_dict
        from study.scene.overrides import apply_overrides
        sc = scene_from_dict(apply_overrides(scene.raw, overrides), scene.name, scene.text)
    return run_scene(sc, out, cache_dir=cache_dir, resume=resume, refresh=refresh,
                     progress=progress, until=until)
