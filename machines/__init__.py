"""machines: what a machine is to geardyn, and the machines it knows.

The contract (:mod:`machines.base`): a machine has gear bodies (6 DOF each, in a
frame), gear meshes between them (eq. 11 per mesh, the mesh frequency as an exact
multiple of the reference shaft speed), shafts and their speed ratios, the nodes where
loads act and its named parts; an FE machine (:class:`FEMachine`) builds its mesh, FE
model, ROM and the forcing on the reduced coordinates, a lumped machine
(:class:`LumpedMachine`) its linear system. The registry (:mod:`machines.registry`)
picks the machine of a scene by ``scene.kind``: ``"fe"`` the pump
(:class:`machines.pump.Pump`), ``"lumped"`` the single-DOF gear pair
(:class:`machines.lumped.LumpedGearPair`, model ``"sdof"``), ``"train"`` the lumped
torsional gear train (:class:`machines.train.LumpedTrain`, on the layout of
:mod:`machines.train.layout`).

Imports core, gears, geometry, fem and reduction — the FE stack only inside functions,
so that ``import machines`` and a lumped scene load no dolfinx, gmsh or petsc4py — and
never study. See docs/architecture.md, section "machines".
"""
from machines.base import (
    GearBody,
    GearMeshSpec,
    LinearModel,
    LumpedMachine,
    Machine,
    Part,
    Shaft,
    check_contract,
)
from machines.fe import FEMachine
from machines.lumped import LumpedGearPair
from machines.pump import Pump
from machines.registry import kinds, machine_class, machine_for, models, register
from machines.train.lumped import LumpedTrain

__all__ = ["Machine", "FEMachine", "LumpedMachine", "GearBody", "GearMeshSpec", "Shaft",
           "Part", "LinearModel", "check_contract", "register", "kinds", "models",
           "machine_class", "machine_for", "Pump", "LumpedGearPair", "LumpedTrain"]
