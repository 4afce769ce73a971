"""Sensitivity of the excitation cases to the invented external inputs (issue 14 item 1).

Two small tools around ``geardyn excitations``:

``scene``
    Write a variant scene that ``extends`` a base scene and replaces its
    ``[[external.aero]]`` and ``[[external.unbalance]]`` tables (arrays of tables
    are replaced whole, docs/scenes.md) by the base's tables with scaled radial
    forces, scaled torques, a scaled unbalance, an extra phase on chosen orders, or
    orders dropped. Nothing else of the base changes.

``spans``
    Split the vibro-impact span of each case of one or more ``excitations.csv``
    (``impacts_rpm`` intervals) into speed bands, e.g. the low windows (500-1500 rpm),
    the H_Z region (1500-3500) and the high-speed end (3500-7000), with the change
    internal -> all per band. The code's span (whole range) is the sum of the bands
    when they cover the range; its definition is not changed here.

Example::

    python -m benchmarks.external_sensitivity scene scenes/pump-paper.toml out/v/nof.toml \
        --force-scale 0
    geardyn excitations out/v/nof.toml --out out/nof
    python -m benchmarks.external_sensitivity spans out/base out/nof
"""
from __future__ import annotations

import argparse
import csv
import logging
import math
import os
from dataclasses import dataclass
from pathlib import Path

from core.files import atomic_write
from study.scene.load import load_scene

log = logging.getLogger("external_sensitivity")

#: Default speed bands (rpm): the paper's low grazings, the H_Z region, the high end.
BANDS = ((500.0, 1500.0), (1500.0, 3500.0), (3500.0, 7000.0))


@dataclass(frozen=True)
class Scaling:
    """How the external tables of the base are changed (1 / 0 / empty: unchanged)."""

    force: float = 1.0
    torque: float = 1.0
    unbalance: float = 1.0
    drop_orders: tuple[int, ...] = ()
    phase_deg: float = 0.0
    phase_orders: tuple[int, ...] = ()


def _num(x: float) -> str:
    return repr(float(x))


def _wrap_deg(x: float) -> float:
    """Angle in degrees inside the scene's allowed [-360, 360] (unchanged if already)."""
    return x if abs(x) <= 360.0 else math.fmod(x, 360.0)


def variant_text(base: Path, out: Path, s: Scaling) -> str:
    """TOML text of a scene at ``out`` that extends ``base`` with scaled external tables.

    Parameters
    ----------
    base, out
        Base scene file and the path the variant will be written to (``extends`` is
        relative to it).
    s
        The scaling.

    Returns
    -------
    str
        The scene text.
    """
    for name, v in (("force", s.force), ("torque", s.torque), ("unbalance", s.unbalance)):
        if not (math.isfinite(v) and v >= 0):
            raise ValueError(f"{name} scale = {v}: must be finite and >= 0")
    scene = load_scene(base)
    ext = scene.external
    rel = os.path.relpath(Path(base).resolve(), Path(out).resolve().parent)
    lines = ["[scene]", f'extends = "{rel}"', f'name = "{scene.name}-{Path(out).stem}"', ""]
    unb = [u for u in ext.unbalance if s.unbalance > 0]
    aero = [a for a in ext.aero if a.order not in s.drop_orders]
    aero = [a for a in aero if s.force * any(a.force) or s.torque * any(a.torque)]
    if not unb or not aero:
        lines += ["[external]"] + (["unbalance = []"] if not unb else []) \
            + (["aero = []"] if not aero else []) + [""]
    for u in unb:
        lines += ["[[external.unbalance]]", f'shaft = "{u.shaft}"',
                  f"m_unb_kgm = {_num(u.m_unb * s.unbalance)}",
                  f"phase_deg = {_num(_wrap_deg(math.degrees(u.phase)))}", ""]
    for a in aero:
        ph = math.degrees(a.phase) + (s.phase_deg if a.order in s.phase_orders else 0.0)
        f = ", ".join(_num(x * s.force) for x in a.force)
        t = ", ".join(_num(x * s.torque) for x in a.torque)
        lines += ["[[external.aero]]", f'shaft = "{a.shaft}"']
        if a.station is not None:
            lines.append(f"station = {a.station}")
        lines += [f"order = {a.order}", f"force_N = [{f}]", f"torque_Nm = [{t}]",
                  f"phase_deg = {_num(_wrap_deg(ph))}", ""]
    return "\n".join(lines)


def write_variant(base: Path, out: Path, s: Scaling) -> Path:
    """Write :func:`variant_text` atomically to ``out`` and check that it loads."""
    text = variant_text(base, out, s)
    with atomic_write(out, "w") as f:
        f.write(text)
    load_scene(out)
    return Path(out)


def intervals(text: str) -> list[tuple[float, float]]:
    """``impacts_rpm`` of excitations.csv (``a-b;c-d``) as (start, end) pairs in rpm."""
    out = []
    for part in filter(None, text.split(";")):
        a, b = (float(x) for x in part.split("-"))
        if b < a:
            raise ValueError(f"impact interval {part!r}: end before start")
        out.append((a, b))
    return out


def band_length(iv: list[tuple[float, float]], lo: float, hi: float) -> float:
    """Total length (rpm) of the intervals inside [lo, hi]."""
    return sum(max(0.0, min(b, hi) - max(a, lo)) for a, b in iv)


def span_table(run: Path, bands: tuple[tuple[float, float], ...] = BANDS) -> dict:
    """Per case and band the span (rpm), and the change internal -> all per band.

    Returns ``{"cases": {case: {band: rpm}}, "change": {band: fraction or None}}``,
    bands keyed ``"lo-hi"``; the band ``"all"`` is the code's whole-range span.
    """
    with open(Path(run) / "excitations.csv", newline="") as f:
        rows = {r["case"]: r for r in csv.DictReader(f)}
    cases = {}
    for case, r in rows.items():
        iv = intervals(r["impacts_rpm"])
        d = {f"{lo:.0f}-{hi:.0f}": band_length(iv, lo, hi) for lo, hi in bands}
        d["all"] = float(r["span_rpm"])
        cases[case] = d
    change = {}
    if "internal" in cases and "all" in cases:
        for k, ref in cases["internal"].items():
            change[k] = cases["all"][k] / ref - 1.0 if ref > 0 else None
    return {"cases": cases, "change": change}


def spans_markdown(runs: list[Path], bands: tuple[tuple[float, float], ...] = BANDS) -> str:
    """Markdown table: per run, internal -> all span per band and its change."""
    keys = [f"{lo:.0f}-{hi:.0f}" for lo, hi in bands] + ["all"]
    head = "| run | " + " | ".join(f"{k} rpm" for k in keys) + " |"
    out = [head, "|---|" + "---|" * len(keys)]
    for run in runs:
        t = span_table(run, bands)
        cells = []
        for k in keys:
            a, b = t["cases"]["internal"][k], t["cases"]["all"][k]
            c = t["change"].get(k)
            cells.append(f"{a:.0f} → {b:.0f} ({'n/a' if c is None else f'{100 * c:+.1f} %'})")
        out.append(f"| {Path(run).name} | " + " | ".join(cells) + " |")
    return "\n".join(out)


def _ints(text: str) -> tuple[int, ...]:
    return tuple(int(x) for x in text.split(",") if x)


def _bands(text: str) -> tuple[tuple[float, float], ...]:
    return tuple(tuple(float(x) for x in b.split("-")) for b in text.split(","))


def main(argv: list[str] | None = None) -> int:
    """Command line: ``scene`` writes a variant, ``spans`` prints the band table."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    sc = sub.add_parser("scene", help="write a variant scene with scaled external tables")
    sc.add_argument("base", type=Path)
    sc.add_argument("out", type=Path)
    sc.add_argument("--force-scale", type=float, default=1.0)
    sc.add_argument("--torque-scale", type=float, default=1.0)
    sc.add_argument("--unbalance-scale", type=float, default=1.0)
    sc.add_argument("--drop-orders", type=_ints, default=())
    sc.add_argument("--phase-deg", type=float, default=0.0,
                    help="extra phase added to the aero tables of --phase-orders")
    sc.add_argument("--phase-orders", type=_ints, default=())
    sp = sub.add_parser("spans", help="span per speed band of excitations runs")
    sp.add_argument("runs", type=Path, nargs="+")
    sp.add_argument("--bands", type=_bands, default=BANDS, help="e.g. 500-1500,1500-3500")
    a = p.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    if a.cmd == "scene":
        s = Scaling(a.force_scale, a.torque_scale, a.unbalance_scale, a.drop_orders,
                    a.phase_deg, a.phase_orders)
        log.info("wrote %s", write_variant(a.base, a.out, s))
    else:
        log.info("%s", spans_markdown(a.runs, a.bands))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
