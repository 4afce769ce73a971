"""Gear estimates from the ``[gear]`` data: ISO 6336-1 tooth stiffness, the mesh
stiffness k_m(t) of perfect teeth and their loaded static transmission error.

Used by the scene loader when ``mesh_stiffness.estimate`` or
``transmission_error.estimate`` is true (docs/theory.md).
"""
from __future__ import annotations

import math

import numpy as np

from study.scene_data import GearData, MeshStiffness, TransmissionError

__all__ = ["iso6336_single_tooth_stiffness", "estimate_mesh_stiffness", "estimate_ste"]


def iso6336_single_tooth_stiffness(gear: GearData, static_load: float, cm: float) -> float:
    """Single-pair tooth stiffness c'·b_f (N/m) from ISO 6336-1 method B.

    c'_th = 1/q' with q' the standard polynomial in the virtual tooth numbers and
    profile shifts (mm·µm/N); c' = c'_th C_M C_R C_B cos β with C_R = C_B = 1 and a
    load correction (F_t/b / 100 N/mm)^0.25 when the line load is below 100 N/mm.
    """
    zn = gear.teeth / math.cos(gear.helix_angle) ** 3
    x = gear.profile_shift
    q = (0.04723 + 0.15551 / zn + 0.25791 / zn - 0.00635 * x - 0.11654 * x / zn
         - 0.00193 * x - 0.24188 * x / zn + 0.00529 * x * x + 0.00182 * x * x)
    c_th = 1.0 / q  # N/(mm·µm)
    c = c_th * cm * math.cos(gear.helix_angle)
    line_load = static_load * math.cos(gear.pressure_angle) / (gear.face_width * 1e3)  # N/mm
    if line_load < 100.0:
        c *= max(line_load, 1e-3) ** 0.25 / 100.0 ** 0.25
    return c * gear.face_width * 1e3 * 1e6  # N/(mm·µm) × mm -> N/µm -> N/m


def estimate_mesh_stiffness(gear: GearData, static_load: float, cm: float,
                            n_harmonics: int) -> MeshStiffness:
    """Rectangular-wave mesh stiffness from ISO 6336 (eq. 16 truncated to n harmonics).

    One pair (c'·b_f) carries the load for a fraction 2 − ε_α of the mesh period, two
    pairs for ε_α − 1: k_m(t) = c' b_f (1 + 𝟙_double(t)), whose mean is c' b_f ε_α and
    whose harmonics are 2 c' b_f sin(kπ(ε_α − 1))/(kπ), phased so that the double-contact
    zone is centred on t = 0.
    """
    k1 = iso6336_single_tooth_stiffness(gear, static_load, cm)
    eps = gear.contact_ratio
    d = eps - math.floor(eps)  # fraction with one more pair in contact
    n0 = math.floor(eps)
    amps, phases = [], []
    for k in range(1, n_harmonics + 1):
        a = 2.0 * k1 * math.sin(k * math.pi * d) / (k * math.pi)
        amps.append(abs(a))
        phases.append(0.0 if a >= 0 else math.pi)
    return MeshStiffness(k1 * (n0 + d), tuple(amps), tuple(phases), estimated=True)


def estimate_ste(ms: MeshStiffness, static_load: float, n_harmonics: int) -> TransmissionError:
    """Loaded STE of perfect teeth, q_s(t) = F_s / k_m(t), truncated to n mesh harmonics."""
    n = 256
    c = np.fft.rfft(static_load / ms.sample(n)) / n
    amps = tuple(float(2 * abs(c[j])) for j in range(1, n_harmonics + 1))
    phases = tuple(float(np.angle(c[j])) for j in range(1, n_harmonics + 1))
    return TransmissionError(float(c[0].real), amps, phases, estimated=True, kind="loaded")

