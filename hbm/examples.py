"""Small synthetic models for tests, benchmarks and examples (SI units).

* :class:`Geared3`: a three-DOF geared model (two gear rotations and the
  bearing of gear 1 along the line of action) with soft shafts and bearing
  against a mesh of any stiffness, optionally written in other length and
  force units (the same physics, for unit-invariance checks);
* :func:`synthetic_rom`: a Craig-Bampton-like reduced model, 12 gear DOF in the
  ``q_c`` order of eq. (11) plus ``n_cm`` fixed-interface modes with
  well-separated or clustered frequencies.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from .basis import HarmonicSet
from .elements import GearMesh
from .problem import HBMProblem
from .system import Excitation, LinearSystem
from .units import RPM_TO_RAD_S

__all__ = ["Geared3", "modal_damping", "synthetic_rom"]

RB1, RB2 = 0.047, 0.047          # base radii (m)
J1, J2, M1 = 1.5e-3, 1.5e-3, 1.2  # gear inertias (kg m^2), gear-1 mass (kg)
Z = 20


def modal_damping(m: np.ndarray, k: np.ndarray, zeta) -> np.ndarray:
    """C = M Phi diag(2 zeta_j w_j) Phi^T M in the modes of (K, M) (eq. 19)."""
    w2, phi = sla.eigh(k, m)
    w = np.sqrt(np.clip(w2, 0, None))
    return m @ phi @ np.diag(2 * np.broadcast_to(zeta, w.shape) * w) @ phi.T @ m


@dataclass
class Geared3:
    """Three-DOF geared model: (theta1, theta2, y), y the gear-1 bearing along the LoA.

    Delta = rb1 theta1 + rb2 theta2 + y. Soft shafts (kt1, kt2 to ground, N m/rad)
    and bearing (kb, N/m) against a mesh of mean stiffness km (N/m).
    """

    km: float = 1e8
    zeta: float = 0.05
    b: float = 10e-6
    torque: float = 47.0           # N m on gear 1 (~1000 N mesh load)
    te: float = 1e-6               # first-harmonic TE amplitude (m)
    k_ratio: float = 0.1           # first-harmonic stiffness fluctuation / km
    kb: float = 1e5
    kt1: float = 50.0
    kt2: float = 2e3
    harmonics: int = 20
    n_time: int | None = None
    condensation: str = "loa"
    length_unit: float = 1.0       # metres per model length unit
    force_unit: float = 1.0        # newtons per model force unit

    def matrices(self):
        m = np.diag([J1, J2, M1])
        k = np.diag([self.kt1, self.kt2, self.kb])
        g = np.array([RB1, RB2, 1.0])
        c = modal_damping(m, k + self.km * np.outer(g, g), self.zeta)
        return m, c, k, g

    def problem(self) -> HBMProblem:
        m, c, k, g = self.matrices()
        ell, phi = self.length_unit, self.force_unit
        d = np.array([1.0, 1.0, ell])                 # q = D q'
        s = np.outer(d, d) / (phi * ell)              # M' = D M D / (phi ell)
        f0 = np.array([self.torque, 0.0, 0.0]) * d / (phi * ell)
        system = LinearSystem(m * s, c * s, k * s)
        kk = self.km * ell / phi
        mesh = GearMesh(g * d / ell, Z, {0: kk, 1: self.k_ratio * kk} if self.k_ratio else
                        {0: kk}, te={1: 1j * self.te / ell} if self.te else {},
                        backlash=self.b / ell)
        exc = Excitation(3, constant={0: f0})
        hs = HarmonicSet.build(Z, self.harmonics, n_time=self.n_time)
        return HBMProblem(system, [mesh], exc, hs, self.condensation)

    def mesh_rpm(self) -> float:
        """Speed (rpm) whose mesh frequency is the mode of largest mesh energy."""
        m, _, k, g = self.matrices()
        w2, phi = sla.eigh(k + self.km * np.outer(g, g), m)
        energy = self.km * (g @ phi) ** 2 / w2
        return float(np.sqrt(w2[np.argmax(energy)]) / Z / RPM_TO_RAD_S)


def synthetic_rom(n_cm: int, clustered: bool, zeta: float = 0.02, km: float = 5e8,
                  harmonics: int = 8, seed: int = 0, modal: bool = True) -> HBMProblem:
    """Craig-Bampton-like ROM: 12 gear DOF (q_c order of eq. 11) + n_cm modal amplitudes.

    ``M = [[M_cc, B], [B^T, I]]`` with ``M_cc = diag + B B^T`` (positive definite),
    ``K = blockdiag(K_cc, diag(w_j^2))``. Fixed-interface frequencies from 200 Hz
    to 20 kHz (geometric) or, ``clustered``, 30 groups of near-coincident
    frequencies (relative spread 1e-7) between 300 Hz and 5 kHz. ``modal``:
    the damping of eq. (19) in the coupled modes; else a block damping that is
    not diagonal in them (dense solves).
    """
    rng = np.random.default_rng(seed)
    n = 12 + n_cm
    if clustered:
        centres = np.geomspace(300.0, 5000.0, 30)
        f = np.repeat(centres, int(np.ceil(n_cm / 30)))[:n_cm]
        f = f * (1 + 1e-7 * rng.standard_normal(n_cm))
    else:
        f = np.geomspace(200.0, 2e4, n_cm)
    w = 2 * np.pi * np.sort(f)
    mc = np.array([1.2, 1.2, 1.2, 1e-3, 1e-3, 1.5e-3] * 2)
    bmat = 0.05 * rng.standard_normal((12, n_cm)) * np.sqrt(mc)[:, None] / np.sqrt(n_cm)
    m = np.zeros((n, n))
    m[:12, :12] = np.diag(mc) + bmat @ bmat.T
    m[:12, 12:] = bmat
    m[12:, :12] = bmat.T
    m[12:, 12:] = np.eye(n_cm)
    k = np.zeros((n, n))
    k[:12, :12] = np.diag([2e8, 2e8, 5e8, 1e6, 1e6, 5e4] * 2)
    k[12:, 12:] = np.diag(w ** 2)
    g = np.zeros(n)
    g[[1, 5, 7, 11]] = [1.0, RB1, -1.0, RB2]
    if modal:
        c = modal_damping(m, k + km * np.outer(g, g), zeta)
    else:
        c = np.zeros((n, n))
        c[12:, 12:] = np.diag(2 * zeta * w)
        c[:12, :12] = 2 * zeta * np.sqrt(np.diag(k[:12, :12]) * mc) * np.eye(12)
    f0 = np.zeros(n)
    f0[5] = 47.0                                          # torque on gear 1 (N m)
    f0[11] = 47.0 * RB2 / RB1                             # reaction torque on gear 2
    mesh = GearMesh(g, Z, {0: km, 1: 0.1 * km}, te={1: 2e-6j}, backlash=10e-6)
    exc = Excitation(n, constant={0: f0})
    return HBMProblem(LinearSystem(m, c, k), [mesh], exc, HarmonicSet.build(Z, harmonics),
                      "loa")
