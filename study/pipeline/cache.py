"""On-disk cache of pipeline stages, keyed by a hash of exactly their inputs.

An entry is a folder ``<root>/<stage>/<key[:24]>/`` holding the stage's output
file(s) and ``manifest.json`` (stage, full key, cache format, the code version the
key includes, and the SHA-256 and size of every output file). A lookup trusts an
entry only if the manifest parses, names the same stage, key and format, and
every file's size and SHA-256 match; otherwise the entry is logged as corrupted
or foreign, removed and rebuilt. Entries are written in a temporary folder and
renamed into place, so a killed run never leaves a half-written entry.
"""
from __future__ import annotations

import dataclasses
import functools
import hashlib
import json
import logging
import math
import os
import shutil
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

logger = logging.getLogger(__name__)

__all__ = ["CACHE_FORMAT", "StageCache", "stage_key", "canonical", "source_hash"]

#: Bump when the manifest layout or the meaning of keys changes.
CACHE_FORMAT = 1


def canonical(obj: Any) -> Any:
    """JSON-able canonical form: dataclasses/dicts sorted, floats by repr, arrays as lists."""
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {f.name: canonical(getattr(obj, f.name)) for f in dataclasses.fields(obj)
                if f.name not in ("raw", "text")}
    if isinstance(obj, dict):
        return {str(k): canonical(obj[k]) for k in sorted(obj, key=str)}
    if isinstance(obj, (list, tuple)):
        return [canonical(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return canonical(obj.tolist())
    if isinstance(obj, (bool, np.bool_)):
        return bool(obj)
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        f = float(obj)
        return repr(f) if math.isfinite(f) else str(f)
    if isinstance(obj, complex):
        return [repr(obj.real), repr(obj.imag)]
    if obj is None or isinstance(obj, str):
        return obj
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"cannot hash {type(obj).__name__}")


@functools.cache
def source_hash(*modules: str) -> str:
    """SHA-256 of the source files of the given packages/modules (code version); a
    package's subpackages included.

    Computed once per process: a process runs the code it imported, even if the
    files change on disk meanwhile. A name that is no module raises
    :class:`ModuleNotFoundError` (a module moved without its stage keys following would
    otherwise drop out of the key unnoticed).
    """
    import importlib.util

    h = hashlib.sha256()
    for name in modules:
        spec = importlib.util.find_spec(name)
        if spec is None or spec.origin is None:
            raise ModuleNotFoundError(f"source_hash: no module {name!r} to hash", name=name)
        origin = Path(spec.origin)
        root = origin.parent
        files = sorted(root.rglob("*.py")) if origin.name == "__init__.py" else [origin]
        for f in files:
            h.update((f.relative_to(root).as_posix() if f.is_relative_to(root) else
                      f.name).encode())
            h.update(f.read_bytes())
    return h.hexdigest()


def stage_key(stage: str, inputs: dict[str, Any], code: str) -> str:
    """Hash of a stage's name, inputs (canonical JSON) and code version."""
    doc = json.dumps({"stage": stage, "format": CACHE_FORMAT, "code": code,
                      "inputs": canonical(inputs)}, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(doc.encode()).hexdigest()


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


class StageCache:
    """A cache folder of stage outputs.

    Parameters
    ----------
    root
        Cache folder (created when needed).
    enabled
        False: every lookup misses and nothing is stored (``--no-cache``).
    """

    def __init__(self, root: str | Path, enabled: bool = True) -> None:
        self.root = Path(root)
        self.enabled = enabled

    def entry(self, stage: str, key: str) -> Path:
        return self.root / stage / key[:24]

    def lookup(self, stage: str, key: str) -> Path | None:
        """Folder of a valid entry, or None (missing, corrupted or foreign: removed)."""
        if not self.enabled:
            return None
        d = self.entry(stage, key)
        if not d.exists():
            return None
        reason = self._invalid(d, stage, key)
        if reason is None:
            return d
        logger.warning("cache entry %s is %s: rebuilding it", d, reason)
        shutil.rmtree(d, ignore_errors=True)
        return None

    @staticmethod
    def _invalid(d: Path, stage: str, key: str) -> str | None:
        try:
            man = json.loads((d / "manifest.json").read_text())
        except (OSError, ValueError):
            return "corrupted (no readable manifest)"
        if not isinstance(man, dict) or man.get("format") != CACHE_FORMAT:
            return f"foreign (cache format {man.get('format') if isinstance(man, dict) else '?'})"
        if man.get("stage") != stage or man.get("key") != key:
            return "foreign (another stage or key)"
        files = man.get("files")
        if not isinstance(files, dict) or not files:
            return "corrupted (manifest lists no files)"
        for name, meta in files.items():
            p = d / name
            try:
                if p.stat().st_size != meta["size"] or _sha256(p) != meta["sha256"]:
                    return f"corrupted ({name} does not match its checksum)"
            except (OSError, KeyError, TypeError):
                return f"corrupted ({name} missing)"
        return None

    def store(self, stage: str, key: str, produce: Callable[[Path], None],
              info: dict | None = None, comm: Any = None,
              elapsed: float | None = 0.0) -> Path:
        """Run ``produce(folder)`` in a temporary folder, checksum, and move into place.

        The manifest records ``seconds``: the time of ``produce`` plus ``elapsed``, the
        seconds already spent computing what it writes (a continuation run before the
        call), so that a later reuse knows what the entry cost (:meth:`seconds`);
        ``elapsed=None``: the cost is not known (a continuation resumed from an earlier
        process), and the manifest says so (``seconds`` null).

        With ``comm`` (a :class:`study.pipeline.parallel.World`) the call is collective: rank 0
        creates the folder, every rank runs ``produce`` (which may be collective and
        should write each file from one rank), then rank 0 checksums and renames the
        entry while the others wait; every rank gets the entry's path.
        """
        t0 = time.perf_counter() - (elapsed or 0.0)

        def took() -> float | None:
            return None if elapsed is None else time.perf_counter() - t0
        if comm is None or comm.size == 1:
            tmp = self._begin(stage, key)
            try:
                produce(tmp)
                return self._commit(stage, key, tmp, info, took())
            except BaseException:
                shutil.rmtree(tmp, ignore_errors=True)
                raise
        tmp = comm.root_call(self._begin, stage, key)
        try:
            produce(tmp)
        except BaseException:
            if comm.rank == 0:
                shutil.rmtree(tmp, ignore_errors=True)
            raise
        comm.barrier()

        seconds = took()

        def commit() -> Path:
            try:
                return self._commit(stage, key, tmp, info, seconds)
            except BaseException:
                shutil.rmtree(tmp, ignore_errors=True)
                raise
        return comm.root_call(commit)

    def _begin(self, stage: str, key: str) -> Path:
        self.root.mkdir(parents=True, exist_ok=True)
        (self.root / stage).mkdir(exist_ok=True)
        return Path(tempfile.mkdtemp(prefix=f".{key[:12]}.", dir=self.root / stage))

    def seconds(self, stage: str, key: str) -> float | None:
        """Wall time [s] the entry took to produce, as its manifest records it (None for a
        missing entry or one written before the manifests kept it)."""
        try:
            man = json.loads((self.entry(stage, key) / "manifest.json").read_text())
            return float(man["seconds"]) if man.get("key") == key else None
        except (OSError, ValueError, KeyError, TypeError):
            return None

    def _commit(self, stage: str, key: str, tmp: Path, info: dict | None,
                seconds: float | None = None) -> Path:
        files = {p.name: {"size": p.stat().st_size, "sha256": _sha256(p)}
                 for p in sorted(tmp.iterdir()) if p.is_file()}
        man = {"format": CACHE_FORMAT, "stage": stage, "key": key, "files": files,
               "info": canonical(info or {}), "seconds": seconds}
        (tmp / "manifest.json").write_text(json.dumps(man, indent=1))
        d = self.entry(stage, key)
        if d.exists():
            shutil.rmtree(d, ignore_errors=True)
        os.replace(tmp, d)
        return d
