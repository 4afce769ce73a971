"""The HBM problem: shared linear data, AFT mesh force, Newton solve at one speed.

Equation (eq. 4, 14, 21):  M q'' + C q' + K q + G f_LoA(G^T q, t) = f_ex(t).

Internally the mean mesh stiffness is moved to the linear part (the operator of
eq. 17), which makes the static dynamic stiffness regular even when K has
rigid-body modes (a free gear pair):

    K' = K + k_bar G G^T,      f'(Delta, t) = f_LoA(Delta, t) - k_bar Delta.

With ``Z'_k(Omega) = K' - (k w0)^2 M + i k w0 C`` (eq. 22) the harmonic balance
reads ``Z'_k q_k + G f'_k = F_k`` for every retained index k.  Which unknowns
the solver sees ("none", "gear", "loa") is decided by a condensation object
(:mod:`hbm.condensation`) that :class:`HBMProblem` delegates the residual, the
Jacobians, the scales and the recovery of the coordinates to.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from . import fixed_speed
from .condensation import CONDENSATIONS, Condensation, make_condensation
from .contact import (
    ContactStiffness,
    KinkCorrection,
    dead_zone,
    dead_zone_stiffness,
    kink_correction,
)
from .fixed_speed import RPM_TO_RAD_S, Point
from .harmonics import HarmonicSet
from .krylov import Preconditioners
from .model import Excitation, GearMesh, LinearSystem
from .modes import length_scale, modes
from .newton import COND_WARN, ConvergenceError, solve_checked

logger = logging.getLogger(__name__)

__all__ = ["HBMProblem", "Point", "ConvergenceError", "RPM_TO_RAD_S", "COND_WARN", "solve_checked"]

LINEAR_SOLVERS = ("auto", "dense", "krylov")
# "corrected": samples of the dead-zone force with the sub-sample kink correction
# (T.13a, C1 in the unknowns); "sampled": the plain samples (piecewise smooth)
AFT_KINDS = ("corrected", "sampled")
# "auto": matrix-free from this many real unknowns on (loa); below, the dense LU is as
# fast (docs/hbm.md, "Linear solver")
KRYLOV_MIN = 400


@dataclass(frozen=True)
class Synthesis:
    """``synth @ x_real``: samples on a grid of ``n_time`` instants of one period, by FFT
    (:meth:`HarmonicSet.synthesize`; the dense ``aft_matrices(n_time)[0]`` without
    storing it)."""

    harmonics: HarmonicSet
    n_time: int

    def __matmul__(self, xr: np.ndarray) -> np.ndarray:
        return self.harmonics.synthesize(xr, self.n_time)


def _check_inputs(system, mesh, excitation, harmonics, condensation: str,
                  linear_solver: str, aft: str) -> None:
    """Refuse bad inputs of :class:`HBMProblem`, naming the field and its allowed values."""
    if not isinstance(system, LinearSystem):
        raise ValueError(f"problem.system = {type(system).__name__}: must be a LinearSystem")
    if not isinstance(mesh, GearMesh):
        raise ValueError(f"problem.mesh = {type(mesh).__name__}: must be a GearMesh")
    if not isinstance(excitation, Excitation):
        raise ValueError(
            f"problem.excitation = {type(excitation).__name__}: must be an Excitation")
    if not isinstance(harmonics, HarmonicSet):
        raise ValueError(
            f"problem.harmonics = {type(harmonics).__name__}: must be a HarmonicSet")
    if condensation not in CONDENSATIONS:
        raise ValueError(
            f"problem.condensation = {condensation!r}: must be 'none', 'gear' or 'loa'")
    if linear_solver not in LINEAR_SOLVERS:
        raise ValueError(f"problem.linear_solver = {linear_solver!r}: must be one of "
                         f"{', '.join(LINEAR_SOLVERS)}")
    if aft not in AFT_KINDS:
        raise ValueError(f"problem.aft = {aft!r}: must be one of {', '.join(AFT_KINDS)}")
    if linear_solver == "krylov" and condensation != "loa":
        raise ValueError("problem.linear_solver = 'krylov': needs condensation = 'loa'")
    n = system.n_dof
    if excitation.n_dof != n:
        raise ValueError(f"excitation.n_dof = {excitation.n_dof}: must equal system size {n}")
    z = mesh.n_teeth
    hs = harmonics
    if hs.fundamental == "mesh" and hs.divisor != z:
        raise ValueError(
            f"harmonics.divisor = {hs.divisor}: a mesh-fundamental set needs divisor = "
            f"n_teeth = {z}")
    if z % hs.divisor:
        raise ValueError(f"harmonics.divisor = {hs.divisor}: must divide n_teeth = {z}")


def _forcing(excitation, hs: HarmonicSet, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Forcing per harmonic index, constant and Omega^2 parts, each (nS, n) complex."""
    fc = np.zeros((hs.n_harmonics, n), dtype=complex)
    fu = np.zeros((hs.n_harmonics, n), dtype=complex)
    pos = {k: i for i, k in enumerate(hs.indices)}
    for name, arr in (("constant", fc), ("omega_squared", fu)):
        for order, vec in getattr(excitation, name).items():
            idx = hs.index_of_shaft_order(order)
            if idx is None:
                raise ValueError(
                    f"excitation.{name} order = {order}: shaft order not representable in "
                    f"the harmonic set ({hs.fundamental} fundamental, w0 = {hs.divisor} "
                    f"Omega, indices {list(hs.indices)[:12]}...)")
            arr[pos[idx]] += vec
    return fc, fu


class HBMProblem:
    """Harmonic balance of a linear system with one gear mesh.

    Parameters
    ----------
    system, mesh, excitation, harmonics
        See :class:`LinearSystem`, :class:`GearMesh`, :class:`Excitation`,
        :class:`HarmonicSet`.
    condensation
        ``"none"``, ``"gear"`` or ``"loa"`` (default).
    """

    def __init__(self, system: LinearSystem, mesh: GearMesh, excitation: Excitation,
                 harmonics: HarmonicSet, condensation: str = "loa",
                 linear_solver: str = "auto", aft: str = "corrected") -> None:
        _check_inputs(system, mesh, excitation, harmonics, condensation, linear_solver, aft)
        self.aft = aft
        n = system.n_dof
        z = mesh.n_teeth
        hs = harmonics
        self.system, self.mesh, self.excitation, self.harmonics = system, mesh, excitation, hs
        self.condensation = condensation
        self.n_dof = n
        self.mesh_step = z // hs.divisor        # harmonic index of mesh harmonic 1
        top = mesh.max_harmonic * self.mesh_step
        if 2 * top >= hs.n_time:
            raise ValueError(
                f"harmonics.n_time = {hs.n_time}: too few samples for mesh harmonic "
                f"{mesh.max_harmonic} (index {top}); need > {2 * top}")
        missing = [m for m in list(mesh.stiffness) + list(mesh.te)
                   if m * self.mesh_step not in hs.indices]
        if missing:
            logger.warning("mesh harmonics %s are not in the harmonic set; their direct "
                           "contribution is only seen through products", sorted(set(missing)))
        self.kS = np.asarray(hs.indices, dtype=float)
        self.harmonic_indices = np.asarray(hs.indices, dtype=np.int64)
        self.nS = hs.n_harmonics
        self.nr = hs.n_real

        # forcing per harmonic index (nS, n) complex
        self.Fc, self.Fu = _forcing(excitation, hs, n)

        # mesh signals on the AFT grid tau = w0 t (Omega-independent); the AFT itself is
        # by FFT (HarmonicSet.synthesize / analyse), E and A are built only on request
        self._aft: tuple | None = None
        phase = hs.time_grid() * self.mesh_step
        self.k_t = mesh.stiffness_at(phase)
        self.e_t = mesh.error_at(phase)
        self.kbar = mesh.mean_stiffness
        self.b = mesh.backlash

        g = system.G
        self.G = g
        self.Kp = system.K + self.kbar * np.outer(g, g)                 # eq. (17) operator
        # equilibration D = diag(M)^-1/2: D Z D is in 1/s^2 whatever the units of each
        # coordinate, so every dense factorisation below is done on it
        self.dof_eq = 1.0 / np.sqrt(np.diag(system.M))
        md = modes(self.Kp, system.M, system.C, g, self.Fc, self.Fu, self.dof_eq)
        self.modal, self.kp_symmetric = md.modal, md.kp_symmetric
        self.w2, self.phi, self.cj, self.gj = md.w2, md.phi, md.cj, md.gj
        self.pfc, self.pfu, self.rigid = md.pfc, md.pfu, md.rigid
        self.length_scale = length_scale(self.b, self.e_t, mesh.static_load, self.kbar, md,
                                         self.Kp, g, self.Fc[0], self.dof_eq)
        self._fine_cache: dict[int, tuple] = {}
        # matrix-free Newton matrices solved by GMRES (hbm/krylov.py) for large sets
        self.matrix_free = condensation == "loa" and (
            linear_solver == "krylov" or (linear_solver == "auto" and hs.n_real >= KRYLOV_MIN))
        self.preconditioners = Preconditioners()
        self.scheme: Condensation = make_condensation(condensation, self)

    # ------------------------------------------------------------------ setup
    def equilibrated_solve(self, z: np.ndarray, rhs: np.ndarray,
                           idx: np.ndarray | None = None) -> np.ndarray:
        """Batched ``z^-1 rhs`` for z (nS, m, m), rhs (nS, m, p), equilibrated by D.

        ``idx`` selects the coordinates of z (default all).
        """
        d = self.dof_eq if idx is None else self.dof_eq[idx]
        zt = z * d[None, :, None] * d[None, None, :]
        return d[None, :, None] * np.linalg.solve(zt, d[None, :, None] * rhs)

    # ------------------------------------------------------------------ linear parts
    def harmonic_frequencies(self, omega: float) -> tuple[np.ndarray, np.ndarray]:
        """``k w0`` (rad/s) of every retained index and its Omega-derivative ``k w0 / Omega``."""
        kd = self.kS * self.harmonics.divisor
        return kd * omega, kd

    def dynamic_stiffness(self, omega: float) -> tuple[np.ndarray, np.ndarray]:
        """Z'_k(Omega) and dZ'_k/dOmega, (nS, n, n) complex (eq. 22)."""
        s = self.system
        w, kd = self.harmonic_frequencies(omega)
        z = (self.Kp[None] - (w ** 2)[:, None, None] * s.M[None]
             + 1j * w[:, None, None] * s.C[None])
        dz = (-2.0 * w * kd)[:, None, None] * s.M[None] + 1j * kd[:, None, None] * s.C[None]
        return z, dz

    def forcing(self, omega: float) -> tuple[np.ndarray, np.ndarray]:
        """F_k(Omega) = F_c,k + Omega^2 F_u,k and its Omega-derivative, (nS, n) complex."""
        return self.Fc + omega ** 2 * self.Fu, 2.0 * omega * self.Fu

    def modal_inverse(self, omega: float) -> tuple[np.ndarray, np.ndarray]:
        """Modal receptances ``1 / (w_j^2 - (k w0)^2 + i k w0 c_j)`` and their
        Omega-derivatives, (n_modes, nS) complex (eq. 18-19).

        The static term of a rigid-body mode the mesh does not restrain is set to 0.
        Meaningful when :attr:`modal` (C diagonal in the eq. (17) modes).
        """
        w, kd = self.harmonic_frequencies(omega)
        den = np.empty((self.w2.size, w.size), dtype=complex)
        den.real = self.w2[:, None] - (w ** 2)[None, :]
        den.imag = w[None, :] * self.cj[:, None]
        zero = self.rigid & (self.kS[0] == 0)                  # harmonic 0 only
        den[zero, 0] = 1.0
        mag2 = den.real * den.real  # 1/den = conj(den)/|den|^2: half NumPy's complex division
        mag2 += den.imag * den.imag
        if not np.all(mag2):
            raise ValueError(
                f"Omega = {omega:.6g} rad/s hits an undamped natural frequency exactly")
        inv = np.conjugate(den, out=den)
        inv *= np.reciprocal(mag2, out=mag2)
        inv[zero, 0] = 0.0
        dinv = inv * inv            # -inv^2 d den/dOmega, d den/dOmega = kd (-2 w + i c_j)
        dinv *= (2.0 * w)[None, :] - 1j * self.cj[:, None]
        dinv *= kd[None, :]
        return inv, dinv

    # ------------------------------------------------------------------ nonlinear force
    @property
    def E(self) -> np.ndarray:
        """Dense synthesis matrix of the AFT grid (N, n_real); the solver uses the FFT."""
        if self._aft is None:
            self._aft = self.harmonics.aft_matrices()
        return self._aft[0]

    @property
    def A(self) -> np.ndarray:
        """Dense Galerkin analysis matrix of the AFT grid (n_real, N)."""
        if self._aft is None:
            self._aft = self.harmonics.aft_matrices()
        return self._aft[1]

    def mesh_force(self, delta_r: np.ndarray, jacobian: bool = True, law: float = 1.0):
        """AFT of f' = f_LoA - k_bar Delta (eq. 13) from the real coefficients of Delta.

        ``law`` = 1 is the dead zone; 0 the linear contact law ``k_m (p - b)``
        (permanent active contact); values in between blend the two (homotopy).
        Returns the real coefficients of f' (N) and, if asked, d f'/d Delta
        (n_real, n_real) (N/m).
        """
        ft, st = self.mesh_force_samples(delta_r, jacobian, law)
        return ft, (self.contact_matrix(st) if jacobian else None)

    def mesh_force_samples(self, delta_r: np.ndarray, stiffness: bool = True,
                           law: float = 1.0) -> tuple[np.ndarray, ContactStiffness | None]:
        """As :meth:`mesh_force`, with ``d f'/d Delta`` on the AFT grid
        (:class:`hbm.contact.ContactStiffness`) instead of the dense matrix.

        The samples of the dead-zone force carry the sub-sample kink correction (T.13a,
        :func:`hbm.contact.kink_correction`) that makes them C1 in the unknowns.
        """
        delta = self.harmonics.synthesize(delta_r)
        p = delta - self.e_t
        if law == 0.0 or self.aft == "sampled":
            kinks = KinkCorrection.none(p.size)
        else:
            kinks = kink_correction(p, self.k_t, self.b)
        if law == 0.0:
            f = self.k_t * (p - self.b)
            s = self.k_t
        else:
            f = dead_zone(p, self.k_t, self.b) + kinks.values
            s = dead_zone_stiffness(p, self.k_t, self.b)
            if law != 1.0:
                f = law * f + (1.0 - law) * self.k_t * (p - self.b)
                s = law * s + (1.0 - law) * self.k_t
                kinks = kinks.scaled(law)
        ft = self.harmonics.analyse(f - self.kbar * delta)
        return ft, (ContactStiffness(s - self.kbar, kinks) if stiffness else None)

    def contact_matrix(self, st: ContactStiffness) -> np.ndarray:
        """Real-layout matrix of ``x -> Galerkin(st.apply(x(tau)))``: the dense
        ``d f'/d Delta`` (n_real, n_real), kink blocks included."""
        out = self.multiplication_matrix(st.samples)
        kc = st.kinks
        if kc.nodes.size == 0:
            return out
        n = st.samples.size
        rows = np.stack([kc.nodes, (kc.nodes + 1) % n], axis=1)
        cols = kc.columns(n)
        nodes = np.unique(np.concatenate([rows.ravel(), cols.ravel()]))
        pr, pc = np.searchsorted(nodes, rows), np.searchsorted(nodes, cols)
        d = np.zeros((nodes.size, nodes.size))
        np.add.at(d, (pr[:, :, None], pc[:, None, :]), kc.blocks)
        e = self.harmonics.synthesis_rows(2.0 * np.pi * nodes / n)
        return out + self.harmonics.galerkin_columns(e, n) @ (d @ e)

    def multiplication_matrix(self, s: np.ndarray) -> np.ndarray:
        """Real-layout matrix of ``x -> Galerkin(s(tau) x(tau))`` on the AFT grid.

        Equal to ``A diag(s) E`` but built from the DFT of s by index gathering
        (circular convolution), O(N log N + n_real^2).
        """
        n = s.size
        sh = np.fft.fft(s) / n
        k = self.harmonic_indices
        wk = np.where(k == 0, 1.0, 2.0)[:, None]
        p = sh[(k[:, None] - k[None, 1:]) % n]
        q = sh[(k[:, None] + k[None, 1:]) % n]
        dc = np.empty((k.size, self.nr), dtype=complex)
        dc[:, 0] = wk[:, 0] * sh[k % n]
        dc[:, 1::2] = 0.5 * wk * (p + q)
        dc[:, 2::2] = 0.5j * wk * (p - q)
        return self.harmonics.to_real(dc.T).T

    # ------------------------------------------------------------------ condensation
    @property
    def n_unknowns(self) -> int:
        """Number of real unknowns of the condensation."""
        return self.scheme.n_unknowns

    @property
    def x_scale(self) -> np.ndarray:
        """Scale of each unknown (physical units): Newton works on ``u / x_scale``."""
        return self.scheme.x_scale

    @property
    def eq_scale(self) -> np.ndarray:
        """Scale of each equation (physical units): Newton works on ``R / eq_scale``."""
        return self.scheme.eq_scale

    def delta_real(self, u: np.ndarray) -> np.ndarray:
        """Real coefficients of Delta = G^T q from the unknowns."""
        return self.scheme.delta_real(u)

    def evaluate(self, u: np.ndarray, omega: float, jacobian: bool = True, law: float = 1.0):
        """Residual R(u, Omega) and, if asked, dR/du and dR/dOmega (physical units).

        loa: R in m; none/gear: R in N (per DOF, DOF-major real layout).
        ``law``: contact law, see :meth:`mesh_force`.
        """
        return self.scheme.evaluate(np.asarray(u, dtype=float), omega, jacobian, law)

    def residual(self, u: np.ndarray, omega: float) -> np.ndarray:
        """Residual (physical units) at unknowns u and shaft speed Omega (rad/s)."""
        return self.evaluate(u, omega, jacobian=False)

    def jacobian(self, u: np.ndarray, omega: float) -> tuple[np.ndarray, np.ndarray]:
        """Analytic (dR/du, dR/dOmega)."""
        _, ju, jw = self.evaluate(u, omega)
        return ju, jw

    def relative_residual(self, r: np.ndarray, u: np.ndarray) -> float:
        """``||R / eq_scale|| / max(||u / x_scale||, 1)``."""
        return float(np.linalg.norm(r / self.eq_scale)
                     / max(np.linalg.norm(u / self.x_scale), 1.0))

    # ------------------------------------------------------------------ Newton
    def initial_guess(self, omega: float) -> np.ndarray:
        """Linear response in permanent contact on the active flank (one Newton step)."""
        return fixed_speed.initial_guess(self, omega)

    def point(self, u: np.ndarray, omega: float, iterations: int = 0,
              residual: float | None = None) -> Point:
        """Wrap unknowns into a :class:`Point` (computes the residual if not given)."""
        if residual is None:
            residual = self.relative_residual(self.residual(u, omega), u)
        return Point(rpm=omega / RPM_TO_RAD_S, omega=omega, unknowns=np.array(u, dtype=float),
                     coefficients=self.harmonics.to_complex(self.delta_real(u)),
                     residual=float(residual), iterations=int(iterations))

    def solve(self, rpm: float, x0: np.ndarray | None = None, tol: float = 1e-8,
              max_iter: int = 40) -> Point:
        """Newton corrector at fixed speed with scaled unknowns and equations; on failure the
        contact-law homotopy, then damped Newton (:func:`hbm.fixed_speed.solve`).

        Parameters
        ----------
        rpm
            Shaft speed (rpm), > 0.
        x0
            Initial unknowns (default: permanent-contact linear response).
        tol
            Relative residual tolerance.

        Raises
        ------
        ConvergenceError
            If the tolerance is not reached in ``max_iter`` iterations.
        """
        return fixed_speed.solve(self, rpm, x0, tol, max_iter)

    def scaled(self, xh: np.ndarray, omega: float, jacobian: bool = True, law: float = 1.0):
        """:meth:`evaluate` on scaled unknowns ``xh = u / x_scale`` and equations
        ``R / eq_scale``: ``R_hat`` or ``(R_hat, dR_hat/dxh, dR_hat/dOmega)``.

        What Newton (here and in :mod:`hbm.continuation`) iterates on.
        """
        u = xh * self.x_scale
        if not jacobian:
            return self.evaluate(u, omega, jacobian=False, law=law) / self.eq_scale
        r, ju, jw = self.evaluate(u, omega, law=law)
        return r / self.eq_scale, self.scaled_jacobian(ju), jw / self.eq_scale

    def scaled_jacobian(self, ju):
        """``dR/du`` in scaled unknowns and equations; a matrix-free one (loa: both
        scales are the same length) is unchanged."""
        if isinstance(ju, np.ndarray):
            return ju * (self.x_scale[None, :] / self.eq_scale[:, None])
        return ju

    # ------------------------------------------------------------------ recovery
    def recover(self, point: Point | np.ndarray, omega: float | None = None) -> np.ndarray:
        """Complex Fourier coefficients of every coordinate, (n_dof, n_harmonics)."""
        if isinstance(point, Point):
            u, omega = point.unknowns, point.omega
        else:
            u = np.asarray(point, dtype=float)
            if omega is None:
                raise ValueError("recover: omega is required with raw unknowns")
        return self.scheme.recover(u, omega)

    def fine_grid(self, n_time: int) -> tuple[Synthesis, np.ndarray, np.ndarray]:
        """Synthesis operator (``synth @ x_real``), k_m and e on a grid of ``n_time``
        samples (cached)."""
        if n_time not in self._fine_cache:
            if len(self._fine_cache) > 8:
                self._fine_cache.clear()
            phase = self.harmonics.time_grid(n_time) * self.mesh_step
            self._fine_cache[n_time] = (Synthesis(self.harmonics, n_time),
                                        self.mesh.stiffness_at(phase), self.mesh.error_at(phase))
        return self._fine_cache[n_time]
