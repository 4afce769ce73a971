"""The cached pipeline ``mesh → fe → rom → hbm → export`` and its plumbing.

:mod:`~study.pipeline.cache` (stage keys, the on-disk cache),
:mod:`~study.pipeline.parallel` (the world under ``mpirun``: rank-0 sections, collective
errors), :mod:`~study.pipeline.progress` (tqdm lines), :mod:`~study.pipeline.runs`
(:class:`RunResult`, :class:`StageStatus`, :class:`SolverError`) →
:mod:`~study.pipeline.export` (the export stage: ``results.h5``, ``curves.csv``, housing
fields, plots, ``report.md``) → :mod:`~study.pipeline.stages` (:class:`Pipeline`: the
stages, their keys, checkpoints and resume; :func:`run_scene`) →
:mod:`~study.pipeline.replay` (``geardyn report``: the export again from ``results.h5``).

Imports :mod:`study.scene`, :mod:`study.outputs` and :mod:`study.plots`, nothing above
(docs/architecture.md). This ``__init__`` is the pipeline's API for users (tests,
benchmarks, scripts): it re-exports the names below and defines nothing; code inside
:mod:`study` imports a name from the module that holds it.
"""
from __future__ import annotations

from study.pipeline.runs import RunResult, SolverError, StageStatus
from study.pipeline.stages import Pipeline, hbm_inputs, run_scene
from study.scene.errors import StageUnavailable

__all__ = ["Pipeline", "run_scene", "hbm_inputs", "RunResult", "StageStatus", "SolverError",
           "StageUnavailable"]
