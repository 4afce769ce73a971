"""Nonlinear elements of the harmonic balance: the contract (:mod:`.base`), the registry of
kinds (:mod:`.registry`), the gear mesh (:mod:`.gear_mesh`, its dead-zone law in
:mod:`.contact_law`) and a cubic spring (:mod:`.cubic_spring`)."""

from .base import Element, ElementStiffness, EventTest, KinkCorrection, Statistic, take_samples
from .cubic_spring import CubicSpring
from .gear_mesh import GearMesh, MeshSamples
from .registry import ELEMENT_KINDS, make_element, register

__all__ = ["CubicSpring", "ELEMENT_KINDS", "Element", "ElementStiffness", "EventTest",
           "GearMesh", "KinkCorrection", "MeshSamples", "Statistic", "make_element",
           "register", "take_samples"]
