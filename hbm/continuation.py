"""Pseudo-arc-length continuation in Omega with grazing, fold and stability tracking.

Unknowns and equations are scaled (``x_hat = u / x_scale``, ``R_hat = R /
eq_scale``, see problem.py) and the speed by the speed range,
``w_hat = Omega / |Omega_end - Omega_start|``, so the arc length ``s`` is
dimensionless: a step of 0.01 moves the speed by at most 1 % of the range.
Predictor: unit tangent of the branch (null vector of ``[J_x, J_w]``); on a
failed step the step is halved and the retries cycle through a corner step
(spherical corrector past a kink of the piecewise-linear branch), the secant
through the last two points and a patient corrector (docs/hbm.md). Corrector:
Newton on the augmented system ``R_hat = 0, t . (y - y_pred) = 0``
(pseudo-arc-length).
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from .krylov import bordered
from .newton import COND_WARN, ConvergenceError, backtrack, newton, solve_checked
from .postprocess import point_stats
from .problem import RPM_TO_RAD_S, HBMProblem
from .stability import stability as point_stability

logger = logging.getLogger(__name__)

__all__ = ["Branch", "GrazingPoint", "trace"]


@dataclass
class GrazingPoint:
    """Grazing bifurcation (eq. 30) located on the branch.

    ``kind`` is ``"onset"`` (impacts start, along the direction of travel) or
    ``"end"``; ``side`` is ``"active"`` (contact loss on the driving flank,
    sign change of phi_GR) or ``"reverse"`` (the back flank starts/stops being hit).
    """

    rpm: float
    kind: str
    side: str


REFINE_BOUND = 1e-7     # refine a converged point when cond * residual exceeds this
CORNER_STEP = 1e-4      # steps below this may turn sharply (corners of the branch)
CORNER_RADIUS = 1e-3    # largest sphere of a corner step (no room for another branch)
FOLD_MERGE_POINTS = 3   # sign changes of dOmega/ds closer than this (points) cancel
# A new point closer than REVISIT_RATIO times its chord to an earlier segment of the
# branch (all but the last) is the branch walking back over itself, not a fold: on the
# pump the retraced points lie 1e-3..5e-2 chords from the old polyline, distinct pieces
# that meet at a fold or corner 0.7..2 chords (docs/hbm.md, "Reversals").
REVISIT_RATIO = 0.1
# A point flagged by REVISIT_RATIO is a revisit only if the old branch at its speed is the
# same solution: Newton at that speed from the old polyline lands within this distance
# (scaled unknowns, relative to max(|y|, 1)) of it. Past a sharp fold whose two pieces
# differ little in state (the pump at 12 mesh harmonics, 1220-1236 rpm: 1e-4..1e-3 apart
# while the chords are ~1e-2, mostly speed) the piece coming back is a distinct solution.
SAME_SOLUTION = 1e-5
MAX_REVERSALS = 8       # roll-backs without progress before the trace gives up
# progress: the branch has grown by more than this many points past its length at the
# furthest reversal so far (a pump curve at converged settings turns at dozens of folds)
REVERSAL_PROGRESS = 5
LEAP_FACTORS = (2.0, 4.0, 8.0, 16.0, 32.0, 64.0)   # corner leap: lengths in last chords

_ARRAYS = ("rpm", "omega", "coefficients", "unknowns", "residual", "newton_iterations",
           "stable", "floquet_max_real", "mesh_load_std", "mesh_load_max", "contact",
           "contact_loss_fraction", "impacts_per_mesh_period", "margin_active",
           "margin_reverse", "ipp", "tangents", "floquet_kind", "stability_consistent")


@dataclass
class Branch:
    """A continuation branch: one entry per accepted point (all arrays).

    Attributes
    ----------
    rpm, omega
        Shaft speed (rpm) and Omega (rad/s).
    coefficients
        Complex (n_points, n_harmonics) Fourier coefficients of Delta (m).
    unknowns
        Real unknown vectors of the problem's condensation (physical units).
    residual
        Relative residual norm of each point (all < tol).
    newton_iterations, stable, floquet_max_real
        Corrector iterations; stability and largest Floquet real part (1/s)
        (:func:`hbm.stability.stability`).
    floquet_kind
        Index in :data:`hbm.stability.KINDS` (0 stable, 1 fold, 2 period doubling,
        3 Neimark-Sacker) of the leading exponent.
    stability_consistent
        False where the branch lies between two folds (T.9) but the variational
        equation (T.10) finds the orbit stable: the harmonic set does not resolve
        the orbit there (the point is reported unstable).
    mesh_load_std, mesh_load_max
        Standard deviation and maximum in time of f_LoA (N).
    contact
        0 permanent contact, 1 single-sided, 2 double-sided impacts.
    contact_loss_fraction, impacts_per_mesh_period
        Per point; ``ipp[i]`` the impacts in each mesh period of the
        fundamental period (the IPP sequence, see :meth:`ipp_sequence`).
    margin_active, margin_reverse
        Contact margins (m), see :class:`hbm.postprocess.PointStats`.
    tangents
        Scaled unit tangents (n_points, n_unknowns + 1), for resuming.
    grazing, folds
        Located grazing points and fold speeds (rpm).
    fold_index
        For each fold, the index of the point where the speed turns back.
    step_cuts, secant_retries, corner_steps
        Failed continuation steps (each halved the step); among the retries,
        those made with the secant predictor, and the points accepted by the
        spherical corrector past a corner of the branch.
    reversals, leaps
        Reversals detected (the branch walking back over points already traced;
        the points after the turn are dropped and the trace re-predicted from it
        with the old orientation) and corner leaps (a predictor several chords
        ahead along the direction of travel past a non-smooth point).
    max_condition
        Largest 1-norm condition estimate of a corrector matrix (scaled); a
        warning is logged once when it exceeds ``hbm.newton.COND_WARN``.
    status, message
        ``"completed"`` (reached rpm_end), ``"left_range"`` (turned back out
        through rpm_start), ``"max_points"``, ``"step_failed"``,
        ``"reversal"`` (kept walking back over its own branch after
        ``MAX_REVERSALS`` recoveries), ``"start_failed"``; the message says why
        in words. Every status but ``"completed"`` means the curve is incomplete.
    """

    harmonics: tuple
    condensation: str
    rpm_start: float
    rpm_end: float
    omega_scale: float
    rpm: np.ndarray
    omega: np.ndarray
    coefficients: np.ndarray
    unknowns: np.ndarray
    residual: np.ndarray
    newton_iterations: np.ndarray
    stable: np.ndarray
    floquet_max_real: np.ndarray
    mesh_load_std: np.ndarray
    mesh_load_max: np.ndarray
    contact: np.ndarray
    contact_loss_fraction: np.ndarray
    impacts_per_mesh_period: np.ndarray
    margin_active: np.ndarray
    margin_reverse: np.ndarray
    ipp: np.ndarray
    tangents: np.ndarray
    floquet_kind: np.ndarray
    stability_consistent: np.ndarray
    grazing: list = field(default_factory=list)
    folds: list = field(default_factory=list)
    fold_index: list = field(default_factory=list)
    status: str = "running"
    message: str = ""
    next_step: float = 0.0
    step_cuts: int = 0
    secant_retries: int = 0
    corner_steps: int = 0
    reversals: int = 0
    leaps: int = 0
    max_condition: float = float("nan")

    def __len__(self) -> int:
        return int(self.rpm.size)

    def ipp_sequence(self, i: int) -> np.ndarray:
        """Impacts per mesh period along the shaft rotation at point i."""
        return self.ipp[i]


class _Recorder:
    def __init__(self, problem: HBMProblem, rpm_start, rpm_end, omega_scale, resume=None):
        self.meta = dict(harmonics=tuple(problem.harmonics.indices),
                         condensation=problem.condensation, rpm_start=float(rpm_start),
                         rpm_end=float(rpm_end), omega_scale=float(omega_scale))
        self.lists: dict[str, list] = {k: [] for k in _ARRAYS}
        self.grazing: list[GrazingPoint] = []
        self.folds: list[float] = []
        self.fold_index: list[int] = []
        self.counters = {"step_cuts": 0, "secant_retries": 0, "corner_steps": 0,
                         "reversals": 0, "leaps": 0, "max_condition": 0.0}
        self.warned = False
        self.n_grazing: list[int] = []   # len(grazing) after each point (for roll-back)
        self.guard: tuple[int, np.ndarray] | None = None   # (point, travel) after a reversal
        self.last_turn: int | None = None   # point the last reversal went back to
        self.releap: int | None = None      # leap from this point (second reversal to it)
        self.stuck = 0          # reversals since the branch grew past stuck_at points,
        self.stuck_at = 0       # its largest length when a reversal was detected
        if resume is not None:
            self.counters = {"step_cuts": int(resume.step_cuts),
                             "secant_retries": int(resume.secant_retries),
                             "corner_steps": int(resume.corner_steps),
                             "reversals": int(getattr(resume, "reversals", 0)),
                             "leaps": int(getattr(resume, "leaps", 0)),
                             "max_condition": float(np.nan_to_num(resume.max_condition))}
            for k in _ARRAYS:
                self.lists[k] = list(getattr(resume, k))
            self.grazing = list(resume.grazing)
            self.folds = list(resume.folds)
            self.fold_index = list(resume.fold_index)
            if len(self.fold_index) != len(self.folds):     # branch rebuilt without it
                self.fold_index = [-(10 ** 9)] * len(self.folds)
            self.n_grazing = [len(self.grazing)] * len(self.lists["rpm"])

    def __len__(self) -> int:
        return len(self.lists["rpm"])

    def last(self, key):
        return self.lists[key][-1]

    def add(self, **values) -> None:
        for k in _ARRAYS:
            self.lists[k].append(values[k])
        self.n_grazing.append(len(self.grazing))

    def truncate(self, n: int) -> None:
        """Keep the first ``n`` points (and the folds and grazing points found by then)."""
        for k in _ARRAYS:
            del self.lists[k][n:]
        keep = [i for i, f in enumerate(self.fold_index) if f + 1 < n]
        self.folds = [self.folds[i] for i in keep]
        self.fold_index = [self.fold_index[i] for i in keep]
        del self.grazing[self.n_grazing[n - 1]:]
        del self.n_grazing[n:]

    def branch(self, status: str, message: str, next_step: float) -> Branch:
        arrays = {}
        for k in _ARRAYS:
            v = self.lists[k]
            arrays[k] = np.array(v) if v else np.zeros((0,))
        return Branch(**self.meta, **arrays, grazing=list(self.grazing), folds=list(self.folds),
                      fold_index=list(self.fold_index),
                      step_cuts=self.counters["step_cuts"],
                      secant_retries=self.counters["secant_retries"],
                      corner_steps=self.counters["corner_steps"],
                      reversals=self.counters["reversals"], leaps=self.counters["leaps"],
                      max_condition=self.counters["max_condition"] or float("nan"),
                      status=status, message=message, next_step=float(next_step))


class _StepRejected(Exception):
    pass


def _augmented(problem: HBMProblem, omega_scale: float):
    def evaluate(y, jacobian=True):
        omega = y[-1] * omega_scale
        if not omega > 0:
            raise ConvergenceError(f"corrector reached Omega = {omega:.3g} <= 0")
        if not jacobian:
            return problem.scaled(y[:-1], omega, False)
        r, jx, jw = problem.scaled(y[:-1], omega)
        return r, jx, jw * omega_scale
    return evaluate


def _correct(evaluate, y_pred, direction, tol, max_iter, conds=None, sphere=None):
    """Newton on R_hat(y) = 0, direction . (y - y_pred) = 0.

    ``conds``, if given, collects the condition estimates of the Newton matrices.
    ``sphere = (centre, radius)`` replaces the plane by ``|y - centre| = radius``
    (spherical arc length: it meets any branch leaving the centre, even one that
    turns by more than 90 degrees at a corner).
    """
    y = y_pred.copy()
    res0 = None
    cond = np.nan
    for it in range(max_iter + 1):
        r, jx, jw = evaluate(y)
        res = float(np.linalg.norm(r) / max(np.linalg.norm(y[:-1]), 1.0))
        if not np.isfinite(res):
            raise ConvergenceError("non-finite residual", res)
        res0 = res if res0 is None else res0
        if res < tol and (it == 0 or cond * res > REFINE_BOUND):
            # within tol already at the predictor (tiny step), or an error bound
            # cond * res that a poorly conditioned Jacobian makes loose: one Newton step
            # more, so that the point does not carry a tol-sized error along the branch
            refined = _refine(evaluate, y, y_pred, direction, sphere, r, jx, jw, res, it)
            return refined if refined is not None else (y, it, res, jx, jw)
        if res < tol:
            return y, it, res, jx, jw
        if it == max_iter or (it > 2 and res > 1e3 * res0):
            break
        row, con = _constraint(y, y_pred, direction, sphere)
        j = bordered(jx, jw, row)
        rhs = -np.concatenate([r, [con]])
        try:
            dy, cond = solve_checked(j, rhs, "continuation corrector", warn=False)
        except ConvergenceError as exc:
            raise ConvergenceError(f"{exc} (relative residual {res:.3g})", res,
                                   exc.condition) from exc
        if conds is not None:
            conds.append(cond)
        if it >= 2:
            # Newton may cycle on the piecewise-linear force: backtrack on ||R||
            # (the constraint is linear, so every partial step keeps it)
            dy = backtrack(lambda yt: _relative_residual(evaluate, yt), y, dy, res, 6) * dy
        y = y + dy
    raise ConvergenceError(f"corrector: relative residual {res:.3g} > tol {tol:.1g} after {it} "
                           f"iterations (condition estimate {cond:.2g})", res, cond)


def _relative_residual(evaluate, y) -> float:
    """``||R_hat(y)|| / max(||x_hat||, 1)``, inf where the residual cannot be evaluated."""
    try:
        r = evaluate(y, False)
    except ConvergenceError:
        return np.inf
    return np.linalg.norm(r) / max(np.linalg.norm(y[:-1]), 1.0)


def _constraint(y, y_pred, direction, sphere):
    if sphere is None:
        return direction, direction @ (y - y_pred)
    v = y - sphere[0]
    return v / sphere[1], 0.5 * (v @ v / sphere[1] - sphere[1])


def _refine(evaluate, y, y_pred, direction, sphere, r, jx, jw, res, it0=0):
    """One Newton step from a point already within tol; kept if it lowers the residual."""
    row, con = _constraint(y, y_pred, direction, sphere)
    j = bordered(jx, jw, row)
    try:
        dy = solve_checked(j, -np.concatenate([r, [con]]), "continuation corrector",
                           warn=False)[0]
        yn = y + dy
        rn, jxn, jwn = evaluate(yn)
    except (ConvergenceError, np.linalg.LinAlgError):
        return None
    resn = float(np.linalg.norm(rn) / max(np.linalg.norm(yn[:-1]), 1.0))
    return (yn, 1 + it0, resn, jxn, jwn) if resn < res else None


def _tangent(jx, jw, previous):
    j = bordered(jx, jw, previous)
    rhs = np.zeros(jw.size + 1)
    rhs[-1] = 1.0
    t = solve_checked(j, rhs, "continuation tangent", warn=False)[0]
    t /= np.linalg.norm(t)
    return t if t @ previous >= 0 else -t


def trace(problem: HBMProblem, rpm_start: float, rpm_end: float, *, step: float = 0.01,
          min_step: float = 1e-6, max_step: float = 0.05, tol: float = 1e-8,
          max_points: int = 2000, max_iter: int = 12,
          on_point: Callable[[Branch], None] | None = None, resume: Branch | None = None,
          stability: bool = True, overshoot: float = 0.25,
          grazing_tol_rpm: float | None = None, start_fallback: bool = True) -> Branch:
    """Follow the periodic solutions from ``rpm_start`` to ``rpm_end``.

    Parameters
    ----------
    problem
        The HBM problem.
    rpm_start, rpm_end
        Speed bounds (rpm, > 0, different); the sweep direction is start -> end.
    step, min_step, max_step
        Initial, smallest and largest arc-length step (dimensionless, scaled
        unknowns, speed scaled by the range).
    tol
        Relative residual tolerance of every point.
    max_points
        Total number of points (including resumed ones).
    on_point
        Called with the branch so far after every accepted point (checkpoint).
    resume
        A previous Branch of the same problem and bounds: continue from its
        last point, tangent and step, giving the same curve as one run.
    stability
        Compute the stability of every point (:func:`hbm.stability.stability`).
    grazing_tol_rpm
        Tolerance on located grazing speeds (default 1e-9 of rpm_end).
    start_fallback
        If Newton (with its homotopy and damped fallbacks) fails at
        ``rpm_start``, approach ``rpm_start`` by a continuation from
        ``rpm_start / 4`` (closer to the quasi-static limit, where Newton
        converges) and start from its point at ``rpm_start``.
    overshoot
        A branch that folds back may go past ``rpm_start`` by this fraction of
        the range (never below half of rpm_start when sweeping up) before the
        trace stops with ``"left_range"``; those points are kept.

    Returns
    -------
    Branch
        Never holds an unconverged point; ``status``/``message`` say why it stopped.
    """
    for name, v in (("rpm_start", rpm_start), ("rpm_end", rpm_end)):
        if not np.isfinite(v) or v <= 0:
            raise ValueError(f"trace.{name} = {v!r}: must be > 0 rpm")
    if rpm_start == rpm_end:
        raise ValueError(f"trace.rpm_end = {rpm_end!r}: must differ from rpm_start")
    if not (0 < min_step <= step <= max_step):
        raise ValueError(f"trace.step = {step!r}: need 0 < min_step ({min_step}) <= step <= "
                         f"max_step ({max_step})")
    if not (0 < tol < 1e-2):
        raise ValueError(f"trace.tol = {tol!r}: must be in (0, 1e-2)")
    if int(max_points) != max_points or max_points < 1:
        raise ValueError(f"trace.max_points = {max_points!r}: must be an integer >= 1")
    w_start, w_end = rpm_start * RPM_TO_RAD_S, rpm_end * RPM_TO_RAD_S
    dirn = 1.0 if w_end > w_start else -1.0
    wscale = abs(w_end - w_start)
    if not overshoot >= 0:
        raise ValueError(f"trace.overshoot = {overshoot!r}: must be >= 0")
    # a branch folding back may leave the range through its start by this much
    w_floor = w_start - dirn * overshoot * wscale
    if dirn > 0:
        w_floor = max(w_floor, 0.5 * w_start)
    gtol = 1e-9 * rpm_end if grazing_tol_rpm is None else float(grazing_tol_rpm)
    xs = problem.x_scale
    evaluate = _augmented(problem, wscale)

    basis = [None]          # dominant Floquet subspace of the last point (warm start)
    # matrix-free: det T(0) (T.9) from the tangent, sign det J = sign det J_0 when the
    # speed component keeps the sign it had at the first point (T.9a, docs/theory.md)
    parity_ref: list = []

    def parity_of(pt, tangent):
        if not (stability and problem.matrix_free and problem.modal):
            return None
        if not parity_ref:
            first = point_stability(problem, pt).fold_parity
            parity_ref.extend([first, tangent[-1] > 0])
        return parity_ref[0] != ((tangent[-1] > 0) != parity_ref[1])

    def record(rec, y, it, res, tangent):
        omega = y[-1] * wscale
        u = y[:-1] * xs
        pt = problem.point(u, omega, it, res)
        st = point_stats(problem, pt)
        if stability:
            stab = point_stability(problem, pt, start=basis[0],
                                   parity=parity_of(pt, tangent))
            basis[0] = stab.basis
            fmax, kind, consistent = stab.max_real, stab.code, stab.consistent
            stable = stab.kind == "stable"
        else:
            fmax, stable, kind, consistent = 0.0, True, 0, True
        rec.add(rpm=pt.rpm, omega=omega, coefficients=pt.coefficients, unknowns=u,
                residual=res, newton_iterations=it, stable=bool(stable), floquet_max_real=fmax,
                mesh_load_std=st.mesh_load_std, mesh_load_max=st.mesh_load_max,
                contact=st.contact, contact_loss_fraction=st.contact_loss_fraction,
                impacts_per_mesh_period=st.impacts_per_mesh_period,
                margin_active=st.margin_active, margin_reverse=st.margin_reverse,
                ipp=st.ipp, tangents=tangent, floquet_kind=kind,
                stability_consistent=bool(consistent))

    if resume is not None:
        if len(resume) == 0:
            raise ValueError("trace.resume: the branch has no point to resume from")
        if resume.unknowns.ndim != 2 or resume.unknowns.shape[1] != problem.n_unknowns:
            raise ValueError("trace.resume: branch does not match this problem's unknowns")
        if resume.status == "completed":
            return resume
        wscale = resume.omega_scale
        evaluate = _augmented(problem, wscale)
        rec = _Recorder(problem, rpm_start, rpm_end, wscale, resume)
        # a run that was interrupted (or hit max_points) continues with its step; one that
        # failed (step, reversal) restarts from its last point with this call's step settings
        ds = resume.next_step if resume.status in ("running", "max_points") and \
            resume.next_step > 0 else step
        ds = min(max(ds, min_step), max_step)
    else:
        rec = _Recorder(problem, rpm_start, rpm_end, wscale)
        try:
            p0 = problem.solve(rpm_start, tol=tol)
        except ConvergenceError as exc:
            p0 = _approach_start(problem, rpm_start, tol, max_iter, max_points) if (
                start_fallback) else None
            if p0 is None:
                msg = f"no converged solution at rpm_start = {rpm_start}: {exc}" + (
                    "; nor by continuation from rpm_start / 4" if start_fallback else "")
                logger.error(msg)
                return rec.branch("start_failed", msg, step)
        y0 = np.concatenate([p0.unknowns / xs, [p0.omega / wscale]])
        _, jx, jw = evaluate(y0)
        try:
            tx = -solve_checked(jx, jw, "initial tangent")[0]
        except ConvergenceError as exc:
            msg = f"singular Jacobian at the first point rpm_start = {rpm_start}: {exc}"
            logger.error(msg)
            return rec.branch("start_failed", msg, step)
        t0 = np.concatenate([tx, [1.0]]) * dirn
        t0 /= np.linalg.norm(t0)
        record(rec, y0, p0.iterations, p0.residual, t0)
        ds = step
        if on_point:
            on_point(rec.branch("running", "", ds))

    def state(i):
        return np.concatenate([rec.lists["unknowns"][i] / xs, [rec.lists["omega"][i] / wscale]])

    status, message = "running", ""
    while True:
        if len(rec) >= max_points:
            status, message = "max_points", f"stopped after max_points = {max_points} points"
            break
        y = state(-1)
        t = rec.last("tangents")
        fails = 0
        accepted = None
        predictor = "tangent"
        if rec.releap == len(rec) - 1:
            # the trace came back to the same turn twice: the steps from it keep landing
            # on the piece traced (a fold sharper than the step); leap across the fold
            rec.releap = None
            accepted = _leap(evaluate, rec, state, tol, max_iter, max_step)
            predictor = "leap after repeated reversals"
        while accepted is None:
            # retries cycle through: tangent, spherical corrector past a corner,
            # secant, tangent with a patient corrector
            d = t
            predictor = "tangent"
            iters = max_iter
            sphere = None
            mode = fails % 4
            if mode == 1:
                predictor, sphere = "corner (spherical corrector)", (y, ds)
            elif mode == 2 and len(rec) >= 2:
                sec = y - state(-2)
                if np.linalg.norm(sec) > 0:
                    d = sec / np.linalg.norm(sec)
                    predictor = "secant"
                    rec.counters["secant_retries"] += 1
            elif mode == 3:
                predictor, iters = "tangent (patient corrector)", 4 * max_iter
            y_pred = y + ds * d
            conds: list[float] = []
            try:
                if sphere is not None:
                    travel = y - state(-2) if len(rec) >= 2 else t
                    yn, it, res, jx, jw = _corner_step(evaluate, y, t, travel,
                                                       min(ds, CORNER_RADIUS), tol, iters,
                                                       conds)
                    _note_condition(rec, conds)
                    chord = (yn - y) / np.linalg.norm(yn - y)
                    tn = _tangent(jx, jw, chord)
                    _check_forward(rec, y, yn)
                    rec.counters["corner_steps"] += 1
                    accepted = (yn, it, res, tn)
                    continue
                yn, it, res, jx, jw = _correct(evaluate, y_pred, d, tol, iters, conds)
                _note_condition(rec, conds)
                tn = _tangent(jx, jw, t)
                jump = np.linalg.norm(yn - y_pred)
                if jump > 0.5 * ds and ds > 4 * min_step:
                    # a long way from the predictor: likely a jump onto another branch
                    raise _StepRejected(f"corrector moved {jump / ds:.2f} steps off the predictor")
                if tn @ t < 0.7 and ds > max(4 * min_step, CORNER_STEP):
                    # (below CORNER_STEP a sharp turn is a corner of the piecewise-smooth
                    # branch, an AFT sample entering contact, not a jump to another branch)
                    angle = np.degrees(np.arccos(np.clip(tn @ t, -1, 1)))
                    raise _StepRejected(f"tangent turned by {angle:.0f} deg")
                _check_forward(rec, y, yn)
                accepted = (yn, it, res, tn)
            except (ConvergenceError, _StepRejected, np.linalg.LinAlgError) as exc:
                _note_condition(rec, conds)
                fails += 1
                rec.counters["step_cuts"] += 1
                ds *= 0.5
                logger.debug("%s step failed at rpm %.6g (%s); step cut to %.3g", predictor,
                             rec.last("rpm"), exc, ds)
                if ds < min_step and fails < 4:
                    ds = min_step        # every predictor gets a try at the smallest step
                elif ds < min_step:
                    status = "step_failed"
                    message = (f"step fell below min_step = {min_step} after {fails} failed "
                               f"steps (tangent, corner, secant and patient retries) from the "
                               f"last converged point at rpm {rec.last('rpm'):.6g}: {exc}")
                    break
        if accepted is None and len(rec) >= 2:
            # corner leap: past a non-smooth point along the direction of travel
            accepted = _leap(evaluate, rec, state, tol, max_iter, max_step)
            if accepted is not None:
                status, message = "running", ""
                ds = max(min_step, min(step, max_step))
        if accepted is None:
            if rec.guard is not None and rec.guard[0] == len(rec) - 1:
                message += ("; the branch had turned back over its own points here (a "
                            "reversal, undone) and no step forward converged")
            break
        yn, it, res, tn = accepted
        logger.debug("accepted rpm %.6g from rpm %.6g (%s, step %.3g, %d iterations)",
                     yn[-1] * wscale / RPM_TO_RAD_S, rec.last("rpm"), predictor, ds, it)
        hit = _revisit(rec, state, yn, evaluate, tol, max_iter)
        if hit is not None:
            # the branch walks back over points already traced: drop the points after
            # the turn, re-predict from it with the old orientation and a smaller step
            past_fold = _past_fold(rec, state, hit, evaluate, tol, max_iter)
            # past a genuine fold, the step from its far side jumped back onto the piece
            # that led to the fold: keep the fold and retry from the last point, shorter
            k = len(rec) - 1 if past_fold else _reversal_point(rec, state, yn, hit)
            rec.counters["reversals"] += 1
            # reversals count until the branch grows well past its length at the last one
            if len(rec) > rec.stuck_at + REVERSAL_PROGRESS:
                rec.stuck = 0
            rec.stuck += 1
            rec.stuck_at = max(rec.stuck_at, len(rec))
            if rec.stuck > MAX_REVERSALS:
                status = "reversal"
                message = (f"the branch walked back over its own points (near rpm "
                           f"{rec.lists['rpm'][hit]:.6g}) after {MAX_REVERSALS} recoveries from "
                           f"reversals; the curve is complete up to rpm {rec.lists['rpm'][k]:.6g}"
                           " only")
                rec.truncate(k + 1)
                break
            logger.warning("continuation reversal: the new point at rpm %.6g revisits the "
                           "branch near rpm %.6g; back to %s at rpm %.6g (point %d of %d) "
                           "with the old orientation (%d without progress)",
                           yn[-1] * wscale / RPM_TO_RAD_S, rec.lists["rpm"][hit],
                           "the last point past the fold" if past_fold else "the turn",
                           rec.lists["rpm"][k], k, len(rec), rec.stuck)
            rec.releap = k if rec.last_turn == k else None
            rec.last_turn = k
            rec.truncate(k + 1)
            travel = state(k) - state(k - 1)
            rec.guard = (k, travel / np.linalg.norm(travel))
            tk = rec.lists["tangents"][k]
            if tk @ travel < 0:      # re-predict with the orientation the branch came in
                rec.lists["tangents"][k] = -tk
            ds = max(min_step, (0.25 if past_fold else 0.5)
                     * min(ds, float(np.linalg.norm(travel))))
            if on_point:
                on_point(rec.branch("running", "", ds))
            continue
        wn = yn[-1] * wscale
        beyond_end = dirn * (wn - w_end) > 0
        before_start = dirn * (wn - w_floor) < 0
        if beyond_end or before_start:
            wb = w_end if beyond_end else w_floor
            lam = (wb - y[-1] * wscale) / (wn - y[-1] * wscale)
            guess = y[:-1] + lam * (yn[:-1] - y[:-1])
            try:
                xb, itb, resb = newton(lambda x, j=True, wb=wb: problem.scaled(x, wb, j), guess,
                                       tol, 30)
                yb = np.concatenate([xb, [wb / wscale]])
                _, jx, jw = evaluate(yb)
                tb = _tangent(jx, jw, tn)
                _check_events(problem, rec, evaluate, yb, tb, itb, resb, wscale, tol, max_iter,
                              gtol, record)
                landed = ""
            except (ConvergenceError, np.linalg.LinAlgError) as exc:
                landed = f" (no converged point exactly on the bound: {exc})"
                logger.warning("could not land on the bound %.6g rpm: %s", wb / RPM_TO_RAD_S, exc)
            if beyond_end:
                status, message = "completed", f"reached rpm_end = {rpm_end}{landed}"
            else:
                status, message = "left_range", (
                    f"the branch turned back and left the range through rpm_start = {rpm_start} "
                    f"(by more than overshoot = {overshoot} of the range){landed}")
            break
        _check_events(problem, rec, evaluate, yn, tn, it, res, wscale, tol, max_iter, gtol, record)
        if it <= 3:
            ds = min(ds * 1.5, max_step)
        elif it >= 7:
            ds = max(ds * 0.6, min_step)
        if on_point:
            on_point(rec.branch("running", "", ds))
    if status != "completed":
        logger.warning("continuation stopped: %s", message)
    else:
        logger.info("continuation %s: %d points", message, len(rec))
    branch = rec.branch(status, message, ds)
    if on_point:
        on_point(branch)
    return branch


def _approach_start(problem, rpm_start, tol, max_iter, max_points):
    """Point at ``rpm_start`` reached by continuation from ``rpm_start / 4``, or None."""
    logger.warning("Newton failed at rpm_start = %.6g; approaching it by continuation from "
                   "%.6g rpm", rpm_start, rpm_start / 4)
    sub = trace(problem, rpm_start / 4, rpm_start, tol=tol, max_iter=max_iter,
                max_points=max_points, stability=False, start_fallback=False)
    if sub.status != "completed" or abs(sub.rpm[-1] - rpm_start) > 1e-12 * rpm_start:
        logger.warning("approach to rpm_start failed: %s", sub.message)
        return None
    return problem.point(sub.unknowns[-1], sub.omega[-1], int(sub.newton_iterations[-1]),
                         float(sub.residual[-1]))


def _corner_step(evaluate, y, t, travel, ds, tol, max_iter, conds):
    """Step past a corner of the piecewise-linear branch (an AFT sample switching
    contact, possibly a fold of the branch there).

    Predictors ``y +- ds t_B`` along the tangent ``t_B`` of the piece beyond the
    corner (null vector of the Jacobian at ``y + ds t``), then ``y + ds t``;
    corrector on the sphere ``|y' - y| = ds``, which meets every branch leaving
    ``y``. A point going back along the branch (chord against the direction of
    ``travel``, the last chord) is refused.
    """
    dirs = []
    try:
        _, jx, jw = evaluate(y + ds * t)
        tb = _tangent(jx, jw, t)
        dirs += [tb, -tb]
    except (ConvergenceError, np.linalg.LinAlgError):
        pass
    dirs.append(t)
    last: Exception = ConvergenceError("corner step: no predictor")
    nb = np.linalg.norm(travel)
    for d in dirs:
        try:
            yn, it, res, jx, jw = _correct(evaluate, y + ds * d, d, tol, max_iter, conds,
                                           sphere=(y, ds))
        except (ConvergenceError, np.linalg.LinAlgError) as exc:
            last = exc
            continue
        chord = yn - y
        if nb > 0 and chord @ travel < -0.9 * np.linalg.norm(chord) * nb:
            last = _StepRejected("spherical corrector went back along the branch")
            continue
        return yn, it, res, jx, jw
    raise last


def _check_forward(rec, y, yn) -> None:
    """After a reversal was undone at point k, refuse a step from k that goes back."""
    if rec.guard is not None and rec.guard[0] == len(rec) - 1 and (yn - y) @ rec.guard[1] <= 0:
        raise _StepRejected("step goes back over the branch (a reversal was undone here)")


def _states(rec, state) -> np.ndarray:
    return np.array([state(i) for i in range(len(rec))])


def _revisit(rec, state, yn, evaluate=None, tol=1e-8, max_iter=12) -> int | None:
    """Index i of the earlier segment (i, i+1) that ``yn`` lies on, or None.

    Every segment but the last is checked; ``yn`` is near the branch when its distance
    to the segment is below ``REVISIT_RATIO`` times its chord from the last point. With
    ``evaluate``, a near point is a revisit only if it is the same solution as the old
    branch at its speed (:func:`_distinct_solution`); otherwise it is another piece of
    the branch lying close by (past a sharp fold) and None is returned.
    """
    n = len(rec)
    if n < 3:
        return None
    ys = _states(rec, state)
    if (yn - ys[-1]) @ (ys[-1] - ys[-2]) > 0:
        # the step went on in the direction of travel: a branch that winds past its own
        # earlier loops (a spiral near a resonance with impacts), not a walk back
        return None
    a, b = ys[:n - 2], ys[1:n - 1]
    ab = b - a
    t = np.clip(np.einsum("ij,ij->i", yn - a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab),
                                                                1e-300), 0.0, 1.0)
    foot = a + t[:, None] * ab
    d = np.linalg.norm(foot - yn, axis=1)
    i = int(np.argmin(d))
    chord = float(np.linalg.norm(yn - ys[-1]))
    if not d[i] < REVISIT_RATIO * chord:
        return None
    if evaluate is not None and _distinct_solution(evaluate, foot[i], yn, tol, max_iter):
        logger.info("point at scaled speed %.9g lies %.2g chords from the branch traced but "
                    "is another solution there (a sharp fold): not a revisit", yn[-1],
                    d[i] / chord)
        return None
    return i


def _distinct_solution(evaluate, foot, yn, tol, max_iter) -> bool:
    """True if the branch traced, at the speed of ``yn``, is a solution other than ``yn``.

    Newton at the fixed speed of ``yn`` from ``foot`` (the nearest point of the old
    polyline, its speed replaced by that of ``yn``). Distinct when it converges to a point
    ``y*`` farther than ``SAME_SOLUTION`` from ``yn`` and closer to ``foot`` than to
    ``yn`` (the old piece, not ``yn``'s or a third one). A failed solve counts as the
    same solution (the revisit is then undone as before).
    """
    y0 = foot.copy()
    y0[-1] = yn[-1]
    e_w = np.zeros_like(yn)
    e_w[-1] = 1.0
    try:
        ys, *_ = _correct(evaluate, y0, e_w, tol, max_iter)
    except (ConvergenceError, np.linalg.LinAlgError) as exc:
        logger.debug("revisit check: no solution at the new point's speed from the old "
                     "branch (%s)", exc)
        return False
    gap = float(np.linalg.norm(ys - yn))
    logger.debug("revisit check: old branch at the new point's speed %.3g from it, %.3g from "
                 "the old polyline", gap, float(np.linalg.norm(ys - y0)))
    return gap > SAME_SOLUTION * max(float(np.linalg.norm(yn[:-1])), 1.0) and \
        float(np.linalg.norm(ys - y0)) < 0.5 * gap


def _past_fold(rec, state, hit, evaluate, tol, max_iter) -> bool:
    """True if the branch turned at a fold after the revisited segment ``hit`` and its
    last point lies on the fold's far piece: another solution than the piece that led to
    the fold, at the same speed (:func:`_distinct_solution`), not that piece walked back.
    """
    if not rec.fold_index:
        return False
    f, n = rec.fold_index[-1], len(rec)
    if not (hit < f < n - 1 and f >= 1):
        return False
    ys = _states(rec, state)
    a, b = ys[:f], ys[1:f + 1]
    ab = b - a
    y = ys[-1]
    t = np.clip(np.einsum("ij,ij->i", y - a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab),
                                                               1e-300), 0.0, 1.0)
    foot = a + t[:, None] * ab
    i = int(np.argmin(np.linalg.norm(foot - y, axis=1)))
    return _distinct_solution(evaluate, foot[i], y, tol, max_iter)


def _reversal_point(rec, state, yn, hit: int) -> int:
    """The point after the revisited segment ``hit`` where the path turned the most."""
    n = len(rec)
    lo = max(hit + 1, 1)
    if lo >= n:
        return n - 1
    ys = np.vstack([_states(rec, state)[lo - 1:], yn])
    ch = np.diff(ys, axis=0)
    nrm = np.maximum(np.linalg.norm(ch, axis=1), 1e-300)
    cos = np.einsum("ij,ij->i", ch[1:], ch[:-1]) / (nrm[1:] * nrm[:-1])
    return lo + int(np.argmin(cos))


def _leap(evaluate, rec, state, tol, max_iter, max_step):
    """Corner leap: plane predictors ``LEAP_FACTORS`` last chords ahead of the last point
    along its direction of travel, then with the speed component of that direction
    reversed (a fold at a corner: the state goes on, the speed turns back); accepted if
    it moves forward along the predictor without revisiting the branch."""
    y = state(-1)
    travel = y - state(-2)
    h = float(np.linalg.norm(travel))
    if not h > 0:
        return None
    folded = travel.copy()
    folded[-1] = -folded[-1]
    e_w = np.zeros_like(y)
    e_w[-1] = 1.0
    for d, plane in ((travel / h, None), (folded / np.linalg.norm(folded), e_w)):
        # folded: longest first (near the fold the piece traced lies close by)
        for f in (LEAP_FACTORS if plane is None else LEAP_FACTORS[::-1]):
            if f * h > max_step:
                continue
            try:
                # folded: corrector at the predicted speed (the state from the last point)
                yn, it, res, jx, jw = _correct(evaluate, y + f * h * d,
                                               d if plane is None else plane, tol, max_iter)
                tn = _tangent(jx, jw, d)
            except (ConvergenceError, np.linalg.LinAlgError):
                continue
            if (yn - y) @ d > 0 and _revisit(rec, state, yn, evaluate, tol, max_iter) is None:
                rec.counters["leaps"] += 1
                logger.info("corner leap past rpm %.6g (%.0f chords ahead%s)", rec.last("rpm"),
                            f, ", speed turned back" if d[-1] * travel[-1] < 0 else "")
                return yn, it, res, tn
    return None


def _note_condition(rec, conds) -> None:
    """Track the largest corrector condition estimate; warn once per trace."""
    finite = [c for c in conds if np.isfinite(c)]
    if not finite:
        return
    c = max(finite)
    rec.counters["max_condition"] = max(rec.counters["max_condition"], c)
    if c > COND_WARN and not rec.warned:
        rec.warned = True
        logger.warning("continuation near rpm %.6g: ill-conditioned corrector, condition "
                       "estimate %.2g of the scaled Jacobian (up to %d digits lost); further "
                       "estimates in branch.max_condition", rec.last("rpm"), c, int(np.log10(c)))


def _check_events(problem, rec, evaluate, yn, tn, it, res, wscale, tol, max_iter, gtol, record):
    """Record the new point after locating grazing and fold events since the last one."""
    xs = problem.x_scale
    ya = np.concatenate([rec.last("unknowns") / xs, [rec.last("omega") / wscale]])
    ma, mra = rec.last("margin_active"), rec.last("margin_reverse")
    record(rec, yn, it, res, tn)
    mb, mrb = rec.last("margin_active"), rec.last("margin_reverse")
    _check_fold(rec, wscale, xs)
    events = []
    if (ma > 0) != (mb > 0):
        events.append(("active", 0, "onset" if ma > 0 else "end"))
    if (mra > 0) != (mrb > 0):
        events.append(("reverse", 1, "onset" if mrb > 0 else "end"))
    for side, which, kind in events:
        rpm = _locate(problem, evaluate, ya, yn, which, wscale, tol, max_iter, gtol)
        rec.grazing.append(GrazingPoint(rpm=rpm, kind=kind, side=side))
        rec.n_grazing[-1] = len(rec.grazing)
        logger.info("grazing (%s, %s flank) at %.9g rpm", kind, side, rpm)


def _check_fold(rec, wscale, xs) -> None:
    """Fold (turning point): the speed increments of the last two steps change sign.

    Secant increments, not the tangent, are used: at kinks of the
    piecewise-smooth branch the one-sided Jacobian can give a tangent whose
    speed component has the wrong sign. The fold speed is the vertex of the
    parabola through the last three points in arc length.
    """
    if len(rec) < 3:
        return
    w = np.array(rec.lists["omega"][-3:])
    if (w[1] - w[0]) * (w[2] - w[1]) >= 0:
        return
    here = len(rec) - 2
    if rec.fold_index and here - rec.fold_index[-1] < FOLD_MERGE_POINTS:
        # two turns within a few points: a kink of the branch, not two folds
        logger.debug("fold pair near %.6g rpm merged", rec.folds[-1])
        rec.folds.pop()
        rec.fold_index.pop()
        return
    y = np.array(rec.lists["unknowns"][-3:]) / xs
    s1 = np.linalg.norm(np.append(y[1] - y[0], (w[1] - w[0]) / wscale))
    s2 = s1 + np.linalg.norm(np.append(y[2] - y[1], (w[2] - w[1]) / wscale))
    c = np.polyfit([0.0, s1, s2], w, 2)
    w_fold = w[1]
    if c[0] != 0:
        sv = -c[1] / (2 * c[0])
        if 0 <= sv <= s2:
            w_fold = np.polyval(c, sv)
    rec.folds.append(float(w_fold / RPM_TO_RAD_S))
    rec.fold_index.append(here)
    logger.info("fold near %.6g rpm", rec.folds[-1])


def _locate(problem, evaluate, ya, yb, which, wscale, tol, max_iter, gtol) -> float:
    """Illinois regula falsi on the chord parameter for a zero contact margin."""
    xs = problem.x_scale

    def margin(y):
        st = point_stats(problem, y[:-1] * xs)
        return st.margin_active if which == 0 else st.margin_reverse

    d = yb - ya
    d /= np.linalg.norm(d)
    lo, hi = 0.0, 1.0
    flo, fhi = margin(ya), margin(yb)
    ylo, yhi = ya, yb
    side = 0
    mscale = problem.length_scale
    for _ in range(60):
        if abs(yhi[-1] - ylo[-1]) * wscale / RPM_TO_RAD_S < gtol:
            break
        s = hi - fhi * (hi - lo) / (fhi - flo) if fhi != flo else 0.5 * (lo + hi)
        if not (lo < s < hi):
            s = 0.5 * (lo + hi)
        y_pred = ya + s * (yb - ya)
        try:
            y, *_ = _correct(evaluate, y_pred, d, tol, max_iter)
        except ConvergenceError as exc:
            logger.warning("grazing location stopped (corrector failed: %s); bracket "
                           "[%.9g, %.9g] rpm", exc, ylo[-1] * wscale / RPM_TO_RAD_S,
                           yhi[-1] * wscale / RPM_TO_RAD_S)
            break
        f = margin(y)
        if abs(f) <= 1e-12 * mscale:
            ylo = yhi = y
            break
        if (f > 0) == (fhi > 0):
            hi, fhi, yhi = s, f, y
            if side == -1:
                flo *= 0.5
            side = -1
        else:
            lo, flo, ylo = s, f, y
            if side == 1:
                fhi *= 0.5
            side = 1
    w = 0.5 * (ylo[-1] + yhi[-1]) * wscale
    return float(w / RPM_TO_RAD_S)
