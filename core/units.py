"""The one unit table of scene files: key suffix -> factor to SI.

Scene keys carry their unit as a suffix (``backlash_um``, ``torque_Nm``); the schema of
:mod:`study.scene.schema` names each field's unit from :data:`TO_SI`, and the free FE
sections (:mod:`machines.pump.params`) accept the suffixes :data:`FE_SUFFIXES` on the
FE packages' dataclass fields. The factors live here, in the bottom layer, so that every
package converts with the same table (SI inside the code).
"""
from __future__ import annotations

import math

__all__ = ["TO_SI", "FE_SUFFIXES"]

TO_SI = {  # suffix -> factor to SI
    "mm": 1e-3, "um": 1e-6, "deg": math.pi / 180.0, "rpm": 1.0, "Nm": 1.0, "N": 1.0,
    "GPa": 1e9, "MPa": 1e6, "N_per_um": 1e6, "N_per_m": 1.0, "kgm": 1.0, "kg": 1.0,
    "kgm2": 1.0, "kg_per_m3": 1.0, "Hz": 1.0, "m_per_s": 1.0, "Nm_per_rad": 1.0, "": 1.0,
}

#: Suffixes allowed on the FE sections' SI field names (``wall_thickness_mm``), in the
#: order error messages list them; their factors are those of :data:`TO_SI`.
FE_SUFFIXES = ("mm", "um", "GPa", "MPa", "deg", "N_per_um", "kgm2", "kg")
