"""Craig–Bampton reduction onto the gear DOF, ROM validation, mesh energy, damping.

Public API (see docs/reduction.md)::

    cb  = craig_bampton(M, K, gear_dofs, n_modes=... | f_cut_hz=...)
    rom = build_rom(cb, G, km_mean, xi=0.05)
    rom.validation = validate_rom(rom, M, K, gear_dofs, G, km_mean, n_check)
    save_rom("rom.h5", rom); rom2 = load_rom("rom.h5"); T = load_basis("rom.h5")
    u = reconstruct(rom.T, q)
"""

from reduction.coupled import (
    Campbell,
    CoupledModes,
    campbell,
    couple,
    coupled_modes,
    dynamic_factor,
    mesh_energy,
    mesh_softening,
    modal_damping,
)
from reduction.craig_bampton import CBResult, craig_bampton, cutoff_from_speed
from reduction.io import load_basis, load_rom, save_rom
from reduction.pipeline import reduce_fe_model
from reduction.reconstruct import reconstruct
from reduction.rom import ROM, build_rom, gear_body_dof_names
from reduction.validate import (
    Validation,
    add_mesh_coupling,
    modes_to_check,
    validate_rom,
    validate_to,
)

__all__ = [
    "ROM",
    "CBResult",
    "Campbell",
    "CoupledModes",
    "Validation",
    "add_mesh_coupling",
    "build_rom",
    "campbell",
    "couple",
    "coupled_modes",
    "craig_bampton",
    "dynamic_factor",
    "gear_body_dof_names",
    "cutoff_from_speed",
    "load_basis",
    "load_rom",
    "mesh_energy",
    "mesh_softening",
    "modal_damping",
    "reconstruct",
    "reduce_fe_model",
    "save_rom",
    "validate_rom",
    "validate_to",
    "modes_to_check",
]
