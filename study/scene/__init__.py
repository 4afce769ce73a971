"""Scene files (``study.scene``): the scene's schema, checker, data, ``--set`` and loader.

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

The work is done by modules that import one way (docs/architecture.md):
:mod:`study.scene.errors` (:class:`SceneError`, :class:`StageUnavailable`) →
:mod:`study.scene.schema` (the :class:`Spec` table) → :mod:`study.scene.check` (the
checker) → :mod:`study.scene.data` (the frozen dataclasses) → :mod:`study.scene.overrides`
(``--set``) → :mod:`study.scene.load` (validation and loading; the ISO 6336 and STE
estimates come from :mod:`gears`). This ``__init__`` is the scene API for users: it
re-exports their public names and defines nothing; code inside :mod:`study` imports a
name from the module that holds it.
"""
from __future__ import annotations

from study.scene.data import (
    Accelerometer,
    AcousticsData,
    AeroLoad,
    BearingData,
    ContinuationData,
    DampingData,
    DriveData,
    ExternalData,
    FourierSeries,
    GearData,
    HbmData,
    LoadData,
    LumpedData,
    MeshData,
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
from study.scene.load import load_scene, parse_scene, scene_from_dict
from study.scene.overrides import apply_overrides, parse_set_values
from study.scene.schema import FE_SECTIONS, PLOT_NAMES, SCHEMA, Spec, schema_markdown

__all__ = [
    "SceneError", "Scene", "SceneInfo", "GearData", "MeshStiffness", "TransmissionError",
    "LoadData", "AeroLoad", "Unbalance", "ExternalData", "DampingData", "LumpedData",
    "RomData", "HbmData", "ContinuationData", "OutputsData", "AcousticsData", "Accelerometer",
    "ShaftData", "BearingData", "TrainGearData", "MeshData", "DriveData", "TrainLoadData",
    "load_scene",
    "parse_scene",
    "scene_from_dict", "apply_overrides", "SCHEMA", "FE_SECTIONS", "PLOT_NAMES",
    "FourierSeries", "Spec", "StageUnavailable", "schema_markdown", "parse_set_values",
]
