"""``--set section.key=value`` overrides of a scene: the value list of the command
line (:func:`parse_set_values`) and setting dotted keys on the parsed TOML document
(:func:`apply_overrides`). The result is validated by :mod:`study.scene.load`.
"""
from __future__ import annotations

import copy
import re
import tomllib
from collections.abc import Sequence
from typing import Any

from study.scene.errors import SceneError

__all__ = ["apply_overrides", "entry_index", "parse_set_values"]


#: ``meshes[1]``: entry 1 (from 0) of an array of tables.
_INDEXED = re.compile(r"([A-Za-z_][\w-]*)\[(\d+)\]")


def apply_overrides(raw: dict, overrides: dict[str, Any]) -> dict:
    """Return a copy of ``raw`` with ``{"section.key": value}`` set (validated later).

    An entry of an array of tables (``[[meshes]]``, ``[[shafts]]``, ...) is named by its
    ``name`` key or by its index from 0: ``meshes.stage2.backlash_um`` or
    ``meshes[1].backlash_um``, and deeper tables of it as usual
    (``meshes.stage2.micro_geometry.both.tip_relief_um``).
    """
    out = copy.deepcopy(raw)
    for dotted, value in overrides.items():
        parts = dotted.split(".")
        if len(parts) < 2 or not all(parts):
            raise SceneError(f"--set {dotted}: must be section.key (e.g. load.torque_Nm)")
        node = out
        i = 0
        while i < len(parts) - 1:
            p = parts[i]
            m = _INDEXED.fullmatch(p)
            if m:
                node = _entry_at(node, m.group(1), int(m.group(2)), dotted)
            else:
                nxt = node.setdefault(p, {})
                if isinstance(nxt, list):        # an array of tables: the next part names
                    if i + 2 > len(parts) - 1:   # an entry
                        raise SceneError(f"--set {dotted}: [[{p}]] is an array of tables; "
                                         f"name an entry: {p}.<name>.<key> or {p}[i].<key>")
                    node = _entry_named(nxt, p, parts[i + 1], dotted)
                    i += 1
                elif isinstance(nxt, dict):
                    node = nxt
                else:
                    raise SceneError(f"--set {dotted}: {p!r} is not a table")
            i += 1
        node[parts[-1]] = value
    return out


def entry_index(dotted: str, array: str, names: Sequence[str]) -> int | None:
    """The index of the entry of ``[[array]]`` that the ``--set`` key ``dotted`` addresses
    (``array.<name>.…`` or ``array[i].…``, as :func:`apply_overrides` reads it; ``names``
    the entries' names in order), None when it addresses none of them."""
    parts = dotted.split(".")
    m = _INDEXED.fullmatch(parts[0])
    if m and m.group(1) == array and int(m.group(2)) < len(names):
        return int(m.group(2))
    if parts[0] == array and len(parts) > 2 and parts[1] in names:
        return list(names).index(parts[1])
    return None


def _tables(node: dict, key: str, dotted: str) -> list[dict]:
    entries = node.get(key) if isinstance(node, dict) else None
    if not isinstance(entries, list) or not all(isinstance(e, dict) for e in entries):
        raise SceneError(f"--set {dotted}: {key!r} is not an array of tables of the scene")
    return entries


def _entry_at(node: dict, key: str, index: int, dotted: str) -> dict:
    entries = _tables(node, key, dotted)
    if index >= len(entries):
        raise SceneError(f"--set {dotted}: index {index} out of range: [[{key}]] has "
                         f"{len(entries)} entries (0 to {len(entries) - 1})")
    return entries[index]


def _entry_named(entries: list, key: str, name: str, dotted: str) -> dict:
    hits = [e for e in entries if isinstance(e, dict) and e.get("name") == name]
    if len(hits) != 1:
        names = ", ".join(repr(e.get("name")) for e in entries if isinstance(e, dict))
        raise SceneError(f"--set {dotted}: [[{key}]] has no entry named {name!r} "
                         f"(its names: {names or 'none'}; or give its index: {key}[i])")
    return hits[0]


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
