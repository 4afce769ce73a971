"""Errors of a scene or run that ``geardyn`` reports without a traceback (the bottom
layer of :mod:`study`: imports nothing of it)."""
from __future__ import annotations

from core.errors import InputError

__all__ = ["SceneError", "StageUnavailable"]


class SceneError(InputError):
    """Invalid scene: the message names the field, its value and what is allowed
    (:class:`core.errors.InputError`, so a :class:`ValueError`); ``geardyn`` exit code 2."""


class StageUnavailable(RuntimeError):
    """A stage cannot run here (missing FE package); ``geardyn`` exit code 4."""
