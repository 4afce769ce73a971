"""The scene file schema: one :class:`Spec` per key, section by section (:data:`SCHEMA`).

The bottom of the scene layers (above :mod:`core.units`): what each key of a scene
file is, its type, default, allowed range, unit suffix and meaning. The one checker
that applies it is :mod:`study.scene.check`; the unit factors come from the one unit
table :data:`core.units.TO_SI`. ``docs/scenes.md`` lists the schema
(:func:`schema_markdown`; a test checks every key is there).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from core.errors import range_text
from core.units import TO_SI

__all__ = ["Spec", "SCHEMA", "FE_SECTIONS", "GEARBOX_SECTIONS", "MESH_SOURCES",
           "mesh_source_schema", "PLOT_NAMES", "TOP_LEVEL", "CALIBRATION_ROWS", "TRAIN_KINDS",
           "TRAIN_SECTIONS", "PAIR_SECTIONS", "HEADINGS", "attr_name", "schema_markdown"]


@dataclass(frozen=True)
class Spec:
    """One scene field: type, default, allowed range, unit and documentation.

    ``kind`` is one of ``float``, ``int``, ``bool``, ``str``, ``choice``, ``floats``
    (list of floats), ``ints`` (list of ints), ``vec3`` (3 floats), ``pair`` (2
    increasing floats) or ``table`` (free table, validated by the stage that uses it).
    """

    kind: str
    default: Any = None
    unit: str = ""
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False
    choices: tuple = ()
    doc: str = ""
    required: bool = False

    def range_text(self) -> str:
        if self.kind == "choice":
            return "one of " + ", ".join(repr(c) for c in self.choices)
        return range_text(self.lo, self.hi, lo_open=self.lo_open, hi_open=self.hi_open)


def _f(default=None, unit="", lo=None, hi=None, lo_open=False, hi_open=False, doc="",
       kind="float", required=False):
    return Spec(kind, default, unit, lo, hi, lo_open, hi_open, (), doc, required)


def _c(default, choices, doc=""):
    return Spec("choice", default, "", None, None, False, False, tuple(choices), doc)


#: Where a mesh's stiffness and transmission error come from (issue 38).
MESH_SOURCES = ("fourier", "ltca", "table")

PLOT_NAMES = ("forced_response", "time_series", "spectrum", "campbell", "rom_error", "housing",
              "order_maps", "erp", "accelerometers", "bifurcation")
FE_SECTIONS = ("geometry", "mesh", "materials", "bearings", "drive", "rotors", "links")
#: The free FE tables of a gearbox scene (machines.gearbox.params checks them).
GEARBOX_SECTIONS = ("housing", "mesh", "materials")
#: Machine kinds described by ``[[shafts]]``, ``[[gears]]``, ``[[meshes]]``, ``[drive]`` and
#: ``[[loads]]`` (issue 36): the lumped torsional train and the FE gearbox.
TRAIN_KINDS = ("train", "gearbox")
#: The sections of a train scene (``drive`` is the FE pump's free table otherwise).
TRAIN_SECTIONS = ("shafts", "gears", "meshes", "loads")
#: The one-pair sections a train scene replaces by its per-mesh ones.
PAIR_SECTIONS = ("gear", "mesh_stiffness", "transmission_error", "load", "lumped")

#: The findings of the paper that ``paper.md`` compares, by the key of
#: :data:`study.studies.paper.findings.PAPER` (a test checks the two agree): the keys of a scene's
#: ``[calibration]``, which says which of them the scene's parameters were fitted to.
CALIBRATION_ROWS = {
    "static_load": "static mesh load F_s",
    "mesh_mode": "mode with most mesh energy (Fig. 8)",
    "resonances": "resonance speeds (Fig. 14)",
    "grazing": "grazing speeds (Fig. 14)",
    "windows": "permanent-contact windows",
    "primary_peak": "primary-peak change, internal only → all (Fig. 12)",
    "primary_jumps": "amplitude jumps at the primary peak (Fig. 12)",
    "span_change": "vibro-impact span change (Fig. 13)",
    "ipp_1700": "IPP sequence at 1700 rpm (Fig. 17)",
    "ipp_1070": "IPP sequence at 1070 rpm (Fig. 18)",
    "ipp_6875": "IPP sequence at 6875 rpm (Fig. 16)",
    "h2_speed": "response at 6875 rpm: DTE and mesh-load harmonics (Fig. 16)",
    "peak_to_peak": "mesh-load peak-to-peak, 2970 → 6875 rpm",
    "impact_loads": "impact loads over a turn at 2970 rpm (Fig. 15b)",
    "dte_modulation": "slow DTE modulation at 2970 rpm (Fig. 15d)",
}

def mesh_source_schema() -> dict[str, dict[str, Spec]]:
    """The sections of the ``ltca`` source of a mesh (issue 38): ``[micro_geometry]`` (its
    ``gear1``, ``gear2`` and ``both`` subtables share one spec) and ``[ltca]``; the same
    tables serve the one mesh of a pair scene and each ``[[meshes]]`` of a train."""
    flank = {
        "tip_relief_um": _f(0.0, "um", 0, 1e4, doc="tip relief C_a removed at the tip "
                            "diameter (0: none)"),
        "tip_relief_start_diameter_mm": _f(None, "mm", 0, 1e5, lo_open=True,
                                           doc="d_Ca where the tip relief starts (between "
                                           "the reference and the tip diameter)"),
        "tip_relief_shape": _c("linear", ("linear", "parabolic"), "growth of the tip relief"),
        "root_relief_um": _f(0.0, "um", 0, 1e4, doc="root relief C_f removed at the form "
                             "diameter (0: none)"),
        "root_relief_start_diameter_mm": _f(None, "mm", 0, 1e5, lo_open=True,
                                            doc="d_Cf where the root relief starts (between "
                                            "the form and the reference diameter)"),
        "root_relief_shape": _c("linear", ("linear", "parabolic"), "growth of the root relief"),
        "crowning_um": _f(0.0, "um", 0, 1000, doc="lead crowning C_β at each face end"),
        "profile_slope_um": _f(0.0, "um", -1000, 1000, doc="profile slope deviation f_Hα"),
        "profile_form_um": _f(0.0, "um", -1000, 1000, doc="profile form deviation f_fα "
                              "(+: barrelled)"),
        "lead_slope_um": _f(0.0, "um", -1000, 1000, doc="helix slope deviation f_Hβ"),
        "pitch_deviations_um": _f([], "um", -1000, 1000, kind="floats",
                                  doc="single pitch deviations f_pt of teeth 0 … z − 1 "
                                  "(sum 0; shaft orders over the hunting period)"),
    }
    ltca = {
        "n_positions": _f(64, "", 8, 100_000, kind="int",
                          doc="roll positions per mesh period (> 2 × the mesh harmonics kept)"),
        "n_slices": _f(200, "", 1, 10_000, kind="int",
                       doc="thin slices across the face (helix, crowning, lead slope)"),
        "bore_diameter_mm": _f([], "mm", 0, 1e5, lo_open=True, kind="floats",
                               doc="[gear 1, gear 2] diameter where each body is held "
                               "(default: the root radius r_f, i.e. r_int = r_f/2)"),
        "youngs_modulus_GPa": _f(210.0, "GPa", 0, 1e4, lo_open=True, doc="E of both gears"),
        "poisson_ratio": _f(0.3, "", 0, 0.5, hi_open=True, doc="ν of both gears"),
        "harris_torque_Nm": _f(None, "Nm", 0, 1e7, lo_open=True, kind="pair",
                               doc="[lowest, highest] torque of the Harris map (default: "
                               "0.2 and 2 × load.torque_Nm)"),
        "harris_points": _f(20, "", 2, 1000, kind="int", doc="torques of the Harris map"),
        "hunting": Spec("bool", True, doc="with pitch deviations, the dynamics take k_m and "
                        "the STE over the hunting period (mesh harmonics and their "
                        "shaft-order sidebands; the harmonic set becomes every shaft order "
                        "up to the top mesh harmonic); false: their mesh-period averages"),
    }
    return {"micro_geometry.gear": flank, "ltca": ltca}


#: The whole schema: section -> key (as written in the file) -> Spec. Array-of-tables
#: sections (``external.aero``, ``external.unbalance``) have their own entries.
SCHEMA: dict[str, dict[str, Spec]] = {
    "scene": {
        "name": Spec("str", None, doc="scene name (default: the file stem)"),
        "kind": _c("lumped", ("lumped", "fe", "train", "gearbox"), "`lumped`: single-DOF "
                   "gear pair, no FE; `fe`: geometry → FE → ROM; `train`: lumped torsional "
                   "gear train of `[[shafts]]`, `[[gears]]`, `[[meshes]]` (no FE); "
                   "`gearbox`: the same train on FE shafts in a housing (`[housing]`, "
                   "`[mesh]`, `[materials]`) → FE → ROM"),
        "description": Spec("str", "", doc="free text"),
    },
    "gear": {
        "teeth": _f(76, lo=5, hi=1000, kind="int",
                    doc="number of teeth Z of each gear (ratio 1:1)"),
        "base_radius_mm": _f(46.984, "mm", 0, 10_000, lo_open=True, doc="base radius r_b"),
        "module_mm": _f(None, "mm", 0, 1000, lo_open=True,
                        doc="module; if given, must agree with 2 r_b/(Z cos α) to 1 %"),
        "pressure_angle_deg": _f(20.0, "deg", 5, 45, doc="normal pressure angle α"),
        "helix_angle_deg": _f(0.0, "deg", 0, 45, hi_open=True, doc="helix angle β"),
        "face_width_mm": _f(20.0, "mm", 0, 10_000, lo_open=True, doc="face width b_f"),
        "addendum_coef": _f(1.0, "", 0.5, 1.5, doc="addendum coefficient h_a"),
        "dedendum_coef": _f(1.25, "", 0.5, 2.0, doc="dedendum coefficient h_d (> h_a)"),
        "profile_shift": _f(0.0, "", -1.0, 1.0, doc="profile shift coefficient x (both gears)"),
        "backlash_um": _f(40.0, "um", 0, 1e5, lo_open=True, doc="half backlash b"),
    },
    "mesh_stiffness": {
        "source": _c("fourier", MESH_SOURCES, "`fourier`: the harmonics below (or the estimate); "
                     "`ltca`: loaded tooth contact analysis of [gear] with [micro_geometry] at "
                     "the scene's torque ([ltca] settings); `table`: the CSV `file` "
                     "(docs/gears.md)"),
        "file": Spec("str", "", doc="`source = \"table\"`: CSV of the stiffness against the mesh "
                     "position, roll angle or roll distance, relative to the scene file"),
        "estimate": Spec("bool", False, doc="estimate from geometry and load (ISO 6336-1)"),
        "mean_N_per_um": _f(None, "N_per_um", 0, 1e7, lo_open=True, doc="mean mesh stiffness k̄_m"),
        "amplitudes_N_per_um": _f([], "N_per_um", 0, 1e7, kind="floats",
                                  doc="amplitude of mesh harmonic k = 1, 2, …"),
        "phases_deg": _f([], "deg", -360, 360, kind="floats", doc="phase of each mesh harmonic"),
        "n_harmonics": _f(3, "", 1, 20, kind="int", doc="harmonics kept by the estimate"),
        "cm": _f(0.8, "", 0.1, 1.0, doc="ISO 6336 correction C_M of the estimate"),
    },
    "transmission_error": {
        "source": _c("fourier", MESH_SOURCES, "`fourier`: the harmonics below (or the estimate); "
                     "`ltca`: the loaded STE of the tooth contact analysis (kind = 'loaded'); "
                     "`table`: the CSV `file`"),
        "file": Spec("str", "", doc="`source = \"table\"`: CSV of the TE against the mesh "
                     "position, roll angle or roll distance, relative to the scene file"),
        "kind": _c("loaded", ("loaded", "unloaded"),
                   "`loaded`: static TE q_s under F_s (paper's STE); `unloaded`: geometric e(t)"),
        "estimate": Spec("bool", False, doc="loaded STE of perfect teeth, q_s = F_s/k_m(t)"),
        "mean_um": _f(0.0, "um", -1e5, 1e5, doc="mean value"),
        "amplitudes_um": _f([], "um", 0, 1e5, kind="floats",
                            doc="amplitude of mesh harmonic k = 1, 2, …"),
        "phases_deg": _f([], "deg", -360, 360, kind="floats", doc="phase of each mesh harmonic"),
    },
    "load": {
        "torque_Nm": _f(2.5, "Nm", 0, 1e7, doc="input torque T; static load F_s = T/r_b1"),
    },
    "external.aero": {
        "shaft": _c(None, ("in", "out"), "shaft the load acts on"),
        "station": _f(None, "", 1, 6, kind="int",
                      doc="station 1–6 along the shaft (FE); omit for the gear (lumped)"),
        "order": _f(None, "", 1, 200, kind="int", doc="shaft order (harmonic of Ω)", required=True),
        "force_N": _f([0.0, 0.0, 0.0], "N", -1e9, 1e9, kind="vec3", doc="force amplitude (x,y,z)"),
        "torque_Nm": _f([0.0, 0.0, 0.0], "Nm", -1e9, 1e9, kind="vec3",
                        doc="torque amplitude (x,y,z)"),
        "phase_deg": _f(0.0, "deg", -360, 360, doc="phase φ: f(t) = A cos(order Ω t + φ)"),
    },
    "external.unbalance": {
        "shaft": _c(None, ("in", "out"), "shaft"),
        "m_unb_kgm": _f(None, "kgm", 0, 10, lo_open=True, doc="unbalance m·e", required=True),
        "phase_deg": _f(0.0, "deg", -360, 360, doc="phase of the rotating force (eq. 2–3)"),
    },
    "train.external.aero": {
        "shaft": Spec("str", None, doc="shaft of the train (its name in [[shafts]]) the load "
                      "acts on, spread evenly on its gears", required=True),
        "order": _f(None, "", 1, 200, kind="int", required=True,
                    doc="order k of that shaft: frequency k ρ_s Ω (ρ_s its speed ratio)"),
        "force_N": _f([0.0, 0.0, 0.0], "N", -1e9, 1e9, kind="vec3",
                      doc="force amplitude (global x, y, z; gearbox only)"),
        "torque_Nm": _f([0.0, 0.0, 0.0], "Nm", -1e9, 1e9, kind="vec3",
                        doc="moment amplitude (global x, y, z; lumped train: z only)"),
        "phase_deg": _f(0.0, "deg", -360, 360,
                        doc="phase φ: f(t) = A cos(k ρ_s Ω t + φ)"),
    },
    "train.external.unbalance": {
        "shaft": Spec("str", None, doc="shaft of the train (gearbox only: a lumped train has "
                      "no lateral DOF)", required=True),
        "m_unb_kgm": _f(None, "kgm", 0, 10, lo_open=True, doc="unbalance m·e, spread evenly "
                        "on the shaft's gears", required=True),
        "phase_deg": _f(0.0, "deg", -360, 360, doc="angle of the force from the global x "
                        "axis at t = 0, in the shaft's sense of rotation"),
    },
    "damping": {
        "modal_ratio": _f(0.05, "", 0, 1, hi_open=True, lo_open=True,
                          doc="modal damping ratio ξ of every mode (eq. 18–19)"),
    },
    "lumped": {
        "model": _c("sdof", ("sdof",), "lumped model: single-DOF on the line of action"),
        "equivalent_mass_kg": _f(None, "kg", 0, 1e6, lo_open=True,
                                 doc="m_e; default from the inertias"),
        "inertia_kgm2": _f(None, "kgm2", 0, 1e6, lo_open=True, kind="floats",
                           doc="[I1, I2]; default: steel disks of pitch radius and face width"),
        "density_kg_per_m3": _f(7800.0, "kg_per_m3", 0, 1e5, lo_open=True,
                                doc="disk density for the default inertias"),
    },
    "rom": {
        "n_cm": _f(None, "", 1, 5000, kind="int",
                   doc="fixed-interface modes kept; default: every mode below cutoff_factor "
                   "× the highest excitation frequency"),
        "cutoff_Hz": _f(None, "Hz", 0, 1e7, lo_open=True,
                        doc="keep modes below this frequency instead of n_cm"),
        "cutoff_factor": _f(3.0, "", 1, 10,
                            doc="without n_cm and cutoff_Hz: keep every mode below this "
                            "multiple of the highest excitation frequency (highest excited "
                            "mesh harmonic or shaft order at the top speed; "
                            "docs/reduction.md)"),
        "n_check": _f(None, "", 0, 5000, kind="int",
                      doc="coupled modes compared with the full model (Fig. 9); default: every "
                      "mode up to the highest excitation frequency; 0: skip"),
        "factorization": _c("cholesky", ("lu", "cholesky"),
                            "MUMPS factorisation of K_ii in the Craig–Bampton eigen-solve: "
                            "`cholesky` (LDLᵀ, K_ii is symmetric positive definite) gives the "
                            "same modes as `lu` (1e-13) with half the factor entries and less "
                            "time (docs/scale.md)"),
        "out_of_core": Spec("bool", False,
                            doc="MUMPS factor of K_ii out of core (ICNTL(22) = 1): written to "
                                "the folder `$MUMPS_OOC_TMPDIR` (default /tmp; must exist and be "
                                "writable), only the active fronts stay in memory; same modes, "
                                "~10 % more time (docs/scale.md)"),
    },
    "hbm": {
        "mesh_harmonics": _f(3, "", 1, 200, kind="int", doc="mesh harmonics kZ, k = 1…n"),
        "sideband_order": _f(0, "", 0, 50, kind="int",
                             doc="sidebands kZ ± e combination order (a train: of its shaft "
                             "orders around the meshes' combinations)"),
        "harmonic_set": _c("combinations", ("combinations", "bands", "contiguous"),
                           "how the builder fills the sidebands: the order-s combinations, "
                           "every index within their reach, or all indices (docs/convergence.md)"),
        "harmonics": _f(None, "", 0, 100_000, kind="ints",
                        doc="explicit harmonic set (must contain 0); overrides the builder"),
        "aft_samples": _f(0, "", 0, 1 << 20, kind="int", doc="AFT time samples (0: automatic)"),
        "condensation": _c("loa", ("loa", "gear", "none"), "exact condensation level"),
        "linear_solver": _c("auto", ("auto", "dense", "krylov"),
                            "Newton matrices: dense LU, or matrix-free GMRES (loa; 'auto' from "
                            "400 real unknowns on; docs/hbm.md)"),
        "stability": Spec("bool", True, doc="stability of every point (variational "
                          "equation, every mode; docs/theory.md §11)"),
        "basis": _c("auto", ("auto", "periodic", "torus"),
                    "train scenes: `periodic`: one fundamental, the hunting fundamental of the "
                    "train; `torus`: every mesh frequency a base of its own (multi-dimensional "
                    "AFT, docs/hbm.md); `auto`: periodic when its AFT grid stays within "
                    "max_aft_samples, else the torus"),
        "max_aft_samples": _f(1 << 16, "", 64, 1 << 26, kind="int",
                              doc="train scenes: largest AFT grid (samples per period) of a "
                              "periodic basis; `basis = 'periodic'` above it is refused"),
    },
    "shafts": {
        "name": Spec("str", None, doc="shaft name (unique)", required=True),
        "length_mm": _f(None, "mm", 0, 1e5, lo_open=True,
                        doc="gearbox: the shaft's length (FE); train: unused"),
        "diameter_mm": _f(None, "mm", 0, 1e4, lo_open=True,
                          doc="gearbox: journal/body diameter; train: the torsional default "
                          "stiffness G J / spacing of its gears"),
        "inertia_kgm2": _f(0.0, "kgm2", 0, 1e6, doc="extra rotor inertia on the shaft"),
        "torsional_stiffness_Nm_per_rad": _f(
            None, "Nm_per_rad", 0, 1e12, lo_open=True,
            doc="train: stiffness between consecutive gears of the shaft (default: G J / "
            "their spacing, G = 80 GPa, from diameter_mm)"),
    },
    "shafts.bearings": {
        "position_mm": _f(None, "mm", -1e5, 1e5, required=True,
                          doc="axial position from the shaft's start (gearbox; train: ignored)"),
        "radial_N_per_um": _f(None, "N_per_um", 0, 1e7, lo_open=True, required=True,
                              doc="radial stiffness"),
        "axial_N_per_um": _f(None, "N_per_um", 0, 1e7, lo_open=True, required=True,
                             doc="axial stiffness"),
        "bore_link": _c("housing", ("housing", "rigid", "distributing"),
                        "gearbox: link of this bearing's bore to its node, RBE2 'rigid' or "
                        "RBE3-type 'distributing'; 'housing': [housing] bore_link"),
        "journal_link": _c("housing", ("housing", "rigid", "distributing"),
                           "gearbox: link of this bearing's journal to its node; 'housing': "
                           "[housing] journal_link"),
    },
    "gears": {
        "name": Spec("str", None, doc="gear (body) name, unique", required=True),
        "shaft": Spec("str", None, doc="the shaft it sits on", required=True),
        "position_mm": _f(None, "mm", -1e5, 1e5, required=True,
                          doc="axial position of its mid-face on the shaft"),
        "teeth": _f(None, "", 5, 1000, kind="int", required=True, doc="number of teeth Z"),
        "module_mm": _f(None, "mm", 0, 1000, lo_open=True, required=True, doc="normal module"),
        "pressure_angle_deg": _f(20.0, "deg", 5, 45, doc="normal pressure angle"),
        "helix_angle_deg": _f(0.0, "deg", -45, 45, lo_open=True, hi_open=True,
                              doc="signed helix angle: + right hand, − left hand (a helical "
                              "pair has opposite signs)"),
        "face_width_mm": _f(None, "mm", 0, 10_000, lo_open=True, required=True,
                            doc="face width"),
        "profile_shift": _f(0.0, "", -1.0, 1.0, doc="profile shift coefficient x"),
        "addendum_coef": _f(1.0, "", 0.5, 1.5, doc="addendum coefficient h_a"),
        "dedendum_coef": _f(1.25, "", 0.5, 2.0, doc="dedendum coefficient h_f (> h_a)"),
        "inertia_kgm2": _f(None, "kgm2", 0, 1e6, lo_open=True,
                           doc="polar inertia; default: steel disk of the pitch diameter"),
        "mass_kg": _f(None, "kg", 0, 1e6, lo_open=True,
                      doc="mass; default: steel disk of the pitch diameter"),
    },
    "meshes": {
        "name": Spec("str", None, doc="mesh name, unique", required=True),
        "gears": Spec("strs", None, doc="[gear 1, gear 2]: gear 1 drives gear 2 (eq. 11 order)",
                      required=True),
        "angle_deg": _f(0.0, "deg", -360, 360,
                        doc="direction of the line of centres from gear 1's shaft to gear 2's "
                        "(x axis = 0, counter-clockwise seen from +z); places the shafts"),
        "centre_distance_mm": _f(None, "mm", 0, 1e5, lo_open=True,
                                 doc="if given, must match the gears' working centre distance "
                                 "(0.001 mm)"),
        "backlash_um": _f(40.0, "um", 0, 1e5, lo_open=True, doc="half backlash b of this mesh"),
        "phase": _c("geometry", ("geometry",),
                    "`geometry`: mesh phase at t = 0 from the tooth positions "
                    "(docs/theory.md §14.5); give phase_deg instead for a stated phase"),
        "phase_deg": _f(None, "deg", -360, 360, doc="stated mesh phase at t = 0 (instead of "
                        "phase = 'geometry')"),
    },
    "train.drive": {
        "shaft": Spec("str", None, doc="shaft where the torque enters (its speed is "
                      "continuation.speed_rpm)", required=True),
        "torque_Nm": _f(None, "Nm", 0, 1e7, lo_open=True, required=True, doc="input torque"),
        "motor_inertia_kgm2": _f(0.01, "kgm2", 0, 1e6, lo_open=True,
                                 doc="motor rotor inertia"),
        "motor_torsional_stiffness_Nm_per_rad": _f(
            2.0e4, "Nm_per_rad", 0, 1e12, lo_open=True,
            doc="coupling stiffness between the motor and the drive shaft"),
    },
    "loads": {
        "shaft": Spec("str", None, doc="shaft where torque leaves", required=True),
        "share": _f(1.0, "", 0, 1, lo_open=True, doc="share of the input power (the shares "
                    "sum to 1)"),
        "inertia_kgm2": _f(0.5, "kgm2", 0, 1e6, lo_open=True, doc="load (brake) inertia"),
        "torsional_stiffness_Nm_per_rad": _f(
            5.0e4, "Nm_per_rad", 0, 1e12, lo_open=True,
            doc="coupling stiffness between the shaft and the load"),
    },
    "continuation": {
        "speed_rpm": _f([500.0, 8000.0], "rpm", 0, 1e6, lo_open=True, kind="pair",
                        doc="[start, end] shaft speed, start < end"),
        "step_rpm": _f(None, "rpm", 0, 1e6, lo_open=True, doc="initial step (default: range/200)"),
        "min_step_rpm": _f(None, "rpm", 0, 1e6, lo_open=True,
                           doc="smallest step (default: range/1e5)"),
        "max_step_rpm": _f(None, "rpm", 0, 1e6, lo_open=True,
                           doc="largest step (default: range/50)"),
        "tolerance": _f(1e-8, "", 1e-14, 1e-2, doc="relative residual tolerance of each point"),
        "max_points": _f(20_000, "", 2, 10_000_000, kind="int", doc="maximum points"),
        "checkpoint_every": _f(20, "", 1, 1_000_000, kind="int",
                               doc="points between checkpoints in results.h5"),
        "period_doubling_depth": _f(1, "", 0, 4, kind="int",
                                    doc="switch at period doublings to the period-2 branches "
                                    "(1), their period-4 branches (2), ...; 0: off"),
        "period_doubling_max_points": _f(0, "", 0, 10_000_000, kind="int",
                                         doc="points of all period-2 (4, ...) branches "
                                         "together at most; 0: as many as the main branch, "
                                         "200 at least"),
    },
    "acoustics": {
        "air_density_kg_per_m3": _f(1.2, "kg_per_m3", 0, 100, lo_open=True,
                                    doc="density ρ of the air the housing radiates into (ERP)"),
        "sound_speed_m_per_s": _f(343.0, "m_per_s", 0, 1e4, lo_open=True,
                                  doc="speed of sound c of that air (ERP = ½ ρ c Σ v_n² A)"),
    },
    "outputs": {
        "plots": Spec("strs", list(PLOT_NAMES),
                      doc="plots to draw, among " + ", ".join(PLOT_NAMES)),
        "time_series_rpm": _f([], "rpm", 0, 1e6, lo_open=True, kind="floats",
                              doc="speeds for time series/spectra, within the speed range "
                              "(default: most loaded point)"),
        "housing_field_rpm": _f([], "rpm", 0, 1e6, lo_open=True, kind="floats",
                                doc="speeds for the XDMF housing field (FE), within the "
                                "speed range; the nearest point is used"),
        "report": Spec("bool", True, doc="write report.md"),
        "attractor_transient_turns": _f(
            0, "", 0, 100_000, kind="int",
            doc="shaft turns of time integration left out from the orbit at the most unstable "
            "point of each unstable segment, before the analysed ones (0: none; report.md, "
            "attractors.csv, results.h5)"),
        "attractor_window_turns": _f(8, "", 1, 10_000, kind="int",
                                     doc="shaft turns analysed after them"),
        "attractor_speeds_per_segment": _f(
            1, "", 1, 1000, kind="int",
            doc="speeds integrated per unstable segment: 1, its most unstable point; n > 1, "
            "the segment's points nearest n speeds spread evenly over it (the bifurcation "
            "diagram's independent check, docs/theory.md §16)"),
        "attractor_sweep": Spec("bool", False,
                                doc="within a segment, each speed after the lowest starts "
                                "from the state the previous one ended in (a slow run-up) "
                                "instead of its own orbit"),
        "attractor_max_integrations": _f(
            200, "", 1, 100_000, kind="int",
            doc="cost bound: time integrations per run; the segments are served by kind "
            "(Neimark–Sacker, period doubling, then folds) and largest std first, the rest "
            "are listed as not integrated"),
        "attractor_perturbation": _f(
            0.0, "", 0.0, 0.1,
            doc="relative disturbance added to the start orbit (0: started exactly on it, "
            "left only through the orbit's own error; 1e-6 makes the transient needed "
            "ln(1e6) / growth rate)"),
        "field_orders": _f([], "", 1, 100_000, kind="ints",
                           doc="shaft orders of the per-order housing fields (FE; default: "
                           "the mesh orders kZ and the external orders of the set)"),
        "housing_frames_per_mesh_period": _f(
            0, "", 0, 10_000, kind="int",
            doc="frames per mesh period of the housing time series (0: 4 per period of the "
            "highest harmonic kept; fewer than 2 alias and are refused)"),
        "housing_mesh_periods": _f(4, "", 1, 1000, kind="int",
                                   doc="length of the housing time series in mesh periods"),
    },
    "calibration": {key: Spec("str", "", doc=f"{what}: what the scene fitted to it (empty: "
                              "nothing)") for key, what in CALIBRATION_ROWS.items()},
    "outputs.accelerometer": {
        "name": Spec("str", None, doc="name of the virtual accelerometer", required=True),
        "position_mm": _f(None, "mm", -1e5, 1e5, kind="vec3", required=True,
                          doc="point on the housing's outer surface (x, y, z); snapped to the "
                          "nearest outer facet centre (at most 10 mm away)"),
        "direction": _f([0.0, 0.0, 0.0], "", -1e6, 1e6, kind="vec3",
                        doc="measuring axis (x, y, z); [0, 0, 0]: the outer surface normal"),
    },
}
SCHEMA.update(mesh_source_schema())
for _s in (*FE_SECTIONS, *GEARBOX_SECTIONS):
    SCHEMA[_s] = {}  # free tables, validated against the FE packages' dataclasses

#: Top-level sections of a scene file, in the order they are checked (the train sections
#: and ``[drive]`` of a train are checked by the loader, :mod:`study.scene.load`).
TOP_LEVEL = ("scene", "gear", "mesh_stiffness", "transmission_error", "micro_geometry",
             "ltca", "load", "external",
             "damping", "lumped", "rom", "hbm", "continuation", "acoustics", "outputs",
             "calibration", *FE_SECTIONS, "housing", *TRAIN_SECTIONS)

#: How :func:`schema_markdown` heads a section (default ``[sec]``, ``[[sec]]`` if dotted).
HEADINGS = {"shafts": "[[shafts]]", "gears": "[[gears]]", "meshes": "[[meshes]]",
            "loads": "[[loads]]", "shafts.bearings": "[[shafts.bearings]]",
            "train.drive": "[drive] (scene.kind = \"train\" or \"gearbox\")",
            "train.external.aero": "[[external.aero]] (scene.kind = \"train\" or \"gearbox\")",
            "train.external.unbalance": "[[external.unbalance]] (scene.kind = \"gearbox\")"}


def attr_name(key: str) -> str:
    """File key -> attribute name (unit suffix of :data:`core.units.TO_SI` dropped)."""
    for suf in sorted(TO_SI, key=len, reverse=True):
        if suf and key.endswith("_" + suf):
            return key[: -len(suf) - 1]
    return key


def schema_markdown() -> str:
    """Markdown tables of :data:`SCHEMA` (key, type, default, allowed, meaning)."""
    lines = []
    for sec, specs in SCHEMA.items():
        if not specs:
            continue
        head = HEADINGS.get(sec, f"[[{sec}]]" if "." in sec else f"[{sec}]")
        if sec == "micro_geometry.gear":
            head = "[micro_geometry.gear1]`, `[micro_geometry.gear2]`, `[micro_geometry.both]"
        lines += [f"### `{head}`", "", "| key | type | default | allowed | meaning |",
                  "|---|---|---|---|---|"]
        for key, sp in specs.items():
            kind = {"floats": "list of floats", "ints": "list of ints", "vec3": "[x, y, z]",
                    "pair": "[start, end]", "strs": "list of strings", "choice": "string"
                    }.get(sp.kind, sp.kind)
            d = "required" if sp.required else ("–" if sp.default is None else repr(sp.default))
            d = d.replace("'", '"').replace("True", "true").replace("False", "false")
            allowed = sp.range_text() if sp.kind not in ("bool", "str", "strs") else "–"
            lines.append(f"| `{key}` | {kind} | {d} | {allowed} | {sp.doc} |")
        lines.append("")
    return "\n".join(lines)

