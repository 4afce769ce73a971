"""Matrix-free Newton matrices of the condensation onto the elements, solved by GMRES.

With the ``"loa"`` condensation the Newton matrix is ``J = I + H S`` (eq. 22-29 on the
elements' deflections): ``H`` multiplies harmonic k by the E x E receptance ``H_k`` and
``S`` is block-diagonal over the elements, each block the Galerkin product by the
element's stiffness samples ``s_e(tau) - k_bar_e`` (``A diag(s_e) E``, eq. 13
differentiated for a gear mesh). A product ``J v`` costs two FFTs of the AFT grid per
element, while forming ``J`` costs ``O((E n_real)^2)`` gathers and factorising it
``O((E n_real)^3)``: at 12 mesh harmonics with a contiguous set (1849 unknowns, one mesh)
67 ms and 104 ms against 0.3 ms for a product.

:class:`LoaJacobian` is that operator, :class:`BorderedOperator` the continuation's
augmented matrix ``[[J, j_w], [row]]``. Both are solved by right-preconditioned GMRES
(:func:`gmres`) whose preconditioner is the LU factorisation of an *earlier* Newton
matrix of the same size, kept in a :class:`Preconditioners` store: along a branch
consecutive matrices differ little and GMRES converges in ~10 products. A solve that
needed more than :data:`REFRESH_AFTER` iterations, or one that fails within
:data:`MAX_ITERATIONS`, makes the next solve form the current matrix (without the
kink blocks of T.13a, a rank-2m update GMRES takes care of) and factorise it, in
single precision first (:func:`hbm.newton.factor_checked`, with its condition
estimate and singularity check), then in double if GMRES still fails. The dense
path of small problems is unchanged.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from .basis import HarmonicSet, complex_mul, mul_rows
from .elements.base import ElementStiffness, KinkCorrection
from .newton import ConvergenceError, factor_checked

logger = logging.getLogger(__name__)

__all__ = ["BorderedOperator", "LoaJacobian", "MAX_ITERATIONS", "Preconditioners",
           "bordered", "contiguous_matrix", "gmres", "is_operator"]

RTOL = 1e-10            # GMRES relative residual of every Krylov solve
MAX_ITERATIONS = 60     # GMRES iterations before the preconditioner is refreshed
# a solve that needed more iterations refreshes it next time: a refresh (forming and
# factorising J) costs as much as ~50 iterations at 1849 unknowns
REFRESH_AFTER = 30


@dataclass
class _Factor:
    lu: np.ndarray
    piv: np.ndarray
    cond: float
    stale: bool = False

    def solve(self, b: np.ndarray) -> np.ndarray:
        # LAPACK getrs itself (what scipy.linalg.lu_solve calls, without its checks)
        x, info = _getrs(self.lu.dtype)(self.lu, self.piv, b.astype(self.lu.dtype))
        if info != 0:
            raise ConvergenceError(f"preconditioner solve: getrs info = {info}")
        return x.astype(float, copy=False)


def _getrs(dtype):
    """LAPACK ``?getrs`` for factors of ``dtype`` (cached)."""
    if dtype not in _GETRS:
        from scipy.linalg import get_lapack_funcs

        _GETRS[dtype] = get_lapack_funcs("getrs", dtype=dtype)
    return _GETRS[dtype]


_GETRS: dict = {}


@dataclass
class Preconditioners:
    """LU factors of the last formed Newton matrix of each size (the problem's and the
    continuation's bordered one), with counters for the benchmarks."""

    factors: dict[int, _Factor] = field(default_factory=dict)
    factorizations: int = 0
    solves: int = 0
    iterations: int = 0


def gmres(matvec: Callable[[np.ndarray], np.ndarray], b: np.ndarray,
          psolve: Callable[[np.ndarray], np.ndarray], rtol: float = RTOL,
          max_iter: int = MAX_ITERATIONS) -> tuple[np.ndarray, int, bool]:
    """Right-preconditioned GMRES without restart: ``A M^-1 z = b``, ``x = M^-1 z``.

    The residual it monitors is the true one of ``A x = b`` (right preconditioning);
    Gram-Schmidt is done twice (CGS2). Returns ``(x, iterations, converged)``.
    """
    n = b.size
    beta = float(np.linalg.norm(b))
    if beta == 0.0:
        return np.zeros(n), 0, True
    v = np.empty((max_iter + 1, n))
    z = np.empty((max_iter, n))
    h = np.zeros((max_iter + 1, max_iter))
    cs, sn = np.zeros(max_iter), np.zeros(max_iter)
    g = np.zeros(max_iter + 1)
    g[0] = beta
    v[0] = b / beta
    k = 0
    for j in range(max_iter):
        z[j] = psolve(v[j])
        w = matvec(z[j])
        for _ in range(2):
            c = v[:j + 1] @ w
            w = w - c @ v[:j + 1]
            h[:j + 1, j] += c
        h[j + 1, j] = float(np.linalg.norm(w))
        for i in range(j):                        # earlier Givens rotations
            a, bb = h[i, j], h[i + 1, j]
            h[i, j], h[i + 1, j] = cs[i] * a + sn[i] * bb, -sn[i] * a + cs[i] * bb
        r = float(np.hypot(h[j, j], h[j + 1, j]))
        cs[j], sn[j] = (1.0, 0.0) if r == 0.0 else (h[j, j] / r, h[j + 1, j] / r)
        h[j, j], h[j + 1, j] = r, 0.0
        g[j + 1], g[j] = -sn[j] * g[j], cs[j] * g[j]
        k = j + 1
        if abs(g[j + 1]) <= rtol * beta:
            break
        nv = float(np.linalg.norm(w))
        if nv == 0.0:
            break
        v[j + 1] = w / nv
    if k == 0 or np.any(np.diag(h[:k, :k]) == 0.0):
        return np.zeros(n), k, False
    import scipy.linalg as sla

    y = sla.solve_triangular(h[:k, :k], g[:k])
    x = y @ z[:k]
    return x, k, bool(abs(g[k]) <= rtol * beta)


class _KrylovSolvable:
    """Shared solve of the matrix-free Newton matrices: GMRES preconditioned by the
    stored factor of an earlier matrix of the same size, else a fresh factorisation."""

    store: Preconditioners

    @property
    def shape(self) -> tuple[int, int]:
        n = self.size
        return n, n

    def solve(self, rhs: np.ndarray, where: str, warn: bool) -> tuple[np.ndarray, float]:
        """``x`` with ``self @ x = rhs`` and the condition estimate of the factor used.

        GMRES with the stored factor; if it is stale or GMRES fails, with a fresh
        single-precision factor of this matrix, then a double-precision one.
        """
        st = self.store
        n = self.size
        st.solves += 1
        f = st.factors.get(n)
        tries = [None, np.float32, np.float64] if f is not None and not f.stale else \
            [np.float32, np.float64]
        its = 0
        for dtype in tries:
            if dtype is not None:
                lu, piv, cond = factor_checked(self.dense(kinks=False), where, warn, dtype)
                st.factorizations += 1
                f = st.factors[n] = _Factor(lu, piv, cond)
            x, its, ok = gmres(self.__matmul__, rhs, f.solve)
            st.iterations += its
            if ok:
                f.stale = its > REFRESH_AFTER
                return x, f.cond
        raise ConvergenceError(f"{where}: GMRES did not reach {RTOL:.0e} in {its} iterations "
                               f"with a fresh factor (condition estimate {f.cond:.2g})",
                               np.inf, f.cond)


@dataclass
class LoaJacobian(_KrylovSolvable):
    """``J v = v + H (.) Galerkin(S (E v))`` on the real layout, element-major (see the
    module).

    ``h``: receptances per element pair and harmonic (E, E, nS) (complex, m/N);
    ``stiffness``: each element's ``d f'/d Delta`` on the AFT grid
    (:class:`hbm.elements.ElementStiffness`); ``stiffness_matrix``: the problem's dense
    builder of one element's ``S`` (for :meth:`dense`); ``scales``: the elements' length
    scales when the unknowns of different elements are scaled differently (the operator
    in scaled unknowns and equations, ``D^-1 J D``), else None.
    """

    h: np.ndarray
    stiffness: list
    harmonics: HarmonicSet
    stiffness_matrix: Callable[[ElementStiffness], np.ndarray]
    store: Preconditioners
    scales: np.ndarray | None = None

    @property
    def n_elements(self) -> int:
        return self.h.shape[0]

    @property
    def size(self) -> int:
        return self.n_elements * self.harmonics.n_real

    def rescaled(self, lengths: np.ndarray) -> LoaJacobian:
        """The operator in unknowns and equations scaled by each element's length
        ``lengths`` (E,): itself when they are all equal (then ``D^-1 J D = J``)."""
        lengths = np.asarray(lengths, dtype=float)
        if np.all(lengths == lengths[0]):
            return self
        return LoaJacobian(self.h, self.stiffness, self.harmonics, self.stiffness_matrix,
                           self.store, lengths)

    def __matmul__(self, v: np.ndarray) -> np.ndarray:
        hs = self.harmonics
        ne, nr = self.n_elements, hs.n_real
        vv = v.reshape(ne, nr)
        if self.scales is not None:
            vv = vv * self.scales[:, None]
        x = hs.synthesize(vv)
        ys = [st.apply(xe) for st, xe in zip(self.stiffness, x, strict=True)]
        a = hs.analyse(ys[0][None] if ne == 1 else np.stack(ys))
        if ne == 1 and self.scales is None:
            return v + complex_mul(self.h[0, 0], a[0])
        out = np.empty(ne * nr)
        for e in range(ne):
            acc = complex_mul(self.h[e, 0], a[0])
            for f in range(1, ne):
                acc = acc + complex_mul(self.h[e, f], a[f])
            if self.scales is not None:
                acc = acc / self.scales[e]
            out[e * nr:(e + 1) * nr] = v[e * nr:(e + 1) * nr] + acc
        return out

    def dense(self, kinks: bool = True) -> np.ndarray:
        """The matrix itself (E n_real square); without the kink blocks of T.13a when
        ``kinks`` is False (the preconditioner: they are a rank-2m update costing
        ``O(n_real^2 m)`` for m crossings, GMRES takes them into account)."""
        hs = self.harmonics
        ne, nr = self.n_elements, hs.n_real
        sts = self.stiffness
        fast = not kinks and hs.contiguous and all(2 * hs.max_index < st.samples.size
                                                   for st in sts)
        if not fast:
            if not kinks:
                sts = [ElementStiffness(st.samples, KinkCorrection.none(st.samples.shape))
                       for st in sts]
            mats = [self.stiffness_matrix(st) for st in sts]
        if ne == 1:
            j = contiguous_matrix(self.h[0, 0], sts[0].samples) if fast else \
                np.eye(nr) + mul_rows(self.h[0, 0], mats[0])
        else:
            j = np.eye(ne * nr)
            for e in range(ne):
                for f in range(ne):
                    block = contiguous_matrix(self.h[e, f], sts[f].samples, identity=False) \
                        if fast else mul_rows(self.h[e, f], mats[f])
                    j[e * nr:(e + 1) * nr, f * nr:(f + 1) * nr] += block
        if self.scales is not None:
            s = np.repeat(self.scales, nr)
            j = j * (s[None, :] / s[:, None])
        return j


@dataclass
class BorderedOperator(_KrylovSolvable):
    """``[[J, j_w], [row]]``: the continuation's augmented Newton matrix."""

    jx: LoaJacobian
    jw: np.ndarray
    row: np.ndarray

    @property
    def store(self) -> Preconditioners:   # type: ignore[override]
        return self.jx.store

    @property
    def size(self) -> int:
        return self.jw.size + 1

    def __matmul__(self, v: np.ndarray) -> np.ndarray:
        return np.concatenate([self.jx @ v[:-1] + self.jw * v[-1], [self.row @ v]])

    def dense(self, kinks: bool = True) -> np.ndarray:
        """The matrix itself (n + 1, n + 1) (``kinks``: see :meth:`LoaJacobian.dense`)."""
        return np.vstack([np.hstack([self.jx.dense(kinks), self.jw[:, None]]),
                          self.row[None, :]])


def contiguous_matrix(h: np.ndarray, samples: np.ndarray, identity: bool = True) -> np.ndarray:
    """``I + H A diag(s) E`` (real layout) for the contiguous set ``0..K`` on ``N > 2K``
    samples ``s``: the matrix of :meth:`LoaJacobian.dense` without kink blocks, equal to
    it entry by entry, built from the DFT of ``s`` read as Toeplitz (``s_hat[k - l]``)
    and Hankel (``s_hat[k + l]``) strided views: no index arrays, a fifth of the time.
    Without the identity when ``identity`` is False (an off-diagonal block of several
    elements).

    With ``w_0 = 1``, ``w_k = 2`` and ``x_l = a_l + i b_l`` (eq. 13 linearised, Galerkin):
    ``y_k = h_k w_k (s_hat_k x_0 + 1/2 sum_l (s_hat_{k-l} + s_hat_{k+l}) a_l
    + i/2 sum_l (s_hat_{k-l} - s_hat_{k+l}) b_l)``.
    """
    from numpy.lib.stride_tricks import as_strided

    n = samples.size
    k_top = h.size - 1
    sh = np.fft.fft(samples) / n
    ext = np.concatenate([sh[n - k_top:], sh[:k_top + 1]])       # ext[i] = s_hat[i - K]
    b = ext.itemsize
    # p[k, l - 1] = s_hat[k - l] = ext[K + k - l], q[k, l - 1] = s_hat[k + l]; l = 1..K
    p = as_strided(ext[k_top - 1:], shape=(k_top + 1, k_top), strides=(b, -b),
                   writeable=False)
    q = as_strided(sh[1:], shape=(k_top + 1, k_top), strides=(b, b), writeable=False)
    w = np.full(k_top + 1, 2.0)
    w[0] = 1.0
    hw = (0.5 * w * h)[:, None]
    c = hw * (p + q)                      # coefficient of a_l
    d = (1j * hw) * (p - q)               # coefficient of b_l
    col0 = w * h * sh[:k_top + 1]         # coefficient of x_0
    nr = 2 * k_top + 1
    j = np.empty((nr, nr))
    j[0, 0] = col0[0].real
    j[1::2, 0], j[2::2, 0] = col0[1:].real, col0[1:].imag
    j[0, 1::2], j[0, 2::2] = c[0].real, d[0].real
    j[1::2, 1::2], j[2::2, 1::2] = c[1:].real, c[1:].imag
    j[1::2, 2::2], j[2::2, 2::2] = d[1:].real, d[1:].imag
    if identity:
        j[np.diag_indices(nr)] += 1.0
    return j


def is_operator(j) -> bool:
    """True for a matrix-free Newton matrix of this module."""
    return isinstance(j, _KrylovSolvable)


def bordered(jx, jw: np.ndarray, row: np.ndarray):
    """``[[jx, jw], [row]]``: dense when ``jx`` is an array, else a :class:`BorderedOperator`."""
    if is_operator(jx):
        return BorderedOperator(jx, np.asarray(jw, dtype=float), np.asarray(row, dtype=float))
    return np.vstack([np.hstack([jx, jw[:, None]]), row[None, :]])
