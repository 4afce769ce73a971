"""The continuation branch: its points (:class:`Branch`), the grazing points located on
it (:class:`GrazingPoint`) and the recorder that grows it point by point, rolls it back
after a reversal and counts the retries (:mod:`hbm.continuation`)."""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np

from .newton import COND_WARN
from .postprocess import point_stats
from .problem import HBMProblem
from .stability import stability as point_stability
from .stability_process import Verdict

# the tracer's log: one name for the continuation and its modules
logger = logging.getLogger("hbm.continuation")

__all__ = ["Branch", "GrazingPoint"]


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


_ARRAYS = ("rpm", "omega", "coefficients", "unknowns", "residual", "newton_iterations",
           "stable", "floquet_max_real", "mesh_load_std", "mesh_load_max", "contact",
           "contact_loss_fraction", "impacts_per_mesh_period", "margin_active",
           "margin_reverse", "ipp", "tangents", "floquet_kind", "stability_consistent",
           "loop")


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
    loop
        Per point: 0 on the branch, ``j >= 1`` on the ``j``-th closed loop (a loop the
        branch went round and closed on itself in the same direction; its points are
        solutions and are kept, docs/hbm.md "Closed loops").
    loops
        One ``(first, last, entry, restart)`` per closed loop: its first and last point,
        the point the trace went back to (where it had entered the loop), and the index
        where the copies of that point and its predecessor restart the branch (the
        segment from ``restart - 1`` to ``restart`` was not traced). Empty without loops.
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
        ``MAX_REVERSALS`` recoveries), ``"loop"`` (closed on itself in the same
        direction and no step from the loop's entry point left it), ``"start_failed"``;
        the message says why
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
    loop: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    loops: list = field(default_factory=list)
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
        # closed loops: (first, last, entry, restart) each (Branch.loops); the segment
        # (restart - 1, restart) joins the loop's end to the copies and was not traced
        self.loops: list[tuple[int, int, int, int]] = []
        self.loop_tries: dict[int, int] = {}   # loop number -> exits tried from its entry
        # per point: the ticket of its stability verdict still to come from the worker
        # process (None: measured), and the hook that collects them (_Measure.settle)
        self.tickets: list = []
        self.settle = None
        # scaled states y = (u / x_scale, Omega / omega_scale) of the points, rows of a
        # buffer grown by doubling (the events read the whole branch at every point)
        self._x_scale = problem.x_scale
        self._ys = np.empty((16, problem.n_unknowns + 1))
        if resume is not None:
            self.counters = {"step_cuts": int(resume.step_cuts),
                             "secant_retries": int(resume.secant_retries),
                             "corner_steps": int(resume.corner_steps),
                             "reversals": int(getattr(resume, "reversals", 0)),
                             "leaps": int(getattr(resume, "leaps", 0)),
                             "max_condition": float(np.nan_to_num(resume.max_condition))}
            n = len(resume)
            for k in _ARRAYS:
                v = getattr(resume, k, None)
                self.lists[k] = list(v) if v is not None and len(v) == n else (
                    [0] * n if k == "loop" else list(v))
            self.loops = [tuple(int(x) for x in row)
                          for row in np.asarray(getattr(resume, "loops", []),
                                                dtype=np.int64).reshape(-1, 4)]
            self.grazing = list(resume.grazing)
            self.folds = list(resume.folds)
            self.fold_index = list(resume.fold_index)
            if len(self.fold_index) != len(self.folds):     # branch rebuilt without it
                self.fold_index = [-(10 ** 9)] * len(self.folds)
            self.n_grazing = [len(self.grazing)] * len(self.lists["rpm"])
            self.tickets = [None] * len(self.lists["rpm"])
            for i in range(len(self.tickets)):
                self._put_state(i)

    def __len__(self) -> int:
        return len(self.lists["rpm"])

    def last(self, key):
        return self.lists[key][-1]

    def add(self, ticket=None, **values) -> None:
        values.setdefault("loop", 0)
        for k in _ARRAYS:
            self.lists[k].append(values[k])
        self.n_grazing.append(len(self.grazing))
        self.tickets.append(ticket)
        self._put_state(len(self) - 1)

    def _put_state(self, i: int) -> None:
        if i >= self._ys.shape[0]:
            grown = np.empty((2 * self._ys.shape[0], self._ys.shape[1]))
            grown[:i] = self._ys[:i]
            self._ys = grown
        self._ys[i, :-1] = self.lists["unknowns"][i] / self._x_scale
        self._ys[i, -1] = self.lists["omega"][i] / self.meta["omega_scale"]

    def untraced(self) -> np.ndarray:
        """Mask over the segments ``(i, i + 1)``: True where the trace did not go from
        ``i`` to ``i + 1`` (it went back to a closed loop's entry point instead)."""
        m = np.zeros(max(len(self) - 1, 0), dtype=bool)
        for *_, restart in self.loops:
            if 0 < restart <= m.size:
                m[restart - 1] = True
        return m

    def restart(self) -> int:
        """Index of the first point of the current piece (after the last loop exit)."""
        return self.loops[-1][3] if self.loops else 0

    def states(self) -> np.ndarray:
        """Scaled states of every point (n_points, n_unknowns + 1), a read-only view."""
        v = self._ys[:len(self)]
        v.flags.writeable = False
        return v

    def fill(self, ticket, **values) -> None:
        """Set the values of the point waiting for ``ticket`` (gone after a roll-back:
        nothing to do)."""
        for i in range(len(self.tickets) - 1, -1, -1):
            if self.tickets[i] == ticket:
                for k, v in values.items():
                    self.lists[k][i] = v
                self.tickets[i] = None
                return

    def truncate(self, n: int) -> None:
        """Keep the first ``n`` points (and the folds and grazing points found by then)."""
        for k in _ARRAYS:
            del self.lists[k][n:]
        del self.tickets[n:]
        keep = [i for i, f in enumerate(self.fold_index) if f + 1 < n]
        self.folds = [self.folds[i] for i in keep]
        self.fold_index = [self.fold_index[i] for i in keep]
        del self.grazing[self.n_grazing[n - 1]:]
        del self.n_grazing[n:]
        self.loops = [lp for lp in self.loops if lp[0] < n]

    def branch(self, status: str, message: str, next_step: float,
               counters: dict | None = None) -> Branch:
        """The branch so far (every stability verdict collected first); ``counters``
        replaces the retry counters (a branch handed out later than it was reached)."""
        if self.settle is not None:
            self.settle()
        counters = self.counters if counters is None else counters
        arrays = {}
        for k in _ARRAYS:
            v = self.lists[k]
            arrays[k] = np.array(v) if v else np.zeros((0,))
        return Branch(**self.meta, **arrays, loops=[tuple(lp) for lp in self.loops],
                      grazing=list(self.grazing), folds=list(self.folds),
                      fold_index=list(self.fold_index),
                      step_cuts=counters["step_cuts"],
                      secant_retries=counters["secant_retries"],
                      corner_steps=counters["corner_steps"],
                      reversals=counters["reversals"], leaps=counters["leaps"],
                      max_condition=counters["max_condition"] or float("nan"),
                      status=status, message=message, next_step=float(next_step))



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


@dataclass
class _Measure:
    """The ``record`` of a :class:`TraceContext`: statistics and stability of a converged
    point, added to the recorder. Keeps the dominant Floquet subspace of the last point
    (warm start) and, matrix-free, the reference of the fold parity.

    With a ``worker`` (:class:`hbm.stability_process.StabilityProcess`) the stability
    is measured there, in the same order with the same warm starts: the point is added
    with a ticket and its verdict filled in by :meth:`settle` (bitwise the same values).
    """

    problem: HBMProblem
    wscale: float
    stability: bool
    basis: object = None
    # matrix-free: det T(0) (T.9) from the tangent, sign det J = sign det J_0 when the
    # speed component keeps the sign it had at the first point (T.9a, docs/theory.md)
    parity_ref: list = field(default_factory=list)
    worker: object = None
    recorder: object = None
    submitted: int = 0

    def parity(self, pt, tangent):
        problem = self.problem
        if not (self.stability and problem.matrix_free and problem.modal):
            return None
        if not self.parity_ref:
            first = point_stability(problem, pt).fold_parity
            self.parity_ref.extend([first, tangent[-1] > 0])
        return self.parity_ref[0] != ((tangent[-1] > 0) != self.parity_ref[1])

    def settle(self, wait: bool = True) -> None:
        """Fill in the verdicts of the worker received so far (all pending if ``wait``)."""
        if self.worker is None or self.recorder is None:
            return
        for ticket, v in self.worker.collect(wait):
            self.recorder.fill(ticket, stable=v.stable, floquet_max_real=v.max_real,
                               floquet_kind=v.code, stability_consistent=v.consistent)

    def __call__(self, rec: _Recorder, y: np.ndarray, it: int, res: float,
                 tangent: np.ndarray) -> None:
        problem = self.problem
        omega = y[-1] * self.wscale
        u = y[:-1] * problem.x_scale
        pt = problem.point(u, omega, it, res)
        st = point_stats(problem, pt)
        ticket = None
        if self.stability and self.worker is not None:
            self.recorder = rec
            rec.settle = self.settle
            ticket = self.submitted
            self.submitted += 1
            self.worker.submit(ticket, u, omega, it, res, self.parity(pt, tangent))
            # placeholders until the verdict arrives (Recorder.branch settles first)
            fmax, stable, kind, consistent = float("nan"), False, 0, True
        elif self.stability:
            stab = point_stability(problem, pt, start=self.basis,
                                   parity=self.parity(pt, tangent))
            self.basis = stab.basis
            v = Verdict.of(stab)
            fmax, kind, consistent, stable = v.max_real, v.code, v.consistent, v.stable
        else:
            fmax, stable, kind, consistent = 0.0, True, 0, True
        rec.add(ticket=ticket, rpm=pt.rpm, omega=omega, coefficients=pt.coefficients,
                unknowns=u, residual=res, newton_iterations=it, stable=bool(stable),
                floquet_max_real=fmax, mesh_load_std=st.mesh_load_std,
                mesh_load_max=st.mesh_load_max, contact=st.contact,
                contact_loss_fraction=st.contact_loss_fraction,
                impacts_per_mesh_period=st.impacts_per_mesh_period,
                margin_active=st.margin_active, margin_reverse=st.margin_reverse,
                ipp=st.ipp, tangents=tangent, floquet_kind=kind,
                stability_consistent=bool(consistent))
        if ticket is not None:
            self.settle(wait=False)
