"""The lumped torsional gear train (``scene.kind = "train"``; no FE).

One rotation about the shafts' axis (global z, positive counter-clockwise seen from +z)
per body: the motor, every gear of :class:`machines.train.layout.TrainLayout` (in the
order of ``[[gears]]``), and each load, in that order. Springs: the motor coupling
between the motor and the drive shaft's first gear (smallest axial position), a
torsional shaft spring between consecutive gears of each shaft (``torsional_stiffness``,
or G J / spacing with J = π d⁴/32, G = 80 GPa), a load coupling between each load
shaft's last gear and its load. A shaft's extra rotor inertia is split evenly on its
gears. Each mesh acts along the θ_z entries of its eq. (11) vector in the global frame
(``sense r_b`` on each gear: the torsional part of eq. 11; the translations are not
modelled here), so that

    M θ'' + C θ' + K θ + Σ_e g_e f_e(g_eᵀ θ, t) = T,

T the drive torque on the motor and the static load torques on the loads (opposing their
shafts' rotation: the rigid rotation of the train is unloaded and free, dropped at zero
frequency by the harmonic balance). Damping: the modal ratio ξ of ``[damping]`` in the
modes of K + Σ_e k̄_e g_e g_eᵀ (eq. 18–19).

Shaft-order excitation (``[[external.aero]]``): a torque ``A cos(k ρ_s Ω t + φ)`` about
+z (``torque_Nm[2]``; the model has no other DOF, so a force or an x/y moment is
refused) on shaft ``s``, spread evenly on its gears: the coefficient ``A e^{iφ} / n_s``
on each gear's rotation at the frequency ratio ``k ρ_s`` (an exact Fraction, the key
of :class:`hbm.Excitation`). An unbalance (``[[external.unbalance]]``) is a rotating
*lateral* force through the shaft's axis: it has no torque about the axis and this
model no lateral DOF, so it is refused (the FE gearbox, ``scene.kind = "gearbox"``,
takes it).
"""
from __future__ import annotations

import dataclasses
import math
from fractions import Fraction
from functools import cached_property
from typing import Any

import numpy as np
import scipy.linalg as sla

from core.errors import InputError
from machines.base import GearBody, GearMeshSpec, LinearModel, LumpedMachine, Part, Shaft
from machines.registry import register
from machines.train.layout import TrainLayout

__all__ = ["LumpedTrain", "SHEAR_MODULUS", "modal_damping", "train_matrices"]

#: Shear modulus of steel (Pa) for the default shaft torsional stiffness G J / L.
SHEAR_MODULUS = 80e9


def modal_damping(M: np.ndarray, K: np.ndarray, zeta: float) -> np.ndarray:
    """C = M Φ diag(2 ξ ω_j) Φᵀ M in the modes (Φᵀ M Φ = I) of (K, M) (eq. 19); modes of
    zero frequency (the rigid rotation) get none."""
    w2, phi = sla.eigh(K, M)
    w = np.sqrt(np.clip(w2, 0.0, None))
    return M @ phi @ np.diag(2.0 * zeta * w) @ phi.T @ M


def _shaft_stiffness(i: int, shaft: Any, a: Any, b: Any) -> float:
    """Torsional stiffness (N m/rad) of shaft ``i`` between its gears ``a`` and ``b``."""
    if shaft.torsional_stiffness is not None:
        return float(shaft.torsional_stiffness)
    if shaft.diameter is None:
        raise InputError(f"shafts[{i}].torsional_stiffness_Nm_per_rad: missing for shaft "
                         f"{shaft.name!r} with gears {a.name!r} and {b.name!r} (give it, or "
                         "diameter_mm for G J / spacing)", field=f"shafts[{i}]."
                         "torsional_stiffness_Nm_per_rad", allowed="> 0")
    spacing = abs(b.position - a.position)
    j = math.pi * shaft.diameter**4 / 32.0
    return SHEAR_MODULUS * j / spacing


def train_matrices(scene: Any, layout: TrainLayout) -> dict[str, Any]:
    """M, K (no meshes), G (one column per mesh: the θ_z entries of eq. 11), the static
    torques and the DOF names of the lumped train (see the module docstring)."""
    names = ["motor"] + [g.name for g in layout.gears] + [f"{ld.shaft}/load"
                                                          for ld in scene.loads]
    index = {n: i for i, n in enumerate(names)}
    n = len(names)
    m = np.zeros(n)
    K = np.zeros((n, n))

    def spring(a: int, b: int, k: float) -> None:
        K[a, a] += k
        K[b, b] += k
        K[a, b] -= k
        K[b, a] -= k

    drive = scene.drive
    m[0] = drive.motor_inertia
    for g in layout.gears:
        m[index[g.name]] = g.inertia
    for i, shaft in enumerate(scene.shafts):
        gears = layout.gears_on(shaft.name)
        for g in gears:
            m[index[g.name]] += shaft.inertia / len(gears)
        for a, b in zip(gears[:-1], gears[1:], strict=True):
            spring(index[a.name], index[b.name], _shaft_stiffness(i, shaft, a, b))
    first = layout.gears_on(drive.shaft)
    if not first:
        raise InputError.of("drive.shaft", drive.shaft, "has no gear")
    spring(0, index[first[0].name], drive.motor_torsional_stiffness)
    f0 = np.zeros(n)
    f0[0] = drive.torque * layout.shaft(drive.shaft).sense
    for i, ld in enumerate(scene.loads):
        j = index[f"{ld.shaft}/load"]
        m[j] = ld.inertia
        last = layout.gears_on(ld.shaft)
        if not last:
            raise InputError.of(f"loads[{i}].shaft", ld.shaft, "has no gear")
        spring(index[last[-1].name], j, ld.torsional_stiffness)
        f0[j] = -layout.shaft(ld.shaft).sense * layout.load_torques[ld.shaft]
    G = np.zeros((n, len(layout.meshes)))
    for e, mesh in enumerate(layout.meshes):
        G[index[mesh.gears[0]], e] += mesh.vector[5]
        G[index[mesh.gears[1]], e] += mesh.vector[11]
    return {"M": np.diag(m), "K": K, "G": G, "f0": f0, "names": tuple(names),
            "orders": shaft_order_torques(scene, layout, index)}


def check_torsional_external(external: Any) -> None:
    """Refuse what a torsional model cannot take, naming the field: an unbalance (a
    lateral force: module docstring), an ``[[external.aero]]`` force or x/y moment."""
    for i, u in enumerate(external.unbalance):
        raise InputError.of(f"external.unbalance[{i}].m_unb_kgm", u.m_unb,
                            "an unbalance is a rotating lateral force through the shaft "
                            "axis: no torque about it, and a lumped torsional train "
                            "(scene.kind = 'train') has no lateral DOF; use scene.kind = "
                            "'gearbox', or a shaft-order torque ([[external.aero]] "
                            "torque_Nm = [0, 0, Mz])", unit="kg m")
    for i, a in enumerate(external.aero):
        if any(a.force) or a.torque[0] or a.torque[1]:
            raise InputError.of(f"external.aero[{i}].force_N", [*a.force, *a.torque[:2]],
                                "a lumped torsional train takes torque_Nm = [0, 0, Mz] only "
                                "(about the shafts' axis; force_N and the x/y moments need "
                                "scene.kind = 'gearbox')", unit="N, N m")


def shaft_order_torques(scene: Any, layout: TrainLayout, index: dict[str, int]
                        ) -> dict[Fraction, np.ndarray]:
    """``{k ρ_s: complex (n,)}``: each ``[[external.aero]]`` torque ``A e^{iφ}`` about z
    spread evenly on the gears of its shaft (module docstring), summed per frequency."""
    out: dict[Fraction, np.ndarray] = {}
    ext = getattr(scene, "external", None)
    for a in getattr(ext, "aero", ()):
        gears = layout.gears_on(a.shaft)       # every shaft has one (the layout's check)
        p = int(a.order) * layout.shaft(a.shaft).speed_ratio
        v = out.setdefault(p, np.zeros(len(index), complex))
        c = a.torque[2] * np.exp(1j * a.phase) / len(gears)
        for g in gears:
            v[index[g.name]] += c
    return out


@register
class LumpedTrain(LumpedMachine):
    """A gear train of ``[[shafts]]``, ``[[gears]]``, ``[[meshes]]``, ``[drive]`` and
    ``[[loads]]`` as a lumped torsional model (module docstring): one G column per mesh,
    each mesh with its own stiffness, TE, backlash, phase and static load."""

    kind = "train"
    summary = "lumped torsional gear train of [[shafts]], [[gears]], [[meshes]], no FE"

    @cached_property
    def layout(self) -> TrainLayout:
        """The scene's :class:`TrainLayout` (its checks run here)."""
        return TrainLayout.from_scene(self.scene)

    def check(self) -> None:
        """The layout's checks, the matrices' (shaft stiffness data), and a periodic basis
        (``hbm.basis = "periodic"``) within ``hbm.max_aft_samples``."""
        check_torsional_external(self.scene.external)
        self._matrices  # noqa: B018  (builds and checks)
        h = self.scene.hbm
        if h.basis == "periodic":
            self.layout.check_periodic(h.mesh_harmonics, h.max_aft_samples,
                                       h.sideband_order)

    @cached_property
    def _matrices(self) -> dict[str, Any]:
        return train_matrices(self.scene, self.layout)

    @cached_property
    def shafts(self) -> tuple[Shaft, ...]:
        return tuple(Shaft(s.name, s.speed_ratio) for s in self.layout.shafts)

    @cached_property
    def gear_bodies(self) -> tuple[GearBody, ...]:
        return tuple(GearBody(g.name, g.shaft, None, g.teeth, g.base_radius, g.frame)
                     for g in self.layout.gears)

    @cached_property
    def gear_meshes(self) -> tuple[GearMeshSpec, ...]:
        return tuple(GearMeshSpec(m.name, m.gears, m.vector, m.teeth[0], m.speed_ratio)
                     for m in self.layout.meshes)

    @property
    def load_nodes(self) -> tuple[str, ...]:
        """The motor and the loads: the torques act there."""
        return tuple(n for n in self._matrices["names"] if n == "motor" or
                     n.endswith("/load"))

    @property
    def parts(self) -> tuple[Part, ...]:
        return ()

    def static_mesh_loads(self) -> tuple[float, ...]:
        """F_s of each mesh from the torque path (:class:`TrainLayout`)."""
        return tuple(m.static_load for m in self.layout.meshes)

    def mean_mesh_stiffness(self) -> tuple[float, ...]:
        return tuple(m.mesh_stiffness.mean for m in self.scene.meshes)

    def stage_inputs(self, stage: str) -> dict[str, Any]:
        if stage != "linear":
            raise ValueError(f"stage = {stage!r}: a lumped machine has the stage 'linear' only")
        s = self.scene
        return {"shafts": [dataclasses.asdict(x) for x in s.shafts],
                "gears": [dataclasses.asdict(x) for x in s.gears],
                "meshes": [dataclasses.asdict(x) for x in s.meshes],
                "drive": dataclasses.asdict(s.drive),
                "loads": [dataclasses.asdict(x) for x in s.loads],
                "damping": dataclasses.asdict(s.damping)}

    def stage_code(self, stage: str) -> tuple[str, ...]:
        if stage != "linear":
            raise ValueError(f"stage = {stage!r}: a lumped machine has the stage 'linear' only")
        return ("machines.train",)

    @property
    def dof_names(self) -> tuple[str, ...]:
        """Name of each coordinate: ``motor``, the gears, ``<shaft>/load``."""
        return self._matrices["names"]

    def linear_model(self) -> LinearModel:
        """M, C (modal ξ in the modes with the mean mesh stiffnesses), K, G, the static
        torques (order 0) and the shaft-order torques (keys ``k ρ_s``)."""
        mats = self._matrices
        M, K, G = mats["M"], mats["K"], mats["G"]
        km = np.asarray(self.mean_mesh_stiffness())
        C = modal_damping(M, K + (G * km) @ G.T, self.scene.damping.modal_ratio)
        return LinearModel(M, C, K, G, {0: mats["f0"].astype(complex), **mats["orders"]})
