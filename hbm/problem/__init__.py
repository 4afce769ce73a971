"""The harmonic-balance problem of a linear system with nonlinear elements: its residual
and Jacobians (:mod:`.residual`) and the solution at one speed (:mod:`.fixed_speed`)."""

from .fixed_speed import Point
from .residual import HBMProblem

__all__ = ["HBMProblem", "Point"]
