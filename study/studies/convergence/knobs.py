"""The numerical knobs of the convergence study, one :class:`Knob` entry each.

A knob is the one scene value the study varies (everything else fixed); its entry says
which scene key it sets, how its default ladder is built around the scene's own value,
when it does not apply, which of its values is the most converged (the reference),
and which pipeline stages rerun for each value (their wall time is the knob's cost).
Adding a knob is one entry in :data:`KNOBS`; :func:`plan` and the study are driven by
that list (``docs/convergence.md`` describes the knobs for users).
"""
from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from study.scene.data import Scene
from study.scene.errors import SceneError
from study.scene.load import scene_from_dict
from study.scene.overrides import apply_overrides

logger = logging.getLogger(__name__)

__all__ = ["Knob", "KNOBS", "KNOB_NAMES", "KNOB_KEYS", "Setting", "knob", "applicable",
           "default_values", "knob_overrides", "plan", "fmt_value"]


def fmt_value(v) -> str:
    """A knob value as written in labels, tables and logs (``%g`` for floats)."""
    return f"{v:g}" if isinstance(v, float) else str(v)


@dataclass(frozen=True)
class Knob:
    """One convergence knob.

    Attributes
    ----------
    name : str
        Name on the command line (``--knob NAME=v1,v2``, ``--only NAME``).
    key : str
        Scene key it sets (``--set KEY=v1,v2`` is the same as ``--knob``).
    units : str
        Units of the knob's values (``-`` dimensionless).
    ladder : callable
        ``ladder(scene) -> [values]``: default values around the scene's own.
    overrides : callable
        ``overrides(scene, value) -> {"section.key": value}``: what one value sets
        (refuses a bad value with :class:`SceneError`).
    finest : callable
        ``min`` or ``max``: picks the most converged value (the knob's reference).
    stages : tuple of str
        Pipeline stages that rerun for each value; their wall time is the cost.
    requires : tuple of callable
        ``check(scene) -> reason or None``, in order: the first reason says why the
        knob does not apply to a scene.
    validate : callable, optional
        ``validate(name, value, scene)`` on the scene with the value set; raises
        :class:`SceneError` before any run.
    """

    name: str
    key: str
    units: str
    ladder: Callable[[Scene], list]
    overrides: Callable[[Scene, Any], dict]
    finest: Callable = max
    stages: tuple[str, ...] = ("hbm",)
    requires: tuple[Callable[[Scene], str | None], ...] = ()
    validate: Callable[[str, Any, Scene], None] | None = None

    def why_not(self, scene: Scene) -> str | None:
        """``None`` if the knob applies to ``scene``, else the reason it does not."""
        return next((r for r in (check(scene) for check in self.requires) if r), None)


# --------------------------------------------------------------------------- conditions

def _fe_only(scene: Scene) -> str | None:
    """The mesh, n_cm and cutoff knobs need an FE machine (meshed, reduced): the pump,
    the gearbox."""
    from machines import FEMachine, machine_for

    return None if isinstance(machine_for(scene), FEMachine) else "FE scenes only"


def _given_n_cm(scene: Scene) -> str | None:
    if scene.rom.n_cm is not None and not scene.rom.cutoff:
        return None
    return ("the scene selects modes by rom.cutoff_factor (knob cutoff)" if scene.rom.auto
            else "the scene selects modes by rom.cutoff_Hz")


def _auto_cutoff(scene: Scene) -> str | None:
    return None if scene.rom.auto else ("the scene gives rom.n_cm or rom.cutoff_Hz (knob "
                                        "n_cm, or none)")


def _no_explicit_harmonics(scene: Scene) -> str | None:
    return ("the scene gives an explicit hbm.harmonics set"
            if scene.hbm.harmonics is not None else None)


def _external(scene: Scene) -> str | None:
    return None if scene.external.present else "no external excitation (no sidebands)"


# --------------------------------------------------------------------------- ladders

def _mesh_size(scene: Scene) -> float:
    from machines import machine_for
    return float(machine_for(scene).mesh_size)


def _n_time(scene: Scene) -> int:
    from study.pipeline.model import harmonic_set
    return int(harmonic_set(scene).n_time)


def _halve_double(get: Callable[[Scene], int], lo: int, hi: int) -> Callable[[Scene], list]:
    """Ladder ×0.5, ×1, ×2 of an integer scene value, clipped to ``[lo, hi]``."""
    def ladder(scene: Scene) -> list:
        n = get(scene)
        return sorted({max(lo, round(n / 2)), n, min(hi, 2 * n)})
    return ladder


def _sideband_ladder(scene: Scene) -> list:
    s = scene.hbm.sideband_order
    return sorted({max(0, s - 1), s, s + 1})


def _aft_ladder(scene: Scene) -> list:
    n = _n_time(scene)
    return [n // 2, n, 2 * n]


def _cutoff_ladder(scene: Scene) -> list:
    f = scene.rom.cutoff_factor
    return sorted({max(1.0, 0.75 * f), f, 1.5 * f})


def _step_ladder(scene: Scene) -> list:
    m = scene.continuation.max_step
    span = scene.continuation.speed[1] - scene.continuation.speed[0]
    return sorted({min(2 * m, span), m, m / 2}, reverse=True)


# --------------------------------------------------------------------------- overrides

def _integer(key: str, name: str) -> Callable[[Scene, Any], dict]:
    def overrides(scene: Scene, value) -> dict:
        if isinstance(value, bool) or float(value) != int(value):
            raise SceneError(f"--knob {name}={value}: must be an integer")
        return {key: int(value)}
    return overrides


def _mesh_overrides(scene: Scene, value) -> dict:
    if not value > 0:
        raise SceneError(f"--knob mesh={value}: the mesh size factor must be > 0")
    return {"mesh.size": float(value) * _mesh_size(scene)}


def _cutoff_overrides(scene: Scene, value) -> dict:
    if not 1.0 <= float(value) <= 10.0:
        raise SceneError(f"--knob cutoff={value}: the cut-off factor must be in [1, 10]")
    return {"rom.cutoff_factor": float(value)}


def _step_overrides(scene: Scene, value) -> dict:
    v = float(value)
    c = scene.continuation
    return {"continuation.max_step_rpm": v, "continuation.step_rpm": min(c.step, v),
            "continuation.min_step_rpm": min(c.min_step, c.step, v)}


def _check_aft(name: str, value, scene: Scene) -> None:
    try:
        _n_time(scene)  # HarmonicSet checks n_time > 2 max index
    except ValueError as exc:
        raise SceneError(f"--knob {name}={fmt_value(value)}: {exc}") from exc


# --------------------------------------------------------------------------- the list

#: The knobs, in the order they are swept.
KNOBS: tuple[Knob, ...] = (
    Knob("mesh", "mesh.size", "factor of the preset size", lambda s: [1.5, 1.0, 0.75],
         _mesh_overrides, finest=min, stages=("mesh", "fe", "rom", "hbm"),
         requires=(_fe_only,)),
    Knob("n_cm", "rom.n_cm", "-", _halve_double(lambda s: s.rom.n_cm, 1, 5000),
         _integer("rom.n_cm", "n_cm"), stages=("fe", "rom", "hbm"),
         requires=(_fe_only, _given_n_cm)),
    Knob("cutoff", "rom.cutoff_factor", "× the highest excitation frequency", _cutoff_ladder,
         _cutoff_overrides, stages=("fe", "rom", "hbm"), requires=(_fe_only, _auto_cutoff)),
    Knob("harmonics", "hbm.mesh_harmonics", "-",
         _halve_double(lambda s: s.hbm.mesh_harmonics, 1, 200),
         _integer("hbm.mesh_harmonics", "harmonics"), requires=(_no_explicit_harmonics,)),
    Knob("sidebands", "hbm.sideband_order", "-", _sideband_ladder,
         _integer("hbm.sideband_order", "sidebands"),
         requires=(_no_explicit_harmonics, _external)),
    Knob("aft", "hbm.aft_samples", "samples per period", _aft_ladder,
         _integer("hbm.aft_samples", "aft"), validate=_check_aft),
    Knob("step", "continuation.max_step_rpm", "rpm", _step_ladder, _step_overrides,
         finest=min),
)
#: Knob names in sweep order.
KNOB_NAMES: tuple[str, ...] = tuple(k.name for k in KNOBS)
#: Scene key each knob changes.
KNOB_KEYS: dict[str, str] = {k.name: k.key for k in KNOBS}
_BY_NAME = {k.name: k for k in KNOBS}


def knob(name: str, option: str = "--knob") -> Knob:
    """The knob called ``name``; :class:`SceneError` naming ``option`` if there is none."""
    try:
        return _BY_NAME[name]
    except KeyError:
        raise SceneError(f"{option} {name!r}: unknown knob; allowed: "
                         f"{', '.join(KNOB_NAMES)}") from None


def applicable(scene: Scene, name: str) -> str | None:
    """``None`` if the knob applies to the scene, else the reason it does not."""
    return knob(name).why_not(scene)


def default_values(scene: Scene, name: str) -> list:
    """Default values of a knob around the scene's own value."""
    return knob(name).ladder(scene)


def knob_overrides(scene: Scene, name: str, value) -> dict:
    """Scene overrides (``{"section.key": value}``) that set knob ``name`` to ``value``."""
    return knob(name).overrides(scene, value)


@dataclass(frozen=True)
class Setting:
    """One run of the study: a knob, its value and the scene overrides it means."""

    knob: str
    value: float
    overrides: dict

    @property
    def label(self) -> str:
        return f"{self.knob}={fmt_value(self.value)}"


def plan(scene: Scene, knobs: dict[str, list] | None = None,
         only: list[str] | None = None) -> list[tuple[Setting, Scene]]:
    """Settings to run, each validated (raises :class:`SceneError` before any run).

    Parameters
    ----------
    scene
        The base scene (the study varies one knob at a time around it).
    knobs
        ``{knob: [values]}`` replacing the default values of those knobs.
    only
        Sweep only these knobs (default: every knob that applies to the scene).
    """
    knobs = dict(knobs or {})
    for k in list(knobs) + list(only or []):
        knob(k, "--knob/--only")
    chosen = [knob(k) for k in only] if only else list(KNOBS)
    out = []
    for kb in chosen:
        why = kb.why_not(scene)
        if why is not None:
            if only or kb.name in knobs:
                raise SceneError(f"--knob/--only {kb.name}: does not apply to scene "
                                 f"{scene.name!r} ({why})")
            logger.info("knob %s skipped: %s", kb.name, why)
            continue
        values = knobs.get(kb.name) or kb.ladder(scene)
        if len(values) < 2:
            raise SceneError(f"--knob {kb.name}={values}: give at least 2 values")
        logger.info("knob %s (%s, %s): %s", kb.name, kb.key, kb.units,
                    ", ".join(fmt_value(v) for v in values))
        for v in values:
            ov = kb.overrides(scene, v)
            sc = scene_from_dict(apply_overrides(scene.raw, ov), scene.name, scene.text)
            if kb.validate is not None:
                kb.validate(kb.name, v, sc)
            out.append((Setting(kb.name, v, ov), sc))
    if not out:
        raise SceneError(f"no knob applies to scene {scene.name!r}")
    return out
