"""The cached pipeline: mesh → fe → rom → hbm → export.

Each stage is cached on disk (:mod:`study.cache`) under a key that hashes exactly
the inputs it depends on plus the source code of the packages that compute it:

========  =====================================================================
stage     key inputs
========  =====================================================================
mesh      the machine's mesh inputs (the pump: ``[geometry]``, ``[mesh]``, gear face
          width/tip radius, centre distance)
fe        mesh key, the machine's FE inputs (the pump: ``[materials]``,
          ``[bearings]``, ``[drive]``, ``[rotors]``, ``[links]``, gear data of G)
          (key only: the FE model is rebuilt from the cached mesh when needed)
rom       fe key, ``[rom]``
ltca      (``source = "ltca"`` only) the LTCA's inputs (macro- and micro-geometry,
          torque, positions, slices, bodies), Harris torques, harmonics; the arrays
          of the outputs (the scene's series come from the same solve); a train: one
          entry per mesh with that source
hbm       rom key (FE) or the lumped machine's linear key (``[lumped]`` + gear),
          mesh stiffness, TE, load, backlash, external, damping, ``[hbm]``,
          ``[continuation]``
branches  hbm key, ``[continuation] period_doubling_depth`` and
          ``period_doubling_max_points`` (cached only when the main curve is the hbm
          stage's cache entry: not after a ``--resume`` with other steps)
export    never cached (writes ``results.h5``, plots and ``report.md``)
========  =====================================================================

The scene's machine (:func:`machines.machine_for`) says which stages it has, what each
stage's key hashes (``Machine.stage_inputs``, ``Machine.stage_code``) and builds them
(``FEMachine.build_mesh``, ``build_fe_model``, ``build_rom``; a lumped machine its
linear model).

So changing the torque, backlash, mesh stiffness or speed range reruns only the
hbm stage (the ROM keeps the physical gear DOF, Sect. 5), while changing a wall
thickness re-meshes. A lumped scene runs only hbm and export and never imports
dolfinx, gmsh or petsc4py. The log says which stages ran and which came from cache.
"""
from __future__ import annotations

import dataclasses
import logging
import time
from pathlib import Path
from typing import Any

import numpy as np

from core.files import atomic_write
from machines import FEMachine, machine_for
from study.pipeline.cache import StageCache, source_hash, stage_key
from study.pipeline.parallel import mark_collective, world
from study.pipeline.progress import ProgressBar, StageBar
from study.pipeline.runs import RunResult, SolverError, StageStatus
from study.scene.data import MeshSource, Scene
from study.scene.errors import SceneError, StageUnavailable

logger = logging.getLogger(__name__)

__all__ = ["RunResult", "SolverError", "StageUnavailable", "StageStatus", "Pipeline",
           "run_scene", "hbm_inputs"]


def _require(*modules: str) -> None:
    """Raise :class:`StageUnavailable` if a package a stage needs cannot be imported."""
    import importlib

    for m in modules:
        try:
            importlib.import_module(m)
        except ImportError as exc:
            raise StageUnavailable(f"package {m!r} is not available: {exc}") from exc


def _asdict(x) -> dict:
    return dataclasses.asdict(x)


#: ``[continuation]`` fields that only steer the path finding: a partial run written with
#: other values of them is resumed (``--resume``), the physics and harmonic set being equal.
#: secondary branches at most per run (each period doubling a branch; the near-grazing
#: tangles of a converged pump curve hold dozens of them, most joined in pairs)
MAX_SECONDARY = 12

RESUMABLE_CONTROLS = ("step", "min_step", "max_step", "tolerance", "max_points",
                      "checkpoint_every")


def hbm_inputs(scene: Scene) -> dict[str, Any]:
    """Exactly what the hbm stage depends on besides the linear model's key."""
    return {"gear": _asdict(scene.gear), "mesh_stiffness": _asdict(scene.mesh_stiffness),
            "transmission_error": _asdict(scene.transmission_error),
            "load": _asdict(scene.load), "external": _asdict(scene.external),
            "damping": _asdict(scene.damping), "hbm": _asdict(scene.hbm),
            # neither changes the curve (the secondary branches are their own stage)
            "continuation": {k: v for k, v in _asdict(scene.continuation).items()
                             if k not in ("checkpoint_every", "period_doubling_depth",
                                          "period_doubling_max_points")}}


class Pipeline:
    """Runs the stages of one scene into one output folder.

    Parameters
    ----------
    scene : Scene
        Validated scene.
    out : path
        Output folder (created).
    cache_dir : path, optional
        Stage cache (default ``<out>/../.geardyn-cache``, shared by sibling runs).
    refresh : bool
        Recompute every stage (cache lookups miss; entries are overwritten).
    resume : bool
        Continue an interrupted continuation from ``<out>/results.h5``.
    progress : bool
        Show tqdm progress bars (rank 0 only under mpirun).

    Under ``mpirun -n N`` (see :mod:`study.parallel`) every rank builds a Pipeline:
    the FE stages run distributed, meshing, cache bookkeeping, the continuation and
    the files of the output folder on rank 0, and every rank gets the same result.
    """

    def __init__(self, scene: Scene, out: str | Path, cache_dir: str | Path | None = None,
                 refresh: bool = False, resume: bool = False, progress: bool = True) -> None:
        self.scene = scene
        self.out = Path(out)
        self.cache = StageCache(Path(cache_dir) if cache_dir else
                                self.out.resolve().parent / ".geardyn-cache", enabled=not refresh)
        self.resume = resume
        self.comm = world()
        self.progress = progress and self.comm.rank == 0
        self.stages: dict[str, str] = {}            # stage -> StageStatus.text
        self.status: dict[str, StageStatus] = {}    # stage -> how it was served
        self.keys: dict[str, str] = {}
        self.machine = machine_for(scene)
        self._fe_model = None
        # the main branch is the hbm stage's cache entry (read from it or stored in it): the
        # branches stage, keyed on the hbm key, may then be cached too
        self._main_cached = False

    # ------------------------------------------------------------------ helpers
    def _log_stage(self, name: str, st: StageStatus, log: bool = True) -> None:
        """Record (and log) how stage ``name`` was served; times of repeated runs add up."""
        old = self.status.get(name)
        if old is not None and old.state == "ran":
            if st.state != "ran":
                return  # a stage that ran in this run and is looked up again stays "ran"
            if old.seconds is not None:
                st = dataclasses.replace(st, seconds=old.seconds + (st.seconds or 0.0))
        self.status[name] = st
        self.stages[name] = st.text
        if not log:
            return
        extra = f" in {st.seconds:.2f} s" if st.seconds is not None else ""
        key = self.keys.get(name, "")
        logger.info("stage %-6s %s%s%s", name, st.text, extra,
                    f" [{key[:12]}]" if key else "")

    # ------------------------------------------------------------------ FE stages
    def _machine_key(self, stage: str, upstream: dict[str, str] | None = None) -> str:
        """Key of ``stage``: the machine's inputs of it and the code computing it, plus the
        key of the stage before it."""
        m = self.machine
        return stage_key(stage, {**(upstream or {}), **m.stage_inputs(stage)},
                         source_hash(*m.stage_code(stage)))

    def mesh_key(self) -> str:
        return self._machine_key("mesh")

    def fe_key(self) -> str:
        return self._machine_key("fe", {"mesh": self.mesh_key()})

    def rom_key(self) -> str:
        return self._machine_key("rom", {"fe": self.fe_key()})

    def run_mesh(self) -> Path:
        """Mesh stage (FE scenes): the machine's cached mesh folder."""
        _require("geometry", "gmsh")
        key = self.keys["mesh"] = self.mesh_key()
        hit = self.comm.root_call(self.cache.lookup, "mesh", key)
        if hit is not None:
            self._log_stage("mesh", StageStatus("cached", from_cache=True))
            return hit
        t = time.perf_counter()
        with StageBar("mesh (gmsh)", self.progress):  # gmsh on rank 0 only
            d = self.comm.root_call(self.cache.store, "mesh", key, self.machine.build_mesh)
        self._log_stage("mesh", StageStatus("ran", seconds=time.perf_counter() - t))
        return d

    def _publish(self, src: Path, name: str) -> Path:
        """Copy a cached file to ``<out>/name`` atomically (rank 0 writes)."""
        import shutil

        def copy() -> Path:
            target = self.out / name
            with atomic_write(target) as tmp:
                shutil.copyfile(src, tmp)
            return target
        return self.comm.root_call(copy)

    def publish_mesh(self, mesh_dir: Path) -> Path:
        """Copy the cached mesh file (the pump's ``pump.msh``) to ``<out>/mesh.msh``
        (atomically) and log its size and quality (``geardyn mesh``)."""
        from machines.fe import mesh_quality

        target = self._publish(Path(mesh_dir) / self.machine.mesh_file, "mesh.msh")
        q = mesh_quality(mesh_dir)
        logger.info("mesh: %s — %d tets (10 nodes), %d nodes, %d P2 DOF; min SICN %.3g, "
                    "%d elements below SICN %.3g", target, q["n_elements"], q["n_nodes"],
                    q["n_dofs"], q["min_sicn"], q["n_poor"], q["poor_threshold"])
        return target

    def publish_rom(self, rom_dir: Path) -> Path:
        """Copy the cached ``rom.h5`` (dense ROM and basis, docs/results-format.md) to
        ``<out>/rom.h5`` atomically (``geardyn reduce``)."""
        target = self._publish(Path(rom_dir) / "rom.h5", "rom.h5")
        logger.info("ROM: %s (%.1f MB)", target, target.stat().st_size / 1e6)
        return target

    def run_rom(self) -> Path:
        """fe + rom stages (FE scenes): the FE model is built only when the ROM misses."""
        _require("reduction", "h5py")
        self.keys["fe"] = self.fe_key()
        key = self.keys["rom"] = self.rom_key()
        hit = self.comm.root_call(self.cache.lookup, "rom", key)
        if hit is not None:
            self.keys["mesh"] = self.mesh_key()
            for st in ("mesh", "fe"):
                self._log_stage(st, StageStatus("skipped", "rom cached", from_cache=True))
            self._log_stage("rom", StageStatus("cached", from_cache=True))
            return hit
        mesh_dir = self.run_mesh()
        t = time.perf_counter()
        with StageBar("fe (assembly)", self.progress):
            model = self.machine.build_fe_model(mesh_dir)
        self._log_stage("fe", StageStatus("ran", seconds=time.perf_counter() - t))
        t = time.perf_counter()
        with StageBar("rom (Craig-Bampton eigen-solve)", self.progress):
            d = self.cache.store("rom", key, lambda tmp: self.machine.build_rom(model, tmp),
                                 comm=self.comm)
        self._log_stage("rom", StageStatus("ran", seconds=time.perf_counter() - t))
        return d

    # ------------------------------------------------------------------ ltca
    def ltca_key(self, src: MeshSource | None = None) -> str:
        """Key of the ltca stage of ``src`` (default: the one-pair scene's source): the
        LTCA's inputs (:class:`gears.LtcaCase`), the Harris torques, the harmonics and
        sources, and the code of gears and of the arrays."""
        src = self.scene.mesh_source if src is None else src
        return stage_key("ltca", {"case": src.case, "harris_torques": src.harris_torques,
                                  "harmonics": src.harmonics, "stiffness": src.stiffness,
                                  "te": src.te},
                         source_hash("gears", "study.scene.excitation",
                                     "study.outputs.mesh_excitation"))

    def run_mesh_excitation(self, src: MeshSource | None = None, mesh: str = ""):
        """The arrays of an ``ltca``/``table`` mesh excitation
        (:class:`study.outputs.mesh_excitation.MeshExcitation`) of ``src`` (default: the
        one-pair scene's; ``mesh``: the train mesh it belongs to, which names its key
        ``ltca <mesh>``), the LTCA's cached by :meth:`ltca_key` (stage ``ltca``); None
        when both sources are ``fourier``."""
        from study.outputs.mesh_excitation import MeshExcitation, from_source

        src = self.scene.mesh_source if src is None else src
        if src is None:
            return None
        if src.case is None:                       # tables only: nothing to solve
            return from_source(src)
        key = self.keys[f"ltca {mesh}" if mesh else "ltca"] = self.ltca_key(src)
        hit = self.cache.lookup("ltca", key)
        if hit is not None:
            self._log_stage("ltca", StageStatus("cached", from_cache=True))
            return MeshExcitation.load(hit / "ltca.npz")
        t = time.perf_counter()
        data = from_source(src)
        dt = time.perf_counter() - t
        self.cache.store("ltca", key, lambda tmp: data.save(tmp / "ltca.npz"),
                         {"positions": int(data.arrays["t"].size)}, elapsed=dt)
        self._log_stage("ltca", StageStatus("ran", seconds=time.perf_counter() - t))
        return data

    def run_train_excitations(self) -> dict:
        """Mesh name -> :class:`~study.outputs.mesh_excitation.MeshExcitation` of every
        mesh of a train whose k_m or TE has an ``ltca``/``table`` source (each LTCA cached
        under its own key, :meth:`run_mesh_excitation`); empty for other scenes."""
        return {m.name: self.run_mesh_excitation(m.source, m.name)
                for m in self.scene.meshes if m.source is not None}

    # ------------------------------------------------------------------ hbm
    def problem(self):
        """The HBM problem and (FE) the ROM it was built from."""
        from study.pipeline.model import build_problem

        m = self.machine
        if isinstance(m, FEMachine):
            rom = m.load_rom(self.run_rom())
            return build_problem(self.scene, m, m.linear_model(rom)), rom
        self.keys.setdefault("linear", self._machine_key("linear"))
        return build_problem(self.scene, m, m.linear_model()), None

    def hbm_key(self) -> str:
        lin = self.keys[self.machine.linear_stage]
        return stage_key("hbm", {"linear": lin, **hbm_inputs(self.scene)},
                         source_hash("hbm", "study.pipeline.model", "study.outputs.results"))

    def hbm_resume_key(self) -> str:
        """Key of what a resumed continuation must share with the partial run: the hbm key
        without the continuation controls (:data:`RESUMABLE_CONTROLS`)."""
        lin = self.keys[self.machine.linear_stage]
        inputs = hbm_inputs(self.scene)
        inputs["continuation"] = {k: v for k, v in inputs["continuation"].items()
                                  if k not in RESUMABLE_CONTROLS}
        return stage_key("hbm_resume", {"linear": lin, **inputs},
                         source_hash("hbm", "study.pipeline.model", "study.outputs.results"))

    def run_hbm(self, problem, write_checkpoint) -> tuple[Any, str]:
        """Continuation (cached by :meth:`hbm_key`), with checkpoints and resume."""
        from hbm import trace
        from study.outputs.results import Checkpointer, read_branch, stored_key

        key = self.keys["hbm"] = self.hbm_key()
        hit = self.cache.lookup("hbm", key)
        if hit is not None:
            br = read_branch(hit / "branch.h5", problem)
            if br is not None and br.status == "completed":
                self._log_stage("hbm", StageStatus("cached", from_cache=True))
                self._main_cached = True
                return br, "cached"
        c = self.scene.continuation
        lo, hi = c.speed
        span = hi - lo
        resume, same = None, True
        results = self.out / "results.h5"
        rkey = self.keys["hbm_resume"] = self.hbm_resume_key()
        if self.resume:
            resume = read_branch(results, problem, expected_key=rkey,
                                 key_name="stage_key_hbm_resume")
            if resume is None and stored_key(results, "stage_key_hbm_resume") not in ("", rkey):
                logger.warning("%s was written for another model, harmonic set, speed range "
                               "or code version (only the continuation steps/tolerance may "
                               "change); not resuming from it", results)
            if resume is not None and len(resume) and np.max(resume.residual) >= c.tolerance:
                logger.warning("--resume: the points in %s have residuals up to %.3g, above "
                               "continuation.tolerance = %g; starting from %g rpm", results,
                               np.max(resume.residual), c.tolerance, lo)
                resume = None
            if resume is None:
                logger.warning("--resume: no matching partial run in %s; starting from %g rpm",
                               results, lo)
            else:
                logger.info("resuming from point %d at %.6g rpm (%s)", len(resume),
                            resume.rpm[-1], resume.status)
                same = stored_key(results, "stage_key_hbm") == key
                if not same:    # steps/tolerance changed: go on with this call's step
                    resume = dataclasses.replace(resume, next_step=0.0)
                    logger.warning("--resume with other continuation steps or tolerance than "
                                   "the partial run: going on with continuation.step_rpm = "
                                   "%g; the curve is not cached (a fresh run with these "
                                   "settings traces other points)", c.step)
        bar = ProgressBar(lo, hi, self.progress)
        ck = Checkpointer(results, c.checkpoint_every, write_checkpoint, bar.update)
        t = time.perf_counter()
        stability = self.scene.hbm.stability
        if stability and not problem.periodic:
            logger.warning("stability: not computed on a torus (a quasi-periodic response; "
                           "docs/theory.md §14.2): every point is written stable = False, "
                           "floquet_kind = -1")
            stability = False
        try:
            br = trace(problem, lo, hi, step=c.step / span, min_step=c.min_step / span,
                       max_step=c.max_step / span, tol=c.tolerance, max_points=c.max_points,
                       on_point=ck, resume=resume, stability=stability)
        finally:
            bar.close()
        dt = time.perf_counter() - t
        how = "resumed" if resume is not None else "ran"
        self._log_stage("hbm", StageStatus(how, seconds=dt))
        logger.info("continuation: %d points, %s (%s); %d checkpoints", len(br), br.status,
                    br.message, ck.n_written)
        if br.status == "completed" and len(br) > 0:
            if np.max(br.residual) >= c.tolerance:
                raise SolverError(f"continuation returned a point with residual "
                                  f"{np.max(br.residual):.3g} >= tolerance {c.tolerance:g}")

            def produce(tmp: Path) -> None:
                import h5py

                from study.outputs.results import write_branch
                with h5py.File(tmp / "branch.h5", "w") as f:
                    write_branch(f, br)
            if resume is None or same:  # a resumed entry's cost is unknown (None)
                self.cache.store("hbm", key, produce, {"points": len(br)},
                                 elapsed=dt if resume is None else None)
                self._main_cached = True
        return br, how

    # ------------------------------------------------------------------ branches
    def branches_key(self) -> str:
        """Key of the branches stage: the hbm key (the main curve and its problem) and the
        settings of the switching (``period_doubling_depth``, ``period_doubling_max_points``,
        :data:`MAX_SECONDARY`), with the code of hbm and of the ``/branches`` files."""
        c = self.scene.continuation
        return stage_key("branches", {"hbm": self.keys.get("hbm") or self.hbm_key(),
                                      "period_doubling_depth": c.period_doubling_depth,
                                      "period_doubling_max_points":
                                          c.period_doubling_max_points,
                                      "max_secondary": MAX_SECONDARY},
                         source_hash("hbm", "study.outputs.branches", "study.outputs.results"))

    def run_branches(self, problem, branch) -> tuple[list, float | None]:
        """Stage ``branches``: switch at the period doublings of the main branch to the
        branches of twice the period, to ``[continuation] period_doubling_depth``
        (:func:`hbm.branching.period_doubling_branches`). Skipped at once when off, without
        stability, on a torus, or when no point of the branch leads with a period
        doubling. All secondary branches together trace at most
        ``period_doubling_max_points`` points (0: as many as the main branch, 200 at
        least), :data:`MAX_SECONDARY` branches at most: on a small model the stage costs
        about what the main curve did (a period-2 point 1.5-2.4x a period-1 point,
        benchmarks/bench_period2.py), plus locating the doublings; in the near-grazing
        tangles of the converged pump a period-2 point cost ~20 s on the loaded machine
        (docs/hbm.md "Period doubling"). Cached by :meth:`branches_key` (``branches.h5``,
        the ``/branches`` group, read back by :func:`study.outputs.branches.read_branches`)
        when the main curve is the hbm stage's cache entry.

        Returns the :class:`hbm.branching.SecondaryBranch` list and what computing it cost
        (s; a cached entry's recorded cost, None when skipped or unknown)."""
        from hbm.branching import doubling_brackets, period_doubling_branches

        c = self.scene.continuation
        why = ("period_doubling_depth = 0" if c.period_doubling_depth == 0 else
               "no stability (hbm.stability = false)" if not self.scene.hbm.stability else
               "torus basis: no Floquet verdict" if not problem.periodic else
               "no period doubling on the main branch" if not doubling_brackets(branch)
               else "")
        if why:
            self._log_stage("branches", StageStatus("skipped", why))
            return [], None
        key = self.keys["branches"] = self.branches_key()
        hit = self.cache.lookup("branches", key) if self._main_cached else None
        if hit is not None:
            got = _read_cached_branches(hit / "branches.h5", problem)
            if got is not None:
                self._log_stage("branches", StageStatus("cached", from_cache=True))
                return got
        t = time.perf_counter()
        budget = c.period_doubling_max_points or max(200, len(branch))
        found = period_doubling_branches(
            problem, branch, c.speed, c.period_doubling_depth,
            step_rpm=(c.step, c.min_step, c.max_step), tol=c.tolerance,
            max_points=min(c.max_points, budget), max_branches=MAX_SECONDARY,
            max_total_points=budget)
        dt = time.perf_counter() - t
        self._log_stage("branches", StageStatus("ran", seconds=dt))
        logger.info("branches: %d of period 2 or more (%s)", len(found),
                    ", ".join(f"{s.name} {s.branch.rpm.min():.1f}-{s.branch.rpm.max():.1f} rpm"
                              for s in found) or "none")
        if self._main_cached:
            def produce(tmp: Path) -> None:
                import h5py

                from study.outputs.branches import write_branches_group
                with h5py.File(tmp / "branches.h5", "w") as f:
                    write_branches_group(f, found, seconds=dt)
            self.cache.store("branches", key, produce, {"branches": len(found)}, elapsed=dt)
        return found, dt

    # ------------------------------------------------------------------ verdicts
    def run_verdict_checks(self, problem, rom, branch):
        """The verdicts in doubt checked on a richer harmonic set
        (:func:`hbm.stability.recheck.recheck_verdicts`): the stable points in and next
        to the near-grazing tangles, and the points whose verdict is already flagged.
        Where the richer set's orbit is the same orbit resolved better its verdict
        replaces the point's (``stable``, ``floquet_kind``, ``floquet_max_real``); where
        Newton finds no orbit near it the point is not stable (the orbit is an artefact
        of the set). Returns :class:`study.outputs.verdict_checks.VerdictChecks`, None
        when skipped (no stability, a train, an explicit harmonic list,
        nothing to check); a few seconds per point, not cached (the branch is)."""
        from hbm.post.tangles import branch_tangles
        from hbm.stability.recheck import (
            recheck_candidates,
            recheck_verdicts,
            richer_mesh_harmonics,
        )
        from study.pipeline.model import build_problem

        s = self.scene
        why = ("no stability" if not s.hbm.stability else
               "a gear train" if s.is_train else
               "explicit harmonic list" if s.hbm.harmonics is not None else
               "not periodic" if not problem.periodic else "")
        idx = np.zeros(0, dtype=np.int64)
        if not why:
            idx = recheck_candidates(branch.stable, branch.stability_consistent,
                                     branch.stability_grazing, branch_tangles(branch))
            why = "no verdict in doubt" if idx.size == 0 else ""
        if why:
            logger.info("verdict checks on a richer harmonic set: skipped (%s)", why)
            return None
        t = time.perf_counter()
        n = richer_mesh_harmonics(s.hbm.mesh_harmonics)
        rich = dataclasses.replace(s, hbm=dataclasses.replace(s.hbm, mesh_harmonics=n,
                                                              aft_samples=0))
        m = self.machine
        linear = m.linear_model(rom) if isinstance(m, FEMachine) else m.linear_model()
        richer = build_problem(rich, m, linear)
        checks = recheck_verdicts(problem, richer, branch.rpm, branch.unknowns, idx,
                                  tol=s.continuation.tolerance)
        from study.outputs.verdict_checks import VerdictChecks

        out = VerdictChecks.apply_to(branch, n, richer.n_unknowns, checks,
                                     time.perf_counter() - t)
        logger.info("verdict checks on %d mesh harmonics: %d points in %.1f s, %d changed",
                    n, len(checks), out.seconds, out.n_changed)
        return out

    # ------------------------------------------------------------------ all
    def run(self, *, until: str = "export") -> RunResult:
        """Run the stages up to ``until`` (``mesh``, ``rom``, ``hbm`` or ``export``)."""
        from study.outputs.provenance import record_stage
        from study.pipeline.export import export, write_partial

        t0 = time.perf_counter()
        s = self.scene
        logger.info("scene %r (%s) -> %s", s.name, s.scene.kind, self.out)
        self.out.mkdir(parents=True, exist_ok=True)
        if not self.machine.stages:
            if until in ("mesh", "rom"):
                raise SceneError(f"scene.kind = {s.scene.kind!r}: there is no {until} stage "
                                 "(only hbm and export)")
            for st in ("mesh", "fe", "rom"):
                self._log_stage(st, StageStatus("skipped", f"{s.scene.kind} scene",
                                                applies=False))
        elif until == "mesh":
            self.publish_mesh(self.run_mesh())
            return RunResult(self.out, self.out / "results.h5", None, None, s, self.stages,
                             self.keys, seconds=time.perf_counter() - t0,
                             status=self.status)
        elif until == "rom":
            self.publish_rom(self.run_rom())
            return RunResult(self.out, self.out / "results.h5", None, None, s, self.stages,
                             self.keys, seconds=time.perf_counter() - t0,
                             status=self.status)
        problem, rom = self.problem()
        from study.outputs.fields import check_outputs
        check_outputs(s, problem.harmonics, rom)
        self.keys.setdefault("hbm", self.hbm_key())
        result = RunResult(self.out, self.out / "results.h5", None, problem, s, self.stages,
                           self.keys, rom=rom, status=self.status)
        if s.mesh_source is not None:
            result.mesh_excitation = self.comm.root_call(self.run_mesh_excitation)
        result.train_excitations = self.comm.root_call(self.run_train_excitations)

        def checkpoint(branch) -> None:
            write_partial(result, branch)

        # the continuation is serial and cheap: rank 0 runs it (and writes the checkpoints),
        # every rank gets the branch
        branch, how = self.comm.root_call(self.run_hbm, problem, checkpoint)
        if "hbm" not in self.status:  # ranks other than 0 (the continuation ran on rank 0)
            self._log_stage("hbm", StageStatus(how, from_cache=how == "cached"), log=False)
        result.branch = branch
        if branch.status != "completed":
            self.comm.root_call(write_partial, result, branch)
            self.comm.root_call(_partial_curves, result)
            how = StageStatus("partial", "results.h5 and curves.csv only")
            if until == "export" and len(branch) >= 2:
                # keep and plot what was computed: plots and report.md say it is incomplete
                try:
                    export(result, figures=True, housing=False)
                    how = StageStatus("partial", "results.h5, curves.csv, plots, report.md: "
                                      "incomplete curve")
                except Exception as exc:  # noqa: BLE001 - the solver failure is what matters
                    logger.warning("plots of the partial curve failed: %s", exc)
            self._log_stage("export", how)
            raise mark_collective(SolverError(
                f"continuation stopped before {s.continuation.speed[1]:g} rpm "
                f"({branch.status}): {branch.message} (results.h5 holds {len(branch)} points; "
                "rerun with --resume after changing the continuation steps/tolerance — a run "
                f"that differs only in {', '.join(RESUMABLE_CONTROLS)} continues from its last "
                "point, or, after a walk back or a closed loop it could not leave, from the "
                "point before the speeds where it was caught)", result))
        result.verdict_checks = self.comm.root_call(self.run_verdict_checks, problem, rom,
                                                    branch)
        result.secondary, result.branches_seconds = self.comm.root_call(
            self.run_branches, problem, branch)
        t = time.perf_counter()
        # listed in report.md, written during export
        self._log_stage("export", StageStatus("ran"), log=False)
        export(result, figures=(until == "export"))
        self._log_stage("export", StageStatus("ran", seconds=time.perf_counter() - t))
        self.comm.root_call(record_stage, result.results, "export", self.status["export"])
        result.seconds = time.perf_counter() - t0
        ran = [k if v == "ran" else f"{k} (resumed)" for k, v in self.stages.items()
               if v in ("ran", "resumed")]
        cached = [k for k, v in self.stages.items() if v == "cached"]
        logger.info("done in %.2f s; ran: %s; from cache: %s", result.seconds,
                    ", ".join(ran) or "-", ", ".join(cached) or "-")
        return result


def _read_cached_branches(path: Path, problem) -> tuple[list, float | None] | None:
    """The secondary branches of a branches cache entry and what they cost to compute
    (None, logged, when it cannot be read back for ``problem``: the stage then runs
    again)."""
    import h5py

    from study.outputs.branches import read_branches

    try:
        with h5py.File(path, "r") as f:
            return read_branches(f, problem)
    except (OSError, KeyError, ValueError) as exc:
        logger.warning("cache entry %s cannot be read back (%s): running the stage", path, exc)
        return None


def _partial_curves(result) -> None:
    """curves.csv of a continuation that stopped early (the points so far); a failure
    here is logged, never raised over the solver error being reported."""
    from study.outputs.nvh import compute_nvh, write_curves_csv

    if len(result.branch) == 0:
        return
    try:
        write_curves_csv(result.out / "curves.csv", result.branch, compute_nvh(result))
    except Exception as exc:  # noqa: BLE001 - the solver error is what the user needs
        logger.warning("curves.csv of the partial branch not written: %s", exc)


def run_scene(scene: Scene, out: str | Path, **kwargs) -> RunResult:
    """Run a validated scene (see :class:`Pipeline`)."""
    until = kwargs.pop("until", "export")
    return Pipeline(scene, out, **kwargs).run(until=until)
