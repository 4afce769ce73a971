"""Validated inputs of the HBM: linear system, gear mesh, external excitation.

Everything is SI. The equation solved is (eq. 4, 14)

    M q'' + C q' + K q + G f_LoA(G^T q, t) = f_ex(t).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np

logger = logging.getLogger(__name__)

__all__ = ["LinearSystem", "GearMesh", "Excitation"]


def _finite(name: str, a: np.ndarray) -> None:
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name}: contains NaN or inf; all entries must be finite")


@dataclass(frozen=True)
class LinearSystem:
    """Dense linear model ``(M, C, K, G)``.

    Parameters
    ----------
    M, C, K
        (n, n) mass (kg), damping (N s/m) and stiffness (N/m) matrices in the
        units of the coordinates (rotations: kg m^2, N m s/rad, N m/rad).
        M symmetric positive definite; C and K real.
    G
        (n,) projection of the coordinates onto the line of action (eq. 11):
        ``Delta = G^T q`` (m).
    """

    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    G: np.ndarray

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
        g = np.atleast_1d(np.asarray(self.G, dtype=float)).ravel()
        if g.shape != (n,):
            raise ValueError(f"system.G shape = {np.shape(self.G)}: must be ({n},)")
        for name, a in {**arrays, "G": g}.items():
            _finite(f"system.{name}", a)
        scale = np.max(np.abs(m))
        if np.max(np.abs(m - m.T)) > 1e-10 * scale:
            raise ValueError("system.M: must be symmetric (max |M - M^T| > 1e-10 max |M|)")
        m = 0.5 * (m + m.T)
        try:
            np.linalg.cholesky(m)
        except np.linalg.LinAlgError as exc:
            raise ValueError("system.M: must be positive definite (Cholesky failed)") from exc
        if not np.any(g != 0.0):
            raise ValueError("system.G: all zero; the mesh must act on at least one coordinate")
        object.__setattr__(self, "M", m)
        object.__setattr__(self, "C", arrays["C"])
        object.__setattr__(self, "K", arrays["K"])
        object.__setattr__(self, "G", g)

    @property
    def n_dof(self) -> int:
        return self.M.shape[0]


def _harmonic_dict(name: str, d, allow_empty: bool = False) -> dict[int, complex]:
    if not isinstance(d, dict):
        raise ValueError(f"{name} = {d!r}: must be a dict {{mesh harmonic m >= 0: coefficient}}")
    out: dict[int, complex] = {}
    for key, val in d.items():
        if isinstance(key, bool) or int(key) != key or key < 0:
            raise ValueError(f"{name} key = {key!r}: must be an integer mesh harmonic >= 0")
        try:
            c = complex(val)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"{name}[{key}] = {val!r}: must be a number") from exc
        if not np.isfinite(c):
            raise ValueError(f"{name}[{key}] = {val!r}: must be finite")
        out[int(key)] = c
    if not out and not allow_empty:
        raise ValueError(f"{name} = {{}}: needs at least the mean (key 0)")
    if 0 in out and out[0].imag != 0.0:
        raise ValueError(f"{name}[0] = {out[0]}: the mean must be real")
    return out


def _mesh_signal(coeffs: dict[int, complex], phase: np.ndarray) -> np.ndarray:
    """``Re sum_m c_m exp(i m phase)`` on the mesh phase samples (rad)."""
    x = np.zeros_like(phase)
    for m, c in coeffs.items():
        x += (c * np.exp(1j * m * phase)).real
    return x


@dataclass(frozen=True)
class GearMesh:
    """Kahraman-Singh dead-zone mesh with time-varying stiffness (eq. 12-16).

    Parameters
    ----------
    n_teeth
        Tooth count Z of the gear turning at Omega (mesh frequency Z Omega).
    stiffness
        {mesh harmonic m: complex coefficient} (N/m) with
        ``k_m(t) = Re sum_m k_m exp(i m Z Omega t)``; key 0 is the real mean > 0.
    te
        {m: coefficient} (m) of the transmission error, same convention.
        ``te_kind="unloaded"``: e(t) itself; ``"loaded"``: the loaded static
        transmission error q_s(t) under ``static_load``, and
        ``e(t) = q_s(t) - F_s / k_m(t)`` (eq. 12).
    backlash
        Half backlash b (m), > 0.
    static_load
        Transmitted static load F_s (N) used by ``te_kind="loaded"``.
    """

    n_teeth: int
    stiffness: dict
    te: dict = field(default_factory=dict)
    backlash: float = 0.0
    static_load: float = 0.0
    te_kind: str = "unloaded"

    def __post_init__(self) -> None:
        z = self.n_teeth
        if isinstance(z, bool) or int(z) != z or z < 1:
            raise ValueError(f"mesh.n_teeth = {self.n_teeth!r}: must be an integer >= 1")
        k = _harmonic_dict("mesh.stiffness", self.stiffness)
        if 0 not in k or not k[0].real > 0:
            raise ValueError(f"mesh.stiffness[0] = {k.get(0)!r}: the mean stiffness must be > 0")
        te = _harmonic_dict("mesh.te", self.te, allow_empty=True)
        b = float(self.backlash)
        if not np.isfinite(b) or b <= 0:
            raise ValueError(f"mesh.backlash = {self.backlash!r}: half backlash must be > 0 (m)")
        fs = float(self.static_load)
        if not np.isfinite(fs):
            raise ValueError(f"mesh.static_load = {self.static_load!r}: must be finite (N)")
        if self.te_kind not in ("unloaded", "loaded"):
            raise ValueError(f"mesh.te_kind = {self.te_kind!r}: must be 'unloaded' or 'loaded'")
        object.__setattr__(self, "n_teeth", int(self.n_teeth))
        object.__setattr__(self, "stiffness", k)
        object.__setattr__(self, "te", te)
        object.__setattr__(self, "backlash", b)
        object.__setattr__(self, "static_load", fs)
        phase = 2 * np.pi * np.arange(4096) / 4096
        kmin = float(np.min(_mesh_signal(k, phase)))
        if kmin <= 0:
            raise ValueError(
                f"mesh.stiffness: k_m(t) reaches {kmin:.4g} N/m over the mesh period; "
                "must stay > 0")

    @property
    def mean_stiffness(self) -> float:
        """Mean mesh stiffness k_m bar (N/m)."""
        return float(self.stiffness[0].real)

    @property
    def max_harmonic(self) -> int:
        """Largest mesh harmonic in stiffness or te."""
        return max(list(self.stiffness) + list(self.te) + [0])

    def stiffness_at(self, mesh_phase: np.ndarray) -> np.ndarray:
        """k_m (N/m) at mesh phase ``Z Omega t`` (rad)."""
        return _mesh_signal(self.stiffness, np.asarray(mesh_phase, dtype=float))

    def error_at(self, mesh_phase: np.ndarray) -> np.ndarray:
        """Unloaded transmission error e (m) at mesh phase ``Z Omega t`` (rad)."""
        ph = np.asarray(mesh_phase, dtype=float)
        e = _mesh_signal(self.te, ph)
        if self.te_kind == "loaded":
            e = e - self.static_load / self.stiffness_at(ph)   # eq. (12)
        return e


@dataclass(frozen=True)
class Excitation:
    """External forcing ``f(t) = Re sum_k (F_k + Omega^2 U_k) exp(i k Omega t)``.

    Parameters
    ----------
    n_dof
        Number of coordinates n.
    constant
        {shaft order k >= 0: complex (n,) vector F_k} (N); k = 0 is the static
        load (must be real).
    omega_squared
        {shaft order k: complex (n,) vector U_k} (N s^2) for loads growing with
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
                if isinstance(key, bool) or int(key) != key or key < 0:
                    raise ValueError(f"excitation.{name} key = {key!r}: must be a shaft order >= 0")
                v = np.asarray(vec, dtype=complex).ravel()
                if v.shape != (n,):
                    raise ValueError(
                        f"excitation.{name}[{key}] shape = {np.shape(vec)}: must be ({n},)")
                _finite(f"excitation.{name}[{key}]", v)
                if key == 0 and np.any(v.imag != 0):
                    raise ValueError(f"excitation.{name}[0]: the static part must be real")
                out[int(key)] = v
            object.__setattr__(self, name, out)
        object.__setattr__(self, "n_dof", int(n))
