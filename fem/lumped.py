"""Lumped 6x6 (or 12x12) mass and stiffness matrices of rigid bodies and springs.

All matrices are in the global frame, DOF order (ux, uy, uz, rx, ry, rz) per node,
SI units (kg, kg m^2, N/m, N m/rad).
"""

from __future__ import annotations

import math

import numpy as np


def _positive(name: str, value: float, allow_zero: bool = False) -> float:
    ok = math.isfinite(value) and (value >= 0 if allow_zero else value > 0)
    if not ok:
        raise ValueError(f"{name} = {value}: must be {'>= 0' if allow_zero else '> 0'}")
    return float(value)


def rigid_body_mass(mass: float, inertia: np.ndarray) -> np.ndarray:
    """6x6 mass matrix of a rigid body at its centre of mass.

    Parameters
    ----------
    mass : float
        Mass (kg), >= 0.
    inertia : array_like, shape (3, 3) or (3,)
        Inertia tensor about the centre (kg m^2), or its principal values.
    """
    _positive("mass", mass, allow_zero=True)
    J = np.asarray(inertia, dtype=float)
    J = np.diag(J) if J.shape == (3,) else J
    if J.shape != (3, 3) or not np.allclose(J, J.T) or np.linalg.eigvalsh(J).min() < 0:
        raise ValueError(f"inertia = {inertia!r}: must be a symmetric PSD 3x3 tensor")
    out = np.zeros((6, 6))
    out[:3, :3] = mass * np.eye(3)
    out[3:, 3:] = J
    return out


def disk_mass(
    outer_radius: float,
    bore_radius: float,
    width: float,
    density: float,
    axis: int = 2,
) -> np.ndarray:
    """6x6 mass matrix of a rigid annular disk (gear blank) about its centre.

    Parameters
    ----------
    outer_radius, bore_radius : float
        Radii (m), 0 <= bore < outer.
    width : float
        Face width along the axis (m), > 0.
    density : float
        Density (kg/m^3), > 0.
    axis : int
        Index of the disk axis in the global frame (2 = z).

    Returns
    -------
    numpy.ndarray, shape (6, 6)
        m = rho pi (Ro^2 - Ri^2) b, J_axis = m (Ro^2 + Ri^2) / 2,
        J_diam = m (3 (Ro^2 + Ri^2) + b^2) / 12.
    """
    _positive("outer_radius", outer_radius)
    _positive("bore_radius", bore_radius, allow_zero=True)
    if bore_radius >= outer_radius:
        raise ValueError(f"bore_radius = {bore_radius}: must be < outer_radius = {outer_radius}")
    _positive("width", width)
    _positive("density", density)
    if axis not in (0, 1, 2):
        raise ValueError(f"axis = {axis}: must be 0, 1 or 2")
    r2 = outer_radius**2 + bore_radius**2
    m = density * math.pi * (outer_radius**2 - bore_radius**2) * width
    J = np.full(3, m * (3.0 * r2 + width**2) / 12.0)
    J[axis] = 0.5 * m * r2
    return rigid_body_mass(m, J)


def axial_spring(
    radial: float,
    axial: float,
    tilting: float = 0.0,
    torsional: float = 0.0,
    axis: int = 2,
) -> np.ndarray:
    """Diagonal 6x6 stiffness of a bearing-like spring with a symmetry axis.

    Parameters
    ----------
    radial, axial : float
        Translational stiffness across / along the axis (N/m), >= 0.
    tilting, torsional : float
        Rotational stiffness about a diameter / the axis (N m/rad), >= 0.
    axis : int
        Index of the axis in the global frame (2 = z).
    """
    for name, v in (("radial", radial), ("axial", axial), ("tilting", tilting),
                    ("torsional", torsional)):  # fmt: skip
        _positive(name, v, allow_zero=True)
    if axis not in (0, 1, 2):
        raise ValueError(f"axis = {axis}: must be 0, 1 or 2")
    k = np.full(6, 0.0)
    k[:3] = radial
    k[axis] = axial
    k[3:] = tilting
    k[3 + axis] = torsional
    return np.diag(k)


def two_node(k6: np.ndarray) -> np.ndarray:
    """12x12 matrix of a spring ``k6`` (6x6) joining two nodes: [[k, -k], [-k, k]]."""
    k6 = np.asarray(k6, dtype=float)
    if k6.shape != (6, 6):
        raise ValueError(f"k6.shape = {k6.shape}: must be (6, 6)")
    return np.block([[k6, -k6], [-k6, k6]])
