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


# ---------------------------------------------------------------- a scene, by attribute
# The train sections as study.scene.data holds them (SI), for machine tests that do not
# go through a scene file.

from dataclasses import dataclass, field  # noqa: E402


@dataclass(frozen=True)
class Bearing:
    position: float
    radial: float = 2.0e8
    axial: float = 5.0e7
    bore_link: str = "housing"
    journal_link: str = "housing"


@dataclass(frozen=True)
class ShaftRow:
    name: str
    length: float
    diameter: float
    bearings: tuple
    inertia: float = 0.0
    torsional_stiffness: float | None = None


@dataclass(frozen=True)
class GearRow:
    name: str
    shaft: str
    position: float
    teeth: int
    face_width: float
    module: float = MODULE
    pressure_angle: float = 0.3490658503988659  # 20 deg
    helix_angle: float = 0.0
    profile_shift: float = 0.0
    addendum_coef: float = 1.0
    dedendum_coef: float = 1.25
    inertia: float | None = None
    mass: float | None = None


@dataclass(frozen=True)
class Stiffness:
    mean: float


@dataclass(frozen=True)
class MeshRow:
    name: str
    gears: tuple
    angle: float = 0.0
    centre_distance: float | None = None
    backlash: float = 40e-6
    phase_mode: str = "geometry"
    phase: float = 0.0
    mesh_stiffness: Stiffness = field(default_factory=lambda: Stiffness(3.0e8))
    transmission_error: object = None


@dataclass(frozen=True)
class Drive:
    shaft: str = "in"
    torque: float = 50.0
    motor_inertia: float = 0.01
    motor_torsional_stiffness: float = 2.0e4


@dataclass(frozen=True)
class Load:
    shaft: str = "out"
    share: float = 1.0
    inertia: float = 0.5
    torsional_stiffness: float = 5.0e4


@dataclass(frozen=True)
class Rom:
    n_cm: int = 20
    cutoff: float | None = None
    n_check: int = 0
    factorization: str = "cholesky"
    out_of_core: bool = False


@dataclass(frozen=True)
class Kind:
    kind: str = "gearbox"


@dataclass(frozen=True)
class Damping:
    modal_ratio: float = 0.02


@dataclass(frozen=True)
class Scene:
    shafts: tuple
    gears: tuple
    meshes: tuple
    drive: Drive
    loads: tuple
    fe: dict
    rom: Rom = field(default_factory=Rom)
    damping: Damping = field(default_factory=Damping)
    scene: Kind = field(default_factory=Kind)


def two_stage_scene(**fe: dict) -> Scene:
    """The two-stage gearbox of :func:`two_stage` as a scene (stage 1 along +x)."""
    def bearings():
        return (Bearing(0.020), Bearing(0.140))

    shafts = (ShaftRow("in", 0.160, 0.025, bearings()),
              ShaftRow("mid", 0.160, 0.030, bearings()),
              ShaftRow("out", 0.160, 0.040, bearings()))
    gears = (GearRow("p1", "in", 0.060, 23, 0.020), GearRow("w1", "mid", 0.060, 61, 0.020),
             GearRow("p2", "mid", 0.105, 19, 0.025), GearRow("w2", "out", 0.105, 67, 0.025))
    meshes = (MeshRow("stage1", ("p1", "w1")), MeshRow("stage2", ("p2", "w2")))
    table = {"mesh": {"preset": "coarse", "size": 0.02}}
    table.update(fe)
    return Scene(shafts, gears, meshes, Drive(), (Load(),), table)
