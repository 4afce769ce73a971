"""Provenance of a results.h5: the scene as run, the code that ran it and how long each
stage took (docs/results-format.md, ``/scene/resolved``, ``/provenance``).

A result must be traceable to what ran: the scene text of the file is not enough once
``--set`` and API overrides changed it and defaults filled the rest, so the resolved
scene (:mod:`study.scene.resolved`) is stored beside it, with the package version, the
git revision of the source tree the package was imported from (``"none"`` when that
is not a git checkout: an installed wheel, an unpacked archive) and the wall time of
each pipeline stage.
"""
from __future__ import annotations

import datetime
import functools
import logging
import subprocess
import sys
from pathlib import Path
from typing import Any

logger = logging.getLogger(__name__)

__all__ = ["git_revision", "write_scene_as_run", "write_provenance", "record_stage"]

#: The source tree the running code comes from (the parent of the ``study`` package).
SOURCE_ROOT = Path(__file__).resolve().parents[2]


@functools.lru_cache(maxsize=8)
def git_revision(root: Path = SOURCE_ROOT) -> tuple[str, str]:
    """(revision, state) of the source tree at ``root``.

    ``revision`` is the commit hash, or ``"none"`` when ``root`` is not a git checkout
    (or git is missing); ``state`` is ``"clean"``, ``"modified"`` (tracked files differ
    from the commit) or why there is no revision. Never raises.
    """
    def git(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run(["git", "-C", str(root), *args], capture_output=True,
                              text=True, timeout=10)
    try:
        head = git("rev-parse", "--verify", "HEAD")
        if head.returncode != 0:
            return "none", f"not a git checkout ({root})"
        dirty = git("status", "--porcelain", "--untracked-files=no")
    except (OSError, subprocess.SubprocessError) as exc:
        return "none", f"git not available ({exc.__class__.__name__})"
    state = "unknown" if dirty.returncode != 0 else ("modified" if dirty.stdout.strip()
                                                      else "clean")
    return head.stdout.strip(), state


def write_scene_as_run(group, scene) -> None:
    """``resolved`` and ``derived`` (JSON text) in the ``/scene`` group: the scene after
    overrides with every default filled in (the FE sections' from the machine's FE
    parameters when it has them), and what the loader computed from it. Nothing for an
    object that is not a :class:`study.scene.Scene` (a test's stand-in)."""
    from machines import machine_for
    from study.scene.data import Scene
    from study.scene.resolved import resolved_json

    if not isinstance(scene, Scene):
        return

    fe_params = getattr(machine_for(scene), "params", None) if scene.fe else None
    resolved, derived = resolved_json(scene, fe_params)
    group.create_dataset("resolved", data=resolved)
    group["resolved"].attrs["format"] = "json"
    group["resolved"].attrs["meaning"] = ("scene as run: file after extends, --set and API "
                                          "overrides, every default filled in; loads with "
                                          "study.scene.scene_from_dict")
    group.create_dataset("derived", data=derived)
    group["derived"].attrs["format"] = "json"


def write_provenance(f, stages: dict[str, Any] | None = None) -> None:
    """``/provenance``: version, git revision and state, source folder, command line,
    UTC time of writing, and per stage (``/provenance/stages``) how it was served and its
    wall time in this run (s; NaN when it did not run here: cached, skipped)."""
    from study import __version__

    rev, state = git_revision()
    p = f.create_group("provenance")
    p.attrs["geardyn_version"] = __version__
    p.attrs["git_revision"] = rev
    p.attrs["git_state"] = state
    p.attrs["source"] = str(SOURCE_ROOT)
    p.attrs["command"] = " ".join(sys.argv)
    p.attrs["written_utc"] = datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")
    s = p.create_group("stages")
    s.attrs["unit"] = "s"
    for name, st in (stages or {}).items():
        _stage_attrs(s, name, st)


def _stage_attrs(group, name: str, st: Any) -> None:
    secs = getattr(st, "seconds", None)
    group.attrs[f"{name}_seconds"] = float("nan") if secs is None else float(secs)
    group.attrs[f"{name}_state"] = getattr(st, "text", str(st))


def record_stage(path: str | Path, name: str, st: Any) -> None:
    """Set one stage's state and wall time in an existing results.h5 (the export stage,
    whose time is known only after it wrote the file). Attributes only, in place."""
    import h5py

    try:
        with h5py.File(path, "r+") as f:
            if "provenance/stages" in f:
                _stage_attrs(f["provenance/stages"], name, st)
    except OSError as exc:
        logger.warning("could not record the %s stage time in %s: %s", name, path, exc)

