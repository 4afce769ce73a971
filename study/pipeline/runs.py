"""What a pipeline run produced (:class:`RunResult`), how each of its stages was served
(:class:`StageStatus`) and the solver failure it may raise (:class:`SolverError`)."""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from study.scene.data import Scene

__all__ = ["SolverError", "StageStatus", "RunResult"]


class SolverError(RuntimeError):
    """The continuation or a solve failed (exit code 3); partial results are saved.

    ``result`` holds the partial :class:`RunResult` when there is one.
    """

    def __init__(self, message: str, result=None) -> None:
        super().__init__(message)
        self.result = result


@dataclass(frozen=True)
class StageStatus:
    """How one stage was served in a run (``Pipeline.status``).

    Attributes
    ----------
    state : str
        ``"ran"``, ``"resumed"``, ``"cached"``, ``"skipped"`` or (export of a failed
        continuation) ``"partial"``.
    note : str
        Why it was skipped / what was written (free text, for the log and report.md).
    seconds : float or None
        Wall time spent computing it in this run (``ran``/``resumed``), else None.
    from_cache : bool
        Its product came from the stage cache (its own entry, or inside the cached
        entry of a later stage: mesh and fe of a cached ROM).
    applies : bool
        False for the stages the scene has none of (mesh, fe, rom of a lumped scene).
    """

    state: str
    note: str = ""
    seconds: float | None = None
    from_cache: bool = False
    applies: bool = True

    @property
    def text(self) -> str:
        """The text of ``Pipeline.stages`` / ``RunResult.stages``: ``"ran"``,
        ``"skipped (rom cached)"``, ..."""
        return f"{self.state} ({self.note})" if self.note else self.state


@dataclass
class RunResult:
    """What a run produced.

    Attributes
    ----------
    out : Path
        Output folder.
    results : Path
        ``results.h5``.
    branch
        The :class:`hbm.Branch`.
    problem
        The :class:`hbm.HBMProblem` (for time series, spectra, recovery).
    stages : dict
        Stage name -> ``"ran"``, ``"cached"``, ``"resumed"`` or ``"skipped"``.
    keys : dict
        Stage name -> cache key.
    figures : list of Path
        PNG files written.
    seconds : float
        Wall time of the run.
    attractors : list
        :class:`study.outputs.attractors.Attractor` per integrated speed of each
        unstable segment (``[outputs] attractor_transient_turns`` > 0; computed by the
        export, with or without report.md).
    bifurcation
        :class:`study.outputs.bifurcation.Diagram` of the run (computed by the export on
        a periodic basis; None before or on a torus).
    status : dict
        Stage name -> :class:`StageStatus` (how it was served, its wall time); the
        pipeline's own dict, so it fills as the stages run (``/provenance`` of results.h5).
    checks : list
        :class:`study.outputs.checks.Check` of the result (computed by the export).
    speed_uses : list
        :class:`study.outputs.points.SpeedUse` of every point output asked at a speed
        (time series, spectra, housing fields): the speed it was computed at.
    mesh_excitation
        :class:`study.outputs.mesh_excitation.MeshExcitation` of an ``ltca``/``table``
        source (None: both ``fourier``).
    train_excitations : dict
        A train's mesh name -> :class:`study.outputs.mesh_excitation.MeshExcitation` of
        every mesh with an ``ltca``/``table`` source (empty otherwise).
    verdict_checks
        :class:`study.outputs.verdict_checks.VerdictChecks`: the verdicts in doubt checked
        on a richer harmonic set (None: none checked).
    secondary
        :class:`hbm.branching.SecondaryBranch` per branch switched to at a period doubling
        (``[continuation] period_doubling_depth``; the stage ``branches``): each with its
        doubled ``problem`` (fundamental ``problem.harmonics.ratio`` Omega) and its
        :class:`hbm.Branch`; empty when the stage was off or found no period doubling.
    secondary_nvh : dict
        Branch name -> :class:`study.outputs.nvh.NVH` of each secondary branch (computed
        by the export, :func:`study.outputs.branches.secondary_nvh`).
    branches_seconds : float or None
        What computing the secondary branches cost (s): this run's stage, or the run that
        filled the cache entry or wrote the results.h5 it was read from (None: unknown).
    """

    out: Path
    results: Path
    branch: Any
    problem: Any
    scene: Scene
    stages: dict[str, str] = field(default_factory=dict)
    keys: dict[str, str] = field(default_factory=dict)
    figures: list[Path] = field(default_factory=list)
    seconds: float = 0.0
    rom: Any = None
    nvh: Any = None
    attractors: list = field(default_factory=list)
    bifurcation: Any = None
    status: dict = field(default_factory=dict)
    checks: list = field(default_factory=list)
    speed_uses: list = field(default_factory=list)
    mesh_excitation: Any = None
    train_excitations: dict = field(default_factory=dict)
    secondary: list = field(default_factory=list)
    verdict_checks: Any = None
    secondary_nvh: dict = field(default_factory=dict)
    branches_seconds: float | None = None
