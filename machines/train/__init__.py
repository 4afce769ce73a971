"""machines.train: gear trains (issue 36).

- :mod:`machines.train.layout` — :class:`TrainLayout`, everything a train scene implies
  (shaft centres, speed ratios and senses, gear pairs, eq. 11 per mesh in the global
  frame, mesh phases, static loads from the torque path, the hunting fundamental) and
  the bad-input checks; pure (core, gears), shared by the lumped and FE train machines.
"""
from machines.train.layout import TrainGear, TrainLayout, TrainMesh, TrainShaft

__all__ = ["TrainLayout", "TrainShaft", "TrainGear", "TrainMesh"]
