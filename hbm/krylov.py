"""Matrix-free Newton matrices of the line-of-action condensation, solved by GMRES.

With the ``"loa"`` condensation the Newton matrix is ``J = I + H S`` (eq. 22-29 on the
line of action): ``H`` multiplies harmonic k by the receptance ``h_k`` and ``S`` is
the Galerkin product by the contact stiffness samples ``s(tau) - k_bar``
(``A diag(s) E``, eq. 13 differentiated). A product ``J v`` costs two FFTs of the AFT
grid, while forming ``J`` costs ``O(n_real^2)`` gathers and factorising it
``O(n_real^3)``: at 12 mesh harmonics with a contiguous set (1849 unknowns) 67 ms and
104 ms against 0.3 ms for a product.

:class:`LoaJacobian` is that operator, :class:`BorderedOperator` the continuation's
augmented matrix ``[[J, j_w], [row]]``. Both are solved by right-preconditioned GMRES
(:func:`gmres`) whose preconditioner is the LU factorisation of an *earlier* Newton
matrix of the same size, kept in a :class:`Preconditioners` store: along a branch
consecutive matrices differ little and GMRES converges in a few products. When it
does not within :data:`MAX_ITERATIONS`, the current matrix is formed, factorised
(:func:`hbm.newton.factor_checked`, with its condition estimate and singularity
check) and stored. The dense path of small problems is unchanged.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from .harmonics import HarmonicSet, complex_mul, mul_rows
from .newton import factor_checked

logger = logging.getLogger(__name__)

__all__ = ["BorderedOperator", "LoaJacobian", "MAX_ITERATIONS", "Preconditioners",
           "bordered", "gmres", "is_operator"]

RTOL = 1e-10            # GMRES relative residual of every Krylov solve
MAX_ITERATIONS = 40     # GMRES iterations before the preconditioner is refreshed
REFRESH_AFTER = 15      # a solve that needed more iterations refreshes it next time


@dataclass
class _Factor:
    lu: np.ndarray
    piv: np.ndarray
    cond: float
    stale: bool = False

    def solve(self, b: np.ndarray) -> np.ndarray:
        import scipy.linalg as sla

        return sla.lu_solve((self.lu, self.piv), b, check_finite=False)


@dataclass
class Preconditioners:
    """LU factors of the last formed Newton matrix of each size (the problem's and the
    continuation's bordered one), with counters for the benchmarks."""

    factors: dict[int, _Factor] = field(default_factory=dict)
    factorizations: int = 0
    solves: int = 0
    iterations: int = 0

    def clear(self) -> None:
        """Forget every factor (the next solve of each size factorises)."""
        self.factors.clear()


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
        """``x`` with ``self @ x = rhs`` and the condition estimate of the factor used."""
        st = self.store
        n = self.size
        st.solves += 1
        f = st.factors.get(n)
        if f is not None and not f.stale:
            x, its, ok = gmres(self.__matmul__, rhs, f.solve)
            st.iterations += its
            if ok:
                f.stale = its > REFRESH_AFTER
                return x, f.cond
        lu, piv, cond = factor_checked(self.dense(), where, warn)
        st.factorizations += 1
        f = st.factors[n] = _Factor(lu, piv, cond)
        return f.solve(rhs), cond


@dataclass
class LoaJacobian(_KrylovSolvable):
    """``J v = v + h (.) Galerkin((s - k_bar) E v)`` on the real layout (see the module).

    ``h``: receptance per harmonic (complex, m/N); ``s``: samples of ``s - k_bar``
    on the AFT grid (N/m); ``multiplication_matrix``: the problem's dense ``S``
    builder (for :meth:`dense`).
    """

    h: np.ndarray
    s: np.ndarray
    harmonics: HarmonicSet
    multiplication_matrix: Callable[[np.ndarray], np.ndarray]
    store: Preconditioners

    @property
    def size(self) -> int:
        return self.harmonics.n_real

    def __matmul__(self, v: np.ndarray) -> np.ndarray:
        hs = self.harmonics
        return v + complex_mul(self.h, hs.analyse(self.s * hs.synthesize(v)))

    def dense(self) -> np.ndarray:
        """The matrix itself (n_real, n_real)."""
        return np.eye(self.size) + mul_rows(self.h, self.multiplication_matrix(self.s))


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

    def dense(self) -> np.ndarray:
        """The matrix itself (n + 1, n + 1)."""
        return np.vstack([np.hstack([self.jx.dense(), self.jw[:, None]]), self.row[None, :]])


def is_operator(j) -> bool:
    """True for a matrix-free Newton matrix of this module."""
    return isinstance(j, _KrylovSolvable)


def bordered(jx, jw: np.ndarray, row: np.ndarray):
    """``[[jx, jw], [row]]``: dense when ``jx`` is an array, else a :class:`BorderedOperator`."""
    if is_operator(jx):
        return BorderedOperator(jx, np.asarray(jw, dtype=float), np.asarray(row, dtype=float))
    return np.vstack([np.hstack([jx, jw[:, None]]), row[None, :]])
