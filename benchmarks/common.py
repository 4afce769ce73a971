"""Shared helpers for the benchmarks: repeated timing, peak memory, atomic JSON.

Timings are medians of repeated runs; comparisons are ratios measured side by
side in the same run. Nothing here is a pass/fail test.
"""
from __future__ import annotations

import json
import os
import platform
import resource
import statistics
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from core.files import atomic_write

RESULTS = Path(__file__).resolve().parent / "results"


def median_time(func: Callable[[], Any], repeats: int = 5, warmup: int = 1) -> tuple[float, Any]:
    """Median wall time of ``func()`` in seconds over ``repeats`` runs, and its last result."""
    result = None
    for _ in range(warmup):
        result = func()
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        result = func()
        times.append(time.perf_counter() - start)
    return statistics.median(times), result


def peak_rss_mb() -> float:
    """Peak resident set size of this process so far, in MiB (Linux ru_maxrss is KiB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def status_kib(field: str) -> int:
    """A memory field of ``/proc/self/status`` (``VmRSS``, ``VmHWM``, ...), in KiB."""
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(field + ":"):
                return int(line.split()[1])
    raise RuntimeError(f"{field} not in /proc/self/status")


def reset_peak() -> bool:
    """Reset ``VmHWM`` to the current RSS (Linux ``clear_refs`` 5); False if not permitted."""
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
        return True
    except OSError:
        return False


def machine() -> dict[str, Any]:
    """A short description of the machine the figures come from."""
    return {
        "cpus": os.cpu_count(),
        "python": platform.python_version(),
        "processor": platform.processor() or platform.machine(),
    }


def records_table(title: str, columns: list[str], records: list[dict]) -> dict[str, Any]:
    """A table of a payload (rendered by :mod:`benchmarks.report`): one row per record,
    its values under ``columns``."""
    return {"title": title, "columns": columns,
            "rows": [[r[c] for c in columns] for r in records]}


def write_json(name: str, payload: dict[str, Any], path: Path | None = None) -> Path:
    """Write ``benchmarks/results/<name>.json`` (or ``path``) atomically and return its
    path."""
    path = RESULTS / f"{name}.json" if path is None else Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    payload = {"benchmark": name, "machine": machine(), **payload}
    with atomic_write(path, "w") as fh:
        json.dump(payload, fh, indent=2, default=float)
        fh.write("\n")
    return path


def scene_overrides(items: list[str]) -> dict[str, Any]:
    """``--set SECTION.KEY=VALUE`` items -> one override dict, parsed and checked as
    ``geardyn --set`` does (:func:`study.cli.parse_sets`); one value per key."""
    from study.cli import parse_sets
    from study.scene.errors import SceneError

    variants = parse_sets(items)
    if len(variants) != 1:
        raise SceneError(f"--set {items}: one value per key here ({len(variants)} "
                         "combinations given)")
    return variants[0]


def finished_run(scene_path: Path, sets: list[str], run: Path, cache: Path):
    """A finished run read back: the scene with the run's ``--set`` items, its HBM problem
    from the run's stage cache (the ROM is not rebuilt), and the main branch of
    ``run/results.h5``, as a :class:`study.pipeline.runs.RunResult` (``rom`` None)."""
    import study
    from study.outputs.results import read_branch
    from study.pipeline import Pipeline
    from study.pipeline.runs import RunResult

    scene = study.load_scene(scene_path, scene_overrides(sets))
    problem, _ = Pipeline(scene, Path(run).parent / "benchmark-scratch", cache_dir=cache,
                          progress=False).problem()
    path = Path(run) / "results.h5"
    return RunResult(Path(run), path, read_branch(path, problem), problem, scene, {}, {})
