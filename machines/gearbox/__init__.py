"""The FE gearbox (``scene.kind = "gearbox"``): N parallel shafts in a housing,
:class:`machines.gearbox.machine.Gearbox`, and its FE sections
(:mod:`machines.gearbox.params`)."""
from machines.gearbox.machine import Gearbox, gear_node
from machines.gearbox.params import GearboxFEParams, HousingOptions, gearbox_parameters

__all__ = ["Gearbox", "gear_node", "GearboxFEParams", "HousingOptions",
           "gearbox_parameters"]
