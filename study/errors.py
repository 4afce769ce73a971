"""Errors of a scene or run that ``geardyn`` reports without a traceback (the bottom
layer of :mod:`study`: imports nothing of it)."""
from __future__ import annotations

__all__ = ["SceneError", "StageUnavailable"]


class SceneError(ValueError):
    """Invalid scene: the message names the field, its value and what is allowed."""


class StageUnavailable(RuntimeError):
    """A stage cannot run here (missing FE package); ``geardyn`` exit code 4."""
