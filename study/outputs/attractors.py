"""What the machine does where the periodic orbit is unstable: time integration from the
orbit at the most unstable point of each unstable segment (``[outputs]
attractor_transient_turns``, :func:`hbm.post.time_response.integrate`), for report.md.
"""
from __future__ import annotations

import csv
import io
import logging
import shutil
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np

from core.files import atomic_write
from hbm.post.time_response import TimeResponse, integrate
from study.outputs.curves import UnstableSegment, unstable_segments

logger = logging.getLogger(__name__)

__all__ = ["Attractor", "attractors", "attractor_line", "scene_time_response",
           "write_attractors_csv", "write_attractors_group"]


@dataclass
class Attractor:
    """The time response from the orbit at ``rpm``, the point of ``segment`` with the
    largest Floquet growth rate (``orbit_std``: that orbit's mesh-load std, N); when the
    refinement or the integration failed, ``response`` is None and ``error`` says why."""

    segment: UnstableSegment
    rpm: float
    orbit_std: float
    response: TimeResponse | None
    error: str = ""


def _most_unstable(br, seg: UnstableSegment) -> int:
    """Index of the segment's point with the largest Floquet growth rate on the branch
    (the orbit the machine leaves fastest; at a fold's end it would barely move)."""
    first, last = seg.index
    rate = np.asarray(br.floquet_max_real[first:last + 1], dtype=float)
    if not np.isfinite(rate).any():      # rates not recorded: the most loaded point
        rate = np.asarray(br.element(0).mesh_load_std[first:last + 1], dtype=float)
    return first + int(np.argmax(np.where(np.isfinite(rate), rate, -np.inf)))


def scene_time_response(result, point) -> TimeResponse | None:
    """:func:`hbm.post.time_response.integrate` from ``point`` with the scene's turns
    (``[outputs] attractor_transient_turns``, ``attractor_window_turns``), or None when
    the scene asks for no time responses (0 turns left out)."""
    o = result.scene.outputs
    if o.attractor_transient_turns == 0:
        return None
    return integrate(result.problem, point.rpm, point, transient=o.attractor_transient_turns,
                     window=o.attractor_window_turns)


def attractors(result) -> list[Attractor]:
    """One :class:`Attractor` per unstable segment of ``result.branch`` when the scene
    asks for them (``attractor_transient_turns`` > 0), else none. A point whose orbit
    Newton cannot refine, or whose integration fails, is logged and kept with the error
    (the run goes on)."""
    br = result.branch
    if result.scene.outputs.attractor_transient_turns == 0 or br is None or not len(br):
        return []
    problem = result.problem
    out = []
    mesh_std = br.element(0).mesh_load_std
    for seg in unstable_segments(br.rpm, mesh_std, br.stable, br.floquet_kind):
        i = _most_unstable(br, seg)
        rpm, std = float(br.rpm[i]), float(mesh_std[i])
        try:
            tr = scene_time_response(result, problem.solve(rpm, x0=br.unknowns[i],
                                                           tol=1e-10))
        except Exception as exc:                # noqa: BLE001 - reported, the run goes on
            logger.warning("time integration at %.1f rpm (%s segment) failed: %s", rpm,
                           seg.label, exc)
            out.append(Attractor(seg, rpm, std, None, f"{type(exc).__name__}: {exc}"))
            continue
        out.append(Attractor(seg, rpm, std, tr))
    return out


def attractor_line(a: Attractor, lines: int = 3) -> str:
    """One report.md line: the time response against the orbit it started from."""
    r = a.response
    if r is None:
        return f"    - time integration from the orbit at {a.rpm:.1f} rpm failed: {a.error}"
    s = r.window_std_per_turn
    kind = {True: "repeats itself every turn", None: "(one turn analysed: periodicity not "
            "judged)", False: "does not repeat itself within a turn (quasi-periodic, "
            "longer-period or not settled)"}[r.periodic]
    top = ", ".join(f"order {o:g} ({o * a.rpm / 60.0:.0f} Hz) {amp:.3g} N"
                    for o, amp in r.lines[:lines])
    return (f"    - time integration from the orbit at {a.rpm:.1f} rpm ({r.transient} turns "
            f"left out, {r.window} analysed): mesh-load std {r.std:.4g} N against the "
            f"orbit's {a.orbit_std:.4g} N ({r.std / a.orbit_std - 1:+.1%}), {s.min():.4g}–"
            f"{s.max():.4g} N per turn; {'it ' if r.periodic is not None else ''}{kind}; "
            f"strongest lines: {top}")


#: Columns of ``attractors.csv`` (docs/results-format.md).
CSV_COLUMNS = ["kind", "segment_from_rpm", "segment_to_rpm", "speed_rpm", "orbit_std_N",
               "response_std_N", "turn_std_min_N", "turn_std_max_N", "max_load_N",
               "periodic", "top_order", "top_amplitude_N", "turns_left_out",
               "turns_analysed", "error"]


def write_attractors_csv(path: Path, found: list[Attractor]) -> Path:
    """``attractors.csv``: one row per :class:`Attractor` (atomic write)."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(CSV_COLUMNS)
    for a in found:
        head = [a.segment.kind, f"{a.segment.rpm[0]:.6f}", f"{a.segment.rpm[1]:.6f}",
                f"{a.rpm:.6f}", f"{a.orbit_std:.8g}"]
        r = a.response
        if r is None:
            w.writerow(head + [""] * 10 + [a.error])
            continue
        s = r.window_std_per_turn
        order, amp = r.lines[0] if r.lines else (float("nan"), float("nan"))
        w.writerow(head + [f"{r.std:.8g}", f"{s.min():.8g}", f"{s.max():.8g}",
                           f"{r.max_load:.8g}", "" if r.periodic is None else int(r.periodic),
                           f"{order:.6g}", f"{amp:.8g}", r.transient, r.window, ""])
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
    with atomic_write(path) as tmp:
        shutil.copyfile(path, tmp)
        with h5py.File(tmp, "a") as f:
            if "attractors" in f:
                del f["attractors"]
            g = f.create_group("attractors")
            g.attrs["count"] = len(found)
            for i, a in enumerate(found):
                _write_one(g.create_group(str(i)), a)
    logger.info("wrote /attractors of %s", path)
    return path


def _write_one(g: h5py.Group, a: Attractor) -> None:
    g.attrs.update(kind=a.segment.kind, segment_rpm=np.array(a.segment.rpm), rpm=a.rpm,
                   orbit_std=a.orbit_std, error=a.error)
    r = a.response
    if r is None:
        return
    g.attrs.update(turns_left_out=r.transient, turns_analysed=r.window, std=r.std,
                   max_load=r.max_load, periodic=-1 if r.periodic is None else int(r.periodic))
    g["std_per_turn"] = r.std_per_turn
    g["lines"] = np.array(r.lines, dtype=float).reshape(-1, 2)
    g["delta_last_turn"] = r.delta
    if r.envelope is not None:
        g["peak_load"] = r.envelope.peak_load
        g["mean_dte"] = r.envelope.mean_dte
