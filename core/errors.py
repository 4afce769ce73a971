"""Refused input, and the one way its messages read.

Bad input is refused early, before any work, by an error whose message names the field,
its value (with its unit when the field name does not carry it) and what is allowed::

    gear.backlash_um = -3: must be > 0
    module = -0.001 m: must be > 0

:class:`InputError` is that error (a :class:`ValueError`); packages derive their own
input errors from it (``study.scene.errors.SceneError`` for scene files).
:func:`check_range` refuses a number outside its range with that message, and
:func:`suggest` adds the closest allowed name to a message about an unknown one.
"""
from __future__ import annotations

import difflib
import math
from collections.abc import Iterable
from typing import Any

__all__ = ["InputError", "show", "range_text", "check_range", "suggest"]


def show(value: Any) -> str:
    """A value as error messages show it: strings quoted, everything else as ``str``."""
    return repr(value) if isinstance(value, str) else str(value)


def suggest(name: str, allowed: Iterable[str]) -> str:
    """`` (did you mean 'x'?)`` for the allowed name closest to ``name``
    (:func:`difflib.get_close_matches`, cutoff 0.5), or an empty string."""
    m = difflib.get_close_matches(name, list(allowed), n=1, cutoff=0.5)
    return f" (did you mean {m[0]!r}?)" if m else ""


def range_text(lo: float | None = None, hi: float | None = None, *, lo_open: bool = False,
               hi_open: bool = False) -> str:
    """The allowed range as messages write it: ``> 0``, ``>= 5 and <= 45``, ``any``.

    Parameters
    ----------
    lo, hi : float, optional
        Bounds; None for none.
    lo_open, hi_open : bool
        Whether the bound itself is excluded.
    """
    parts = []
    if lo is not None:
        parts.append(("> " if lo_open else ">= ") + f"{lo:g}")
    if hi is not None:
        parts.append(("< " if hi_open else "<= ") + f"{hi:g}")
    return " and ".join(parts) if parts else "any"


class InputError(ValueError):
    """Refused input; the message says which field, its value and what is allowed.

    Parameters
    ----------
    message : str
        The whole message (free text for the cases :meth:`of` does not fit: a missing
        key, a file that cannot be read, two fields that disagree).
    field, value, unit, allowed : optional
        The parts of the message, kept as attributes for callers that react to a field.

    Notes
    -----
    Build the usual message with :meth:`of`; the error pickles with its parts (it may
    cross a process boundary in a parallel run).
    """

    def __init__(self, message: str, *, field: str | None = None, value: Any = None,
                 unit: str = "", allowed: str = "") -> None:
        super().__init__(message)
        self.field = field
        self.value = value
        self.unit = unit
        self.allowed = allowed

    @classmethod
    def of(cls, field: str, value: Any, allowed: str, *, unit: str = "") -> InputError:
        """``"<field> = <value>[ <unit>]: <allowed>"``, e.g.
        ``InputError.of("module", -1e-3, "must be > 0", unit="m")``."""
        shown = show(value) + (f" {unit}" if unit else "")
        return cls(f"{field} = {shown}: {allowed}", field=field, value=value, unit=unit,
                   allowed=allowed)

    def __reduce__(self) -> tuple:
        return (_rebuild, (type(self), str(self), self.field, self.value, self.unit,
                           self.allowed))


def _rebuild(cls: type, message: str, field: str | None, value: Any, unit: str,
             allowed: str) -> InputError:
    return cls(message, field=field, value=value, unit=unit, allowed=allowed)


def check_range(field: str, value: float, *, lo: float | None = None,
                hi: float | None = None, lo_open: bool = False, hi_open: bool = False,
                unit: str = "", error: type[InputError] = InputError) -> float:
    """``value`` if it is a finite number within the range, else ``error``.

    Parameters
    ----------
    field : str
        Name of the field in the message.
    value : float
        The number to check.
    lo, hi, lo_open, hi_open
        The allowed range (see :func:`range_text`).
    unit : str
        Unit shown after the value (``"m"``, ``"rad"``), empty for none.
    error : type
        The :class:`InputError` subclass to raise.

    Returns
    -------
    float
        ``value``, unchanged.
    """
    bad = isinstance(value, bool) or not isinstance(value, (int, float))
    if not bad:
        bad = not math.isfinite(value)
        if lo is not None:
            bad |= value <= lo if lo_open else value < lo
        if hi is not None:
            bad |= value >= hi if hi_open else value > hi
    if bad:
        allowed = range_text(lo, hi, lo_open=lo_open, hi_open=hi_open)
        raise error.of(field, value, f"must be finite and {allowed}" if allowed != "any"
                       else "must be a finite number", unit=unit)
    return value
