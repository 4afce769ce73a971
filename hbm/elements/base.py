"""The contract of a nonlinear element of the harmonic balance.

A nonlinear element ``e`` acts along one direction ``g_e`` (n,) of the system's
coordinates: its deflection is ``Delta_e = g_e^T q`` and its force ``f_e(Delta_e, t)``
enters the equations of motion as ``g_e f_e`` (eq. 4, 14, one term per element):

    M q'' + C q' + K q + sum_e g_e f_e(g_e^T q, t) = f_ex(t).

Each element moves a linear stiffness ``k_bar_e`` into the linear operator,
``K' = K + sum_e k_bar_e g_e g_e^T`` (eq. 17), and the harmonic balance works with the
rest, ``f'_e = f_e - k_bar_e Delta_e``. Its parameters may vary in time with its own base
frequency, a rational multiple of the reference speed Omega (a gear mesh: Z Omega);
the basis samples them on its AFT grid (:meth:`Element.sample`).

What the engine asks of an element (:class:`Element`): its direction, ``k_bar_e``, its
base frequency ratio, the AFT samples of ``f'_e`` and of its derivative (with any
sub-sample correction of a non-smooth law, :class:`KinkCorrection`, and the homotopy
parameter ``law`` from a linear law, 0, to the element's own, 1), its force at one instant
for time integration, the per-step mean stiffness of the monodromy (T.10), its
statistics over one period, its named event test functions (:class:`EventTest`) and its
length scale. The design follows one class per element kind behind an abstract base and
a registry by kind (:mod:`hbm.elements.registry`), as pyHarm does for its elements and
NLvib's ``HB_residual`` sums the nonlinear elements of a list, each with its type and
direction.
"""
from __future__ import annotations

import dataclasses
from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, ClassVar

import numpy as np

__all__ = ["Element", "ElementStiffness", "EventTest", "KinkCorrection", "Statistic",
           "check_direction", "take_samples"]


@dataclass(frozen=True)
class Statistic:
    """A per-point statistic of an element kind: its name, unit and type; ``per_period``:
    one value per base period of the element over the fundamental period (an array);
    ``temporal``: it needs the samples in time order (impacts: a loss of contact followed
    by contact), so on a torus basis it is measured along the time line rather than over
    the torus grid (:func:`hbm.post.torus.torus_statistics`)."""

    name: str
    unit: str = ""
    integer: bool = False
    per_period: bool = False
    temporal: bool = False


@dataclass(frozen=True)
class EventTest:
    """A named event test function of an element kind: the statistic ``statistic`` whose
    sign change between two points of a branch is an event (a grazing, eq. 30), located
    by the continuation. ``name`` says where (a gear mesh: the flank, ``"active"`` or
    ``"reverse"``); the event is an ``"onset"`` when the value becomes positive if
    ``onset_positive``, when it stops being positive otherwise, else an ``"end"``."""

    name: str
    statistic: str
    onset_positive: bool


@dataclass(frozen=True)
class KinkCorrection:
    """Sub-sample correction of a sampled force and of its derivative.

    ``values`` (shaped like the samples) is added to the force samples; ``nodes`` are the
    first samples ``j`` (flat indices) of the intervals ``(j, j+1)`` (periodic) over
    which the law has a kink (a dead zone's ``+-b``); ``blocks[i]`` (2, 4) is the
    derivative of the corrections at samples ``(j, j+1)`` with respect to the deflection
    at ``(j-1, j, j+1, j+2)`` (N/m). See :func:`hbm.elements.contact_law.kink_correction`
    (T.13a). On a torus grid (samples of shape ``(N_1, ..., N_d)``) the intervals run
    along the last axis, periodic within each row of ``period = N_d`` samples (0: the
    whole grid is one row, a period of one fundamental).
    """

    values: np.ndarray
    nodes: np.ndarray
    blocks: np.ndarray
    period: int = 0

    def columns(self, n: int) -> np.ndarray:
        """Sample indices ``(j-1, j, j+1, j+2)`` of each block, (m, 4) (flat, on a grid of
        ``n`` samples)."""
        length = self.period or n
        col = self.nodes % length
        return (self.nodes - col)[:, None] + (col[:, None] + np.arange(-1, 3)[None, :]) % length

    def successors(self, n: int) -> np.ndarray:
        """Flat indices of the samples ``j + 1`` after the nodes (periodic in their row)."""
        length = self.period or n
        col = self.nodes % length
        return self.nodes - col + (col + 1) % length

    def apply(self, x: np.ndarray) -> np.ndarray:
        """The derivative times samples ``x`` (N/m times m)."""
        xf = x.reshape(-1)
        cols, succ = self._indices(xf.size)
        xc = xf[cols]                                              # (m, 4)
        y = np.zeros_like(xf)
        # the nodes are distinct, and so are their successors: no repeated index per call
        y[self.nodes] += np.einsum("mc,mc->m", self.blocks[:, 0], xc)
        y[succ] += np.einsum("mc,mc->m", self.blocks[:, 1], xc)
        return y.reshape(x.shape)

    def _indices(self, n: int) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`columns` and the successors of the nodes on a grid of ``n`` (kept: a
        GMRES solve applies the same correction tens of times)."""
        cached = self.__dict__.get("_indices_cache")
        if cached is None or cached[0] != n:
            cached = (n, self.columns(n), self.successors(n))
            object.__setattr__(self, "_indices_cache", cached)
        return cached[1], cached[2]

    def scaled(self, factor: float) -> KinkCorrection:
        """The correction times ``factor`` (the contact-law homotopy)."""
        return KinkCorrection(factor * self.values, self.nodes, factor * self.blocks,
                              self.period)

    @classmethod
    def none(cls, shape) -> KinkCorrection:
        """No correction on a grid of ``shape`` samples (an int: one period of them)."""
        return cls(np.zeros(shape), np.zeros(0, dtype=int), np.zeros((0, 2, 4)))


@dataclass(frozen=True)
class ElementStiffness:
    """``d f'_e / d Delta_e`` on the AFT grid: the samples (N/m) and the blocks of the
    sub-sample correction (:class:`KinkCorrection`)."""

    samples: np.ndarray
    kinks: KinkCorrection

    def apply(self, x: np.ndarray) -> np.ndarray:
        """The derivative times the samples ``x`` of a variation of Delta."""
        y = self.samples * x
        if self.kinks.nodes.size:
            y = y + self.kinks.apply(x)
        return y


def take_samples(samples, index):
    """The samples at ``index`` of an element's parameters on a grid (what
    :meth:`Element.sample` returned: None, or a dataclass of arrays over the samples)."""
    if samples is None:
        return None
    return dataclasses.replace(samples, **{f.name: getattr(samples, f.name)[index]
                                           for f in dataclasses.fields(samples)})


def check_direction(name: str, direction) -> np.ndarray:
    """The direction ``g_e`` as a finite, non-zero float vector (refused otherwise)."""
    g = np.atleast_1d(np.asarray(direction, dtype=float)).ravel()
    if g.size == 0 or not np.all(np.isfinite(g)):
        raise ValueError(f"{name}.direction: must be a non-empty finite vector (n,)")
    if not np.any(g != 0.0):
        raise ValueError(f"{name}.direction: all zero; the element must act on at least one "
                         "coordinate")
    return g


class Element(ABC):
    """A nonlinear element acting along ``direction`` (see the module).

    Subclasses are frozen dataclasses whose first field is ``direction`` (n,) and which
    have a ``name``; they declare their ``kind`` (the registry key), the
    ``statistics`` they measure and their event ``tests``, and register themselves
    (:func:`hbm.elements.registry.register`).

    ``samples`` below is what :meth:`sample` returned for the grid in question (the
    element's parameters there, e.g. a mesh's stiffness and transmission error); ``delta``
    the deflection ``Delta_e`` (m) on the same grid.
    """

    kind: ClassVar[str] = ""
    statistics: ClassVar[tuple[Statistic, ...]] = ()
    tests: ClassVar[tuple[EventTest, ...]] = ()
    direction: np.ndarray
    name: str

    # ------------------------------------------------------------------ linear part
    @property
    @abstractmethod
    def linear_stiffness(self) -> float:
        """``k_bar_e`` (N/m) moved into the linear operator (eq. 17)."""

    # ------------------------------------------------------------------ time
    @property
    def base_ratio(self) -> Fraction | None:
        """The frequency of the element's parameters as a ratio of Omega (exact), or None
        when they do not vary in time."""
        return None

    @property
    def parameter_harmonics(self) -> tuple[int, ...]:
        """Harmonics of the base frequency present in the parameters (0: the mean)."""
        return ()

    @property
    def sub_periods(self) -> int:
        """Periods its statistics count in per base period (a gear mesh whose parameters
        repeat every ``cycles`` mesh periods: ``cycles``); the statistics grid holds a
        whole number of samples in each. Default 1."""
        return 1

    @abstractmethod
    def sample(self, phase: np.ndarray) -> Any:
        """The parameters at the base phases ``phase`` (rad) (``base_ratio Omega t``):
        None, or a dataclass of arrays shaped like ``phase`` (:func:`take_samples`)."""

    # ------------------------------------------------------------------ force
    @abstractmethod
    def force(self, delta: np.ndarray, samples, law: float = 1.0, corrected: bool = True,
              stiffness: bool = True) -> tuple[np.ndarray, ElementStiffness | None]:
        """AFT samples of ``f'_e = f_e - k_bar_e Delta_e`` (N) and, if ``stiffness``, of its
        derivative. ``law``: homotopy from the element's linear law (0) to its own (1);
        ``corrected``: with the sub-sample correction of a non-smooth law (T.13a)."""

    @abstractmethod
    def load(self, delta: np.ndarray, samples, corrected: bool = False) -> np.ndarray:
        """The force ``f_e`` (N) at the samples; ``corrected``: plus the sub-sample
        correction of the AFT (what the harmonic balance integrates)."""

    @abstractmethod
    def load_stiffness(self, delta: np.ndarray, samples) -> np.ndarray:
        """``d f_e / d Delta_e`` (N/m) at the samples (e.g. the Jacobian of a time
        integration)."""

    @abstractmethod
    def time_force(self) -> Callable[[float, float], float]:
        """``f(delta, phase)``: the force ``f_e`` (N) at one instant of base phase ``phase``
        (rad), for the right-hand side of a time integration (scalar arithmetic)."""

    @abstractmethod
    def step_stiffness(self, delta: np.ndarray, samples) -> np.ndarray:
        """Mean of ``d f'_e / d Delta_e`` over each step between consecutive samples of
        one period (periodic), for the monodromy of (T.10)."""

    # ------------------------------------------------------------------ measures
    @abstractmethod
    def measure(self, delta: np.ndarray, samples, periods: int) -> dict[str, Any]:
        """The :attr:`statistics` of the element over one fundamental period sampled
        evenly, holding ``periods`` base periods."""

    def signals(self, delta: np.ndarray, samples) -> dict[str, np.ndarray]:
        """Named time signals beside ``Delta_e`` and the force (e.g. contact thresholds)."""
        return {}

    @abstractmethod
    def scale(self, samples) -> float:
        """The element's own length scale (m) on the samples of one period (e.g. a
        backlash), for the scaling of the unknowns; 0 when it has none."""

    def static_scale(self, samples, n: int) -> np.ndarray:
        """Per sample of a grid of ``n``, a deflection (m) of the order of the static
        equilibrium's, to bracket it (default: :meth:`scale` everywhere)."""
        return np.full(n, self.scale(samples))

    def statistic_names(self) -> tuple[str, ...]:
        """Names of :attr:`statistics`."""
        return tuple(s.name for s in self.statistics)
