"""The ``ltca`` and ``table`` sources of a mesh's stiffness and transmission error
(``[mesh_stiffness] source``, ``[transmission_error] source``; issue 38, docs/gears.md).

Everything here is a function of ONE mesh's tables — its ``mesh_stiffness`` and
``transmission_error`` tables, its ``micro_geometry`` and ``ltca`` tables, its
:class:`gears.GearPair`, torque and the number of mesh harmonics its HBM set uses — so
that the same code serves the pair scenes' top-level sections and each ``[[meshes]]``
table of a train. :func:`mesh_source` checks every field (naming it, before any
computation) and returns a :class:`~study.scene.data.MeshSource`;
:func:`source_series` then solves the LTCA (:func:`solve_cached`: one solve per case and
process) or fits the table, and gives the Fourier series the dynamics use.
"""
from __future__ import annotations

import functools
import logging
import math
from pathlib import Path
from typing import Any

import numpy as np

from core.errors import InputError, show
from gears.excitation import Series
from gears.flank import Flank, Relief
from gears.ltca import LtcaCase, LtcaResult, hunting_series, mesh_series, solve_ltca
from gears.pair import GearPair
from gears.te_table import MeshTable, read_mesh_table, table_series
from gears.tooth import Material
from study.scene.check import check_known, check_table
from study.scene.data import MeshSource
from study.scene.errors import SceneError
from study.scene.schema import SCHEMA

logger = logging.getLogger(__name__)

__all__ = ["uses_other_source", "check_source_keys", "set_mesh_harmonics", "scene_pair",
           "mesh_source", "source_series", "solve_cached"]

#: gears' field names -> the scene keys they come from (for messages)
_FLANK_KEYS = {"tip_relief.amount": "tip_relief_um",
               "tip_relief.start_diameter": "tip_relief_start_diameter_mm",
               "root_relief.amount": "root_relief_um",
               "root_relief.start_diameter": "root_relief_start_diameter_mm",
               "pitch_deviations": "pitch_deviations_um"}
_GEARS = ("gear1", "gear2", "both")


def uses_other_source(ms: dict, te: dict) -> bool:
    """True when either checked table asks for a source other than ``fourier``."""
    return ms["source"] != "fourier" or te["source"] != "fourier"


def set_mesh_harmonics(hbm: dict, teeth: int, external: bool) -> int:
    """Mesh harmonics the HBM set of a checked ``[hbm]`` table reaches: ``mesh_harmonics``,
    or the highest mesh harmonic of an explicit list (indices of the mesh frequency, or of
    the shaft frequency when external orders are present: ⌊max/Z⌋)."""
    hs = hbm["harmonics"]
    if hs is None:
        return int(hbm["mesh_harmonics"])
    top = max(hs) // teeth if external else max(hs)
    return max(int(top), 1)


def scene_pair(gear) -> GearPair:
    """The :class:`gears.GearPair` of a pair scene's ``[gear]`` (1:1). Spur: as
    :meth:`GearData.pair`. Helical: the normal module that gives the scene's base radius
    r_b = z m_n cos α_t / (2 cos β) (the ``module_mm`` check of ``[gear]`` is the spur
    relation)."""
    if gear.helix_angle == 0.0:
        return gear.pair()
    beta, alpha = gear.helix_angle, gear.pressure_angle
    alpha_t = math.atan(math.tan(alpha) / math.cos(beta))
    m_n = 2.0 * gear.base_radius * math.cos(beta) / (gear.teeth * math.cos(alpha_t))
    x = gear.profile_shift
    return GearPair(teeth=(gear.teeth, gear.teeth), module=m_n, pressure_angle=alpha,
                    face_width=gear.face_width, helix_angle=beta, profile_shift=(x, x),
                    addendum_coef=gear.addendum_coef, dedendum_coef=gear.dedendum_coef)


def _ignored_fourier_keys(where: str, d: dict, raw: dict, keys: tuple[str, ...]) -> None:
    """The Fourier keys of a table whose source is ``ltca``/``table`` are ignored, with a
    warning (so ``--set mesh_stiffness.source=ltca`` or an ``extends`` scene can switch a
    Fourier scene without removing its harmonics)."""
    given = [k for k in keys if k in raw]
    if given:
        logger.warning("%s.source = %r: %s ignored (the %s gives the series)", where,
                       d["source"], ", ".join(f"{where}.{k}" for k in given), d["source"])


def check_source_keys(where: str, d: dict, raw: dict, section: str | None = None) -> None:
    """``file`` only with ``table``; the Fourier keys of another source are ignored
    (logged)."""
    if d["source"] == "table" and not d["file"]:
        raise SceneError(f"{where}.file: missing (required with {where}.source = 'table': "
                         "the CSV of the mesh table)")
    if d["source"] != "table" and d["file"]:
        raise SceneError(f"{where}.file = {d['file']!r}: only with {where}.source = 'table' "
                         f"(source is {d['source']!r})")
    if d["source"] != "fourier":
        spec = SCHEMA[section or where.rsplit(".", 1)[-1]]
        fourier = tuple(k for k in spec if k not in ("source", "file", "kind"))
        _ignored_fourier_keys(where, d, raw, fourier)


def _flank(where: str, d: dict, pitch: tuple[float, ...]) -> Flank:
    """A gear's :class:`gears.Flank` from its checked ``micro_geometry`` values (SI)."""
    reliefs = {}
    for end in ("tip", "root"):
        amount, start = d[f"{end}_relief"], d[f"{end}_relief_start_diameter"]
        if amount > 0.0:
            if start is None:
                raise SceneError(f"{where}.{end}_relief_start_diameter_mm: missing (required "
                                 f"with {where}.{end}_relief_um = {amount * 1e6:g})")
            reliefs[f"{end}_relief"] = Relief(amount, start, d[f"{end}_relief_shape"])
    return Flank(**reliefs, crowning=d["crowning"], profile_slope=d["profile_slope"],
                 profile_form=d["profile_form"], lead_slope=d["lead_slope"],
                 pitch_deviations=pitch)


def _flanks(section: str, raw: Any) -> tuple[Flank, Flank]:
    """``[micro_geometry]``: subtables ``gear1``, ``gear2`` and ``both`` (keys of ``both``
    apply to the two gears, a gear's own keys over them)."""
    if raw is None:
        raw = {}
    if not isinstance(raw, dict):
        raise SceneError(f"[{section}] = {show(raw)}: must be a table")
    check_known(raw, _GEARS, lambda key: f"{section}.{key}",
                note=f" (subtables [{section}.gear1], [{section}.gear2], [{section}.both])")
    for key, sub in raw.items():
        if not isinstance(sub, dict):
            raise SceneError(f"{section}.{key} = {show(sub)}: must be a table of micro-"
                             "geometry keys")
    spec = SCHEMA["micro_geometry.gear"]
    check_table(f"{section}.both", raw.get("both", {}), spec)
    out = []
    for gear in ("gear1", "gear2"):
        own = raw.get(gear, {})
        where = f"{section}.{gear}"
        merged = {**raw.get("both", {}), **own}
        d = check_table(where, merged, spec)
        pitch = tuple(d["pitch_deviations"])
        try:
            out.append(_flank(where, d, pitch))
        except InputError as exc:
            if isinstance(exc, SceneError):
                raise
            raise SceneError(f"{where}: {exc}", field=where) from exc
    return out[0], out[1]


def _scene_field(exc: InputError, micro: str, ltca: str) -> str:
    """The scene key a refusal of :class:`gears.LtcaCase` comes from."""
    name = str(exc.field or "")
    if name.startswith("flanks["):
        gear = name[7]
        rest = name.split("].", 1)[1] if "]." in name else ""
        return f"{micro}.gear{gear}.{_FLANK_KEYS.get(rest, rest)}"
    if name.startswith("bore_radii"):
        return f"{ltca}.bore_diameter_mm"
    if name.startswith(("n_positions", "n_slices")):
        return f"{ltca}.{name}"
    return "gear"


def _case(pair: GearPair, torque: float, flanks: tuple[Flank, Flank], lt: dict, micro: str,
          ltca: str, harmonics: int) -> LtcaCase:
    if not torque > 0.0:
        raise SceneError(f"load.torque_Nm = {torque:g}: source = 'ltca' needs a torque > 0 "
                         "(the LTCA is solved at the scene's load)")
    n_pos = lt["n_positions"]
    if n_pos <= 2 * harmonics + 1:
        raise SceneError(f"{ltca}.n_positions = {n_pos}: must be > {2 * harmonics + 1} to "
                         f"resolve the {harmonics} mesh harmonics the HBM set uses "
                         "(hbm.mesh_harmonics or hbm.harmonics)")
    bores = lt["bore_diameter"]
    if bores and len(bores) != 2:
        raise SceneError(f"{ltca}.bore_diameter_mm = {[b * 1e3 for b in bores]}: must be "
                         "[gear 1, gear 2]")
    for i, (d, r_f) in enumerate(zip(bores, pair.root_radii, strict=False), start=1):
        if not d < 2.0 * r_f:
            raise SceneError(f"{ltca}.bore_diameter_mm = {[round(b * 1e3, 6) for b in bores]}: "
                             f"gear {i}'s must be < its root diameter {2e3 * r_f:.4g} mm (the "
                             "body is held inside the teeth)")
    radii = (0.5 * bores[0], 0.5 * bores[1]) if bores else \
        (0.5 * pair.root_radii[0], 0.5 * pair.root_radii[1])
    mat = Material(lt["youngs_modulus"], lt["poisson_ratio"])
    try:
        return LtcaCase(pair, torque, radii, flanks=flanks, materials=(mat, mat),
                        n_positions=n_pos, n_slices=lt["n_slices"])
    except SceneError:
        raise
    except InputError as exc:
        where = _scene_field(exc, micro, ltca)
        raise SceneError(f"{where}: {exc}", field=where, value=exc.value, unit=exc.unit,
                         allowed=exc.allowed) from exc


def _table(where: str, d: dict, quantity: str, pair: GearPair, base: Path | None,
           harmonics: int) -> MeshTable:
    path = Path(d["file"])
    if not path.is_absolute() and base is not None:
        path = base / path
    try:
        table = read_mesh_table(path, teeth=pair.teeth[0], base_pitch=pair.base_pitch)
        if getattr(table, quantity) is None:
            columns = ("te_um or te_m" if quantity == "te" else
                       "stiffness_N_per_um or stiffness_N_per_m")
            raise InputError(f"{path.name}: has no {quantity} column ({columns})",
                             field=quantity)
        table_series(table, quantity, harmonics)          # enough samples per period?
    except InputError as exc:
        raise SceneError(f"{where}.file = {d['file']!r}: {exc}", field=f"{where}.file",
                         value=d["file"]) from exc
    return table


def mesh_source(ms: dict, te: dict, raw_ms: dict, raw_te: dict, micro_raw: Any, lt: dict,
                *, pair: GearPair, torque: float, harmonics: int, base: Path | None = None,
                names: tuple[str, str, str, str] = ("mesh_stiffness", "transmission_error",
                                                    "micro_geometry", "ltca")
                ) -> MeshSource:
    """Check one mesh's ``ltca``/``table`` sources and build its :class:`MeshSource`
    (no LTCA is solved here).

    Parameters
    ----------
    ms, te : dict
        The checked ``mesh_stiffness`` and ``transmission_error`` tables (SI values).
    raw_ms, raw_te : dict
        The same tables as written (to tell given keys from defaults).
    micro_raw : dict or None
        The ``micro_geometry`` table as written (subtables gear1, gear2, both).
    lt : dict
        The checked ``ltca`` table.
    pair : GearPair
        The mesh's macro-geometry.
    torque : float
        Torque on gear 1 (N·m).
    harmonics : int
        Mesh harmonics the HBM set uses: the number kept from the LTCA or table.
    base : Path, optional
        Folder of the scene file (tables are read relative to it).
    names : 4 str
        Section names of the four tables in messages (``meshes[0].ltca`` …).

    Raises
    ------
    SceneError
        Naming the field: micro-geometry that does not fit the gears (relief longer or
        deeper than the addendum/dedendum, pitch deviations not one per tooth or not
        closing), interference or a contact ratio below 1, a torque ≤ 0, too few positions
        for the harmonics, a table not periodic over the mesh period or with fewer samples
        than the harmonics.
    """
    w_ms, w_te, w_micro, w_ltca = names
    check_source_keys(w_ms, ms, raw_ms, "mesh_stiffness")
    check_source_keys(w_te, te, raw_te, "transmission_error")
    uses_ltca = "ltca" in (ms["source"], te["source"])
    if te["source"] == "ltca" and te["kind"] != "loaded":
        raise SceneError(f"{w_te}.kind = {te['kind']!r}: source = 'ltca' gives the loaded "
                         "STE q_s (kind = 'loaded')")
    if not uses_ltca and micro_raw:
        raise SceneError(f"[{w_micro}]: used only with source = 'ltca' (in [{w_ms}] or "
                         f"[{w_te}])")
    case, torques = None, ()
    if uses_ltca:
        flanks = _flanks(w_micro, micro_raw)
        case = _case(pair, torque, flanks, lt, w_micro, w_ltca, harmonics)
        lo, hi = lt["harris_torque"] or (0.2 * torque, 2.0 * torque)
        torques = tuple(float(v) for v in np.linspace(lo, hi, lt["harris_points"]))
    tables = {}
    for where, d, quantity in ((w_ms, ms, "stiffness"), (w_te, te, "te")):
        if d["source"] == "table":
            tables[quantity] = _table(where, d, quantity, pair, base, harmonics)
    return MeshSource(ms["source"], te["source"], harmonics, case, torques, tables,
                      hunting=bool(lt["hunting"]))


@functools.lru_cache(maxsize=64)
def solve_cached(case: LtcaCase) -> LtcaResult:
    """:func:`gears.solve_ltca` once per case and process (the scene's series and the ltca
    stage's outputs share one solve; a variant study reuses the unchanged ones)."""
    return solve_ltca(case)


def source_series(src: MeshSource, quantity: str) -> Series:
    """The (mean, amplitudes, phases) series in SI of ``quantity`` (``"stiffness"`` or
    ``"te"``) from its ``ltca`` or ``table`` source, ``src.harmonics`` mesh harmonics: of
    the mesh period, or with ``src.cycles = c > 1`` harmonics 1 … c·harmonics of the
    hunting period (:func:`gears.hunting_series`)."""
    source = src.stiffness if quantity == "stiffness" else src.te
    if source == "table":
        return table_series(src.tables[quantity], quantity, src.harmonics)
    if source != "ltca" or src.case is None:
        raise ValueError(f"{quantity}: source {source!r} has no series here")
    if src.cycles > 1:
        stiffness, ste, _ = hunting_series(solve_cached(src.case), src.harmonics)
    else:
        stiffness, ste = mesh_series(solve_cached(src.case), src.harmonics)
    return stiffness if quantity == "stiffness" else ste
