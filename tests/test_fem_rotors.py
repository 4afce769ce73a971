"""Lumped rotor parts on the pump's gears (``fem.RotorParams``, docs/theory.md §13.5):
bad input is refused naming the field.

The rotors built into the FE model are checked against the same parts added exactly on
the plain pump's ROM by ``benchmarks/tests/test_fem_rotors_on_the_rom.py``: that route
(``benchmarks.grounded_gears``) is a tool of the calibration study, not of the product.
"""

from __future__ import annotations

import pytest

pytest.importorskip("dolfinx")

import fem  # noqa: E402

pytestmark = pytest.mark.fem


def test_rotor_params_refuse_a_rotor_without_its_spring() -> None:
    with pytest.raises(ValueError, match="rotors.inertia"):
        fem.RotorParams(inertia=0.05)
    with pytest.raises(ValueError, match=r"rotors.gear_mass = -1"):
        fem.RotorParams(gear_mass=-1.0)
    assert not fem.RotorParams().active


def test_rotor_params_refuse_a_rim_without_its_web() -> None:
    with pytest.raises(ValueError, match=r"rotors.rim_inertia = 0.0005.*all > 0"):
        fem.RotorParams(rim_inertia=5e-4, rim_mass=0.2)
    web = dict(inertia=0.18632, torsional_stiffness=1.5e5, gear_inertia=1.0e-4,
               gear_mass=0.18, lateral_stiffness=2.0e9, rim_inertia=5.1e-4, rim_mass=0.225,
               web_torsional_stiffness=7.0e5, web_radial_stiffness=1.7e9)
    assert fem.RotorParams(**web).webbed and not fem.RotorParams().webbed
