"""The secondary branches of a run, born at period doublings (:mod:`hbm.branching`): their
``/branches`` group of results.h5, their summary rows and their section of report.md.

Each branch is written as ``/branches/<name>`` (``period2_1``, ``period4_1``, ...) with
the datasets of the main branch (``continuation``, ``grazing``, ``folds``, by
:func:`study.outputs.results.write_branch`: its unknowns are those of the doubled
problem, its statistics over the doubled period) and attributes naming its parent, its
period, the fundamental of its harmonic set, where it was switched from and where it met
its parent again (docs/results-format.md, "/branches"), and the branch's NVH
(``/branches/<name>/nvh``: mesh load and, with a radiating housing, ERP and the
accelerometers per order of its own harmonic set, the half orders included). The same
group, read back (:func:`read_branches`), is what ``geardyn report`` and the stage cache
of ``branches`` rebuild the branches from; ``curves_branches.csv`` holds their curves
(:func:`write_branch_curves_csv`).
"""

from __future__ import annotations

import csv
import io
import logging
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from core.files import atomic_write
from hbm.stability import KINDS

logger = logging.getLogger(__name__)

__all__ = ["AttractingLevels", "BranchRow", "attracting_levels", "branch_rows", "report_lines",
           "write_branches_group", "read_branches", "secondary_nvh", "subharmonic_mask",
           "write_branch_curves_csv", "erp_lines", "CURVES_FILE"]

#: The curves of the secondary branches, beside curves.csv (docs/results-format.md).
CURVES_FILE = "curves_branches.csv"


@dataclass(frozen=True)
class BranchRow:
    """One secondary branch in words and numbers (report.md, the log)."""

    name: str
    parent: str
    period: int
    doubling_rpm: float          # where it was switched from (harmonic balance)
    floquet_rpm: float           # where the parent's Floquet verdict puts it (NaN: none)
    rejoin_rpm: float            # where it met its parent again (NaN: it did not)
    rpm_min: float
    rpm_max: float
    points: int
    stable_points: int
    stable_ranges: tuple[tuple[float, float], ...]
    max_std: float               # largest mesh-load std (N) of element 0
    max_std_rpm: float
    kinds: dict                  # unstable kind -> points
    status: str


def _runs(rpm: np.ndarray, mask: np.ndarray) -> tuple[tuple[float, float], ...]:
    """Speed intervals of the runs of consecutive points where ``mask`` holds."""
    out, start = [], None
    for i, m in enumerate(mask):
        if m and start is None:
            start = i
        if (not m or i == len(mask) - 1) and start is not None:
            stop = i if m else i - 1
            seg = rpm[start:stop + 1]
            out.append((float(seg.min()), float(seg.max())))
            start = None
    return tuple(out)


def branch_rows(secondary) -> list[BranchRow]:
    """A :class:`BranchRow` per :class:`hbm.branching.SecondaryBranch`."""
    rows = []
    for s in secondary:
        br = s.branch
        std = br.element(0).mesh_load_std
        i = int(np.argmax(std))
        stable = br.stable.astype(bool)
        rows.append(BranchRow(
            s.name, s.parent, s.period, s.doubling.rpm, s.doubling.floquet_rpm,
            s.rejoin_rpm, float(br.rpm.min()), float(br.rpm.max()), len(br),
            int(stable.sum()), _runs(br.rpm, stable), float(std[i]), float(br.rpm[i]),
            {KINDS[k]: int(np.sum(br.floquet_kind == k)) for k in range(1, len(KINDS))
             if np.any(br.floquet_kind == k)}, br.status))
    return rows


def write_branches_group(f, secondary, nvh: dict | None = None,
                         seconds: float | None = None) -> None:
    """``/branches/<name>`` of every secondary branch (see the module docstring): with
    ``nvh`` (name -> :class:`study.outputs.nvh.NVH`, :func:`secondary_nvh`) its
    ``nvh/`` group, with ``seconds`` what the stage cost (``branches.attrs["seconds"]``,
    the report's "N branches in X s")."""
    from study.outputs.nvh import write_nvh_group
    from study.outputs.results import write_branch

    if not secondary:
        return
    top = f.create_group("branches")
    top.attrs["names"] = [s.name for s in secondary]
    if seconds is not None:
        top.attrs["seconds"] = float(seconds)
    for s in secondary:
        g = top.create_group(s.name)
        write_branch(g, s.branch)
        hs = s.problem.harmonics
        g.attrs["parent"] = s.parent
        g.attrs["period"] = s.period
        g.attrs["ratio"] = str(hs.ratio)
        g.attrs["fundamental"] = hs.fundamental
        g.attrs["doubling_rpm"] = s.doubling.rpm
        g.attrs["doubling_omega"] = s.doubling.omega
        g.attrs["doubling_floquet_rpm"] = s.doubling.floquet_rpm
        g.attrs["doubling_bracket"] = s.doubling.index
        g.attrs["doubling_tau"] = s.doubling.tau
        g.attrs["rejoin_rpm"] = s.rejoin_rpm
        g.attrs["epsilon"] = s.epsilon
        g["doubling_vector"] = s.doubling.vector
        g["doubling_unknowns"] = s.doubling.unknowns
        if nvh and s.name in nvh:
            write_nvh_group(g, nvh[s.name])
            g["nvh/subharmonic"] = subharmonic_mask(s)


def _text(x) -> str:
    return x.decode() if isinstance(x, bytes) else str(x)


def read_branches(f, problem) -> tuple[list, float | None]:
    """The secondary branches written by :func:`write_branches_group` into the open HDF5
    file (or group) ``f``, each with its doubled problem rebuilt from its parent's
    (:func:`hbm.branching.doubled_problem`, as the stage built it), and the stage's cost
    (``seconds``, None when not recorded); ``([], None)`` without ``/branches``.

    Raises ValueError when a branch does not belong to ``problem`` (another harmonic set:
    its fundamental or number of unknowns differs)."""
    from hbm.branching import DoublingPoint, SecondaryBranch, doubled_problem
    from study.outputs.results import branch_from_group

    if "branches" not in f:
        return [], None
    top = f["branches"]
    problems = {"main": problem}
    name0 = problem.elements[0].name if len(problem.elements) == 1 else None
    out = []
    for name in (_text(x) for x in top.attrs["names"]):
        g = top[name]
        parent = _text(g.attrs["parent"])
        child = doubled_problem(problems[parent])
        if str(child.harmonics.ratio) != _text(g.attrs["ratio"]):
            raise ValueError(f"/branches/{name}: fundamental {_text(g.attrs['ratio'])} x "
                             f"Omega, the scene's doubled set has {child.harmonics.ratio}")
        br = branch_from_group(g, name0)
        if br.unknowns.shape[1] != child.n_unknowns:
            raise ValueError(f"/branches/{name}: {br.unknowns.shape[1]} unknowns per point, "
                             f"the scene's doubled problem has {child.n_unknowns}")
        a = g.attrs
        d = DoublingPoint(float(a["doubling_rpm"]), float(a["doubling_omega"]),
                          g["doubling_unknowns"][()], g["doubling_vector"][()],
                          int(a["doubling_bracket"]), float(a["doubling_floquet_rpm"]),
                          float(a["doubling_tau"]))
        out.append(SecondaryBranch(name, int(a["period"]), child, br, parent, d,
                                   float(a["rejoin_rpm"]), float(a["epsilon"])))
        problems[name] = child
    seconds = top.attrs.get("seconds")
    return out, None if seconds is None else float(seconds)


def subharmonic_mask(s) -> np.ndarray:
    """Mask of the harmonics of secondary branch ``s`` that no period-1 response has: the
    indices of its set that are not multiples of its period (a period-2 branch: the odd
    ones, the half orders ``Z/2``, ``3Z/2``, ``Z±1/2``, ...; period 4: the quarter and
    half orders)."""
    return np.asarray(s.problem.harmonics.indices, dtype=int) % int(s.period) != 0


def secondary_nvh(result) -> dict:
    """:class:`study.outputs.nvh.NVH` of every secondary branch of ``result`` (name -> NVH),
    computed as the main branch's (:func:`study.outputs.nvh.compute_nvh`) on the branch's
    own problem: the mesh load per harmonic of its doubled set and, for a machine with a
    radiating part, the housing's ERP and accelerometers from the same recovery
    ``q̃_k = s.problem.recover(point)`` and the cached radiation data of the run's ROM (the
    FE model is not rebuilt); the frequency of index ``k`` is ``k ω₀/period``."""
    from study.outputs.nvh import compute_nvh

    out = {}
    for s in getattr(result, "secondary", None) or ():
        view = SimpleNamespace(problem=s.problem, branch=s.branch, scene=result.scene,
                               rom=result.rom)
        out[s.name] = compute_nvh(view)
    return out


def write_branch_curves_csv(path: Path, secondary, nvh: dict) -> Path | None:
    """``curves_branches.csv``: the columns of ``curves.csv`` for every point of every
    secondary branch, led by ``branch``, ``parent``, ``period`` (rows grouped by branch in
    the order found, points in branch order) and followed by the content the main branch
    cannot have: ``fundamental_order`` (the branch's lowest line, shaft orders: ``Z/2``
    = 38 for 76 teeth), ``fundamental_amplitude_N`` (the mesh load's amplitude there),
    ``subharmonic_rms_N`` (RMS of the mesh load over the lines that are not multiples of
    the main fundamental, :func:`subharmonic_mask`) and ``erp_subharmonic_dB_re_1pW``
    (their ERP; empty without a radiating housing). Atomic; a stale file is removed
    when there is no secondary branch (returns None)."""
    from study.outputs.acoustics import power_db
    from study.outputs.nvh import CONTACT_NAMES

    path = Path(path)
    if not secondary:
        if path.exists():
            path.unlink()
        return None
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["branch", "parent", "period", "point", "speed_rpm", "mesh_load_std_N",
                "mesh_load_max_N", "mesh_load_peak_to_peak_N", "erp_dB_re_1pW",
                "contact_class", "contact", "stable", "fundamental_order",
                "fundamental_amplitude_N", "subharmonic_rms_N", "erp_subharmonic_dB_re_1pW"])
    for s in secondary:
        n, br, mesh = nvh[s.name], s.branch, s.branch.element(0)
        sub = subharmonic_mask(s)
        first = int(np.flatnonzero(np.asarray(n.harmonics) == 1)[0])
        rms = np.sqrt(0.5 * np.sum(n.mesh_load_amplitude[:, sub] ** 2, axis=1))
        db = n.erp_total_db
        sub_db = None if n.erp is None else power_db(n.erp[:, sub].sum(axis=1))
        for i in range(len(br)):
            cls = int(mesh.contact[i])
            w.writerow([s.name, s.parent, s.period, i, f"{br.rpm[i]:.6f}",
                        f"{mesh.mesh_load_std[i]:.8g}", f"{mesh.mesh_load_max[i]:.8g}",
                        f"{n.mesh_load_ptp[i]:.8g}", "" if db is None else f"{db[i]:.4f}",
                        cls, CONTACT_NAMES[cls], int(bool(br.stable[i])),
                        f"{float(n.orders[first]):.8g}",
                        f"{n.mesh_load_amplitude[i, first]:.8g}", f"{rms[i]:.8g}",
                        "" if sub_db is None else f"{sub_db[i]:.4f}"])
    with atomic_write(path, "w") as fh:
        fh.write(buf.getvalue())
    logger.info("wrote %s", path)
    return path


def _span(a: float, b: float) -> str:
    """``a–b`` rpm with enough decimals to tell them apart (0.1 rpm and finer)."""
    width = abs(b - a)
    d = 1 if width >= 1 else min(4, int(np.ceil(-np.log10(max(width, 1e-4)))) + 1)
    return f"{a:.{d}f}–{b:.{d}f}"


def _ranges(iv) -> str:
    return ", ".join(_span(a, b) for a, b in iv) or "none"


def report_lines(secondary, brackets: int | None = None, depth: int = 1,
                 seconds: float | None = None) -> list[str]:
    """The report.md section "Period doubling" (empty when nothing was switched at);
    ``brackets``: the main branch's intervals where the leading Floquet kind enters or
    leaves period doubling."""
    if not secondary and not brackets:
        return []
    out = ["## Period doubling: branches of period 2 and beyond", "",
           f"- switched at the period doublings of the main branch (multiplier −1, located "
           f"on the harmonic-balance equations) to the branch of twice the period, to depth "
           f"{depth} (`[continuation] period_doubling_depth`), each traced like the main "
           "branch with stability over its own period; results.h5 `/branches/<name>` "
           "(docs/theory.md §15)"]
    if brackets is not None:
        main = [x for x in secondary if x.parent == "main"]
        out.append(f"- the main branch enters or leaves period doubling {brackets} time"
                   f"{'s' if brackets != 1 else ''}; {len(main)} period-2 branch"
                   f"{'es' if len(main) != 1 else ''} switched to (a period doubling where "
                   "one of them rejoined the main branch is not switched at again; one "
                   "where no multiplier crosses −1 on the harmonic balance, or past the "
                   "stage's budget, is not switched at: see the log)")
    if seconds is not None:
        out.append(f"- {len(secondary)} branch{'es' if len(secondary) != 1 else ''} in "
                   f"{seconds:.1f} s")
    if not secondary:
        out.append("- no period-2 branch could be started (see the log)")
        return out
    out += ["", "| branch | from | doubling at (rpm) | Floquet verdict (rpm) | rejoins at (rpm) "
            "| speed range (rpm) | points | stable on (rpm) | largest std (N) | ends |",
            "|---|---|---:|---:|---:|---|---:|---|---|---|"]
    for r in branch_rows(secondary):
        rej = f"{r.rejoin_rpm:.4f}" if np.isfinite(r.rejoin_rpm) else "–"
        fl = f"{r.floquet_rpm:.4f}" if np.isfinite(r.floquet_rpm) else "–"
        out.append(f"| {r.name} | {r.parent} | {r.doubling_rpm:.4f} | {fl} | {rej} | "
                   f"{_span(r.rpm_min, r.rpm_max)} | {r.points} | "
                   f"{_ranges(r.stable_ranges)} | {r.max_std:.4g} at {r.max_std_rpm:.6g} | "
                   f"{r.status} |")
    out += ["", "- a stable period-2 branch is where the harmonic balance says the machine "
            "goes when its parent loses stability: a mesh load repeating every two "
            "fundamental periods, with lines at the half orders (forced-response plot: in "
            "colour, unstable parts dashed; order maps `*_attracting`). Near grazing "
            "check it by time integration: in the pump's near-grazing tangles the "
            "integration leaves such orbits (docs/hbm.md \"Period doubling\")"]
    return out


@dataclass
class AttractingLevels:
    """Per order, the levels of the responses the machine settles on along the speed: the
    stable points of the main branch and of every secondary branch, sorted by speed (where
    two coexist both are kept). ``orders`` holds the main set's orders and the half (or
    quarter) orders of the secondary ones; a level is NaN at an order its branch does
    not hold."""

    rpm: np.ndarray            # (n,)
    orders: np.ndarray         # (n_o,) shaft orders (floats)
    period: np.ndarray         # (n,) 1 on the main branch, 2, 4 ... on a secondary one
    mesh_load: np.ndarray      # (n, n_o) N
    erp: np.ndarray | None     # (n, n_o) W, or None without a radiating housing


def attracting_levels(result) -> AttractingLevels | None:
    """:class:`AttractingLevels` of a run with secondary branches (None without): the
    levels of their NVH (``result.secondary_nvh``, :func:`secondary_nvh`)."""
    secondary = getattr(result, "secondary", None)
    nvh = getattr(result, "nvh", None)
    if not secondary or nvh is None or len(result.problem.elements) > 1:
        return None
    br = result.branch
    parts = []           # (rpm, orders, period, amp, erp)
    rows = np.flatnonzero(br.stable.astype(bool))
    main_erp = None if nvh.erp is None else nvh.erp[rows]
    parts.append((br.rpm[rows], np.asarray(nvh.orders, dtype=float), 1,
                  nvh.mesh_load_amplitude[rows], main_erp))
    for s in secondary:
        rows = np.flatnonzero(s.branch.stable.astype(bool))
        if rows.size == 0:
            continue
        sn = result.secondary_nvh[s.name]
        parts.append((s.branch.rpm[rows], np.asarray(sn.orders, dtype=float), s.period,
                      sn.mesh_load_amplitude[rows], None if sn.erp is None else sn.erp[rows]))
    orders = np.unique(np.concatenate([p[1] for p in parts]))
    # only the orders with a level somewhere (a main order above every stable point's
    # set, e.g., would be an empty row)
    n = sum(p[0].size for p in parts)
    amp = np.full((n, orders.size), np.nan)
    erp = None if nvh.erp is None else np.full((n, orders.size), np.nan)
    rpm, period = np.zeros(n), np.zeros(n, dtype=int)
    k = 0
    for r, o, per, a, e in parts:
        cols = np.searchsorted(orders, o)
        sl = slice(k, k + r.size)
        rpm[sl], period[sl] = r, per
        amp[sl, cols] = a
        if erp is not None and e is not None:
            erp[sl, cols] = e
        k += r.size
    order = np.argsort(rpm, kind="stable")
    keep = ~np.all(np.isnan(amp), axis=0)
    return AttractingLevels(rpm[order], orders[keep], period[order], amp[order][:, keep],
                            None if erp is None else erp[order][:, keep])


def erp_lines(result, segments) -> list[str]:
    """report.md "Noise" lines: per period-doubling segment of the main branch
    (``segments``, :class:`study.outputs.curves.UnstableSegment` in branch order), what its
    unstable orbit radiates (largest total ERP over the segment's points) against every
    secondary branch over the segment: the largest ERP of its stable points there, the
    part at the orders a period-1 response cannot have (:func:`subharmonic_mask`) and its
    loudest such order. Empty without a radiating housing or secondary branches."""
    from study.outputs.acoustics import power_db

    nvh, sec = getattr(result, "nvh", None), getattr(result, "secondary", None) or ()
    snvh = getattr(result, "secondary_nvh", None) or {}
    if nvh is None or nvh.erp_total is None or not sec:
        return []
    z = result.scene.gear.teeth
    out = []
    for u in segments:
        if u.kind != "period_doubling" or u.index is None:
            continue
        lo, hi = u.rpm
        i0, i1 = u.index
        main = float(np.max(nvh.erp_total_db[i0:i1 + 1]))
        parts = []
        for s in sec:
            n = snvh.get(s.name)
            if n is None or n.erp_total is None:
                continue
            rpm = s.branch.rpm
            over = (rpm >= lo) & (rpm <= hi)
            if not over.any():
                continue
            ok = np.flatnonzero(over & s.branch.stable.astype(bool))
            if ok.size == 0:
                parts.append(f"`{s.name}` (period {s.period}) has no stable point there")
                continue
            j = ok[int(np.argmax(n.erp_total[ok]))]
            sub = subharmonic_mask(s)
            top = np.flatnonzero(sub)[int(np.argmax(n.erp[j, sub]))]
            db = float(n.erp_total_db[j])
            parts.append(
                f"`{s.name}` (period {s.period}, stable at {ok.size} of its points there) up "
                f"to {db:.1f} dB ({db - main:+.1f} dB against it) at {rpm[j]:.1f} rpm, "
                f"{float(power_db(n.erp[j, sub].sum())):.1f} dB of it at the orders of "
                f"period {s.period} (loudest {n.order_name(top, z)}, "
                f"{float(n.erp_db[j, top]):.1f} dB)")
        if parts:
            out.append(f"- period doubling {lo:.1f}–{hi:.1f} rpm: the main branch's orbit, "
                       f"unstable there, radiates up to {main:.1f} dB re 1 pW; the response "
                       "that takes over: " + "; ".join(parts) + " (per order: "
                       "`/branches/<name>/nvh`, curves: `curves_branches.csv`)")
    return out
