"""The problem's equations integrated in time: what the machine does where the periodic
orbit is unstable (docs/hbm.md "Time integration").

The equations are those the harmonic balance solves (eq. 4, 13-14),
``M q'' + C q' + K q + sum_e g_e f_e(g_e^T q, t) = f_ex(t)`` with every element, in the
coupled modes of eq. (17): with ``K' = K + sum_e k_bar_e g_e g_e^T`` and the modal
damping of eq. (18-19) the linear part is diagonal and the right-hand side costs O(n)
per element per evaluation; all modes are kept, so the change of basis is exact.
``solve_ivp`` (DOP853) integrates them over whole shaft turns from the state of an HBM
point; :func:`integrate` leaves out a transient and analyses a window for one element
(a gear mesh): the load std of every turn and the strongest lines of its spectrum.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
from scipy.integrate import solve_ivp

from ..problem import HBMProblem, Point
from ..units import RPM_TO_RAD_S
from .poincare import Section, classify_section, section_coordinates, windowed_lines
from .stats import MeshPeriodEnvelope

logger = logging.getLogger(__name__)

__all__ = ["ModalModel", "TimeResponse", "element_load", "equations", "fundamentals_per_turn",
           "initial_state", "integrate", "modal_model", "periods_per_turn", "perturbed",
           "state_atol"]

#: Samples per mesh period of the analysed turns.
SAMPLES_PER_MESH_PERIOD = 64


@dataclass
class ModalModel:
    """The HBM problem's equations at one speed, in the coupled modes of eq. (17).

    ``eta'' + D eta' + diag(w2) eta + sum_e gamma_e (f_e(Delta_e, t) - k_bar_e Delta_e)
    = p(t)``, ``Delta_e = gamma_e . eta``, ``p(t) = Re sum_k P_k exp(i kw_k t)``.
    """

    phi: np.ndarray          # (n, m) mass-normalised modes
    w2: np.ndarray           # (m,) rad²/s²
    damp: np.ndarray         # (m,) modal damping 2 xi w (1/s), or (m, m) if not modal
    gamma: np.ndarray        # (E, m) Phi^T g_e
    forcing: np.ndarray      # (nS, m) complex modal forcing P_k (N/kg^1/2)
    kw: np.ndarray           # (nS,) angular frequencies k w0 (rad/s)
    kbar: np.ndarray         # (E,) k_bar_e (N/m)
    elements: tuple          # the problem's elements: f_e(Delta, t)
    rates: tuple             # (E,) base phase rates base_ratio Omega (rad/s), 0 if none
    period: float            # fundamental period 2 pi / w0 (s)

    @property
    def n_modes(self) -> int:
        return self.w2.size


def _rate(el, omega: float) -> float:
    """Base phase rate ``base_ratio * Omega`` of an element (rad/s; 0 if time-invariant)."""
    r = el.base_ratio
    if r is None:
        return 0.0
    return r.numerator * omega if r.denominator == 1 else float(r) * omega


def modal_model(problem: HBMProblem, rpm: float) -> ModalModel:
    """The equations of ``problem`` at ``rpm`` in modal form.

    Modes of ``(K + sum k_bar_e g_e g_e^T, M)`` (eq. 17), mass-normalised. If
    ``Phi^T C Phi`` is diagonal to 1e-9 (the modal damping of eq. 18-19) only its diagonal
    is kept.

    Raises
    ------
    ValueError
        If ``rpm`` is not > 0, or a rigid mode of ``K'`` is loaded.
    """
    problem.require_periodic("time_response.modal_model")
    if not np.isfinite(rpm) or rpm <= 0:
        raise ValueError(f"rpm = {rpm!r}: must be > 0")
    s = problem.system
    omega = rpm * RPM_TO_RAD_S
    w0 = problem.harmonics.fundamental_rad_s(omega)
    w2, phi = sla.eigh(problem.Kp, s.M)
    forcing = (problem.Fc + omega ** 2 * problem.Fu) @ phi          # (nS, m)
    rigid = w2 < 1e-9 * np.max(np.abs(w2))
    if np.any(rigid):
        gam = [phi[:, rigid].T @ g for g in problem.directions]
        if np.any(np.abs(forcing[:, rigid]) > 0) or any(np.any(np.abs(x) > 0) for x in gam):
            raise ValueError("problem: a rigid mode of K + sum k_bar g g^T is loaded "
                             "(no periodic steady state)")
        phi, w2, forcing = phi[:, ~rigid], w2[~rigid], forcing[:, ~rigid]
    cm = phi.T @ s.C @ phi
    off = cm - np.diag(np.diag(cm))
    damp = np.diag(cm).copy() if np.max(np.abs(off)) <= 1e-9 * max(np.max(np.abs(cm)), 1e-300) \
        else cm
    return ModalModel(phi=phi, w2=w2, damp=damp,
                      gamma=np.stack([phi.T @ g for g in problem.directions]),
                      forcing=forcing, kw=problem.kS * w0, kbar=problem.kbar,
                      elements=problem.elements,
                      rates=tuple(_rate(el, omega) for el in problem.elements),
                      period=2 * np.pi / w0)


def element_load(mm: ModalModel, delta: np.ndarray, t: np.ndarray, element: int = 0
                 ) -> np.ndarray:
    """Force ``f_e`` (N) of element ``element`` (a gear mesh: the dead zone of eq. 13)
    at times ``t`` (s)."""
    el = mm.elements[element]
    return el.load(delta, el.sample(mm.rates[element] * t))


def equations(mm: ModalModel) -> Callable[[float, np.ndarray], np.ndarray]:
    """Right-hand side ``y' = f(t, y)`` of the modal state ``y = (eta, eta')``."""
    m = mm.n_modes
    w2, damp, P, kw = mm.w2, mm.damp, mm.forcing, mm.kw
    loaded_rows = np.any(P != 0, axis=1)     # only the forced harmonics: exact, and the
    P, kw = P[loaded_rows], kw[loaded_rows]  # shaft-order sets hold hundreds of unforced ones
    modal = damp.ndim == 1
    terms = [(g, el.time_force(), rate, kb) for g, el, rate, kb in
             zip(mm.gamma, mm.elements, mm.rates, mm.kbar, strict=True)]

    def fun(t: float, y: np.ndarray) -> np.ndarray:
        eta, vel = y[:m], y[m:]
        ext = (np.exp(1j * kw * t) @ P).real
        acc = ext - (damp * vel if modal else damp @ vel) - w2 * eta
        for gam, force, rate, kbar in terms:
            delta = gam @ eta
            acc = acc - gam * (force(delta, rate * t) - kbar * delta)
        return np.concatenate([vel, acc])
    return fun


def initial_state(problem: HBMProblem, point: Point, mm: ModalModel) -> np.ndarray:
    """Modal state ``(eta, eta')`` at t = 0 of an HBM point (on its orbit)."""
    q = problem.recover(point)                            # (n, nS) complex
    x0 = q.real.sum(axis=1)
    v0 = (1j * mm.kw * q).real.sum(axis=1)
    proj = mm.phi.T @ problem.system.M
    return np.concatenate([proj @ x0, proj @ v0])


def state_atol(mm: ModalModel, y0: np.ndarray, rtol: float) -> np.ndarray:
    """Absolute tolerances of ``solve_ivp``: ``rtol`` times the largest modal amplitude
    of ``y0`` per block (velocities at least that of the positions times w0)."""
    m = mm.n_modes
    scale_x = max(np.max(np.abs(y0[:m])), 1e-300)
    scale_v = max(np.max(np.abs(y0[m:])), scale_x * 2 * np.pi / mm.period)
    return np.concatenate([np.full(m, rtol * scale_x), np.full(m, rtol * scale_v)])


def perturbed(y: np.ndarray, m: int, size: float, seed: int = 0) -> np.ndarray:
    """The modal state ``y`` plus a disturbance in every mode: a fixed pseudo-random
    direction (``seed``) scaled to ``size`` times the largest amplitude of each block
    (positions, velocities), so that it reaches every unstable direction and the run is
    repeatable."""
    d = np.random.default_rng(seed).standard_normal(y.size)
    out = np.array(y, dtype=float)
    for blk in (slice(0, m), slice(m, 2 * m)):
        scale = max(float(np.max(np.abs(out[blk]))), 1e-300)
        out[blk] += size * scale * d[blk] / max(float(np.max(np.abs(d[blk]))), 1e-300)
    return out


@dataclass
class TimeResponse:
    """A time integration over ``transient + window`` shaft turns (:func:`integrate`).

    ``lines`` are the strongest lines of the window's mesh-load spectrum as (shaft
    order, amplitude N), resolution ``1 / window`` orders. The response repeats itself
    every turn (``periodic``) when the std of the window's turns (two or more) agree to
    1e-3 and its strongest line lies on an integer order; otherwise it is
    quasi-periodic, or longer than a turn, or has not settled.
    """

    rpm: float
    transient: int
    window: int
    std_per_turn: np.ndarray         # (transient + window,) mesh-load std of each turn (N)
    std: float                       # mesh-load std over the window (N)
    max_load: float                  # largest mesh load over the window (N)
    lines: list[tuple[float, float]]
    seconds: float
    state: np.ndarray = field(repr=False)   # modal state at the end
    delta: np.ndarray = field(repr=False)   # Delta (m) over the last turn, from its start
    #: largest mesh load and mean Delta in each mesh period of the window (Z x window)
    envelope: MeshPeriodEnvelope | None = field(default=None, repr=False)
    #: load (N) at the start of every fundamental period of the window: the Poincaré
    #: section of :mod:`hbm.post.poincare` (None when a turn's samples do not fall on
    #: every fundamental period's start)
    section: np.ndarray | None = field(default=None, repr=False)
    #: Delta (m) at the same instants (the smooth coordinate of the section: the load
    #: is zero whenever contact is lost, whatever the motion)
    section_delta: np.ndarray | None = field(default=None, repr=False)
    #: std of Delta over the window (m)
    delta_std: float = 0.0
    #: load (N) over the window, ``samples_per_turn`` per shaft turn
    load: np.ndarray | None = field(default=None, repr=False)
    samples_per_turn: int = 0

    @property
    def window_std_per_turn(self) -> np.ndarray:
        """Mesh-load std of each analysed turn (N)."""
        return self.std_per_turn[self.transient:]

    @property
    def periodic(self) -> bool | None:
        """Whether the response repeats itself every turn; None with one turn analysed."""
        if self.window < 2:
            return None
        s = self.window_std_per_turn
        spread = (s.max() - s.min()) / max(s.max(), 1e-300)
        order = self.lines[0][0] if self.lines else 0.0
        return bool(spread < 1e-3 and abs(order - round(order)) < 0.5 / self.window)

    def windowed_lines(self, n_lines: int = 12) -> list[tuple[float, float]]:
        """The window's strongest mesh-load lines as (shaft order, amplitude N), Hann
        window and band power (:func:`hbm.post.poincare.windowed_lines`: amplitudes
        that do not depend on where a line falls between the 1/window bins)."""
        if self.load is None:
            return []
        return windowed_lines(self.load, self.samples_per_turn, n_lines)

    @property
    def poincare(self) -> Section | None:
        """The window's Poincaré section classified
        (:func:`hbm.post.poincare.classify_section` of (Delta, load), each relative to its
        std over the window), None without a section."""
        if self.section is None or self.section.size < 2:
            return None
        return classify_section(section_coordinates(self.section_delta, self.delta_std,
                                                    self.section, self.std), 1.0)


def fundamentals_per_turn(problem: HBMProblem) -> int:
    """Fundamental periods of the harmonic set in one turn of the reference shaft: 1
    (shaft fundamental) or Z (mesh fundamental); refused for a fundamental below the
    shaft's (a turn is not a whole number of fundamental periods)."""
    r = problem.harmonics.ratio
    if r.denominator != 1:
        raise ValueError(f"time response: the fundamental {r} Omega is not a whole number "
                         "of periods per shaft turn")
    return r.numerator


def periods_per_turn(problem: HBMProblem, element: int) -> int:
    """Base periods of element ``element`` in one turn of the reference shaft (a gear
    mesh on that shaft: Z; a time-invariant element: 1)."""
    r = problem.elements[element].base_ratio
    if r is None:
        return 1
    if r.denominator != 1:
        raise ValueError(f"time response: {problem.labels[element]} has {r} base periods "
                         "per shaft turn; a whole number is needed")
    return r.numerator


def _turn(problem: HBMProblem, mm: ModalModel, element: int) -> tuple[float, np.ndarray]:
    """Duration of a shaft turn (s) and its sample times (Z x SAMPLES_PER_MESH_PERIOD)."""
    T = fundamentals_per_turn(problem) * mm.period
    n = periods_per_turn(problem, element) * SAMPLES_PER_MESH_PERIOD
    return T, T * np.arange(n) / n


def integrate(problem: HBMProblem, rpm: float, start: Point | np.ndarray,
              transient: int = 30, window: int = 16, rtol: float = 1e-9,
              n_lines: int = 12, element: int = 0, perturbation: float = 0.0
              ) -> TimeResponse:
    """Integrate the equations at ``rpm`` over whole shaft turns (every element), and
    analyse the load of element ``element``.

    Parameters
    ----------
    problem
        The HBM problem.
    rpm
        Speed (> 0).
    start
        An HBM point (its orbit at t = 0 is the start) or a modal state ``(eta, eta')``
        (:attr:`TimeResponse.state` of another speed: a run-up).
    transient, window
        Shaft turns left out (>= 0) and analysed (>= 1).
    rtol
        Relative tolerance of DOP853; the absolute one is ``rtol`` times the largest
        modal amplitude of the start per block.
    n_lines
        Spectral lines kept.
    perturbation
        Relative size of a disturbance added to the start (:func:`perturbed`; 0: none,
        the start as given). Started exactly on an unstable orbit, the response leaves
        it only through the orbit's own error; a disturbance of known size makes the
        transient needed, ``ln(1 / perturbation) / growth rate``, independent of it.

    Raises
    ------
    ValueError
        On a negative ``transient``, ``window`` < 1, ``rtol`` outside (0, 1), ``rpm``
        not > 0, ``perturbation`` outside [0, 1) or a modal state of the wrong shape.
    RuntimeError
        If ``solve_ivp`` fails.
    """
    if transient < 0 or window < 1:
        raise ValueError(f"transient = {transient}, window = {window}: must be >= 0 and >= 1")
    if not 0 < rtol < 1:
        raise ValueError(f"rtol = {rtol!r}: must be in (0, 1)")
    if not 0 <= perturbation < 1:
        raise ValueError(f"perturbation = {perturbation!r}: must be in [0, 1)")
    mm = modal_model(problem, rpm)
    T, te = _turn(problem, mm, element)
    y = initial_state(problem, start, mm) if isinstance(start, Point) else \
        np.array(start, dtype=float)
    if y.shape != (2 * mm.n_modes,):
        raise ValueError(f"start: modal state of shape {y.shape}, the problem has "
                         f"{2 * mm.n_modes} (positions and velocities of {mm.n_modes} modes)")
    if perturbation > 0:
        y = perturbed(y, mm.n_modes, perturbation)
    fun, atol, m = equations(mm), state_atol(mm, y, rtol), mm.n_modes
    stds, loads, deltas, delta = [], [], [], np.zeros(te.size)
    t0 = time.perf_counter()
    for k in range(transient + window):
        sol = solve_ivp(fun, (0.0, T), y, method="DOP853", rtol=rtol, atol=atol,
                        t_eval=np.append(te, T))
        if not sol.success:
            raise RuntimeError(f"{rpm:.6g} rpm: solve_ivp failed after {k} turns: "
                               f"{sol.message}")
        y = sol.y[:, -1]
        delta = mm.gamma[element] @ sol.y[:m, :-1]
        load = element_load(mm, delta, te, element)
        stds.append(float(load.std()))
        if k >= transient:
            loads.append(load)
            deltas.append(delta)
    sig = np.concatenate(loads)
    fpt = fundamentals_per_turn(problem)
    every = te.size // fpt if te.size % fpt == 0 else 0
    dsig = np.concatenate(deltas)
    spec = np.abs(np.fft.rfft(sig - sig.mean())) / sig.size * 2
    top = np.argsort(-spec)[:n_lines]
    out = TimeResponse(rpm=rpm, transient=transient, window=window,
                       std_per_turn=np.array(stds), std=float(sig.std()),
                       max_load=float(sig.max()),
                       lines=[(float(j / window), float(spec[j])) for j in top],
                       seconds=time.perf_counter() - t0, state=y, delta=delta,
                       envelope=MeshPeriodEnvelope.of(
                           sig, dsig,
                           periods_per_turn(problem, element) * window),
                       section=sig[::every].copy() if every else None,
                       section_delta=dsig[::every].copy() if every else None,
                       delta_std=float(dsig.std()), load=sig, samples_per_turn=te.size)
    logger.info("time integration at %.6g rpm: %d + %d turns in %.1f s, std %.4g N "
                "(periodic over a turn: %s)", rpm, transient, window, out.seconds, out.std,
                out.periodic)
    return out
