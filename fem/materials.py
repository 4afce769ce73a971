"""Isotropic linear elastic materials (SI units)."""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class Material:
    """Isotropic linear elastic material.

    Attributes
    ----------
    E : float
        Young's modulus (Pa), > 0.
    nu : float
        Poisson's ratio, in (-1, 0.5).
    rho : float
        Density (kg/m^3), > 0.
    """

    E: float
    nu: float
    rho: float

    def __post_init__(self) -> None:
        if not (math.isfinite(self.E) and self.E > 0):
            raise ValueError(f"material.E = {self.E}: must be > 0 (Pa)")
        if not (-1.0 < self.nu < 0.5):
            raise ValueError(f"material.nu = {self.nu}: must be in (-1, 0.5)")
        if not (math.isfinite(self.rho) and self.rho > 0):
            raise ValueError(f"material.rho = {self.rho}: must be > 0 (kg/m^3)")

    @property
    def lame(self) -> tuple[float, float]:
        """Lamé parameters (lambda, mu) in Pa."""
        mu = self.E / (2.0 * (1.0 + self.nu))
        lam = self.E * self.nu / ((1.0 + self.nu) * (1.0 - 2.0 * self.nu))
        return lam, mu


STEEL = Material(E=210e9, nu=0.3, rho=7850.0)
CAST_IRON = Material(E=110e9, nu=0.28, rho=7200.0)
ALUMINIUM = Material(E=70e9, nu=0.33, rho=2700.0)
