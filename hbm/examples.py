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

__all__ = ["Geared3", "TwoStage", "modal_damping", "synthetic_rom"]

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


@dataclass
class TwoStage:
    """Lumped torsional two-stage reducer: three shafts (inertias J1, J2, J3, rotations
    theta_i in each shaft's own sense of rotation), two dead-zone meshes with their own
    TVMS, unloaded TE and backlash (docs/hbm.md, "Several base frequencies").

    Gear 1 (``teeth[0]``) on the input shaft drives gear 2 (``teeth[1]``) on the
    intermediate shaft, gear 3 (``teeth[2]``) there drives gear 4 (``teeth[3]``) on the
    output shaft: ``Delta_1 = rb1 theta1 - rb2 theta2``, ``Delta_2 = rb3 theta2 -
    rb4 theta3``. The input torque drives, the output torque balances it; no shaft is
    restrained (the rigid rotation of the train is unloaded, dropped at zero frequency).
    Modal damping ``zeta`` in the modes of ``sum_e k_bar_e g_e g_e^T`` (eq. 17-19).
    Mesh e: ``k_e(phi) = k_bar (1 + a cos phi)``, ``e_e(phi) = te cos(phi)`` at its mesh phase
    ``phi = Z rho Omega t + phase_e``; ``shaft_forcing``: torque ripples ``{shaft index:
    (order, amplitude N m)}`` at shaft orders of the input (0) or output (2) shaft.
    """

    teeth: tuple[int, int, int, int] = (20, 30, 15, 45)
    module: float = 3e-3
    inertias: tuple[float, float, float] = (2e-3, 4e-3, 3e-2)
    stiffness: tuple[float, float] = (3e8, 3e8)
    variation: tuple[float, float] = (0.2, 0.2)
    te: tuple[float, float] = (4e-6, 4e-6)
    backlash: tuple[float, float] = (10e-6, 10e-6)
    torque: float = 50.0
    zeta: float = 0.05
    phases: tuple[float, float] = (0.0, 0.0)
    shaft_forcing: tuple = ()

    @property
    def base_radii(self) -> np.ndarray:
        """r_b of the four gears (m), pressure angle 20 degrees."""
        return 0.5 * self.module * np.asarray(self.teeth, dtype=float) * np.cos(np.pi / 9)

    @property
    def speeds(self) -> tuple:
        """Shaft speeds over the input's, exact: (1, Z1/Z2, Z1 Z3/(Z2 Z4))."""
        from fractions import Fraction

        z1, z2, z3, z4 = self.teeth
        return (Fraction(1), Fraction(z1, z2), Fraction(z1 * z3, z2 * z4))

    @property
    def mesh_ratios(self) -> tuple:
        """Mesh frequencies over Omega: (Z1, Z3 Z1/Z2)."""
        return (self.teeth[0] * self.speeds[0], self.teeth[2] * self.speeds[1])

    @property
    def directions(self) -> tuple[np.ndarray, np.ndarray]:
        rb = self.base_radii
        return np.array([rb[0], -rb[1], 0.0]), np.array([0.0, rb[2], -rb[3]])

    @property
    def static_loads(self) -> tuple[float, float]:
        """Transmitted mesh forces (N): T / rb1 and that times rb2 / rb3."""
        rb = self.base_radii
        f1 = self.torque / rb[0]
        return f1, f1 * rb[1] / rb[2]

    def system(self) -> LinearSystem:
        m = np.diag(np.asarray(self.inertias, dtype=float))
        kp = sum(k * np.outer(g, g) for k, g in zip(self.stiffness, self.directions,
                                                     strict=True))
        return LinearSystem(m, modal_damping(m, kp, self.zeta), np.zeros((3, 3)))

    def meshes(self) -> list[GearMesh]:
        out = []
        for e, (g, z, rho) in enumerate(zip(self.directions, (self.teeth[0], self.teeth[2]),
                                            self.speeds[:2], strict=True)):
            k = self.stiffness[e]
            out.append(GearMesh(direction=g, n_teeth=z,
                                stiffness={0: k, 1: k * self.variation[e]},
                                te={1: self.te[e]}, backlash=self.backlash[e],
                                speed_ratio=rho, name=f"mesh {e + 1}",
                                phase=self.phases[e]))
        return out

    def excitation(self) -> Excitation:
        """The driving torque and its balancing load, plus the shaft torque ripples
        (keys: shaft orders times the shaft's speed)."""
        rb = self.base_radii
        load = self.torque * rb[1] * rb[3] / (rb[0] * rb[2])
        const = {0: np.array([self.torque, 0.0, -load])}
        for shaft, order, amp in self.shaft_forcing:
            vec = np.zeros(3)
            vec[shaft] = amp
            key = order * self.speeds[shaft]
            const[key] = const.get(key, np.zeros(3)) + vec
        return Excitation(3, constant=const)

    def problem(self, harmonics, **kwargs) -> HBMProblem:
        """The HBM problem on the basis ``harmonics`` (a HarmonicSet or a TorusBasis)."""
        return HBMProblem(self.system(), self.meshes(), self.excitation(), harmonics,
                          **kwargs)

    def resonance_rpm(self) -> np.ndarray:
        """Speeds (rpm) where mesh 1's frequency meets each elastic natural frequency."""
        s = self.system()
        kp = sum(k * np.outer(g, g) for k, g in zip(self.stiffness, self.directions,
                                                     strict=True))
        w2 = sla.eigh(kp, s.M, eigvals_only=True)
        w = np.sqrt(w2[w2 > 1e-6 * w2.max()])
        return w / float(self.mesh_ratios[0]) / RPM_TO_RAD_S
