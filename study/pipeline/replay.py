"""``geardyn report``: the export stage again from a finished run's ``results.h5``.

The branch is read back (it must belong to the scene's inputs: the hbm stage key is
compared), and so are the secondary branches of ``/branches`` with their doubled problems
(:func:`study.outputs.branches.read_branches`; the branches stage key is compared), the
HBM problem and, for FE scenes, the ROM come from the stage cache, and
the plots, housing fields and ``report.md`` are written as the export stage writes them
(:mod:`study.pipeline.export`), and the checks computed for them replace ``/checks`` of
``results.h5`` (the report's banner and the file say the same); the continuation does
not run.
"""
from __future__ import annotations

from pathlib import Path

from study.outputs.branches import read_branches, secondary_nvh
from study.outputs.nvh import compute_nvh
from study.outputs.results import read_branch, stored_key
from study.pipeline.export import draw_figures, record_checks, write_housing, write_report_files
from study.pipeline.parallel import mark_collective
from study.pipeline.runs import RunResult, StageStatus
from study.pipeline.stages import Pipeline
from study.scene.errors import SceneError
from study.scene.load import load_scene

__all__ = ["report_from_results"]


def report_from_results(scene_path: Path, out: Path, overrides: dict | None = None,
                        cache: str | None = None) -> RunResult:
    """Plots and report.md from an existing ``OUT/results.h5`` (no continuation)."""
    scene = load_scene(scene_path, overrides)
    pipe = Pipeline(scene, out, cache_dir=cache, progress=False)
    problem, rom = pipe.problem()
    key = pipe.hbm_key()
    path = Path(out) / "results.h5"
    # read by every rank under mpirun: the same error everywhere
    if not path.exists():
        raise mark_collective(FileNotFoundError(f"{path}: no such file; run `geardyn run` "
                                                "with this scene and --out first"))
    br = read_branch(path, problem, expected_key=key)
    if br is None:
        raise mark_collective(SceneError(f"{path} holds no continuation of this scene's "
                                         "inputs (model, harmonic set, speed range, --set "
                                         "values or code version differ); run `geardyn run` "
                                         "with them first"))
    res = RunResult(Path(out), Path(out) / "results.h5", br, problem, scene,
                    {"hbm": "from results.h5"}, pipe.keys, rom=rom)
    res.secondary, res.branches_seconds = _secondary(pipe, path, problem)
    res.verdict_checks = _verdict_checks(path)
    if res.secondary:
        res.status["branches"] = StageStatus("from results.h5")
        res.stages["branches"] = res.status["branches"].text
    if scene.mesh_source is not None:           # the ltca stage's arrays (cached)
        res.mesh_excitation = pipe.comm.root_call(pipe.run_mesh_excitation)
    res.train_excitations = pipe.comm.root_call(pipe.run_train_excitations)
    # the housing fields from the cached ROM (rank 0 writes); their renderings, if asked,
    # run beside the plots
    renders = write_housing(res) if scene.outputs.housing_field else []

    def draw() -> None:
        res.nvh = compute_nvh(res)  # per-order levels and ERP for the NVH plots (seconds)
        res.secondary_nvh = secondary_nvh(res)
        draw_figures(res, renders)
        write_report_files(res)
        record_checks(res)          # /checks of results.h5 as report.md's banner states them
    pipe.comm.root_call(draw)                       # rank 0 writes the files
    return res


def _verdict_checks(path: Path):
    """The run's verdict checks on a richer harmonic set (``/verdict_checks``), None
    when it made none."""
    import h5py

    from study.outputs.verdict_checks import read_verdict_checks

    with h5py.File(path, "r") as f:
        return read_verdict_checks(f)


def _secondary(pipe: Pipeline, path: Path, problem) -> tuple[list, float | None]:
    """The secondary branches of ``/branches`` in ``path`` and their stage's cost; the
    file's branches stage key must be the scene's (the same main curve and period-doubling
    settings), else SceneError; none when the run switched at no period doubling."""
    import h5py

    stored = stored_key(path, "stage_key_branches")
    if not stored:                    # the stage was skipped: nothing was switched at
        return [], None
    if stored != pipe.branches_key():
        raise mark_collective(SceneError(
            f"{path}: its period-2 branches were computed with other "
            "`[continuation] period_doubling_*` settings (or code version) than the scene's; "
            "run `geardyn run` with them first"))
    with h5py.File(path, "r") as f:
        return read_branches(f, problem)
