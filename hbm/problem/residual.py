"""The HBM problem: shared linear data, AFT forces of the elements, Newton at one speed.

Equation (eq. 4, 14, 21):  M q'' + C q' + K q + sum_e g_e f_e(g_e^T q, t) = f_ex(t),
one term per nonlinear element ``e`` (:mod:`hbm.elements`) acting along its direction
``g_e``; ``G = [g_1 ... g_E]`` (n, E).

Internally each element's linear stiffness is moved to the linear part (the operator of
eq. 17), which makes the static dynamic stiffness regular even when K has rigid-body
modes (a free gear pair):

    K' = K + sum_e k_bar_e g_e g_e^T,      f'_e(Delta_e, t) = f_e(Delta_e, t) - k_bar_e Delta_e.

With ``Z'_k(Omega) = K' - (k w0)^2 M + i k w0 C`` (eq. 22) the harmonic balance
reads ``Z'_k q_k + sum_e g_e f'_e,k = F_k`` for every retained index k.  Which unknowns
the solver sees ("none", "gear", "loa") is decided by a condensation object
(:mod:`hbm.condensation`) that :class:`HBMProblem` delegates the residual, the
Jacobians, the scales and the recovery of the coordinates to.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np

from ..basis import HarmonicSet
from ..condensation import CONDENSATIONS, Condensation, make_condensation
from ..elements.base import Element, ElementStiffness
from ..krylov import Preconditioners
from ..modes import modes, static_deflection
from ..system import Excitation, LinearSystem
from ..torus import TorusBasis
from ..units import RPM_TO_RAD_S
from . import fixed_speed
from .fixed_speed import Point

logger = logging.getLogger(__name__)

__all__ = ["AFT_KINDS", "HBMProblem", "LINEAR_SOLVERS", "KRYLOV_MIN", "Synthesis",
           "block_diagonal"]

LINEAR_SOLVERS = ("auto", "dense", "krylov")
# "corrected": samples of the non-smooth forces with the sub-sample kink correction
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


def block_diagonal(blocks) -> np.ndarray:
    """The block-diagonal matrix of the square ``blocks`` (one per element)."""
    if len(blocks) == 1:
        return blocks[0]
    n = sum(b.shape[0] for b in blocks)
    out = np.zeros((n, n), dtype=np.result_type(*blocks))
    i = 0
    for b in blocks:
        out[i:i + b.shape[0], i:i + b.shape[0]] = b
        i += b.shape[0]
    return out


def _check_inputs(system, elements, excitation, harmonics, condensation: str,
                  linear_solver: str, aft: str) -> tuple[Element, ...]:
    """Refuse bad inputs of :class:`HBMProblem`, naming the field and its allowed values;
    the elements as a tuple."""
    if not isinstance(system, LinearSystem):
        raise ValueError(f"problem.system = {type(system).__name__}: must be a LinearSystem")
    if isinstance(elements, Element) or not isinstance(elements, (list, tuple)):
        raise ValueError(f"problem.elements = {type(elements).__name__}: must be a list of "
                         "elements (hbm.GearMesh, ...)")
    if not elements:
        raise ValueError("problem.elements = []: needs at least one nonlinear element")
    n = system.n_dof
    for i, el in enumerate(elements):
        if not isinstance(el, Element):
            raise ValueError(f"problem.elements[{i}] = {type(el).__name__}: must be an "
                             "hbm element (hbm.GearMesh, hbm.CubicSpring, ...)")
        if el.direction.shape != (n,):
            raise ValueError(f"problem.elements[{i}].direction shape = {el.direction.shape}: "
                             f"must be ({n},) like the system")
    if not isinstance(excitation, Excitation):
        raise ValueError(
            f"problem.excitation = {type(excitation).__name__}: must be an Excitation")
    if not isinstance(harmonics, (HarmonicSet, TorusBasis)):
        raise ValueError(f"problem.harmonics = {type(harmonics).__name__}: must be a "
                         "HarmonicSet or a TorusBasis")
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
    if excitation.n_dof != n:
        raise ValueError(f"excitation.n_dof = {excitation.n_dof}: must equal system size {n}")
    return tuple(elements)


def _forcing(excitation, hs: HarmonicSet, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Forcing per harmonic index, constant and Omega^2 parts, each (nS, n) complex."""
    fc = np.zeros((hs.n_harmonics, n), dtype=complex)
    fu = np.zeros((hs.n_harmonics, n), dtype=complex)
    pos = {k: i for i, k in enumerate(hs.indices)}
    for name, arr in (("constant", fc), ("omega_squared", fu)):
        for ratio, vec in getattr(excitation, name).items():
            idx = hs.index_of(ratio)
            if idx is None:
                raise ValueError(
                    f"excitation.{name} frequency ratio = {ratio}: not representable in the "
                    f"harmonic set ({hs.fundamental} fundamental, w0 = {hs.ratio} Omega, "
                    f"indices {list(hs.indices)[:12]}...)")
            arr[pos[idx]] += vec
    return fc, fu


class HBMProblem:
    """Harmonic balance of a linear system with a list of nonlinear elements.

    Parameters
    ----------
    system, elements, excitation, harmonics
        See :class:`LinearSystem`, :mod:`hbm.elements` (a list, each element with its
        direction), :class:`Excitation`, :class:`HarmonicSet`. The fundamental of the
        harmonic set must divide every element's base frequency.
    condensation
        ``"none"``, ``"gear"`` or ``"loa"`` (default).
    linear_solver
        ``"auto"``, ``"dense"`` or ``"krylov"`` (matrix-free Newton, loa only).
    aft
        ``"corrected"`` (default) or ``"sampled"``: the AFT of non-smooth forces with or
        without the sub-sample kink correction (T.13a).

    Attributes
    ----------
    elements
        The elements (tuple); ``n_elements`` of them, ``directions`` their ``g_e`` and
        ``G`` the (n, n_elements) matrix of them.
    steps
        Per element, the harmonic index of its base frequency (0: time-invariant).
    samples
        Per element, its parameters on the AFT grid (:meth:`Element.sample`).
    kbar
        Per element, ``k_bar_e`` (N/m) moved into ``Kp`` (eq. 17).
    length_scales
        Per element, the scale of its unknowns (m): the largest of its own and of its
        static deflection.
    """

    def __init__(self, system: LinearSystem, elements, excitation: Excitation,
                 harmonics: HarmonicSet, condensation: str = "loa",
                 linear_solver: str = "auto", aft: str = "corrected") -> None:
        elements = _check_inputs(system, elements, excitation, harmonics, condensation,
                                 linear_solver, aft)
        self.aft = aft
        n = system.n_dof
        hs = harmonics
        self.system, self.elements, self.excitation, self.harmonics = (system, elements,
                                                                        excitation, hs)
        self.condensation = condensation
        self.n_dof = n
        self.n_elements = len(elements)
        self.labels = tuple(f"elements[{i}] ({el.name})" for i, el in enumerate(elements))
        self.steps = tuple(0 if el.base_ratio is None else
                           hs.element_step(el.base_ratio, el.parameter_harmonics, lab)
                           for el, lab in zip(elements, self.labels, strict=True))
        # frequency of each retained index in units of hs.ratio Omega (the index itself
        # for a HarmonicSet; k . w / w_unit, possibly negative or 0, on a torus)
        self.kS = np.asarray(hs.frequency_index, dtype=float)
        self.harmonic_indices = np.asarray(hs.frequency_index, dtype=np.int64)
        self.nS = hs.n_harmonics
        self.nr = hs.n_real

        # forcing per harmonic index (nS, n) complex
        self.Fc, self.Fu = _forcing(excitation, hs, n)

        # element parameters on the AFT grid tau = w0 t (Omega-independent); the AFT itself
        # is by FFT (HarmonicSet.synthesize / analyse), E and A are built only on request
        self._aft: tuple | None = None
        self.samples = self._sample(hs.n_time)
        self.kbar = np.array([el.linear_stiffness for el in elements])
        self.directions = tuple(el.direction for el in elements)
        self.G = np.column_stack(self.directions)                      # (n, n_elements)
        kp = system.K
        for el, g in zip(elements, self.directions, strict=True):
            kp = kp + el.linear_stiffness * np.outer(g, g)             # eq. (17) operator
        self.Kp = kp
        # equilibration D = diag(M)^-1/2: D Z D is in 1/s^2 whatever the units of each
        # coordinate, so every dense factorisation below is done on it
        self.dof_eq = 1.0 / np.sqrt(np.diag(system.M))
        md = modes(self.Kp, system.M, system.C, self.directions, self.Fc, self.Fu,
                   self.dof_eq)
        self.modal, self.kp_symmetric = md.modal, md.kp_symmetric
        self.w2, self.phi, self.cj, self.gj = md.w2, md.phi, md.cj, md.gj
        self.pfc, self.pfu, self.rigid = md.pfc, md.pfu, md.rigid
        self.length_scales = np.array([
            float(max(el.scale(smp), static_deflection(md, self.Kp, g, gj, self.Fc[0],
                                                       self.dof_eq)))
            for el, smp, g, gj in zip(elements, self.samples, self.directions, md.gj,
                                      strict=True)])
        if not np.all(self.length_scales > 0):
            bad = [lab for lab, s in zip(self.labels, self.length_scales, strict=True)
                   if not s > 0]
            raise ValueError(f"problem: {', '.join(bad)} has no length scale (no own scale "
                             "and no static deflection): the unknowns cannot be scaled")
        self._fine_cache: dict[int, tuple] = {}
        # matrix-free Newton matrices solved by GMRES (hbm/krylov.py) for large sets
        self.matrix_free = condensation == "loa" and (
            linear_solver == "krylov" or (linear_solver == "auto"
                                          and self.n_elements * hs.n_real >= KRYLOV_MIN))
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
        kd = self.kS * self.harmonics.rate
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

    def modal_inverse(self, omega: float, derivative: bool = True,
                      columns: slice | np.ndarray | None = None
                      ) -> tuple[np.ndarray, np.ndarray | None]:
        """Modal receptances ``1 / (w_j^2 - (k w0)^2 + i k w0 c_j)`` and their
        Omega-derivatives (None unless ``derivative``), (n_modes, nS) complex (eq. 18-19).

        ``columns``: only these harmonic indices (a slice or an index array), the same
        numbers as those columns of the whole array (every entry is computed on its own).
        The static term of a rigid-body mode no element restrains is set to 0.
        Meaningful when :attr:`modal` (C diagonal in the eq. (17) modes).
        """
        w, kd = self.harmonic_frequencies(omega)
        ks = self.kS
        if columns is not None:
            w, kd, ks = w[columns], kd[columns], ks[columns]
        den = np.empty((self.w2.size, w.size), dtype=complex)
        den.real = self.w2[:, None] - (w ** 2)[None, :]
        den.imag = w[None, :] * self.cj[:, None]
        # static columns: index 0 (and, on a torus, combinations of zero frequency)
        zero = np.ix_(self.rigid, np.flatnonzero(ks == 0))
        den[zero] = 1.0
        mag2 = den.real * den.real  # 1/den = conj(den)/|den|^2: half NumPy's complex division
        mag2 += den.imag * den.imag
        if not np.all(mag2):
            raise ValueError(
                f"Omega = {omega:.6g} rad/s hits an undamped natural frequency exactly")
        inv = np.conjugate(den, out=den)
        inv *= np.reciprocal(mag2, out=mag2)
        inv[zero] = 0.0
        if not derivative:
            return inv, None
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

    def _sample(self, n_time: int) -> tuple:
        """Every element's parameters on a grid of ``n_time`` instants of one fundamental
        period (base phase ``step * tau``)."""
        hs = self.harmonics
        return tuple(el.sample(hs.base_phase(step, n_time)) if step else None
                     for el, step in zip(self.elements, self.steps, strict=True))

    def forces(self, delta_r: np.ndarray, jacobian: bool = True, law: float = 1.0):
        """AFT of every element's ``f'_e = f_e - k_bar_e Delta_e`` from the real
        coefficients of the Deltas (n_elements, n_real).

        ``law`` = 1 is each element's own law, 0 its linear law (a gear mesh: permanent
        active contact); values in between blend the two (homotopy). Returns the real
        coefficients of the f'_e (n_elements, n_real) (N) and, if asked, their
        derivatives ``d f'_e/d Delta_e``, a list of (n_real, n_real) matrices (N/m).
        """
        ft, st = self.force_samples(delta_r, jacobian, law)
        return ft, ([self.stiffness_matrix(s) for s in st] if jacobian else None)

    def force_samples(self, delta_r: np.ndarray, stiffness: bool = True,
                      law: float = 1.0) -> tuple[np.ndarray, list[ElementStiffness] | None]:
        """As :meth:`forces`, with each ``d f'_e/d Delta_e`` on the AFT grid
        (:class:`hbm.elements.ElementStiffness`) instead of the dense matrix.

        With ``aft = "corrected"`` the samples of a non-smooth force carry the sub-sample
        kink correction (T.13a) that makes them C1 in the unknowns.
        """
        delta = self.harmonics.synthesize(delta_r)
        corrected = self.aft == "corrected"
        fs, sts = [], []
        for el, smp, d in zip(self.elements, self.samples, delta, strict=True):
            f, st = el.force(d, smp, law, corrected, stiffness)
            fs.append(f)
            sts.append(st)
        ft = self.harmonics.analyse(fs[0][None] if len(fs) == 1 else np.stack(fs))
        return ft, (sts if stiffness else None)

    def element_jacobian(self, delta_r: np.ndarray) -> np.ndarray:
        """``J_f``: the block-diagonal ``d f'/d Delta`` of every element (n_elements n_real
        square, element-major), at the elements' own law."""
        return block_diagonal(self.forces(delta_r)[1])

    def stiffness_matrix(self, st: ElementStiffness) -> np.ndarray:
        """Real-layout matrix of ``x -> Galerkin(st.apply(x(tau)))``: an element's dense
        ``d f'/d Delta`` (n_real, n_real), kink blocks included."""
        out = self.multiplication_matrix(st.samples)
        kc = st.kinks
        if kc.nodes.size == 0:
            return out
        n = st.samples.size
        rows = np.stack([kc.nodes, kc.successors(n)], axis=1)
        cols = kc.columns(n)
        nodes = np.unique(np.concatenate([rows.ravel(), cols.ravel()]))
        pr, pc = np.searchsorted(nodes, rows), np.searchsorted(nodes, cols)
        d = np.zeros((nodes.size, nodes.size))
        np.add.at(d, (pr[:, :, None], pc[:, None, :]), kc.blocks)
        e = self.harmonics.grid_rows(nodes, st.samples.shape)
        return out + self.harmonics.galerkin_columns(e, n) @ (d @ e)

    def multiplication_matrix(self, s: np.ndarray) -> np.ndarray:
        """Real-layout matrix of ``x -> Galerkin(s x)`` on the AFT grid: ``A diag(s) E``
        built from the DFT of s by index gathering (circular convolution),
        O(N log N + n_real^2) (the basis's :meth:`multiplication_matrix`)."""
        return self.harmonics.multiplication_matrix(s)

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
        """Real coefficients of every ``Delta_e = g_e^T q`` from the unknowns,
        (n_elements, n_real)."""
        return self.scheme.delta_real(u)

    @property
    def vibration(self) -> np.ndarray:
        """Mask of the unknowns that are not a mean (index 0) of their signal."""
        return np.arange(self.n_unknowns) % self.nr != 0

    def evaluate(self, u: np.ndarray, omega: float, jacobian: bool = True, law: float = 1.0):
        """Residual R(u, Omega) and, if asked, dR/du and dR/dOmega (physical units).

        loa: R in m; none/gear: R in N (per DOF, DOF-major real layout).
        ``law``: the elements' law, see :meth:`forces`.
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
        contact-law homotopy, then damped Newton (:func:`hbm.problem.fixed_speed.solve`).

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
        """``dR/du`` in scaled unknowns and equations; a matrix-free one (loa: the scale of
        each element's unknowns and equations is the same length) is unchanged with one
        length scale, else rescaled between the elements' blocks."""
        if isinstance(ju, np.ndarray):
            return ju * (self.x_scale[None, :] / self.eq_scale[:, None])
        return ju.rescaled(self.length_scales)

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

    @property
    def sums_modally(self) -> bool:
        """Whether the condensation sums over the eq. (17) modes (``"loa"`` with a modal
        damping): :meth:`modal_coordinates` then exists."""
        return self.modal and hasattr(self.scheme, "modal_coordinates")

    def modal_coordinates(self, point: Point) -> np.ndarray | None:
        """The point's coordinates in the eq. (17) modes, ``recover(point) = phi @ eta``
        (n_modes, n_harmonics) complex (m), when the condensation sums modally
        (:attr:`sums_modally`); else None. A quadratic form of every DOF, such as a
        radiated power ``q^H W q``, is then ``eta^H (phi^T W phi) eta``: one product per
        point instead of two."""
        if not self.sums_modally:
            return None
        return self.scheme.modal_coordinates(point.unknowns, point.omega)

    def fine_grid(self, n_time: int) -> tuple[Synthesis, tuple]:
        """Synthesis operator (``synth @ x_real``) and every element's parameters on a grid
        of ``n_time`` samples (cached)."""
        if n_time not in self._fine_cache:
            if len(self._fine_cache) > 8:
                self._fine_cache.clear()
            self._fine_cache[n_time] = (Synthesis(self.harmonics, n_time),
                                        self._sample(n_time))
        return self._fine_cache[n_time]

    @property
    def periodic(self) -> bool:
        """True for a periodic response (a :class:`HarmonicSet`), False on a torus
        (:class:`hbm.torus.TorusBasis`: several independent base frequencies)."""
        return self.harmonics.periodic

    def require_periodic(self, what: str) -> None:
        """Refuse ``what`` (a one-period computation: Floquet stability, shooting, the
        response over one fundamental period) on a torus basis, saying why."""
        if not self.periodic:
            hs = self.harmonics
            raise ValueError(
                f"{what}: needs a periodic response (one fundamental, a HarmonicSet); this "
                f"problem's basis is a torus of {hs.dimension} base frequencies "
                f"({', '.join(hs.names)}): its response is quasi-periodic on the torus "
                "(docs/hbm.md, 'Several base frequencies'; hbm.post.torus for its "
                "statistics and its time line)")

    def require_torus(self, what: str) -> None:
        """Refuse ``what`` (a computation on the torus) on a periodic basis."""
        if self.periodic:
            raise ValueError(f"{what}: needs a torus basis (hbm.torus.TorusBasis); this "
                             "problem is periodic (use the one-period post-processing)")

    def fine_periods(self, n_time=None):
        """A sample count over one fundamental period, at least ``n_time`` (default four
        times the AFT grid's), that every element's base period (and each of its
        :attr:`~hbm.elements.base.Element.sub_periods`) divides evenly; on a torus
        the statistics grid (:meth:`hbm.torus.TorusBasis.refined_grid`)."""
        if not self.periodic:
            return self.harmonics.refined_grid(n_time)
        step = math.lcm(*(s * el.sub_periods for s, el in zip(self.steps, self.elements,
                                                               strict=True) if s), 1)
        n = 4 * self.harmonics.n_time if n_time is None else int(n_time)
        return step * int(np.ceil(n / step))
