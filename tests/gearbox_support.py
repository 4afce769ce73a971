"""The small two-stage gearbox of the tests (23:61 then 19:67, m = 2 mm) as
geometry.GearboxParams (not collected by pytest)."""

from __future__ import annotations

from geometry import GearboxParams, GearboxShaftParams, GearSeatParams, JournalParams

MODULE = 0.002


def tip(z: int) -> float:
    """Tip radius of a standard gear of ``z`` teeth at module 2 mm [m]."""
    return MODULE * (z + 2) / 2


def two_stage(**housing: object) -> GearboxParams:
    """Three shafts on y = 0 at x = 0, 84, 170 mm, bearings at 20 and 140 mm."""
    from geometry import GearboxHousingParams

    def bearings() -> tuple[JournalParams, JournalParams]:
        return (JournalParams(0.020), JournalParams(0.140))

    shafts = (
        GearboxShaftParams("in", (0.0, 0.0), 0.160, 0.0125, bearings(),
                           (GearSeatParams("p1", 0.060, 0.020, tip(23)),)),
        GearboxShaftParams("mid", (0.084, 0.0), 0.160, 0.015, bearings(),
                           (GearSeatParams("w1", 0.060, 0.020, tip(61)),
                            GearSeatParams("p2", 0.105, 0.025, tip(19)))),
        GearboxShaftParams("out", (0.170, 0.0), 0.160, 0.020, bearings(),
                           (GearSeatParams("w2", 0.105, 0.025, tip(67)),)),
    )
    return GearboxParams(shafts, GearboxHousingParams(**housing))
