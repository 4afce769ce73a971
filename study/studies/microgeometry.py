"""``geardyn microgeometry``: one micro-geometry (or LTCA) parameter varied over a list of
values on a scene whose mesh excitation comes from the LTCA (issue 38 item 4) — a
one-pair scene, or the mesh of a train the key names (``meshes.<name>.…`` or
``meshes[i].…``) —, and what it does to the vibro-impact map of that mesh: per value
the loaded STE's peak-to-peak and mean stiffness, the mesh-load std over the speed
range, the grazing speeds and impact ranges, and (FE scenes) the housing's equivalent
radiated power.

Each value is one run of the pipeline (:func:`study.pipeline.stages.run_scene`) in
``OUT/<key>=<value>/``, sharing one stage cache: only the ltca and hbm stages rerun (the
ROM of an FE scene does not depend on the micro-geometry). The study writes
``OUT/microgeometry.md`` (table), ``OUT/microgeometry.csv`` and ``OUT/microgeometry.png``
(forced responses overlaid, STE fluctuation and mesh-load std against the value, the
ERP against speed for FE scenes).
"""
from __future__ import annotations

import csv
import io
import logging
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from core.files import atomic_write
from study.outputs.curves import contact_intervals
from study.pipeline.runs import SolverError
from study.pipeline.stages import run_scene
from study.plots.mesh_excitation import parameter_study_plot
from study.scene.errors import SceneError
from study.scene.load import load_scene
from study.scene.overrides import entry_index

logger = logging.getLogger(__name__)

__all__ = ["MicroVariant", "run_microgeometry", "microgeometry_rows", "write_microgeometry",
           "studied_mesh"]


@dataclass
class MicroVariant:
    """One value of the varied key and its run (``result`` None when it failed); ``mesh``
    the train mesh studied (empty for a one-pair scene) and ``element`` its index."""

    value: Any
    result: Any
    mesh: str = ""
    element: int = 0

    @property
    def excitation(self) -> Any:
        """The studied mesh's :class:`~study.outputs.mesh_excitation.MeshExcitation`."""
        r = self.result
        if r is None:
            return None
        return r.train_excitations.get(self.mesh) if self.mesh else r.mesh_excitation


def studied_mesh(scene: Any, key: str) -> tuple[str, int, Any]:
    """(mesh name, element index, its ``MeshSource``) that ``key`` varies: the one-pair
    scene's mesh (``""``, 0), or the train mesh the key names (``meshes.<name>.…`` or
    ``meshes[i].…``)."""
    if not scene.meshes:
        return "", 0, scene.mesh_source
    names = [m.name for m in scene.meshes]
    i = entry_index(key, "meshes", names)
    if i is None:
        raise SceneError(f"--set {key}: a train's micro-geometry study varies a key of one "
                         f"mesh: meshes.<name>.… or meshes[i].… (its meshes: "
                         f"{', '.join(map(repr, names))})")
    return names[i], i, scene.meshes[i].source


def _folder(key: str, value: Any) -> str:
    return re.sub(r"[^\w.=+-]+", "-", f"{key.split('.')[-1]}={value}").strip("-")


def run_microgeometry(scene_path: str | Path, out: str | Path, key: str, values: list,
                      overrides: dict | None = None, **run_kwargs) -> list[MicroVariant]:
    """Run the scene once per value of ``key`` (a scene key, ``section.key``, e.g.
    ``micro_geometry.both.tip_relief_um``), every variant validated before any run.

    Raises
    ------
    SceneError
        Fewer than two values, a scene whose k_m and TE both come from ``fourier`` (the
        micro-geometry would change nothing), or any invalid variant (naming the field).
    """
    if len(values) < 2:
        raise SceneError(f"--set {key}: give at least two values to compare")
    base = dict(overrides or {})
    scenes = [load_scene(scene_path, {**base, key: v}) for v in values]
    mesh, element, src = studied_mesh(scenes[0], key)
    if src is None or not src.uses_ltca:
        where = f"mesh {mesh!r}'s" if mesh else "the scene's"
        raise SceneError(f"microgeometry: {where} mesh_stiffness and transmission_error "
                         "do not come from the LTCA (set source = 'ltca' in one of them)")
    out = Path(out)
    variants = []
    for v, sc in zip(values, scenes, strict=True):
        logger.info("microgeometry: %s = %s", key, v)
        try:
            r = run_scene(sc, out / _folder(key, v), **run_kwargs)
            variants.append(MicroVariant(v, r, mesh, element))
        except SolverError as exc:
            logger.error("microgeometry: %s = %s: %s", key, v, exc)
            keep = exc.result if (exc.result is not None and exc.result.branch is not None
                                  and len(exc.result.branch) > 1) else None
            variants.append(MicroVariant(v, keep, mesh, element))
    return variants


def microgeometry_rows(variants: list[MicroVariant]) -> list[dict[str, Any]]:
    """One record per value: STE and k_m of the LTCA, mesh-load std (largest, at rpm,
    mean over the points), grazing speeds, impact ranges, largest total ERP (FE)."""
    rows = []
    for var in variants:
        r = var.result
        row: dict[str, Any] = {"value": var.value}
        if r is None:
            rows.append({**row, "status": "failed"})
            continue
        data = var.excitation
        if data is not None and data.has_ltca:
            row["ste_peak_to_peak_um"] = float(np.ptp(data.mesh_cycle("ste"))) * 1e6
            row["stiffness_mean_N_per_um"] = float(data.arrays["stiffness"].mean()) * 1e-6
        br = r.branch
        cur = br.element(var.element)
        std = cur.mesh_load_std
        i = int(np.argmax(std))
        row.update(max_std_N=float(std[i]), at_rpm=float(br.rpm[i]),
                   mean_std_N=float(np.mean(std)),
                   grazing_rpm=[round(float(g.rpm), 1)
                                for g in sorted(cur.grazing, key=lambda g: g.rpm)],
                   impacts="; ".join(f"{'SS' if c == 1 else 'DS'} {a:.0f}–{b:.0f}"
                                     for c, ivs in contact_intervals(br, var.element).items()
                                     for a, b in ivs) or "none",
                   status=br.status)
        nvh = getattr(r, "nvh", None)
        if nvh is not None and nvh.erp is not None and len(br):
            j = int(np.argmax(nvh.erp_total_db))
            row.update(max_erp_dB=float(nvh.erp_total_db[j]), erp_at_rpm=float(br.rpm[j]))
        rows.append(row)
    return rows


def _fmt(v: Any) -> str:
    if isinstance(v, float):
        return f"{v:.4g}"
    if isinstance(v, list):
        return ", ".join(f"{x:g}" for x in v) or "–"
    return str(v)


_COLUMNS = {"value": "value", "ste_peak_to_peak_um": "STE p-p (µm)",
            "stiffness_mean_N_per_um": "k̄_m (N/µm)", "max_std_N": "max std (N)",
            "at_rpm": "at rpm", "mean_std_N": "mean std (N)", "grazing_rpm": "grazing (rpm)",
            "impacts": "impacts (rpm)", "max_erp_dB": "max ERP (dB re 1 pW)",
            "erp_at_rpm": "ERP at rpm", "status": "status"}


def write_microgeometry(out: str | Path, key: str, variants: list[MicroVariant]
                        ) -> tuple[Path, Path, Path]:
    """``microgeometry.md`` (table), ``microgeometry.csv`` and ``microgeometry.png``."""
    out = Path(out)
    rows = microgeometry_rows(variants)
    cols = [c for c in _COLUMNS if any(c in r for r in rows)]
    lines = [f"# Micro-geometry study: `{key}`", "",
             "Per value: the LTCA's loaded STE peak-to-peak over the mesh period and mean "
             "mesh stiffness at the scene's torque; along the speed range the std of the "
             "dynamic mesh load (largest, where, mean over the points), the grazing "
             "speeds and impact ranges (SS single-, DS double-sided)"
             + ("; the largest total ERP of the housing" if "max_erp_dB" in cols else "")
             + ".", "",
             "| " + " | ".join(_COLUMNS[c] for c in cols) + " |",
             "|" + "---|" * len(cols)]
    lines += ["| " + " | ".join(_fmt(r.get(c, "–")) for c in cols) + " |" for r in rows]
    lines += ["", "![microgeometry](microgeometry.png)", ""]
    md = out / "microgeometry.md"
    with atomic_write(md, "w") as f:
        f.write("\n".join(lines))
    buf = io.StringIO()
    w = csv.writer(buf)
    w.writerow(cols)
    for r in rows:
        w.writerow([";".join(str(x) for x in r[c]) if isinstance(r.get(c), list)
                    else r.get(c, "") for c in cols])
    path_csv = out / "microgeometry.csv"
    with atomic_write(path_csv, "w") as f:
        f.write(buf.getvalue())
    ok = [v for v in variants if v.result is not None]
    png = parameter_study_plot(
        [v.value for v in ok], [v.result.branch for v in ok], [v.excitation for v in ok],
        [getattr(v.result, "nvh", None) for v in ok], key, out / "microgeometry.png",
        element=ok[0].element if ok else 0)
    logger.info("wrote %s, %s and %s", md, path_csv, png)
    return md, path_csv, png
