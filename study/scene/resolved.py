"""The scene as run: the file after ``extends``, ``--set`` and API overrides, with every
default filled in, as a table that loads back into the same scene.

:func:`resolved_table` keeps the keys as the file writes them (with their unit suffix,
in the file's units) and adds every key the file left to its default; a default that
the loader derives (``gear.module_mm``, the continuation steps) is written with the
derived value. The FE sections keep their given keys and gain the FE parameter
dataclasses' other fields in SI (the machine's :attr:`params`, when it has them).
:func:`derived_quantities` lists what the loader computed from them (static load, the
mesh stiffness and TE series actually used, contact ratio). results.h5 stores both as
JSON (``/scene/resolved``, ``/scene/derived``, docs/results-format.md).
"""
from __future__ import annotations

import copy
import dataclasses
import json
import math
from typing import Any

from core.units import FE_SUFFIXES
from study.scene.data import Scene
from study.scene.schema import (
    FE_SECTIONS,
    GEARBOX_SECTIONS,
    PAIR_SECTIONS,
    SCHEMA,
    TOP_LEVEL,
    TRAIN_KINDS,
    TRAIN_SECTIONS,
    Spec,
)

__all__ = ["resolved_table", "derived_quantities", "resolved_json"]

#: FE section -> field of the machine's FE parameter set that holds its dataclass
_FE_PARAMS = {"geometry": "pump", "mesh": "mesh", "materials": "materials",
              "bearings": "bearings", "drive": "drive", "rotors": "rotors", "links": "links"}
#: dataclass fields the scene does not take in that section (set through another key)
_FE_SKIP = {"bearings": ("seat_link",), "mesh": ("name",)}


def _plain(v: Any) -> Any:
    """JSON-able copy: tuples as lists, dataclass fields recursively."""
    if isinstance(v, (list, tuple)):
        return [_plain(x) for x in v]
    if isinstance(v, dict):
        return {k: _plain(x) for k, x in v.items()}
    return v


def _filled(given: dict, specs: dict[str, Spec]) -> dict:
    """``given`` with every key of ``specs`` it lacks at its (non-None) default."""
    out = {k: _plain(v) for k, v in given.items()}
    for key, spec in specs.items():
        if key not in out and spec.default is not None:
            out[key] = _plain(spec.default)
    return out


def _derived_defaults(scene: Scene, table: dict) -> None:
    """Fill the keys whose default the loader derives (in place)."""
    c = table["continuation"]
    if "gear" in table:
        table["gear"].setdefault("module_mm", scene.gear.module * 1e3)
    c.setdefault("step_rpm", scene.continuation.step)
    c.setdefault("min_step_rpm", scene.continuation.min_step)
    c.setdefault("max_step_rpm", scene.continuation.max_step)
    table["scene"]["name"] = scene.name


def _fe_defaults(section: str, given: dict, obj: Any) -> dict:
    """A free FE table with the other fields of its dataclass ``obj`` in SI."""
    out = _plain(copy.deepcopy(given))
    if not dataclasses.is_dataclass(obj):
        return out
    for f in dataclasses.fields(obj):
        if f.name in _FE_SKIP.get(section, ()):
            continue
        val = getattr(obj, f.name)
        if val is None:             # "derived" in the dataclass: left to it
            continue
        if dataclasses.is_dataclass(val):
            out[f.name] = _fe_defaults(f"{section}.{f.name}", given.get(f.name, {}), val)
            continue
        if not any(k in given for k in (f.name, *(f"{f.name}_{s}" for s in FE_SUFFIXES))):
            out[f.name] = _plain(val)
    return out


def resolved_table(scene: Scene, fe_params: Any = None) -> dict:
    """The scene table as run (loads back with :func:`study.scene.load.scene_from_dict`).

    Parameters
    ----------
    scene
        The validated scene (its ``raw`` is the file after ``extends`` and overrides).
    fe_params
        The machine's FE parameter set (``machines.pump.FEParams``), whose dataclass
        fields fill the FE sections' defaults; None: the FE sections as given.
    """
    raw = scene.raw
    out: dict[str, Any] = {}
    train = scene.scene.kind in TRAIN_KINDS
    for sec in TOP_LEVEL:
        if (train and sec in PAIR_SECTIONS) or (sec in TRAIN_SECTIONS and sec not in raw):
            continue                              # refused in a train / only in a train
        if train and sec == "drive":
            out[sec] = _filled(raw.get(sec, {}), SCHEMA["train.drive"])
            continue
        if sec in GEARBOX_SECTIONS and (scene.scene.kind != "fe" or sec not in FE_SECTIONS):
            if sec in raw:                        # the gearbox's free tables, as given
                out[sec] = _plain(copy.deepcopy(raw[sec]))
            continue
        if sec in FE_SECTIONS:
            pump = scene.scene.kind == "fe"       # the pump's FEParams fill its defaults
            if sec in raw or (pump and fe_params is not None and sec in _FE_PARAMS):
                obj = getattr(fe_params, _FE_PARAMS[sec], None) \
                    if pump and fe_params is not None else None
                out[sec] = _fe_defaults(sec, raw.get(sec, {}), obj)
                if sec == "mesh":
                    out[sec].setdefault("preset", "coarse")      # machines.pump.params
            continue
        if sec == "external":
            ext = raw.get("external", {})
            if train and not ext:
                continue
            out["external"] = {name: [_filled(item, SCHEMA[f"external.{name}"])
                                      for item in ext.get(name, [])]
                               for name in ("aero", "unbalance")}
            continue
        if isinstance(raw.get(sec), list):        # an array of tables
            out[sec] = [_filled(item, SCHEMA.get(sec, {})) for item in raw[sec]]
            continue
        if sec not in SCHEMA:                     # a section without a flat spec table
            if sec in raw:
                out[sec] = _plain(copy.deepcopy(raw[sec]))
            continue
        given = dict(raw.get(sec, {}))
        accel = given.pop("accelerometer", None) if sec == "outputs" else None
        # the calibration's rows, and a series an ltca/table source gives: as given (the
        # loader refuses or ignores their other keys)
        as_given = sec == "calibration" or given.get("source", "fourier") != "fourier"
        out[sec] = _plain(given) if as_given else _filled(given, SCHEMA[sec])
        if accel:
            out[sec]["accelerometer"] = [_filled(a, SCHEMA["outputs.accelerometer"])
                                         for a in accel]
    for sec in raw:                               # anything the loop above does not know
        out.setdefault(sec, _plain(copy.deepcopy(raw[sec])))
    if scene.scene.kind != "lumped":
        out.pop("lumped", None)
    _derived_defaults(scene, out)
    return out


def derived_quantities(scene: Scene) -> dict:
    """What the loader computed from the inputs (SI): static load, the mesh stiffness and
    transmission error series used (estimated or given), module, contact ratio; for an FE
    scene the highest excitation frequency and the component-mode cut-off derived from it
    (``rom``, :func:`study.scene.frequency.resolve_rom`)."""
    def series(s) -> dict:
        return {"mean": s.mean, "amplitudes": list(s.amplitudes), "phases": list(s.phases),
                "estimated": s.estimated}
    te = series(scene.transmission_error)
    te["kind"] = scene.transmission_error.kind
    r = scene.rom
    rom = {} if r.check_hz is None else {"rom": {
        "highest_excitation_Hz": r.check_hz, "cutoff_Hz": r.cutoff, "n_cm": r.n_cm,
        "cutoff_from_factor": r.auto}}
    if getattr(scene, "is_train", False):
        return {**rom, "meshes": [{"name": m.name, "backlash_m": m.backlash,
                            "mesh_stiffness_N_per_m": series(m.mesh_stiffness)
                            if m.mesh_stiffness is not None else None,
                            "transmission_error_m": series(m.transmission_error)
                            if m.transmission_error is not None else None}
                           for m in scene.meshes],
                "speed_rpm": list(scene.continuation.speed), "phases_unit": "rad"}
    return {**rom, "static_load_N": scene.static_load, "module_m": scene.gear.module,
            "pitch_radius_m": scene.gear.pitch_radius,
            "contact_ratio": scene.gear.contact_ratio,
            "mesh_stiffness_N_per_m": series(scene.mesh_stiffness),
            "transmission_error_m": te,
            "speed_rpm": list(scene.continuation.speed),
            "phases_unit": "rad"}


def resolved_json(scene: Scene, fe_params: Any = None) -> tuple[str, str]:
    """(resolved table, derived quantities) as JSON text (sorted keys, 2-space indent)."""
    def dump(x) -> str:
        return json.dumps(x, indent=2, sort_keys=True, ensure_ascii=False,
                          default=lambda v: None if isinstance(v, float) and
                          not math.isfinite(v) else str(v))
    return dump(resolved_table(scene, fe_params)), dump(derived_quantities(scene))
