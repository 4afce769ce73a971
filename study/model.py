"""Scene -> HBM inputs: gear mesh, harmonic set, excitation and the HBM problem.

The linear part (M, C, K) and the line of action G come from :mod:`study.lumped` or from
a ROM; this module adds what the scene says about the mesh and the excitation (eq. 12–16)
and builds the :class:`hbm.HBMProblem` with the gear mesh as its one element.
"""
from __future__ import annotations

import logging

import numpy as np

from study.lumped import sdof_forcing, sdof_matrices
from study.scene.data import Scene

logger = logging.getLogger(__name__)

__all__ = ["gear_mesh", "harmonic_set", "lumped_problem", "build_problem"]


def gear_mesh(scene: Scene, G):
    """The :class:`hbm.GearMesh` of the scene along the line of action ``G`` (k_m and TE
    per mesh harmonic, SI)."""
    from hbm import GearMesh

    te = scene.transmission_error
    return GearMesh(direction=np.asarray(G), n_teeth=scene.gear.teeth,
                    stiffness=scene.mesh_stiffness.coefficients(),
                    te=te.coefficients(), backlash=scene.gear.backlash,
                    static_load=scene.static_load, te_kind=te.kind)


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


def build_problem(scene: Scene, M, C, K, G, constant: dict, omega_squared: dict | None = None):
    """Assemble :class:`hbm.HBMProblem` from a linear model and forcing vectors."""
    from hbm import Excitation, HBMProblem, LinearSystem

    system = LinearSystem(np.asarray(M), np.asarray(C), np.asarray(K))
    exc = Excitation(system.n_dof, constant=constant, omega_squared=omega_squared or {})
    return HBMProblem(system, [gear_mesh(scene, G)], exc, harmonic_set(scene),
                      condensation=scene.hbm.condensation,
                      linear_solver=scene.hbm.linear_solver)


def lumped_problem(scene: Scene):
    """HBM problem of a lumped (single-DOF) scene."""

    M, C, K, G = sdof_matrices(scene)
    return build_problem(scene, M, C, K, G, sdof_forcing(scene))
