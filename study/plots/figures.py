"""The figures of a run: :func:`draw_all` draws the PNG plots the scene's ``[outputs]
plots`` asks for, each by the module of what it draws (:mod:`study.plots`).

Units on the plots: rpm, µm, N, Hz.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from hbm import point_stats
from study.outputs.checks import rom_limit_hz
from study.outputs.points import nearest_point, point_at_speed, time_series_speeds
from study.plots.modes import order_map_plot, rom_plots
from study.plots.point import spectrum_plot, time_series_plot
from study.plots.speed import accelerometer_plot, erp_plot, forced_response

__all__ = ["draw_all"]


def _attracting_order_maps(result, z: int, valid_hz) -> list[Path]:
    """Order maps of the responses the machine settles on: the stable points of the main
    branch and of its period-2 (4, ...) branches, the half orders as their own rows
    (:func:`study.outputs.branches.attracting_levels`)."""
    from study.outputs.branches import attracting_levels

    lv = attracting_levels(result)
    if lv is None or lv.rpm.size < 2:
        return []
    out, name = Path(result.out), result.scene.name
    modes = result.rom.frequencies_hz if result.rom is not None else None
    paths = [order_map_plot(lv.rpm, lv.orders, 20 * np.log10(np.maximum(lv.mesh_load, 1e-30)),
                            z, out / "order_map_mesh_load_attracting.png",
                            "mesh-load amplitude, dB re 1 N",
                            f"{name}: mesh load per order, stable responses (half orders: "
                            "period 2)", modes, rom_valid_hz=valid_hz)]
    if lv.erp is not None:
        from study.outputs.acoustics import power_db
        paths.append(order_map_plot(lv.rpm, lv.orders, power_db(np.maximum(lv.erp, 1e-300)),
                                    z, out / "order_map_erp_attracting.png", "ERP, dB re 1 pW",
                                    f"{name}: housing ERP per order, stable responses",
                                    modes, rom_valid_hz=valid_hz))
    return paths


def draw_all(result) -> list[Path]:
    """All plots the scene's ``[outputs] plots`` asks for; returns the PNG paths."""
    want = set(result.scene.outputs.plots)
    out = Path(result.out)
    br, pb = result.branch, result.problem
    paths: list[Path] = []
    name = result.scene.name
    if "forced_response" in want and not result.scene.is_train:
        paths.append(forced_response(br, out / "forced_response.png", f"{name}: forced response",
                                     secondary=getattr(result, "secondary", ())))
    valid_hz = rom_limit_hz(result.rom)          # None for a lumped scene
    speeds = time_series_speeds(result) if {"time_series", "spectrum"} & want else []
    asked = bool(result.scene.outputs.time_series)   # else branch points (most loaded)
    for rpm in speeds:
        if asked:
            i, pt, use = point_at_speed(result, rpm, "time series and spectrum")
            c = int(point_stats(pb, pt)[0]["contact"]) if use.how == "solved" else \
                int(br.element(0).contact[i])
        else:
            i, pt = nearest_point(result, rpm)
            c = int(br.element(0).contact[i])
        tag = f"{pt.rpm:.0f}rpm"
        cls = ("permanent contact", "single-sided impacts", "double-sided impacts")[c]
        if "time_series" in want and pb.harmonics.periodic and not result.scene.is_train:
            paths.append(time_series_plot(pb, pt, out / f"time_series_{tag}.png",
                                          f"{name}: {pt.rpm:.1f} rpm, {cls}"))
        if "spectrum" in want and not result.scene.is_train:
            paths.append(spectrum_plot(pb, pt, out / f"spectrum_{tag}.png",
                                       rom_valid_hz=valid_hz))
    if result.scene.is_train:   # per mesh, orders named by shaft and mesh (study.plots.train)
        from study.plots.train import train_plots

        return paths + train_plots(result, want, speeds)
    nvh = getattr(result, "nvh", None)
    z = result.scene.gear.teeth
    if nvh is not None and "order_maps" in want and len(br) > 0:
        ml = 20 * np.log10(np.maximum(nvh.mesh_load_amplitude, 1e-30) / 1.0)
        modes = result.rom.frequencies_hz if result.rom is not None else None
        paths.append(order_map_plot(br.rpm, nvh.orders, ml, z, out / "order_map_mesh_load.png",
                                    "mesh-load amplitude, dB re 1 N",
                                    f"{name}: mesh load per order", modes,
                                    rom_valid_hz=valid_hz))
        if nvh.erp is not None:
            paths.append(order_map_plot(br.rpm, nvh.orders, nvh.erp_db, z,
                                        out / "order_map_erp.png", "ERP, dB re 1 pW",
                                        f"{name}: housing ERP per order", modes,
                                        rom_valid_hz=valid_hz))
    if nvh is not None and "order_maps" in want and getattr(result, "secondary", None):
        paths += _attracting_order_maps(result, z, valid_hz)
    if nvh is not None and nvh.erp is not None and "erp" in want and len(br) > 0:
        paths.append(erp_plot(br, nvh.erp_total_db, nvh.erp_db, nvh.orders, z,
                              out / "erp.png", f"{name}: equivalent radiated power",
                              rom_valid_hz=valid_hz))
    if nvh is not None and nvh.accel_velocity is not None and "accelerometers" in want \
            and len(br) > 0:
        paths.append(accelerometer_plot(br, nvh.accel_names, nvh.accel_velocity, nvh.orders, z,
                                        out / "accelerometers.png",
                                        f"{name}: virtual accelerometers"))
    if result.rom is not None:
        paths += rom_plots(result, want)
    return paths
