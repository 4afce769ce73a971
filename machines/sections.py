"""The free FE sections of a scene (``[mesh]``, ``[materials]``, ``[housing]``, ...) ->
keyword arguments of the FE packages' parameter dataclasses, for every FE machine.

Keys are the dataclass field names in SI units, or the field name with a unit suffix of
:data:`core.units.FE_SUFFIXES` (``wall_thickness_mm = 8``, ``shaft_E_GPa = 210``,
``radial_N_per_um = 100``). Bad values raise :class:`FEParameterError` (a
:class:`core.errors.InputError`) naming the key.
"""
from __future__ import annotations

import dataclasses
import math
from typing import Any

from core.errors import InputError, suggest
from core.units import FE_SUFFIXES, TO_SI

__all__ = ["FEParameterError", "convert_section"]


class FEParameterError(InputError):
    """A refused key or value of the pump's FE sections (the message names it)."""


def convert_section(section: str, table: dict, cls: type, nested: dict[str, type] | None = None,
             skip: tuple[str, ...] = ()) -> dict:
    """Scene table ``[section]`` -> keyword arguments of the dataclass ``cls``: keys are
    its field names in SI or with a unit suffix of :data:`core.units.FE_SUFFIXES`
    (converted), values checked against the fields' defaults' types; ``nested`` maps a
    key to the dataclass of its sub-table, ``skip`` lists keys left out. Raises
    :class:`FEParameterError` naming ``section.key``."""
    names = [f.name for f in dataclasses.fields(cls)]
    defaults = {f.name: f.default for f in dataclasses.fields(cls)
                if f.default is not dataclasses.MISSING}
    nested = nested or {}
    out: dict[str, Any] = {}
    for key, val in table.items():
        if key in skip:
            continue
        if key in nested:
            if not isinstance(val, dict):
                raise FEParameterError(f"{section}.{key} = {val!r}: must be a table "
                                 f"([{section}.{key}])")
            out[key] = nested[key](**convert_section(f"{section}.{key}", val, nested[key]))
            continue
        field, factor = key, 1.0
        if key not in names:
            for suf in sorted(FE_SUFFIXES, key=len, reverse=True):
                f = TO_SI[suf]
                if key.endswith("_" + suf) and key[: -len(suf) - 1] in names:
                    field, factor = key[: -len(suf) - 1], f
                    break
        if field not in names:
            allowed = [n for n in names if n not in skip] + list(nested)
            raise FEParameterError(f"{section}.{key}: unknown key{suggest(key, allowed)}; allowed: "
                             f"{', '.join(allowed)} (SI, or with a unit suffix "
                             f"{', '.join('_' + s for s in FE_SUFFIXES)})")
        if isinstance(val, bool) or not isinstance(val, (int, float, str, list)):
            raise FEParameterError(f"{section}.{key} = {val!r}: must be a number, string or list")
        if factor != 1.0:
            if isinstance(val, list):
                if not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in val):
                    raise FEParameterError(f"{section}.{key} = {val!r}: must be numbers")
                val = tuple(v * factor for v in val)
            elif isinstance(val, (int, float)):
                val = val * factor
            else:
                raise FEParameterError(f"{section}.{key} = {val!r}: must be a number")
        elif isinstance(val, list):
            val = tuple(val)
        if isinstance(val, float) and not math.isfinite(val):
            raise FEParameterError(f"{section}.{key} = {val!r}: must be finite")
        default = defaults.get(field)
        if isinstance(default, (int, float)) and not isinstance(default, bool):
            if isinstance(val, bool) or not isinstance(val, (int, float)):
                raise FEParameterError(f"{section}.{key} = {val!r}: must be a number")
            if isinstance(default, int) and not isinstance(default, bool) and \
                    not (isinstance(val, int) or float(val).is_integer()):
                raise FEParameterError(f"{section}.{key} = {val!r}: must be an integer")
            val = type(default)(val) if isinstance(default, int) else float(val)
        elif isinstance(default, str) and not isinstance(val, str):
            raise FEParameterError(f"{section}.{key} = {val!r}: must be a string")
        out[field] = val
    return out
