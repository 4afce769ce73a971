"""machines.train: gear trains (issue 36).

- :mod:`machines.train.layout` — :class:`TrainLayout`, everything a train scene implies
  (shaft centres, speed ratios and senses, gear pairs, eq. 11 per mesh in the global
  frame, mesh phases, static loads from the torque path, the hunting fundamental) and
  the bad-input checks; pure (core, gears), shared by the lumped and FE train machines;
- :mod:`machines.train.lumped` — :class:`LumpedTrain`, ``scene.kind = "train"``: the
  lumped torsional train (motor, gears, shaft springs, loads), one G column per mesh.
"""
from machines.train.layout import TrainGear, TrainLayout, TrainMesh, TrainShaft
from machines.train.lumped import LumpedTrain

__all__ = ["TrainLayout", "TrainShaft", "TrainGear", "TrainMesh", "LumpedTrain"]
