"""Scene files: the public face of the scene layers of :mod:`study`.

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
:mod:`study.scene_schema` (the :class:`Spec` table) → :mod:`study.scene_check` (the
checker) → :mod:`study.scene_data` (the frozen dataclasses) → :mod:`study.scene_overrides`
(``--set``) → :mod:`study.scene_load` (validation and loading; the ISO 6336 and STE
estimates come from :mod:`gears`). This module re-exports their
public names; code inside :mod:`study` imports from the module that holds a name.
"""
from __future__ import annotations

from study.errors import SceneError, StageUnavailable
from study.scene_data import (
    Accelerometer,
    AcousticsData,
    AeroLoad,
    ContinuationData,
    DampingData,
    ExternalData,
    FourierSeries,
    GearData,
    HbmData,
    LoadData,
    LumpedData,
    MeshStiffness,
    OutputsData,
    RomData,
    Scene,
    SceneInfo,
    TransmissionError,
    Unbalance,
)
from study.scene_load import load_scene, parse_scene, scene_from_dict
from study.scene_overrides import apply_overrides, parse_set_values
from study.scene_schema import FE_SECTIONS, PLOT_NAMES, SCHEMA, Spec, schema_markdown

__all__ = [
    "SceneError", "Scene", "SceneInfo", "GearData", "MeshStiffness", "TransmissionError",
    "LoadData", "AeroLoad", "Unbalance", "ExternalData", "DampingData", "LumpedData",
    "RomData", "HbmData", "ContinuationData", "OutputsData", "AcousticsData", "Accelerometer",
    "load_scene",
    "parse_scene",
    "scene_from_dict", "apply_overrides", "SCHEMA", "FE_SECTIONS", "PLOT_NAMES",
    "FourierSeries", "Spec", "StageUnavailable", "schema_markdown", "parse_set_values",
]
