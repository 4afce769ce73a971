"""gears: the gear physics of geardyn, pure NumPy (imports :mod:`core` only).

- :mod:`gears.pair` — :class:`GearPair` (radii, working centre distance, path of
  contact, contact ratios), the gear-pair frame of Fig. 1 and the line-of-action
  vector G of eq. (11);
- :mod:`gears.iso6336` — ISO 6336-1 method B tooth stiffness c' and mesh stiffness c_γα;
- :mod:`gears.excitation` — mesh stiffness and static transmission error as Fourier
  series over the mesh period (rectangular-wave k_m of perfect teeth, q_s = F_s/k_m);
- :mod:`gears.spur`, :mod:`gears.compliance`, :mod:`gears.iso1328`, :mod:`gears.ltca` —
  the loaded tooth contact analysis of a 1:1 spur pair (docs/theory.md §13.3).

See docs/gears.md. SI units throughout.
"""
from .compliance import beam_compliance, pair_compliance, pitch_point_stiffness
from .excitation import (
    fourier_harmonics,
    fourier_sample,
    perfect_teeth_ste,
    rectangular_mesh_stiffness,
)
from .iso1328 import Deviations, class_deviations, iso1328_tolerances
from .iso6336 import (
    approximate_virtual_teeth,
    basic_rack_factor,
    mesh_stiffness,
    pair_stiffness,
    single_stiffness,
    theoretical_single_stiffness,
)
from .ltca import LtcaResult, scene_coefficients, solve_ltca
from .pair import (
    GearPair,
    contact_path_length,
    inverse_involute,
    involute,
    line_of_action_vector,
    pair_frame,
)
from .spur import SpurPair, check_pair

__all__ = [
    "GearPair", "contact_path_length", "involute", "inverse_involute",
    "line_of_action_vector", "pair_frame",
    "approximate_virtual_teeth", "basic_rack_factor", "mesh_stiffness", "pair_stiffness",
    "single_stiffness", "theoretical_single_stiffness",
    "fourier_harmonics", "fourier_sample", "perfect_teeth_ste", "rectangular_mesh_stiffness",
    "SpurPair", "check_pair", "beam_compliance", "pair_compliance", "pitch_point_stiffness",
    "Deviations", "class_deviations", "iso1328_tolerances",
    "LtcaResult", "scene_coefficients", "solve_ltca",
]
