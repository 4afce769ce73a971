"""The bifurcation diagram of a run: Poincaré samples of the mesh load against speed
(docs/theory.md §16), from

- the periodic branch (``result.branch``): one sample per point, the load at ``t = 0``
  of the fundamental period evaluated from the harmonics (stable or not, per point);
- secondary branches (period-k branches started at period doublings): any
  ``(problem, branch)`` pairs whose fundamental is the main one's divided by ``k``
  (:func:`hbm.post.poincare.periods_in`), ``k`` samples per point; read from
  ``result.secondary`` when the pipeline provides them (items with
  ``.problem`` and ``.branch``, or pairs);
- the time-integrated attractors of the unstable segments
  (:mod:`study.outputs.attractors`): every section sample of the analysed window — the
  independent check of the branches;

written to results.h5 ``/bifurcation`` (docs/results-format.md), drawn by
:func:`study.plots.bifurcation.bifurcation_plot`, and summarised per unstable segment in
report.md (:func:`response_lines`).
"""
from __future__ import annotations

import logging
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hbm import Point
from hbm.post.poincare import SECTION_KINDS, orbit_samples, periods_in
from study.outputs.results import replace_group

logger = logging.getLogger(__name__)

__all__ = ["Diagram", "SOURCES", "branch_samples", "diagram", "response_lines",
           "secondary_of", "write_bifurcation_group"]

#: Where a sample comes from, by code (``/bifurcation/source``).
SOURCES = ("periodic branch", "secondary branch", "time integration")
#: Section samples of one time integration kept in the diagram (the last ones).
MAX_TI_SAMPLES = 512


@dataclass
class Diagram:
    """Poincaré samples of the mesh load (element 0) against speed, one row per sample.

    ``rpm`` (rpm), ``load`` (N) and ``delta`` (the mesh deflection Delta at the same
    instant, m: smooth where the load is zero for lost contact); ``source`` a code of
    :data:`SOURCES`; ``branch`` 0 for the main branch, ``j`` for the ``j``-th secondary
    branch, the attractor's index for a time integration; ``point`` the branch point
    (or -1); ``stable`` 1/0 on a branch, -1 for a time integration (no verdict: it is
    the attractor);
    ``periods`` the reference periods in the sample's orbit (k of a period-k branch, 0
    for a time integration); ``section_kind`` the code (:data:`SECTION_KINDS`) of the
    integration's section (-1 on branches).
    """

    rpm: np.ndarray
    load: np.ndarray
    delta: np.ndarray
    source: np.ndarray
    branch: np.ndarray
    point: np.ndarray
    stable: np.ndarray
    periods: np.ndarray
    section_kind: np.ndarray

    def __len__(self) -> int:
        return int(self.rpm.size)

    def of(self, source: str) -> np.ndarray:
        """Mask of the samples from ``source`` (one of :data:`SOURCES`)."""
        return self.source == SOURCES.index(source)


def _point(branch, i: int) -> Point:
    return Point(rpm=float(branch.rpm[i]), omega=float(branch.omega[i]),
                 unknowns=branch.unknowns[i], coefficients=branch.stats["coefficients"][i],
                 residual=float(branch.residual[i]), iterations=int(branch.newton_iterations[i]))


def branch_samples(problem, branch, reference, element: int = 0
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int]:
    """Poincaré samples of every point of ``branch`` (a branch of ``problem``) on the
    section of ``reference`` (the main problem): ``(rpm (n,), load (n, k) N, delta (n, k)
    m, stable (n,), k)`` with ``k`` = :func:`hbm.post.poincare.periods_in`."""
    k = periods_in(reference, problem)
    n = len(branch)
    load, delta = np.empty((n, k)), np.empty((n, k))
    for i in range(n):
        load[i], delta[i] = orbit_samples(problem, _point(branch, i), k, element)
    return (np.asarray(branch.rpm, dtype=float), load, delta,
            np.asarray(branch.stable, dtype=bool), k)


def secondary_of(result) -> list[tuple]:
    """The run's secondary branches as ``(problem, branch)`` pairs
    (``result.secondary``: pairs or items with ``.problem`` and ``.branch``;
    none when the run has no such attribute)."""
    out = []
    for item in getattr(result, "secondary", None) or ():
        out.append(tuple(item) if isinstance(item, tuple | list) else
                   (item.problem, item.branch))
    return out


def diagram(result, secondary: Sequence[tuple] | None = None,
            found: Iterable | None = None) -> Diagram:
    """The run's :class:`Diagram`: its branch, ``secondary`` (default
    :func:`secondary_of`) and the attractors ``found`` (default ``result.attractors``).

    Raises
    ------
    ValueError
        On a torus basis (no period: a quasi-periodic forced response has no Poincaré
        section of one fundamental) or a secondary fundamental that is not the main one
        divided by a whole number.
    """
    pb = result.problem
    pb.require_periodic("bifurcation diagram")
    cols: dict[str, list] = {k: [] for k in ("rpm", "load", "delta", "source", "branch",
                                             "point", "stable", "periods", "section_kind")}

    def add(rpm, load, delta, source, branch, point, stable, periods, kind):
        n = np.size(load)
        for key, v in (("rpm", rpm), ("load", load), ("delta", delta), ("source", source),
                       ("branch", branch), ("point", point), ("stable", stable),
                       ("periods", periods), ("section_kind", kind)):
            cols[key].append(np.broadcast_to(np.asarray(v), (n,)).ravel()
                             if np.ndim(v) else np.full(n, v))

    pairs = [(pb, result.branch)] + list(secondary_of(result) if secondary is None
                                         else secondary)
    for j, (prob, br) in enumerate(pairs):
        if br is None or not len(br):
            continue
        rpm, load, delta, stable, k = branch_samples(prob, br, pb)
        idx = np.arange(len(br))
        add(np.repeat(rpm, k), load.ravel(), delta.ravel(), int(j > 0), j, np.repeat(idx, k),
            np.repeat(stable.astype(np.int8), k), k, -1)
    for j, a in enumerate(result.attractors if found is None else found):
        r = a.response
        if r is None or r.section is None:
            continue
        add(a.rpm, r.section[-MAX_TI_SAMPLES:], r.section_delta[-MAX_TI_SAMPLES:], 2, j, -1,
            -1, 0, a.section.code)
    if not cols["rpm"]:
        empty = np.zeros(0)
        return Diagram(empty, empty, empty, *(np.zeros(0, dtype=int) for _ in range(6)))
    cat = {k: np.concatenate(v) for k, v in cols.items()}
    return Diagram(rpm=cat["rpm"].astype(float), load=cat["load"].astype(float),
                   delta=cat["delta"].astype(float),
                   source=cat["source"].astype(np.int8), branch=cat["branch"].astype(np.int32),
                   point=cat["point"].astype(np.int32), stable=cat["stable"].astype(np.int8),
                   periods=cat["periods"].astype(np.int32),
                   section_kind=cat["section_kind"].astype(np.int8))


def write_bifurcation_group(path: Path, d: Diagram) -> Path:
    """Replace ``/bifurcation`` of an existing ``results.h5`` by ``d`` (atomic: a copy
    of the file is updated, then renamed over it; everything else is kept)."""
    path = Path(path)
    with replace_group(path, "bifurcation") as g:
        g.attrs["sources"] = ", ".join(SOURCES)
        g.attrs["section_kinds"] = ", ".join(SECTION_KINDS)
        g.attrs["element"] = 0
        for name in ("rpm", "load", "delta", "source", "branch", "point", "stable",
                     "periods", "section_kind"):
            g[name] = getattr(d, name)
    logger.info("wrote /bifurcation of %s", path)
    return path


def response_lines(result, found: Sequence | None = None,
                   secondary: Sequence[tuple] | None = None) -> list[str]:
    """report.md section: which response the machine reaches in each unstable segment
    that was integrated (the outcome at each speed, :attr:`Attractor.outcome`), with the
    secondary branches that cover it, and the cost of the integrations."""
    found = list(result.attractors if found is None else found)
    if not found:
        return []
    sec = secondary_of(result) if secondary is None else list(secondary)
    o = result.scene.outputs
    seconds = sum(a.response.seconds for a in found if a.response is not None)
    runs = sum(a.response is not None for a in found)
    turns = runs * (o.attractor_transient_turns + o.attractor_window_turns)
    lines = ["## What the machine does in the unstable segments", "",
             f"Time integration from the orbits of each unstable segment ({runs} "
             f"integrations of {o.attractor_transient_turns} + "
             f"{o.attractor_window_turns} shaft turns, {turns} turns in {seconds:.1f} s; "
             f"`attractor_speeds_per_segment = {o.attractor_speeds_per_segment}`"
             f"{', as a slow sweep' if o.attractor_sweep else ''}); each response is "
             "classified by its Poincaré section, once per fundamental period "
             "(docs/theory.md §16; the samples are in `/bifurcation` of results.h5 and "
             "in bifurcation.png):", "",
             "| segment (rpm) | kind | speeds | response reached |", "|---|---|---:|---|"]
    by_seg: dict = {}
    for a in found:
        by_seg.setdefault(a.segment, []).append(a)
    left: dict[str, int] = {}
    for seg, atts in by_seg.items():
        if all(a.skipped for a in atts):
            left[seg.label] = left.get(seg.label, 0) + 1
            continue
        words = _outcomes(atts, 3 if seg.rpm[1] - seg.rpm[0] < 1 else 1)
        cover = [f"period-{periods_in(result.problem, p)} branch computed at "
                 f"{float(np.min(b.rpm)):.1f}–{float(np.max(b.rpm)):.1f} rpm"
                 for p, b in sec if len(b) and np.min(b.rpm) <= seg.rpm[1]
                 and np.max(b.rpm) >= seg.rpm[0]]
        lines.append(f"| {seg.rpm[0]:.3f}–{seg.rpm[1]:.3f} | {seg.label} | {len(atts)} | "
                     + "; ".join([words] + cover) + " |")
    if left:
        lines += ["", f"Not integrated ({sum(left.values())} segments: "
                  + ", ".join(f"{k} {n}" for k, n in left.items())
                  + f"): the run's bound `attractor_max_integrations = "
                  f"{o.attractor_max_integrations}` was reached (Neimark–Sacker segments are "
                  "served first, then period doubling, then folds, largest std first)."]
    return lines + [""]


def _outcomes(atts: list, digits: int = 1) -> str:
    """The outcomes over a segment's speeds, one phrase: each distinct outcome with the
    speeds it holds at (rpm, ``digits`` decimals); quasi-periodic ones with their
    rotation; an orbit kept or a response not settled with fewer e-folds of growth over
    the turns left out than the start disturbance needs
    (:attr:`~study.outputs.attractors.Attractor.left_orbit`) marked as such."""
    groups: dict[str, list[str]] = {}
    for a in atts:
        tag = f"{a.rpm:.{digits}f}"
        if a.outcome in ("quasi-periodic", "chaotic-like") and a.section is not None:
            tag += f" (rotation {a.section.rotation:.3f})"
        if a.outcome in ("orbit kept", "not settled") and not a.left_orbit:
            tag += f" (only {a.transient_folds:.1f} e-folds of growth in the turns left " \
                   "out: too few to leave the orbit)"
        if a.response is not None and a.outcome != "orbit kept":
            tag += f" (std {a.response.std:.4g} N, orbit {a.orbit_std:.4g} N"
            if a.outcome == "aperiodic" and a.section is not None:
                tag += f"; {a.section.samples} section samples: too few to tell " \
                       "quasi-periodic from chaotic"
            tag += ")"
        groups.setdefault(a.outcome, []).append(tag)
    return "; ".join(f"**{k}** at {', '.join(v)} rpm" for k, v in groups.items())
