"""``--set section.key=value`` overrides of a scene: the value list of the command
line (:func:`parse_set_values`) and setting dotted keys on the parsed TOML document
(:func:`apply_overrides`). The result is validated by :mod:`study.scene.load`.
"""
from __future__ import annotations

import copy
import tomllib
from typing import Any

from study.scene.errors import SceneError

__all__ = ["apply_overrides", "parse_set_values"]


def apply_overrides(raw: dict, overrides: dict[str, Any]) -> dict:
    """Return a copy of ``raw`` with ``{"section.key": value}`` set (validated later)."""
    out = copy.deepcopy(raw)
    for dotted, value in overrides.items():
        parts = dotted.split(".")
        if len(parts) < 2 or not all(parts):
            raise SceneError(f"--set {dotted}: must be section.key (e.g. load.torque_Nm)")
        node = out
        for p in parts[:-1]:
            nxt = node.setdefault(p, {})
            if not isinstance(nxt, dict):
                raise SceneError(f"--set {dotted}: {p!r} is not a table")
            node = nxt
        node[parts[-1]] = value
    return out


def parse_set_values(text: str) -> list[Any]:
    """Parse the value list of ``--set section.key=v1,v2`` with TOML value syntax.

    Lists are written with brackets and split at top-level commas only:
    ``speed_rpm=[500,4000],[500,8000]``.
    """
    items, depth, cur = [], 0, ""
    for ch in text:
        if ch == "[":
            depth += 1
        elif ch == "]":
            depth -= 1
        if ch == "," and depth == 0:
            items.append(cur)
            cur = ""
        else:
            cur += ch
    items.append(cur)
    out = []
    for s in items:
        s = s.strip()
        try:
            out.append(tomllib.loads(f"v = {s}")["v"])
        except tomllib.TOMLDecodeError:
            out.append(s)  # bare word -> string
    return out
