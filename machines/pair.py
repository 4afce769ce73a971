"""The one-pair machines' shared description: the 1:1 pair of ``[gear]``.

The pump (:class:`machines.pump.Pump`) and the single-DOF pair
(:class:`machines.lumped.LumpedGearPair`) are the same gear pair on two shafts ``in``
(the reference speed) and ``out``: gear bodies ``in/gear`` (gear 1, driving) and
``out/gear`` in the frame of Fig. 1 (:func:`gears.pair.pair_frame`), one mesh with the
eq. (11) vector of the ``[gear]`` angles and base radii
(:func:`gears.pair.line_of_action_vector`), the static load F_s = T / r_b1 and the
scene's mean mesh stiffness. :class:`OnePair` gives them to both; a machine says only
which FE node carries each gear (:meth:`OnePair.gear_node`).
"""
from __future__ import annotations

from fractions import Fraction
from functools import cached_property

from gears.pair import line_of_action_vector, pair_frame
from machines.base import GearBody, GearMeshSpec, Shaft

__all__ = ["OnePair", "SHAFTS"]

#: The two shafts of a one-pair machine: the reference (motor) shaft and the driven one.
SHAFTS = ("in", "out")


class OnePair:
    """Mixin of a :class:`machines.base.Machine` that is the 1:1 pair of ``[gear]``
    (module docstring); needs ``self.scene``."""

    def gear_node(self, shaft: str) -> str | None:
        """The FE node of the gear on ``shaft`` (None: no FE node, a lumped model)."""
        return None

    @cached_property
    def shafts(self) -> tuple[Shaft, ...]:
        z = self.scene.gear.teeth
        return (Shaft("in", Fraction(1)), Shaft("out", Fraction(z, z)))

    @cached_property
    def gear_bodies(self) -> tuple[GearBody, ...]:
        """``in/gear`` (gear 1, driving) and ``out/gear``, both in the frame of Fig. 1."""
        g = self.scene.gear
        frame = pair_frame(g.pressure_angle)
        return tuple(GearBody(f"{s}/gear", s, self.gear_node(s), g.teeth, g.base_radius,
                              frame) for s in SHAFTS)

    @cached_property
    def gear_meshes(self) -> tuple[GearMeshSpec, ...]:
        """The one mesh, eq. (11) with the ``[gear]`` angles and base radii."""
        g = self.scene.gear
        v = line_of_action_vector(g.pressure_angle, g.helix_angle, g.base_radius,
                                  g.base_radius)
        return (GearMeshSpec("gear mesh", ("in/gear", "out/gear"), v, g.teeth, Fraction(1)),)

    def static_mesh_loads(self) -> tuple[float, ...]:
        """F_s = T / r_b1 (``Scene.static_load``): the load torque T balanced by the
        motor through the mesh."""
        return (self.scene.static_load,)

    def mean_mesh_stiffness(self) -> tuple[float, ...]:
        return (self.scene.mesh_stiffness.mean,)
