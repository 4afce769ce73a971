"""Scene -> HBM inputs: gear meshes, harmonic set, excitation and the HBM problem.

The linear part (M, C, K), the directions of the gear meshes and the forcing come from
the scene's machine (:mod:`machines`: a lumped machine's linear system, or an FE
machine's ROM); this module adds what the scene says about each mesh and the excitation
(eq. 12–16) and builds the :class:`hbm.HBMProblem` with one gear-mesh element per mesh
of the machine.
"""
from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

from machines import FEMachine, LinearModel, Machine, machine_for
from study.scene.data import Scene

logger = logging.getLogger(__name__)

__all__ = ["gear_meshes", "harmonic_set", "build_problem", "scene_problem"]


def gear_meshes(scene: Scene, machine: Machine, G) -> list:
    """One :class:`hbm.GearMesh` per mesh of the machine, along its column of ``G``
    ``(n, E)`` (k_m and TE per mesh harmonic from the scene, static load from the
    machine's torque path, SI)."""
    from hbm import GearMesh

    G = np.asarray(G)
    specs = machine.gear_meshes
    if G.ndim != 2 or G.shape[1] != len(specs):
        raise ValueError(f"G.shape = {G.shape}: must be (n, {len(specs)}), one direction per "
                         "gear mesh of the machine")
    te = scene.transmission_error
    loads = machine.static_mesh_loads()
    return [GearMesh(direction=np.ascontiguousarray(G[:, e]), n_teeth=m.teeth,
                     stiffness=scene.mesh_stiffness.coefficients(),
                     te=te.coefficients(), backlash=scene.gear.backlash,
                     static_load=loads[e], te_kind=te.kind, speed_ratio=m.speed_ratio,
                     name=m.name)
            for e, m in enumerate(specs)]


def harmonic_set(scene: Scene):
    """The :class:`hbm.HarmonicSet`: explicit list, or built from the excitation orders.

    Without external excitation the fundamental is the mesh frequency ZΩ and the
    indices are 0…n (``hbm.mesh_harmonics``); with it, the shaft frequency Ω with
    mesh harmonics kZ, the external orders and their sidebands.
    """
    from hbm import HarmonicSet

    h = scene.hbm
    n_time = h.aft_samples or None
    ext = scene.external.orders
    if h.harmonics is not None:
        if ext:
            return HarmonicSet(h.harmonics, ratio=1, fundamental="shaft", n_time=n_time)
        return HarmonicSet(h.harmonics, ratio=scene.gear.teeth, fundamental="mesh",
                           n_time=n_time)
    return HarmonicSet.build(scene.gear.teeth, h.mesh_harmonics, ext, h.sideband_order,
                             n_time=n_time, kind=h.harmonic_set)


def build_problem(scene: Scene, machine: Machine, linear: LinearModel):
    """Assemble :class:`hbm.HBMProblem` from the machine's linear model and forcing."""
    from hbm import Excitation, HBMProblem, LinearSystem

    system = LinearSystem(np.asarray(linear.M), np.asarray(linear.C), np.asarray(linear.K))
    exc = Excitation(system.n_dof, constant=linear.constant,
                     omega_squared=linear.omega_squared or {})
    return HBMProblem(system, gear_meshes(scene, machine, linear.G), exc, harmonic_set(scene),
                      condensation=scene.hbm.condensation,
                      linear_solver=scene.hbm.linear_solver)


def scene_problem(scene: Scene, rom_dir: str | Path | None = None):
    """(HBMProblem, RomData or None) of a scene: a lumped machine's own linear system, or
    an FE machine's ROM read from its cached rom folder ``rom_dir``."""
    machine = machine_for(scene)
    if isinstance(machine, FEMachine):
        if rom_dir is None:
            raise ValueError(f"scene.kind = {scene.scene.kind!r}: the problem is built on a "
                             "ROM; give its cached folder (rom_dir)")
        rom = machine.load_rom(Path(rom_dir))
        return build_problem(scene, machine, machine.linear_model(rom)), rom
    return build_problem(scene, machine, machine.linear_model()), None
