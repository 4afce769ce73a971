"""The HBM problem: residual, analytic Jacobian, condensations, Newton corrector.

Equation (eq. 4, 14, 21):  M q'' + C q' + K q + G f_LoA(G^T q, t) = f_ex(t).

Internally the mean mesh stiffness is moved to the linear part (the operator of
eq. 17), which makes the static dynamic stiffness regular even when K has
rigid-body modes (a free gear pair):

    K' = K + k_bar G G^T,      f'(Delta, t) = f_LoA(Delta, t) - k_bar Delta.

With ``Z'_k(Omega) = K' - (k w0)^2 M + i k w0 C`` (eq. 22) the harmonic balance
reads ``Z'_k q_k + G f'_k = F_k`` for every retained index k.  Condensations:

* ``"none"``: all n DOF are unknowns (DOF-major real layout, see harmonics.py).
* ``"gear"``: Schur complement onto the DOF where G != 0 (eq. 24-29).
* ``"loa"``: exact condensation onto Delta = G^T q per harmonic,
  ``Delta_k - d_k + h_k f'_k = 0`` with ``h_k = G^T Z'_k^-1 G`` and
  ``d_k = G^T Z'_k^-1 F_k``, by modal summation over the modes of eq. (17) when
  C is diagonal in them (modal damping eq. 18-19), else by a dense complex
  solve per harmonic.
"""

from __future__ import annotations

import logging
import warnings
from dataclasses import dataclass

import numpy as np

from .contact import dead_zone, dead_zone_stiffness
from .harmonics import HarmonicSet
from .model import Excitation, GearMesh, LinearSystem

logger = logging.getLogger(__name__)

__all__ = ["HBMProblem", "Point", "ConvergenceError", "RPM_TO_RAD_S", "COND_WARN", "solve_checked"]

RPM_TO_RAD_S = 2.0 * np.pi / 60.0


COND_WARN = 1e10   # 1-norm condition estimate of a Newton matrix above which we warn


class ConvergenceError(RuntimeError):
    """Newton did not reach the tolerance; carries the last relative residual
    and the condition estimate of the last Newton matrix (inf if singular)."""

    def __init__(self, message: str, residual: float = np.inf,
                 condition: float = np.nan) -> None:
        super().__init__(message)
        self.residual = residual
        self.condition = condition


def solve_checked(j: np.ndarray, rhs: np.ndarray, where: str = "Newton",
                  warn: bool = True) -> tuple[np.ndarray, float]:
    """Solve ``j x = rhs`` by LU and estimate the 1-norm condition number of ``j``.

    The estimate is LAPACK's ``gecon`` on the LU factors (O(n^2) on top of the
    factorisation).  Above :data:`COND_WARN` a warning naming ``where`` and the
    estimate is logged (when ``warn``).

    Returns
    -------
    x, condition
        The solution and the condition estimate.

    Raises
    ------
    ConvergenceError
        If the matrix is singular to working precision (zero pivot or
        condition estimate above 1/eps) or not finite.
    """
    import scipy.linalg as sla

    j = np.asarray(j, dtype=float)
    if not np.all(np.isfinite(j)):
        raise ConvergenceError(f"{where}: the Jacobian contains NaN or inf", np.inf, np.inf)
    anorm = float(np.max(np.sum(np.abs(j), axis=0))) if j.size else 0.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sla.LinAlgWarning)     # singularity is handled below
        lu, piv = sla.lu_factor(j, check_finite=False)
    diag = np.abs(np.diag(lu))
    if anorm == 0.0 or np.min(diag) == 0.0:
        raise ConvergenceError(f"{where}: singular Jacobian (zero pivot in its LU factors)",
                               np.inf, np.inf)
    gecon = sla.get_lapack_funcs("gecon", (lu,))
    rcond, _ = gecon(lu, anorm, norm="1")
    cond = float(np.inf if rcond <= 0 else 1.0 / rcond)
    if cond * np.finfo(float).eps > 1.0:
        raise ConvergenceError(f"{where}: singular Jacobian (condition estimate {cond:.2g} > "
                               f"1/eps)", np.inf, cond)
    if warn and cond > COND_WARN:
        logger.warning("%s: ill-conditioned Jacobian, condition estimate %.2g (n = %d); "
                       "the solution may lose up to %d digits", where, cond, j.shape[0],
                       int(np.log10(cond)))
    return sla.lu_solve((lu, piv), rhs, check_finite=False), cond


@dataclass
class Point:
    """A converged periodic solution at one speed.

    Attributes
    ----------
    rpm, omega
        Shaft speed (rpm) and Omega (rad/s).
    unknowns
        Real unknown vector of the problem's condensation (physical units).
    coefficients
        Complex Fourier coefficients of Delta = G^T q (m), one per index.
    residual
        Relative residual norm ``||R_hat|| / max(||x_hat||, 1)`` (scaled).
    iterations
        Newton iterations used.
    """

    rpm: float
    omega: float
    unknowns: np.ndarray
    coefficients: np.ndarray
    residual: float
    iterations: int


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
                 harmonics: HarmonicSet, condensation: str = "loa") -> None:
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
        if condensation not in ("none", "gear", "loa"):
            raise ValueError(
                f"problem.condensation = {condensation!r}: must be 'none', 'gear' or 'loa'")
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
        self._kint = np.asarray(hs.indices, dtype=np.int64)
        self.nS = hs.n_harmonics
        self.nr = hs.n_real

        # forcing per harmonic index (nS, n) complex
        self.Fc = np.zeros((self.nS, n), dtype=complex)
        self.Fu = np.zeros((self.nS, n), dtype=complex)
        pos = {k: i for i, k in enumerate(hs.indices)}
        for name, arr in (("constant", self.Fc), ("omega_squared", self.Fu)):
            for order, vec in getattr(excitation, name).items():
                idx = hs.index_of_shaft_order(order)
                if idx is None:
                    raise ValueError(
                        f"excitation.{name} order = {order}: shaft order not representable in "
                        f"the harmonic set ({hs.fundamental} fundamental, w0 = {hs.divisor} "
                        f"Omega, indices {list(hs.indices)[:12]}...)")
                arr[pos[idx]] += vec

        # AFT matrices and mesh signals on the grid tau = w0 t (Omega-independent)
        self.E, self.A = hs.aft_matrices()
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
        self._setup_modes()
        self._setup_scales()
        self._fine_cache: dict[int, tuple] = {}
        self._lin_cache: tuple = (None, None)

    # ------------------------------------------------------------------ setup
    def _setup_modes(self) -> None:
        import scipy.linalg as sla

        s = self.system
        d = self.dof_eq
        dd = np.outer(d, d)
        w2, phi = sla.eigh(0.5 * (self.Kp + self.Kp.T) * dd, s.M * dd)
        phi = d[:, None] * phi                                    # mass-normalised modes
        top = max(np.max(np.abs(w2)), 1e-300)
        if np.min(w2) < -1e-9 * top:
            raise ValueError(
                f"system.K: K + k_bar G G^T has a negative eigenvalue {np.min(w2):.3g}; "
                "the linear model must be positive semi-definite")
        w2 = np.clip(w2, 0.0, None)
        cm = phi.T @ s.C @ phi
        diag = np.diag(cm).copy()
        off = cm - np.diag(diag)
        cscale = max(np.max(np.abs(diag)), np.sqrt(top) * 1e-300, 1e-300)
        self.modal = bool(np.max(np.abs(off), initial=0.0) <= 1e-9 * cscale)
        self.kp_symmetric = bool(np.allclose(self.Kp * dd, (self.Kp * dd).T, rtol=0,
                                             atol=1e-12 * top))
        if not self.kp_symmetric:
            self.modal = False
        self.w2, self.phi, self.cj = w2, phi, diag
        self.gj = phi.T @ self.G
        self.pfc = phi.T @ self.Fc.T        # (n_modes, nS)
        self.pfu = phi.T @ self.Fu.T
        gn = np.linalg.norm(self.gj)
        rigid = w2 <= 1e-12 * top
        self.rigid = rigid & (np.abs(self.gj) <= 1e-12 * gn)
        if np.any(rigid & ~self.rigid):
            raise ValueError("system: a rigid-body mode of K + k_bar G G^T moves the mesh")
        if np.any(self.rigid):
            f0 = np.abs(self.pfc[self.rigid, 0]) + np.abs(self.pfu[self.rigid, 0])
            fscale = np.linalg.norm(self.Fc[0]) + np.linalg.norm(self.Fu[0]) + 1e-300
            if np.any(f0 > 1e-9 * fscale):
                raise ValueError(
                    "excitation.constant[0]: the static load drives a rigid-body mode that the "
                    "mesh does not restrain (no steady state)")
            if not self.modal and self.condensation != "none":
                raise ValueError(
                    "system: K + k_bar G G^T is singular and C is not modal; use a modal damping "
                    "or restrain the rigid-body modes")
        if self.condensation == "gear":
            nl = np.flatnonzero(self.G != 0.0)
            self.nl = nl
            self.ln = np.setdiff1d(np.arange(self.n_dof), nl)
            if self.ln.size:
                kll = (self.Kp * dd)[np.ix_(self.ln, self.ln)]
                if np.linalg.cond(kll) > 1e13:
                    raise ValueError(
                        "problem.condensation = 'gear': the stiffness of the DOF off the mesh "
                        "is singular (a rigid-body mode the mesh does not restrain); use 'loa' "
                        "with modal damping or 'none'")
        if not self.modal and self.condensation == "loa":
            logger.info("damping is not modal in the eq. (17) modes: dense solve per harmonic")

    def _setup_scales(self) -> None:
        b = self.b
        te_amp = 0.5 * (np.max(self.e_t) - np.min(self.e_t)) if self.e_t.size else 0.0
        keep = ~self.rigid
        static = 0.0
        if self.modal and np.any(keep):
            static = abs(float(np.sum(self.gj[keep] * self.pfc[keep, 0].real / self.w2[keep])))
        elif np.any(self.Fc[0] != 0):
            # static mesh deflection under the mean load, whatever the damping
            d = self.dof_eq
            x = d * np.linalg.lstsq(self.Kp * np.outer(d, d), d * self.Fc[0].real,
                                    rcond=None)[0]
            static = abs(float(self.G @ x))
        L = max(b, te_amp, abs(self.mesh.static_load) / self.kbar, static)
        self.length_scale = float(L)
        if self.condensation == "loa":
            self.x_scale = np.full(self.nr, L)
            self.eq_scale = np.full(self.nr, L)
            self.n_unknowns = self.nr
            return
        if self.condensation == "none":
            kr, dr = self.Kp, self.dof_eq
        else:
            kr, dr = self._static_schur(), self.dof_eq[self.nl]
        m = kr.shape[0]
        # diagonal static compliance, from the equilibrated matrix (unit-independent)
        comp = dr ** 2 * np.abs(np.diag(np.linalg.pinv(kr * np.outer(dr, dr))))
        sd = L * np.sqrt(self.kbar * comp)
        sd = np.maximum(sd, 1e-12 * np.max(sd))
        ed = np.abs(np.diag(kr)) * sd
        ed = np.maximum(ed, 1e-12 * np.max(ed))
        self.x_scale = np.repeat(sd, self.nr)
        self.eq_scale = np.repeat(ed, self.nr)
        self.n_unknowns = m * self.nr

    def _static_schur(self) -> np.ndarray:
        kp, nl, ln, d = self.Kp, self.nl, self.ln, self.dof_eq
        if ln.size == 0:
            return kp[np.ix_(nl, nl)]
        kt = kp * np.outer(d, d)
        x = np.linalg.lstsq(kt[np.ix_(ln, ln)], kt[np.ix_(ln, nl)], rcond=None)[0]
        st = kt[np.ix_(nl, nl)] - kt[np.ix_(nl, ln)] @ x
        return st / np.outer(d[nl], d[nl])

    def _esolve(self, z: np.ndarray, rhs: np.ndarray, idx=None) -> np.ndarray:
        """Batched ``z^-1 rhs`` for z (nS, m, m), rhs (nS, m, p), equilibrated by D.

        ``idx`` selects the coordinates of z (default all).
        """
        d = self.dof_eq if idx is None else self.dof_eq[idx]
        zt = z * d[None, :, None] * d[None, None, :]
        return d[None, :, None] * np.linalg.solve(zt, d[None, :, None] * rhs)

    # ------------------------------------------------------------------ linear parts
    def _w(self, omega: float) -> tuple[np.ndarray, np.ndarray]:
        kd = self.kS * self.harmonics.divisor
        return kd * omega, kd

    def _dyn(self, omega: float) -> tuple[np.ndarray, np.ndarray]:
        """Z'_k(Omega) and dZ'_k/dOmega, (nS, n, n) complex (eq. 22)."""
        s = self.system
        w, kd = self._w(omega)
        z = (self.Kp[None] - (w ** 2)[:, None, None] * s.M[None]
             + 1j * w[:, None, None] * s.C[None])
        dz = (-2.0 * w * kd)[:, None, None] * s.M[None] + 1j * kd[:, None, None] * s.C[None]
        return z, dz

    def _forcing(self, omega: float) -> tuple[np.ndarray, np.ndarray]:
        return self.Fc + omega ** 2 * self.Fu, 2.0 * omega * self.Fu

    def _modal_inv(self, omega: float) -> tuple[np.ndarray, np.ndarray]:
        w, kd = self._w(omega)
        den = self.w2[:, None] - (w ** 2)[None, :] + 1j * w[None, :] * self.cj[:, None]
        zero = np.zeros_like(den, dtype=bool)
        zero[:, 0] = self.rigid & (self.kS[0] == 0)
        den = np.where(zero, 1.0, den)
        if np.any(den == 0):
            raise ValueError(
                f"Omega = {omega:.6g} rad/s hits an undamped natural frequency exactly")
        inv = np.where(zero, 0.0, 1.0 / den)
        dden = (-2.0 * w * kd)[None, :] + 1j * kd[None, :] * self.cj[:, None]
        dinv = -inv ** 2 * dden
        return inv, dinv

    def _lin_loa(self, omega: float):
        """(h, d) and their Omega-derivatives, each (nS,) complex (cached per Omega)."""
        key = ("loa", float(omega))
        if self._lin_cache[0] != key:
            self._lin_cache = (key, self._lin_loa_compute(omega))
        return self._lin_cache[1]

    def _lin_loa_compute(self, omega: float):
        if self.modal:
            inv, dinv = self._modal_inv(omega)
            g = self.gj
            g2 = g * g
            h = g2 @ inv
            dh = g2 @ dinv
            pf = self.pfc + omega ** 2 * self.pfu
            d = g @ (pf * inv)
            dd = g @ (pf * dinv) + g @ (2.0 * omega * self.pfu * inv)
            return (h, d), (dh, dd)
        z, dz = self._dyn(omega)
        f, df = self._forcing(omega)
        g = self.G.astype(complex)
        rhs = np.stack([np.broadcast_to(g, f.shape), f, df], axis=-1)      # (nS, n, 3)
        x = self._esolve(z, rhs)
        gg = np.broadcast_to(g, f.shape)[..., None]
        y = self._esolve(np.transpose(z, (0, 2, 1)), gg)[..., 0]
        h = x[:, :, 0] @ g
        d = x[:, :, 1] @ g
        dh = -np.einsum("ki,kij,kj->k", y, dz, x[:, :, 0])
        dd = -np.einsum("ki,kij,kj->k", y, dz, x[:, :, 1]) + x[:, :, 2] @ g
        return (h, d), (dh, dd)

    def _lin_gear(self, omega: float):
        """Schur complement Z_r, F_r and derivatives (eq. 26-29), cached per Omega."""
        key = ("gear", float(omega))
        if self._lin_cache[0] != key:
            self._lin_cache = (key, self._lin_gear_compute(omega))
        return self._lin_cache[1]

    def _lin_gear_compute(self, omega: float):
        z, dz = self._dyn(omega)
        f, df = self._forcing(omega)
        nl, ln = self.nl, self.ln
        znn = z[:, nl][:, :, nl]
        dznn = dz[:, nl][:, :, nl]
        if ln.size == 0:
            return znn, dznn, f[:, nl], df[:, nl]
        zll = z[:, ln][:, :, ln]
        zln = z[:, ln][:, :, nl]
        znl = z[:, nl][:, :, ln]
        sol = self._esolve(zll, np.concatenate([zln, f[:, ln, None]], axis=2), ln)
        x, xf = sol[:, :, :-1], sol[:, :, -1]
        y = np.transpose(self._esolve(np.transpose(zll, (0, 2, 1)),
                                      np.transpose(znl, (0, 2, 1)), ln), (0, 2, 1))
        dzll = dz[:, ln][:, :, ln]
        dzln = dz[:, ln][:, :, nl]
        dznl = dz[:, nl][:, :, ln]
        zr = znn - znl @ x
        fr = f[:, nl] - np.einsum("kij,kj->ki", znl, xf)
        dzr = dznn - dznl @ x - y @ dzln + y @ dzll @ x
        dfr = (df[:, nl] - np.einsum("kij,kj->ki", dznl, xf)
               + np.einsum("kij,kj->ki", y @ dzll, xf) - np.einsum("kij,kj->ki", y, df[:, ln]))
        return zr, dzr, fr, dfr

    # ------------------------------------------------------------------ nonlinear force
    def mesh_force(self, delta_r: np.ndarray, jacobian: bool = True, law: float = 1.0):
        """AFT of f' = f_LoA - k_bar Delta (eq. 13) from the real coefficients of Delta.

        ``law`` = 1 is the dead zone; 0 the linear contact law ``k_m (p - b)``
        (permanent active contact); values in between blend the two (homotopy).
        Returns the real coefficients of f' (N) and, if asked, d f'/d Delta
        (n_real, n_real) (N/m).
        """
        delta = self.E @ delta_r
        p = delta - self.e_t
        if law == 0.0:
            f = self.k_t * (p - self.b)
            s = self.k_t
        else:
            f = dead_zone(p, self.k_t, self.b)
            s = dead_zone_stiffness(p, self.k_t, self.b)
            if law != 1.0:
                f = law * f + (1.0 - law) * self.k_t * (p - self.b)
                s = law * s + (1.0 - law) * self.k_t
        ft = self.A @ (f - self.kbar * delta)
        if not jacobian:
            return ft, None
        return ft, self.multiplication_matrix(s - self.kbar)

    def multiplication_matrix(self, s: np.ndarray) -> np.ndarray:
        """Real-layout matrix of ``x -> Galerkin(s(tau) x(tau))`` on the AFT grid.

        Equal to ``A diag(s) E`` but built from the DFT of s by index gathering
        (circular convolution), O(N log N + n_real^2).
        """
        n = s.size
        sh = np.fft.fft(s) / n
        k = self._kint
        wk = np.where(k == 0, 1.0, 2.0)[:, None]
        p = sh[(k[:, None] - k[None, 1:]) % n]
        q = sh[(k[:, None] + k[None, 1:]) % n]
        dc = np.empty((k.size, self.nr), dtype=complex)
        dc[:, 0] = wk[:, 0] * sh[k % n]
        dc[:, 1::2] = 0.5 * wk * (p + q)
        dc[:, 2::2] = 0.5j * wk * (p - q)
        return self.harmonics.to_real(dc.T).T

    # ------------------------------------------------------------------ complex helpers
    def _cmul(self, h: np.ndarray, xr: np.ndarray) -> np.ndarray:
        """Real layout of ``h_k * x_k`` (x a real-layout vector)."""
        return self._cmul_rows(h, xr[:, None])[:, 0]

    def _cmul_rows(self, h: np.ndarray, j: np.ndarray) -> np.ndarray:
        """Rows of a real-layout matrix multiplied by the complex h_k (h_0 real)."""
        out = np.empty_like(j)
        hr, hi = h.real[1:, None], h.imag[1:, None]
        jr, ji = j[1::2], j[2::2]
        out[0] = h[0].real * j[0]
        out[1::2] = hr * jr - hi * ji
        out[2::2] = hi * jr + hr * ji
        return out

    # ------------------------------------------------------------------ residual
    def delta_real(self, u: np.ndarray) -> np.ndarray:
        """Real coefficients of Delta = G^T q from the unknowns."""
        if self.condensation == "loa":
            return np.asarray(u, dtype=float)
        g = self.G if self.condensation == "none" else self.G[self.nl]
        return g @ np.asarray(u, dtype=float).reshape(g.size, self.nr)

    def evaluate(self, u: np.ndarray, omega: float, jacobian: bool = True, law: float = 1.0):
        """Residual R(u, Omega) and, if asked, dR/du and dR/dOmega (physical units).

        loa: R in m; none/gear: R in N (per DOF, DOF-major real layout).
        ``law``: contact law, see :meth:`mesh_force`.
        """
        u = np.asarray(u, dtype=float)
        if self.condensation == "loa":
            (h, d), (dh, dd) = self._lin_loa(omega)
            ft, jf = self.mesh_force(u, jacobian, law)
            r = u - self.harmonics.to_real(d) + self._cmul(h, ft)
            if not jacobian:
                return r
            ju = np.eye(self.nr) + self._cmul_rows(h, jf)
            jw = -self.harmonics.to_real(dd) + self._cmul(dh, ft)
            return r, ju, jw
        if self.condensation == "none":
            z, dz = self._dyn(omega)
            f, df = self._forcing(omega)
            g = self.G
        else:
            z, dz, f, df = self._lin_gear(omega)
            g = self.G[self.nl]
        m = g.size
        hs = self.harmonics
        uu = u.reshape(m, self.nr)
        uc = hs.to_complex(uu)                                   # (m, nS)
        ft, jf = self.mesh_force(g @ uu, jacobian, law)
        rc = np.einsum("kij,jk->ik", z, uc) - f.T
        r = (hs.to_real(rc) + g[:, None] * ft[None, :]).ravel()
        if not jacobian:
            return r
        j4 = np.zeros((m, self.nr, m, self.nr))
        re = np.concatenate([[0], np.arange(1, self.nr, 2)])
        im = np.arange(2, self.nr, 2)
        j4[:, re, :, re] = z.real
        j4[:, re[1:], :, im] = -z[1:].imag
        j4[:, im, :, re[1:]] = z[1:].imag
        j4[:, im, :, im] = z[1:].real
        ju = j4.reshape(m * self.nr, m * self.nr) + np.kron(np.outer(g, g), jf)
        jw = hs.to_real(np.einsum("kij,jk->ik", dz, uc) - df.T).ravel()
        return r, ju, jw

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
        u0 = np.zeros(self.n_unknowns)
        r, ju, _ = self.evaluate(u0, omega, law=0.0)
        dx = solve_checked(ju * self.x_scale[None, :] / self.eq_scale[:, None],
                           r / self.eq_scale, "initial guess (linear contact)")[0]
        return u0 - dx * self.x_scale

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
        """Newton corrector at fixed speed with scaled unknowns and equations.

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
        if not np.isfinite(rpm) or rpm <= 0:
            raise ValueError(f"rpm = {rpm!r}: must be > 0")
        omega = float(rpm) * RPM_TO_RAD_S
        u = self.initial_guess(omega) if x0 is None else np.array(x0, dtype=float)
        if u.shape != (self.n_unknowns,):
            raise ValueError(f"x0 shape = {u.shape}: must be ({self.n_unknowns},)")
        def fun(x, j=True):
            return self._scaled(x, omega, j)

        try:
            xh, it, res = newton(fun, u / self.x_scale, tol, max_iter, line_search=False)
        except ConvergenceError as exc:
            logger.debug("plain Newton failed at %.6g rpm (%s); homotopy from linear contact",
                         rpm, exc)
            try:
                xh, it, res = self._homotopy(omega, tol, max_iter)
            except ConvergenceError:
                logger.debug("homotopy failed at %.6g rpm; damped Newton", rpm)
                xh, it, res = newton(fun, u / self.x_scale, tol, 4 * max_iter, line_search=True)
        u = xh
        return self.point(u * self.x_scale, omega, it, res)

    def _homotopy(self, omega: float, tol: float, max_iter: int):
        """Natural continuation in lam from the linear contact law (0) to the dead zone (1)."""
        x = self.initial_guess(omega) / self.x_scale
        lam, dlam, total = 0.0, 0.25, 0
        slope = np.zeros_like(x)
        while lam < 1.0:
            target = min(1.0, lam + dlam)
            guess = x + slope * (target - lam)

            def fun(y, j=True, t=target):
                return self._scaled(y, omega, j, law=t)

            try:
                xn, it, _ = newton(fun, guess, tol, max_iter)
            except ConvergenceError:
                dlam *= 0.5
                if dlam < 1e-4:
                    raise
                continue
            slope = (xn - x) / (target - lam)
            x, lam = xn, target
            total += it
            dlam = min(2 * dlam, 0.5) if it <= 4 else dlam
        r = self._scaled(x, omega, False)
        return x, total, float(np.linalg.norm(r) / max(np.linalg.norm(x), 1.0))

    def _scaled(self, xh: np.ndarray, omega: float, jacobian: bool = True, law: float = 1.0):
        u = xh * self.x_scale
        if not jacobian:
            return self.evaluate(u, omega, jacobian=False, law=law) / self.eq_scale
        r, ju, jw = self.evaluate(u, omega, law=law)
        return (r / self.eq_scale, ju * (self.x_scale[None, :] / self.eq_scale[:, None]),
                jw / self.eq_scale)

    # ------------------------------------------------------------------ recovery
    def recover(self, point: Point | np.ndarray, omega: float | None = None) -> np.ndarray:
        """Complex Fourier coefficients of every coordinate, (n_dof, n_harmonics)."""
        if isinstance(point, Point):
            u, omega = point.unknowns, point.omega
        else:
            u = np.asarray(point, dtype=float)
            if omega is None:
                raise ValueError("recover: omega is required with raw unknowns")
        hs = self.harmonics
        if self.condensation == "none":
            return hs.to_complex(u.reshape(self.n_dof, self.nr))
        ft, _ = self.mesh_force(self.delta_real(u), jacobian=False)
        fc = hs.to_complex(ft)
        f, _ = self._forcing(omega)
        if self.condensation == "gear":
            q = np.zeros((self.n_dof, self.nS), dtype=complex)
            qn = hs.to_complex(u.reshape(self.nl.size, self.nr))
            q[self.nl] = qn
            if self.ln.size:
                z, _ = self._dyn(omega)
                zll = z[:, self.ln][:, :, self.ln]
                zln = z[:, self.ln][:, :, self.nl]
                rhs = f[:, self.ln] - np.einsum("kij,jk->ki", zln, qn)
                q[self.ln] = self._esolve(zll, rhs[..., None], self.ln)[..., 0].T
            return q
        rhs = f - fc[:, None] * self.G[None, :]                    # (nS, n)
        if self.modal:
            inv, _ = self._modal_inv(omega)
            eta = inv * (self.phi.T @ rhs.T)
            return self.phi @ eta
        z, _ = self._dyn(omega)
        return self._esolve(z, rhs[..., None])[..., 0].T

    def fine_grid(self, n_time: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Synthesis matrix, k_m and e on a grid of ``n_time`` samples (cached)."""
        if n_time not in self._fine_cache:
            if len(self._fine_cache) > 8:
                self._fine_cache.clear()
            phase = self.harmonics.time_grid(n_time) * self.mesh_step
            self._fine_cache[n_time] = (self.harmonics.aft_matrices(n_time)[0],
                                        self.mesh.stiffness_at(phase), self.mesh.error_at(phase))
        return self._fine_cache[n_time]


def newton(fun, x: np.ndarray, tol: float, max_iter: int, diverge: float = 1e8,
           line_search: bool = False):
    """Damped Newton on scaled unknowns: ``fun(x) -> (r, J, ...)``, ``fun(x, False) -> r``.

    Returns (x, iterations, relative residual); raises ConvergenceError.
    """
    res = np.inf
    r0 = None
    cond = np.nan
    warned = False
    for it in range(max_iter + 1):
        r = fun(x, False)
        res = float(np.linalg.norm(r) / max(np.linalg.norm(x), 1.0))
        if not np.isfinite(res):
            raise ConvergenceError(f"non-finite residual at iteration {it}", res, cond)
        if r0 is None:
            r0 = res
        if res < tol and (it == 0 or cond * res > 1e-7):
            # converged at the guess, or with a loose error bound cond * res: one
            # Newton step more (kept if it lowers the residual)
            try:
                rr, jj = fun(x)[:2]
                xn = x + solve_checked(jj, -rr, "Newton refinement", warn=False)[0]
                resn = float(np.linalg.norm(fun(xn, False)) / max(np.linalg.norm(xn), 1.0))
            except ConvergenceError:
                resn = np.inf
            return (xn, it + 1, resn) if resn < res else (x, it, res)
        if res < tol:
            return x, it, res
        if it == max_iter or res > diverge * max(r0, tol):
            break
        r, j = fun(x)[:2]
        try:
            dx, cond = solve_checked(j, -r, f"Newton iteration {it}", warn=not warned)
        except ConvergenceError as exc:
            raise ConvergenceError(f"{exc} (relative residual {res:.3g})", res,
                                   exc.condition) from exc
        warned = warned or cond > COND_WARN
        # backtracking on the residual norm (the force is only piecewise smooth)
        alpha = 1.0
        for _ in range(8):
            xt = x + alpha * dx
            rt = fun(xt, False) if line_search else None
            if rt is None:
                break
            rest = float(np.linalg.norm(rt) / max(np.linalg.norm(xt), 1.0))
            if np.isfinite(rest) and rest < (1.0 - 1e-4 * alpha) * res:
                break
            alpha *= 0.5
        x = x + alpha * dx
    why = "diverged: relative residual" if res > diverge * max(r0, tol) else "relative residual"
    raise ConvergenceError(f"Newton {why} {res:.3g} > tol {tol:.1g} after {it} iterations "
                           f"(condition estimate of the scaled Jacobian {cond:.2g})", res, cond)
