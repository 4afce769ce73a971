"""The one checker of scene tables against their :class:`~study.scene.schema.Spec`.

:func:`check_table` refuses unknown keys (with a "did you mean"), wrong types,
values out of range and missing required keys with a :class:`SceneError` naming the
field, its value and what is allowed; it returns the table's values in SI units
(factors of :data:`core.units.TO_SI`) under their attribute names, defaults filled in.
"""
from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Collection, Iterable
from typing import Any

from core.errors import show, suggest
from core.units import TO_SI
from study.scene.errors import SceneError
from study.scene.schema import Spec, attr_name

__all__ = ["check_table", "check_value", "check_known"]


def _is_num(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _check_number(where: str, v: Any, spec: Spec) -> float | int:
    if spec.kind == "int":
        if not (isinstance(v, int) and not isinstance(v, bool)):
            if _is_num(v) and float(v).is_integer():
                v = int(v)
            else:
                raise SceneError(f"{where} = {show(v)}: must be an integer "
                                 f"({spec.range_text()})")
    elif not _is_num(v):
        raise SceneError(f"{where} = {show(v)}: must be a number ({spec.range_text()})")
    if not math.isfinite(v):
        raise SceneError(f"{where} = {show(v)}: must be finite ({spec.range_text()})")
    bad = False
    if spec.lo is not None:
        bad |= v <= spec.lo if spec.lo_open else v < spec.lo
    if spec.hi is not None:
        bad |= v >= spec.hi if spec.hi_open else v > spec.hi
    if bad:
        raise SceneError(f"{where} = {show(v)}: must be {spec.range_text()}")
    return v


def check_value(where: str, v: Any, spec: Spec) -> Any:
    """Type/range check one value; returns it converted to SI."""
    k = spec.kind
    factor = TO_SI[spec.unit]
    if k in ("float", "int"):
        n = _check_number(where, v, spec)
        return n if k == "int" else float(n) * factor
    if k == "bool":
        if not isinstance(v, bool):
            raise SceneError(f"{where} = {show(v)}: must be true or false")
        return v
    if k == "str":
        if not isinstance(v, str):
            raise SceneError(f"{where} = {show(v)}: must be a string")
        return v
    if k == "choice":
        if not isinstance(v, str) or v not in spec.choices:
            hint = suggest(v, spec.choices) if isinstance(v, str) else ""
            raise SceneError(f"{where} = {show(v)}: must be {spec.range_text()}{hint}")
        return v
    if k == "strs":
        if not isinstance(v, list) or not all(isinstance(s, str) for s in v):
            raise SceneError(f"{where} = {show(v)}: must be a list of strings")
        return tuple(v)
    if k in ("floats", "ints", "vec3", "pair"):
        if not isinstance(v, list):
            raise SceneError(f"{where} = {show(v)}: must be a list of numbers")
        if k == "vec3" and len(v) != 3:
            raise SceneError(f"{where} = {show(v)}: must be a list of 3 numbers (x, y, z)")
        if k == "pair" and len(v) != 2:
            raise SceneError(f"{where} = {show(v)}: must be a list [start, end] of 2 numbers")
        item = dataclasses.replace(spec, kind="int" if k == "ints" else "float")
        out = [check_value(f"{where}[{i}]", x, item) for i, x in enumerate(v)]
        if k == "pair" and not out[0] < out[1]:
            raise SceneError(f"{where} = {show(v)}: start must be smaller than end "
                             "(reversed or empty range)")
        return tuple(out)
    raise AssertionError(k)


def check_known(keys: Iterable[str], allowed: Collection[str], name: Callable[[str], str],
                what: str = "key", note: str = "") -> None:
    """Refuse the first of ``keys`` not in ``allowed``; ``name(key)`` is how the message
    names it, ``what`` what it is (key, section), ``note`` is appended to the message."""
    for key in keys:
        if key not in allowed:
            raise SceneError(f"{name(key)}: unknown {what}{suggest(key, allowed)}; "
                             f"allowed: {', '.join(allowed)}{note}")


def check_table(where: str, table: Any, specs: dict[str, Spec]) -> dict[str, Any]:
    """Validate one table against its specs; returns {attr: SI value} incl. defaults."""
    if not isinstance(table, dict):
        raise SceneError(f"[{where}] = {show(table)}: must be a table")
    check_known(table, specs, lambda key: f"{where}.{key}")
    out: dict[str, Any] = {}
    for key, spec in specs.items():
        if key in table:
            out[attr_name(key)] = check_value(f"{where}.{key}", table[key], spec)
        elif spec.required or (spec.default is None and spec.kind == "choice"):
            raise SceneError(f"{where}.{key}: missing (required; {spec.range_text()})")
        else:
            d = spec.default
            if d is not None and spec.kind in ("float", "floats", "vec3", "pair") and d != []:
                d = check_value(f"{where}.{key}", d, spec)
            elif isinstance(d, list):
                d = tuple(d)
            out[attr_name(key)] = d
    return out

