"""Speed sweeps of an HBM problem: the continuation (:mod:`hbm.continuation`, which knows
only a residual and its tangent) given the problem and the monitor that measures its
points (:class:`PointMonitor`: every element's statistics, the events of its test
functions, the stability of every point in-line or in a worker process)."""

from __future__ import annotations

import logging
from collections import deque
from collections.abc import Callable
from typing import Any

import numpy as np

from .continuation import Branch, EventFunction, Measurement, continue_branch
from .continuation.tracer import RETRY_STEPS
from .post.stats import element_statistics
from .problem import HBMProblem
from .stability.process import StabilityProcess, wanted, warm_stride
from .stability.verdict import Verdict
from .stability.verdict import stability as point_stability

logger = logging.getLogger(__name__)

__all__ = ["PointMonitor", "trace"]


class PointMonitor:
    """Measures the converged points of an HBM problem's branch
    (:class:`hbm.continuation.protocol.Monitor`).

    Per point: every element's statistics (:meth:`hbm.elements.Element.measure`) and
    the complex coefficients of its deflection, into the branch's per-element table
    (each ``(n_elements, ...)``; a statistic an element kind does not have is NaN, or -1
    for an integer; per-period sequences padded with -1); the stability
    (:func:`hbm.stability.stability`), warm-started from the point measured
    :func:`~hbm.stability.process.warm_stride` points before (the previous one, or two
    before for a matrix-free problem), with the fold parity from the tangent when the
    Newton matrices are matrix-free (T.9a, docs/theory.md). With worker processes
    (:mod:`hbm.stability.process`, as many as the stride, started by :meth:`start`) the
    stability is measured there with the same warm starts, bitwise the same values, and
    collected by :meth:`collect`.

    The event test functions are every element's :attr:`~hbm.elements.Element.tests`,
    scaled by the element's length scale.
    """

    def __init__(self, problem: HBMProblem, stability: bool = True,
                 process: bool | None = None) -> None:
        if stability and not problem.periodic:
            raise ValueError(
                "stability = True: Floquet theory is for periodic responses; on a torus of "
                f"{problem.harmonics.dimension} base frequencies the response is "
                "quasi-periodic and its stability (Lyapunov exponents of the torus) is not "
                "computed: trace with stability=False (folds are still located; each point "
                "is written stable=False, floquet_max_real=NaN, floquet_kind=-1: not "
                "computed)")
        self.problem = problem
        self.stability = stability
        self._process = wanted(problem, stability, process)
        self.worker: StabilityProcess | None = None
        self.stride = warm_stride(problem)
        self.bases: deque = deque(maxlen=self.stride)   # of the last points measured
        # matrix-free: det T(0) (T.9) from the tangent, sign det J = sign det J_0 when the
        # speed component keeps the sign it had at the first point (T.9a, docs/theory.md)
        self.parity_ref: list = []
        self.submitted = 0
        self.events = tuple(
            EventFunction(e, t.name, t.statistic, t.onset_positive,
                          float(problem.length_scales[e]))
            for e, el in enumerate(problem.elements) for t in el.tests)
        specs: dict[str, Any] = {}
        for el in problem.elements:
            for st in el.statistics:
                specs.setdefault(st.name, st)
        self._specs = specs
        self.statistics = (*specs, "coefficients")

    # ------------------------------------------------------------------ the protocol
    @property
    def asynchronous(self) -> bool:
        return self.worker is not None

    def branch_meta(self) -> dict[str, Any]:
        pb = self.problem
        return {"harmonics": tuple(pb.harmonics.indices), "condensation": pb.condensation,
                "element_names": tuple(el.name for el in pb.elements),
                "statistics": self.statistics,
                "element_statistics": tuple(el.statistic_names() for el in pb.elements)}

    def start(self) -> None:
        if self._process and self.worker is None:
            self.worker = StabilityProcess(self.problem, workers=self.stride)

    def stop(self) -> None:
        if self.worker is not None:
            self.worker.close()
            self.worker = None

    def auxiliary(self) -> PointMonitor:
        return PointMonitor(self.problem, stability=False)

    def measure(self, unknowns: np.ndarray, omega: float, iterations: int, residual: float,
                tangent: np.ndarray) -> Measurement:
        problem = self.problem
        pt = problem.point(unknowns, omega, iterations, residual)
        stats = self.table(element_statistics(problem, unknowns), pt.coefficients)
        if self.stability and self.worker is not None:
            ticket = self.submitted
            self.submitted += 1
            self.worker.submit(ticket, unknowns, omega, iterations, residual,
                               self.parity(pt, tangent))
            return Measurement(False, float("nan"), 0, True, stats, ticket)
        if self.stability:
            start = self.bases[0] if len(self.bases) == self.stride else None
            stab = point_stability(problem, pt, start=start,
                                   parity=self.parity(pt, tangent))
            self.bases.append(stab.basis)
            v = Verdict.of(stab)
            return Measurement(v.stable, v.max_real, v.code, v.consistent, stats,
                               amplification=v.amplification, grazing=v.grazing)
        if not problem.periodic:           # not computed (see __init__)
            return Measurement(False, float("nan"), -1, True, stats)
        # not computed: listed stable (documented), no exponent written
        return Measurement(True, float("nan"), 0, True, stats)

    def test_value(self, index: int, unknowns: np.ndarray) -> float:
        ev = self.events[index]
        pb = self.problem
        if not pb.periodic:
            return element_statistics(pb, unknowns)[ev.element][ev.statistic]
        synth, samples = pb.fine_grid(pb.fine_periods())
        delta = (synth @ pb.delta_real(unknowns))[ev.element]
        el = pb.elements[ev.element]
        return el.measure(delta, samples[ev.element], pb.steps[ev.element] or 1)[ev.statistic]

    @property
    def pending(self) -> int:
        return 0 if self.worker is None else self.worker.pending

    def collect(self, wait: bool, keep: int = 0) -> list[tuple[Any, dict[str, Any]]]:
        if self.worker is None:
            return []
        return [(ticket, {"stable": v.stable, "floquet_max_real": v.max_real,
                          "floquet_kind": v.code, "stability_consistent": v.consistent,
                          "floquet_amplification": v.amplification,
                          "stability_grazing": v.grazing})
                for ticket, v in self.worker.collect(wait, keep)]

    # ------------------------------------------------------------------ helpers
    def parity(self, pt, tangent: np.ndarray) -> bool | None:
        """``det T(0) < 0`` from the tangent (matrix-free, modal), else None (computed)."""
        problem = self.problem
        if not (self.stability and problem.matrix_free and problem.modal):
            return None
        if not self.parity_ref:
            first = point_stability(problem, pt).fold_parity
            self.parity_ref.extend([first, tangent[-1] > 0])
        return self.parity_ref[0] != ((tangent[-1] > 0) != self.parity_ref[1])

    def table(self, per_element: list[dict[str, Any]], coefficients: np.ndarray
              ) -> dict[str, np.ndarray]:
        """The point's row of the per-element table: each statistic over the elements."""
        out = {}
        for name, spec in self._specs.items():
            fill = -1 if spec.integer else float("nan")
            values = [d.get(name, fill) for d in per_element]
            if spec.per_period:
                values = [np.atleast_1d(v) for v in values]
                width = max(v.size for v in values)
                values = [np.pad(v, (0, width - v.size), constant_values=-1)
                          if v.size < width else v for v in values]
            out[name] = np.array(values)
        out["coefficients"] = coefficients
        return out


def trace(problem: HBMProblem, rpm_start: float, rpm_end: float, *, step: float = 0.01,
          min_step: float = 1e-6, max_step: float = 0.05, tol: float = 1e-8,
          max_points: int = 2000, max_iter: int = 12,
          on_point: Callable[[Branch], None] | None = None, resume: Branch | None = None,
          stability: bool | None = None, overshoot: float = 0.25,
          grazing_tol_rpm: float | None = None, start_fallback: bool = True,
          stability_process: bool | None = None,
          retry_steps: tuple[float, ...] = RETRY_STEPS,
          start: np.ndarray | None = None) -> Branch:
    """Follow the periodic solutions of ``problem`` from ``rpm_start`` to ``rpm_end``
    (:func:`hbm.continuation.continue_branch` with a :class:`PointMonitor`).

    Parameters
    ----------
    problem
        The HBM problem.
    stability
        Compute the stability of every point (:func:`hbm.stability.stability`). None (the
        default): on a periodic basis yes, on a torus basis no (refused when True there:
        Floquet theory does not apply to a quasi-periodic response; the points are then
        written ``stable=False``, ``floquet_max_real=NaN``, ``floquet_kind=-1``).
    stability_process
        Measure the stability in a second process while the corrector looks for
        the next point (:mod:`hbm.stability.process`; bitwise the same verdicts).
        None: when ``stability`` is on, the Newton matrices are matrix-free (large
        harmonic sets), the machine has more than one core and ``fork`` exists.
        ``on_point`` is then called for each point once the next one is corrected.
    rpm_start, rpm_end, step, min_step, max_step, tol, max_points, max_iter, on_point, \
resume, overshoot, grazing_tol_rpm, start_fallback, retry_steps, start
        As :func:`hbm.continuation.continue_branch` (``start``: unknowns of the problem;
        without it Newton starts from the linear response).

    Returns
    -------
    Branch
        Never holds an unconverged point; ``status``/``message`` say why it stopped.
    """
    if stability is None:
        stability = problem.periodic
    return continue_branch(problem, PointMonitor(problem, stability, stability_process),
                           rpm_start, rpm_end, step=step, min_step=min_step,
                           max_step=max_step, tol=tol, max_points=max_points,
                           max_iter=max_iter, on_point=on_point, resume=resume,
                           overshoot=overshoot, grazing_tol_rpm=grazing_tol_rpm,
                           start_fallback=start_fallback, retry_steps=retry_steps,
                           start=start)
