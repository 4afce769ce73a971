"""Impacts per mesh period of the *nonlinear* solution at fixed speeds as a function of
the transmission-error harmonics: the second stage of the TE calibration of
:mod:`benchmarks.calibrate_pump` after the linear screen of :mod:`benchmarks.te_margin`.

The linear margin locates grazings exactly (there the branch is the linear solution), but
far from them the impacts change the response, and the IPP of the linear solution is not
the branch's. Here every candidate TE is solved by Newton at each target speed
(:meth:`hbm.HBMProblem.solve`), started from the solution of the nearest candidate seen so
far (a homotopy in the TE, from a branch point of the scene's own run). The share of the
turn with at least 1, 2, 3 impacts per mesh period is measured smoothly on the lowest
minima of ``p - b = Delta - e - b`` in each mesh period (:func:`benchmarks.te_margin.soft_ipp`)
so that Nelder–Mead sees a slope, and exactly by :func:`hbm.point_stats` for the report.
The grazings stay on the linear margin (within a tolerance), the permanent-contact
windows keep a depth, and optionally the internal-only case keeps impacting over a range
(the span-change criterion of docs/theory.md §13.5).
"""
from __future__ import annotations

import dataclasses
import logging

import numpy as np
from numpy.typing import ArrayLike

from benchmarks import te_margin as tm
from hbm import ConvergenceError, HBMProblem, Point, impacts_per_mesh_period, point_stats

log = logging.getLogger("te_ipp")


def with_te(problem: HBMProblem, amps_um: ArrayLike, phases_deg: ArrayLike) -> HBMProblem:
    """The problem with other TE harmonics.

    Parameters
    ----------
    problem
        Any problem; its TE mean, kind (loaded/unloaded) and everything else are kept.
    amps_um, phases_deg
        Amplitudes (µm, >= 0) and phases (deg) of TE harmonics 1, 2, ..., in the scene's
        convention ``a_k exp(i phi_k)`` (``study.scene.data``).

    Returns
    -------
    HBMProblem
        A new problem with the same solver settings.
    """
    amps, phs = np.asarray(amps_um, dtype=float), np.asarray(phases_deg, dtype=float)
    if amps.shape != phs.shape or amps.ndim != 1:
        raise ValueError(f"amps_um {amps.shape} and phases_deg {phs.shape}: one value per "
                         "TE harmonic each")
    if not (np.all(np.isfinite(amps)) and np.all(amps >= 0) and np.all(np.isfinite(phs))):
        raise ValueError(f"amps_um = {amps.tolist()}, phases_deg = {phs.tolist()}: "
                         "amplitudes must be finite and >= 0, phases finite")
    te = {k: c for k, c in problem.elements[0].te.items() if k == 0 or k > amps.size}
    for k, (a, p) in enumerate(zip(amps, phs, strict=True), start=1):
        te[k] = complex(1e-6 * a * np.exp(1j * np.radians(p)))
    mesh = dataclasses.replace(problem.elements[0], te=te)
    return HBMProblem(problem.system, [mesh], problem.excitation, problem.harmonics,
                      condensation=problem.condensation,
                      linear_solver="krylov" if problem.matrix_free else "dense",
                      aft=problem.aft)


def gap_signal(problem: HBMProblem, unknowns: np.ndarray, n_time: int | None = None
               ) -> np.ndarray:
    """The active-flank gap ``p - b = Delta - e - b`` of a solution over its period
    (eq. 12-13: the mesh force is ``k (p - b)`` while it is positive).

    Parameters
    ----------
    problem, unknowns
        The problem and one solution of it.
    n_time
        Samples per period, rounded up to a whole number per mesh period (default four
        times the AFT grid, as :func:`hbm.point_stats` samples it).

    Returns
    -------
    numpy.ndarray
        ``p - b`` (m); negative where the active flank is open.
    """
    n = problem.fine_periods(n_time)
    synth, samples = problem.fine_grid(n)
    return (synth @ problem.delta_real(unknowns))[0] - samples[0].e - problem.elements[0].backlash


class NonlinearIPP:
    """Nonlinear solutions of TE candidates at fixed speeds.

    Parameters
    ----------
    problem
        The scene's problem (any TE; only its TE harmonics are replaced).
    starts
        {rpm: unknowns} solutions of ``problem`` (e.g. branch points) at the speeds.
    tol
        Newton's relative residual tolerance.
    keep
        How many solved candidates to keep as starting points.
    n_te
        How many TE harmonics (1, ..., n_te) the candidates set.
    """

    def __init__(self, problem: HBMProblem, starts: dict[float, np.ndarray],
                 tol: float = 1e-8, keep: int = 400, n_te: int = 3) -> None:
        if not starts:
            raise ValueError("starts: give a solution at one speed at least")
        if n_te < 1 or keep < 2:
            raise ValueError(f"n_te = {n_te}, keep = {keep}: must be >= 1 and >= 2")
        if not 0.0 < tol < 1.0:
            raise ValueError(f"tol = {tol}: must be in (0, 1)")
        n = problem.n_unknowns
        for rpm, u in starts.items():
            if np.ndim(u) != 1 or np.size(u) != n:
                raise ValueError(f"starts[{rpm}]: one vector of the problem's unknowns "
                                 f"({n}), got shape {np.shape(u)}")
        self.problem, self.tol, self.keep, self.n_te = problem, float(tol), int(keep), n_te
        self.speeds = tuple(float(r) for r in starts)
        te = problem.elements[0].te
        ks = range(1, n_te + 1)
        x0 = [np.log(max(abs(te.get(k, 0.0)) * 1e6, 1e-6)) for k in ks]
        p0 = [np.degrees(np.angle(te.get(k, 0.0))) for k in ks]
        self._store = [(np.r_[x0, p0], {float(r): np.asarray(u, dtype=float)
                                        for r, u in starts.items()})]
        self._added = 0             # solved candidates so far (ring index of the store)

    def _nearest(self, x: np.ndarray) -> dict[float, np.ndarray]:
        # amplitudes on a log scale, phases per 30 degrees (wrapped)
        n = self.n_te
        d = [np.abs(x[:n] - xs[:n]).sum()
             + np.abs((x[n:] - xs[n:] + 180.0) % 360.0 - 180.0).sum() / 30.0
             for xs, _ in self._store]
        return self._store[int(np.argmin(d))][1]

    def solve(self, amps_um: ArrayLike, phases_deg: ArrayLike
              ) -> tuple[HBMProblem, dict[float, Point]] | None:
        """The problem of the candidate and its solution at each speed, or None when
        Newton fails at one of them."""
        if np.size(amps_um) != self.n_te:
            raise ValueError(f"amps_um has {np.size(amps_um)} values: give n_te = "
                             f"{self.n_te} (TE harmonics 1..{self.n_te})")
        prob = with_te(self.problem, amps_um, phases_deg)    # checks the values
        x = np.r_[np.log(np.maximum(np.asarray(amps_um, dtype=float), 1e-6)),
                  np.asarray(phases_deg, dtype=float)]
        start = self._nearest(x)
        out: dict[float, Point] = {}
        for rpm in self.speeds:
            try:
                out[rpm] = prob.solve(rpm, x0=start[rpm], tol=self.tol)
            except ConvergenceError:
                return None
        sol = {r: p.unknowns for r, p in out.items()}
        if len(self._store) < self.keep:
            self._store.append((x, sol))
        else:                   # the oldest solved candidate goes; the scene's entry stays
            self._store[1 + self._added % (self.keep - 1)] = (x, sol)
        self._added += 1
        return prob, out


@dataclasses.dataclass
class IPPTargets:
    """What :func:`refine_nonlinear_ipp` fits besides the grazings.

    Attributes
    ----------
    shares
        {rpm: shares of the turn at 0, 1, 2, 3+ impacts per mesh period}.
    weights
        {rpm: weight} of each speed's distance (default 1).
    minimum
        {rpm: lower bounds of the shares at 0, 1, 2, 3+ impacts per mesh period}
        (penalised, not fitted: e.g. "keep some contact at 1070 rpm").
    tol
        Relative tolerance of the grazings on the linear margin.
    min_depth
        Depth (m) the permanent-contact windows keep on the linear margin.
    internal
        Linear margin model of the internal-only case whose speeds must all impact
        (margin below ``-internal_margin``), or None.
    internal_margin
        That margin (m).
    scale
        Smoothing (m) of the impact count (:func:`benchmarks.te_margin.soft_ipp`).
    """

    shares: dict[float, list[float]]
    weights: dict[float, float] = dataclasses.field(default_factory=dict)
    minimum: dict[float, list[float]] = dataclasses.field(default_factory=dict)
    tol: float = 0.03
    min_depth: float = 6e-9
    internal: tm.MarginModel | None = None
    internal_margin: float = 6e-9
    scale: float = 2e-9

    def __post_init__(self) -> None:
        for rpm, s in self.shares.items():
            s = np.asarray(s, dtype=float)
            if s.shape != (4,) or np.any(s < 0) or abs(s.sum() - 1.0) > 1e-6:
                raise ValueError(f"shares[{rpm}] = {s.tolist()}: four shares (0, 1, 2, 3+ "
                                 "impacts per mesh period) >= 0 summing to 1")
        for rpm, s in self.minimum.items():
            s = np.asarray(s, dtype=float)
            if s.shape != (4,) or np.any(s < 0) or s.sum() > 1.0:
                raise ValueError(f"minimum[{rpm}] = {s.tolist()}: four lower bounds (0, 1, "
                                 "2, 3+ impacts per mesh period) >= 0 summing to <= 1")
        for rpm, w in self.weights.items():
            if rpm not in self.shares or not w >= 0.0:
                raise ValueError(f"weights[{rpm}] = {w}: a weight >= 0 of a speed of shares "
                                 f"({sorted(self.shares)})")
        if not 0.0 < self.tol < 1.0:
            raise ValueError(f"tol = {self.tol}: must be in (0, 1)")
        if not (self.min_depth >= 0.0 and self.internal_margin >= 0.0):
            raise ValueError(f"min_depth = {self.min_depth}, internal_margin = "
                             f"{self.internal_margin}: must be >= 0 (m)")
        if not self.scale > 0.0:
            raise ValueError(f"scale = {self.scale}: must be > 0 (m)")


def linear_penalty(model: tm.MarginModel, target: tuple[float, ...], targets: IPPTargets,
                   amps_um: ArrayLike, phases_deg: ArrayLike) -> tuple[float, dict]:
    """Penalty of the linear criteria of a TE, 0 when all hold.

    Grazings beyond ``targets.tol`` cost 100 per unit of relative error; windows
    shallower than ``targets.min_depth`` and internal-only speeds without impacts cost 1
    per nm short; a margin without the target's grazing pattern costs more than 100.

    Returns
    -------
    tuple
        (penalty, the measured grazings, depth and internal margin).
    """
    m = model.margins(amps_um, phases_deg)[0]
    s, c = tm.pattern_score(model.rpm, m, target)
    if s >= 1.0:
        return 100.0 + s, {"score": s}
    err = float(np.max(np.abs(np.asarray(c) - np.asarray(target)) / np.asarray(target)))
    dep = tm.depth(model.rpm, m, c)
    pen = 100.0 * max(err - targets.tol, 0.0) + 1e9 * max(targets.min_depth - dep, 0.0)
    info = {"score": s, "grazing_rpm": c, "grazing_error": err, "depth_m": dep}
    if targets.internal is not None:
        mi = float(targets.internal.margins(amps_um, phases_deg)[0].max())
        pen += 1e9 * max(mi + targets.internal_margin, 0.0)
        info["internal_max_margin_m"] = mi
    return pen, info


def refine_nonlinear_ipp(model: tm.MarginModel, nl: NonlinearIPP, target: tuple[float, ...],
                         targets: IPPTargets, amps_um: ArrayLike, phases_deg: ArrayLike,
                         max_evals: int = 350,
                         restarts: int = 2) -> dict:
    """Fit the TE to the nonlinear IPP shares under the linear criteria.

    Nelder–Mead on (log amplitudes, phases): the penalty of :func:`linear_penalty`
    and, where it holds, ``Σ_speeds w ½ Σ_k |s_k - r_k|`` with ``s`` the smooth
    nonlinear shares at >= k impacts (:func:`benchmarks.te_margin.soft_ipp` on
    :func:`gap_signal`) and ``r`` the reference's,
    plus 100 per unit of share (exact and smooth) below ``targets.minimum``; a failed
    Newton scores 500.

    Parameters
    ----------
    model
        Linear margin of the all-excitations case (grazings, windows).
    nl
        Nonlinear solver at the speeds of ``targets.shares`` and ``targets.minimum``.
    target
        The grazing speeds (rpm).
    targets
        Shares, bounds, weights and tolerances.
    amps_um, phases_deg
        The start (µm > 0, deg), ``nl.n_te`` values each.
    max_evals, restarts
        ``restarts`` runs of ``max_evals`` evaluations, each from a fresh simplex at
        the last point.

    Returns
    -------
    dict
        The candidate, its linear grazings and depth, and its exact nonlinear IPP per
        speed (``nonlinear``).
    """
    speeds = set(map(float, targets.shares)) | set(map(float, targets.minimum))
    missing = speeds - set(nl.speeds)
    if missing:
        raise ValueError(f"shares or minimum at {sorted(missing)} rpm: nl has solutions "
                         f"at {list(nl.speeds)} rpm only")
    ref = {float(r): tm.cumulative(np.asarray(s, dtype=float)) for r, s in targets.shares.items()}
    low = {float(r): np.asarray(s, dtype=float) for r, s in targets.minimum.items()}
    n = nl.n_te
    if np.size(amps_um) != n or np.size(phases_deg) != n or np.min(amps_um) <= 0.0:
        raise ValueError(f"amps_um = {list(amps_um)}, phases_deg = {list(phases_deg)}: "
                         f"{n} values each (nl.n_te), amplitudes > 0 (a log-scale search)")

    def f(x):
        a, p = np.exp(x[:n]), x[n:]
        pen, _ = linear_penalty(model, target, targets, a, p)
        if pen > 50.0:
            return 100.0 + pen
        sol = nl.solve(a, p)
        if sol is None:
            return 500.0
        prob, pts = sol
        gaps = {r: gap_signal(prob, pts[r].unknowns) for r in speeds}   # once per speed
        d = sum(targets.weights.get(r, 1.0) * 0.5 * float(np.abs(
            tm.soft_ipp(gaps[r], prob.steps[0], targets.scale) - c).sum())
            for r, c in ref.items())
        for r, lo in low.items():        # 100 per unit of share below its bound, exact
            gap = gaps[r]                                # and smooth (for a slope)
            exact = tm.ipp_fraction_vector(impacts_per_mesh_period(gap < 0.0, prob.steps[0]))
            soft = tm.fractions_from_cumulative(tm.soft_ipp(gap, prob.steps[0], targets.scale))
            d += 100.0 * float(np.maximum(lo - exact, 0.0).sum()
                               + np.maximum(lo - soft, 0.0).sum())
        return pen + d

    r = tm.nelder_mead(f, np.r_[np.log(amps_um), phases_deg], [0.06] * n + [6.0] * n,
                       max_evals, xatol=1e-4, fatol=1e-3, restarts=restarts)
    amps, phs = np.exp(r.x[:n]), np.mod(r.x[n:], 360.0)
    pen, info = linear_penalty(model, target, targets, amps, phs)
    out = {"amplitudes_um": amps.tolist(), "phases_deg": phs.tolist(), **info,
           "linear_penalty": pen, "objective": float(r.fun),
           "start": {"amplitudes_um": list(map(float, amps_um)),
                     "phases_deg": list(map(float, phases_deg))},
           "targets": {"shares": {str(k): list(v) for k, v in targets.shares.items()},
                       "minimum": {str(k): list(v) for k, v in targets.minimum.items()},
                       "tol": targets.tol, "min_depth_m": targets.min_depth,
                       "scale_m": targets.scale,
                       "internal": targets.internal is not None}}
    sol = nl.solve(amps, phs)
    if sol is not None:
        prob, pts = sol
        out["nonlinear"] = {}
        for rpm, pt in pts.items():
            ipp = point_stats(prob, pt)[0].ipp
            out["nonlinear"][str(rpm)] = {
                "fractions": tm.ipp_fraction_vector(ipp).tolist(),
                "ipp": ipp.tolist()}
    return out


def sensitivity(nl: NonlinearIPP, amps_um: ArrayLike, phases_deg: ArrayLike, rel: float = 0.02,
                deg: float = 2.0) -> list[dict]:
    """Exact IPP shares at ``nl``'s speeds of the TE and of each change of one amplitude
    by ``±rel`` (relative) or one phase by ``±deg``, each solved by Newton from the
    stored candidates (:meth:`NonlinearIPP.solve`).

    Returns
    -------
    list of dict
        ``{"change": label, "amplitudes_um", "phases_deg", "fractions": {rpm: shares at
        0, 1, 2, 3+ impacts per mesh period} or None when Newton fails}``, the TE first.
    """
    if not (0.0 < rel < 1.0 and 0.0 < deg < 180.0):
        raise ValueError(f"rel = {rel}, deg = {deg}: must be in (0, 1) and (0, 180)")
    a0, p0 = np.asarray(amps_um, dtype=float), np.asarray(phases_deg, dtype=float)
    cases = [("TE", a0, p0)]
    for k in range(a0.size):
        for f in (1.0 - rel, 1.0 + rel):
            a = a0.copy()
            a[k] *= f
            cases.append((f"a{k + 1} x{f:g}", a, p0))
    for k in range(p0.size):
        for d in (-deg, deg):
            ph = p0.copy()
            ph[k] += d
            cases.append((f"phi{k + 1} {d:+g} deg", a0, ph))
    out = []
    for label, a, ph in cases:
        sol = nl.solve(a, ph)
        fr = None if sol is None else {
            str(r): tm.ipp_fraction_vector(point_stats(sol[0], pt)[0].ipp).tolist()
            for r, pt in sol[1].items()}
        out.append({"change": label, "amplitudes_um": a.tolist(),
                    "phases_deg": ph.tolist(), "fractions": fr})
    return out
