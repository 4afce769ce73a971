"""The continuation branch: its points (:class:`Branch`), one element's curve along it
(:class:`ElementCurve`), the events located on it (:class:`GrazingPoint`) and the
recorder that grows it point by point, rolls it back after a reversal and counts the
retries (:class:`Recorder`)."""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..newton import COND_WARN
from ..records import Record
from .segments import SegmentIndex

# the tracer's log: one name for the continuation and its modules
logger = logging.getLogger("hbm.continuation")

__all__ = ["Branch", "ElementCurve", "GrazingPoint", "POINT_FIELDS", "Recorder",
           "note_condition"]


@dataclass
class GrazingPoint:
    """An event located on the branch: a grazing bifurcation (eq. 30) of element
    ``element``.

    ``kind`` is ``"onset"`` (impacts start, along the direction of travel) or
    ``"end"``; ``side`` is the element's test function (a gear mesh's flank: ``"active"``,
    contact loss on the driving flank, sign change of phi_GR; ``"reverse"``, the back
    flank starts/stops being hit).
    """

    rpm: float
    kind: str
    side: str
    element: int = 0


#: The per-point arrays of every branch, whatever the elements.
POINT_FIELDS = ("rpm", "omega", "unknowns", "residual", "newton_iterations", "stable",
                "floquet_max_real", "tangents", "floquet_kind", "stability_consistent",
                "loop", "floquet_amplification", "stability_grazing")
#: Point fields a branch of an older file may lack, and their value there (not computed)
LATER_FIELDS = {"floquet_amplification": float("nan"), "stability_grazing": False}


class ElementCurve(Record):
    """One element's statistics along a branch, by name (a :class:`hbm.records.Record`
    of per-point arrays: ``curve.mesh_load_std`` for a gear mesh), with ``element`` its
    index, ``name`` its label and ``grazing`` the events located on it."""

    __slots__ = ("element", "name", "grazing")

    def __init__(self, values: dict[str, np.ndarray], element: int, name: str,
                 grazing: list[GrazingPoint]) -> None:
        super().__init__(values)
        object.__setattr__(self, "element", element)
        object.__setattr__(self, "name", name)
        object.__setattr__(self, "grazing", grazing)

    def __reduce__(self):
        return type(self), (dict(self), self.element, self.name, self.grazing)


@dataclass
class Branch:
    """A continuation branch: one entry per accepted point (all arrays).

    Attributes
    ----------
    harmonics, condensation
        The problem's harmonic indices and condensation (what the unknowns mean).
    rpm, omega
        Shaft speed (rpm) and Omega (rad/s).
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
    floquet_amplification
        Transient amplification over one period: the largest singular value of the
        monodromy in the energy norm (a lower bound from its dominant subspace for a
        large model); NaN where not computed.
    stability_grazing
        True where the verdict is unresolved near grazing: an orbit shift of
        ``hbm.stability.grazing.GRAZING_RTOL`` of the peak-to-peak deflection changes
        its sign, or the fold parity contradicts (T.10) there (reported unstable).
    stats
        The per-element table: each statistic of the elements (a gear mesh:
        ``mesh_load_std``, ``mesh_load_max``, ``contact``, ``contact_loss_fraction``,
        ``impacts_per_mesh_period``, ``margin_active``, ``margin_reverse``, ``ipp``;
        :attr:`hbm.elements.Element.statistics`) and ``coefficients`` (the complex
        Fourier coefficients of each Delta_e, m), each ``(n_points, n_elements[, ...])``.
        A statistic an element kind does not have is NaN (integers: -1) for it; the IPP
        sequences of elements with fewer base periods are padded with -1. Read one
        element's curve with :meth:`element`.
    element_names
        The elements' labels.
    element_statistics
        Per element, the names of its own statistics (the others of the table are NaN or
        -1 for it); empty: every element has every statistic.
    tangents
        Scaled unit tangents (n_points, n_unknowns + 1), for resuming.
    grazing, folds
        Located grazing points (with their element) and fold speeds (rpm).
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
    unknowns: np.ndarray
    residual: np.ndarray
    newton_iterations: np.ndarray
    stable: np.ndarray
    floquet_max_real: np.ndarray
    tangents: np.ndarray
    floquet_kind: np.ndarray
    stability_consistent: np.ndarray
    stats: dict[str, np.ndarray] = field(default_factory=dict)
    element_names: tuple[str, ...] = ()
    element_statistics: tuple[tuple[str, ...], ...] = ()
    loop: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    floquet_amplification: np.ndarray = field(default_factory=lambda: np.zeros(0))
    stability_grazing: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))
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

    def __post_init__(self) -> None:
        # a branch read from an older file: the later fields were not computed
        n = int(np.size(self.rpm))
        for k, fill in LATER_FIELDS.items():
            if np.size(getattr(self, k)) != n:
                setattr(self, k, np.full(n, fill))

    def __len__(self) -> int:
        return int(self.rpm.size)

    @property
    def n_elements(self) -> int:
        """Number of elements of the problem."""
        return len(self.element_names)

    def element(self, e: int = 0) -> ElementCurve:
        """Element ``e``'s curve: its own statistics per point (each array's first axis)
        and the coefficients of its deflection, its label and the events located on it."""
        if not 0 <= e < max(self.n_elements, 1):
            raise IndexError(f"branch.element({e}): the branch has {self.n_elements} "
                             "elements")
        own = set(self.element_statistics[e]) | {"coefficients"} \
            if self.element_statistics else set(self.stats)
        values = {k: (v[:, e] if v.ndim >= 2 else v) for k, v in self.stats.items()
                  if k in own}
        name = self.element_names[e] if self.element_names else ""
        return ElementCurve(values, e, name, [g for g in self.grazing if g.element == e])


class Recorder:
    """The branch as it grows: the per-point lists, the events found so far and the
    tracer's bookkeeping (retry counters, the guard after a reversal, closed loops,
    tickets of stability verdicts still to come).

    ``meta`` (:meth:`Monitor.branch_meta`) names the per-element statistics; ``x_scale``
    and ``omega_scale`` scale the states of the points; ``resume`` is a branch to
    continue.
    """

    def __init__(self, meta: dict[str, Any], x_scale: np.ndarray, rpm_start, rpm_end,
                 omega_scale, resume: Branch | None = None):
        self.meta = dict(harmonics=tuple(meta["harmonics"]),
                         condensation=meta["condensation"], rpm_start=float(rpm_start),
                         rpm_end=float(rpm_end), omega_scale=float(omega_scale))
        self.element_names = tuple(meta.get("element_names", ()))
        self.element_statistics = tuple(tuple(s) for s in meta.get("element_statistics", ()))
        self.stat_names = tuple(meta["statistics"])
        self.lists: dict[str, list] = {k: [] for k in (*POINT_FIELDS, *self.stat_names)}
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
        # process (None: measured), and the hook that collects them
        self.tickets: list = []
        self.settle = None
        self._settled = 0       # points before it all hold their verdicts
        # a number per recorded point, never reused (a point rolled back and another
        # recorded at its index differ): identifies points handed out later
        self.serials: list[int] = []
        self._next_serial = 0
        # scaled states y = (u / x_scale, Omega / omega_scale) of the points, rows of a
        # buffer grown by doubling (the events read the whole branch at every point)
        self._x_scale = x_scale
        self._ys = np.empty((16, x_scale.size + 1))
        # bounding balls over the segments between them (the walk-back and closed-loop
        # tests look only at the segments near a new point)
        self.segments = SegmentIndex()
        # the lists stacked as arrays for branch(), grown point by point (a branch is
        # handed to on_point after every point: stacking every list again cost O(n))
        self._rows = {k: _Rows() for k in self.lists}
        if resume is not None:
            self._resume(resume)

    def _resume(self, resume: Branch) -> None:
        self.counters = {"step_cuts": int(resume.step_cuts),
                         "secant_retries": int(resume.secant_retries),
                         "corner_steps": int(resume.corner_steps),
                         "reversals": int(getattr(resume, "reversals", 0)),
                         "leaps": int(getattr(resume, "leaps", 0)),
                         "max_condition": float(np.nan_to_num(resume.max_condition))}
        n = len(resume)
        for k in POINT_FIELDS:
            v = getattr(resume, k, None)
            self.lists[k] = list(v) if v is not None and len(v) == n else (
                [0] * n if k == "loop" else [LATER_FIELDS[k]] * n if k in LATER_FIELDS
                else list(v))
        for k in self.stat_names:
            self.lists[k] = list(resume.stats[k])
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
        self.serials = list(range(len(self.tickets)))
        self._next_serial = len(self.tickets)
        for i in range(len(self.tickets)):
            self._put_state(i)

    def __len__(self) -> int:
        return len(self.lists["rpm"])

    def last(self, key):
        return self.lists[key][-1]

    def add(self, ticket=None, stats: dict | None = None, **values) -> None:
        """Append a point: the :data:`POINT_FIELDS` (``loop`` 0 by default), its
        per-element ``stats`` and the ticket of a stability still to come."""
        values.setdefault("loop", 0)
        for k, fill in LATER_FIELDS.items():
            values.setdefault(k, fill)
        for k in POINT_FIELDS:
            self.lists[k].append(values[k])
        for k in self.stat_names:
            self.lists[k].append(stats[k])
        self.n_grazing.append(len(self.grazing))
        self.tickets.append(ticket)
        self.serials.append(self._next_serial)
        self._next_serial += 1
        self._put_state(len(self) - 1)

    def set(self, key: str, i: int, value) -> None:
        """Replace the value of the per-point list ``key`` at point ``i`` (write rows of
        points already recorded only through here: :meth:`branch` keeps them stacked)."""
        self.lists[key][i] = value
        self._rows[key].invalidate(i)

    def stat(self, name: str, i: int, element: int):
        """Statistic ``name`` of ``element`` at point ``i``."""
        return self.lists[name][i][element]

    def _put_state(self, i: int) -> None:
        if i >= self._ys.shape[0]:
            grown = np.empty((2 * self._ys.shape[0], self._ys.shape[1]))
            grown[:i] = self._ys[:i]
            self._ys = grown
        self._ys[i, :-1] = self.lists["unknowns"][i] / self._x_scale
        self._ys[i, -1] = self.lists["omega"][i] / self.meta["omega_scale"]
        self.segments.grow(self._ys, i + 1)

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
        for i in range(len(self.tickets) - 1, self._settled - 1, -1):
            if self.tickets[i] == ticket:
                for k, v in values.items():
                    self.set(k, i, v)
                self.tickets[i] = None
                return

    def truncate(self, n: int) -> None:
        """Keep the first ``n`` points (and the folds and grazing points found by then)."""
        for k in self.lists:
            del self.lists[k][n:]
            self._rows[k].invalidate(n)
        del self.tickets[n:]
        del self.serials[n:]
        self._settled = min(self._settled, n)
        self.segments.truncate(n)
        self.folds, self.fold_index, self.grazing, self.loops = self._events_on(n)
        del self.n_grazing[n:]

    def _events_on(self, n: int) -> tuple[list, list, list, list]:
        """The folds (speeds and indices), grazing points and loops found on the first
        ``n`` points (``n >= 1``), as new lists."""
        keep = [i for i, f in enumerate(self.fold_index) if f + 1 < n]
        return ([self.folds[i] for i in keep], [self.fold_index[i] for i in keep],
                self.grazing[:self.n_grazing[n - 1]],
                [lp for lp in self.loops if lp[0] < n])

    def settled_prefix(self) -> int:
        """How many points from the first hold their stability verdicts (amortised
        ``O(1)``: the count only moves forward, but for a roll-back)."""
        while self._settled < len(self) and self.tickets[self._settled] is None:
            self._settled += 1
        return self._settled

    def holds(self, i: int, serial: int) -> bool:
        """Whether point ``i`` is still the point recorded with ``serial``."""
        return i < len(self) and self.serials[i] == serial

    def branch(self, status: str, message: str, next_step: float,
               counters: dict | None = None, upto: int | None = None) -> Branch:
        """The branch so far (every stability verdict collected first), or its first
        ``upto`` points (which must hold their verdicts, :meth:`settled_prefix`: none is
        waited for), with the folds, grazing points and loops found on them;
        ``counters`` replaces the retry counters (a branch handed out later than it was
        reached).

        A ``"running"`` branch (the one handed to ``on_point`` after every point) holds
        read-only views of arrays the recorder grows, ``O(1)`` per point amortised;
        any other status gets arrays of its own."""
        if upto is None:
            if self.settle is not None:
                self.settle()
        elif not 0 < upto <= self.settled_prefix():
            raise ValueError(f"upto = {upto}: points 1..{self.settled_prefix()} hold "
                             "their verdicts")
        counters = self.counters if counters is None else counters
        view = status == "running"
        n = len(self) if upto is None else upto
        arrays = {k: self._rows[k].stacked(self.lists[k], k in self.stat_names, view, n)
                  for k in (*POINT_FIELDS, *self.stat_names)}
        stats = {k: arrays.pop(k) for k in self.stat_names}
        folds, fold_index, grazing, loops = (
            (self.folds, self.fold_index, self.grazing, self.loops) if upto is None
            else self._events_on(n))
        return Branch(**self.meta, **arrays, stats=stats, element_names=self.element_names,
                      element_statistics=self.element_statistics,
                      loops=[tuple(lp) for lp in loops],
                      grazing=list(grazing), folds=list(folds),
                      fold_index=list(fold_index),
                      step_cuts=counters["step_cuts"],
                      secant_retries=counters["secant_retries"],
                      corner_steps=counters["corner_steps"],
                      reversals=counters["reversals"], leaps=counters["leaps"],
                      max_condition=counters["max_condition"] or float("nan"),
                      status=status, message=message, next_step=float(next_step))


class _Rows:
    """One per-point list of a :class:`Recorder` stacked into an array, grown by
    doubling as points are added. The rows kept all have the buffer's dtype and shape,
    so ``buf[:valid]`` is ``np.array`` of the list's first ``valid`` items, bitwise.
    Views of the first ``shared`` rows were handed out and are never written again: a row
    changed there (:meth:`invalidate`) moves the rows kept to a fresh buffer first. A
    list whose items differ in dtype or shape (a branch resumed from another run, IPP
    sequences of another length) is stacked whole at every call, as before."""

    __slots__ = ("buf", "valid", "shared")

    def __init__(self) -> None:
        self.buf: np.ndarray | None = None
        self.valid = 0
        self.shared = 0

    def invalidate(self, i: int) -> None:
        """Row ``i`` and the rows after it no longer hold the list's items."""
        self.valid = min(self.valid, i)

    def stacked(self, values: list, padded: bool, view: bool, upto: int | None = None
                ) -> np.ndarray:
        """The list (its first ``upto`` items) as one array: a read-only view of the
        buffer (``view``: only those rows count as handed out) or a copy. ``padded``:
        per-element statistics (:func:`_stacked`)."""
        n, m = len(values), self.valid
        k = n if upto is None else upto
        if n == 0:
            return np.zeros((0,))
        if n > m:
            new = [np.asarray(v) for v in values[m:]]
            buf = self.buf if m > 0 else None
            dtype, shape = (new[0].dtype, new[0].shape) if buf is None else \
                (buf.dtype, buf.shape[1:])
            if any(a.dtype != dtype or a.shape != shape for a in new):
                self.buf, self.valid, self.shared = None, 0, 0
                return (_stacked(values) if padded else np.array(values))[:k]
            if buf is None or n > buf.shape[0] or m < self.shared:
                # new, full, or rows handed out would change: the rows kept move
                grown = np.empty((max(16, 2 * n), *shape), dtype)
                if m:
                    grown[:m] = buf[:m]
                buf = self.buf = grown
                self.shared = 0
            buf[m:n] = new
            self.valid = n
        if not view:
            return self.buf[:k].copy()
        self.shared = max(self.shared, k)
        out = self.buf[:k]
        out.flags.writeable = False
        return out


def _stacked(values: list) -> np.ndarray:
    """The per-point arrays of a statistic as one array (n_points, n_elements, ...); IPP
    sequences of different lengths padded with -1."""
    if not values:
        return np.zeros((0,))
    shapes = {np.shape(v) for v in values}
    if len(shapes) > 1:                        # a branch resumed from another run
        width = max(s[-1] for s in shapes)
        values = [np.pad(v, [(0, 0)] * (np.ndim(v) - 1) + [(0, width - np.shape(v)[-1])],
                         constant_values=-1) for v in values]
    return np.array(values)


def note_condition(rec: Recorder, conds) -> None:
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
