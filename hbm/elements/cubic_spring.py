"""A cubic spring: ``f(Delta) = k1 Delta + k3 Delta^3`` along a direction (a Duffing
nonlinearity, NLvib's and pyHarm's first example element).

A smooth, time-invariant element: it shows that the engine asks no more of an element
than its contract (:class:`hbm.elements.base.Element`). ``k1`` is moved into the linear
operator (eq. 17), the harmonic balance works with ``f' = k3 Delta^3``; the homotopy
parameter ``law`` scales the cubic term.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .base import Element, ElementStiffness, KinkCorrection, Statistic, check_direction
from .registry import register

__all__ = ["CubicSpring"]


@register
@dataclass(frozen=True, eq=False)
class CubicSpring(Element):
    """``f = linear Delta + cubic Delta^3`` along ``direction``.

    Parameters
    ----------
    direction
        (n,) ``Delta = direction^T q`` (m).
    linear
        ``k1`` (N/m), >= 0, moved into the linear operator.
    cubic
        ``k3`` (N/m^3), finite (negative: softening).
    name
        A label.
    """

    kind = "cubic_spring"
    statistics = (Statistic("force_std", "N"), Statistic("force_max", "N"),
                  Statistic("deflection_max", "m"))

    direction: np.ndarray
    linear: float
    cubic: float
    name: str = "cubic spring"

    def __post_init__(self) -> None:
        object.__setattr__(self, "direction", check_direction("spring", self.direction))
        k1, k3 = float(self.linear), float(self.cubic)
        if not np.isfinite(k1) or k1 < 0:
            raise ValueError(f"spring.linear = {self.linear!r}: must be >= 0 (N/m)")
        if not np.isfinite(k3):
            raise ValueError(f"spring.cubic = {self.cubic!r}: must be finite (N/m^3)")
        object.__setattr__(self, "linear", k1)
        object.__setattr__(self, "cubic", k3)

    @property
    def linear_stiffness(self) -> float:
        return self.linear

    def sample(self, phase: np.ndarray) -> None:
        """No parameter varies in time."""
        return None

    def force(self, delta: np.ndarray, samples=None, law: float = 1.0, corrected: bool = True,
              stiffness: bool = True) -> tuple[np.ndarray, ElementStiffness | None]:
        """``f' = law k3 Delta^3`` and ``law 3 k3 Delta^2`` (smooth: no correction)."""
        k3 = law * self.cubic
        d2 = delta * delta
        f = k3 * d2 * delta
        if not stiffness:
            return f, None
        return f, ElementStiffness(3.0 * k3 * d2, KinkCorrection.none(delta.shape))

    def load(self, delta: np.ndarray, samples=None, corrected: bool = False) -> np.ndarray:
        return self.linear * delta + self.cubic * delta * delta * delta

    def load_stiffness(self, delta: np.ndarray, samples=None) -> np.ndarray:
        return self.linear + 3.0 * self.cubic * delta * delta

    def time_force(self):
        k1, k3 = self.linear, self.cubic
        return lambda delta, ph: k1 * delta + k3 * delta * delta * delta

    def step_stiffness(self, delta: np.ndarray, samples=None) -> np.ndarray:
        """Trapezoidal mean of ``3 k3 Delta^2`` over each step (second order)."""
        s = 3.0 * self.cubic * delta * delta
        return 0.5 * (s + np.roll(s, -1))

    def measure(self, delta: np.ndarray, samples, periods: int) -> dict[str, Any]:
        """Std and maximum of the force (N), largest ``|Delta|`` (m)."""
        f = self.load(delta)
        return {"force_std": float(np.std(f)), "force_max": float(np.max(f)),
                "deflection_max": float(np.max(np.abs(delta)))}

    def scale(self, samples=None) -> float:
        """``sqrt(k1 / |k3|)``: where the cubic force equals the linear one (0 if either
        vanishes)."""
        if self.linear > 0 and self.cubic != 0:
            return float(np.sqrt(self.linear / abs(self.cubic)))
        return 0.0
