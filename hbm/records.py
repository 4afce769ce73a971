"""Named values read as a mapping or by attribute: the statistics of an element at one
point (:func:`hbm.point_stats`) and its curve along a branch
(:meth:`hbm.Branch.element`). The names are the element kind's
(:attr:`hbm.elements.Element.statistics`), so the record is a mapping, with attribute
access for reading (``stats.mesh_load_std`` or ``stats["mesh_load_std"]``)."""
from __future__ import annotations

from collections.abc import Iterator, Mapping
from typing import Any

__all__ = ["Record"]


class Record(Mapping):
    """Read-only named values (a mapping; each name also an attribute)."""

    __slots__ = ("_values",)

    def __init__(self, values: Mapping[str, Any]) -> None:
        object.__setattr__(self, "_values", dict(values))

    def __getitem__(self, name: str) -> Any:
        return self._values[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._values)

    def __len__(self) -> int:
        return len(self._values)

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__") or name == "_values":
            raise AttributeError(name)
        try:
            return self._values[name]
        except KeyError:
            raise AttributeError(f"{type(self).__name__} has no {name!r}; it holds "
                                 f"{', '.join(self._values)}") from None

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError(f"{type(self).__name__} is read-only")

    def __reduce__(self):
        return type(self), (self._values,)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({', '.join(self._values)})"
