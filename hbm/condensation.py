"""The three condensations of the harmonic balance, one class each behind one contract.

A condensation decides which real unknowns the Newton solver sees and how the
physical coordinates are recovered from them (eq. 22-29):

* :class:`FullCoordinates` (``"none"``): every DOF is an unknown (DOF-major real
  layout, see harmonics.py); the residual is ``Z'_k q_k + G f'_k - F_k`` (N).
* :class:`GearCondensation` (``"gear"``): Schur complement onto the DOF where
  G != 0 (eq. 24-29); the residual is in N on those DOF.
* :class:`LoaCondensation` (``"loa"``): exact condensation onto Delta = G^T q per
  harmonic, ``Delta_k - d_k + h_k f'_k = 0`` (m), with ``h_k = G^T Z'_k^-1 G`` and
  ``d_k = G^T Z'_k^-1 F_k``, by modal summation over the modes of eq. (17) when C
  is diagonal in them (eq. 18-19), else by a dense complex solve per harmonic.

The contract (:class:`Condensation`) is what :class:`hbm.problem.HBMProblem`
delegates to: ``n_unknowns``, ``x_scale`` and ``eq_scale`` (unknown and equation
scales), ``delta_real(u)``, ``evaluate(u, omega, jacobian, law)`` (residual, dR/du,
dR/dOmega) and ``recover(u, omega)`` (complex coefficients of every DOF).  Each
class reads the shared linear data (Z'_k, F_k, modes, AFT force) from the problem
through its public methods.  The design follows one class per variant behind one
small interface, as sfepy's linear-combination boundary conditions do
(sfepy/discrete/fem/lcbc_operators.py).
"""

from __future__ import annotations

import logging
from typing import Protocol

import numpy as np

from .harmonics import HarmonicSet, complex_mul, mul_rows, real_blocks
from .krylov import LoaJacobian, Preconditioners

logger = logging.getLogger(__name__)

__all__ = ["CONDENSATIONS", "Condensation", "FullCoordinates", "GearCondensation",
           "LinearData", "LoaCondensation", "make_condensation"]


class LinearData(Protocol):
    """What a condensation reads of :class:`hbm.problem.HBMProblem` (its shared data).

    Declared here so that this module does not import hbm.problem (one-way imports).
    """

    harmonics: HarmonicSet
    n_dof: int
    nS: int
    nr: int
    G: np.ndarray
    Kp: np.ndarray
    dof_eq: np.ndarray
    kbar: float
    length_scale: float
    modal: bool
    rigid: np.ndarray
    gj: np.ndarray
    phi: np.ndarray
    pfc: np.ndarray
    pfu: np.ndarray
    matrix_free: bool
    preconditioners: Preconditioners

    def dynamic_stiffness(self, omega: float) -> tuple[np.ndarray, np.ndarray]: ...

    def forcing(self, omega: float) -> tuple[np.ndarray, np.ndarray]: ...

    def modal_inverse(self, omega: float) -> tuple[np.ndarray, np.ndarray]: ...

    def equilibrated_solve(self, z: np.ndarray, rhs: np.ndarray,
                           idx: np.ndarray | None = None) -> np.ndarray: ...

    def mesh_force(self, delta_r: np.ndarray, jacobian: bool = True, law: float = 1.0): ...

    def mesh_force_samples(self, delta_r: np.ndarray, stiffness: bool = True,
                           law: float = 1.0): ...

    def contact_matrix(self, st) -> np.ndarray: ...


class Condensation(Protocol):
    """What :class:`hbm.problem.HBMProblem` needs of a condensation.

    Attributes
    ----------
    name
        ``"none"``, ``"gear"`` or ``"loa"``.
    n_unknowns
        Number of real unknowns.
    x_scale, eq_scale
        Scale of each unknown and of each equation (physical units); the Newton
        solver works on ``u / x_scale`` and ``R / eq_scale``.
    """

    name: str
    n_unknowns: int
    x_scale: np.ndarray
    eq_scale: np.ndarray

    def delta_real(self, u: np.ndarray) -> np.ndarray:
        """Real coefficients of Delta = G^T q from the unknowns."""

    def evaluate(self, u: np.ndarray, omega: float, jacobian: bool = True,
                 law: float = 1.0):
        """Residual R(u, Omega) and, if asked, (R, dR/du, dR/dOmega)."""

    def recover(self, u: np.ndarray, omega: float) -> np.ndarray:
        """Complex Fourier coefficients of every coordinate, (n_dof, n_harmonics)."""


def _require_restrained(problem: LinearData) -> None:
    """A condensation that solves with Z'_k needs it regular or modal at k = 0."""
    if np.any(problem.rigid) and not problem.modal:
        raise ValueError(
            "system: K + k_bar G G^T is singular and C is not modal; use a modal damping "
            "or restrain the rigid-body modes")


class LoaCondensation:
    """Condensation onto the line of action: the unknowns are the real coefficients
    of Delta (m); the residual ``Delta_k - d_k + h_k f'_k`` is in m."""

    name = "loa"

    def __init__(self, problem: LinearData) -> None:
        _require_restrained(problem)
        if not problem.modal:
            logger.info("damping is not modal in the eq. (17) modes: dense solve per harmonic")
        self.problem = problem
        L = problem.length_scale
        self.x_scale = np.full(problem.nr, L)
        self.eq_scale = np.full(problem.nr, L)
        self.n_unknowns = problem.nr
        self._cache: tuple = (None, None)
        self._gpf: tuple | None = None

    def delta_real(self, u: np.ndarray) -> np.ndarray:
        """Real coefficients of Delta: the unknowns themselves."""
        return np.asarray(u, dtype=float)

    def receptance(self, omega: float):
        """``(h, d), (dh/dOmega, dd/dOmega)``, each (nS,) complex (cached per Omega).

        ``h_k = G^T Z'_k^-1 G`` (m/N) and ``d_k = G^T Z'_k^-1 F_k`` (m).
        """
        key = float(omega)
        if self._cache[0] != key:
            self._cache = (key, self._compute(omega))
        return self._cache[1]

    def _compute(self, omega: float):
        pb = self.problem
        if pb.modal:
            inv, dinv = pb.modal_inverse(omega)
            g = pb.gj
            g2 = g * g
            h = g2 @ inv
            dh = g2 @ dinv
            if self._gpf is None:            # g_j times the modal forces (Omega-free)
                self._gpf = (g[:, None] * pb.pfc, g[:, None] * pb.pfu)
            gpfc, gpfu = self._gpf
            gpf = gpfc + omega ** 2 * gpfu
            d = np.einsum("jk,jk->k", gpf, inv)
            dd = np.einsum("jk,jk->k", gpf, dinv) + 2.0 * omega * np.einsum("jk,jk->k", gpfu,
                                                                            inv)
            return (h, d), (dh, dd)
        z, dz = pb.dynamic_stiffness(omega)
        f, df = pb.forcing(omega)
        g = pb.G.astype(complex)
        rhs = np.stack([np.broadcast_to(g, f.shape), f, df], axis=-1)      # (nS, n, 3)
        x = pb.equilibrated_solve(z, rhs)
        gg = np.broadcast_to(g, f.shape)[..., None]
        y = pb.equilibrated_solve(np.transpose(z, (0, 2, 1)), gg)[..., 0]
        h = x[:, :, 0] @ g
        d = x[:, :, 1] @ g
        dh = -np.einsum("ki,kij,kj->k", y, dz, x[:, :, 0])
        dd = -np.einsum("ki,kij,kj->k", y, dz, x[:, :, 1]) + x[:, :, 2] @ g
        return (h, d), (dh, dd)

    def evaluate(self, u: np.ndarray, omega: float, jacobian: bool = True,
                 law: float = 1.0):
        """Residual ``Delta_k - d_k + h_k f'_k`` (m) and, if asked, its Jacobians."""
        pb = self.problem
        (h, d), (dh, dd) = self.receptance(omega)
        if pb.matrix_free:
            ft, sk = pb.mesh_force_samples(u, jacobian, law)
        else:
            ft, jf = pb.mesh_force(u, jacobian, law)
        r = u - pb.harmonics.to_real(d) + complex_mul(h, ft)
        if not jacobian:
            return r
        if pb.matrix_free:         # J = I + H S, applied by FFT (hbm/krylov.py)
            ju = LoaJacobian(h, sk, pb.harmonics, pb.contact_matrix, pb.preconditioners)
        else:
            ju = np.eye(pb.nr) + mul_rows(h, jf)
        jw = -pb.harmonics.to_real(dd) + complex_mul(dh, ft)
        return r, ju, jw

    def recover(self, u: np.ndarray, omega: float) -> np.ndarray:
        """Every DOF from Z'_k q_k = F_k - G f'_k, modally or by a dense solve."""
        pb = self.problem
        ft, _ = pb.mesh_force(self.delta_real(u), jacobian=False)
        fc = pb.harmonics.to_complex(ft)
        f, _ = pb.forcing(omega)
        rhs = f - fc[:, None] * pb.G[None, :]                    # (nS, n)
        if pb.modal:
            inv, _ = pb.modal_inverse(omega)
            eta = inv * (pb.phi.T @ rhs.T)
            return pb.phi @ eta
        z, _ = pb.dynamic_stiffness(omega)
        return pb.equilibrated_solve(z, rhs[..., None])[..., 0].T


class _DofCondensation:
    """Shared part of the DOF-based condensations: the unknowns are the real
    coefficients of m coordinates (DOF-major), the residual is in N."""

    name = ""

    def __init__(self, problem: LinearData, g: np.ndarray, kr: np.ndarray,
                 dr: np.ndarray) -> None:
        self.problem = problem
        self.g = g
        pb = problem
        m = kr.shape[0]
        # diagonal static compliance, from the equilibrated matrix (unit-independent)
        comp = dr ** 2 * np.abs(np.diag(np.linalg.pinv(kr * np.outer(dr, dr))))
        sd = pb.length_scale * np.sqrt(pb.kbar * comp)
        sd = np.maximum(sd, 1e-12 * np.max(sd))
        ed = np.abs(np.diag(kr)) * sd
        ed = np.maximum(ed, 1e-12 * np.max(ed))
        self.x_scale = np.repeat(sd, pb.nr)
        self.eq_scale = np.repeat(ed, pb.nr)
        self.n_unknowns = m * pb.nr

    def linear(self, omega: float):
        """``(Z_r, dZ_r/dOmega, F_r, dF_r/dOmega)`` on the retained coordinates."""
        raise NotImplementedError

    def delta_real(self, u: np.ndarray) -> np.ndarray:
        """Real coefficients of Delta = g^T u on the retained coordinates."""
        g = self.g
        return g @ np.asarray(u, dtype=float).reshape(g.size, self.problem.nr)

    def evaluate(self, u: np.ndarray, omega: float, jacobian: bool = True,
                 law: float = 1.0):
        """Residual ``Z_r u_k + g f'_k - F_r`` (N) and, if asked, its Jacobians."""
        pb = self.problem
        nr = pb.nr
        z, dz, f, df = self.linear(omega)
        g = self.g
        m = g.size
        hs = pb.harmonics
        uu = u.reshape(m, nr)
        uc = hs.to_complex(uu)                                   # (m, nS)
        ft, jf = pb.mesh_force(g @ uu, jacobian, law)
        rc = np.einsum("kij,jk->ik", z, uc) - f.T
        r = (hs.to_real(rc) + g[:, None] * ft[None, :]).ravel()
        if not jacobian:
            return r
        ju = real_blocks(z, nr) + np.kron(np.outer(g, g), jf)
        jw = hs.to_real(np.einsum("kij,jk->ik", dz, uc) - df.T).ravel()
        return r, ju, jw


class FullCoordinates(_DofCondensation):
    """No condensation: every DOF is an unknown."""

    name = "none"

    def __init__(self, problem: LinearData) -> None:
        super().__init__(problem, problem.G, problem.Kp, problem.dof_eq)

    def linear(self, omega: float):
        """Z'_k, F_k and their Omega-derivatives (not cached)."""
        pb = self.problem
        z, dz = pb.dynamic_stiffness(omega)
        f, df = pb.forcing(omega)
        return z, dz, f, df

    def recover(self, u: np.ndarray, omega: float) -> np.ndarray:
        """The unknowns are the coordinates."""
        pb = self.problem
        return pb.harmonics.to_complex(np.asarray(u, dtype=float).reshape(pb.n_dof, pb.nr))


class GearCondensation(_DofCondensation):
    """Schur complement onto the DOF where G != 0 (eq. 24-29).

    Attributes
    ----------
    nl, ln
        Indices of the retained (mesh) DOF and of the condensed ones.
    """

    name = "gear"

    def __init__(self, problem: LinearData) -> None:
        _require_restrained(problem)
        self.problem = pb = problem
        self.nl = np.flatnonzero(pb.G != 0.0)
        self.ln = np.setdiff1d(np.arange(pb.n_dof), self.nl)
        if self.ln.size:
            d = pb.dof_eq
            kll = (pb.Kp * np.outer(d, d))[np.ix_(self.ln, self.ln)]
            if np.linalg.cond(kll) > 1e13:
                raise ValueError(
                    "problem.condensation = 'gear': the stiffness of the DOF off the mesh "
                    "is singular (a rigid-body mode the mesh does not restrain); use 'loa' "
                    "with modal damping or 'none'")
        self._cache: tuple = (None, None)
        super().__init__(problem, pb.G[self.nl], self._static_schur(), pb.dof_eq[self.nl])

    def _static_schur(self) -> np.ndarray:
        pb = self.problem
        kp, nl, ln, d = pb.Kp, self.nl, self.ln, pb.dof_eq
        if ln.size == 0:
            return kp[np.ix_(nl, nl)]
        kt = kp * np.outer(d, d)
        x = np.linalg.lstsq(kt[np.ix_(ln, ln)], kt[np.ix_(ln, nl)], rcond=None)[0]
        st = kt[np.ix_(nl, nl)] - kt[np.ix_(nl, ln)] @ x
        return st / np.outer(d[nl], d[nl])

    def linear(self, omega: float):
        """Schur complement Z_r, F_r and derivatives (eq. 26-29), cached per Omega."""
        key = float(omega)
        if self._cache[0] != key:
            self._cache = (key, self._compute(omega))
        return self._cache[1]

    def _compute(self, omega: float):
        pb = self.problem
        z, dz = pb.dynamic_stiffness(omega)
        f, df = pb.forcing(omega)
        nl, ln = self.nl, self.ln
        znn = z[:, nl][:, :, nl]
        dznn = dz[:, nl][:, :, nl]
        if ln.size == 0:
            return znn, dznn, f[:, nl], df[:, nl]
        zll = z[:, ln][:, :, ln]
        zln = z[:, ln][:, :, nl]
        znl = z[:, nl][:, :, ln]
        sol = pb.equilibrated_solve(zll, np.concatenate([zln, f[:, ln, None]], axis=2), ln)
        x, xf = sol[:, :, :-1], sol[:, :, -1]
        y = np.transpose(pb.equilibrated_solve(np.transpose(zll, (0, 2, 1)),
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

    def recover(self, u: np.ndarray, omega: float) -> np.ndarray:
        """Mesh DOF from the unknowns, the others from Z_ll q_l = F_l - Z_ln q_n."""
        pb = self.problem
        hs = pb.harmonics
        f, _ = pb.forcing(omega)
        q = np.zeros((pb.n_dof, pb.nS), dtype=complex)
        qn = hs.to_complex(np.asarray(u, dtype=float).reshape(self.nl.size, pb.nr))
        q[self.nl] = qn
        if self.ln.size:
            z, _ = pb.dynamic_stiffness(omega)
            zll = z[:, self.ln][:, :, self.ln]
            zln = z[:, self.ln][:, :, self.nl]
            rhs = f[:, self.ln] - np.einsum("kij,jk->ki", zln, qn)
            q[self.ln] = pb.equilibrated_solve(zll, rhs[..., None], self.ln)[..., 0].T
        return q


CONDENSATIONS = {"loa": LoaCondensation, "gear": GearCondensation, "none": FullCoordinates}


def make_condensation(name: str, problem: LinearData) -> Condensation:
    """The condensation object named ``name`` for ``problem`` (validates and scales)."""
    if name not in CONDENSATIONS:
        raise ValueError(f"problem.condensation = {name!r}: must be 'none', 'gear' or 'loa'")
    return CONDENSATIONS[name](problem)
