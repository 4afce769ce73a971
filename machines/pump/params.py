"""The pump's free scene sections -> the FE packages' parameter dataclasses.

``[geometry]``, ``[mesh]``, ``[materials]``, ``[bearings]``, ``[drive]``, ``[rotors]``
and ``[links]`` become :class:`geometry.PumpParams`, :class:`geometry.MeshOptions`,
:class:`fem.MaterialParams`, :class:`fem.BearingParams`, :class:`fem.DriveParams`,
:class:`fem.RotorParams`, :class:`fem.LinkParams` and :class:`fem.GearParams`
(:func:`fe_parameters`; ``[links]`` sets ``GearParams.hub_link`` and
``BearingParams.seat_link``). Keys
are the dataclass field names in SI units, or the field name with a unit suffix of
:data:`core.units.FE_SUFFIXES` (``wall_thickness_mm = 8``, ``shaft_E_GPa = 210``,
``radial_N_per_um = 100``). geometry and fem are imported inside
:func:`fe_parameters`, so importing this module loads neither. Bad values raise
:class:`FEParameterError` (a :class:`core.errors.InputError`) naming the key.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

from core.errors import InputError, suggest
from core.units import FE_SUFFIXES, TO_SI

__all__ = ["FEParams", "FEParameterError", "fe_parameters"]


class FEParameterError(InputError):
    """A refused key or value of the pump's FE sections (the message names it)."""


@dataclass(frozen=True)
class FEParams:
    """Parameter dataclasses of the FE packages for one scene."""

    pump: Any
    mesh: Any
    materials: Any
    bearings: Any
    drive: Any
    gears: Any
    rotors: Any
    links: Any = None


def _convert(section: str, table: dict, cls: type, nested: dict[str, type] | None = None,
             skip: tuple[str, ...] = ()) -> dict:
    """Scene table -> keyword arguments of ``cls`` (unit suffixes converted)."""
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
            out[key] = nested[key](**_convert(f"{section}.{key}", val, nested[key]))
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


def fe_parameters(fe: dict[str, dict], gear) -> FEParams:
    """Build and validate the FE parameter dataclasses (raises :class:`FEParameterError`).

    ``[geometry]`` holds :class:`geometry.PumpParams` fields with nested tables
    ``[geometry.housing]``, ``[geometry.shaft_in]``, ``[geometry.shaft_out]``;
    the centre distance, gear tip radius and gear width default to the ``[gear]``
    values. ``[mesh]`` holds ``preset`` (default ``"coarse"``) and
    :class:`geometry.MeshOptions` overrides.
    """
    import fem
    import geometry
    try:
        g = _convert("geometry", fe.get("geometry", {}), geometry.PumpParams,
                     {"housing": geometry.HousingParams, "shaft_in": geometry.ShaftParams,
                      "shaft_out": geometry.ShaftParams})
        g.setdefault("centre_distance", gear.centre_distance)
        g.setdefault("gear_tip_radius", gear.tip_radius)
        g.setdefault("gear_width", gear.face_width)
        pump = geometry.PumpParams(**g)
        pump.validate()
        m = dict(fe.get("mesh", {}))
        name = m.pop("preset", "coarse")
        if not isinstance(name, str):
            raise FEParameterError(f"mesh.preset = {name!r}: must be a string ('coarse', 'fine' "
                             "or 'million')")
        opts = geometry.preset(name, **_convert("mesh", m, geometry.MeshOptions))
        opts.validate()
        mats = fem.MaterialParams(**_convert("materials", fe.get("materials", {}),
                                             fem.MaterialParams))
        if "seat_link" in fe.get("bearings", {}):
            raise FEParameterError("bearings.seat_link: set the journal-seat link kind as "
                             "links.journal ('rigid' or 'distributing')")
        bear = fem.BearingParams(**_convert("bearings", fe.get("bearings", {}),
                                            fem.BearingParams))
        drive = fem.DriveParams(**_convert("drive", fe.get("drive", {}), fem.DriveParams))
        rotors = fem.RotorParams(**_convert("rotors", fe.get("rotors", {}), fem.RotorParams))
        links = fem.LinkParams(**_convert("links", fe.get("links", {}), fem.LinkParams))
        gears = fem.GearParams(base_radius_1=gear.base_radius, base_radius_2=gear.base_radius,
                               pressure_angle=gear.pressure_angle, helix_angle=gear.helix_angle,
                               face_width=gear.face_width, outer_radius=gear.tip_radius)
    except FEParameterError:
        raise
    except (TypeError, ValueError) as exc:  # the dataclasses' own checks
        raise FEParameterError(f"FE parameters: {exc}") from exc
    gears, bear = links.apply(gears, bear)
    return FEParams(pump, opts, mats, bear, drive, gears, rotors, links)
