"""What the machine does where the periodic orbit is unstable: time integration from the
orbits of each unstable segment (``[outputs] attractor_transient_turns``, the most
unstable point or ``attractor_speeds_per_segment`` speeds spread over the segment,
optionally as a slow sweep, at most ``attractor_max_integrations``;
:func:`hbm.post.time_response.integrate`), each summarised by its Poincaré section
(:mod:`hbm.post.poincare`: period-k, quasi-periodic, chaotic-like), for report.md, the
bifurcation diagram (:mod:`study.outputs.bifurcation`) and docs/theory.md §16.
"""
from __future__ import annotations

import csv
import io
import logging
import math
from dataclasses import dataclass, replace
from pathlib import Path

import h5py
import numpy as np

from core.files import atomic_write
from hbm.post.poincare import Section
from hbm.post.time_response import TimeResponse, integrate
from study.outputs.curves import UnstableSegment, unstable_segments
from study.outputs.results import replace_group

logger = logging.getLogger(__name__)

__all__ = ["Attractor", "attractors", "attractor_line", "scene_time_response",
           "segment_points", "write_attractors_csv", "write_attractors_group",
           "SAME_ORBIT"]

#: Relative std difference within which a period-1 response is the orbit it started
#: from ("orbit kept"); beyond it the machine jumped to another periodic orbit.
SAME_ORBIT = 1e-2
#: Segment kinds in the order the integration budget serves them.
PRIORITY = ("neimark_sacker", "period_doubling", "unclassified", "fold")


@dataclass
class Attractor:
    """The time response at ``rpm``, a point of ``segment`` (``orbit_std``: that orbit's
    mesh-load std, N; ``growth``: its largest Floquet real part, 1/s), started from that
    orbit (``start`` = ``"orbit"``) or from the state a lower speed of the segment ended
    in (``"sweep from X rpm"``). When the refinement or the integration failed, or the
    run's bound on integrations left it out (``skipped``), ``response`` is None and
    ``error`` says why. ``perturbation``: the relative start disturbance used
    (``[outputs] attractor_perturbation``)."""

    segment: UnstableSegment
    rpm: float
    orbit_std: float
    response: TimeResponse | None
    error: str = ""
    start: str = "orbit"
    growth: float = math.nan
    skipped: bool = False
    perturbation: float = 0.0

    @property
    def transient_folds(self) -> float:
        """e-folds of growth of a disturbance of the start orbit over the turns left out,
        ``growth * transient * 60 / rpm`` (NaN without a response)."""
        if self.response is None:
            return math.nan
        return self.growth * self.response.transient * 60.0 / self.rpm

    @property
    def left_orbit(self) -> bool:
        """Whether the turns left out gave a disturbance of the start orbit the time to
        grow to the response's size: ``ln(1 / perturbation)`` e-folds (the orbit's own
        error, ~1e-10, without a disturbance). Always True for a sweep start."""
        if self.start != "orbit":
            return True
        need = math.log(1.0 / self.perturbation) if self.perturbation > 0 else math.log(1e10)
        folds = self.transient_folds
        return not math.isfinite(folds) or folds >= need

    @property
    def section(self) -> Section | None:
        """The response's classified Poincaré section (None without one)."""
        return None if self.response is None else self.response.poincare

    @property
    def outcome(self) -> str:
        """What the machine does there: ``"orbit kept"`` (period-1 with the orbit's std
        within :data:`SAME_ORBIT`), ``"another period-1 orbit"`` (a jump), ``"period-k"``,
        ``"quasi-periodic"``, ``"chaotic-like"``, ``"aperiodic"`` (not periodic, too few
        section samples to say more), ``"not settled"`` (not periodic, and the turns left
        out were too few for a disturbance of the orbit to grow: :attr:`left_orbit`),
        ``"not integrated"`` or ``"failed"``."""
        r = self.response
        if r is None:
            return "not integrated" if self.skipped else "failed"
        sec = self.section
        if sec is None:
            return ("orbit kept" if abs(r.std / self.orbit_std - 1) <= SAME_ORBIT else
                    "another period-1 orbit") if r.periodic else "aperiodic"
        if sec.kind == "periodic" and sec.period == 1:
            return "orbit kept" if abs(r.std / self.orbit_std - 1) <= SAME_ORBIT else \
                "another period-1 orbit"
        if sec.kind != "periodic" and not self.left_orbit:
            return "not settled"
        return sec.label


def _most_unstable(br, seg: UnstableSegment) -> int:
    """Index of the segment's point with the largest Floquet growth rate on the branch
    (the orbit the machine leaves fastest; at a fold's end it would barely move)."""
    first, last = seg.index
    rate = np.asarray(br.floquet_max_real[first:last + 1], dtype=float)
    if not np.isfinite(rate).any():      # rates not recorded: the most loaded point
        rate = np.asarray(br.element(0).mesh_load_std[first:last + 1], dtype=float)
    return first + int(np.argmax(np.where(np.isfinite(rate), rate, -np.inf)))


def segment_points(br, seg: UnstableSegment, n: int) -> list[int]:
    """Branch indices to integrate from on ``seg``: its most unstable point for ``n`` =
    1; else the points nearest ``n`` speeds spread evenly from its lowest to its highest
    speed (each once, at most the segment's points), by increasing speed."""
    if n < 1:
        raise ValueError(f"attractor_speeds_per_segment = {n}: must be >= 1")
    if n == 1:
        return [_most_unstable(br, seg)]
    first, last = seg.index
    rpm = np.asarray(br.rpm[first:last + 1], dtype=float)
    picked = {first + int(np.argmin(np.abs(rpm - r)))
              for r in np.linspace(rpm.min(), rpm.max(), n)}
    return sorted(picked, key=lambda i: (float(br.rpm[i]), i))


def scene_time_response(result, point) -> TimeResponse | None:
    """:func:`hbm.post.time_response.integrate` from ``point`` with the scene's turns
    (``[outputs] attractor_transient_turns``, ``attractor_window_turns``) and start
    disturbance (``attractor_perturbation``), or None when the scene asks for no time
    responses (0 turns left out)."""
    o = result.scene.outputs
    if o.attractor_transient_turns == 0:
        return None
    return integrate(result.problem, point.rpm, point, transient=o.attractor_transient_turns,
                     window=o.attractor_window_turns, perturbation=o.attractor_perturbation)


def _budget_order(segments: list[UnstableSegment]) -> list[int]:
    """Segment indices in the order the integration budget serves them: by kind
    (:data:`PRIORITY`), then largest std first."""
    def rank(i: int) -> tuple[int, float]:
        k = segments[i].kind
        return (PRIORITY.index(k) if k in PRIORITY else len(PRIORITY),
                -segments[i].peak_std)
    return sorted(range(len(segments)), key=rank)


def attractors(result) -> list[Attractor]:
    """The :class:`Attractor` of each speed of each unstable segment of ``result.branch``
    (:func:`segment_points`) when the scene asks for them (``attractor_transient_turns``
    > 0), else none; in branch order of the segments, by speed within one. At most
    ``attractor_max_integrations`` are integrated (:func:`_budget_order`); the others
    are kept as not integrated. A point whose orbit Newton cannot refine, or whose
    integration fails, is logged and kept with the error (the run goes on)."""
    br = result.branch
    o = result.scene.outputs
    if o.attractor_transient_turns == 0 or br is None or not len(br):
        return []
    mesh_std = br.element(0).mesh_load_std
    segments = unstable_segments(br.rpm, mesh_std, br.stable, br.floquet_kind)
    budget = o.attractor_max_integrations
    found: dict[int, list[Attractor]] = {}
    done: dict[bytes, Attractor] = {}      # a branch that winds repeats its points
    for j in _budget_order(segments):
        seg = segments[j]
        found[j] = []
        state, prev = None, None
        for i in segment_points(br, seg, o.attractor_speeds_per_segment):
            rpm, std = float(br.rpm[i]), float(mesh_std[i])
            growth = float(br.floquet_max_real[i])
            key = np.append(br.unknowns[i], rpm).tobytes()
            if state is None and key in done:          # the same orbit: the same response
                found[j].append(replace(done[key], segment=seg))
                continue
            if budget <= 0:
                found[j].append(Attractor(seg, rpm, std, None, "the run's bound "
                                          "attractor_max_integrations = "
                                          f"{o.attractor_max_integrations} was reached",
                                          growth=growth, skipped=True))
                continue
            budget -= 1
            a = _integrate_one(result, seg, i, state if o.attractor_sweep else None, prev)
            found[j].append(a)
            if a.start == "orbit":
                done[key] = a
            state = a.response.state if a.response is not None else None
            prev = rpm if a.response is not None else None
    return [a for j in range(len(segments)) for a in found[j]]


def _integrate_one(result, seg: UnstableSegment, i: int, state, prev: float | None
                   ) -> Attractor:
    """The time response at branch point ``i``: from its orbit (refined by Newton), or
    from ``state`` (the end of the integration at ``prev`` rpm: a sweep)."""
    br = result.branch
    rpm, std = float(br.rpm[i]), float(br.element(0).mesh_load_std[i])
    growth = float(br.floquet_max_real[i])
    o = result.scene.outputs
    try:
        if state is not None:
            tr = integrate(result.problem, rpm, state, transient=o.attractor_transient_turns,
                           window=o.attractor_window_turns)
            return Attractor(seg, rpm, std, tr, start=f"sweep from {prev:.1f} rpm",
                             growth=growth, perturbation=o.attractor_perturbation)
        tr = scene_time_response(result, result.problem.solve(rpm, x0=br.unknowns[i],
                                                              tol=1e-10))
    except Exception as exc:                # noqa: BLE001 - reported, the run goes on
        logger.warning("time integration at %.1f rpm (%s segment) failed: %s", rpm,
                       seg.label, exc)
        return Attractor(seg, rpm, std, None, f"{type(exc).__name__}: {exc}", growth=growth)
    return Attractor(seg, rpm, std, tr, growth=growth, perturbation=o.attractor_perturbation)


def attractor_line(a: Attractor, lines: int = 3) -> str:
    """One report.md line: the time response against the orbit it started from, its
    Poincaré section and what the machine does there (:attr:`Attractor.outcome`)."""
    r = a.response
    if r is None:
        if a.skipped:
            return f"    - at {a.rpm:.1f} rpm: not integrated ({a.error})"
        return f"    - time integration from the orbit at {a.rpm:.1f} rpm failed: {a.error}"
    s = r.window_std_per_turn
    kind = {True: "repeats itself every turn", None: "(one turn analysed: periodicity not "
            "judged)", False: "does not repeat itself within a turn (quasi-periodic, "
            "longer-period or not settled)"}[r.periodic]
    top = ", ".join(f"order {o:g} ({o * a.rpm / 60.0:.0f} Hz) {amp:.3g} N"
                    for o, amp in r.lines[:lines])
    where = f"from the orbit at {a.rpm:.1f} rpm" if a.start == "orbit" else \
        f"at {a.rpm:.1f} rpm {a.start}"
    return (f"    - time integration {where} ({r.transient} turns "
            f"left out, {r.window} analysed): mesh-load std {r.std:.4g} N against the "
            f"orbit's {a.orbit_std:.4g} N ({r.std / a.orbit_std - 1:+.1%}), {s.min():.4g}–"
            f"{s.max():.4g} N per turn; {'it ' if r.periodic is not None else ''}{kind}; "
            f"strongest lines: {top}{_section_text(a)}")


def _section_text(a: Attractor) -> str:
    """The Poincaré section's verdict for :func:`attractor_line` ("" without one)."""
    sec = a.section
    if sec is None:
        return ""
    extra = f", rotation {sec.rotation:.4g} of the fundamental" \
        if sec.kind in ("quasi-periodic", "chaotic-like", "aperiodic") else ""
    return (f"; Poincaré section ({sec.samples} samples, once per fundamental period): "
            f"{sec.label}{extra} — **{a.outcome}** ({a.response.seconds:.1f} s)")


#: Columns of ``attractors.csv`` (docs/results-format.md).
CSV_COLUMNS = ["kind", "segment_from_rpm", "segment_to_rpm", "speed_rpm", "orbit_std_N",
               "response_std_N", "turn_std_min_N", "turn_std_max_N", "max_load_N",
               "periodic", "top_order", "top_amplitude_N", "turns_left_out",
               "turns_analysed", "error", "start", "growth_rate_1_s", "section",
               "section_samples", "rotation", "outcome"]


def write_attractors_csv(path: Path, found: list[Attractor]) -> Path:
    """``attractors.csv``: one row per :class:`Attractor` (atomic write)."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(CSV_COLUMNS)
    for a in found:
        head = [a.segment.kind, f"{a.segment.rpm[0]:.6f}", f"{a.segment.rpm[1]:.6f}",
                f"{a.rpm:.6f}", f"{a.orbit_std:.8g}"]
        tail = [a.start, f"{a.growth:.6g}"]
        r = a.response
        if r is None:
            w.writerow(head + [""] * 10 + [a.error] + tail + ["", "", "", a.outcome])
            continue
        s = r.window_std_per_turn
        order, amp = r.lines[0] if r.lines else (float("nan"), float("nan"))
        sec = a.section
        w.writerow(head + [f"{r.std:.8g}", f"{s.min():.8g}", f"{s.max():.8g}",
                           f"{r.max_load:.8g}", "" if r.periodic is None else int(r.periodic),
                           f"{order:.6g}", f"{amp:.8g}", r.transient, r.window, ""] + tail
                   + (["", "", ""] if sec is None else
                      [sec.label, sec.samples, f"{sec.rotation:.6g}"])
                   + [a.outcome])
    path = Path(path)
    with atomic_write(path, "w") as fh:
        fh.write(buf.getvalue())
    logger.info("wrote %s", path)
    return path


def write_attractors_group(path: Path, found: list[Attractor]) -> Path:
    """Replace ``/attractors`` of an existing ``results.h5`` by ``found`` (one subgroup
    per :class:`Attractor`, docs/results-format.md). Atomic: a copy of the file is
    updated, then renamed over it, so everything else in it is kept as it was."""
    path = Path(path)
    with replace_group(path, "attractors") as g:
        g.attrs["count"] = len(found)
        for i, a in enumerate(found):
            _write_one(g.create_group(str(i)), a)
    logger.info("wrote /attractors of %s", path)
    return path


def _write_one(g: h5py.Group, a: Attractor) -> None:
    g.attrs.update(kind=a.segment.kind, segment_rpm=np.array(a.segment.rpm), rpm=a.rpm,
                   orbit_std=a.orbit_std, error=a.error, start=a.start, growth=a.growth,
                   outcome=a.outcome)
    r = a.response
    if r is None:
        return
    g.attrs.update(turns_left_out=r.transient, turns_analysed=r.window, std=r.std,
                   max_load=r.max_load, periodic=-1 if r.periodic is None else int(r.periodic),
                   seconds=r.seconds)
    g["std_per_turn"] = r.std_per_turn
    g["lines"] = np.array(r.lines, dtype=float).reshape(-1, 2)
    g["windowed_lines"] = np.array(r.windowed_lines(), dtype=float).reshape(-1, 2)
    g["delta_last_turn"] = r.delta
    if r.envelope is not None:
        g["peak_load"] = r.envelope.peak_load
        g["mean_dte"] = r.envelope.mean_dte
    if r.section is not None:
        g["section"] = r.section
        g["section_delta"] = r.section_delta
        sec = a.section
        g.attrs.update(section_kind=sec.kind, section_period=sec.period,
                       rotation=sec.rotation, concentration=sec.concentration)
