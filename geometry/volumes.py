"""Analytic volumes of the parts, from their parameters (for checks and tests)."""

from __future__ import annotations

import math

from .params import DEFAULT_CENTRE_DISTANCE, HousingParams, PumpParams, ShaftParams


def shaft_volume(params: ShaftParams) -> float:
    """Volume of a stepped shaft [m³]: sum of ``π r² L`` over its segments."""
    return sum(math.pi * r * r * (z1 - z0) for z0, z1, r, _ in params.segments())


def housing_volume(params: HousingParams,
                   centre_distance: float = DEFAULT_CENTRE_DISTANCE) -> float:
    """Volume of the housing [m³].

    Outer box minus cavity, plus four bosses, minus four bores (through wall
    and boss), plus four feet and the ribs. Valid for parameters that pass
    ``params.validate(centre_distance)`` (no overlaps between these features).
    """
    params.validate(centre_distance)
    p = params
    t = p.wall_thickness
    box = p.length_x * p.height_y * p.length_z
    cavity = (p.length_x - 2 * t) * (p.height_y - 2 * t) * (p.length_z - 2 * t)
    bosses = 4 * math.pi * p.boss_radius ** 2 * p.boss_length
    bores = 4 * math.pi * p.bore_radius ** 2 * p.bore_length
    feet = 4 * p.foot_width * p.foot_height * p.foot_depth
    ribs = p.rib_count * p.length_x * p.rib_height * p.rib_thickness
    return box - cavity + bosses - bores + feet + ribs


def part_volumes(params: PumpParams) -> dict[str, float]:
    """Analytic volume of each part of the pump [m³], keyed by volume group name."""
    return {
        "shaft_in": shaft_volume(params.shaft_in),
        "shaft_out": shaft_volume(params.shaft_out),
        "housing": housing_volume(params.housing, params.centre_distance),
    }
