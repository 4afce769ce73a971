"""Export stage: ``results.h5`` (with the ROM's ``/rom`` group), the housing fields, PNG
plots and ``report.md`` of a run."""
from __future__ import annotations

import logging
from pathlib import Path

from study.outputs import fields
from study.outputs.checks import run_checks, write_checks_group
from study.outputs.nvh import compute_nvh, write_curves_csv, write_nvh_group
from study.outputs.points import point_at_speed
from study.outputs.results import replace_group
from study.pipeline.parallel import world

logger = logging.getLogger(__name__)

__all__ = ["write_partial", "export", "draw_figures", "write_housing", "write_rom_group",
           "housing_fields", "write_report_files", "write_attractor_files",
           "write_bifurcation_files", "record_checks"]


def _settings(result) -> dict:
    c = result.scene.continuation
    out = {"tolerance": c.tolerance, "checkpoint_every": c.checkpoint_every}
    if result.scene.is_train:   # the basis chosen and both sizes (hbm.basis)
        from machines import machine_for
        from study.pipeline.model import train_basis_choice

        choice = train_basis_choice(result.scene, machine_for(result.scene).layout)
        out.update(choice.attributes())
    return out


def _extra(result):
    nvh = getattr(result, "nvh", None)
    mesh = getattr(result, "mesh_excitation", None)
    secondary = getattr(result, "secondary", None)
    checks = getattr(result, "verdict_checks", None)
    per_mesh = getattr(result, "train_excitations", None) or {}
    if result.rom is None and nvh is None and mesh is None and not secondary and \
            checks is None and not per_mesh:
        return None

    def extra(f) -> None:
        if result.rom is not None:
            write_rom_group(f, result)
        if nvh is not None:
            write_nvh_group(f, nvh, getattr(result.rom, "radiation", None))
        if mesh is not None:
            from study.outputs.mesh_excitation import write_group
            write_group(f, mesh)
        if per_mesh:
            from study.outputs.mesh_excitation import write_element_groups
            write_element_groups(f, per_mesh)
        if checks is not None:
            checks.write_group(f)
        if secondary:
            from study.outputs.branches import write_branches_group
            write_branches_group(f, secondary, getattr(result, "secondary_nvh", None),
                                 getattr(result, "branches_seconds", None))
    return extra


def write_partial(result, branch) -> None:
    """(Re)write results.h5 with the branch so far (checkpoint; atomic)."""
    from study.outputs.results import write_results

    write_results(result.results, result.scene, result.problem, branch,
                  settings=_settings(result), extra=_extra(result), stage_keys=result.keys,
                  stages=result.status)


def export(result, figures: bool = True, housing: bool = True) -> None:
    """Write the final results.h5 (with ``/nvh``, and the secondary branches' NVH in
    ``/branches/<name>/nvh``), ``curves.csv`` and ``curves_branches.csv``, then the housing
    fields, plots and report.md the scene asks for (``housing=False``: no housing
    fields, e.g. for an incomplete curve).

    Under mpirun (:mod:`study.pipeline.parallel`) rank 0 writes every file."""
    from study.outputs.branches import CURVES_FILE, secondary_nvh, write_branch_curves_csv

    comm = world()
    result.nvh = compute_nvh(result)
    result.secondary_nvh = secondary_nvh(result)
    comm.root_call(write_partial, result, result.branch)
    logger.info("wrote %s", result.results)
    comm.root_call(write_curves_csv, Path(result.out) / "curves.csv", result.branch,
                   result.nvh)
    comm.root_call(write_branch_curves_csv, Path(result.out) / CURVES_FILE,
                   result.secondary, result.secondary_nvh)
    renders = write_housing(result) if housing else []
    if figures:
        comm.root_call(_figures, result, renders)   # plots, renderings, checks, report.md
    else:       # no time responses: the diagram of the branches alone, no plot
        comm.root_call(write_bifurcation_files, result, plot=False)
        result.checks = comm.root_call(run_checks, result)
    comm.root_call(record_checks, result)


def record_checks(result) -> None:
    """Write ``/checks`` of the run (:mod:`study.outputs.checks`) into the finished
    results.h5 (computed after the file, by the plots and fields that ask for solutions
    at given speeds); atomic: a failure leaves the file as it was."""
    with replace_group(result.results, "checks") as g:
        write_checks_group(g, result.checks)


def write_housing(result) -> list[Path]:
    """The housing fields the scene asks for (FE scenes, ``[outputs] housing_field_rpm``),
    appended to ``result.figures``; collective under mpirun (rank 0 writes). Returns the
    XDMF files to render when the scene asks for the ``housing`` plot (the renderings
    run beside the other plots, :func:`draw_figures`)."""
    if result.rom is None or not result.scene.outputs.housing_field:
        return []
    paths = housing_fields(result)
    result.figures += paths
    if "housing" not in result.scene.outputs.plots:
        return []
    return [x for x in paths if not x.name.startswith(("housing_orders_", "housing_surface_"))]


def write_rom_group(f, result) -> None:
    """Copy the cached ROM's dense datasets into results.h5 ``/rom`` (no basis) and
    replace the coupled quantities by those of the run's k̄ and ξ."""
    import h5py

    rd = result.rom
    with h5py.File(rd.folder / "rom.h5", "r") as src:
        g = f.create_group("rom")
        for k, v in src["rom"].attrs.items():
            g.attrs[k] = v
        for name in src["rom"]:
            if name != "basis":
                src.copy(src["rom"][name], g, name=name)
    for name, val in (("C", rd.C), ("frequencies_hz", rd.frequencies_hz),
                      ("mesh_energy", rd.mesh_energy)):
        del g[name]
        g[name] = val
    g.attrs["km_mean"] = rd.km_mean
    g.attrs["xi_run"] = result.scene.damping.modal_ratio


def housing_fields(result) -> list[Path]:
    """Housing-only XDMF files at the scene's ``housing_field_rpm`` speeds (study.outputs.fields):
    time series of the dynamic displacement (no aliasing), complex amplitudes per order,
    normal velocity and ERP density per order on the outer surface.

    From the cached ROM alone (the radiating part's ``housing.h5`` and ``radiation.h5``
    of the rom stage, :class:`machines.rom.RomData`): no FE model and no mesh file. Rank 0
    writes; the files are the same whatever the number of ranks that reduced the model."""
    return world().root_call(_write_housing_fields, result)


def _write_housing_fields(result) -> list[Path]:
    sc = result.scene
    hd = result.rom.housing()
    paths = []
    for rpm in sc.outputs.housing_field:
        _, pt, _ = point_at_speed(result, rpm, "housing field")
        qk = result.problem.recover(pt)                      # (n_r, nS) complex
        paths += fields.write_housing_fields(Path(result.out), pt.rpm, hd, result.rom.radiation,
                                             qk, result.problem.harmonics, pt.omega, sc)
    return paths


def draw_figures(result, renders: list[Path] = ()) -> None:
    """The PNG plots of a run: those the scene's ``[outputs] plots`` asks for
    (:func:`study.plots.figures.draw_all`), those of an ``ltca``/``table`` mesh
    excitation (:func:`study.plots.mesh_excitation.mesh_excitation_plots`) and the
    renderings of the housing fields ``renders`` (each in a child process started first
    and collected last, :class:`study.plots.render.HousingRender`: it runs while the
    plots are drawn; its PNG is listed where the rendering was asked, after the fields)."""
    from study.plots.figures import draw_all

    at = len(result.figures)
    running = []
    if renders:
        from study.plots.render import HousingRender
        running = [HousingRender(x, x.with_suffix(".png")) for x in renders]
    try:
        result.figures += draw_all(result)
        if getattr(result, "mesh_excitation", None) is not None:
            from study.plots.mesh_excitation import mesh_excitation_plots
            result.figures += mesh_excitation_plots(result.mesh_excitation, result.scene,
                                                    Path(result.out))
        if getattr(result, "train_excitations", None):
            from study.plots.mesh_excitation import train_excitation_plots
            result.figures += train_excitation_plots(result.train_excitations, result.scene,
                                                     Path(result.out))
    finally:
        pngs = [r.wait() for r in running]
    result.figures[at:at] = [p for p in pngs if p is not None]


def _figures(result, renders: list[Path] = ()) -> None:
    draw_figures(result, renders)
    result.checks = run_checks(result)
    if result.scene.outputs.report:
        write_report_files(result)
    else:                       # time responses asked for are kept without report.md too
        write_attractor_files(result)


def write_attractor_files(result) -> None:
    """The time responses at the unstable segments when the scene asks for them
    (``[outputs] attractor_transient_turns``): ``result.attractors``, attractors.csv and
    ``/attractors`` of results.h5."""
    from study.outputs.attractors import attractors, write_attractors_csv, write_attractors_group

    result.attractors = attractors(result)
    if result.attractors:
        write_attractors_csv(out_path(result, "attractors.csv"), result.attractors)
        write_attractors_group(result.results, result.attractors)
    write_bifurcation_files(result)


def write_bifurcation_files(result, plot: bool = True) -> None:
    """The run's bifurcation diagram (:mod:`study.outputs.bifurcation`, after the time
    responses ``result.attractors``, if any): ``result.bifurcation``, ``/bifurcation`` of
    results.h5 and, when ``plot`` and the scene's plots ask for it, bifurcation.png.
    None on a torus basis (no period)."""
    from study.outputs.bifurcation import diagram, write_bifurcation_group

    if not result.problem.periodic or result.branch is None or not len(result.branch):
        return
    result.bifurcation = diagram(result)
    write_bifurcation_group(result.results, result.bifurcation)
    if plot and "bifurcation" in result.scene.outputs.plots:
        from study.plots.bifurcation import bifurcation_plot

        result.figures.append(bifurcation_plot(
            result.bifurcation, out_path(result, "bifurcation.png"),
            f"{result.scene.name}: bifurcation diagram (Δ and mesh load once per "
            "fundamental period)"))


def write_report_files(result) -> Path:
    """report.md, with the time responses at the unstable segments and their files
    (:func:`write_attractor_files`)."""
    from study.outputs import report

    write_attractor_files(result)
    if not result.checks:
        result.checks = run_checks(result)
    p = report.write_report(result)
    logger.info("wrote %s", p)
    return p


def out_path(result, name: str) -> Path:
    return Path(result.out) / name
