"""The registry of machines: ``scene.kind`` (and, for a kind with several models, the
model named in the scene section of that kind) -> the :class:`machines.base.Machine`
subclass that builds it.

A machine class registers itself with the :func:`register` decorator when its module
is imported; :mod:`machines` imports every machine module (none of them loads the FE
stack at import), so :func:`kinds` lists them all. pyHarm keeps one such factory per
concept (systems, substructures, solvers), keyed by a type string.
"""
from __future__ import annotations

from typing import Any

from core.errors import InputError, suggest
from machines.base import Machine, check_contract

__all__ = ["register", "kinds", "models", "machine_class", "machine_for"]

#: kind -> model (None for a kind with one machine) -> class
_REGISTRY: dict[str, dict[str | None, type[Machine]]] = {}


def register(cls: type[Machine]) -> type[Machine]:
    """Class decorator: make ``cls`` the machine of its ``kind`` (and ``model``)."""
    kind = getattr(cls, "kind", None)
    if not isinstance(kind, str) or not kind:
        raise TypeError(f"{cls.__name__}.kind = {kind!r}: a machine class needs a kind")
    by_model = _REGISTRY.setdefault(kind, {})
    if cls.model in by_model and by_model[cls.model] is not cls:
        raise TypeError(f"{cls.__name__}: kind {kind!r} model {cls.model!r} is already "
                        f"registered by {by_model[cls.model].__name__}")
    by_model[cls.model] = cls
    return cls


def kinds() -> tuple[str, ...]:
    """The registered kinds, sorted."""
    return tuple(sorted(_REGISTRY))


def models(kind: str) -> tuple[str, ...]:
    """The model names of ``kind`` (empty when the kind has one machine without one)."""
    return tuple(sorted(m for m in _REGISTRY.get(kind, {}) if m is not None))


def machine_class(kind: str, model: str | None = None) -> type[Machine]:
    """The class registered for ``kind`` (and ``model`` when the kind has several).

    Raises
    ------
    core.errors.InputError
        Unknown kind (naming ``scene.kind`` and the known kinds) or model.
    """
    if kind not in _REGISTRY:
        raise InputError.of("scene.kind", kind, f"unknown machine kind"
                            f"{suggest(str(kind), kinds())}; known: "
                            f"{', '.join(repr(k) for k in kinds())}")
    by_model = _REGISTRY[kind]
    if model in by_model:
        return by_model[model]
    if len(by_model) == 1 and (model is None or None in by_model):
        return next(iter(by_model.values()))  # one machine: the kind says it all
    known = ", ".join(repr(m) for m in models(kind))
    raise InputError.of(f"{kind}.model", model, f"unknown {kind} model"
                        f"{suggest(str(model), models(kind))}; known: {known}")


def _scene_model(scene: Any, kind: str) -> str | None:
    """The model the scene names in the section called after its kind (``[lumped]
    model``), or None."""
    return getattr(getattr(scene, kind, None), "model", None)


def machine_for(scene: Any) -> Machine:
    """The machine of a validated scene, its description checked
    (:func:`machines.base.check_contract`)."""
    kind = scene.scene.kind
    cls = machine_class(kind, _scene_model(scene, kind))
    return check_contract(cls(scene))
