"""The data of a validated scene: frozen dataclasses in SI units.

Attribute names are the scene file's keys without their unit suffix. Built by
:mod:`study.scene.load`; everything downstream (models, stages, outputs) reads a
scene through these types only. Imports nothing of :mod:`study`; the gear geometry
and the Fourier series of the mesh come from :mod:`gears`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from gears.excitation import fourier_sample
from gears.ltca import LtcaCase
from gears.pair import GearPair, contact_path_length
from gears.te_table import MeshTable

__all__ = ["Scene", "SceneInfo", "GearData", "FourierSeries", "MeshStiffness",
           "TransmissionError", "LoadData", "AeroLoad", "Unbalance", "ExternalData",
           "DampingData", "LumpedData", "RomData", "HbmData", "ContinuationData",
           "OutputsData", "AcousticsData", "Accelerometer", "MeshSource", "BearingData",
           "ShaftData", "TrainGearData", "MeshData", "DriveData", "TrainLoadData"]


@dataclass(frozen=True)
class SceneInfo:
    """``[scene]``: name, kind (``lumped`` or ``fe``) and description."""

    name: str
    kind: str
    description: str = ""


@dataclass(frozen=True)
class GearData:
    """``[gear]`` in SI: radii (m), angles (rad), half backlash (m)."""

    teeth: int
    base_radius: float
    module: float
    pressure_angle: float
    helix_angle: float
    face_width: float
    addendum_coef: float
    dedendum_coef: float
    profile_shift: float
    backlash: float

    @property
    def pitch_radius(self) -> float:
        """Pitch radius r = r_b / cos α (m)."""
        return self.base_radius / math.cos(self.pressure_angle)

    @property
    def centre_distance(self) -> float:
        """Centre distance a = 2 r (m), ratio 1:1."""
        return 2.0 * self.pitch_radius

    @property
    def tip_radius(self) -> float:
        """Tip radius r_a = r + (h_a + x) m (m)."""
        return self.pitch_radius + (self.addendum_coef + self.profile_shift) * self.module

    @property
    def contact_ratio(self) -> float:
        """Transverse contact ratio ε_α = g_α / (π m cos α) of the pair (spur, ratio 1:1,
        standard centre distance; g_α of :func:`gears.pair.contact_path_length`)."""
        rb, ra, alpha = self.base_radius, self.tip_radius, self.pressure_angle
        path = contact_path_length((ra, ra), (rb, rb), self.centre_distance, alpha)
        return path / (math.pi * self.module * math.cos(alpha))

    def pair(self) -> GearPair:
        """The pair as a :class:`gears.pair.GearPair` (1:1, this module, both gears'
        profile shift). Its radii follow the module; those above follow r_b, as the
        dynamics do (Table 1): they agree when ``module_mm`` is omitted (to rounding)."""
        x = self.profile_shift
        return GearPair(teeth=(self.teeth, self.teeth), module=self.module,
                        pressure_angle=self.pressure_angle, face_width=self.face_width,
                        helix_angle=self.helix_angle, profile_shift=(x, x),
                        addendum_coef=self.addendum_coef, dedendum_coef=self.dedendum_coef)


@dataclass(frozen=True)
class FourierSeries:
    """x(θ) = x̄ + Σ_k a_k cos(k θ + φ_k), θ the mesh angle Z Ω t (SI values, rad).

    The one periodic-data type of a scene: :class:`MeshStiffness` and
    :class:`TransmissionError` are this series; ``estimated`` marks a series computed
    from the gear data instead of read from the file.
    """

    mean: float
    amplitudes: tuple[float, ...]
    phases: tuple[float, ...]
    estimated: bool = False
    #: mesh periods of one period of the series (1: θ is the mesh angle; c > 1: the
    #: series is of θ / c, e.g. over the hunting period of a pair with pitch deviations,
    #: :func:`gears.hunting_series`)
    cycles: int = 1

    def coefficients(self) -> dict[int, complex]:
        """Complex one-sided coefficients per mesh harmonic, {0: x̄, k: a_k e^{iφ_k}}."""
        out: dict[int, complex] = {0: complex(self.mean)}
        for k, (a, p) in enumerate(zip(self.amplitudes, self.phases, strict=True), start=1):
            out[k] = complex(a * np.exp(1j * p))
        return out

    def minimum(self) -> float:
        """Lower bound x̄ − Σ|a_k| of x(θ)."""
        return self.mean - float(sum(self.amplitudes))

    def sample(self, n: int) -> np.ndarray:
        """Values at θ = 2π j/n, j = 0 … n − 1 (one mesh period;
        :func:`gears.excitation.fourier_sample`)."""
        return fourier_sample(self.mean, self.amplitudes, self.phases, n)


@dataclass(frozen=True)
class MeshStiffness(FourierSeries):
    """Mesh stiffness k_m(t) = k̄ + Σ_k a_k cos(k Z Ω t + φ_k) (eq. 16), N/m and rad."""


@dataclass(frozen=True)
class TransmissionError(FourierSeries):
    """Transmission error (m, rad); ``kind`` is ``loaded`` (STE q_s) or ``unloaded`` (e)."""

    kind: str = "loaded"


@dataclass(frozen=True)
class MeshSource:
    """Where a mesh's stiffness and transmission error come from when either is not
    ``fourier`` (``[mesh_stiffness] source``, ``[transmission_error] source``; issue 38).

    Attributes
    ----------
    stiffness, te : str
        ``fourier``, ``ltca`` or ``table`` for k_m and for the TE.
    harmonics : int
        Mesh harmonics kept from the LTCA or the table (those the HBM set uses).
    case : gears.LtcaCase or None
        The LTCA's inputs (macro- and micro-geometry, torque, settings) when a source is
        ``ltca``; hashable, the cache key of the ltca stage.
    harris_torques : tuple of float
        Torques (N·m) of the Harris map drawn beside the LTCA.
    tables : dict
        ``{"stiffness" | "te": gears.MeshTable}`` read for the ``table`` sources.
    hunting : bool
        ``[ltca] hunting``: with pitch deviations, the dynamics take the series over the
        hunting period (:attr:`cycles`).
    """

    stiffness: str
    te: str
    harmonics: int
    case: LtcaCase | None = None
    harris_torques: tuple[float, ...] = ()
    tables: dict[str, MeshTable] = field(default_factory=dict)
    hunting: bool = True

    @property
    def uses_ltca(self) -> bool:
        return "ltca" in (self.stiffness, self.te)

    @property
    def cycles(self) -> int:
        """Mesh periods of the ``ltca`` series the dynamics take: the hunting period of
        the LTCA (pitch deviations) when ``hunting``, else 1."""
        if not self.uses_ltca or self.case is None or not self.hunting:
            return 1
        return self.case.periods


@dataclass(frozen=True)
class LoadData:
    """``[load]``: input torque T (N·m)."""

    torque: float


@dataclass(frozen=True)
class AeroLoad:
    """One aerodynamic harmonic on a shaft station (eq. 1): A cos(order Ω t + φ)."""

    shaft: str
    station: int | None
    order: int
    force: tuple[float, float, float]
    torque: tuple[float, float, float]
    phase: float


@dataclass(frozen=True)
class Unbalance:
    """Mass unbalance m·e (kg·m) on a shaft, rotating force of eq. (2–3) with a phase (rad)."""

    shaft: str
    m_unb: float
    phase: float


@dataclass(frozen=True)
class ExternalData:
    """``[external]``: aerodynamic harmonics and unbalances."""

    aero: tuple[AeroLoad, ...] = ()
    unbalance: tuple[Unbalance, ...] = ()

    @property
    def orders(self) -> tuple[int, ...]:
        """Sorted shaft orders present in the external excitation."""
        o = {a.order for a in self.aero} | ({1} if self.unbalance else set())
        return tuple(sorted(o))

    @property
    def present(self) -> bool:
        return bool(self.aero or self.unbalance)


@dataclass(frozen=True)
class DampingData:
    """``[damping]``: modal damping ratio ξ."""

    modal_ratio: float


@dataclass(frozen=True)
class LumpedData:
    """``[lumped]``: single-DOF model data, SI."""

    model: str
    equivalent_mass: float | None
    inertia: tuple[float, ...] | None
    density: float


@dataclass(frozen=True)
class RomData:
    """``[rom]``: number of fixed-interface modes or a cut-off frequency (Hz), and the
    Fig. 9 check.

    ``n_cm`` None and ``cutoff`` None select every mode below ``cutoff_factor`` times the
    highest excitation frequency; the loader (:func:`study.scene.frequency.resolve_rom`)
    writes that cut-off into ``cutoff`` (and ``auto`` True) and the highest excitation
    frequency into ``check_hz``. ``n_check`` None compares every coupled mode up to
    ``check_hz``.
    """

    n_cm: int | None
    cutoff: float | None
    n_check: int | None = None
    factorization: str = "cholesky"
    out_of_core: bool = False
    cutoff_factor: float = 3.0
    check_hz: float | None = None
    auto: bool = False


@dataclass(frozen=True)
class HbmData:
    """``[hbm]``: harmonic set and AFT settings."""

    mesh_harmonics: int
    sideband_order: int
    harmonics: tuple[int, ...] | None
    harmonic_set: str
    aft_samples: int
    condensation: str
    stability: bool = True
    linear_solver: str = "auto"
    basis: str = "auto"
    max_aft_samples: int = 1 << 16


@dataclass(frozen=True)
class ContinuationData:
    """``[continuation]``: speed range and steps in rpm, tolerance, checkpoints, depth of
    the branch switching at period doublings."""

    speed: tuple[float, float]
    step: float
    min_step: float
    max_step: float
    tolerance: float
    max_points: int
    checkpoint_every: int
    period_doubling_depth: int = 1
    period_doubling_max_points: int = 0


@dataclass(frozen=True)
class AcousticsData:
    """``[acoustics]``: air density (kg/m³) and speed of sound (m/s) of the ERP."""

    air_density: float = 1.2
    sound_speed: float = 343.0


@dataclass(frozen=True)
class Accelerometer:
    """``[[outputs.accelerometer]]``: name, position (m), direction (zero: surface normal)."""

    name: str
    position: tuple[float, float, float]
    direction: tuple[float, float, float] = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class OutputsData:
    """``[outputs]``: plots, time-series speeds (rpm), housing field speeds (rpm), per-order
    field orders, housing time-series sampling, virtual accelerometers, time integration
    at unstable segments (turns left out, turns analysed, speeds per segment, sweep, the
    bound on integrations, start disturbance)."""

    plots: tuple[str, ...]
    time_series: tuple[float, ...]
    housing_field: tuple[float, ...]
    report: bool
    field_orders: tuple[int, ...] = ()
    housing_frames_per_mesh_period: int = 0
    housing_mesh_periods: int = 4
    accelerometers: tuple[Accelerometer, ...] = ()
    attractor_transient_turns: int = 0
    attractor_window_turns: int = 8
    attractor_speeds_per_segment: int = 1
    attractor_sweep: bool = False
    attractor_max_integrations: int = 200
    attractor_perturbation: float = 0.0


@dataclass(frozen=True)
class BearingData:
    """``[[shafts.bearings]]``: axial position (m), radial and axial stiffness (N/m), and
    (gearbox) the links of its bore and journal (``"housing"``: those of ``[housing]``)."""

    position: float
    radial: float
    axial: float
    bore_link: str = "housing"
    journal_link: str = "housing"


@dataclass(frozen=True)
class ShaftData:
    """``[[shafts]]`` of a train, SI: length and diameter (m, None if not given), extra
    rotor inertia (kg m²), torsional stiffness between its gears (N m/rad, None: from G J
    / spacing), bearings."""

    name: str
    length: float | None
    diameter: float | None
    inertia: float
    torsional_stiffness: float | None
    bearings: tuple[BearingData, ...] = ()


@dataclass(frozen=True)
class TrainGearData:
    """``[[gears]]`` of a train, SI: axial position (m), teeth, normal module (m), normal
    pressure angle and signed helix angle (rad, + right hand), face width (m), profile
    shift, addendum/dedendum coefficients, inertia (kg m²) and mass (kg) or None."""

    name: str
    shaft: str
    position: float
    teeth: int
    module: float
    pressure_angle: float
    helix_angle: float
    face_width: float
    profile_shift: float
    addendum_coef: float
    dedendum_coef: float
    inertia: float | None
    mass: float | None


@dataclass(frozen=True)
class MeshData:
    """``[[meshes]]`` of a train, SI: the two gears (gear 1 drives), line-of-centres angle
    (rad), centre distance (m, None if not given), half backlash (m), phase at t = 0
    (``phase_mode`` ``"geometry"``: from the layout; ``"given"``: ``phase`` in rad), and
    its mesh stiffness and transmission error (per mesh harmonic; ``estimated`` when the
    ISO 6336 estimate, the LTCA or a table filled them in; ``source`` then says which)."""

    name: str
    gears: tuple[str, str]
    angle: float
    centre_distance: float | None
    backlash: float
    phase_mode: str
    phase: float
    mesh_stiffness: MeshStiffness | None = None
    transmission_error: TransmissionError | None = None
    #: ``ltca``/``table`` sources of this mesh (None: both ``fourier``)
    source: MeshSource | None = None


@dataclass(frozen=True)
class DriveData:
    """``[drive]`` of a train: the drive shaft, input torque (N m), motor inertia (kg m²)
    and coupling stiffness (N m/rad)."""

    shaft: str
    torque: float
    motor_inertia: float
    motor_torsional_stiffness: float


@dataclass(frozen=True)
class TrainLoadData:
    """``[[loads]]`` of a train: the shaft, its share of the power, the load inertia
    (kg m²) and coupling stiffness (N m/rad)."""

    shaft: str
    share: float
    inertia: float
    torsional_stiffness: float


@dataclass(frozen=True)
class Scene:
    """A validated scene in SI units. ``raw`` is the parsed file (for hashing/records)."""

    scene: SceneInfo
    gear: GearData
    mesh_stiffness: MeshStiffness
    transmission_error: TransmissionError
    load: LoadData
    external: ExternalData
    damping: DampingData
    lumped: LumpedData
    rom: RomData
    hbm: HbmData
    continuation: ContinuationData
    outputs: OutputsData
    fe: dict = field(default_factory=dict)
    raw: dict = field(default_factory=dict, compare=False, repr=False)
    text: str = field(default="", compare=False, repr=False)
    acoustics: AcousticsData = field(default_factory=AcousticsData)
    #: ``[calibration]``: paper.md row key -> what the scene fitted to that finding (only
    #: the rows it declares)
    calibration: dict[str, str] = field(default_factory=dict, compare=False)
    #: ``ltca``/``table`` sources of the mesh excitation (None: both ``fourier``)
    mesh_source: MeshSource | None = None
    #: ``[[shafts]]``, ``[[gears]]``, ``[[meshes]]``, ``[drive]``, ``[[loads]]`` of a train
    #: (scene.kind "train" or "gearbox"); empty/None otherwise
    shafts: tuple[ShaftData, ...] = ()
    gears: tuple[TrainGearData, ...] = ()
    meshes: tuple[MeshData, ...] = ()
    drive: DriveData | None = None
    loads: tuple[TrainLoadData, ...] = ()

    @property
    def is_train(self) -> bool:
        """Whether the scene is a train (``[[meshes]]`` instead of ``[gear]``)."""
        return bool(self.meshes)

    @property
    def static_load(self) -> float:
        """Static mesh load F_s = T / r_b1 (N)."""
        return self.load.torque / self.gear.base_radius

    @property
    def name(self) -> str:
        return self.scene.name

