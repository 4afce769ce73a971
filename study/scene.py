"""Scene files: the TOML schema, its validation and the conversion to SI units.

A scene describes one machine and its operating range. Files use engineering
units, carried by each key's suffix (``backlash_um``, ``speed_rpm``,
``torque_Nm``, ``face_width_mm``, ``youngs_modulus_GPa``); :func:`load_scene`
converts everything to SI (m, kg, s, N, rad, Pa) and returns a frozen
:class:`Scene` of dataclasses whose attribute names drop the unit suffix.

Every field is checked before any heavy work: unknown keys (with a "did you
mean" suggestion), wrong types, values out of range, reversed speed ranges,
harmonic sets without 0 and inconsistent gear data all raise
:class:`SceneError`, a :class:`ValueError` whose message names the field, its
value and what is allowed. The schema is documented in ``docs/scenes.md``.
"""
from __future__ import annotations

import copy
import dataclasses
import difflib
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from study.errors import SceneError, StageUnavailable
from study.fe_params import fe_parameters
from study.units import TO_SI

__all__ = [
    "SceneError", "Scene", "SceneInfo", "GearData", "MeshStiffness", "TransmissionError",
    "LoadData", "AeroLoad", "Unbalance", "ExternalData", "DampingData", "LumpedData",
    "RomData", "HbmData", "ContinuationData", "OutputsData", "AcousticsData", "Accelerometer",
    "load_scene",
    "parse_scene",
    "scene_from_dict", "apply_overrides", "SCHEMA", "FE_SECTIONS", "PLOT_NAMES",
]


# --------------------------------------------------------------------------- schema


@dataclass(frozen=True)
class Spec:
    """One scene field: type, default, allowed range, unit and documentation.

    ``kind`` is one of ``float``, ``int``, ``bool``, ``str``, ``choice``, ``floats``
    (list of floats), ``ints`` (list of ints), ``vec3`` (3 floats), ``pair`` (2
    increasing floats) or ``table`` (free table, validated by the stage that uses it).
    """

    kind: str
    default: Any = None
    unit: str = ""
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False
    choices: tuple = ()
    doc: str = ""
    required: bool = False

    def range_text(self) -> str:
        if self.kind == "choice":
            return "one of " + ", ".join(repr(c) for c in self.choices)
        parts = []
        if self.lo is not None:
            parts.append(("> " if self.lo_open else ">= ") + f"{self.lo:g}")
        if self.hi is not None:
            parts.append(("< " if self.hi_open else "<= ") + f"{self.hi:g}")
        return " and ".join(parts) if parts else "any"


def _f(default=None, unit="", lo=None, hi=None, lo_open=False, hi_open=False, doc="",
       kind="float", required=False):
    return Spec(kind, default, unit, lo, hi, lo_open, hi_open, (), doc, required)


def _c(default, choices, doc=""):
    return Spec("choice", default, "", None, None, False, False, tuple(choices), doc)


PLOT_NAMES = ("forced_response", "time_series", "spectrum", "campbell", "rom_error", "housing",
              "order_maps", "erp", "accelerometers")
FE_SECTIONS = ("geometry", "mesh", "materials", "bearings", "drive")

#: The whole schema: section -> key (as written in the file) -> Spec. Array-of-tables
#: sections (``external.aero``, ``external.unbalance``) have their own entries.
SCHEMA: dict[str, dict[str, Spec]] = {
    "scene": {
        "name": Spec("str", None, doc="scene name (default: the file stem)"),
        "kind": _c("lumped", ("lumped", "fe"), "`lumped`: single-DOF gear pair, no FE; "
                   "`fe`: geometry → FE → ROM"),
        "description": Spec("str", "", doc="free text"),
    },
    "gear": {
        "teeth": _f(76, lo=5, hi=1000, kind="int",
                    doc="number of teeth Z of each gear (ratio 1:1)"),
        "base_radius_mm": _f(46.984, "mm", 0, 10_000, lo_open=True, doc="base radius r_b"),
        "module_mm": _f(None, "mm", 0, 1000, lo_open=True,
                        doc="module; if given, must agree with 2 r_b/(Z cos α) to 1 %"),
        "pressure_angle_deg": _f(20.0, "deg", 5, 45, doc="normal pressure angle α"),
        "helix_angle_deg": _f(0.0, "deg", 0, 45, hi_open=True, doc="helix angle β"),
        "face_width_mm": _f(20.0, "mm", 0, 10_000, lo_open=True, doc="face width b_f"),
        "addendum_coef": _f(1.0, "", 0.5, 1.5, doc="addendum coefficient h_a"),
        "dedendum_coef": _f(1.25, "", 0.5, 2.0, doc="dedendum coefficient h_d (> h_a)"),
        "profile_shift": _f(0.0, "", -1.0, 1.0, doc="profile shift coefficient x (both gears)"),
        "backlash_um": _f(40.0, "um", 0, 1e5, lo_open=True, doc="half backlash b"),
    },
    "mesh_stiffness": {
        "estimate": Spec("bool", False, doc="estimate from geometry and load (ISO 6336-1)"),
        "mean_N_per_um": _f(None, "N_per_um", 0, 1e7, lo_open=True, doc="mean mesh stiffness k̄_m"),
        "amplitudes_N_per_um": _f([], "N_per_um", 0, 1e7, kind="floats",
                                  doc="amplitude of mesh harmonic k = 1, 2, …"),
        "phases_deg": _f([], "deg", -360, 360, kind="floats", doc="phase of each mesh harmonic"),
        "n_harmonics": _f(3, "", 1, 20, kind="int", doc="harmonics kept by the estimate"),
        "cm": _f(0.8, "", 0.1, 1.0, doc="ISO 6336 correction C_M of the estimate"),
    },
    "transmission_error": {
        "kind": _c("loaded", ("loaded", "unloaded"),
                   "`loaded`: static TE q_s under F_s (paper's STE); `unloaded`: geometric e(t)"),
        "estimate": Spec("bool", False, doc="loaded STE of perfect teeth, q_s = F_s/k_m(t)"),
        "mean_um": _f(0.0, "um", -1e5, 1e5, doc="mean value"),
        "amplitudes_um": _f([], "um", 0, 1e5, kind="floats",
                            doc="amplitude of mesh harmonic k = 1, 2, …"),
        "phases_deg": _f([], "deg", -360, 360, kind="floats", doc="phase of each mesh harmonic"),
    },
    "load": {
        "torque_Nm": _f(2.5, "Nm", 0, 1e7, doc="input torque T; static load F_s = T/r_b1"),
    },
    "external.aero": {
        "shaft": _c(None, ("in", "out"), "shaft the load acts on"),
        "station": _f(None, "", 1, 6, kind="int",
                      doc="station 1–6 along the shaft (FE); omit for the gear (lumped)"),
        "order": _f(None, "", 1, 200, kind="int", doc="shaft order (harmonic of Ω)", required=True),
        "force_N": _f([0.0, 0.0, 0.0], "N", -1e9, 1e9, kind="vec3", doc="force amplitude (x,y,z)"),
        "torque_Nm": _f([0.0, 0.0, 0.0], "Nm", -1e9, 1e9, kind="vec3",
                        doc="torque amplitude (x,y,z)"),
        "phase_deg": _f(0.0, "deg", -360, 360, doc="phase φ: f(t) = A cos(order Ω t + φ)"),
    },
    "external.unbalance": {
        "shaft": _c(None, ("in", "out"), "shaft"),
        "m_unb_kgm": _f(None, "kgm", 0, 10, lo_open=True, doc="unbalance m·e", required=True),
        "phase_deg": _f(0.0, "deg", -360, 360, doc="phase of the rotating force (eq. 2–3)"),
    },
    "damping": {
        "modal_ratio": _f(0.05, "", 0, 1, hi_open=True, lo_open=True,
                          doc="modal damping ratio ξ of every mode (eq. 18–19)"),
    },
    "lumped": {
        "model": _c("sdof", ("sdof",), "lumped model: single-DOF on the line of action"),
        "equivalent_mass_kg": _f(None, "kg", 0, 1e6, lo_open=True,
                                 doc="m_e; default from the inertias"),
        "inertia_kgm2": _f(None, "kgm2", 0, 1e6, lo_open=True, kind="floats",
                           doc="[I1, I2]; default: steel disks of pitch radius and face width"),
        "density_kg_per_m3": _f(7800.0, "kg_per_m3", 0, 1e5, lo_open=True,
                                doc="disk density for the default inertias"),
    },
    "rom": {
        "n_cm": _f(250, "", 1, 5000, kind="int", doc="fixed-interface modes kept"),
        "cutoff_Hz": _f(None, "Hz", 0, 1e7, lo_open=True,
                        doc="keep modes below this frequency instead of n_cm"),
        "n_check": _f(30, "", 0, 5000, kind="int",
                      doc="coupled modes compared with the full model (Fig. 9); 0: skip"),
        "factorization": _c("lu", ("lu", "cholesky"),
                            "MUMPS factorisation of K_ii in the Craig–Bampton eigen-solve: "
                            "`cholesky` (LDLᵀ) gives the same modes with about half the factor "
                            "memory and time (docs/scale.md)"),
    },
    "hbm": {
        "mesh_harmonics": _f(3, "", 1, 200, kind="int", doc="mesh harmonics kZ, k = 1…n"),
        "sideband_order": _f(0, "", 0, 50, kind="int", doc="sidebands kZ ± e combination order"),
        "harmonic_set": _c("combinations", ("combinations", "bands", "contiguous"),
                           "how the builder fills the sidebands: the order-s combinations, "
                           "every index within their reach, or all indices (docs/convergence.md)"),
        "harmonics": _f(None, "", 0, 100_000, kind="ints",
                        doc="explicit harmonic set (must contain 0); overrides the builder"),
        "aft_samples": _f(0, "", 0, 1 << 20, kind="int", doc="AFT time samples (0: automatic)"),
        "condensation": _c("loa", ("loa", "gear", "none"), "exact condensation level"),
        "stability": Spec("bool", True, doc="stability of every point (variational "
                          "equation, every mode; docs/theory.md §11)"),
    },
    "continuation": {
        "speed_rpm": _f([500.0, 8000.0], "rpm", 0, 1e6, lo_open=True, kind="pair",
                        doc="[start, end] shaft speed, start < end"),
        "step_rpm": _f(None, "rpm", 0, 1e6, lo_open=True, doc="initial step (default: range/200)"),
        "min_step_rpm": _f(None, "rpm", 0, 1e6, lo_open=True,
                           doc="smallest step (default: range/1e5)"),
        "max_step_rpm": _f(None, "rpm", 0, 1e6, lo_open=True,
                           doc="largest step (default: range/50)"),
        "tolerance": _f(1e-8, "", 1e-14, 1e-2, doc="relative residual tolerance of each point"),
        "max_points": _f(20_000, "", 2, 10_000_000, kind="int", doc="maximum points"),
        "checkpoint_every": _f(20, "", 1, 1_000_000, kind="int",
                               doc="points between checkpoints in results.h5"),
    },
    "acoustics": {
        "air_density_kg_per_m3": _f(1.2, "kg_per_m3", 0, 100, lo_open=True,
                                    doc="density ρ of the air the housing radiates into (ERP)"),
        "sound_speed_m_per_s": _f(343.0, "m_per_s", 0, 1e4, lo_open=True,
                                  doc="speed of sound c of that air (ERP = ½ ρ c Σ v_n² A)"),
    },
    "outputs": {
        "plots": Spec("strs", list(PLOT_NAMES),
                      doc="plots to draw, among " + ", ".join(PLOT_NAMES)),
        "time_series_rpm": _f([], "rpm", 0, 1e6, lo_open=True, kind="floats",
                              doc="speeds for time series/spectra (default: most loaded point)"),
        "housing_field_rpm": _f([], "rpm", 0, 1e6, lo_open=True, kind="floats",
                                doc="speeds for the XDMF housing field (FE)"),
        "report": Spec("bool", True, doc="write report.md"),
        "field_orders": _f([], "", 1, 100_000, kind="ints",
                           doc="shaft orders of the per-order housing fields (FE; default: "
                           "the mesh orders kZ and the external orders of the set)"),
        "housing_frames_per_mesh_period": _f(
            0, "", 0, 10_000, kind="int",
            doc="frames per mesh period of the housing time series (0: 4 per period of the "
            "highest harmonic kept; fewer than 2 alias and are refused)"),
        "housing_mesh_periods": _f(4, "", 1, 1000, kind="int",
                                   doc="length of the housing time series in mesh periods"),
    },
    "outputs.accelerometer": {
        "name": Spec("str", None, doc="name of the virtual accelerometer", required=True),
        "position_mm": _f(None, "mm", -1e5, 1e5, kind="vec3", required=True,
                          doc="point on the housing's outer surface (x, y, z); snapped to the "
                          "nearest outer facet centre (at most 10 mm away)"),
        "direction": _f([0.0, 0.0, 0.0], "", -1e6, 1e6, kind="vec3",
                        doc="measuring axis (x, y, z); [0, 0, 0]: the outer surface normal"),
    },
}
for _s in FE_SECTIONS:
    SCHEMA[_s] = {}  # free tables, validated against the FE packages' dataclasses

_TOP_LEVEL = ("scene", "gear", "mesh_stiffness", "transmission_error", "load", "external",
              "damping", "lumped", "rom", "hbm", "continuation", "acoustics", "outputs",
              *FE_SECTIONS)


def _attr(key: str) -> str:
    """File key -> attribute name (unit suffix dropped)."""
    for suf in sorted(TO_SI, key=len, reverse=True):
        if suf and key.endswith("_" + suf):
            return key[: -len(suf) - 1]
    return key


# --------------------------------------------------------------------------- dataclasses

@dataclass(frozen=True)
class SceneInfo:
    """``[scene]``: name, kind (``lumped`` or ``fe``) and description."""

    name: str
    kind: str
    description: str = ""


@dataclass(frozen=True)
class GearData:
    """``[gear]`` in SI: radii (m), angles (rad), half backlash (m)."""

    teeth: int
    base_radius: float
    module: float
    pressure_angle: float
    helix_angle: float
    face_width: float
    addendum_coef: float
    dedendum_coef: float
    profile_shift: float
    backlash: float

    @property
    def pitch_radius(self) -> float:
        """Pitch radius r = r_b / cos α (m)."""
        return self.base_radius / math.cos(self.pressure_angle)

    @property
    def centre_distance(self) -> float:
        """Centre distance a = 2 r (m), ratio 1:1."""
        return 2.0 * self.pitch_radius

    @property
    def tip_radius(self) -> float:
        """Tip radius r_a = r + (h_a + x) m (m)."""
        return self.pitch_radius + (self.addendum_coef + self.profile_shift) * self.module

    @property
    def contact_ratio(self) -> float:
        """Transverse contact ratio ε_α of the pair (spur, ratio 1:1, standard centre distance)."""
        rb, ra, r = self.base_radius, self.tip_radius, self.pitch_radius
        alpha = self.pressure_angle
        path = 2.0 * math.sqrt(ra**2 - rb**2) - 2.0 * r * math.sin(alpha)
        return path / (math.pi * self.module * math.cos(alpha))


@dataclass(frozen=True)
class MeshStiffness:
    """Mesh stiffness k_m(t) = k̄ + Σ_k a_k cos(k Z Ω t + φ_k) (eq. 16), N/m and rad."""

    mean: float
    amplitudes: tuple[float, ...]
    phases: tuple[float, ...]
    estimated: bool = False

    def coefficients(self) -> dict[int, complex]:
        """Complex one-sided coefficients per mesh harmonic, {0: k̄, k: a_k e^{iφ_k}}."""
        out: dict[int, complex] = {0: complex(self.mean)}
        for k, (a, p) in enumerate(zip(self.amplitudes, self.phases, strict=True), start=1):
            out[k] = complex(a * np.exp(1j * p))
        return out

    def minimum(self) -> float:
        """Lower bound k̄ − Σ|a_k| of k_m(t) (N/m)."""
        return self.mean - float(sum(self.amplitudes))


@dataclass(frozen=True)
class TransmissionError:
    """Transmission error (m, rad); ``kind`` is ``loaded`` (STE q_s) or ``unloaded`` (e)."""

    kind: str
    mean: float
    amplitudes: tuple[float, ...]
    phases: tuple[float, ...]
    estimated: bool = False

    def coefficients(self) -> dict[int, complex]:
        """Complex one-sided coefficients per mesh harmonic (m)."""
        out: dict[int, complex] = {0: complex(self.mean)}
        for k, (a, p) in enumerate(zip(self.amplitudes, self.phases, strict=True), start=1):
            out[k] = complex(a * np.exp(1j * p))
        return out


@dataclass(frozen=True)
class LoadData:
    """``[load]``: input torque T (N·m)."""

    torque: float


@dataclass(frozen=True)
class AeroLoad:
    """One aerodynamic harmonic on a shaft station (eq. 1): A cos(order Ω t + φ)."""

    shaft: str
    station: int | None
    order: int
    force: tuple[float, float, float]
    torque: tuple[float, float, float]
    phase: float


@dataclass(frozen=True)
class Unbalance:
    """Mass unbalance m·e (kg·m) on a shaft, rotating force of eq. (2–3) with a phase (rad)."""

    shaft: str
    m_unb: float
    phase: float


@dataclass(frozen=True)
class ExternalData:
    """``[external]``: aerodynamic harmonics and unbalances."""

    aero: tuple[AeroLoad, ...] = ()
    unbalance: tuple[Unbalance, ...] = ()

    @property
    def orders(self) -> tuple[int, ...]:
        """Sorted shaft orders present in the external excitation."""
        o = {a.order for a in self.aero} | ({1} if self.unbalance else set())
        return tuple(sorted(o))

    @property
    def present(self) -> bool:
        return bool(self.aero or self.unbalance)


@dataclass(frozen=True)
class DampingData:
    """``[damping]``: modal damping ratio ξ."""

    modal_ratio: float


@dataclass(frozen=True)
class LumpedData:
    """``[lumped]``: single-DOF model data, SI."""

    model: str
    equivalent_mass: float | None
    inertia: tuple[float, ...] | None
    density: float


@dataclass(frozen=True)
class RomData:
    """``[rom]``: number of fixed-interface modes or a cut-off frequency (Hz)."""

    n_cm: int
    cutoff: float | None
    n_check: int = 30
    factorization: str = "lu"


@dataclass(frozen=True)
class HbmData:
    """``[hbm]``: harmonic set and AFT settings."""

    mesh_harmonics: int
    sideband_order: int
    harmonics: tuple[int, ...] | None
    harmonic_set: str
    aft_samples: int
    condensation: str
    stability: bool = True


@dataclass(frozen=True)
class ContinuationData:
    """``[continuation]``: speed range and steps in rpm, tolerance, checkpoints."""

    speed: tuple[float, float]
    step: float
    min_step: float
    max_step: float
    tolerance: float
    max_points: int
    checkpoint_every: int


@dataclass(frozen=True)
class AcousticsData:
    """``[acoustics]``: air density (kg/m³) and speed of sound (m/s) of the ERP."""

    air_density: float = 1.2
    sound_speed: float = 343.0


@dataclass(frozen=True)
class Accelerometer:
    """``[[outputs.accelerometer]]``: name, position (m), direction (zero: surface normal)."""

    name: str
    position: tuple[float, float, float]
    direction: tuple[float, float, float] = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class OutputsData:
    """``[outputs]``: plots, time-series speeds (rpm), housing field speeds (rpm), per-order
    field orders, housing time-series sampling, virtual accelerometers."""

    plots: tuple[str, ...]
    time_series: tuple[float, ...]
    housing_field: tuple[float, ...]
    report: bool
    field_orders: tuple[int, ...] = ()
    housing_frames_per_mesh_period: int = 0
    housing_mesh_periods: int = 4
    accelerometers: tuple[Accelerometer, ...] = ()


@dataclass(frozen=True)
class Scene:
    """A validated scene in SI units. ``raw`` is the parsed file (for hashing/records)."""

    scene: SceneInfo
    gear: GearData
    mesh_stiffness: MeshStiffness
    transmission_error: TransmissionError
    load: LoadData
    external: ExternalData
    damping: DampingData
    lumped: LumpedData
    rom: RomData
    hbm: HbmData
    continuation: ContinuationData
    outputs: OutputsData
    fe: dict = field(default_factory=dict)
    raw: dict = field(default_factory=dict, compare=False, repr=False)
    text: str = field(default="", compare=False, repr=False)
    acoustics: AcousticsData = field(default_factory=AcousticsData)

    @property
    def static_load(self) -> float:
        """Static mesh load F_s = T / r_b1 (N)."""
        return self.load.torque / self.gear.base_radius

    @property
    def name(self) -> str:
        return self.scene.name


# --------------------------------------------------------------------------- checking

def _fmt(v: Any) -> str:
    return repr(v) if isinstance(v, str) else str(v)


def _is_num(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _check_number(where: str, v: Any, spec: Spec) -> float | int:
    if spec.kind == "int":
        if not (isinstance(v, int) and not isinstance(v, bool)):
            if _is_num(v) and float(v).is_integer():
                v = int(v)
            else:
                raise SceneError(f"{where} = {_fmt(v)}: must be an integer "
                                 f"({spec.range_text()})")
    elif not _is_num(v):
        raise SceneError(f"{where} = {_fmt(v)}: must be a number ({spec.range_text()})")
    if not math.isfinite(v):
        raise SceneError(f"{where} = {_fmt(v)}: must be finite ({spec.range_text()})")
    bad = False
    if spec.lo is not None:
        bad |= v <= spec.lo if spec.lo_open else v < spec.lo
    if spec.hi is not None:
        bad |= v >= spec.hi if spec.hi_open else v > spec.hi
    if bad:
        raise SceneError(f"{where} = {_fmt(v)}: must be {spec.range_text()}")
    return v


def _check_value(where: str, v: Any, spec: Spec) -> Any:
    """Type/range check one value; returns it converted to SI."""
    k = spec.kind
    factor = TO_SI[spec.unit]
    if k in ("float", "int"):
        n = _check_number(where, v, spec)
        return n if k == "int" else float(n) * factor
    if k == "bool":
        if not isinstance(v, bool):
            raise SceneError(f"{where} = {_fmt(v)}: must be true or false")
        return v
    if k == "str":
        if not isinstance(v, str):
            raise SceneError(f"{where} = {_fmt(v)}: must be a string")
        return v
    if k == "choice":
        if not isinstance(v, str) or v not in spec.choices:
            hint = _suggest(v, spec.choices) if isinstance(v, str) else ""
            raise SceneError(f"{where} = {_fmt(v)}: must be {spec.range_text()}{hint}")
        return v
    if k == "strs":
        if not isinstance(v, list) or not all(isinstance(s, str) for s in v):
            raise SceneError(f"{where} = {_fmt(v)}: must be a list of strings")
        return tuple(v)
    if k in ("floats", "ints", "vec3", "pair"):
        if not isinstance(v, list):
            raise SceneError(f"{where} = {_fmt(v)}: must be a list of numbers")
        if k == "vec3" and len(v) != 3:
            raise SceneError(f"{where} = {_fmt(v)}: must be a list of 3 numbers (x, y, z)")
        if k == "pair" and len(v) != 2:
            raise SceneError(f"{where} = {_fmt(v)}: must be a list [start, end] of 2 numbers")
        item = dataclasses.replace(spec, kind="int" if k == "ints" else "float")
        out = [_check_value(f"{where}[{i}]", x, item) for i, x in enumerate(v)]
        if k == "pair" and not out[0] < out[1]:
            raise SceneError(f"{where} = {_fmt(v)}: start must be smaller than end "
                             "(reversed or empty range)")
        return tuple(out)
    raise AssertionError(k)


def _suggest(key: str, allowed) -> str:
    m = difflib.get_close_matches(key, list(allowed), n=1, cutoff=0.5)
    return f" (did you mean {m[0]!r}?)" if m else ""


def _check_table(where: str, table: Any, specs: dict[str, Spec]) -> dict[str, Any]:
    """Validate one table against its specs; returns {attr: SI value} incl. defaults."""
    if not isinstance(table, dict):
        raise SceneError(f"[{where}] = {_fmt(table)}: must be a table")
    for key in table:
        if key not in specs:
            raise SceneError(f"{where}.{key}: unknown key{_suggest(key, specs)}; "
                             f"allowed: {', '.join(specs)}")
    out: dict[str, Any] = {}
    for key, spec in specs.items():
        if key in table:
            out[_attr(key)] = _check_value(f"{where}.{key}", table[key], spec)
        elif spec.required or (spec.default is None and spec.kind == "choice"):
            raise SceneError(f"{where}.{key}: missing (required; {spec.range_text()})")
        else:
            d = spec.default
            if d is not None and spec.kind in ("float", "floats", "vec3", "pair") and d != []:
                d = _check_value(f"{where}.{key}", d, spec)
            elif isinstance(d, list):
                d = tuple(d)
            out[_attr(key)] = d
    return out


# --------------------------------------------------------------------------- estimates

def iso6336_single_tooth_stiffness(gear: GearData, static_load: float, cm: float) -> float:
    """Single-pair tooth stiffness c'·b_f (N/m) from ISO 6336-1 method B.

    c'_th = 1/q' with q' the standard polynomial in the virtual tooth numbers and
    profile shifts (mm·µm/N); c' = c'_th C_M C_R C_B cos β with C_R = C_B = 1 and a
    load correction (F_t/b / 100 N/mm)^0.25 when the line load is below 100 N/mm.
    """
    zn = gear.teeth / math.cos(gear.helix_angle) ** 3
    x = gear.profile_shift
    q = (0.04723 + 0.15551 / zn + 0.25791 / zn - 0.00635 * x - 0.11654 * x / zn
         - 0.00193 * x - 0.24188 * x / zn + 0.00529 * x * x + 0.00182 * x * x)
    c_th = 1.0 / q  # N/(mm·µm)
    c = c_th * cm * math.cos(gear.helix_angle)
    line_load = static_load * math.cos(gear.pressure_angle) / (gear.face_width * 1e3)  # N/mm
    if line_load < 100.0:
        c *= max(line_load, 1e-3) ** 0.25 / 100.0 ** 0.25
    return c * gear.face_width * 1e3 * 1e6  # N/(mm·µm) × mm -> N/µm -> N/m


def estimate_mesh_stiffness(gear: GearData, static_load: float, cm: float,
                            n_harmonics: int) -> MeshStiffness:
    """Rectangular-wave mesh stiffness from ISO 6336 (eq. 16 truncated to n harmonics).

    One pair (c'·b_f) carries the load for a fraction 2 − ε_α of the mesh period, two
    pairs for ε_α − 1: k_m(t) = c' b_f (1 + 𝟙_double(t)), whose mean is c' b_f ε_α and
    whose harmonics are 2 c' b_f sin(kπ(ε_α − 1))/(kπ), phased so that the double-contact
    zone is centred on t = 0.
    """
    k1 = iso6336_single_tooth_stiffness(gear, static_load, cm)
    eps = gear.contact_ratio
    d = eps - math.floor(eps)  # fraction with one more pair in contact
    n0 = math.floor(eps)
    amps, phases = [], []
    for k in range(1, n_harmonics + 1):
        a = 2.0 * k1 * math.sin(k * math.pi * d) / (k * math.pi)
        amps.append(abs(a))
        phases.append(0.0 if a >= 0 else math.pi)
    return MeshStiffness(k1 * (n0 + d), tuple(amps), tuple(phases), estimated=True)


def estimate_ste(ms: MeshStiffness, static_load: float, n_harmonics: int) -> TransmissionError:
    """Loaded STE of perfect teeth, q_s(t) = F_s / k_m(t), truncated to n mesh harmonics."""
    n = 256
    t = np.arange(n) / n
    k = np.full(n, ms.mean)
    for j, (a, p) in enumerate(zip(ms.amplitudes, ms.phases, strict=True), start=1):
        k += a * np.cos(2 * np.pi * j * t + p)
    c = np.fft.rfft(static_load / k) / n
    amps = tuple(float(2 * abs(c[j])) for j in range(1, n_harmonics + 1))
    phases = tuple(float(np.angle(c[j])) for j in range(1, n_harmonics + 1))
    return TransmissionError("loaded", float(c[0].real), amps, phases, estimated=True)


# --------------------------------------------------------------------------- building

def _harmonic_pairs(where: str, d: dict, amp: str, ph: str) -> tuple[tuple, tuple]:
    a, p = d[_attr(amp)], d[_attr(ph)]
    if len(p) == 0 and len(a) > 0:
        p = (0.0,) * len(a)
    if len(a) != len(p):
        raise SceneError(f"{where}.{ph} = {[round(math.degrees(x), 6) for x in p]}: must have as "
                         f"many entries as {where}.{amp} ({len(a)})")
    return tuple(a), tuple(p)


def _build_gear(d: dict) -> GearData:
    z, rb, alpha = d["teeth"], d["base_radius"], d["pressure_angle"]
    m_derived = 2.0 * rb / (z * math.cos(alpha))
    m = d["module"]
    if m is None:
        m = m_derived
    elif abs(m - m_derived) > 0.01 * m_derived:
        raise SceneError(
            f"gear.module_mm = {m * 1e3:g}: inconsistent with gear.base_radius_mm = {rb * 1e3:g}, "
            f"gear.teeth = {z} and gear.pressure_angle_deg = {math.degrees(alpha):g}, which give "
            f"{m_derived * 1e3:.6g} mm (allowed: within 1 %, or omit module_mm)")
    if d["dedendum_coef"] <= d["addendum_coef"]:
        raise SceneError(f"gear.dedendum_coef = {d['dedendum_coef']:g}: must be > "
                         f"gear.addendum_coef = {d['addendum_coef']:g} (tip clearance)")
    g = GearData(module=m, **{k: v for k, v in d.items() if k != "module"})
    root = g.pitch_radius - (g.dedendum_coef - g.profile_shift) * m
    if root <= 0:
        raise SceneError(f"gear.teeth = {z}: root radius {root * 1e3:.4g} mm must be > 0 "
                         "(too few teeth for this module and profile)")
    eps = g.contact_ratio
    if not (1.0 <= eps < 4.0):
        raise SceneError(f"gear.teeth = {z}: contact ratio ε_α = {eps:.3f} from teeth, module, "
                         "pressure angle and addendum must be in [1, 4)")
    if g.backlash > 0.5 * math.pi * m:
        raise SceneError(f"gear.backlash_um = {g.backlash * 1e6:g}: must be < half the circular "
                         f"pitch, {0.5 * math.pi * m * 1e6:.4g} µm")
    return g


def _build_accelerometers(items: Any, kind: str) -> tuple[Accelerometer, ...]:
    if not isinstance(items, list):
        raise SceneError(f"outputs.accelerometer = {_fmt(items)}: must be an array of tables "
                         "([[outputs.accelerometer]])")
    out: list[Accelerometer] = []
    for i, item in enumerate(items):
        where = f"outputs.accelerometer[{i}]"
        d = _check_table(where, item, SCHEMA["outputs.accelerometer"])
        if kind != "fe":
            raise SceneError(f"{where}: accelerometers need the housing (scene.kind = 'fe')")
        if any(a.name == d["name"] for a in out):
            raise SceneError(f"{where}.name = {d['name']!r}: used twice (names must be unique)")
        if not d["name"].strip():
            raise SceneError(f"{where}.name = {d['name']!r}: must not be empty")
        out.append(Accelerometer(d["name"], tuple(d["position"]), tuple(d["direction"])))
    return tuple(out)


def _build_external(ext: Any, kind: str) -> ExternalData:
    if ext is None:
        return ExternalData()
    if not isinstance(ext, dict):
        raise SceneError(f"[external] = {_fmt(ext)}: must be a table")
    for key in ext:
        if key not in ("aero", "unbalance"):
            raise SceneError(f"external.{key}: unknown key{_suggest(key, ('aero', 'unbalance'))}; "
                             "allowed: aero, unbalance ([[external.aero]] tables)")
    aero, unb = [], []
    for name, target in (("aero", aero), ("unbalance", unb)):
        items = ext.get(name, [])
        if not isinstance(items, list):
            raise SceneError(f"external.{name} = {_fmt(items)}: must be an array of tables "
                             f"([[external.{name}]])")
        for i, item in enumerate(items):
            where = f"external.{name}[{i}]"
            d = _check_table(where, item, SCHEMA[f"external.{name}"])
            if name == "aero":
                if kind == "lumped":
                    if any(d["force"]) or d["torque"][0] or d["torque"][1]:
                        raise SceneError(f"{where}.force_N = {list(d['force'])}: a lumped "
                                         "(torsional) scene takes torque_Nm = [0, 0, Mz] only")
                    if d["station"] is not None:
                        raise SceneError(f"{where}.station = {d['station']}: a lumped scene has "
                                         "no shaft stations (omit it: the torque acts on the gear)")
                elif d["station"] is None:
                    raise SceneError(f"{where}.station: missing (required for fe scenes; 1–6)")
                target.append(AeroLoad(**d))
            else:
                if kind == "lumped":
                    raise SceneError(f"{where}.m_unb_kgm = {d['m_unb'] * 1.0:g}: unbalance "
                                     "needs lateral DOF; not allowed in a lumped (torsional) scene")
                target.append(Unbalance(**d))
    return ExternalData(tuple(aero), tuple(unb))


def scene_from_dict(raw: dict, name: str = "scene", text: str = "") -> Scene:
    """Validate a parsed scene table and return the SI :class:`Scene`.

    Parameters
    ----------
    raw : dict
        The TOML document as parsed by :mod:`tomllib`.
    name : str
        Default scene name (the file stem) when ``[scene] name`` is absent.
    text : str
        The original file text, kept for records.

    Raises
    ------
    SceneError
        On any invalid field; the message names the field, its value and what is allowed.
    """
    try:
        return _scene_from_dict(raw, name, text)
    except (SceneError, StageUnavailable):
        raise
    except (TypeError, ValueError, ArithmeticError, KeyError) as exc:  # defensive: never leak
        raise SceneError(f"scene could not be validated: {exc}") from exc


def _scene_from_dict(raw: dict, name: str, text: str) -> Scene:
    if not isinstance(raw, dict):
        raise SceneError(f"scene = {_fmt(raw)}: must be a TOML document (table)")
    for key in raw:
        if key not in _TOP_LEVEL:
            raise SceneError(f"[{key}]: unknown section{_suggest(key, _TOP_LEVEL)}; "
                             f"allowed: {', '.join(_TOP_LEVEL)}")
    raw_out = raw.get("outputs", {})
    accel_raw = []
    if isinstance(raw_out, dict) and "accelerometer" in raw_out:
        raw_out = dict(raw_out)
        accel_raw = raw_out.pop("accelerometer")
    sec = {s: _check_table(s, raw_out if s == "outputs" else raw.get(s, {}), SCHEMA[s])
           for s in _TOP_LEVEL if s not in ("external", *FE_SECTIONS)}
    info = SceneInfo(**{**sec["scene"], "name": sec["scene"]["name"] or name})
    gear = _build_gear(sec["gear"])
    static_load = sec["load"]["torque"] / gear.base_radius

    d = sec["mesh_stiffness"]
    if d["estimate"]:
        if d["mean"] is not None or d["amplitudes"]:
            raise SceneError("mesh_stiffness.estimate = true: remove mean_N_per_um and "
                             "amplitudes_N_per_um (they would be ignored)")
        if static_load <= 0:
            raise SceneError("load.torque_Nm = 0: mesh_stiffness.estimate needs a torque > 0")
        ms = estimate_mesh_stiffness(gear, static_load, d["cm"], d["n_harmonics"])
    else:
        if d["mean"] is None:
            raise SceneError("mesh_stiffness.mean_N_per_um: missing (give it, or estimate = true)")
        a, p = _harmonic_pairs("mesh_stiffness", d, "amplitudes_N_per_um", "phases_deg")
        ms = MeshStiffness(d["mean"], a, p)
        if ms.minimum() <= 0:
            raise SceneError(f"mesh_stiffness.amplitudes_N_per_um = "
                             f"{[x / 1e6 for x in a]}: their sum must be < mean_N_per_um = "
                             f"{ms.mean / 1e6:g} so that k_m(t) > 0")

    d = sec["transmission_error"]
    if d["estimate"]:
        if d["amplitudes"] or d["mean"] != 0.0:
            raise SceneError("transmission_error.estimate = true: remove mean_um and "
                             "amplitudes_um (they would be ignored)")
        if d["kind"] != "loaded":
            raise SceneError(f"transmission_error.kind = {d['kind']!r}: the estimate is a "
                             "loaded STE (kind = 'loaded')")
        te = estimate_ste(ms, static_load, max(len(ms.amplitudes), 1))
    else:
        a, p = _harmonic_pairs("transmission_error", d, "amplitudes_um", "phases_deg")
        te = TransmissionError(d["kind"], d["mean"], a, p)

    external = _build_external(raw.get("external"), info.kind)

    lum = sec["lumped"]
    if lum["inertia"] is not None and len(lum["inertia"]) != 2:
        raise SceneError(f"lumped.inertia_kgm2 = {list(lum['inertia'])}: must be [I1, I2]")
    if lum["inertia"] is not None and lum["equivalent_mass"] is not None:
        raise SceneError("lumped.equivalent_mass_kg: give either equivalent_mass_kg or "
                         "inertia_kgm2, not both")
    lumped = LumpedData(**lum)

    rom = RomData(**sec["rom"])
    h = sec["hbm"]
    if h["harmonics"] is not None:
        hs = h["harmonics"]
        if 0 not in hs:
            raise SceneError(f"hbm.harmonics = {list(hs)}: must contain 0 (the mean)")
        if len(set(hs)) != len(hs) or list(hs) != sorted(hs):
            raise SceneError(f"hbm.harmonics = {list(hs)}: must be sorted without repeats")
        if len(hs) < 2:
            raise SceneError(f"hbm.harmonics = {list(hs)}: needs at least one harmonic besides 0")
        n_mesh = max(len(ms.amplitudes), len(te.amplitudes))
        need = {k * (gear.teeth if external.present else 1) for k in range(1, n_mesh + 1)}
        missing = sorted(need - set(hs))
        lacking = sorted(set(external.orders) - set(hs))
        if lacking:
            raise SceneError(f"hbm.harmonics = {list(hs)}: lacks the external shaft orders "
                             f"{lacking} (fundamental Ω)")
        if missing:
            raise SceneError(f"hbm.harmonics = {list(hs)}: lacks the excited mesh harmonics "
                             f"{missing} (fundamental {'Ω' if external.present else 'ZΩ'})")
    hbm = HbmData(**h)

    c = sec["continuation"]
    lo, hi = c["speed"]
    span = hi - lo
    step = c["step"] or span / 200.0
    min_step = c["min_step"] or min(span / 1e5, step)
    max_step = c["max_step"] or max(span / 50.0, step)
    if not min_step <= step <= max_step:
        raise SceneError(f"continuation.step_rpm = {step:g}: must lie between min_step_rpm = "
                         f"{min_step:g} and max_step_rpm = {max_step:g}")
    if step > span:
        raise SceneError(f"continuation.step_rpm = {step:g}: must be <= the speed range "
                         f"{span:g} rpm")
    cont = ContinuationData(c["speed"], step, min_step, max_step, c["tolerance"],
                            c["max_points"], c["checkpoint_every"])

    o = sec["outputs"]
    for p in o["plots"]:
        if p not in PLOT_NAMES:
            raise SceneError(f"outputs.plots: {p!r} is not a plot{_suggest(p, PLOT_NAMES)}; "
                             f"allowed: {', '.join(PLOT_NAMES)}")
    for key in ("time_series", "housing_field"):
        for v in o[key]:
            if not lo <= v <= hi:
                raise SceneError(f"outputs.{key}_rpm = {list(o[key])}: {v:g} is outside "
                                 f"continuation.speed_rpm = [{lo:g}, {hi:g}]")
    if o["field_orders"] and info.kind != "fe":
        raise SceneError(f"outputs.field_orders = {list(o['field_orders'])}: only for "
                         "scene.kind = 'fe'")
    if o["housing_field"] and info.kind != "fe":
        raise SceneError(f"outputs.housing_field_rpm = {list(o['housing_field'])}: only for "
                         "scene.kind = 'fe'")
    accels = _build_accelerometers(accel_raw, info.kind)
    outputs = OutputsData(**o, accelerometers=accels)

    fe: dict[str, dict] = {}
    for s in FE_SECTIONS:
        t = raw.get(s)
        if t is None:
            continue
        if info.kind != "fe":
            raise SceneError(f"[{s}]: only allowed when scene.kind = 'fe' (kind is "
                             f"{info.kind!r})")
        if not isinstance(t, dict):
            raise SceneError(f"[{s}] = {_fmt(t)}: must be a table")
        fe[s] = copy.deepcopy(t)
    if info.kind == "fe":
        try:  # geometry and fem are imported only here, for FE scenes
            fe_parameters(fe, gear)
        except ImportError as exc:
            raise StageUnavailable(f"scene.kind = 'fe' needs geometry/fem (gmsh, DOLFINx): "
                                   f"{exc}") from exc

    return Scene(info, gear, ms, te, LoadData(**sec["load"]), external,
                 DampingData(**sec["damping"]), lumped, rom, hbm, cont, outputs, fe,
                 copy.deepcopy(raw), text, AcousticsData(**sec["acoustics"]))


def parse_scene(text: str, name: str = "scene") -> Scene:
    """Parse and validate TOML text (see :func:`scene_from_dict`)."""
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"scene file is not valid TOML: {exc}") from exc
    return scene_from_dict(raw, name, text)


def load_scene(path: str | Path, overrides: dict[str, Any] | None = None) -> Scene:
    """Read, override (``{"section.key": value}``) and validate a scene file.

    Raises
    ------
    SceneError
        File missing/unreadable, invalid TOML, or any invalid field.
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as exc:
        raise SceneError(f"scene file {str(p)!r}: cannot be read ({exc.strerror})") from exc
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"scene file {str(p)!r} is not valid TOML: {exc}") from exc
    if overrides:
        raw = apply_overrides(raw, overrides)
    return scene_from_dict(raw, p.stem, text)


def apply_overrides(raw: dict, overrides: dict[str, Any]) -> dict:
    """Return a copy of ``raw`` with ``{"section.key": value}`` set (validated later)."""
    out = copy.deepcopy(raw)
    for dotted, value in overrides.items():
        parts = dotted.split(".")
        if len(parts) < 2 or not all(parts):
            raise SceneError(f"--set {dotted}: must be section.key (e.g. load.torque_Nm)")
        node = out
        for p in parts[:-1]:
            nxt = node.setdefault(p, {})
            if not isinstance(nxt, dict):
                raise SceneError(f"--set {dotted}: {p!r} is not a table")
            node = nxt
        node[parts[-1]] = value
    return out


def schema_markdown() -> str:
    """Markdown tables of :data:`SCHEMA` (key, type, default, allowed, meaning)."""
    lines = []
    for sec, specs in SCHEMA.items():
        if not specs:
            continue
        head = f"[[{sec}]]" if "." in sec else f"[{sec}]"
        lines += [f"### `{head}`", "", "| key | type | default | allowed | meaning |",
                  "|---|---|---|---|---|"]
        for key, sp in specs.items():
            kind = {"floats": "list of floats", "ints": "list of ints", "vec3": "[x, y, z]",
                    "pair": "[start, end]", "strs": "list of strings", "choice": "string"
                    }.get(sp.kind, sp.kind)
            d = "required" if sp.required else ("–" if sp.default is None else repr(sp.default))
            d = d.replace("'", '"').replace("True", "true").replace("False", "false")
            allowed = sp.range_text() if sp.kind not in ("bool", "str", "strs") else "–"
            lines.append(f"| `{key}` | {kind} | {d} | {allowed} | {sp.doc} |")
        lines.append("")
    return "\n".join(lines)


def parse_set_values(text: str) -> list[Any]:
    """Parse the value list of ``--set section.key=v1,v2`` with TOML value syntax.

    Lists are written with brackets and split at top-level commas only:
    ``speed_rpm=[500,4000],[500,8000]``.
    """
    items, depth, cur = [], 0, ""
    for ch in text:
        if ch == "[":
            depth += 1
        elif ch == "]":
            depth -= 1
        if ch == "," and depth == 0:
            items.append(cur)
            cur = ""
        else:
            cur += ch
    items.append(cur)
    out = []
    for s in items:
        s = s.strip()
        try:
            out.append(tomllib.loads(f"v = {s}")["v"])
        except tomllib.TOMLDecodeError:
            out.append(s)  # bare word -> string
    return out
