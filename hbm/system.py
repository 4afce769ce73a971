"""Validated linear inputs of the HBM: the linear system and the external excitation.

Everything is SI. The equation solved is (eq. 4, 14)

    M q'' + C q' + K q + sum_e g_e f_e(g_e^T q, t) = f_ex(t),

the nonlinear elements ``e`` (:mod:`hbm.elements`) each acting along their direction
``g_e``.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np

from .basis import as_ratio

logger = logging.getLogger(__name__)

__all__ = ["LinearSystem", "Excitation", "finite"]


def finite(name: str, a: np.ndarray) -> None:
    """Refuse an array with NaN or inf, naming it."""
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name}: contains NaN or inf; all entries must be finite")


@dataclass(frozen=True)
class LinearSystem:
    """Dense linear model ``(M, C, K)``.

    Parameters
    ----------
    M, C, K
        (n, n) mass (kg), damping (N s/m) and stiffness (N/m) matrices in the
        units of the coordinates (rotations: kg m^2, N m s/rad, N m/rad).
        M symmetric positive definite; C and K real.
    """

    M: np.ndarray
    C: np.ndarray
    K: np.ndarray

    def __post_init__(self) -> None:
        m = np.atleast_2d(np.asarray(self.M, dtype=float))
        n = m.shape[0]
        if m.ndim != 2 or m.shape != (n, n) or n < 1:
            raise ValueError(f"system.M shape = {np.shape(self.M)}: must be square (n, n), n >= 1")
        arrays = {"M": m}
        for name in ("C", "K"):
            a = np.atleast_2d(np.asarray(getattr(self, name), dtype=float))
            if a.shape != (n, n):
                raise ValueError(f"system.{name} shape = {a.shape}: must be ({n}, {n}) like M")
            arrays[name] = a
        for name, a in arrays.items():
            finite(f"system.{name}", a)
        scale = np.max(np.abs(m))
        if np.max(np.abs(m - m.T)) > 1e-10 * scale:
            raise ValueError("system.M: must be symmetric (max |M - M^T| > 1e-10 max |M|)")
        m = 0.5 * (m + m.T)
        try:
            np.linalg.cholesky(m)
        except np.linalg.LinAlgError as exc:
            raise ValueError("system.M: must be positive definite (Cholesky failed)") from exc
        object.__setattr__(self, "M", m)
        object.__setattr__(self, "C", arrays["C"])
        object.__setattr__(self, "K", arrays["K"])

    @property
    def n_dof(self) -> int:
        return self.M.shape[0]


def _key(key, name: str):
    """An excitation key: an exact frequency ratio (:func:`hbm.basis.as_ratio`, >= 0), or
    on a torus basis a lattice vector, a tuple of integers (all zero: the ratio 0)."""
    if isinstance(key, tuple):
        if not key or any(isinstance(v, bool) or not isinstance(v, (int, np.integer))
                          for v in key):
            raise ValueError(f"{name} = {key!r}: a lattice vector must be a tuple of "
                             "integers")
        k = tuple(int(v) for v in key)
        return as_ratio(0, name, positive=False) if not any(k) else k
    return as_ratio(key, name, positive=False)


@dataclass(frozen=True)
class Excitation:
    """External forcing ``f(t) = Re sum_p (F_p + Omega^2 U_p) exp(i p Omega t)``.

    Parameters
    ----------
    n_dof
        Number of coordinates n.
    constant
        {frequency ratio p >= 0: complex (n,) vector F_p} (N); p = 0 is the static
        load (must be real). The keys are exact ratios of the reference speed Omega
        (int, :class:`fractions.Fraction`): shaft order k of a shaft turning at
        ``rho Omega`` is ``p = k rho``. On a torus basis (:class:`hbm.torus.TorusBasis`)
        a key may also be a lattice vector ``k`` (a tuple of integers, canonical: first
        non-zero component > 0): the term ``Re F_k exp(i k . theta)``.
    omega_squared
        {frequency ratio p: complex (n,) vector U_p} (N s^2) for loads growing with
        Omega^2 (unbalance, aerodynamic).
    """

    n_dof: int
    constant: dict = field(default_factory=dict)
    omega_squared: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        n = self.n_dof
        if isinstance(n, bool) or int(n) != n or n < 1:
            raise ValueError(f"excitation.n_dof = {n!r}: must be an integer >= 1")
        for name in ("constant", "omega_squared"):
            d = getattr(self, name)
            if not isinstance(d, dict):
                raise ValueError(f"excitation.{name} = {d!r}: must be a dict {{order: vector}}")
            out = {}
            for key, vec in d.items():
                p = _key(key, f"excitation.{name} key")
                v = np.asarray(vec, dtype=complex).ravel()
                if v.shape != (n,):
                    raise ValueError(
                        f"excitation.{name}[{key}] shape = {np.shape(vec)}: must be ({n},)")
                finite(f"excitation.{name}[{key}]", v)
                if p == 0 and np.any(v.imag != 0):
                    raise ValueError(f"excitation.{name}[0]: the static part must be real")
                if p in out:
                    raise ValueError(f"excitation.{name}: frequency ratio {p} given twice")
                out[p] = v
            object.__setattr__(self, name, out)
        object.__setattr__(self, "n_dof", int(n))
