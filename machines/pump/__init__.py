"""The pump of the paper (``scene.kind = "fe"``): :class:`Pump` and the conversion of
its free scene sections to the FE packages' parameters (:mod:`machines.pump.params`)."""
from machines.pump.machine import LOAD_NODES, N_STATIONS, PARTS, SHAFTS, Pump
from machines.pump.params import FEParameterError, FEParams, fe_parameters

__all__ = ["Pump", "LOAD_NODES", "N_STATIONS", "PARTS", "SHAFTS", "FEParams",
           "FEParameterError", "fe_parameters"]
