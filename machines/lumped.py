"""The lumped gear pair: a single DOF on the line of action (``scene.kind = "lumped"``,
``[lumped] model = "sdof"``; no FE).

Two rigid disks (inertias I1, I2, base radii r_b1, r_b2) coupled by the mesh. With
both rotations positive about +z, Δ = r_b1 θ1 + r_b2 θ2 (docs/architecture.md) and

    m_e Δ'' + c Δ' + f_LoA(Δ, t) = m_e (r_b1 T1(t)/I1 + r_b2 T2(t)/I2),
    m_e = I1 I2 / (I1 r_b2² + I2 r_b1²),

where T1 is the torque about +z on the input gear and T2 the torque about +z on the
output gear. The static part is F_s = T / r_b1 (the load torque T2 = T r_b2/r_b1
balances the input). The modal damping ratio ξ of the linearised system (mean mesh
stiffness k̄, eq. 17–19) gives c = 2 ξ sqrt(k̄ m_e). The linear stiffness K is 0:
the mesh carries all the stiffness, so (M, C, K, G) = ([m_e], [c], [0], [1]).
"""
from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from machines.base import LinearModel, LumpedMachine, Part
from machines.pair import OnePair
from machines.registry import register

__all__ = ["LumpedGearPair", "disk_inertia", "gear_inertias", "equivalent_mass",
           "sdof_matrices", "sdof_forcing"]


def disk_inertia(radius: float, width: float, density: float) -> float:
    """Polar inertia of a full disk, I = ½ ρ π w r⁴ (kg·m²)."""
    return 0.5 * density * math.pi * width * radius**4


def gear_inertias(scene: Any) -> tuple[float, float]:
    """(I1, I2) in kg·m²: given, or steel disks of pitch radius and face width."""
    if scene.lumped.inertia is not None:
        i1, i2 = scene.lumped.inertia
        return float(i1), float(i2)
    g = scene.gear
    i = disk_inertia(g.pitch_radius, g.face_width, scene.lumped.density)
    return i, i


def equivalent_mass(scene: Any) -> float:
    """m_e = I1 I2 / (I1 r_b2² + I2 r_b1²) (kg), or the given equivalent mass."""
    if scene.lumped.equivalent_mass is not None:
        return float(scene.lumped.equivalent_mass)
    i1, i2 = gear_inertias(scene)
    rb = scene.gear.base_radius
    return i1 * i2 / (i1 * rb**2 + i2 * rb**2)


def sdof_matrices(scene: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(M, C, K, G) of the single-DOF model, each (1, 1) or (1,), SI."""
    m = equivalent_mass(scene)
    c = 2.0 * scene.damping.modal_ratio * math.sqrt(scene.mesh_stiffness.mean * m)  # eq. (18)
    return np.array([[m]]), np.array([[c]]), np.zeros((1, 1)), np.ones(1)


def sdof_forcing(scene: Any) -> dict[int, np.ndarray]:
    """External force on Δ per shaft order {order: complex (1,) vector} (N).

    Order 0 is the static load F_s; aerodynamic torques about z (``torque_Nm[2]``)
    on the input/output gear add m_e r_b T_k / I per order, with
    T(t) = A cos(kΩt + φ) -> coefficient A e^{iφ}.
    """
    m = equivalent_mass(scene)
    if scene.lumped.inertia is not None or scene.lumped.equivalent_mass is None:
        i1, i2 = gear_inertias(scene)
    else:  # only m_e given: split symmetrically (I1 = I2 = 2 m_e r_b²)
        i1 = i2 = 2.0 * m * scene.gear.base_radius**2
    rb = scene.gear.base_radius
    out: dict[int, np.ndarray] = {0: np.array([scene.static_load], dtype=complex)}
    for a in scene.external.aero:
        lever = rb / (i1 if a.shaft == "in" else i2)
        coef = m * lever * a.torque[2] * np.exp(1j * a.phase)
        out[a.order] = out.get(a.order, np.zeros(1, complex)) + coef
    return out


@register
class LumpedGearPair(OnePair, LumpedMachine):
    """The 1:1 spur or helical pair of ``[gear]`` as one DOF Δ on the line of action.

    Its shafts, gear bodies ``in/gear`` and ``out/gear`` (no FE node) and its one mesh
    are those of the pump (:class:`machines.pair.OnePair`: same frame of Fig. 1 and
    eq. 11 vector); the model's coordinate is Δ itself, so its direction is 1.
    """

    kind = "lumped"
    model = "sdof"
    summary = "single-DOF gear pair, no FE"

    @property
    def load_nodes(self) -> tuple[str, ...]:
        """The gears: the static load and the aerodynamic torques act there."""
        return ("in/gear", "out/gear")

    @property
    def parts(self) -> tuple[Part, ...]:
        return ()

    def stage_inputs(self, stage: str) -> dict[str, Any]:
        if stage != "linear":
            raise ValueError(f"stage = {stage!r}: a lumped machine has the stage 'linear' only")
        s = self.scene
        return {"lumped": dataclasses.asdict(s.lumped), "gear": dataclasses.asdict(s.gear),
                "damping": dataclasses.asdict(s.damping),
                "mean_stiffness": s.mesh_stiffness.mean}

    def stage_code(self, stage: str) -> tuple[str, ...]:
        if stage != "linear":
            raise ValueError(f"stage = {stage!r}: a lumped machine has the stage 'linear' only")
        return ("machines.lumped",)

    def linear_model(self) -> LinearModel:
        """([m_e], [c], [0], [[1]]) and the forcing on Δ (:func:`sdof_forcing`)."""
        M, C, K, G = sdof_matrices(self.scene)
        return LinearModel(M, C, K, G.reshape(-1, 1), sdof_forcing(self.scene))
