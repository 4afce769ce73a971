"""Equivalent radiated power (ERP) of the housing from the ROM coordinates, and the
levels in dB of sound power and vibration velocity: pure NumPy on the radiation matrix
``W`` that the rom stage computed (:mod:`fem.post.radiation`, cached as ``radiation.h5``).

ERP is the sound power a surface would radiate if every element radiated as a
plane wave (radiation efficiency 1)::

    P = ½ ρ c ∫_Γ |v_n|² dA        (time average of one harmonic, amplitude v_n)

For the harmonic k of the HBM solution (``x(t) = Re Σ_k x̃_k e^{i k ω₀ t}``) the
normal velocity is ``ṽ_n = i k ω₀ n·ũ_k`` with ``ũ_k = P T q̃_k`` (the P2
displacement rebuilt from the ROM coordinates, eq. 8), so

    P_k = ½ ρ c (k ω₀)² q̃_kᴴ W q̃_k,      W = (P T)ᵀ A (P T),
    A_ij = ∫_Γ (φ_i·n)(φ_j·n) dA       (P2 shape functions φ, outer normal n).

Per continuation point the ERP of every harmonic is a few n_r² products (half of them
with the Cholesky factor of ``W``, :class:`PowerForm`). Harmonics are orthogonal over the
period, so the total ERP is ``Σ_k P_k``.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.linalg import blas, lapack

__all__ = ["AIR_DENSITY", "SOUND_SPEED", "P_REF", "V_REF", "DB_FLOOR", "PowerForm",
           "erp_harmonics", "power_db", "velocity_level_db", "sphere_erp"]

#: Default air density [kg/m³] and speed of sound [m/s] (20 °C, sea level).
AIR_DENSITY = 1.2
SOUND_SPEED = 343.0
#: Reference sound power for dB [W].
P_REF = 1e-12
#: Reference velocity of velocity levels (ISO 1683) [m/s].
V_REF = 1e-9
#: Floor of the dB values (a zero power, e.g. of the mean k = 0, reads as this) [dB].
DB_FLOOR = -100.0


def power_db(power_w: np.ndarray) -> np.ndarray:
    """Sound power level ``10 log10(P / 1e-12 W)`` [dB], floored at ``DB_FLOOR``."""
    p = np.asarray(power_w, dtype=float)
    floor = P_REF * 10 ** (DB_FLOOR / 10)
    return 10.0 * np.log10(np.maximum(p, floor) / P_REF)


def velocity_level_db(v_amp: np.ndarray, axis: int = -1) -> np.ndarray:
    """Velocity level ``20 log10(v_rms / 1 nm/s)`` [dB] of harmonics of amplitudes
    ``|ṽ_k|`` summed along ``axis`` (``v_rms² = Σ |ṽ_k|²/2``), floored at −100 dB."""
    ms = 0.5 * np.sum(np.abs(v_amp) ** 2, axis=axis)
    return 10.0 * np.log10(np.maximum(ms, (V_REF * 1e-5) ** 2) / V_REF ** 2)


class PowerForm:
    """The quadratic form ``x -> xᵀ W x`` of a symmetric positive semi-definite ``W``
    (a radiation matrix) by its pivoted Cholesky factor, ``W = P L Lᵀ Pᵀ`` (LAPACK
    ``dpstrf``): ``|Lᵀ Pᵀ x|²``, a triangular product, half the multiplications of
    ``W x`` (24 ms against 42 ms for 772 coordinates and 1850 columns). The factor is
    kept only when it reproduces ``W`` to 1e-12 of its largest entry (else, e.g. an
    indefinite ``W``, the form multiplies by ``W`` itself)."""

    def __init__(self, W: np.ndarray) -> None:
        W = np.asarray(W, dtype=float)
        self.W = W
        self.factor = None
        if W.ndim != 2 or W.shape[0] != W.shape[1] or W.shape[0] == 0:
            return
        c, piv, rank, info = lapack.dpstrf(W, lower=1)
        if info < 0 or rank == 0:
            return
        lower = np.tril(c)[:, :rank]                          # (n, r), rows in pivot order
        rows = piv - 1
        back = np.zeros_like(W)
        back[np.ix_(rows, rows)] = lower @ lower.T
        if np.max(np.abs(back - W)) > 1e-12 * max(float(np.max(np.abs(W))), 1e-300):
            return
        self.factor = (np.asfortranarray(lower[:rank]), lower[rank:].T.copy(), rows)

    def __call__(self, x: np.ndarray) -> np.ndarray:
        """``xᵀ W x`` of every column of the real ``x`` (n, m)."""
        if self.factor is None:
            return np.einsum("ik,ik->k", x, self.W @ x)
        l11, l21t, rows = self.factor
        r = l11.shape[0]
        xp = x[rows]
        y = blas.dtrmm(1.0, l11, np.asfortranarray(xp[:r]), side=0, lower=1, trans_a=1)
        if r < xp.shape[0]:
            y += l21t @ xp[r:]
        return np.einsum("ik,ik->k", y, y)


def erp_harmonics(W: np.ndarray | PowerForm, qk: np.ndarray, omega_k: np.ndarray,
                  rho: float = AIR_DENSITY, c: float = SOUND_SPEED) -> np.ndarray:
    """ERP of every harmonic, ``P_k = ½ ρ c ω_k² q̃_kᴴ W q̃_k`` [W].

    Parameters
    ----------
    W : (n_r, n_r) float, or its :class:`PowerForm`
        Radiation matrix (``fem.post.radiation.reduced_radiation_matrix``) [m²]; a
        :class:`PowerForm` of it when many points use the same matrix.
    qk : (n_r, n_h) complex
        ROM coordinates per harmonic (complex amplitudes, ``x = Re Σ q̃_k e^{iω_k t}``).
    omega_k : (n_h,) float
        Angular frequency of each harmonic [rad/s].
    rho, c : float
        Air density [kg/m³] and speed of sound [m/s].
    """
    form = W if isinstance(W, PowerForm) else None
    qk = np.asarray(qk)
    if np.iscomplexobj(qk):
        # W is real: Re(q̃ᴴ W q̃) = aᵀWa + bᵀWb for q̃ = a + ib, one real
        # product with the (Re, Im) pairs (NumPy would promote W to complex: 4× the work)
        qk = np.ascontiguousarray(qk, dtype=complex)
        n, m = qk.shape
        pairs = qk.view(np.float64).reshape(n, 2 * m)
        quad = (form(pairs) if form else np.einsum("ik,ik->k", pairs, W @ pairs)
                ).reshape(m, 2).sum(axis=1)
    else:
        quad = form(qk) if form else np.einsum("ik,ik->k", qk, W @ qk)
    return 0.5 * rho * c * np.asarray(omega_k, dtype=float) ** 2 * np.maximum(quad, 0.0)


def sphere_erp(radius: float, u0: float, omega: float, rho: float = AIR_DENSITY,
               c: float = SOUND_SPEED) -> float:
    """Closed form: ERP of a sphere pulsating with radial amplitude ``u0`` [W]."""
    return 0.5 * rho * c * (omega * u0) ** 2 * 4.0 * math.pi * radius ** 2
