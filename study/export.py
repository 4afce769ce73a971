"""Export stage: ``results.h5``, PNG plots and ``report.md`` of a run."""
from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

logger = logging.getLogger(__name__)

__all__ = ["write_partial", "export", "time_series_speeds"]


def _settings(result) -> dict:
    c = result.scene.continuation
    return {"tolerance": c.tolerance, "checkpoint_every": c.checkpoint_every}


def _extra(result):
    if result.rom is None:
        return None
    from study import fe_stages
    return lambda f: fe_stages.write_rom_group(f, result)


def write_partial(result, branch) -> None:
    """(Re)write results.h5 with the branch so far (checkpoint; atomic)."""
    from study.results import write_results

    write_results(result.results, result.scene, result.problem, branch,
                  settings=_settings(result), extra=_extra(result), stage_keys=result.keys)


def time_series_speeds(result) -> list[float]:
    """Speeds for time series: the scene's list, else per contact class the stable point
    with the largest dynamic mesh load."""
    s = result.scene.outputs.time_series
    if s:
        return list(s)
    br = result.branch
    out = []
    for cls in (0, 1, 2):
        idx = np.flatnonzero((br.contact == cls) & br.stable)
        if idx.size:
            out.append(float(br.rpm[idx[np.argmax(br.mesh_load_std[idx])]]))
    return out


def nearest_point(result, rpm: float):
    """The stored point closest in speed (stable ones preferred) as an :class:`hbm.Point`."""
    from hbm import Point

    br = result.branch
    d = np.abs(br.rpm - rpm) + np.where(br.stable, 0.0, 1e9)
    i = int(np.argmin(d))
    return i, Point(rpm=float(br.rpm[i]), omega=float(br.omega[i]), unknowns=br.unknowns[i],
                    coefficients=br.coefficients[i], residual=float(br.residual[i]),
                    iterations=int(br.newton_iterations[i]))


def export(result, figures: bool = True, housing: bool = True) -> None:
    """Write the final results.h5, then the plots and report.md the scene asks for
    (``housing=False``: no housing fields, e.g. for an incomplete curve)."""
    write_partial(result, result.branch)
    logger.info("wrote %s", result.results)
    if housing and result.rom is not None and result.scene.outputs.housing_field:
        from study import fe_stages
        fields = fe_stages.housing_fields(result)
        result.figures += fields
        if figures and "housing" in result.scene.outputs.plots:
            from study.render import render_housing_isolated
            for x in fields:
                png = render_housing_isolated(x, x.with_suffix(".png"))
                if png is not None:
                    result.figures.append(png)
    if not figures:
        return
    from study import plots, report

    result.figures += plots.draw_all(result)
    if result.scene.outputs.report:
        p = report.write_report(result)
        logger.info("wrote %s", p)


def out_path(result, name: str) -> Path:
    return Path(result.out) / name
