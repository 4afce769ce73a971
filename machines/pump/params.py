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

from dataclasses import dataclass
from typing import Any

from machines.sections import FEParameterError, convert_section

__all__ = ["FEParams", "FEParameterError", "fe_parameters"]


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
        g = convert_section("geometry", fe.get("geometry", {}), geometry.PumpParams,
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
        opts = geometry.preset(name, **convert_section("mesh", m, geometry.MeshOptions))
        opts.validate()
        mats = fem.MaterialParams(**convert_section("materials", fe.get("materials", {}),
                                             fem.MaterialParams))
        if "seat_link" in fe.get("bearings", {}):
            raise FEParameterError("bearings.seat_link: set the journal-seat link kind as "
                             "links.journal ('rigid' or 'distributing')")
        bear = fem.BearingParams(**convert_section("bearings", fe.get("bearings", {}),
                                            fem.BearingParams))
        drive = fem.DriveParams(**convert_section("drive", fe.get("drive", {}), fem.DriveParams))
        rotors = fem.RotorParams(**convert_section("rotors", fe.get("rotors", {}), fem.RotorParams))
        links = fem.LinkParams(**convert_section("links", fe.get("links", {}), fem.LinkParams))
        gears = fem.GearParams(base_radius_1=gear.base_radius, base_radius_2=gear.base_radius,
                               pressure_angle=gear.pressure_angle, helix_angle=gear.helix_angle,
                               face_width=gear.face_width, outer_radius=gear.tip_radius)
    except FEParameterError:
        raise
    except (TypeError, ValueError) as exc:  # the dataclasses' own checks
        raise FEParameterError(f"FE parameters: {exc}") from exc
    gears, bear = links.apply(gears, bear)
    return FEParams(pump, opts, mats, bear, drive, gears, rotors, links)
