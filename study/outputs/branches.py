"""The secondary branches of a run, born at period doublings (:mod:`hbm.branching`): their
``/branches`` group of results.h5, their summary rows and their section of report.md.

Each branch is written as ``/branches/<name>`` (``period2_1``, ``period4_1``, ...) with
the datasets of the main branch (``continuation``, ``grazing``, ``folds``, by
:func:`study.outputs.results.write_branch`: its unknowns are those of the doubled
problem, its statistics over the doubled period) and attributes naming its parent, its
period, the fundamental of its harmonic set, where it was switched from and where it met
its parent again (docs/results-format.md, "/branches").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hbm.stability import KINDS

__all__ = ["AttractingLevels", "BranchRow", "attracting_levels", "branch_rows", "report_lines",
           "write_branches_group"]


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


def write_branches_group(f, secondary) -> None:
    """``/branches/<name>`` of every secondary branch (see the module docstring)."""
    from study.outputs.results import write_branch

    if not secondary:
        return
    top = f.create_group("branches")
    top.attrs["names"] = [s.name for s in secondary]
    for s in secondary:
        g = top.create_group(s.name)
        write_branch(g, s.branch)
        hs = s.problem.harmonics
        g.attrs["parent"] = s.parent
        g.attrs["period"] = s.period
        g.attrs["ratio"] = str(hs.ratio)
        g.attrs["fundamental"] = hs.fundamental
        g.attrs["doubling_rpm"] = s.doubling.rpm
        g.attrs["doubling_floquet_rpm"] = s.doubling.floquet_rpm
        g.attrs["doubling_bracket"] = s.doubling.index
        g.attrs["rejoin_rpm"] = s.rejoin_rpm
        g.attrs["epsilon"] = s.epsilon
        g["doubling_vector"] = s.doubling.vector
        g["doubling_unknowns"] = s.doubling.unknowns


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


def _amplitudes(problem, branch, rows) -> np.ndarray:
    """|f̃_k| of the mesh load (element 0) at the harmonics of ``problem`` for the points
    ``rows`` of ``branch``, over one period of the problem (N)."""
    from hbm import time_series

    idx = np.asarray(problem.harmonics.indices, dtype=int)
    out = np.zeros((len(rows), idx.size))
    for r, i in enumerate(rows):
        f = time_series(problem, problem.point(branch.unknowns[i], branch.omega[i])).load
        c = np.fft.rfft(f) / f.size
        c[1:] *= 2.0
        out[r] = np.abs(c[idx])
    return out


def _erp(result, problem, branch, rows) -> np.ndarray | None:
    """ERP per harmonic (W) of the housing at the points ``rows`` (None without one)."""
    from study.outputs.acoustics import erp_harmonics

    rad = getattr(result.rom, "radiation", None) if result.rom is not None else None
    if rad is None:
        return None
    ac = result.scene.acoustics
    idx = np.asarray(problem.harmonics.indices, dtype=int)
    out = np.zeros((len(rows), idx.size))
    for r, i in enumerate(rows):
        qk = problem.recover(problem.point(branch.unknowns[i], branch.omega[i]))
        w0 = problem.harmonics.fundamental_rad_s(branch.omega[i])
        out[r] = erp_harmonics(rad["W"], qk, idx * w0, ac.air_density, ac.sound_speed)
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
    """:class:`AttractingLevels` of a run with secondary branches (None without)."""
    from study.outputs.nvh import orders_of

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
        parts.append((s.branch.rpm[rows], orders_of(s.problem.harmonics), s.period,
                      _amplitudes(s.problem, s.branch, rows),
                      _erp(result, s.problem, s.branch, rows)))
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
