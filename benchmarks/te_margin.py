"""Contact margin of the permanent-contact (linear) solution as an affine function of the
transmission-error harmonics: a screen for TE shapes against the paper's grazing speeds.

In permanent contact the mesh force is ``k_m (p - b)`` with ``p = Delta - e`` (eq. 13),
and with a loaded STE ``e = q_s - F_s/k_m`` (eq. 12), so the linear periodic solution
``Delta`` is affine in the complex TE harmonics ``c_k = a_k exp(i phi_k)``:

    p(t) - b = P_0(t) + sum_k (Re c_k P_k^re(t) + Im c_k P_k^im(t))
               - Re sum_k c_k exp(i k Z Omega t)

``P_0`` is the response (external loads, mean STE, stiffness harmonics) with no TE
harmonics, ``P_k^re, P_k^im`` the response to ``c_k = 1, i`` (per metre). A grazing of
the nonlinear branch is a point where the branch passes between permanent contact and
impacts: there the solution *is* the linear one and its margin ``min_t (p - b)`` is
zero. The grazing speeds of a curve are therefore zeros of the linear margin
``m(rpm) = min_t (p - b)`` — all of them where the branch visits the linear solution;
a window of the linear solution inside a folded impact region may be skipped by the
branch, and the resonance peaks (softening) are not seen here. Candidates found on the
screen are checked with the nonlinear runs of :mod:`benchmarks.calibrate_pump`.

One linear solve per speed and basis vector (:func:`hbm.fixed_speed.initial_guess`,
``law = 0``); the time signals are kept, so a candidate costs one weighted sum.
"""
from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.optimize import OptimizeResult, minimize

from hbm import impacts_per_mesh_period

log = logging.getLogger("te_margin")

#: Unit TE harmonic of the basis (m); the response is linear, any value gives the same.
UNIT = 1e-7


@dataclass
class MarginBasis:
    """Time signals of ``p - b`` (m) of the linear solution, per speed.

    Attributes
    ----------
    rpm
        Speeds (rpm), (n_speed,).
    p0
        ``p - b`` with no TE harmonics, (n_speed, n_time).
    dp
        Response of ``Delta`` to ``c_k = 1`` and ``c_k = i`` (per metre of TE),
        (n_te, 2, n_speed, n_time).
    mesh_phase
        Mesh phase ``Z Omega t`` of the samples (rad), (n_time,).
    mesh_step
        Mesh periods in the fundamental period of the samples.
    """

    rpm: np.ndarray
    p0: np.ndarray
    dp: np.ndarray
    mesh_phase: np.ndarray
    mesh_step: int = 1

    def te_signal(self, amps_m: np.ndarray, phases_rad: np.ndarray) -> np.ndarray:
        """``Re sum_k c_k exp(i k Z Omega t)`` (m) on the samples."""
        k = np.arange(1, len(amps_m) + 1)
        c = np.asarray(amps_m) * np.exp(1j * np.asarray(phases_rad))
        return (c[:, None] * np.exp(1j * k[:, None] * self.mesh_phase[None, :])).real.sum(0)

    def signals(self, amps_m, phases_rad) -> np.ndarray:
        """``p - b`` (m) of the linear solution, (n_speed, n_time)."""
        c = np.asarray(amps_m, dtype=float) * np.exp(1j * np.asarray(phases_rad, dtype=float))
        p = self.p0 - self.te_signal(amps_m, phases_rad)[None, :]
        for k, ck in enumerate(c):
            p = p + ck.real * self.dp[k, 0] + ck.imag * self.dp[k, 1]
        return p

    def margin(self, amps_m, phases_rad) -> np.ndarray:
        """``m(rpm) = min_t (p - b)`` (m) of the linear solution at every speed."""
        return self.signals(amps_m, phases_rad).min(axis=1)


def build_basis(scene_path: Path, overrides: dict, rpm: np.ndarray, cache: Path,
                n_te: int = 3, n_time: int | None = None,
                case: str | None = None) -> MarginBasis:
    """Linear solutions of the scene at ``rpm`` for no TE harmonics and for each unit
    harmonic (real and imaginary), from the cached ROM; with ``case`` (``"internal"``,
    ``"external"``, ``"all"``) those of that excitation case of
    :func:`study.studies.excitations.case_scenes`."""
    from hbm.problem.fixed_speed import initial_guess
    from hbm.units import RPM_TO_RAD_S
    from study.pipeline import Pipeline
    from study.scene.load import load_scene
    from study.studies.excitations import case_scenes

    def problem(amps, phases):
        ov = {**overrides, "transmission_error.amplitudes_um": list(amps),
              "transmission_error.phases_deg": list(phases)}
        sc = load_scene(scene_path, ov)
        if case is not None:
            cases = case_scenes(sc)
            if case not in cases:
                raise ValueError(f"case = {case!r}: one of {sorted(cases)}")
            sc = cases[case]
        return Pipeline(sc, cache / "te_margin_out", cache_dir=cache,
                        progress=False).problem()[0]

    zero = [0.0] * n_te
    base = problem(zero, zero)
    n = base.harmonics.n_time if n_time is None else int(n_time)
    synth, samples = base.fine_grid(n)
    e0 = samples[0].e
    phase = base.harmonics.time_grid(n) * base.steps[0]

    def deltas(prob):
        out = np.empty((len(rpm), n))
        for i, r in enumerate(rpm):
            u = initial_guess(prob, float(r) * RPM_TO_RAD_S)
            out[i] = (synth @ prob.delta_real(u))[0]
        return out

    d0 = deltas(base)
    p0 = d0 - e0[None, :] - base.elements[0].backlash
    dp = np.empty((n_te, 2, len(rpm), n))
    for k in range(n_te):
        for j, ph in enumerate((0.0, 90.0)):
            amps, phs = list(zero), list(zero)
            amps[k], phs[k] = UNIT * 1e6, ph
            dp[k, j] = (deltas(problem(amps, phs)) - d0) / UNIT
            log.info("basis: TE harmonic %d at %g deg done", k + 1, ph)
    return MarginBasis(np.asarray(rpm, dtype=float), p0, dp, phase, int(base.steps[0]))


def crossings(rpm: np.ndarray, m: np.ndarray) -> list[float]:
    """Speeds (rpm) where ``m`` changes sign, linearly interpolated."""
    s = m < 0
    idx = np.flatnonzero(s[1:] != s[:-1])
    return [float(rpm[i] - m[i] * (rpm[i + 1] - rpm[i]) / (m[i + 1] - m[i])) for i in idx]


def impact_intervals(rpm: np.ndarray, m: np.ndarray) -> list[tuple[float, float]]:
    """Speed intervals (rpm) where the linear solution loses contact (``m < 0``)."""
    c = crossings(rpm, m)
    edges = ([float(rpm[0])] if m[0] < 0 else []) + c + ([float(rpm[-1])] if m[-1] < 0 else [])
    return [(edges[i], edges[i + 1]) for i in range(0, len(edges) - 1, 2)]


def grazing_set_distance(found: list[float], target: tuple[float, ...]) -> float:
    """Largest relative distance of each target grazing to the nearest found one and of
    each found one to the nearest target (0: the same set)."""
    if not found:
        return 1.0
    f, t = np.asarray(found), np.asarray(target)
    a = np.abs(f[:, None] - t[None, :]) / t[None, :]
    return float(max(a.min(axis=0).max(), a.min(axis=1).max()))


class MarginModel:
    """The margin of :class:`MarginBasis` as a linear map of the six real TE unknowns
    ``(Re c_1, Im c_1, Re c_2, ...)`` (m), on every ``speed_step``-th speed and
    ``time_step``-th sample (a coarser screen)."""

    def __init__(self, basis: MarginBasis, speed_step: int = 1, time_step: int = 1) -> None:
        ph = basis.mesh_phase[::time_step]
        self.rpm = basis.rpm[::speed_step]
        self.p0 = basis.p0[::speed_step, ::time_step]
        n_te = basis.dp.shape[0]
        q = []
        for k in range(n_te):
            q.append(basis.dp[k, 0, ::speed_step, ::time_step] - np.cos((k + 1) * ph))
            q.append(basis.dp[k, 1, ::speed_step, ::time_step] + np.sin((k + 1) * ph))
        self.q = np.stack(q).reshape(2 * n_te, -1)

    @staticmethod
    def unknowns(amps_um, phases_deg) -> np.ndarray:
        """``(..., 2 n_te)`` real unknowns (m) of amplitudes (µm) and phases (deg)."""
        c = np.asarray(amps_um, dtype=float) * 1e-6 * np.exp(1j * np.radians(phases_deg))
        return np.stack([c.real, c.imag], axis=-1).reshape(*c.shape[:-1], 2 * c.shape[-1])

    def margins(self, amps_um, phases_deg) -> np.ndarray:
        """Margins (m), ``(n_candidates, n_speed)`` for ``(n_candidates, n_te)`` inputs."""
        th = self.unknowns(np.atleast_2d(amps_um), np.atleast_2d(phases_deg))
        p = self.p0.reshape(1, -1) + th @ self.q
        return p.reshape(len(th), *self.p0.shape).min(axis=2)


def pattern_score(rpm: np.ndarray, m: np.ndarray, target: tuple[float, ...]
                  ) -> tuple[float, list[float]]:
    """How far the linear grazings are from ``target`` (rpm, sorted), and the grazings.

    The target pattern: contact at the first speed, impacts at the last, one zero of
    the margin per target speed. Such a curve scores the largest relative error plus
    0.3 × the RMS error (< 1); any other scores 1 + the set distance
    (:func:`grazing_set_distance`) + 0.02 per missing or extra grazing (+ 0.5 with impacts at
    the first speed).
    """
    c = crossings(rpm, m)
    if m[0] > 0 and (m[-1] < 0) == (len(target) % 2 == 1) and len(c) == len(target):
        e = np.abs(np.asarray(c) - np.asarray(target)) / np.asarray(target)
        return float(e.max() + 0.3 * np.sqrt(np.mean(e ** 2))), c
    return (1.0 + grazing_set_distance(c, target) + 0.02 * abs(len(c) - len(target))
            + (0.5 if m[0] <= 0 else 0.0)), c


def random_search(model: MarginModel, target: tuple[float, ...], n: int, seed: int = 0,
                  amp_range_um: tuple[float, float] = (0.02, 1.0),
                  batch: int = 20, phases_deg=None) -> list[dict]:
    """``n`` log-uniform amplitudes (H_3Z up to 0.6 of the range) and uniform phases
    (or the fixed ``phases_deg``), scored by :func:`pattern_score`; sorted, best first."""
    rng = np.random.default_rng(seed)
    lo, hi = np.log(amp_range_um[0]), np.log(amp_range_um[1])
    amps = np.exp(rng.uniform(lo, hi, (n, 3))) * np.array([1.0, 1.0, 0.6])
    phs = rng.uniform(0.0, 360.0, (n, 3)) if phases_deg is None else \
        np.tile(np.asarray(phases_deg, dtype=float), (n, 1))
    out = []
    for i in range(0, n, batch):
        for j, m in enumerate(model.margins(amps[i:i + batch], phs[i:i + batch])):
            s, c = pattern_score(model.rpm, m, target)
            out.append({"score": s, "amplitudes_um": amps[i + j].tolist(),
                        "phases_deg": phs[i + j].tolist(), "grazing_rpm": c})
    return sorted(out, key=lambda r: r["score"])


def depth(rpm: np.ndarray, m: np.ndarray, c: list[float]) -> float:
    """The smallest of: the margin's minimum below the first grazing ``c[0]`` and its
    maximum inside each permanent-contact window ``(c[1], c[2]), (c[3], c[4]), ...``
    (m): how far the pattern is from losing a window or gaining impacts at low speed."""
    vals = [float(m[rpm < c[0]].min())]
    for lo, hi in zip(c[1::2], c[2::2], strict=False):
        inside = m[(rpm > lo) & (rpm < hi)]
        vals.append(float(inside.max()) if inside.size else 0.0)
    return min(vals)


def robust_score(rpm: np.ndarray, m: np.ndarray, target: tuple[float, ...], tol: float,
                 scale: float) -> float:
    """For a curve of the target pattern: 100 × the grazing error beyond ``tol`` minus
    :func:`depth` / ``scale`` (lower is better); 10 + :func:`pattern_score` otherwise."""
    s, c = pattern_score(rpm, m, target)
    if s >= 1.0:
        return 10.0 + s
    e = float(np.max(np.abs(np.asarray(c) - np.asarray(target)) / np.asarray(target)))
    return 100.0 * max(e - tol, 0.0) - depth(rpm, m, c) / scale


def nelder_mead(f: Callable[[np.ndarray], float], x0: np.ndarray, steps: Sequence[float],
                max_evals: int, xatol: float, fatol: float, restarts: int = 1
                ) -> OptimizeResult:
    """Nelder–Mead with restarts.

    Parameters
    ----------
    f, x0
        The function and the start.
    steps
        The initial simplex: ``x0`` and ``x0`` plus each step along its coordinate.
    max_evals, xatol, fatol
        SciPy's ``maxfev``, ``xatol``, ``fatol`` of each run.
    restarts
        Runs, each from a fresh simplex at the last point (escapes a collapsed simplex).

    Returns
    -------
    scipy.optimize.OptimizeResult
        The result of the last run.
    """
    if restarts < 1:
        raise ValueError(f"restarts = {restarts}: must be >= 1")
    if len(steps) != np.size(x0):
        raise ValueError(f"steps has {len(steps)} values: one per coordinate of x0 "
                         f"({np.size(x0)})")
    x = np.asarray(x0, dtype=float)
    for _ in range(restarts):
        simplex = x + np.vstack([np.zeros(x.size), np.diag(np.asarray(steps, dtype=float))])
        r = minimize(f, x, method="Nelder-Mead",
                     options={"xatol": xatol, "fatol": fatol, "maxfev": max_evals,
                              "initial_simplex": simplex})
        x = r.x
    return r


def refine(model: MarginModel, target: tuple[float, ...], amps_um, phases_deg,
           max_evals: int = 500, robust: tuple[float, float] | None = None,
           fix_phases: bool = False) -> dict:
    """Nelder–Mead on (log amplitudes, phases) from a start (only the log amplitudes
    with ``fix_phases``), scored by :func:`pattern_score`, or with
    ``robust = (tol, scale)`` by :func:`robust_score` (the deepest windows with every
    grazing within ``tol``)."""
    fixed = np.asarray(phases_deg, dtype=float)

    def f(x):
        m = model.margins(np.exp(x[:3]), fixed if fix_phases else x[3:])[0]
        if robust is not None:
            return robust_score(model.rpm, m, target, *robust)
        return pattern_score(model.rpm, m, target)[0]

    x0 = np.log(amps_um) if fix_phases else np.r_[np.log(amps_um), phases_deg]
    steps = [0.15] * 3 + ([] if fix_phases else [20.0] * 3)
    r = nelder_mead(f, x0, steps, max_evals, xatol=1e-3, fatol=1e-4)
    amps = np.exp(r.x[:3])
    phs = fixed if fix_phases else np.mod(r.x[3:], 360.0)
    m = model.margins(amps, phs)[0]
    s, c = pattern_score(model.rpm, m, target)
    out = {"score": s, "amplitudes_um": amps.tolist(), "phases_deg": phs.tolist(),
           "grazing_rpm": c, "start": {"amplitudes_um": list(map(float, amps_um)),
                                       "phases_deg": list(map(float, phases_deg))}}
    if s < 1.0:
        out["depth_m"] = depth(model.rpm, m, c)
    if robust is not None:
        out["robust"] = {"tol": robust[0], "scale_m": robust[1]}
    return out


# --- how the linear response at one speed splits into impacts per mesh period ----------
#
# The paper's 1070 rpm sequence (Fig. 18: contact, 1-, 2-, 3-IPP) needs a margin whose
# mesh period holds three minima of similar depth, swept through zero by the slow
# (shaft-order) modulation. The linear solution shows that before any nonlinear run:
# its loss intervals per mesh period (the "linear IPP") and the mesh harmonics of p.


def linear_ipp(signal: np.ndarray, mesh_step: int) -> np.ndarray:
    """Loss intervals of ``signal = p - b`` in each mesh period (the linear IPP).

    ``signal`` holds ``(..., n_time)`` samples of one fundamental period of ``mesh_step``
    mesh periods; the loss samples (``< 0``) are counted by
    :func:`hbm.impacts_per_mesh_period`, as :func:`hbm.point_stats` counts them on the
    nonlinear solution. Returns ``(..., mesh_step)`` integers.
    """
    s = np.asarray(signal, dtype=float)
    n = s.shape[-1]
    if mesh_step < 1 or n % mesh_step:
        raise ValueError(f"mesh_step = {mesh_step}: must be >= 1 and divide the "
                         f"{n} samples of the signal")
    return impacts_per_mesh_period(s < 0.0, mesh_step)


def ipp_fraction_vector(ipp: np.ndarray, n_max: int = 3) -> np.ndarray:
    """Fractions of the period at 0, 1, ..., ``n_max`` impacts per mesh period (counts
    above ``n_max`` join ``n_max``), ``(..., n_max + 1)``."""
    a = np.minimum(np.asarray(ipp, dtype=int), n_max)
    return np.stack([(a == k).mean(axis=-1) for k in range(n_max + 1)], axis=-1)


def ipp_distance(fractions: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """Total-variation distance ``½ Σ_k |f_k - r_k|`` of two IPP fraction vectors
    (0: the same shares of the turn, 1: disjoint)."""
    return 0.5 * np.abs(np.asarray(fractions) - np.asarray(reference)).sum(axis=-1)


def mesh_harmonics(signal: np.ndarray, mesh_step: int, n: int = 3) -> np.ndarray:
    """Amplitudes of ``H_Z ... H_nZ`` (orders ``k mesh_step`` of the fundamental period)
    of ``(..., n_time)`` samples, ``(..., n)``."""
    s = np.asarray(signal, dtype=float)
    f = np.fft.rfft(s, axis=-1)
    k = mesh_step * np.arange(1, n + 1)
    if k[-1] >= f.shape[-1]:
        raise ValueError(f"n = {n}: H_{n}Z needs more than {s.shape[-1]} samples")
    return 2.0 * np.abs(f[..., k]) / s.shape[-1]


def h3_ratio(signal: np.ndarray, mesh_step: int) -> np.ndarray:
    """``|H_3Z| / (|H_Z| + |H_2Z|)`` of ``p - b``: how much the third mesh harmonic
    governs the response (Sect. 4.3 at 1070 rpm)."""
    a = mesh_harmonics(signal, mesh_step, 3)
    return a[..., 2] / (a[..., 0] + a[..., 1])


def fourier_resample(signal: np.ndarray, n: int) -> np.ndarray:
    """Samples of one period of a band-limited periodic signal (harmonics below half the
    ``n_time`` given) on ``n`` equispaced points instead, ``(..., n)``: exact for the
    harmonic-balance signals, whose largest harmonic index is below half the AFT grid."""
    s = np.asarray(signal, dtype=float)
    m = s.shape[-1]
    if n < m:
        raise ValueError(f"n = {n}: must be >= the {m} samples given")
    f = np.fft.rfft(s, axis=-1)
    f[..., -1] *= 0.5 if m % 2 == 0 else 1.0     # split the Nyquist bin
    return np.fft.irfft(f, n, axis=-1) * (n / m)


class SpeedModel:
    """``p - b`` of :class:`MarginBasis` at one speed as an affine map of the six real TE
    unknowns (full time resolution): the linear IPP of many candidates at once."""

    def __init__(self, basis: MarginBasis, rpm: float, oversample: int = 4) -> None:
        i = int(np.argmin(np.abs(basis.rpm - rpm)))
        if abs(basis.rpm[i] - rpm) > 1e-6 * max(rpm, 1.0):
            raise ValueError(f"rpm = {rpm}: not a speed of the basis "
                             f"({basis.rpm[0]:g}–{basis.rpm[-1]:g})")
        self.rpm, self.mesh_step = float(basis.rpm[i]), int(basis.mesh_step)
        ph = basis.mesh_phase
        q = []
        for k in range(basis.dp.shape[0]):
            q.append(basis.dp[k, 0, i] - np.cos((k + 1) * ph))
            q.append(basis.dp[k, 1, i] + np.sin((k + 1) * ph))
        # a whole number of samples per mesh period, as hbm.point_stats samples it
        n = len(ph)
        n_fine = self.mesh_step * int(np.ceil(oversample * n / self.mesh_step))
        self.p0 = fourier_resample(basis.p0[i], n_fine)
        self.q = fourier_resample(np.stack(q), n_fine)

    def signals(self, amps_um, phases_deg) -> np.ndarray:
        """``p - b`` (m), ``(n_candidates, n_time)``."""
        th = MarginModel.unknowns(np.atleast_2d(amps_um), np.atleast_2d(phases_deg))
        return self.p0[None, :] + th @ self.q

    def ipp_fractions(self, amps_um, phases_deg, n_max: int = 3) -> np.ndarray:
        """Linear IPP fractions (:func:`ipp_fraction_vector`), ``(n_candidates, n_max+1)``."""
        return ipp_fraction_vector(linear_ipp(self.signals(amps_um, phases_deg),
                                              self.mesh_step), n_max)


def period_minima(signal: np.ndarray, mesh_step: int, n: int = 3) -> np.ndarray:
    """The ``n`` lowest local minima of ``signal`` (cyclic) in each mesh period, sorted
    (``+inf`` where a period has fewer), ``(..., mesh_step, n)``. With ``signal = p - b``
    of the linear solution, minimum k below zero means a k-th impact in that period."""
    s = np.asarray(signal, dtype=float)
    m = s.shape[-1]
    if mesh_step < 1 or m % mesh_step:
        raise ValueError(f"mesh_step = {mesh_step}: must be >= 1 and divide the "
                         f"{m} samples of the signal")
    is_min = (s < np.roll(s, 1, axis=-1)) & (s <= np.roll(s, -1, axis=-1))
    v = np.where(is_min, s, np.inf).reshape(*s.shape[:-1], mesh_step, m // mesh_step)
    return np.sort(v, axis=-1)[..., :n]


def minima_count(signal: np.ndarray, mesh_step: int, fraction: float = 0.5) -> np.ndarray:
    """Local minima per mesh period whose depth below the period's mean reaches
    ``fraction`` of the deepest one's, ``(..., mesh_step)``: 3 when the third mesh
    harmonic governs the period, 1 when the first does."""
    s = np.asarray(signal, dtype=float)
    per = s.reshape(*s.shape[:-1], mesh_step, s.shape[-1] // mesh_step)
    mean = per.mean(axis=-1, keepdims=True)
    d = mean - period_minima(s, mesh_step, per.shape[-1])   # depths below the mean
    return (d >= fraction * d[..., :1]).sum(axis=-1)


def soft_ipp(signal: np.ndarray, mesh_step: int, scale: float, n: int = 3) -> np.ndarray:
    """Smooth stand-in for the share of the period with at least 1, ..., ``n`` impacts
    per mesh period: the mean over mesh periods of ``sigmoid(-m_k / scale)`` of the
    k-th lowest minimum ``m_k`` (:func:`period_minima`), ``(..., n)``; the step of
    :func:`linear_ipp` as ``scale`` → 0, smooth in the TE for a local search."""
    m = period_minima(signal, mesh_step, n)
    with np.errstate(over="ignore"):
        return (1.0 / (1.0 + np.exp(np.clip(m / scale, -50.0, 50.0)))).mean(axis=-2)


def coexistence_gap(signal: np.ndarray, mesh_step: int, k: int = 3) -> float:
    """``max(-max_j m_1j, min_j m_kj)`` (m) of the lowest and k-th lowest minima
    (:func:`period_minima`) over the mesh periods ``j``: negative when one turn of the
    linear solution holds both a permanent-contact period and a k-impact one (the
    paper's 1070 rpm sequence, k = 3); its size is how far it is from that. Both need
    the slow modulation of the minima to exceed their spread within a mesh period."""
    m = period_minima(signal, mesh_step, k)
    return float(max(-m[:, 0].max(), m[:, k - 1].min()))


def cumulative(fractions: np.ndarray) -> np.ndarray:
    """Shares at >= 1, >= 2, ... impacts of IPP fractions at 0, 1, 2, ... impacts."""
    f = np.asarray(fractions, dtype=float)
    return np.flip(np.cumsum(np.flip(f[..., 1:], -1), -1), -1)


def fractions_from_cumulative(cum: np.ndarray) -> np.ndarray:
    """Shares at 0, 1, ..., n-1, n+ impacts from the shares at >= 1, ..., >= n impacts
    of one turn (the inverse of :func:`cumulative`)."""
    c = np.r_[1.0, np.asarray(cum, dtype=float), 0.0]
    return c[:-1] - c[1:]


def ipp_score(rpm: np.ndarray, m: np.ndarray, target: tuple[float, ...], tol: float,
              fractions: np.ndarray, reference: np.ndarray) -> float:
    """For a curve of the target pattern: 100 × the grazing error beyond ``tol`` plus the
    :func:`ipp_distance` of the linear IPP ``fractions`` at the IPP speed to
    ``reference`` (lower is better, < 1 with every grazing within ``tol``);
    10 + :func:`pattern_score` otherwise."""
    s, c = pattern_score(rpm, m, target)
    if s >= 1.0:
        return 10.0 + s
    e = float(np.max(np.abs(np.asarray(c) - np.asarray(target)) / np.asarray(target)))
    return 100.0 * max(e - tol, 0.0) + float(ipp_distance(fractions, reference))


def refine_ipp(model: MarginModel, speed: SpeedModel, target: tuple[float, ...],
               reference: np.ndarray, amps_um, phases_deg, tol: float = 0.03,
               max_evals: int = 600, scale: float = 5e-9, objective: str = "fractions",
               gap_scale: float = 3e-7, restarts: int = 1) -> dict:
    """Nelder–Mead on (log amplitudes, phases) from a start: the grazings within ``tol``
    (100 × the error beyond it) and the linear IPP at ``speed.rpm`` closest to
    ``reference`` (fractions at 0, 1, 2, 3+ impacts per mesh period), the latter
    through :func:`soft_ipp` with ``scale`` (m) so that the search sees a slope
    (½ Σ |soft − cumulative reference|); the result reports the exact
    :func:`ipp_score` parts (linear IPP fractions, their :func:`ipp_distance`).
    ``objective = "coexist"`` minimises :func:`coexistence_gap` / ``gap_scale`` instead
    (contact and the largest count of ``reference`` in one turn, whatever the shares).
    ``restarts`` runs of ``max_evals`` each, every one from a fresh simplex at the last
    point (the grazing penalty makes the landscape kinked)."""
    if objective not in ("fractions", "coexist"):
        raise ValueError(f"objective = {objective!r}: must be 'fractions' or 'coexist'")
    if restarts < 1:
        raise ValueError(f"restarts = {restarts}: must be >= 1")
    ref = np.asarray(reference, dtype=float)
    ref_cum = cumulative(ref)

    def f(x):
        a, p = np.exp(x[:3]), x[3:]
        m = model.margins(a, p)[0]
        s, c = pattern_score(model.rpm, m, target)
        if s >= 1.0:
            return 10.0 + s
        e = float(np.max(np.abs(np.asarray(c) - np.asarray(target)) / np.asarray(target)))
        sig = speed.signals(a, p)[0]
        if objective == "coexist":
            return 100.0 * max(e - tol, 0.0) + coexistence_gap(
                sig, speed.mesh_step, len(ref) - 1) / gap_scale
        soft = soft_ipp(sig, speed.mesh_step, scale, len(ref) - 1)
        return 100.0 * max(e - tol, 0.0) + 0.5 * float(np.abs(soft - ref_cum).sum())

    r = nelder_mead(f, np.r_[np.log(amps_um), phases_deg], [0.15] * 3 + [20.0] * 3,
                    max_evals, xatol=1e-3, fatol=1e-5, restarts=restarts)
    amps, phs = np.exp(r.x[:3]), np.mod(r.x[3:], 360.0)
    m = model.margins(amps, phs)[0]
    s, c = pattern_score(model.rpm, m, target)
    frac = speed.ipp_fractions(amps, phs)[0]
    sig = speed.signals(amps, phs)[0]
    out = {"score": s, "amplitudes_um": amps.tolist(), "phases_deg": phs.tolist(),
           "grazing_rpm": c, "start": {"amplitudes_um": list(map(float, amps_um)),
                                       "phases_deg": list(map(float, phases_deg))},
           "ipp": {"rpm": speed.rpm, "tol": tol, "reference": ref.tolist(),
                   "fractions": frac.tolist(), "distance": float(ipp_distance(frac, ref)),
                   "h3_ratio": float(h3_ratio(sig, speed.mesh_step)),
                   "mesh_harmonics_um": (1e6 * mesh_harmonics(sig, speed.mesh_step)).tolist(),
                   "objective": float(r.fun), "objective_kind": objective,
                   "coexistence_gap_m": coexistence_gap(sig, speed.mesh_step, len(ref) - 1),
                   "minima_count": np.bincount(minima_count(sig, speed.mesh_step),
                                               minlength=4).tolist(),
                   "score": ipp_score(model.rpm, m, target, tol, frac, ref)}}
    if s < 1.0:
        out["depth_m"] = depth(model.rpm, m, c)
    return out
