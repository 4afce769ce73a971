"""gears: the gear physics of geardyn, pure NumPy (imports :mod:`core` only).

- :mod:`gears.pair` — :class:`GearPair` (radii, working centre distance, path of
  contact, contact ratios, form circles, interference and contact-ratio checks), the
  gear-pair frame of Fig. 1 and the line-of-action vector G of eq. (11);
- :mod:`gears.iso6336` — ISO 6336-1 method B tooth stiffness c' and mesh stiffness c_γα;
- :mod:`gears.excitation` — mesh stiffness and static transmission error as Fourier
  series over the mesh period (rectangular-wave k_m of perfect teeth, q_s = F_s/k_m);
- :mod:`gears.tooth`, :mod:`gears.flank`, :mod:`gears.iso1328`, :mod:`gears.ltca` —
  the loaded tooth contact analysis of a spur or helical pair with micro-geometry
  (tooth compliance, flank modifications and deviations, ISO 1328 classes, the LTCA,
  Harris maps, contact patterns, mesh and shaft-order series);
- :mod:`gears.te_table` — measured or third-party TE and stiffness tables as Fourier
  series;
- :mod:`gears.train` — mesh phasing in a train: the phase of each mesh's cycle from the
  tooth positions and the angles of the mating gears (idlers, intermediate shafts).

See docs/gears.md. SI units throughout.
"""
from .excitation import (
    Series,
    fourier_harmonics,
    fourier_sample,
    perfect_teeth_ste,
    rectangular_mesh_stiffness,
)
from .flank import (
    Flank,
    Relief,
    check_flank,
    eccentricity_pitch_deviations,
    flank_deviation,
    pitch_positions,
)
from .iso1328 import class_deviations, iso1328_tolerances
from .iso6336 import (
    approximate_virtual_teeth,
    basic_rack_factor,
    mesh_stiffness,
    pair_stiffness,
    single_stiffness,
    theoretical_single_stiffness,
)
from .ltca import (
    ContactPattern,
    HarrisMap,
    LtcaCase,
    LtcaResult,
    contact_pattern,
    harris_map,
    hunting_series,
    mesh_series,
    order_series,
    scene_coefficients,
    solve_ltca,
)
from .pair import (
    GearPair,
    contact_path_length,
    inverse_involute,
    involute,
    line_of_action_vector,
    pair_frame,
)
from .te_table import MeshTable, mesh_table, read_mesh_table, table_series
from .tooth import (
    STEEL,
    Material,
    beam_compliance,
    half_angle,
    hertz_compliance,
    pair_compliance,
    tooth_compliance,
)
from .train import (
    idler_phase_difference,
    mesh_phase,
    pitch_point_phase,
    relative_phase,
    tooth_half_angle,
    working_radius,
)

__all__ = [
    "GearPair", "contact_path_length", "involute", "inverse_involute",
    "line_of_action_vector", "pair_frame",
    "approximate_virtual_teeth", "basic_rack_factor", "mesh_stiffness", "pair_stiffness",
    "single_stiffness", "theoretical_single_stiffness",
    "Series", "fourier_harmonics", "fourier_sample", "perfect_teeth_ste",
    "rectangular_mesh_stiffness",
    "Material", "STEEL", "beam_compliance", "half_angle", "hertz_compliance",
    "pair_compliance", "tooth_compliance",
    "Flank", "Relief", "check_flank", "eccentricity_pitch_deviations", "flank_deviation",
    "pitch_positions",
    "class_deviations", "iso1328_tolerances",
    "LtcaCase", "LtcaResult", "solve_ltca", "HarrisMap", "harris_map", "ContactPattern",
    "contact_pattern", "mesh_series", "hunting_series", "order_series", "scene_coefficients",
    "MeshTable", "mesh_table", "read_mesh_table", "table_series",
    "idler_phase_difference", "mesh_phase", "pitch_point_phase", "relative_phase",
    "tooth_half_angle", "working_radius",
]
