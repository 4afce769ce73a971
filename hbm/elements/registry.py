"""The element kinds by name: a registry that element classes join with :func:`register`
(as pyHarm's factory of elements and sfepy's table of linear-combination conditions),
and :func:`make_element` that builds one from its kind and parameters (a scene, a file)."""
from __future__ import annotations

from typing import Any

from .base import Element

__all__ = ["ELEMENT_KINDS", "make_element", "register"]

#: Element classes by their ``kind``.
ELEMENT_KINDS: dict[str, type[Element]] = {}


def register(cls: type[Element]) -> type[Element]:
    """Class decorator: add an :class:`~hbm.elements.base.Element` subclass under its
    ``kind`` (refused when the kind is empty or taken by another class)."""
    kind = getattr(cls, "kind", "")
    if not isinstance(kind, str) or not kind:
        raise ValueError(f"{cls.__name__}.kind = {kind!r}: an element kind needs a name")
    if ELEMENT_KINDS.get(kind, cls) is not cls:
        raise ValueError(f"element kind {kind!r} is registered already "
                         f"({ELEMENT_KINDS[kind].__name__})")
    ELEMENT_KINDS[kind] = cls
    return cls


def make_element(kind: str, **parameters: Any) -> Element:
    """The element of kind ``kind`` with ``parameters`` (its fields: ``direction`` and the
    kind's own)."""
    if kind not in ELEMENT_KINDS:
        raise ValueError(f"element kind = {kind!r}: must be one of "
                         f"{', '.join(sorted(ELEMENT_KINDS))}")
    return ELEMENT_KINDS[kind](**parameters)
