"""Pseudo-arc-length continuation in the speed of any residual with its tangent
(:func:`continue_branch`, NLvib's ``solve_and_continue`` is the model): the tracer
(:mod:`.tracer`), its corrector (:mod:`.corrector`), predictors (:mod:`.predictors`),
events (:mod:`.events`), the branch walking back over itself (:mod:`.revisits`), closed
loops (:mod:`.loops`) and the branch (:mod:`.branch`). What it needs of a problem and of
the measures of its points is declared in :mod:`.protocol`; it imports no problem."""

from .branch import Branch, ElementCurve, GrazingPoint, Recorder
from .context import SpeedRange, TraceContext
from .predictors import PREDICTORS
from .protocol import ContinuationModel, EventFunction, Measurement, Monitor
from .tracer import continue_branch

__all__ = ["PREDICTORS", "Branch", "ContinuationModel", "ElementCurve", "EventFunction",
           "GrazingPoint", "Measurement", "Monitor", "Recorder", "SpeedRange",
           "TraceContext", "continue_branch"]
