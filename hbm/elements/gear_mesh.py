"""The gear-mesh element: Kahraman-Singh dead zone with time-varying mesh stiffness and a
loaded or unloaded transmission error (eq. 12-16).

Along the line of action ``g`` (eq. 11) the mesh deflection is ``Delta = g^T q``, the
approach net of the unloaded transmission error ``p = Delta - e(t)``, and the force the
dead-zone law of eq. (13) with the mesh stiffness ``k_m(t)``
(:mod:`hbm.elements.contact_law`). Stiffness and transmission error are Fourier series of
the mesh frequency ``Z rho Omega`` (Z teeth on a gear turning at ``rho Omega``), or, with
``cycles = c > 1``, of ``Z rho Omega / c``: parameters that repeat only every c mesh
periods (pitch deviations of the teeth: the hunting period of the pair, whose harmonics
are the mesh harmonics and their shaft-order sidebands).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any

import numpy as np

from ..basis import as_ratio
from .base import Element, ElementStiffness, EventTest, KinkCorrection, Statistic, check_direction
from .contact_law import (
    dead_zone,
    dead_zone_stiffness,
    impacts_per_mesh_period,
    in_contact_fraction,
    kink_correction,
    refined_minimum,
)
from .registry import register

__all__ = ["GearMesh", "MeshSamples"]


def harmonic_dict(name: str, d, allow_empty: bool = False) -> dict[int, complex]:
    """``{mesh harmonic m >= 0: complex coefficient}`` validated (key 0 real)."""
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


def mesh_signal(coeffs: dict[int, complex], phase: np.ndarray) -> np.ndarray:
    """``Re sum_m c_m exp(i m phase)`` on the mesh phase samples (rad)."""
    x = np.zeros_like(phase)
    for m, c in coeffs.items():
        x += (c * np.exp(1j * m * phase)).real
    return x


@dataclass(frozen=True)
class MeshSamples:
    """A mesh's parameters on a grid: stiffness ``k`` (N/m) and unloaded transmission
    error ``e`` (m)."""

    k: np.ndarray
    e: np.ndarray


@register
@dataclass(frozen=True, eq=False)
class GearMesh(Element):
    """Kahraman-Singh dead-zone mesh with time-varying stiffness (eq. 12-16).

    Parameters
    ----------
    direction
        (n,) the line of action in the system's coordinates (eq. 11):
        ``Delta = direction^T q`` (m).
    n_teeth
        Tooth count Z of the gear turning at ``speed_ratio * Omega`` (mesh frequency
        ``Z speed_ratio Omega``).
    stiffness
        {mesh harmonic m: complex coefficient} (N/m) with
        ``k_m(t) = Re sum_m k_m exp(i m Z rho Omega t)``; key 0 is the real mean > 0.
    te
        {m: coefficient} (m) of the transmission error, same convention.
        ``te_kind="unloaded"``: e(t) itself; ``"loaded"``: the loaded static
        transmission error q_s(t) under ``static_load``, and
        ``e(t) = q_s(t) - F_s / k_m(t)`` (eq. 12).
    backlash
        Half backlash b (m), > 0.
    static_load
        Transmitted static load F_s (N) used by ``te_kind="loaded"``.
    speed_ratio
        Speed of that gear over the reference speed Omega, exact (default 1).
    name
        A label (outputs, messages).
    phase
        Mesh phase at t = 0 (rad): the stiffness and TE at time t are those at the mesh
        phase ``Z rho Omega t + phase`` (two meshes on one gear: their relative phasing
        from the geometry, :func:`gears.train.mesh_phase`; default 0).
    cycles
        Mesh periods over which stiffness and TE repeat (default 1): their keys are
        harmonics of ``Z rho Omega / cycles`` (the base frequency); with pitch deviations
        the hunting period of the pair in mesh periods (:attr:`gears.LtcaCase.periods`).
        The statistics still count impacts per mesh period.
    """

    kind = "gear_mesh"
    statistics = (Statistic("mesh_load_std", "N"), Statistic("mesh_load_max", "N"),
                  Statistic("contact", integer=True), Statistic("contact_loss_fraction"),
                  Statistic("impacts_per_mesh_period", temporal=True),
                  Statistic("margin_active", "m"), Statistic("margin_reverse", "m"),
                  Statistic("ipp", integer=True, per_period=True, temporal=True))
    # margin_active > 0: permanent contact on the driving flank, its sign is phi_GR of
    # eq. (30); margin_reverse > 0: the back flank is hit
    tests = (EventTest("active", "margin_active", onset_positive=False),
             EventTest("reverse", "margin_reverse", onset_positive=True))

    direction: np.ndarray
    n_teeth: int
    stiffness: dict
    te: dict = field(default_factory=dict)
    backlash: float = 0.0
    static_load: float = 0.0
    te_kind: str = "unloaded"
    speed_ratio: Fraction = Fraction(1)
    name: str = "gear mesh"
    phase: float = 0.0
    cycles: int = 1

    def __post_init__(self) -> None:
        object.__setattr__(self, "direction", check_direction("mesh", self.direction))
        z = self.n_teeth
        if isinstance(z, bool) or int(z) != z or z < 1:
            raise ValueError(f"mesh.n_teeth = {self.n_teeth!r}: must be an integer >= 1")
        k = harmonic_dict("mesh.stiffness", self.stiffness)
        if 0 not in k or not k[0].real > 0:
            raise ValueError(f"mesh.stiffness[0] = {k.get(0)!r}: the mean stiffness must be > 0")
        te = harmonic_dict("mesh.te", self.te, allow_empty=True)
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
        object.__setattr__(self, "speed_ratio", as_ratio(self.speed_ratio, "mesh.speed_ratio"))
        if not isinstance(self.name, str) or not self.name:
            raise ValueError(f"mesh.name = {self.name!r}: must be a non-empty string")
        if isinstance(self.phase, bool) or not np.isfinite(float(self.phase)):
            raise ValueError(f"mesh.phase = {self.phase!r}: must be a finite angle (rad)")
        object.__setattr__(self, "phase", float(self.phase))
        c = self.cycles
        if isinstance(c, bool) or int(c) != c or c < 1:
            raise ValueError(f"mesh.cycles = {self.cycles!r}: must be an integer >= 1 (mesh "
                             "periods over which stiffness and TE repeat)")
        object.__setattr__(self, "cycles", int(c))
        n_check = max(4096, 16 * max(list(k) + list(te) + [0]))
        phase = 2 * np.pi * np.arange(n_check) / n_check
        kmin = float(np.min(mesh_signal(k, phase)))
        if kmin <= 0:
            raise ValueError(
                f"mesh.stiffness: k_m(t) reaches {kmin:.4g} N/m over its period; "
                "must stay > 0")

    # ------------------------------------------------------------------ parameters
    @property
    def mean_stiffness(self) -> float:
        """Mean mesh stiffness k_m bar (N/m)."""
        return float(self.stiffness[0].real)

    @property
    def linear_stiffness(self) -> float:
        """The mean mesh stiffness, moved into the linear operator (eq. 17)."""
        return self.mean_stiffness

    @property
    def base_ratio(self) -> Fraction:
        """Base frequency of the parameters over Omega: the mesh frequency ``Z rho``, or
        ``Z rho / cycles``."""
        if self.cycles == 1:
            return self.n_teeth * self.speed_ratio
        return self.n_teeth * self.speed_ratio / self.cycles

    @property
    def sub_periods(self) -> int:
        """Mesh periods per base period (``cycles``)."""
        return self.cycles

    @property
    def max_harmonic(self) -> int:
        """Largest harmonic of the base frequency in stiffness or te."""
        return max(list(self.stiffness) + list(self.te) + [0])

    @property
    def phase_offset(self) -> float:
        """:attr:`phase` on the base phase (``phase / cycles``, rad)."""
        return self.phase if self.cycles == 1 else self.phase / self.cycles

    @property
    def parameter_harmonics(self) -> tuple[int, ...]:
        return tuple(sorted(set(self.stiffness) | set(self.te)))

    def stiffness_at(self, mesh_phase: np.ndarray) -> np.ndarray:
        """k_m (N/m) at base phase ``Z rho Omega t / cycles`` (rad; the mesh phase when
        ``cycles = 1``)."""
        return mesh_signal(self.stiffness, np.asarray(mesh_phase, dtype=float))

    def error_at(self, mesh_phase: np.ndarray) -> np.ndarray:
        """Unloaded transmission error e (m) at base phase ``Z rho Omega t / cycles``
        (rad)."""
        ph = np.asarray(mesh_phase, dtype=float)
        e = mesh_signal(self.te, ph)
        if self.te_kind == "loaded":
            e = e - self.static_load / self.stiffness_at(ph)   # eq. (12)
        return e

    def sample(self, phase: np.ndarray) -> MeshSamples:
        """Stiffness and TE at the base phases ``phase`` (rad), shifted by the mesh phase
        :attr:`phase` (:attr:`phase_offset` on the base phase)."""
        if self.phase:
            phase = phase + self.phase_offset
        return MeshSamples(self.stiffness_at(phase), self.error_at(phase))

    # ------------------------------------------------------------------ force
    def force(self, delta: np.ndarray, samples: MeshSamples, law: float = 1.0,
              corrected: bool = True, stiffness: bool = True
              ) -> tuple[np.ndarray, ElementStiffness | None]:
        """AFT samples of ``f' = f_LoA - k_bar Delta`` (eq. 13) and of ``d f'/d Delta``.

        ``law`` = 1 is the dead zone; 0 the linear contact law ``k_m (p - b)``
        (permanent active contact); values in between blend the two (homotopy).
        ``corrected``: the samples of the dead-zone force carry the sub-sample kink
        correction (T.13a, :func:`hbm.elements.contact_law.kink_correction`) that makes
        them C1 in the unknowns.
        """
        k, b = samples.k, self.backlash
        p = delta - samples.e
        if law == 0.0 or not corrected:
            kinks = KinkCorrection.none(p.shape)
        else:
            kinks = kink_correction(p, k, b)
        if law == 0.0:
            f = k * (p - b)
            s = k
        else:
            f = dead_zone(p, k, b) + kinks.values
            s = dead_zone_stiffness(p, k, b)
            if law != 1.0:
                f = law * f + (1.0 - law) * k * (p - b)
                s = law * s + (1.0 - law) * k
                kinks = kinks.scaled(law)
        kbar = self.mean_stiffness
        return f - kbar * delta, (ElementStiffness(s - kbar, kinks) if stiffness else None)

    def load(self, delta: np.ndarray, samples: MeshSamples, corrected: bool = False
             ) -> np.ndarray:
        """``f_LoA`` (N, eq. 13) at the samples; ``corrected``: plus the sub-sample kink
        correction of the AFT (T.13a)."""
        p = delta - samples.e
        f = dead_zone(p, samples.k, self.backlash)
        if corrected:
            f = f + kink_correction(p, samples.k, self.backlash).values
        return f

    def load_stiffness(self, delta: np.ndarray, samples: MeshSamples) -> np.ndarray:
        return dead_zone_stiffness(delta - samples.e, samples.k, self.backlash)

    def time_force(self):
        """``f_LoA(delta, phase)`` in scalar arithmetic (eq. 12-13)."""
        k_coef = list(self.stiffness.items())
        te_coef = list(self.te.items())
        loaded = self.te_kind == "loaded"
        fs = self.static_load
        b = self.backlash
        offset = self.phase_offset

        def f(delta: float, ph: float) -> float:
            if offset:
                ph = ph + offset
            km = sum((c * np.exp(1j * mi * ph)).real for mi, c in k_coef)
            e = sum((c * np.exp(1j * mi * ph)).real for mi, c in te_coef)
            if loaded:
                e -= fs / km                                                # eq. (12)
            p = delta - e
            return km * (p - b) if p > b else km * (p + b) if p < -b else 0.0   # eq. (13)
        return f

    def step_stiffness(self, delta: np.ndarray, samples: MeshSamples) -> np.ndarray:
        """Mean of ``s'(t) = d f'/d Delta`` over each step between the samples (N/m).

        eq. (13) differentiated: ``k_m`` where a flank is loaded (``p > b`` or
        ``p < -b``), 0 in the backlash, minus ``k_bar``; the fraction of a step in
        contact from the linear interpolation of the gap ``p``.
        """
        gap, k, b = delta - samples.e, samples.k, self.backlash
        p1, k1 = np.roll(gap, -1), np.roll(k, -1)
        frac = in_contact_fraction(gap, p1, b) + in_contact_fraction(-gap, -p1, b)
        return 0.5 * (k + k1) * frac - self.mean_stiffness

    # ------------------------------------------------------------------ measures
    def measure(self, delta: np.ndarray, samples: MeshSamples, periods: int
                ) -> dict[str, Any]:
        """Contact classification, margins and mesh-load statistics over one period.

        ``mesh_load_std``, ``mesh_load_max``: of f_LoA in time (N); ``contact``: 0
        permanent contact, 1 single-sided impacts, 2 double-sided impacts;
        ``contact_loss_fraction``: of the period with ``|Delta - e| <= b``;
        ``impacts_per_mesh_period``: mean re-contacts per mesh period; ``margin_active``
        ``min_t (Delta - e - b)`` (m, > 0: permanent active contact, phi_GR of eq. 30);
        ``margin_reverse`` ``max_t (e - Delta - b)`` (m, > 0: the reverse flank is hit);
        ``ipp``: impacts in each mesh period along the fundamental period (``periods``
        base periods of ``cycles`` mesh periods each; per base period when the samples
        do not split evenly into mesh periods).
        """
        b = self.backlash
        p = delta - samples.e
        f = dead_zone(p, samples.k, b)
        act = p > b
        rev = p < -b
        loss = ~(act | rev)
        touch_a, touch_r = bool(act.any()), bool(rev.any())
        if not loss.any():
            contact = 0
        elif touch_a and touch_r:
            contact = 2
        else:
            contact = 1
        mesh_periods = periods * self.cycles
        if loss.shape[-1] % mesh_periods:
            mesh_periods = periods
        ipp = impacts_per_mesh_period(loss, mesh_periods)
        return {"mesh_load_std": float(np.std(f)), "mesh_load_max": float(np.max(f)),
                "contact": contact, "contact_loss_fraction": float(np.mean(loss)),
                "impacts_per_mesh_period": float(np.mean(ipp)),
                "margin_active": refined_minimum(p - b),
                "margin_reverse": -refined_minimum(p + b), "ipp": ipp.astype(int)}

    def signals(self, delta: np.ndarray, samples: MeshSamples) -> dict[str, np.ndarray]:
        """``gap_active = b + e(t)`` (contact on the active flank when Delta exceeds it),
        ``gap_reverse = e(t) - b`` (reverse flank when Delta is below it), ``stiffness``
        k_m(t)."""
        b = self.backlash
        return {"gap_active": b + samples.e, "gap_reverse": samples.e - b,
                "stiffness": samples.k}

    def static_scale(self, samples: MeshSamples, n: int) -> np.ndarray:
        """``|e(t)| + b``: the equilibrium lies within the backlash about the TE or beyond."""
        return np.abs(samples.e) + self.backlash

    def scale(self, samples: MeshSamples) -> float:
        """Largest of the backlash, the TE amplitude and the static load over ``k_bar``."""
        e = samples.e
        te_amp = 0.5 * (np.max(e) - np.min(e)) if e.size else 0.0
        return max(self.backlash, te_amp, abs(self.static_load) / self.mean_stiffness)
