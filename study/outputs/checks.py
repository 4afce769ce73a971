"""The checks a result must pass before its numbers are read as the machine's: the
banner at the top of report.md lists every one that fails (issue 39, "honest outputs").

=====================  ===============================================================
check                  fails when
=====================  ===============================================================
``rom_validity``       the ROM's coupled frequencies agree with the full FE model's
                       (Fig. 9, ``rom.n_check``) to a lower frequency than the highest
                       excitation frequency of the run (the highest excited mesh
                       harmonic k·Z or external order, at the top speed), or the ROM
                       was not checked (``rom.n_check = 0``)
``harmonic_truncation``the share of the mesh-load variance outside the retained
                       harmonic set exceeds :data:`TRUNCATION_LIMIT` at a sampled point
                       (:func:`truncation_share`)
``stability``          the harmonic set does not resolve the stability of some points
                       (between two folds of the balance, the variational equation
                       finds the orbit stable)
``residual``           a point's relative residual is not below the tolerance
``inputs``             an input is unusual (:mod:`study.scene.plausibility`)
``dynamic_ratio``      the peak mesh load exceeds 10 × the static one
                       (:func:`study.scene.plausibility.dynamic_ratio_warning`)
``speeds``             a time series or housing field asked at a speed could not be
                       solved there and shows the nearest point's speed
=====================  ===============================================================

:func:`run_checks` computes them from a run; report.md shows the banner
(:func:`banner_lines`) and a table of all; results.h5 stores them in ``/checks``.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from study.scene.frequency import highest_excitation_hz
from study.scene.plausibility import (
    DYNAMIC_RATIO_USUAL,
    dynamic_ratio_warning,
    plausibility_warnings,
)

logger = logging.getLogger(__name__)

__all__ = ["Check", "TRUNCATION_LIMIT", "TRUNCATION_POINTS", "run_checks", "rom_limit_hz",
           "highest_excitation_hz", "truncation_share", "truncation_survey", "banner_lines",
           "check_lines", "write_checks_group"]

#: Largest share of the mesh-load variance allowed outside the retained harmonic set
#: (1 %: the std is then within 0.5 % of the whole signal's).
TRUNCATION_LIMIT = 1e-2
#: Branch points sampled for the truncation (evenly in point order, plus the largest
#: std and the point outputs' speeds).
TRUNCATION_POINTS = 64


@dataclass(frozen=True)
class Check:
    """One check of a result: its name (module table), whether it passed and one
    sentence with the numbers (``value`` against ``limit`` where it has them)."""

    name: str
    passed: bool
    text: str
    value: float = float("nan")
    limit: float = float("nan")


def rom_limit_hz(rom) -> float | None:
    """Highest frequency (Hz) up to which the ROM was checked against the full model and
    found valid (:class:`reduction.validate.RomValidation` ``validity_hz``: the last
    checked frequency when every checked mode passes); 0 when not checked; None without a
    ROM (lumped scenes)."""
    if rom is None:
        return None
    v = getattr(rom, "validation", None)
    if v is None or len(v.full_hz) == 0:
        return 0.0
    return float(v.validity_hz)


def truncation_share(problem, point, element: int = 0) -> float:
    """Share of the mesh-load variance outside the retained harmonic set at ``point``.

    The mesh load f(t) is rebuilt on a grid four times finer than the AFT's from the
    retained displacement harmonics (:func:`hbm.spectrum`): its harmonics outside the set
    are what the balance leaves out (the impacts' higher harmonics). Returns
    Σ_{k ∉ set} |f_k|² / Σ_{k ≥ 1} |f_k|² (0 for a constant load).
    """
    from hbm import spectrum

    sp = spectrum(problem, point, element=element)
    idx, amp = np.asarray(sp["index"]), np.asarray(sp["amplitude"], dtype=float)
    power = amp ** 2
    total = float(np.sum(power[idx >= 1]))
    if total <= 0.0:
        return 0.0
    kept = np.isin(idx, np.asarray(problem.harmonics.indices))
    return float(np.sum(power[(idx >= 1) & ~kept])) / total


def truncation_survey(result, extra_rpm=()) -> tuple[float, float, int]:
    """(largest share, its speed in rpm, points sampled) of :func:`truncation_share` over
    :data:`TRUNCATION_POINTS` branch points evenly spread in point order, the point of
    largest std and the points nearest to ``extra_rpm``."""
    from study.outputs.points import point_at

    br = result.branch
    n = len(br)
    idx = set(np.linspace(0, n - 1, min(n, TRUNCATION_POINTS)).round().astype(int).tolist())
    idx.add(int(np.argmax(br.element(0).mesh_load_std)))
    idx |= {int(np.argmin(np.abs(br.rpm - r))) for r in extra_rpm}
    meshes = _gear_meshes(result.problem)
    shares = {i: max(truncation_share(result.problem, point_at(result, i), e) for e in meshes)
              for i in sorted(idx)}
    i = max(shares, key=shares.get)
    return shares[i], float(br.rpm[i]), len(idx)


def _gear_meshes(problem) -> list[int]:
    """Indices of the problem's gear-mesh elements."""
    from hbm import GearMesh

    return [e for e, el in enumerate(problem.elements) if isinstance(el, GearMesh)]


def _rom_check(result) -> Check | None:
    lim = rom_limit_hz(result.rom)
    if lim is None:
        return None
    f_exc, label = highest_excitation_hz(result.scene)
    if lim == 0.0:
        return Check("rom_validity", False, "ROM **not checked** against the full FE model "
                     f"(`rom.n_check = 0`); the excitation reaches {f_exc:.0f} Hz ({label})",
                     lim, f_exc)
    ok = lim >= f_exc
    v = result.rom.validation
    verdict = "covers" if ok else "**does not cover**"
    # every checked mode passed: the check, not the ROM, stops at its last mode
    short = bool(np.all(np.asarray(v.relative_error) <= v.tol))
    advice = ("leave `rom.n_check` unset (every mode up to the highest excitation "
              "frequency) or raise it: the check's last mode is the limit" if short else
              "raise `rom.cutoff_factor` (or `rom.n_cm`, `rom.cutoff_Hz` where the scene "
              "sets them)")
    return Check("rom_validity", ok,
                 f"ROM checked valid to {lim:.0f} Hz (tol {v.tol:g}), which {verdict} the "
                 f"highest excitation frequency {f_exc:.0f} Hz ({label})"
                 + ("" if ok else f"; levels above it (shaded in the plots) are not "
                    f"trustworthy: {advice}"), lim, f_exc)


def _truncation_check(result, extra_rpm) -> Check:
    if not result.problem.periodic:
        return Check("harmonic_truncation", True, "harmonic truncation not measured (a torus "
                     "basis: its response is quasi-periodic)")
    try:
        share, at, n = truncation_survey(result, extra_rpm)
    except (NotImplementedError, ValueError, RuntimeError) as exc:   # e.g. a torus basis
        return Check("harmonic_truncation", True, f"harmonic truncation not measured ({exc})")
    ok = share <= TRUNCATION_LIMIT
    hs = result.problem.harmonics
    return Check("harmonic_truncation", ok,
                 f"{share:.2%} of the mesh-load variance lies outside the {hs.n_harmonics} "
                 f"retained harmonics at {at:.1f} rpm (largest of {n} points sampled; limit "
                 f"{TRUNCATION_LIMIT:.0%})" + ("" if ok else ": the spectrum and the std miss "
                 "that part; raise `hbm.mesh_harmonics` / `sideband_order`"),
                 share, TRUNCATION_LIMIT)


def run_checks(result) -> list:
    """Every check of a finished (or partial) run, in the order of the module table."""
    sc, br = result.scene, result.branch
    out: list[Check] = []
    rom = _rom_check(result)
    if rom is not None:
        out.append(rom)
    if len(br):
        out.append(_truncation_check(result, (*sc.outputs.time_series,
                                              *sc.outputs.housing_field)))
    if sc.hbm.stability and len(br):
        bad = br.rpm[~np.asarray(br.stability_consistent, dtype=bool)
                     | np.asarray(br.stability_grazing, dtype=bool)]
        out.append(Check("stability", bad.size == 0,
                         "stability resolved at every point" if bad.size == 0 else
                         f"stability **not resolved** at {bad.size} points "
                         f"({bad.min():.1f}–{bad.max():.1f} rpm): the harmonic set does not "
                         "resolve the orbit there (between folds of the branch but stable by "
                         "the variational equation, or near grazing)", float(bad.size), 0.0))
    elif not sc.hbm.stability:
        out.append(Check("stability", False, "stability **not computed** "
                         "(`hbm.stability = false`): every point is listed as stable"))
    if len(br):
        r = float(np.max(br.residual))
        tol = sc.continuation.tolerance
        out.append(Check("residual", r < tol, f"largest relative residual {r:.2e} "
                         f"({'below' if r < tol else '**not below**'} the tolerance {tol:g})",
                         r, tol))
    warn = plausibility_warnings(sc)
    out.append(Check("inputs", not warn, "inputs inside their usual ranges" if not warn else
                     "unusual inputs: " + "; ".join(warn)))
    if len(br):
        ratio = _dynamic_ratio(result)
        if ratio is not None:
            r, peak, static, rpm, name = ratio
            w = dynamic_ratio_warning(peak, static, rpm)
            out.append(Check("dynamic_ratio", w is None, (w or f"peak mesh load {r:.3g} × the "
                             f"static load (at {rpm:.1f} rpm)") + name, r,
                             DYNAMIC_RATIO_USUAL))
    uses = getattr(result, "speed_uses", [])
    if uses:
        out.append(Check("speeds", all(u.exact for u in uses),
                         "; ".join(u.text for u in uses)))
    return out


def _dynamic_ratio(result) -> tuple[float, float, float, float, str] | None:
    """(ratio, peak load N, static load N, rpm, " (mesh `name`)" or "") of the gear mesh
    whose peak mesh load is the largest multiple of its static load; None without a
    loaded gear mesh."""
    br, best = result.branch, None
    els = result.problem.elements
    for e in _gear_meshes(result.problem):
        static = float(els[e].static_load)
        if static <= 0:
            continue
        mx = np.asarray(br.element(e).mesh_load_max)
        i = int(np.argmax(mx))
        name = f" (mesh `{els[e].name}`)" if len(els) > 1 else ""
        cand = (float(mx[i]) / static, float(mx[i]), static, float(br.rpm[i]), name)
        if best is None or cand[0] > best[0]:
            best = cand
    return best


def banner_lines(checks: list) -> list[str]:
    """The report's banner: a quote block naming every failed check, or nothing."""
    bad = [c for c in checks if not c.passed]
    if not bad:
        return []
    n = len(bad)
    return [f"> **⚠ This result fails {n} check{'' if n == 1 else 's'}** — read its numbers "
            "with that in mind (all checks: section *Checks*):", ">",
            *[f"> - `{c.name}`: {c.text}" for c in bad], ""]


def check_lines(checks: list) -> list[str]:
    """The report's *Checks* section: every check, passed or not."""
    out = ["## Checks", "", "| check | result | details |", "|---|---|---|"]
    out += [f"| `{c.name}` | {'ok' if c.passed else '**failed**'} | {c.text} |"
            for c in checks]
    return out + [""]


def write_checks_group(g, checks: list) -> None:
    """Fill ``/checks`` of results.h5 (``g``, the empty group): per check attributes
    ``<name>_passed``, ``<name>_text``, ``<name>_value``, ``<name>_limit``; ``n_failed``."""
    g.attrs["n_failed"] = sum(not c.passed for c in checks)
    for c in checks:
        g.attrs[f"{c.name}_passed"] = bool(c.passed)
        g.attrs[f"{c.name}_text"] = c.text
        g.attrs[f"{c.name}_value"] = float(c.value)
        g.attrs[f"{c.name}_limit"] = float(c.limit)
