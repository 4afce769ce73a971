"""The internal excitation of a gear mesh over one mesh period: the mesh stiffness
k_m(θ) and the static transmission error as Fourier series (eq. 15-16).

A periodic quantity of the mesh is ``x(θ) = x̄ + Σ_k a_k cos(kθ + φ_k)``, θ the mesh
angle Z Ω t: :func:`fourier_sample` evaluates it, :func:`fourier_harmonics` analyses
samples (T.31). :func:`rectangular_mesh_stiffness` is the mesh stiffness of perfect
teeth whose single-pair stiffness is constant (the ISO 6336-1 estimate,
:mod:`gears.iso6336`), :func:`perfect_teeth_ste` their loaded static transmission
error q_s = F_s / k_m(θ). Pure NumPy, SI units; every series is (mean, amplitudes,
phases) in plain numbers.
"""
from __future__ import annotations

import math
import numbers
from collections.abc import Sequence

import numpy as np

from core.errors import InputError, check_range

__all__ = ["fourier_sample", "fourier_harmonics", "rectangular_mesh_stiffness",
           "perfect_teeth_ste"]

#: A Fourier series over the mesh period: (x̄, (a_1, …, a_n), (φ_1, …, φ_n)).
Series = tuple[float, tuple[float, ...], tuple[float, ...]]


def fourier_sample(mean: float, amplitudes: Sequence[float], phases: Sequence[float],
                   n: int) -> np.ndarray:
    """Values of x(θ) = x̄ + Σ_k a_k cos(kθ + φ_k) at θ = 2π j/n, j = 0 … n − 1.

    Parameters
    ----------
    mean : float
        x̄.
    amplitudes, phases : sequence of float
        a_k and φ_k (rad) of the mesh harmonics k = 1, 2, …, same length.
    n : int
        Samples over one mesh period.

    Returns
    -------
    numpy.ndarray, shape (n,)
    """
    t = np.arange(n) / n
    x = np.full(n, mean)
    for j, (a, p) in enumerate(zip(amplitudes, phases, strict=True), start=1):
        x += a * np.cos(2 * np.pi * j * t + p)
    return x


def fourier_harmonics(samples: np.ndarray, n_harmonics: int
                      ) -> tuple[float, np.ndarray, np.ndarray]:
    """Mean, amplitudes a_k and phases φ_k (rad) of x(t) = x̄ + Σ a_k cos(2πk t + φ_k),
    k = 1..n, from samples on t = j/N over one period (T.31):
    a_k e^{iφ_k} = (2/N) Σ_j x_j e^{−2πi k j/N}.

    Parameters
    ----------
    samples : array_like, shape (N,)
        x(j/N), j = 0 … N − 1.
    n_harmonics : int
        Harmonics to return, 1 … N/2 − 1.

    Returns
    -------
    mean : float
    amplitudes, phases : numpy.ndarray, shape (n_harmonics,)
    """
    x = np.asarray(samples, dtype=float)
    if not (1 <= n_harmonics < x.size // 2):
        raise InputError(f"n_harmonics = {n_harmonics}: allowed 1..{x.size // 2 - 1} for "
                         f"{x.size} positions")
    c = np.fft.rfft(x) / x.size
    amplitudes = np.array([2 * abs(c[k]) for k in range(1, n_harmonics + 1)])
    phases = np.array([np.angle(c[k]) for k in range(1, n_harmonics + 1)])
    return float(c[0].real), amplitudes, phases


def rectangular_mesh_stiffness(single_pair: float, contact_ratio: float,
                               n_harmonics: int) -> Series:
    """Mesh stiffness of perfect teeth as a rectangular wave, truncated to n harmonics
    (eq. 16).

    One pair (stiffness ``single_pair``, e.g. ISO 6336-1's c'·b) carries the load for a
    fraction 2 − ε_α of the mesh period, two pairs for ε_α − 1 (for 1 ≤ ε_α < 2; in
    general ⌊ε_α⌋ pairs, one more for the fraction d = ε_α − ⌊ε_α⌋):

        k_m(θ) = c' b (⌊ε_α⌋ + 𝟙_more(θ)),  mean c' b ε_α,
        a_k = 2 c' b |sin(kπ d)| / (kπ), φ_k ∈ {0, π} (the sign of sin(kπ d)),

    phased so that the zone with one more pair is centred on θ = 0.

    Parameters
    ----------
    single_pair : float
        Stiffness of one tooth pair over the face width (N/m), > 0.
    contact_ratio : float
        Transverse contact ratio ε_α, ≥ 1.
    n_harmonics : int
        Harmonics kept, ≥ 1.

    Returns
    -------
    (mean, amplitudes, phases) : Series
        N/m and rad.
    """
    check_range("single_pair", single_pair, lo=0.0, lo_open=True, unit="N/m")
    check_range("contact_ratio", contact_ratio, lo=1.0)
    if (isinstance(n_harmonics, bool) or not isinstance(n_harmonics, numbers.Integral)
            or n_harmonics < 1):
        raise InputError.of("n_harmonics", n_harmonics, "must be an integer >= 1")
    k1, eps = single_pair, contact_ratio
    d = eps - math.floor(eps)  # fraction with one more pair in contact
    n0 = math.floor(eps)
    amps, phases = [], []
    for k in range(1, n_harmonics + 1):
        a = 2.0 * k1 * math.sin(k * math.pi * d) / (k * math.pi)
        amps.append(abs(a))
        phases.append(0.0 if a >= 0 else math.pi)
    return k1 * (n0 + d), tuple(amps), tuple(phases)


def perfect_teeth_ste(stiffness: Series, static_load: float, n_harmonics: int,
                      n_samples: int = 256) -> Series:
    """Loaded static transmission error of perfect teeth, q_s(θ) = F_s / k_m(θ),
    truncated to n mesh harmonics (T.31 on ``n_samples`` points).

    Parameters
    ----------
    stiffness : Series
        The mesh stiffness (mean, amplitudes, phases) in N/m and rad; k_m(θ) > 0.
    static_load : float
        F_s (N).
    n_harmonics : int
        Harmonics of q_s kept, 1 … n_samples/2 − 1.
    n_samples : int
        Points of the mesh period on which F_s / k_m is sampled.

    Returns
    -------
    (mean, amplitudes, phases) : Series
        m and rad.
    """
    mean, amplitudes, phases = stiffness
    k = fourier_sample(mean, amplitudes, phases, n_samples)
    if not np.all(k > 0):
        raise InputError(f"stiffness: k_m(θ) reaches {k.min():.6g} N/m; must stay > 0",
                         field="stiffness", value=stiffness, unit="N/m", allowed="> 0")
    q0, qa, qp = fourier_harmonics(static_load / k, n_harmonics)
    return q0, tuple(float(a) for a in qa), tuple(float(p) for p in qp)
