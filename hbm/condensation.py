"""The three condensations of the harmonic balance, one class each behind one contract.

A condensation decides which real unknowns the Newton solver sees and how the
physical coordinates are recovered from them (eq. 22-29):

* :class:`FullCoordinates` (``"none"``): every DOF is an unknown (DOF-major real
  layout, see basis.py); the residual is ``Z'_k q_k + sum_e g_e f'_e,k - F_k`` (N).
* :class:`GearCondensation` (``"gear"``): Schur complement onto the DOF where any
  element direction g_e != 0 (eq. 24-29); the residual is in N on those DOF.
* :class:`LoaCondensation` (``"loa"``): exact condensation onto the deflections of the
  elements, ``Delta = G^T q`` (E per harmonic, ``G = [g_1 ... g_E]``):
  ``Delta_k - d_k + H_k f'_k = 0`` (m), with the E x E receptance ``H_k = G^T Z'_k^-1 G``
  and ``d_k = G^T Z'_k^-1 F_k``, by modal summation over the modes of eq. (17) when C
  is diagonal in them (eq. 18-19), else by a dense complex solve per harmonic. The
  unknowns are the elements' Deltas themselves (element-major), not an orthonormal
  basis of their span: two elements may act along parallel directions. One element is
  the line-of-action condensation of the paper.

The contract (:class:`Condensation`) is what :class:`hbm.problem.HBMProblem`
delegates to: ``n_unknowns``, ``x_scale`` and ``eq_scale`` (unknown and equation
scales), ``delta_real(u)``, ``evaluate(u, omega, jacobian, law)`` (residual, dR/du,
dR/dOmega) and ``recover(u, omega)`` (complex coefficients of every DOF).  Each
class reads the shared linear data (Z'_k, F_k, modes, AFT forces) from the problem
through its public methods.  The design follows one class per variant behind one
small interface, as sfepy's linear-combination boundary conditions do
(sfepy/discrete/fem/lcbc_operators.py).
"""

from __future__ import annotations

import logging
from typing import Protocol

import numpy as np

from .basis import HarmonicSet, complex_mul, mul_rows, real_blocks
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
    n_elements: int
    nS: int
    nr: int
    G: np.ndarray
    directions: tuple
    Kp: np.ndarray
    dof_eq: np.ndarray
    kbar: np.ndarray
    length_scales: np.ndarray
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

    def forces(self, delta_r: np.ndarray, jacobian: bool = True, law: float = 1.0): ...

    def force_samples(self, delta_r: np.ndarray, stiffness: bool = True,
                      law: float = 1.0): ...

    def stiffness_matrix(self, st) -> np.ndarray: ...


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
        """Real coefficients of the Deltas ``G^T q`` from the unknowns, (E, n_real)."""

    def evaluate(self, u: np.ndarray, omega: float, jacobian: bool = True,
                 law: float = 1.0):
        """Residual R(u, Omega) and, if asked, (R, dR/du, dR/dOmega)."""

    def recover(self, u: np.ndarray, omega: float) -> np.ndarray:
        """Complex Fourier coefficients of every coordinate, (n_dof, n_harmonics)."""


def _require_restrained(problem: LinearData) -> None:
    """A condensation that solves with Z'_k needs it regular or modal at k = 0."""
    if np.any(problem.rigid) and not problem.modal:
        raise ValueError(
            "system: K + sum k_bar g g^T is singular and C is not modal; use a modal damping "
            "or restrain the rigid-body modes")


def _accumulate(terms):
    """``t_0 + t_1 + ...`` left to right (one term: itself, no arithmetic)."""
    it = iter(terms)
    acc = next(it)
    for t in it:
        acc = acc + t
    return acc


def _real_times_complex(a: np.ndarray, z: np.ndarray) -> np.ndarray:
    """``a @ z`` for a real ``a`` (p, q) and a complex ``z`` (q, r): one real product of
    ``a`` with the (Re, Im) pairs of ``z`` read as 2 r real columns (NumPy would promote
    ``a`` to complex and do four times the multiplications)."""
    z = np.ascontiguousarray(z)
    q, r = z.shape
    return (a @ z.view(np.float64).reshape(q, 2 * r)).view(np.complex128)


def _stacked(blocks: list[np.ndarray]) -> np.ndarray:
    """The element blocks one after the other (one block: itself)."""
    return blocks[0] if len(blocks) == 1 else np.concatenate(blocks)


#: Bytes of one real array of a block of the modal sums (:meth:`LoaCondensation.
#: _modal_sums`): 42 harmonics of the pump's 772 modes, the fastest width measured there
#: (16: 3.7 ms, 32: 3.1, 64: 3.4, all 925 at once: 5.1 per speed).
BLOCK_BYTES = 1 << 18


class LoaCondensation:
    """Condensation onto the elements' deflections: the unknowns are the real
    coefficients of every Delta_e (m, element-major); the residual
    ``Delta_k - d_k + H_k f'_k`` is in m."""

    name = "loa"

    def __init__(self, problem: LinearData) -> None:
        _require_restrained(problem)
        if not problem.modal:
            logger.info("damping is not modal in the eq. (17) modes: dense solve per harmonic")
        self.problem = problem
        L = problem.length_scales
        self.x_scale = np.repeat(L, problem.nr)
        self.eq_scale = np.repeat(L, problem.nr)
        self.n_unknowns = problem.n_elements * problem.nr
        self._cache: tuple = (None, None)
        self._gpf: tuple | None = None

    def delta_real(self, u: np.ndarray) -> np.ndarray:
        """Real coefficients of the Deltas: the unknowns themselves, (E, n_real)."""
        pb = self.problem
        return np.asarray(u, dtype=float).reshape(pb.n_elements, pb.nr)

    def receptance(self, omega: float):
        """``(H, d), (dH/dOmega, dd/dOmega)``: ``H`` (E, E, nS) and ``d`` (E, nS) complex
        (cached per Omega).

        ``H_k[e, f] = g_e^T Z'_k^-1 g_f`` (m/N) and ``d_k[e] = g_e^T Z'_k^-1 F_k`` (m).
        """
        key = float(omega)
        if self._cache[0] != key:
            self._cache = (key, self._compute(omega))
        return self._cache[1]

    def _compute(self, omega: float):
        pb = self.problem
        ne, ns = pb.n_elements, pb.nS
        h = np.empty((ne, ne, ns), dtype=complex)
        dh = np.empty((ne, ne, ns), dtype=complex)
        d = np.empty((ne, ns), dtype=complex)
        dd = np.empty((ne, ns), dtype=complex)
        if pb.modal:
            self._modal_sums(omega, h, dh, d, dd)
            return (h, d), (dh, dd)
        z, dz = pb.dynamic_stiffness(omega)
        f, df = pb.forcing(omega)
        gs = [g.astype(complex) for g in pb.directions]
        rhs = np.stack([*(np.broadcast_to(g, f.shape) for g in gs), f, df], axis=-1)
        x = pb.equilibrated_solve(z, rhs)                                 # (nS, n, E + 2)
        gg = np.stack([np.broadcast_to(g, f.shape) for g in gs], axis=-1)
        y = pb.equilibrated_solve(np.transpose(z, (0, 2, 1)), gg)          # (nS, n, E)
        for e, ge in enumerate(gs):
            for k in range(ne):
                h[e, k] = x[:, :, k] @ ge
                dh[e, k] = -np.einsum("ki,kij,kj->k", y[..., e], dz, x[:, :, k])
            d[e] = x[:, :, ne] @ ge
            dd[e] = -np.einsum("ki,kij,kj->k", y[..., e], dz, x[:, :, ne]) + x[:, :, ne + 1] @ ge
        return (h, d), (dh, dd)

    def _modal_sums(self, omega: float, h: np.ndarray, dh: np.ndarray, d: np.ndarray,
                    dd: np.ndarray) -> None:
        """Fill ``H``, ``d`` and their Omega-derivatives by modal summation (eq. 18-19).

        ``H_k[e, f] = sum_j g_je g_jf / den_jk`` with ``den_jk = w_j^2 - w_k^2 + i w_k c_j``
        is summed in real arithmetic: ``1 / den = U - i V`` with ``U = a / |den|^2``,
        ``V = b / |den|^2`` (``a``, ``b`` the real and imaginary parts of ``den``), and
        ``d/dOmega (1 / den) = (P - 2 i U V) (2 w_k - i c_j) w_k / Omega`` with
        ``P = U^2 - V^2``, so that ``H`` and ``dH/dOmega`` are six real products of the
        pair weights ``g_je g_jf`` (and ``g_je g_jf c_j``) with U, V, P and UV. The
        arrays are formed a block of harmonics at a time (:data:`BLOCK_BYTES` each, kept
        in cache between their passes). ``d`` is summed only at the harmonics where a
        modal force is non-zero (those of the external excitation: a few), with the
        complex receptances of those columns. The same sums as the complex arrays of
        :meth:`hbm.problem.HBMProblem.modal_inverse` to round-off (1e-16 of the largest
        ``H``, 3e-15 of the largest derivative), in a fifth of the time on the shipped
        pump (772 modes, 925 harmonics: 3.6 ms against 18 ms per speed)."""
        pb = self.problem
        ne, ns = pb.n_elements, pb.nS
        if self._gpf is None:          # Omega-free: pair weights, forced harmonics, g_j F_j
            gj = pb.gj
            pairs = np.array([gj[e] * gj[f] for e in range(ne) for f in range(ne)])
            forced = np.flatnonzero(np.any(pb.pfc != 0, axis=0) | np.any(pb.pfu != 0, axis=0))
            self._gpf = (pairs, np.vstack([pairs, pairs * pb.cj[None, :]]), forced,
                         [(g[:, None] * pb.pfc[:, forced], g[:, None] * pb.pfu[:, forced])
                          for g in gj])
        pairs, weights, forced, gpfs = self._gpf
        npair = pairs.shape[0]
        w, kd = pb.harmonic_frequencies(omega)
        su, sv = np.empty((npair, ns)), np.empty((npair, ns))
        sp, sq = np.empty((2 * npair, ns)), np.empty((2 * npair, ns))
        w2, cj = pb.w2[:, None], pb.cj[:, None]
        rigid = np.flatnonzero(pb.rigid)
        width = max(1, BLOCK_BYTES // (8 * max(1, pb.w2.size)))
        for start in range(0, ns, width):
            stop = min(start + width, ns)
            wb = w[None, start:stop]
            u = w2 - wb * wb
            v = cj * wb
            # static columns of a rigid mode no element restrains: receptance 0
            zero = np.ix_(rigid, np.flatnonzero(pb.kS[start:stop] == 0)) if rigid.size \
                else None
            if zero is not None:
                u[zero], v[zero] = 1.0, 0.0
            m = u * u
            m += v * v
            np.reciprocal(m, out=m)
            u *= m
            v *= m
            if zero is not None:
                u[zero], v[zero] = 0.0, 0.0
            su[:, start:stop] = pairs @ u
            sv[:, start:stop] = pairs @ v
            uv = u * v
            u *= u
            v *= v
            u -= v
            sp[:, start:stop] = weights @ u
            sq[:, start:stop] = weights @ uv
        if not (np.all(np.isfinite(su)) and np.all(np.isfinite(sp))):
            raise ValueError(
                f"Omega = {omega:.6g} rad/s hits an undamped natural frequency exactly")
        h[:] = (su - 1j * sv).reshape(ne, ne, ns)
        dh[:] = (kd * (2.0 * w * sp[:npair] - 2.0 * sq[npair:]
                       - 1j * (sp[npair:] + 4.0 * w * sq[:npair]))).reshape(ne, ne, ns)
        d[:] = 0.0
        dd[:] = 0.0
        if forced.size == 0:
            return
        inv, dinv = pb.modal_inverse(omega, columns=forced)
        for e, (gpfc, gpfu) in enumerate(gpfs):
            gpf = gpfc + omega ** 2 * gpfu
            d[e, forced] = np.einsum("jk,jk->k", gpf, inv)
            dd[e, forced] = np.einsum("jk,jk->k", gpf, dinv) + 2.0 * omega * np.einsum(
                "jk,jk->k", gpfu, inv)

    def evaluate(self, u: np.ndarray, omega: float, jacobian: bool = True,
                 law: float = 1.0):
        """Residual ``Delta_k - d_k + H_k f'_k`` (m) and, if asked, its Jacobians."""
        pb = self.problem
        hs = pb.harmonics
        ne, nr = pb.n_elements, pb.nr
        (h, d), (dh, dd) = self.receptance(omega)
        du = self.delta_real(u)
        if pb.matrix_free:
            ft, sk = pb.force_samples(du, jacobian, law)
        else:
            ft, jf = pb.forces(du, jacobian, law)
        r = _stacked([du[e] - hs.to_real(d[e]) + _accumulate(complex_mul(h[e, f], ft[f])
                                                             for f in range(ne))
                      for e in range(ne)])
        if not jacobian:
            return r
        if pb.matrix_free:         # J = I + H S, applied by FFT (hbm/krylov.py)
            ju = LoaJacobian(h, sk, hs, pb.stiffness_matrix, pb.preconditioners)
        elif ne == 1:
            ju = np.eye(nr) + mul_rows(h[0, 0], jf[0])
        else:
            ju = np.eye(ne * nr) + np.block([[mul_rows(h[e, f], jf[f]) for f in range(ne)]
                                             for e in range(ne)])
        jw = _stacked([-hs.to_real(dd[e]) + _accumulate(complex_mul(dh[e, f], ft[f])
                                                         for f in range(ne))
                       for e in range(ne)])
        return r, ju, jw

    def _force_coefficients(self, u: np.ndarray) -> np.ndarray:
        """Complex coefficients of every element's ``f'_e`` (N), (E, nS)."""
        ft, _ = self.problem.forces(self.delta_real(u), jacobian=False)
        return self.problem.harmonics.to_complex(ft)

    def modal_coordinates(self, u: np.ndarray, omega: float) -> np.ndarray:
        """The coordinates in the eq. (17) modes, ``eta_k = (phi^T F_k - sum_e g_j,e
        f'_e,k) / (w_j^2 - w_k^2 + i w_k c_j)`` (n_modes, nS): every DOF is ``phi @ eta``
        (:meth:`recover`). Only for a modal damping (:attr:`LinearData.modal`)."""
        pb = self.problem
        if not pb.modal:
            raise ValueError("modal coordinates need a damping diagonal in the eq. (17) "
                             "modes")
        fc = self._force_coefficients(u)
        inv, _ = pb.modal_inverse(omega, derivative=False)
        modal = (pb.pfc + omega ** 2 * pb.pfu) - _accumulate(
            fc[e][None, :] * g[:, None] for e, g in enumerate(pb.gj))   # (n_modes, nS)
        return inv * modal

    def recover(self, u: np.ndarray, omega: float) -> np.ndarray:
        """Every DOF from Z'_k q_k = F_k - sum_e g_e f'_e,k, modally or by a dense solve.

        Modally the modal forces are those of the residual, ``phi^T F_k`` (kept by the
        problem) minus ``g_j,e f'_e,k``, and the one product with the modes is a real
        matrix product with the (Re, Im) pairs (:func:`_real_times_complex`): a third
        of the time of the two complex products it replaces (the NVH export recovers
        every point; the coordinates agree to 1e-15 of their largest)."""
        pb = self.problem
        if pb.modal:
            return _real_times_complex(pb.phi, self.modal_coordinates(u, omega))
        fc = self._force_coefficients(u)
        f, _ = pb.forcing(omega)
        rhs = f - _accumulate(fc[e][:, None] * g[None, :]
                              for e, g in enumerate(pb.directions))   # (nS, n)
        z, _ = pb.dynamic_stiffness(omega)
        return pb.equilibrated_solve(z, rhs[..., None])[..., 0].T


class _DofCondensation:
    """Shared part of the DOF-based condensations: the unknowns are the real
    coefficients of m coordinates (DOF-major), the residual is in N.

    ``gs``: every element's direction on the retained coordinates."""

    name = ""

    def __init__(self, problem: LinearData, gs: list[np.ndarray], kr: np.ndarray,
                 dr: np.ndarray) -> None:
        self.problem = problem
        self.gs = gs
        pb = problem
        m = kr.shape[0]
        # diagonal static compliance, from the equilibrated matrix (unit-independent)
        comp = dr ** 2 * np.abs(np.diag(np.linalg.pinv(kr * np.outer(dr, dr))))
        # the largest displacement of each DOF under any element's k_bar L
        sd = pb.length_scales[0] * np.sqrt(pb.kbar[0] * comp)
        for lsc, kb in zip(pb.length_scales[1:], pb.kbar[1:], strict=True):
            sd = np.maximum(sd, lsc * np.sqrt(kb * comp))
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
        """Real coefficients of every Delta_e = g_e^T u on the retained coordinates,
        (E, n_real)."""
        uu = np.asarray(u, dtype=float).reshape(self.gs[0].size, self.problem.nr)
        return np.stack([g @ uu for g in self.gs])

    def evaluate(self, u: np.ndarray, omega: float, jacobian: bool = True,
                 law: float = 1.0):
        """Residual ``Z_r u_k + sum_e g_e f'_e,k - F_r`` (N) and, if asked, its Jacobians."""
        pb = self.problem
        nr = pb.nr
        z, dz, f, df = self.linear(omega)
        gs = self.gs
        m = gs[0].size
        hs = pb.harmonics
        uu = u.reshape(m, nr)
        uc = hs.to_complex(uu)                                   # (m, nS)
        ft, jf = pb.forces(np.stack([g @ uu for g in gs]), jacobian, law)
        rc = np.einsum("kij,jk->ik", z, uc) - f.T
        r = (hs.to_real(rc) + _accumulate(g[:, None] * ft[e][None, :]
                                          for e, g in enumerate(gs))).ravel()
        if not jacobian:
            return r
        ju = real_blocks(z, nr)
        for e, g in enumerate(gs):
            ju = ju + np.kron(np.outer(g, g), jf[e])
        jw = hs.to_real(np.einsum("kij,jk->ik", dz, uc) - df.T).ravel()
        return r, ju, jw


class FullCoordinates(_DofCondensation):
    """No condensation: every DOF is an unknown."""

    name = "none"

    def __init__(self, problem: LinearData) -> None:
        super().__init__(problem, list(problem.directions), problem.Kp, problem.dof_eq)

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
    """Schur complement onto the DOF where any element direction g_e != 0 (eq. 24-29).

    Attributes
    ----------
    nl, ln
        Indices of the retained (element) DOF and of the condensed ones.
    """

    name = "gear"

    def __init__(self, problem: LinearData) -> None:
        _require_restrained(problem)
        self.problem = pb = problem
        self.nl = np.flatnonzero(np.any(pb.G != 0.0, axis=1))
        self.ln = np.setdiff1d(np.arange(pb.n_dof), self.nl)
        if self.ln.size:
            d = pb.dof_eq
            kll = (pb.Kp * np.outer(d, d))[np.ix_(self.ln, self.ln)]
            if np.linalg.cond(kll) > 1e13:
                raise ValueError(
                    "problem.condensation = 'gear': the stiffness of the DOF off the elements "
                    "is singular (a rigid-body mode no element restrains); use 'loa' "
                    "with modal damping or 'none'")
        self._cache: tuple = (None, None)
        super().__init__(problem, [g[self.nl] for g in pb.directions], self._static_schur(),
                         pb.dof_eq[self.nl])

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
        """Element DOF from the unknowns, the others from Z_ll q_l = F_l - Z_ln q_n."""
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
