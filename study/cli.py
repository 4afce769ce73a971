"""The ``geardyn`` command line (also ``python -m study``).

::

    geardyn run SCENE --out DIR [--set section.key=v1,v2,...] [--resume] [-q|-v]
    geardyn mesh SCENE --out DIR        # FE scenes: geometry + mesh stage only
    geardyn reduce SCENE --out DIR      # FE scenes: mesh, FE model and ROM stages;
                                        # writes DIR/rom.h5 (ROM and basis)
    geardyn export SCENE --out DIR      # all stages (cached ones reused), results.h5 and
                                        # housing fields, no plots
    geardyn report SCENE --out DIR      # plots + report.md from DIR/results.h5
    geardyn convergence SCENE --out DIR [--knob harmonics=4,8,16] [--only n_cm]
                                        [--tol 1e-2]   # error against run time per knob
    geardyn excitations SCENE --out DIR # the paper's three excitation cases (internal
                                        # only, all but TVMS, all) into DIR/<case>/ on
                                        # one ROM; comparison and paper.md in DIR
    geardyn microgeometry SCENE --out DIR --set micro_geometry.both.tip_relief_um=0,6,12
                                        # an LTCA scene with one micro-geometry key varied:
                                        # table + plot of its effect on the mesh-load std,
                                        # the grazing speeds and (FE) the ERP

``run``, ``mesh``, ``reduce``, ``export`` and ``report`` also run under ``mpirun -n N``
(:mod:`study.pipeline.parallel`, docs/scale.md): FE stages distributed, files from rank 0, the
same exit code on every rank; ``convergence`` refuses (exit 2).

Exit codes: 0 success; 2 invalid input (scene, option or value: the message names
the field); 3 solver failure (continuation stopped early; the points computed so
far are in results.h5, ``--resume`` continues); 4 a stage cannot run here
(missing FE package); 5 file system error; 1 unexpected internal error;
130 interrupted (Ctrl-C; checkpoints are kept).
"""
from __future__ import annotations

import argparse
import itertools
import logging
import os
import re
import sys
from pathlib import Path

from study.scene.errors import SceneError

EXIT_OK, EXIT_INTERNAL, EXIT_INPUT, EXIT_SOLVER, EXIT_UNAVAILABLE, EXIT_IO = 0, 1, 2, 3, 4, 5
EXIT_INTERRUPTED = 130

logger = logging.getLogger("geardyn")

__all__ = ["main", "build_parser", "parse_sets"]


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="geardyn",
        description="Vibro-impact dynamics of geared machines: scene -> forced response.",
        epilog="Exit codes: 0 ok, 2 invalid input, 3 solver failure, 4 stage unavailable, "
               "5 file error, 130 interrupted.")
    p.add_argument("command", choices=["run", "mesh", "reduce", "export", "report", "convergence",
                                        "excitations", "microgeometry"],
                   help="what to do")
    p.add_argument("scene", help="scene file (TOML, see docs/scenes.md)")
    p.add_argument("--out", required=True, help="output folder")
    p.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=V1[,V2...]",
                   help="override a scene value; several values run one variant each "
                        "(TOML syntax: --set load.torque_Nm=50,100 --set "
                        "continuation.speed_rpm=[500,3000])")
    p.add_argument("--resume", action="store_true",
                   help="continue an interrupted continuation from OUT/results.h5")
    p.add_argument("--cache", default=None,
                   help="stage cache folder (default $GEARDYN_CACHE or OUT/../.geardyn-cache)")
    p.add_argument("--no-cache", action="store_true",
                   help="recompute every stage (and overwrite its cache entry)")
    g = p.add_mutually_exclusive_group()
    g.add_argument("-q", "--quiet", action="store_true", help="only warnings and errors")
    g.add_argument("-v", "--verbose", action="store_true", help="debug messages")
    p.add_argument("--no-progress", action="store_true",
                   help="no progress bars (shown only when stderr is a terminal, never with -q)")
    c = p.add_argument_group("convergence")
    c.add_argument("--knob", action="append", default=[], metavar="NAME=V1,V2,...",
                   help="values of one knob (mesh size factors, n_cm, cutoff factors, harmonics, "
                        "sidebands, aft, step [rpm]); repeatable")
    c.add_argument("--only", action="append", default=[], metavar="NAME",
                   help="sweep only this knob (repeatable; default: all that apply)")
    c.add_argument("--tol", type=float, default=1e-2,
                   help="relative error tolerance of the recommendation (default 1e-2)")
    return p


def parse_sets(items: list[str]) -> list[dict]:
    """``["a.b=1,2", "c.d=x"]`` -> list of override dicts (Cartesian product)."""
    from study.scene.overrides import parse_set_values

    axes = []
    for item in items:
        if "=" not in item:
            raise SceneError(f"--set {item!r}: must be SECTION.KEY=VALUE[,VALUE...]")
        key, val = item.split("=", 1)
        key = key.strip()
        if not re.fullmatch(r"[A-Za-z_][\w]*(\.[A-Za-z_][\w]*)+", key):
            raise SceneError(f"--set {item!r}: {key!r} must be section.key")
        if not val.strip():
            raise SceneError(f"--set {item!r}: no value given")
        axes.append([(key, v) for v in parse_set_values(val)])
    if not axes:
        return [{}]
    return [dict(combo) for combo in itertools.product(*axes)]


class _OnceFilter(logging.Filter):
    """Drop repeats of an identical warning (e.g. one per continuation point)."""

    def __init__(self) -> None:
        super().__init__()
        self.seen: set[tuple[str, str]] = set()

    def filter(self, record: logging.LogRecord) -> bool:
        if record.levelno != logging.WARNING:
            return True
        key = (record.name, record.getMessage())
        if key in self.seen:
            return False
        self.seen.add(key)
        return True


def _setup_logging(quiet: bool, verbose: bool, rank: int = 0) -> None:
    """One log stream: rank 0 logs at the chosen level, other ranks (mpirun) only errors,
    prefixed with their rank."""
    level = logging.WARNING if quiet else (logging.DEBUG if verbose else logging.INFO)
    if rank != 0:
        level = logging.ERROR
    root = logging.getLogger()
    for h in list(root.handlers):
        root.removeHandler(h)
    h = logging.StreamHandler(sys.stderr)
    tag = f"[rank {rank}] " if rank else ""
    h.setFormatter(logging.Formatter(f"%(asctime)s %(levelname)-7s {tag}%(name)s: %(message)s",
                                     "%H:%M:%S"))
    h.addFilter(_OnceFilter())
    root.addHandler(h)
    root.setLevel(level)
    for noisy in ("matplotlib", "PIL", "h5py"):
        logging.getLogger(noisy).setLevel(max(level, logging.WARNING))


def _label(ov: dict) -> str:
    return ",".join(f"{k}={v}" for k, v in ov.items())


def _folder(ov: dict) -> str:
    def val(v) -> str:
        return "-".join(str(x) for x in v) if isinstance(v, list) else str(v)
    s = "_".join(f"{k.split('.')[-1]}={val(v)}" for k, v in ov.items())
    return re.sub(r"[^\w.=+-]+", "-", s).strip("-") or "base"


def _progress(args) -> bool:
    """Progress bars only on a terminal: in a pipe or a log file they are noise."""
    return not (args.no_progress or args.quiet) and sys.stderr.isatty()


def _run_variants(args, scene_path: Path, variants: list[dict], until: str) -> int:
    import study
    from study.pipeline.runs import SolverError
    from study.scene.load import load_scene

    out = Path(args.out)
    cache = args.cache or os.environ.get("GEARDYN_CACHE") or None
    if len(variants) == 1:
        study.run(scene_path, out, overrides=variants[0], cache_dir=cache, resume=args.resume,
                  refresh=args.no_cache, progress=_progress(args), until=until)
        return EXIT_OK
    # validate every variant before any heavy work
    scenes = [load_scene(scene_path, ov) for ov in variants]
    cache = cache or str(out.resolve().parent / ".geardyn-cache")  # shared with `run --out OUT`
    results, failed = [], []
    for ov, sc in zip(variants, scenes, strict=True):
        logger.info("variant %s", _label(ov))
        try:
            r = study.run(sc, out / _folder(ov), cache_dir=cache, resume=args.resume,
                          refresh=args.no_cache, progress=_progress(args), until=until)
            results.append((ov, r))
        except SolverError as exc:
            logger.error("variant %s: %s", _label(ov), exc)
            failed.append(ov)
            if exc.result is not None and exc.result.branch is not None \
                    and len(exc.result.branch) > 1:
                results.append((ov, exc.result))
    if results and until == "export":
        from study.pipeline.parallel import world
        from study.studies.variants import write_variants
        world().root_call(write_variants, out, results)
    return EXIT_SOLVER if failed else EXIT_OK


def _report(args, scene_path: Path, overrides: dict) -> int:
    from study.pipeline.replay import report_from_results
    report_from_results(scene_path, Path(args.out), overrides,
                        cache=args.cache or os.environ.get("GEARDYN_CACHE"))
    return EXIT_OK


def _excitations(args, scene_path: Path, overrides: dict) -> int:
    """``geardyn excitations``: three cases, their comparison (study.studies.excitations)
    and paper.md (study.studies.paper)."""
    from study.pipeline.parallel import world
    from study.scene.load import load_scene
    from study.studies.excitations import run_cases, write_comparison
    from study.studies.paper.report import write_paper_files

    scene = load_scene(scene_path, overrides)
    results, failed = run_cases(scene, args.out, cache_dir=args.cache or
                                os.environ.get("GEARDYN_CACHE") or None, resume=args.resume,
                                refresh=args.no_cache, progress=_progress(args))
    if results:
        world().root_call(write_comparison, Path(args.out), scene, results)
        world().root_call(write_paper_files, Path(args.out), scene, results)
    return EXIT_SOLVER if failed else EXIT_OK


def _microgeometry(args, scene_path: Path) -> int:
    """``geardyn microgeometry``: one ``--set`` key with several values (the varied
    micro-geometry or LTCA parameter), others with one value (the base);
    study.studies.microgeometry runs and compares them."""
    from study.scene.overrides import parse_set_values
    from study.studies.microgeometry import run_microgeometry, write_microgeometry

    varied, base = [], {}
    for item in args.set:
        key, sep, val = item.partition("=")
        vals = parse_set_values(val) if sep and val.strip() else []
        if len(vals) > 1:
            varied.append((key.strip(), vals))
        else:
            base.update(parse_sets([item])[0])
    if len(varied) != 1:
        raise SceneError("microgeometry: give exactly one --set SECTION.KEY=V1,V2,... with "
                         "several values (e.g. --set micro_geometry.both.tip_relief_um="
                         f"0,6,12); got {len(varied)}")
    key, values = varied[0]
    out = Path(args.out)
    cache = args.cache or os.environ.get("GEARDYN_CACHE") or str(out.resolve() / ".cache")
    variants = run_microgeometry(scene_path, out, key, values, base, cache_dir=cache,
                                 refresh=args.no_cache, resume=args.resume,
                                 progress=_progress(args))
    if any(v.result is not None for v in variants):
        write_microgeometry(out, key, variants)
    return EXIT_SOLVER if any(v.result is None or v.result.branch.status != "completed"
                              for v in variants) else EXIT_OK


def _convergence(args, scene_path: Path) -> int:
    """``geardyn convergence``: one knob at a time, table + Pareto plot + advice."""
    from study.scene.overrides import parse_set_values
    from study.studies.convergence.knobs import KNOB_KEYS
    from study.studies.convergence.sweep import run_convergence

    knobs: dict[str, list] = {}
    for item in args.knob:
        name, sep, val = item.partition("=")
        vals = parse_set_values(val) if sep and val.strip() else []
        if not vals or not all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                for v in vals):
            raise SceneError(f"--knob {item!r}: must be NAME=V1,V2,... with numbers")
        knobs[name.strip()] = vals
    only = list(args.only)
    base: dict = {}
    # --set KNOB_KEY=v1,v2 is the same as --knob NAME=v1,v2 --only NAME (not for the mesh,
    # whose knob values are size factors, not sizes)
    by_key = {v: k for k, v in KNOB_KEYS.items() if k != "mesh"}
    for item in args.set:
        key, _, val = item.partition("=")
        vals = parse_set_values(val)
        if len(vals) > 1 and key.strip() in by_key:
            knobs[by_key[key.strip()]] = vals
            only.append(by_key[key.strip()])
        elif len(vals) == 1:
            base.update(parse_sets([item])[0])
        else:
            raise SceneError(f"--set {item!r}: convergence takes one value per key "
                             "(use --knob NAME=V1,V2 for the swept values)")
    cache = args.cache or os.environ.get("GEARDYN_CACHE") or None
    run_convergence(scene_path, args.out, knobs=knobs, only=only or None, tol=args.tol,
                    overrides=base, cache_dir=cache, refresh=args.no_cache,
                    progress=_progress(args))
    return EXIT_OK


def _dispatch(args) -> int:
    scene_path = Path(args.scene)
    variants = parse_sets(args.set)
    cmd = args.command
    from study.pipeline.parallel import world

    if cmd != "convergence" and (args.knob or args.only or args.tol != 1e-2):
        raise SceneError(f"{cmd}: --knob, --only and --tol are options of `geardyn "
                         "convergence` only (vary a scene value with --set)")
    if cmd == "report":
        if len(variants) != 1:
            raise SceneError("report: --set takes a single value per key")
        return _report(args, scene_path, variants[0])
    if cmd == "excitations":
        if len(variants) != 1:
            raise SceneError("excitations: --set takes a single value per key")
        return _excitations(args, scene_path, variants[0])
    if cmd == "microgeometry":
        if world().size > 1:
            raise SceneError(f"microgeometry under mpirun -n {world().size}: not supported; "
                             "run it without mpirun")
        return _microgeometry(args, scene_path)
    if cmd == "convergence":
        if world().size > 1:
            raise SceneError(f"convergence under mpirun -n {world().size}: not supported; "
                             "run it without mpirun (its FE runs are coarse)")
        return _convergence(args, scene_path)
    until = {"run": "export", "mesh": "mesh", "reduce": "rom", "export": "hbm"}[cmd]
    return _run_variants(args, scene_path, variants, until)


def main(argv: list[str] | None = None) -> int:
    """Entry point; returns the exit code (see module docstring)."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse: usage errors -> 2, --help -> 0
        return int(exc.code or 0)
    from study.pipeline.parallel import world

    comm = world()
    _setup_logging(args.quiet, args.verbose, comm.rank)
    code, exc = _main(args)
    if exc is None:
        return code
    from study.scene.errors import StageUnavailable

    # raised identically on every rank (scene validation runs on every rank; rank-0
    # sections share their errors, study.pipeline.parallel): rank 0 alone reports it
    agreed = isinstance(exc, (SceneError, StageUnavailable)) or \
        bool(getattr(exc, "collective", False))
    if comm.rank != 0 and agreed:
        logger.disabled = True
    code = _exit_code(exc)
    if comm.size > 1 and not agreed:
        # this error may be local to this rank while the others wait in a collective
        # call: end the whole job with the same exit code
        logger.error("rank %d ends the MPI job (exit code %d)", comm.rank, code)
        sys.stderr.flush()
        comm.mpi.Abort(code)
    return code


def _main(args) -> tuple[int, BaseException | None]:
    """Run the command: its exit code, or the exception it raised."""
    try:
        return _dispatch(args), None
    except BaseException as exc:  # noqa: BLE001 - mapped to an exit code by main
        return EXIT_INTERNAL, exc


def _exit_code(exc: BaseException) -> int:
    """Log ``exc`` and return its exit code (module docstring)."""
    from hbm import ConvergenceError
    from study.pipeline.runs import SolverError
    from study.scene.errors import StageUnavailable

    if isinstance(exc, SceneError):
        logger.error("invalid input: %s", exc)
        return EXIT_INPUT
    if isinstance(exc, (SolverError, ConvergenceError)):
        logger.error("solver failure: %s", exc)
        return EXIT_SOLVER
    if isinstance(exc, StageUnavailable):
        logger.error("stage unavailable: %s", exc)
        return EXIT_UNAVAILABLE
    if isinstance(exc, KeyboardInterrupt):
        logger.error("interrupted; checkpoints are kept (rerun with --resume)")
        return EXIT_INTERRUPTED
    if isinstance(exc, ValueError):  # invalid model data caught by hbm/fem/reduction checks
        logger.error("invalid input: %s", exc)
        return EXIT_INPUT
    if isinstance(exc, OSError):
        logger.error("file error: %s", exc)
        return EXIT_IO
    if not isinstance(exc, Exception):  # SystemExit and the like
        raise exc
    logger.error("internal error (please report)", exc_info=exc)
    return EXIT_INTERNAL
