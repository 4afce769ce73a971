"""Loading a scene: TOML text or file -> validated :class:`~study.scene.data.Scene`,
with the ``--set`` overrides of :mod:`study.scene.overrides` applied first.

Each section is checked against :data:`study.scene.schema.SCHEMA` by the one checker
(:func:`study.scene.check.check_table`), then the builders below check what spans
keys or sections (gear consistency, harmonic sets, speed ranges, FE sections) in a
fixed order, so the first error in a file is always the same one.
"""
from __future__ import annotations

import copy
import dataclasses
import math
import tomllib
from pathlib import Path
from typing import Any

from core.errors import InputError, show, suggest
from gears.excitation import perfect_teeth_ste, rectangular_mesh_stiffness
from gears.iso6336 import approximate_virtual_teeth, single_stiffness
from study.scene.check import check_known, check_table
from study.scene.data import (
    Accelerometer,
    AcousticsData,
    AeroLoad,
    BearingData,
    ContinuationData,
    DampingData,
    DriveData,
    ExternalData,
    GearData,
    HbmData,
    LoadData,
    LumpedData,
    MeshData,
    MeshSource,
    MeshStiffness,
    OutputsData,
    RomData,
    Scene,
    SceneInfo,
    ShaftData,
    TrainGearData,
    TrainLoadData,
    TransmissionError,
    Unbalance,
)
from study.scene.errors import SceneError, StageUnavailable
from study.scene.excitation import (
    check_source_keys,
    mesh_source,
    scene_pair,
    set_mesh_harmonics,
    source_series,
    uses_other_source,
)
from study.scene.frequency import resolve_rom
from study.scene.overrides import apply_overrides
from study.scene.plausibility import check_plausibility, check_required_sections
from study.scene.schema import (
    FE_SECTIONS,
    GEARBOX_SECTIONS,
    PAIR_SECTIONS,
    PLOT_NAMES,
    SCHEMA,
    TOP_LEVEL,
    TRAIN_KINDS,
    TRAIN_SECTIONS,
    attr_name,
)

__all__ = ["scene_from_dict", "parse_scene", "load_scene"]


# --------------------------------------------------------------------------- sections

def _harmonic_pairs(where: str, d: dict, amp: str, ph: str) -> tuple[tuple, tuple]:
    a, p = d[attr_name(amp)], d[attr_name(ph)]
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


def _build_accelerometers(items: Any) -> tuple[Accelerometer, ...]:
    if not isinstance(items, list):
        raise SceneError(f"outputs.accelerometer = {show(items)}: must be an array of tables "
                         "([[outputs.accelerometer]])")
    out: list[Accelerometer] = []
    for i, item in enumerate(items):
        where = f"outputs.accelerometer[{i}]"
        d = check_table(where, item, SCHEMA["outputs.accelerometer"])
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
        raise SceneError(f"[external] = {show(ext)}: must be a table")
    check_known(ext, ("aero", "unbalance"), lambda key: f"external.{key}",
                note=" ([[external.aero]] tables)")
    aero, unb = [], []
    for name, target in (("aero", aero), ("unbalance", unb)):
        items = ext.get(name, [])
        if not isinstance(items, list):
            raise SceneError(f"external.{name} = {show(items)}: must be an array of tables "
                             f"([[external.{name}]])")
        for i, item in enumerate(items):
            where = f"external.{name}[{i}]"
            if kind in TRAIN_KINDS:     # the train's shafts; machines.train checks the rest
                d = check_table(where, item, SCHEMA[f"train.external.{name}"])
                target.append(AeroLoad(station=None, **d) if name == "aero"
                              else Unbalance(**d))
                continue
            d = check_table(where, item, SCHEMA[f"external.{name}"])
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



def _mesh_stiffness(d: dict, gear: GearData, static_load: float) -> MeshStiffness:
    """``[mesh_stiffness]``: given harmonics, or the ISO 6336-1 estimate: a rectangular
    wave between c' b and 2 c' b (:func:`gears.excitation.rectangular_mesh_stiffness`,
    :func:`gears.iso6336.single_stiffness` with z_n ≈ z/cos³β and the low-load
    correction at F_s)."""
    if d["estimate"]:
        if d["mean"] is not None or d["amplitudes"]:
            raise SceneError("mesh_stiffness.estimate = true: remove mean_N_per_um and "
                             "amplitudes_N_per_um (they would be ignored)")
        if static_load <= 0:
            raise SceneError("load.torque_Nm = 0: mesh_stiffness.estimate needs a torque > 0")
        zn = approximate_virtual_teeth(gear.teeth, gear.helix_angle)
        single = single_stiffness((zn, zn), (gear.profile_shift, gear.profile_shift),
                                  gear.helix_angle, gear.pressure_angle, gear.face_width,
                                  c_m=d["cm"], static_load=static_load)
        return MeshStiffness(*rectangular_mesh_stiffness(single, gear.contact_ratio,
                                                         d["n_harmonics"]), estimated=True)
    if d["mean"] is None:
        raise SceneError("mesh_stiffness.mean_N_per_um: missing (give it, or estimate = true)")
    a, p = _harmonic_pairs("mesh_stiffness", d, "amplitudes_N_per_um", "phases_deg")
    ms = MeshStiffness(d["mean"], a, p)
    if ms.minimum() <= 0:
        raise SceneError(f"mesh_stiffness.amplitudes_N_per_um = "
                         f"{[x / 1e6 for x in a]}: their sum must be < mean_N_per_um = "
                         f"{ms.mean / 1e6:g} so that k_m(t) > 0")
    return ms


def _transmission_error(d: dict, ms: MeshStiffness, static_load: float) -> TransmissionError:
    """``[transmission_error]``: given harmonics, or the loaded STE of perfect teeth
    q_s = F_s / k_m(θ), as many harmonics as k_m (:func:`gears.excitation.perfect_teeth_ste`)."""
    if d["estimate"]:
        if d["amplitudes"] or d["mean"] != 0.0:
            raise SceneError("transmission_error.estimate = true: remove mean_um and "
                             "amplitudes_um (they would be ignored)")
        if d["kind"] != "loaded":
            raise SceneError(f"transmission_error.kind = {d['kind']!r}: the estimate is a "
                             "loaded STE (kind = 'loaded')")
        series = (ms.mean, ms.amplitudes, ms.phases)
        return TransmissionError(*perfect_teeth_ste(series, static_load,
                                                    max(len(ms.amplitudes), 1)),
                                 estimated=True, kind="loaded")
    a, p = _harmonic_pairs("transmission_error", d, "amplitudes_um", "phases_deg")
    return TransmissionError(d["mean"], a, p, kind=d["kind"])


def _lumped(lum: dict) -> LumpedData:
    """``[lumped]``: either the equivalent mass or the two inertias."""
    if lum["inertia"] is not None and len(lum["inertia"]) != 2:
        raise SceneError(f"lumped.inertia_kgm2 = {list(lum['inertia'])}: must be [I1, I2]")
    if lum["inertia"] is not None and lum["equivalent_mass"] is not None:
        raise SceneError("lumped.equivalent_mass_kg: give either equivalent_mass_kg or "
                         "inertia_kgm2, not both")
    return LumpedData(**lum)


def _hbm(h: dict, ms: MeshStiffness, te: TransmissionError, gear: GearData,
         external: ExternalData, kind: str = "lumped") -> HbmData:
    """``[hbm]``: an explicit harmonic set must hold 0, the excited mesh harmonics and
    the external shaft orders; a train takes its set from the meshes (``basis``), the
    one-pair scenes know no ``basis``."""
    hs = h["harmonics"]
    if kind in TRAIN_KINDS:
        if hs is not None:
            raise SceneError(f"hbm.harmonics = {list(hs)}: not for a train (scene.kind = "
                             f"{kind!r}); its set follows from hbm.mesh_harmonics, "
                             "hbm.basis and the meshes")
        if h["sideband_order"] != 0 and not external.present:
            raise SceneError(f"hbm.sideband_order = {h['sideband_order']}: a train without "
                             "shaft-order excitation ([[external.aero]], "
                             "[[external.unbalance]]) has no sidebands (omit it)")
        return HbmData(**h)
    if h["basis"] != "auto":
        raise SceneError(f"hbm.basis = {h['basis']!r}: only for a train (scene.kind = "
                         f"'train' or 'gearbox'); this scene has one fundamental")
    if hs is not None:
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
    if h["linear_solver"] == "krylov" and h["condensation"] != "loa":
        raise SceneError(f"hbm.linear_solver = 'krylov': needs hbm.condensation = 'loa' "
                         f"(got {h['condensation']!r})")
    return HbmData(**h)


def _continuation(c: dict) -> ContinuationData:
    """``[continuation]``: steps defaulted from the speed range and ordered."""
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
    return ContinuationData(c["speed"], step, min_step, max_step, c["tolerance"],
                            c["max_points"], c["checkpoint_every"],
                            c["period_doubling_depth"], c["period_doubling_max_points"])


def _outputs(o: dict, accel_raw: Any, speed: tuple[float, float]) -> OutputsData:
    """``[outputs]``: known plots, speeds inside the range (the housing's outputs are
    checked against the machine: :func:`_check_housing_outputs`)."""
    lo, hi = speed
    for p in o["plots"]:
        if p not in PLOT_NAMES:
            raise SceneError(f"outputs.plots: {p!r} is not a plot{suggest(p, PLOT_NAMES)}; "
                             f"allowed: {', '.join(PLOT_NAMES)}")
    for key in ("time_series", "housing_field"):
        for v in o[key]:
            if not lo <= v <= hi:
                raise SceneError(f"outputs.{key}_rpm = {list(o[key])}: {v:g} is outside "
                                 f"continuation.speed_rpm = [{lo:g}, {hi:g}]")
    return OutputsData(**o, accelerometers=_build_accelerometers(accel_raw))


def _fe_sections(raw: dict, kind: str) -> dict[str, dict]:
    """The free FE tables (copied): the pump's (scene.kind "fe") or the gearbox's; the
    machine checks them (:func:`_check_machine`)."""
    fe: dict[str, dict] = {}
    by_kind = {"fe": FE_SECTIONS, "gearbox": GEARBOX_SECTIONS}
    allowed = by_kind.get(kind, ())
    for s in (*FE_SECTIONS, *GEARBOX_SECTIONS):
        t = raw.get(s)
        if t is None or (s == "drive" and kind in TRAIN_KINDS) or s in fe:
            continue
        if s not in allowed:
            kinds = " or ".join(repr(k) for k, secs in by_kind.items() if s in secs)
            raise SceneError(f"[{s}]: only allowed when scene.kind = {kinds} (kind is "
                             f"{kind!r})")
        if not isinstance(t, dict):
            raise SceneError(f"[{s}] = {show(t)}: must be a table")
        fe[s] = copy.deepcopy(t)
    return fe


def _check_housing_outputs(scene: Scene, machine: Any) -> None:
    """Housing fields, field orders and accelerometers need a machine with a radiating part
    (:attr:`machines.base.Machine.radiating_part`: the pump's or the gearbox's housing)."""
    if machine.radiating_part is not None:
        return
    o = scene.outputs
    why = (f"the machine of scene.kind = {scene.scene.kind!r} has no radiating housing "
           "(an FE machine with one: scene.kind = 'fe' or 'gearbox')")
    if o.field_orders:
        raise SceneError(f"outputs.field_orders = {list(o.field_orders)}: only for a "
                         f"housing; {why}")
    if o.housing_field:
        raise SceneError(f"outputs.housing_field_rpm = {list(o.housing_field)}: only for "
                         f"a housing; {why}")
    if o.accelerometers:
        raise SceneError(f"outputs.accelerometer[0]: accelerometers need the housing; {why}")


def _check_machine(scene: Scene) -> Scene:
    """The scene's machine (:func:`machines.machine_for`) checks what the schema cannot
    see (the pump: its free FE sections, importing geometry and fem); its refusals are
    reported as :class:`SceneError` with their message."""
    from machines import machine_for

    try:
        machine = machine_for(scene)
        _check_housing_outputs(scene, machine)
        machine.check()
    except ImportError as exc:
        raise StageUnavailable(f"scene.kind = {scene.scene.kind!r} needs geometry/fem (gmsh, "
                               f"DOLFINx): {exc}") from exc
    except SceneError:
        raise
    except InputError as exc:
        raise SceneError(str(exc), field=exc.field, value=exc.value, unit=exc.unit,
                         allowed=exc.allowed) from exc
    return scene


def _check_sections(raw: Any) -> tuple[dict[str, dict], Any]:
    """Known sections only; each schema section checked. Returns the checked sections
    and the raw ``[[outputs.accelerometer]]`` list (checked with the outputs)."""
    if not isinstance(raw, dict):
        raise SceneError(f"scene = {show(raw)}: must be a TOML document (table)")
    check_known(raw, TOP_LEVEL, lambda key: f"[{key}]", what="section")
    raw_out = raw.get("outputs", {})
    accel_raw = []
    if isinstance(raw_out, dict) and "accelerometer" in raw_out:
        raw_out = dict(raw_out)
        accel_raw = raw_out.pop("accelerometer")
    sec = {s: check_table(s, raw_out if s == "outputs" else raw.get(s, {}), SCHEMA[s])
           for s in TOP_LEVEL if s not in ("external", "micro_geometry", *FE_SECTIONS,
                                               *GEARBOX_SECTIONS, *TRAIN_SECTIONS)}
    return sec, accel_raw


# --------------------------------------------------------------------------- gear trains

def _array(raw: dict, name: str) -> list:
    items = raw.get(name, [])
    if not isinstance(items, list) or not all(isinstance(t, dict) for t in items):
        raise SceneError(f"{name} = {show(items)}: must be an array of tables ([[{name}]])")
    return items


def _train_tables(raw: dict, kind: str) -> tuple:
    """``[[shafts]]`` (with ``[[shafts.bearings]]``), ``[[gears]]``, ``[[meshes]]`` (their
    ``mesh_stiffness``/``transmission_error`` subtables returned raw, checked once the
    static loads are known), ``[drive]`` and ``[[loads]]`` of a train scene; refused in
    any other scene, as are the one-pair sections in a train."""
    if kind not in TRAIN_KINDS:
        for s in TRAIN_SECTIONS:
            if s in raw:
                raise SceneError(f"[[{s}]]: only for a gear train (scene.kind = 'train' or "
                                 f"'gearbox'; kind is {kind!r})")
        return (), (), (), None, (), ()
    for s in PAIR_SECTIONS:
        if s in raw:
            raise SceneError(f"[{s}]: not in a gear train (scene.kind = {kind!r}): each "
                             "[[meshes]] has its own gears, backlash, mesh_stiffness and "
                             "transmission_error, [drive] the torque")
    shafts = []
    for i, t in enumerate(_array(raw, "shafts")):
        t = dict(t)
        bearings = t.pop("bearings", [])
        if not isinstance(bearings, list):
            raise SceneError(f"shafts[{i}].bearings = {show(bearings)}: must be an array of "
                             "tables ([[shafts.bearings]])")
        d = check_table(f"shafts[{i}]", t, SCHEMA["shafts"])
        b = tuple(BearingData(**check_table(f"shafts[{i}].bearings[{j}]", bt,
                                            SCHEMA["shafts.bearings"]))
                  for j, bt in enumerate(bearings))
        shafts.append(ShaftData(**d, bearings=b))
    if len(shafts) < 2:
        raise SceneError(f"shafts: {len(shafts)} [[shafts]]: a train needs at least two")
    gears = []
    for i, t in enumerate(_array(raw, "gears")):
        d = check_table(f"gears[{i}]", t, SCHEMA["gears"])
        if d["dedendum_coef"] <= d["addendum_coef"]:
            raise SceneError(f"gears[{i}].dedendum_coef = {d['dedendum_coef']:g}: must be > "
                             f"gears[{i}].addendum_coef = {d['addendum_coef']:g}")
        gears.append(TrainGearData(**d))
    meshes, subtables = [], []
    for i, t in enumerate(_array(raw, "meshes")):
        t = dict(t)
        sub = {k: t.pop(k) for k in ("mesh_stiffness", "transmission_error",
                                     "micro_geometry", "ltca") if k in t}
        d = check_table(f"meshes[{i}]", t, SCHEMA["meshes"])
        if len(d["gears"]) != 2:
            raise SceneError(f"meshes[{i}].gears = {list(d['gears'])}: must be two gear names "
                             "[driving, driven]")
        if "phase" in t and "phase_deg" in t:
            raise SceneError(f"meshes[{i}].phase_deg: give phase = 'geometry' or phase_deg, "
                             "not both")
        given = d.pop("phase")      # phase_deg's value (phase and phase_deg share the name)
        mode = "given" if "phase_deg" in t else "geometry"
        meshes.append(MeshData(name=d["name"], gears=tuple(d["gears"]), angle=d["angle"],
                               centre_distance=d["centre_distance"], backlash=d["backlash"],
                               phase_mode=mode, phase=given if mode == "given" else 0.0))
        subtables.append(sub)
    if "drive" not in raw:
        raise SceneError(f"[drive]: missing (scene.kind = {kind!r}: shaft and torque_Nm "
                         "where the torque enters)")
    drive = DriveData(**check_table("drive", raw["drive"], SCHEMA["train.drive"]))
    loads = tuple(TrainLoadData(**check_table(f"loads[{i}]", t, SCHEMA["loads"]))
                  for i, t in enumerate(_array(raw, "loads")))
    return tuple(shafts), tuple(gears), tuple(meshes), drive, loads, tuple(subtables)


def _series_table(where: str, table: Any, spec: str) -> dict:
    if not isinstance(table, dict):
        raise SceneError(f"[{where}] = {show(table)}: must be a table")
    return check_table(where, table, SCHEMA[spec])


def _train_mesh_stiffness(i: int, sub: dict, mesh: Any) -> MeshStiffness:
    """``[meshes.mesh_stiffness]``: given harmonics, or (omitted, or ``estimate = true``)
    the ISO 6336-1 estimate of the pair at its static load, as the one-pair scenes'
    :func:`_mesh_stiffness` (rectangular wave between c' b and 2 c' b)."""
    where = f"meshes[{i}].mesh_stiffness"
    d = _series_table(where, sub.get("mesh_stiffness", {"estimate": True}), "mesh_stiffness")
    if d["estimate"]:
        if d["mean"] is not None or d["amplitudes"]:
            raise SceneError(f"{where}.estimate = true: remove mean_N_per_um and "
                             "amplitudes_N_per_um (they would be ignored)")
        pair = mesh.pair
        zn = tuple(approximate_virtual_teeth(z, pair.helix_angle) for z in pair.teeth)
        single = single_stiffness(zn, pair.profile_shift, pair.helix_angle,
                                  pair.pressure_angle, pair.face_width, c_m=d["cm"],
                                  static_load=mesh.static_load)
        return MeshStiffness(*rectangular_mesh_stiffness(
            single, pair.transverse_contact_ratio, d["n_harmonics"]), estimated=True)
    if d["mean"] is None:
        raise SceneError(f"{where}.mean_N_per_um: missing (give it, or estimate = true, or "
                         "omit the table for the ISO 6336 estimate)")
    a, p = _harmonic_pairs(where, d, "amplitudes_N_per_um", "phases_deg")
    ms = MeshStiffness(d["mean"], a, p)
    if ms.minimum() <= 0:
        raise SceneError(f"{where}.amplitudes_N_per_um = {[x / 1e6 for x in a]}: their sum "
                         f"must be < mean_N_per_um = {ms.mean / 1e6:g} so that k_m(t) > 0")
    return ms


def _train_te(i: int, sub: dict, ms: MeshStiffness, static_load: float) -> TransmissionError:
    """``[meshes.transmission_error]``: as :func:`_transmission_error`, per mesh (omitted:
    no transmission error)."""
    where = f"meshes[{i}].transmission_error"
    d = _series_table(where, sub.get("transmission_error", {}), "transmission_error")
    if d["estimate"]:
        if d["amplitudes"] or d["mean"] != 0.0:
            raise SceneError(f"{where}.estimate = true: remove mean_um and amplitudes_um")
        if d["kind"] != "loaded":
            raise SceneError(f"{where}.kind = {d['kind']!r}: the estimate is a loaded STE")
        series = (ms.mean, ms.amplitudes, ms.phases)
        return TransmissionError(*perfect_teeth_ste(series, static_load,
                                                    max(len(ms.amplitudes), 1)),
                                 estimated=True, kind="loaded")
    a, p = _harmonic_pairs(where, d, "amplitudes_um", "phases_deg")
    return TransmissionError(d["mean"], a, p, kind=d["kind"])


def _train_mesh_source(i: int, sub: dict, mesh: Any, harmonics: int, base: Path | None
                       ) -> MeshSource | None:
    """``[meshes.mesh_stiffness] source`` / ``[meshes.transmission_error] source``: the
    ``ltca`` or ``table`` source of mesh ``i`` (:func:`study.scene.excitation.mesh_source`
    on the mesh's own pair, at its torque on gear 1 ``F_s r_b1``, with its
    ``[meshes.micro_geometry]`` and ``[meshes.ltca]``), or None when both are ``fourier``.
    A train takes the mesh-period series (pitch deviations: their synchronous average;
    ``ltca.hunting`` is for one-pair scenes)."""
    names = tuple(f"meshes[{i}].{k}" for k in ("mesh_stiffness", "transmission_error",
                                               "micro_geometry", "ltca"))
    ms_raw = sub.get("mesh_stiffness", {})
    te_raw = sub.get("transmission_error", {})
    ms = _series_table(names[0], ms_raw, "mesh_stiffness")
    te = _series_table(names[1], te_raw, "transmission_error")
    if not uses_other_source(ms, te):
        for key, where in (("micro_geometry", names[2]), ("ltca", names[3])):
            if sub.get(key):
                raise SceneError(f"[{where}]: used only with source = 'ltca' (in "
                                 f"[{names[0]}] or [{names[1]}])")
        return None
    lt = _series_table(names[3], sub.get("ltca", {}), "ltca")
    if lt["hunting"] and sub.get("ltca", {}).get("hunting") is True:
        raise SceneError(f"{names[3]}.hunting = true: not for a train yet (its meshes take "
                         "the mesh-period series; set it false or omit it)")
    lt = {**lt, "hunting": False}
    torque = mesh.static_load * mesh.pair.base_radii[0]
    return mesh_source(ms, te, ms_raw, te_raw, sub.get("micro_geometry"), lt,
                       pair=mesh.pair, torque=torque, harmonics=harmonics, base=base,
                       names=names)


def _with_train_meshes(scene: Scene, subtables: tuple, base: Path | None = None) -> Scene:
    """The train scene with each mesh's stiffness and TE (the ISO estimates need the static
    loads of the torque path: :class:`machines.train.layout.TrainLayout`, whose refusals
    become :class:`SceneError`); its one-pair fields ``gear``, ``mesh_stiffness``,
    ``transmission_error`` and ``load`` are those of the first mesh (gear 1, the drive
    torque), for outputs that label one pair."""
    from machines.train.layout import TrainLayout

    try:
        layout = TrainLayout.from_scene(scene)
    except SceneError:
        raise
    except InputError as exc:
        raise SceneError(str(exc), field=exc.field, value=exc.value, unit=exc.unit,
                         allowed=exc.allowed) from exc
    meshes = []
    for i, (m, lm) in enumerate(zip(scene.meshes, layout.meshes, strict=True)):
        src = _train_mesh_source(i, subtables[i], lm, scene.hbm.mesh_harmonics, base)
        ms = _train_mesh_stiffness(i, subtables[i], lm) if src is None or \
            src.stiffness == "fourier" else \
            MeshStiffness(*source_series(src, "stiffness"), estimated=True)
        if src is None or src.te == "fourier":
            te = _train_te(i, subtables[i], ms, lm.static_load)
        else:
            kind = "loaded" if src.te == "ltca" else \
                subtables[i].get("transmission_error", {}).get("kind", "loaded")
            te = TransmissionError(*source_series(src, "te"), estimated=True, kind=kind)
        meshes.append(dataclasses.replace(m, mesh_stiffness=ms, transmission_error=te,
                                          source=src))
    first = layout.meshes[0]
    g1 = layout.gear(first.gears[0])
    gear = GearData(teeth=g1.teeth, base_radius=g1.base_radius, module=g1.module,
                    pressure_angle=first.pair.working_pressure_angle,
                    helix_angle=first.pair.helix_angle, face_width=first.pair.face_width,
                    addendum_coef=g1.addendum_coef, dedendum_coef=g1.dedendum_coef,
                    profile_shift=g1.profile_shift, backlash=first.backlash)
    return dataclasses.replace(
        scene, meshes=tuple(meshes), gear=gear, mesh_stiffness=meshes[0].mesh_stiffness,
        transmission_error=meshes[0].transmission_error,
        load=LoadData(first.static_load * g1.base_radius))


# --------------------------------------------------------------------------- loading

def scene_from_dict(raw: dict, name: str = "scene", text: str = "",
                    base: Path | None = None) -> Scene:
    """Validate a parsed scene table and return the SI :class:`Scene`.

    Parameters
    ----------
    raw : dict
        The TOML document as parsed by :mod:`tomllib`.
    name : str
        Default scene name (the file stem) when ``[scene] name`` is absent.
    text : str
        The original file text, kept for records.
    base : Path, optional
        Folder the scene's relative file names (mesh tables) are read from (default: the
        working directory).

    Raises
    ------
    SceneError
        On any invalid field; the message names the field, its value and what is allowed.
    """
    try:
        return _scene_from_dict(raw, name, text, base)
    except (SceneError, StageUnavailable):
        raise
    except (TypeError, ValueError, ArithmeticError, KeyError) as exc:  # defensive: never leak
        raise SceneError(f"scene could not be validated: {exc}") from exc


def _mesh_excitation(sec: dict, raw: dict, gear: GearData, external: ExternalData,
                     base: Path | None
                     ) -> tuple[MeshStiffness, TransmissionError, MeshSource]:
    """k_m and TE of a pair scene whose ``[mesh_stiffness]`` or ``[transmission_error]``
    source is ``ltca`` or ``table`` (:mod:`study.scene.excitation`); a ``fourier`` one of
    the two is read as usual."""
    ms_d, te_d = sec["mesh_stiffness"], sec["transmission_error"]
    src = mesh_source(ms_d, te_d, raw.get("mesh_stiffness", {}),
                      raw.get("transmission_error", {}), raw.get("micro_geometry"),
                      sec["ltca"], pair=scene_pair(gear), torque=sec["load"]["torque"],
                      harmonics=set_mesh_harmonics(sec["hbm"], gear.teeth, external.present),
                      base=base)
    static_load = sec["load"]["torque"] / gear.base_radius
    if src.stiffness == "fourier":
        ms = _mesh_stiffness(ms_d, gear, static_load)
    else:
        ms = MeshStiffness(*source_series(src, "stiffness"), estimated=True,
                           cycles=src.cycles if src.stiffness == "ltca" else 1)
    if src.te == "fourier":
        te = _transmission_error(te_d, ms, static_load)
    else:
        kind = "loaded" if src.te == "ltca" else te_d["kind"]
        te = TransmissionError(*source_series(src, "te"), estimated=True, kind=kind,
                               cycles=src.cycles if src.te == "ltca" else 1)
    return ms, te, src


def _scene_from_dict(raw: dict, name: str, text: str, base: Path | None = None) -> Scene:
    sec, accel_raw = _check_sections(raw)
    info = SceneInfo(**{**sec["scene"], "name": sec["scene"]["name"] or name})
    check_required_sections(raw, info.kind)
    shafts, gears, meshes, drive, loads, subtables = _train_tables(raw, info.kind)
    train = info.kind in TRAIN_KINDS
    gear = _build_gear(sec["gear"])
    static_load = sec["load"]["torque"] / gear.base_radius
    source = None
    if train:   # the first mesh's, filled in by _with_train_meshes
        if uses_other_source(sec["mesh_stiffness"], sec["transmission_error"]) \
                or raw.get("micro_geometry"):
            raise SceneError("[mesh_stiffness] / [transmission_error] source and "
                             "[micro_geometry]: not yet for a gear train (scene.kind = "
                             f"{info.kind!r}); give each [[meshes]] its Fourier series or "
                             "the ISO 6336 estimate")
        ms, te = MeshStiffness(1.0, (), ()), TransmissionError(0.0, (), ())
        external = _build_external(raw.get("external"), info.kind)
    elif uses_other_source(sec["mesh_stiffness"], sec["transmission_error"]):
        external = _build_external(raw.get("external"), info.kind)
        ms, te, source = _mesh_excitation(sec, raw, gear, external, base)
    else:
        if raw.get("micro_geometry"):
            raise SceneError("[micro_geometry]: used only with source = 'ltca' (in "
                             "[mesh_stiffness] or [transmission_error])")
        for where in ("mesh_stiffness", "transmission_error"):
            check_source_keys(where, sec[where], raw.get(where, {}))
        ms = _mesh_stiffness(sec["mesh_stiffness"], gear, static_load)
        te = _transmission_error(sec["transmission_error"], ms, static_load)
        external = _build_external(raw.get("external"), info.kind)
    lumped = _lumped(sec["lumped"])
    rom = RomData(**sec["rom"])
    hbm = _hbm(sec["hbm"], ms, te, gear, external, info.kind)
    cont = _continuation(sec["continuation"])
    outputs = _outputs(sec["outputs"], accel_raw, sec["continuation"]["speed"])
    fe = _fe_sections(raw, info.kind)
    scene = Scene(info, gear, ms, te, LoadData(**sec["load"]), external,
                  DampingData(**sec["damping"]), lumped, rom, hbm, cont, outputs,
                  fe, copy.deepcopy(raw), text, AcousticsData(**sec["acoustics"]),
                  {k: v.strip() for k, v in sec["calibration"].items() if v.strip()},
                  source, shafts, gears, meshes, drive, loads)
    if train:
        scene = _with_train_meshes(scene, subtables, base)
    return check_plausibility(resolve_rom(_check_machine(scene)))


def parse_scene(text: str, name: str = "scene") -> Scene:
    """Parse and validate TOML text (see :func:`scene_from_dict`)."""
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"scene file is not valid TOML: {exc}") from exc
    return scene_from_dict(raw, name, text)


def _read(p: Path) -> tuple[dict, str]:
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as exc:
        raise SceneError(f"scene file {str(p)!r}: cannot be read ({exc.strerror})") from exc
    try:
        return tomllib.loads(text), text
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"scene file {str(p)!r} is not valid TOML: {exc}") from exc


def _merged(base: dict, top: dict) -> dict:
    """``top`` over ``base``: tables merge key by key, anything else (values, arrays of
    tables such as ``[[external.aero]]``) is replaced whole."""
    out = copy.deepcopy(base)
    for key, val in top.items():
        if isinstance(val, dict) and isinstance(out.get(key), dict):
            out[key] = _merged(out[key], val)
        else:
            out[key] = copy.deepcopy(val)
    return out


def _resolve(p: Path, chain: tuple[Path, ...] = ()) -> tuple[dict, str]:
    """Raw table and record text of scene file ``p`` with its ``[scene] extends`` chain
    (a path relative to the file) applied: the file's keys over its base's."""
    raw, text = _read(p)
    info = raw.get("scene", {})
    base = info.pop("extends", None) if isinstance(info, dict) else None
    if base is None:
        return raw, text
    if not isinstance(base, str) or not base:
        raise SceneError(f"scene.extends = {base!r}: must be the path of a scene file, "
                         "relative to this one")
    bp = (p.parent / base).resolve()
    if bp in chain or bp == p.resolve() or len(chain) > 8:
        raise SceneError(f"scene.extends = {base!r} in {str(p)!r}: circular or deeper than "
                         "8 files")
    if not bp.is_file():
        raise SceneError(f"scene.extends = {base!r} in {str(p)!r}: no such file {str(bp)!r}")
    base_raw, base_text = _resolve(bp, (*chain, p.resolve()))
    return _merged(base_raw, raw), f"{text}\n# ---- scene.extends = {base!r}: ----\n{base_text}"


def load_scene(path: str | Path, overrides: dict[str, Any] | None = None) -> Scene:
    """Read, override (``{"section.key": value}``) and validate a scene file.

    ``[scene] extends = "base.toml"`` (relative to the file) reads that scene first and
    puts this file's keys over it: tables merge key by key, values and arrays of tables
    (``[[external.aero]]``) are replaced whole. The record text holds both files.

    Raises
    ------
    SceneError
        File missing/unreadable, invalid TOML, a bad ``extends``, or any invalid field.
    """
    p = Path(path)
    raw, text = _resolve(p)
    if overrides:
        raw = apply_overrides(raw, overrides)
    return scene_from_dict(raw, p.stem, text, p.resolve().parent)


def resolved_table(path: str | Path, overrides: dict[str, Any] | None = None) -> dict:
    """The raw TOML table of scene file ``path`` as :func:`load_scene` reads it (its
    ``extends`` chain merged, ``overrides`` applied), not validated.

    Raises
    ------
    SceneError
        File missing/unreadable, invalid TOML, a bad ``extends`` or override path.
    """
    raw, _ = _resolve(Path(path))
    return apply_overrides(raw, overrides) if overrides else raw
