"""Physical plausibility of a scene's inputs: a value the schema allows (a positive
number) may still be the wrong unit or a slip of a digit.

Each row of :data:`BOUNDS` names a quantity of the scene (a key as written in the
file, or a ratio of two), the unit it is judged in, the range outside which it is
refused (:class:`~study.scene.errors.SceneError` naming the key and its unit: a
Young's modulus of 210 Pa, a density of 7.2 kg/m³, bearings of 100 N/m, a 0.04 µm
backlash) and the narrower range outside which it is merely unusual (a warning,
logged when the scene loads and written in ``report.md``). The table is documented in
docs/scenes.md ("Plausibility bounds"; a test checks the two agree).

Besides the table: a loaded transmission error (STE, measured under load) with
``load.torque_Nm = 0`` is refused, and an absent section a scene kind needs
(:data:`REQUIRED_SECTIONS`: ``[gear]`` of a gear-pair scene, ...) is an error instead
of a hidden default. The result's own check (the dynamic-to-static deflection ratio,
:func:`dynamic_ratio_warning`) runs after the continuation (study.outputs.checks).

Imports nothing of :mod:`study` but the scene's data and errors (the FE sections are
read from their free tables with :data:`core.units.FE_SUFFIXES`, without the FE stack).
"""
from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from core.units import FE_SUFFIXES, TO_SI
from study.scene.data import Scene
from study.scene.errors import SceneError

logger = logging.getLogger(__name__)

__all__ = ["Bound", "BOUNDS", "LENGTH_FIELDS", "REQUIRED_SECTIONS", "DYNAMIC_RATIO_USUAL",
           "Finding",
           "check_required_sections", "check_plausibility", "plausibility_warnings",
           "dynamic_ratio_warning", "bounds_markdown"]


@dataclass(frozen=True)
class Bound:
    """One plausibility row.

    Attributes
    ----------
    field : str
        What is judged, as the scene names it (``materials.shaft_E``: the key with any
        unit suffix; a ratio ``a / b`` of two keys).
    unit : str
        Unit the bounds are written in (``GPa``, ``N/µm``, ``-``).
    error : (lo, hi)
        Outside ``[lo, hi]`` the scene is refused (None: no bound on that side).
    usual : (lo, hi)
        Outside ``[lo, hi]`` (and inside ``error``) a warning.
    meaning : str
        Why these bounds (docs/scenes.md).
    zero_is_none : bool
        A value 0 means "none" (no rotor, no tail) and is not judged.
    """

    field: str
    unit: str
    error: tuple[float | None, float | None]
    usual: tuple[float | None, float | None]
    meaning: str
    zero_is_none: bool = False


#: Factor from SI to each unit of :data:`BOUNDS` (N/(mm·µm): k [N/m] / b [m] · 1e-9).
_FROM_SI = {"GPa": 1e-9, "kg/m³": 1.0, "-": 1.0, "N/µm": 1e-6, "µm": 1e6, "mm": 1e3,
            "N/(mm·µm)": 1e-9, "N·m/rad": 1.0, "N/mm": 1e-3, "deg": 180.0 / math.pi,
            "kg·m²": 1.0, "kg": 1.0, "kg·m": 1.0}

_E = "Young's modulus; metals 40–450 GPa, polymers and composites from 1 GPa"
_NU = "Poisson's ratio; metals 0.25–0.35"
_RHO = "density; metals 1700–20000 kg/m³, polymers from 900 kg/m³"
_BEAR = "rolling-bearing stiffness; ball and roller bearings 10–5000 N/µm"
_LEN = ("; 0: none, not judged. A length in m under a plain key (8 for 8 mm) or in m "
        "under a `_mm` key (0.008) is refused")
_J = ("polar inertia of a rotating part; 1e-7 kg·m² (a 20 mm steel gear) to 100 kg·m² "
      "(a 200 kg wheel of 1 m diameter)")
_MASS = "mass of a lumped part; 1 g to 1 t"
_ZERO_NONE = "; 0: none, not judged"

#: The plausibility table (docs/scenes.md, "Plausibility bounds").
BOUNDS: tuple[Bound, ...] = (
    Bound("gear.backlash", "µm", (1.0, None), (5.0, 500.0),
          "half backlash b; 0.03–0.1 module in practice (b = 40 µm on module 1.3 mm)"),
    Bound("gear.module", "mm", (0.05, 100.0), (0.3, 50.0), "module m of the pair"),
    Bound("gear.pressure_angle", "deg", (None, None), (14.5, 30.0),
          "normal pressure angle α; 20° is the standard"),
    Bound("gear.face_width / gear.module", "-", (0.5, 200.0), (3.0, 40.0),
          "face width over module b_f/m; spur gears 6–30"),
    Bound("mesh_stiffness.mean", "N/µm", (1.0, 1e5), (None, None),
          "mean mesh stiffness k̄_m"),
    Bound("mesh_stiffness.mean / gear.face_width", "N/(mm·µm)", (0.2, 300.0), (4.0, 30.0),
          "k̄_m per face width; ISO 6336-1 c_γ ≈ 20 N/(mm·µm) for steel spur gears"),
    Bound("load.torque / gear.face_width", "N/mm", (None, 20000.0), (None, 2000.0),
          "line load F_s/b_f of the static mesh force (torque / r_b / b_f)"),
    Bound("load.torque / mesh_stiffness.mean", "µm", (None, 1000.0), (None, 100.0),
          "static mesh deflection F_s/k̄_m"),
    Bound("damping.modal_ratio", "-", (None, None), (0.002, 0.15),
          "modal damping ratio ξ; gearboxes 0.01–0.1"),
    Bound("lumped.density", "kg/m³", (100.0, 25000.0), (900.0, 20000.0), _RHO),
    Bound("materials.shaft_E", "GPa", (0.1, 1500.0), (1.0, 450.0), _E),
    Bound("materials.housing_E", "GPa", (0.1, 1500.0), (1.0, 450.0), _E),
    Bound("materials.shaft_nu", "-", (0.0, 0.5), (0.2, 0.45), _NU),
    Bound("materials.housing_nu", "-", (0.0, 0.5), (0.2, 0.45), _NU),
    Bound("materials.shaft_rho", "kg/m³", (100.0, 25000.0), (900.0, 20000.0), _RHO),
    Bound("materials.housing_rho", "kg/m³", (100.0, 25000.0), (900.0, 20000.0), _RHO),
    Bound("bearings.radial", "N/µm", (0.1, 1e6), (10.0, 5000.0), _BEAR),
    Bound("bearings.axial", "N/µm", (0.01, 1e6), (1.0, 5000.0), _BEAR),
    Bound("drive.motor_torsional_stiffness", "N·m/rad", (1.0, 1e9), (100.0, 1e8),
          "motor coupling; elastomer couplings from 100 N·m/rad"),
    Bound("drive.impeller_inertia", "kg·m²", (None, 1e4), (None, 100.0),
          "driven inertia on the output coupling"),
    Bound("rotors.lateral_stiffness", "N/µm", (0.1, 1e6), (10.0, 1e4),
          "radial spring beside each gear (0: none, not judged)", zero_is_none=True),
    Bound("rotors.torsional_stiffness", "N·m/rad", (1.0, 1e10), (100.0, 1e9),
          "rotor neck (0: no rotor, not judged)", zero_is_none=True),
    # geometry dimensions
    Bound("geometry.*", "mm", (0.01, 5000.0), (0.5, 2000.0),
          "every length of the pump's [geometry] and of its tables [geometry.housing], "
          "[geometry.shaft_in], [geometry.shaft_out] (radii, lengths, walls, feet, ribs, "
          "clearance)" + _LEN, zero_is_none=True),
    Bound("housing.*", "mm", (0.01, 5000.0), (0.5, 2000.0),
          "every length of a gearbox's parametric [housing] (walls, clearance, bosses, "
          "bearing section and width, feet, ribs)" + _LEN, zero_is_none=True),
    Bound("shafts.diameter", "mm", (0.5, 5000.0), (3.0, 1000.0),
          "shaft diameter of a train or gearbox [[shafts]]"),
    Bound("shafts.length", "mm", (1.0, 20000.0), (10.0, 5000.0),
          "shaft length of a gearbox [[shafts]]"),
    Bound("gears.module", "mm", (0.05, 100.0), (0.3, 50.0), "normal module of a [[gears]]"),
    Bound("gears.face_width / gears.module", "-", (0.5, 200.0), (3.0, 40.0),
          "face width over module b_f/m of a [[gears]]; spur gears 6–30"),
    Bound("shafts.bearings.radial", "N/µm", (0.1, 1e6), (10.0, 5000.0), _BEAR),
    Bound("shafts.bearings.axial", "N/µm", (0.01, 1e6), (1.0, 5000.0), _BEAR),
    # rotor inertias and lumped masses
    Bound("lumped.inertia", "kg·m²", (None, 1e4), (1e-7, 100.0), _J),
    Bound("lumped.equivalent_mass", "kg", (None, 1e5), (1e-3, 1e3), _MASS),
    Bound("rotors.inertia", "kg·m²", (None, 1e4), (1e-7, 100.0), _J + _ZERO_NONE,
          zero_is_none=True),
    Bound("rotors.gear_inertia", "kg·m²", (None, 1e4), (1e-7, 100.0), _J + _ZERO_NONE,
          zero_is_none=True),
    Bound("rotors.rim_inertia", "kg·m²", (None, 1e4), (1e-7, 100.0), _J + _ZERO_NONE,
          zero_is_none=True),
    Bound("rotors.gear_mass", "kg", (None, 1e5), (1e-3, 1e3), _MASS + _ZERO_NONE,
          zero_is_none=True),
    Bound("rotors.rim_mass", "kg", (None, 1e5), (1e-3, 1e3), _MASS + _ZERO_NONE,
          zero_is_none=True),
    Bound("drive.impeller_mass", "kg", (None, 1e5), (1e-3, 1e3), _MASS + _ZERO_NONE,
          zero_is_none=True),
    Bound("shafts.inertia", "kg·m²", (None, 1e4), (1e-7, 100.0), _J + _ZERO_NONE,
          zero_is_none=True),
    Bound("gears.inertia", "kg·m²", (None, 1e4), (1e-7, 100.0), _J),
    Bound("gears.mass", "kg", (None, 1e5), (1e-3, 1e3), _MASS),
    Bound("drive.motor_inertia", "kg·m²", (None, 1e4), (1e-7, 100.0), _J),
    Bound("loads.inertia", "kg·m²", (None, 1e4), (1e-7, 100.0), _J),
    # unbalance
    Bound("external.unbalance.m_unb", "kg·m", (None, 1.0), (1e-7, 1e-2),
          "mass unbalance m·e; ISO 21940-11 (G 0.4 – G 40): 1e-6 kg·m (1 g·mm) on a small "
          "rotor to 1e-2 kg·m on a 100 kg one (the pump: 3e-5 kg·m = 30 g·mm)"),
)

#: Largest usual ratio of the peak mesh load to the static one (≈ peak deflection over
#: the static deflection): beyond it the teeth would be loaded far past anything they
#: are designed for (the result is a warning in report.md, docs/scenes.md).
DYNAMIC_RATIO_USUAL = 10.0

#: Sections a scene kind must give (no hidden default for them).
REQUIRED_SECTIONS: dict[str, tuple[str, ...]] = {
    "lumped": ("gear", "mesh_stiffness", "load", "continuation"),
    "fe": ("gear", "mesh_stiffness", "load", "continuation", "materials", "bearings"),
    "train": ("continuation",),     # [[shafts]], [[gears]], [[meshes]], [drive]: its loader
}

#: Rows judged per [[meshes]] entry of a gear train (their pair rows are not: a train has
#: no [gear], [mesh_stiffness], [load]): row field -> (key in the mesh, getter).
_MESH_ROWS: dict[str, tuple[str, Callable[[Any], float | None]]] = {
    "gear.backlash": ("backlash_um", lambda m: m.backlash),
    "mesh_stiffness.mean": ("mesh_stiffness.mean_N_per_um",
                            lambda m: None if m.mesh_stiffness is None else m.mesh_stiffness.mean),
}

_SCENE_FIELDS: dict[str, Callable[[Scene], float | None]] = {
    "gear.backlash": lambda s: s.gear.backlash,
    "gear.module": lambda s: s.gear.module,
    "gear.pressure_angle": lambda s: s.gear.pressure_angle,
    "gear.face_width": lambda s: s.gear.face_width,
    "mesh_stiffness.mean": lambda s: s.mesh_stiffness.mean,
    "load.torque": lambda s: s.static_load,   # judged as the mesh force F_s = T / r_b
    "damping.modal_ratio": lambda s: s.damping.modal_ratio,
    "lumped.density": lambda s: s.lumped.density if s.scene.kind == "lumped" else None,
}
# the key of each scene field as written in a file (unit suffix)
_SCENE_KEYS = {"gear.backlash": "gear.backlash_um", "gear.module": "gear.module_mm",
               "gear.pressure_angle": "gear.pressure_angle_deg",
               "gear.face_width": "gear.face_width_mm",
               "mesh_stiffness.mean": "mesh_stiffness.mean_N_per_um",
               "load.torque": "load.torque_Nm", "damping.modal_ratio": "damping.modal_ratio",
               "lumped.density": "lumped.density_kg_per_m3"}


@dataclass(frozen=True)
class Finding:
    """A value outside a row's usual or error range."""

    bound: Bound
    key: str
    value: float
    fatal: bool
    written: float | None = None

    @property
    def text(self) -> str:
        """``key = value unit: ...`` (the value as written first when its unit differs)."""
        b = self.bound
        rng = b.error if self.fatal else b.usual
        what = "outside the plausible range" if self.fatal else "unusual: outside"
        val = f"{self.value:.4g} {b.unit}"
        if self.written is not None and not math.isclose(self.written, self.value):
            val = f"{self.written:g} ({val})"
        return (f"{self.key} = {val}: {what} {_range(rng, b.unit)} ({b.meaning})"
                + ("; is the unit right?" if self.fatal else ""))


def _range(rng: tuple[float | None, float | None], unit: str) -> str:
    lo, hi = rng
    if lo is not None and hi is not None:
        return f"[{lo:g}, {hi:g}] {unit}"
    return f">= {lo:g} {unit}" if lo is not None else f"<= {hi:g} {unit}"


def _fe_value(section: str, table: Any, name: str) -> tuple[str, float, float] | None:
    """(key as written, SI value, value as written) of FE field ``name`` in a free FE
    table (the field name in SI, or with a unit suffix of :data:`core.units.FE_SUFFIXES`);
    None when absent or not a number (the FE parameter check refuses that)."""
    if not isinstance(table, dict):
        return None
    for suf in ("", *FE_SUFFIXES):
        key = f"{name}_{suf}" if suf else name
        v = table.get(key)
        if isinstance(v, (int, float)) and not isinstance(v, bool):
            return f"{section}.{key}", float(v) * TO_SI[suf], float(v)
    return None


_SHAFT_LENGTHS = ("coupling_radius", "coupling_length", "journal_radius", "journal_length",
                  "body_radius", "span_a", "hub_radius", "hub_length", "span_b",
                  "tail_radius", "tail_length", "station_width", "rotor_radius", "rotor_gap")
#: The lengths judged by the ``geometry.*`` row (pump: :class:`geometry.PumpParams` and
#: the tables of its :class:`geometry.HousingParams` and :class:`geometry.ShaftParams`) and
#: by the ``housing.*`` row (gearbox: :class:`geometry.GearboxHousingParams` and
#: ``HousingOptions.bearing_width``); a test checks them against the dataclasses.
LENGTH_FIELDS: dict[str, tuple[str, ...]] = {
    "geometry": ("centre_distance", "gear_z", "gear_tip_radius", "gear_width",
                 "min_clearance"),
    "geometry.housing": ("length_x", "height_y", "length_z", "wall_thickness", "boss_radius",
                         "boss_length", "bore_radius", "foot_width", "foot_depth",
                         "foot_height", "foot_overhang", "rib_thickness", "rib_height"),
    "geometry.shaft_in": _SHAFT_LENGTHS,
    "geometry.shaft_out": _SHAFT_LENGTHS,
    "housing": ("wall_thickness", "clearance", "boss_length", "boss_thickness",
                "bearing_section", "foot_width", "foot_depth", "foot_height",
                "foot_overhang", "rib_thickness", "rib_height", "bearing_width"),
}
#: Scene kinds with free FE tables (study.scene.schema FE_SECTIONS, GEARBOX_SECTIONS).
_FE_KINDS = ("fe", "gearbox")


def _entries(scene: Scene, field: str) -> list[tuple[str, float]] | None:
    """(key as written, SI value) of every entry of a train table, of ``[lumped]``
    inertias or ``[[external.unbalance]]`` that ``field`` names; None when ``field`` is
    not one of them."""
    sh, gs = scene.shafts, scene.gears
    d = scene.drive
    get: dict[str, Callable[[], list]] = {
        "shafts.diameter": lambda: [(f"shafts[{i}].diameter_mm", x.diameter)
                                    for i, x in enumerate(sh)],
        "shafts.length": lambda: [(f"shafts[{i}].length_mm", x.length)
                                  for i, x in enumerate(sh)],
        "shafts.inertia": lambda: [(f"shafts[{i}].inertia_kgm2", x.inertia)
                                   for i, x in enumerate(sh)],
        "shafts.bearings.radial": lambda: [
            (f"shafts[{i}].bearings[{j}].radial_N_per_um", b.radial)
            for i, x in enumerate(sh) for j, b in enumerate(x.bearings)],
        "shafts.bearings.axial": lambda: [
            (f"shafts[{i}].bearings[{j}].axial_N_per_um", b.axial)
            for i, x in enumerate(sh) for j, b in enumerate(x.bearings)],
        "gears.module": lambda: [(f"gears[{i}].module_mm", g.module) for i, g in enumerate(gs)],
        "gears.face_width": lambda: [(f"gears[{i}].face_width_mm", g.face_width)
                                     for i, g in enumerate(gs)],
        "gears.inertia": lambda: [(f"gears[{i}].inertia_kgm2", g.inertia)
                                  for i, g in enumerate(gs)],
        "gears.mass": lambda: [(f"gears[{i}].mass_kg", g.mass) for i, g in enumerate(gs)],
        "drive.motor_inertia": lambda: [] if d is None else
        [("drive.motor_inertia_kgm2", d.motor_inertia)],
        "loads.inertia": lambda: [(f"loads[{i}].inertia_kgm2", x.inertia)
                                  for i, x in enumerate(scene.loads)],
        "lumped.inertia": lambda: [(f"lumped.inertia_kgm2[{i}]", v)
                                   for i, v in enumerate(scene.lumped.inertia or ())],
        "lumped.equivalent_mass": lambda: [("lumped.equivalent_mass_kg",
                                            scene.lumped.equivalent_mass)],
        "external.unbalance.m_unb": lambda: [
            (f"external.unbalance[{i}].m_unb_kgm", u.m_unb)
            for i, u in enumerate(scene.external.unbalance)],
    }
    if field not in get:
        return None
    return [(k, float(v)) for k, v in get[field]() if v is not None]


def _written(key: str, si: float) -> float:
    """``si`` in the unit of ``key``'s suffix (``_mm``, ``_kgm2``, ...; none: SI)."""
    base = key.split("[")[0] if key.endswith("]") else key
    suffix = next((s for s in sorted(TO_SI, key=len, reverse=True)
                   if s and base.endswith("_" + s)), "")
    return si / TO_SI[suffix]


def _values(scene: Scene, field: str) -> list[tuple[str, float, float]]:
    """(key as written, SI value, value as written) of every instance of one side of a
    row (one for a scene value or an FE key, one per entry of a table), [] when not given
    or not applicable."""
    if field in _SCENE_FIELDS:
        v = _SCENE_FIELDS[field](scene)
        if v is None:
            return []
        key = _SCENE_KEYS[field]
        return [(key, float(v), _written(key, float(v)))]
    entries = _entries(scene, field)
    if entries is not None:
        return [(k, v, _written(k, v)) for k, v in entries]
    if scene.scene.kind not in _FE_KINDS:
        return []
    section, name = field.split(".", 1)
    if name == "*":           # every length of the section and its tables
        out = []
        for path, names in LENGTH_FIELDS.items():
            head, *sub = path.split(".")
            if head != section or (section == "geometry") != (scene.scene.kind == "fe"):
                continue
            table = scene.fe.get(head)
            for t in sub:
                table = table.get(t) if isinstance(table, dict) else None
            out += [v for n in names if (v := _fe_value(path, table, n)) is not None]
        return out
    v = _fe_value(section, scene.fe.get(section), name)
    return [] if v is None else [v]


def _judge(scene: Scene, b: Bound) -> list[Finding]:
    """The findings of one row: per instance of its field, or per entry of a ratio
    (a ratio of a table's entries pairs them entry by entry)."""
    parts = [p.strip() for p in b.field.split("/")]
    if len(parts) == 1:
        rows = [(k, si, w) for k, si, w in _values(scene, parts[0])]
    else:
        num, den = (_values(scene, p) for p in parts)
        if not num or not den:
            return []
        if len(den) == 1:
            den = den * len(num)
        rows = [(f"{a[0]} / {c[0]}", a[1] / c[1], None)
                for a, c in zip(num, den, strict=True)]
    out = []
    for key, si, written in rows:
        if b.zero_is_none and si == 0.0:
            continue
        f = _judge_value(b, key, si, written)
        if f is not None:
            out.append(f)
    return out


def check_required_sections(raw: dict, kind: str) -> None:
    """Refuse a scene of ``kind`` that lacks a section of :data:`REQUIRED_SECTIONS`."""
    for sec in REQUIRED_SECTIONS.get(kind, ()):
        if sec not in raw:
            raise SceneError(f"[{sec}]: missing (required for scene.kind = {kind!r}; "
                             "no default is assumed, docs/scenes.md)", field=sec)


def _judge_value(b: Bound, key: str, si: float, written: float | None) -> Finding | None:
    x = si * _FROM_SI[b.unit]
    for rng, fatal in ((b.error, True), (b.usual, False)):
        lo, hi = rng
        if (lo is not None and x < lo) or (hi is not None and x > hi):
            return Finding(b, key, x, fatal, written)
    return None


def _findings(scene: Scene) -> list[Finding]:
    if not getattr(scene, "is_train", False):
        return [f for b in BOUNDS for f in _judge(scene, b)]
    # a train: the rows of its own sections (FE, damping, its tables), then each mesh's
    own = [b for b in BOUNDS if b.field.split(".")[0] not in ("gear", "mesh_stiffness", "load",
                                                              "lumped")]
    out = [f for b in own for f in _judge(scene, b)]
    rows = {b.field: b for b in BOUNDS}
    for i, m in enumerate(scene.meshes):
        for field, (key, get) in _MESH_ROWS.items():
            v = get(m)
            if v is not None:
                b = rows[field]
                f = _judge_value(b, f"meshes[{i}].{key}", float(v),
                                 float(v) * _FROM_SI[b.unit])
                if f is not None:
                    out.append(f)
    return out


def check_plausibility(scene: Scene) -> Scene:
    """Refuse physically implausible values (:data:`BOUNDS`, the loaded TE without
    torque) with a :class:`SceneError` naming the key and its unit; log the unusual ones
    as warnings. Returns ``scene``."""
    te = scene.transmission_error
    if getattr(scene, "is_train", False):
        _check_train_torque(scene)
    elif te.kind == "loaded" and scene.load.torque == 0.0 and \
            (te.mean != 0.0 or any(a != 0.0 for a in te.amplitudes)):
        raise SceneError("load.torque_Nm = 0 (N·m) with transmission_error.kind = 'loaded': a "
                         "loaded STE is the error under the static load; give the torque it "
                         "was computed at, or kind = 'unloaded' for a geometric error",
                         field="load.torque_Nm", value=0.0, unit="N·m", allowed="> 0")
    found = _findings(scene)
    for f in found:
        if f.fatal:
            raise SceneError(f.text, field=f.key, value=f.value, unit=f.bound.unit,
                             allowed=_range(f.bound.error, f.bound.unit))
    for text in plausibility_warnings(scene):
        logger.warning("%s", text)
    return scene


def _check_train_torque(scene: Scene) -> None:
    """A train's loaded TE needs the drive torque."""
    if scene.drive is None or scene.drive.torque != 0.0:
        return
    for i, m in enumerate(scene.meshes):
        te = m.transmission_error
        if te is not None and te.kind == "loaded" and \
                (te.mean != 0.0 or any(a != 0.0 for a in te.amplitudes)):
            raise SceneError(f"drive.torque_Nm = 0 (N·m) with meshes[{i}].transmission_error"
                             ".kind = 'loaded': a loaded STE is the error under the static "
                             "load; give the torque, or kind = 'unloaded'",
                             field="drive.torque_Nm", value=0.0, unit="N·m", allowed="> 0")


def plausibility_warnings(scene: Scene) -> list[str]:
    """The unusual inputs of a (valid) scene, one sentence each (report.md lists them)."""
    out = [f.text for f in _findings(scene) if not f.fatal]
    te, ms = scene.transmission_error, scene.mesh_stiffness
    if getattr(scene, "is_train", False):
        return out
    if te.kind == "loaded" and scene.load.torque > 0 and te.mean != 0.0 and ms.mean > 0:
        static = scene.static_load / ms.mean
        if not static / 3.0 <= te.mean <= 3.0 * static:
            out.append(f"transmission_error.mean_um = {te.mean * 1e6:.4g} µm: unusual for a "
                       f"loaded STE whose static deflection F_s/k̄_m is {static * 1e6:.4g} µm "
                       "(outside a factor 3 of it)")
    return out


def dynamic_ratio_warning(peak_load: float, static_load: float, rpm: float) -> str | None:
    """The result's post-check: a warning when the peak mesh load exceeds
    :data:`DYNAMIC_RATIO_USUAL` times the static one (None otherwise, or without a static
    load)."""
    if static_load <= 0 or not math.isfinite(peak_load):
        return None
    r = peak_load / static_load
    if r <= DYNAMIC_RATIO_USUAL:
        return None
    return (f"dynamic-to-static deflection ratio {r:.3g} (peak mesh load {peak_load:.4g} N at "
            f"{rpm:.1f} rpm on a static load of {static_load:.4g} N): above "
            f"{DYNAMIC_RATIO_USUAL:g}, far past what teeth carry; check the backlash, damping "
            "and excitation amplitudes (the contact model is linear elastic)")


def bounds_markdown() -> str:
    """The table of :data:`BOUNDS` as docs/scenes.md shows it."""
    def rng(r):
        lo, hi = r
        return f"{'–' if lo is None else f'{lo:g}'} … {'–' if hi is None else f'{hi:g}'}"
    lines = ["| quantity | unit | error outside | warning outside | meaning |",
             "|---|---|---|---|---|"]
    lines += [f"| `{b.field}` | {b.unit} | {rng(b.error)} | {rng(b.usual)} | {b.meaning} |"
              for b in BOUNDS]
    return "\n".join(lines)
