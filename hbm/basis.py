"""The harmonic basis: a set of harmonics of a fundamental frequency, the AFT grid, and
the real/complex Fourier layout of the HBM unknowns.

Convention (docs/architecture.md, "Fourier convention"): a periodic signal is
``x(t) = Re sum_{k in S} x_k exp(i k w0 t)`` with ``S`` a sorted set of
non-negative integer indices containing 0 and ``x_0`` real (eq. 20).  The real
unknown layout of one signal is ``[x_0, Re x_k1, Im x_k1, Re x_k2, Im x_k2, ...]``.

The fundamental is ``w0 = r Omega``, ``r`` a positive rational number (a
:class:`fractions.Fraction`) of the reference speed Omega: 1 for the shaft, Z for the
mesh of a gear with Z teeth on that shaft, 1/2 for a period-2 response, the common
submultiple of several shafts' and meshes' frequencies for a train
(:func:`common_fundamental`). A frequency ``p Omega`` (an excitation's order, an
element's base frequency) is the harmonic index ``p / r`` when that is an integer.
"""

from __future__ import annotations

import logging
import math
import numbers
from dataclasses import dataclass, field
from fractions import Fraction
from functools import cached_property
from typing import Any, ClassVar, Protocol

import numpy as np

logger = logging.getLogger(__name__)

__all__ = ["SET_KINDS", "Basis", "HarmonicSet", "RealLayout", "as_ratio", "combination_offsets",
           "common_fundamental", "complex_mul", "default_n_time", "embed_coefficients",
           "index_positions", "mul_rows", "real_blocks"]

# How HarmonicSet.build fills the sidebands (docs/convergence.md, "Harmonic sets")
SET_KINDS = ("combinations", "bands", "contiguous")


def combination_offsets(orders, order: int) -> set[int]:
    """Positive shaft orders ``|sum c_i e_i|`` with ``1 <= sum |c_i| <= order``.

    Every frequency the external orders ``e_i`` create together through a nonlinearity
    of polynomial degree ``order``: sums and differences, each order used up to
    ``order`` times (e.g. e = {2, 4}, order 2: 2, 4, 6, 8 and 4 - 2 = 2). Built by
    adding one ``+-e_i`` at a time to the offsets of the previous degree (reachable
    sums, not coefficient vectors: O(order * n_orders * |offsets|)).
    """
    ext = sorted({int(e) for e in orders})
    if int(order) != order or order < 0:
        raise ValueError(f"harmonics.sideband_order = {order!r}: must be an integer >= 0")
    frontier, seen = {0}, {0}
    for _ in range(int(order)):
        frontier = {v + sgn * e for v in frontier for e in ext for sgn in (1, -1)}
        seen |= frontier
    return {abs(v) for v in seen if v != 0}


def default_n_time(max_index: int) -> int:
    """Number of AFT time samples for a largest harmonic index ``max_index``.

    The contact force is ``k_m(t)`` times a piecewise-linear function of ``Delta``;
    a product of two signals of largest index H lands on indices up to 2H, and
    projecting it onto indices <= H without aliasing needs N > 3H samples.  The
    kinks of the dead zone add a slowly decaying tail, so we take four times that
    margin: the smallest power of two >= max(64, 8 H + 4).
    """
    need = max(64, 8 * int(max_index) + 4)
    return int(2 ** int(np.ceil(np.log2(need))))


def as_ratio(value, name: str, positive: bool = True) -> Fraction:
    """``value`` as an exact frequency ratio (:class:`fractions.Fraction`).

    Integers and fractions are exact; a float is accepted when it is an integer (a
    non-integer float such as 0.1 has no exact ratio: give a ``Fraction``); a string
    such as ``"1/2"`` is parsed. Refused, naming ``name``: booleans, negative values
    (or zero when ``positive``), anything else.
    """
    if isinstance(value, bool):
        raise ValueError(f"{name} = {value!r}: must be a frequency ratio, not a boolean")
    if isinstance(value, numbers.Rational):
        r = Fraction(value)
    elif isinstance(value, str):
        try:
            r = Fraction(value)
        except ValueError as exc:
            raise ValueError(f"{name} = {value!r}: must be a ratio such as 3 or '1/2'") \
                from exc
    elif isinstance(value, numbers.Real) and math.isfinite(value) and int(value) == value:
        r = Fraction(int(value))
    else:
        raise ValueError(f"{name} = {value!r}: must be an integer or a fractions.Fraction "
                         "(an exact frequency ratio)")
    if r < 0 or (positive and r == 0):
        raise ValueError(f"{name} = {value!r}: must be {'> 0' if positive else '>= 0'}")
    return r


def common_fundamental(*ratios) -> Fraction:
    """The largest ratio ``r`` of which every one of ``ratios`` (> 0) is an integer multiple:
    the fundamental ``w0 = r Omega`` of a basis that holds all those frequencies
    (e.g. 2 and 3: 1; 6 and 9/2: 3/2; a pair of 23:61 teeth at Omega: ``Z1 = 23`` and the
    shaft orders 1 and 23/61 give 1/61)."""
    rs = [as_ratio(r, "common_fundamental ratio") for r in ratios]
    if not rs:
        raise ValueError("common_fundamental: needs at least one ratio")
    den = math.lcm(*(r.denominator for r in rs))
    num = math.gcd(*(r.numerator * (den // r.denominator) for r in rs))
    return Fraction(num, den)


class Basis(Protocol):
    """What the harmonic balance (:class:`hbm.problem.HBMProblem`, the condensations,
    :mod:`hbm.krylov`) asks of a harmonic basis; :class:`HarmonicSet` (one fundamental,
    periodic responses) and :class:`hbm.torus.TorusBasis` (d independent base
    frequencies, multi-dimensional AFT on a torus grid) both satisfy it.

    A signal is ``x = Re sum_k x_k exp(i k . theta)`` over the retained indices ``k``
    (``indices``; the first is the mean), real layout ``[x_0, Re x_k1, Im x_k1, ...]``
    (:class:`RealLayout`); index ``k`` has the frequency ``frequency_index[k] * ratio *
    Omega`` (an integer multiple of the exact ``ratio``, possibly negative or zero on a
    torus). ``n_time`` is the AFT grid (an int, or a shape on a torus), ``synthesize`` /
    ``analyse`` go between the real layout and samples on it by FFT,
    ``multiplication_matrix`` and ``grid_rows``/``galerkin_columns`` give the Galerkin
    matrix of a product by samples (the Jacobian blocks), ``element_step`` /
    ``base_phase`` where an element's base frequency sits and its phase on the grid,
    ``index_of`` the index of an excitation's frequency. ``periodic``: Floquet theory
    and the one-period post-processing apply (one fundamental).
    """

    indices: tuple
    ratio: Fraction
    fundamental: str
    n_time: Any
    periodic: bool

    @property
    def dimension(self) -> int: ...

    @property
    def n_harmonics(self) -> int: ...

    @property
    def n_real(self) -> int: ...

    @property
    def contiguous(self) -> bool: ...

    @property
    def rate(self) -> float: ...

    @property
    def frequency_index(self) -> tuple[int, ...]: ...

    def fundamental_rad_s(self, omega: float) -> float: ...

    def index_of(self, key) -> Any: ...

    def element_step(self, ratio, harmonics, label: str) -> Any: ...

    def base_phase(self, step, n_time=None) -> np.ndarray: ...

    def to_real(self, xc: np.ndarray) -> np.ndarray: ...

    def to_complex(self, xr: np.ndarray) -> np.ndarray: ...

    def synthesize(self, xr: np.ndarray, n_time=None) -> np.ndarray: ...

    def analyse(self, x: np.ndarray) -> np.ndarray: ...

    def aft_matrices(self, n_time=None) -> tuple[np.ndarray, np.ndarray]: ...

    def multiplication_matrix(self, s: np.ndarray) -> np.ndarray: ...

    def grid_rows(self, nodes: np.ndarray, shape: tuple[int, ...]) -> np.ndarray: ...

    def galerkin_columns(self, rows: np.ndarray, n_time: int) -> np.ndarray: ...


class RealLayout:
    """The real layout of the Fourier coefficients of one signal, shared by the bases:
    ``[x_0, Re x_k1, Im x_k1, Re x_k2, Im x_k2, ...]`` (index 0 real)."""

    @property
    def n_harmonics(self) -> int:
        """Number of harmonic indices (complex coefficients per signal)."""
        return len(self.indices)

    @property
    def n_real(self) -> int:
        """Real unknowns per signal: ``2 * n_harmonics - 1`` (index 0 is real)."""
        return 2 * len(self.indices) - 1

    def to_real(self, xc: np.ndarray) -> np.ndarray:
        """Complex coefficients (..., n_harmonics) -> real layout (..., n_real)."""
        xc = np.asarray(xc)
        out = np.empty(xc.shape[:-1] + (self.n_real,))
        out[..., 0] = xc[..., 0].real
        out[..., 1::2] = xc[..., 1:].real
        out[..., 2::2] = xc[..., 1:].imag
        return out

    def to_complex(self, xr: np.ndarray) -> np.ndarray:
        """Real layout (..., n_real) -> complex coefficients (..., n_harmonics)."""
        xr = np.asarray(xr, dtype=float)
        out = np.empty(xr.shape[:-1] + (self.n_harmonics,), dtype=complex)
        out[..., 0] = xr[..., 0]
        out[..., 1:] = xr[..., 1::2] + 1j * xr[..., 2::2]
        return out

    def galerkin_columns(self, rows: np.ndarray, n_time: int) -> np.ndarray:
        """Columns of the Galerkin analysis matrix ``A`` (n_real, m) at the samples whose
        synthesis ``rows`` are given, on a grid of ``n_time`` samples in all."""
        w = np.where(np.arange(self.n_real) == 0, 1.0, 2.0) / n_time
        return rows.T * w[:, None]

    def product_matrix(self, sh: np.ndarray, p: np.ndarray, q: np.ndarray) -> np.ndarray:
        """Real-layout matrix of ``x -> Galerkin(s x)`` from the DFT coefficients of the
        samples ``s``: ``sh`` at each index ``k`` (nS,), ``p = s_hat[k - l]`` and
        ``q = s_hat[k + l]`` (nS, nS - 1) for the indices ``l`` but the first.

        With ``w_0 = 1``, ``w_k = 2`` and ``x_l = a_l + i b_l``: ``y_k = w_k (s_hat_k x_0
        + 1/2 sum_l (s_hat_{k-l} + s_hat_{k+l}) a_l + i/2 sum_l (s_hat_{k-l} -
        s_hat_{k+l}) b_l)``.
        """
        wk = np.where(np.arange(sh.size) == 0, 1.0, 2.0)[:, None]
        dc = np.empty((sh.size, self.n_real), dtype=complex)
        dc[:, 0] = wk[:, 0] * sh
        dc[:, 1::2] = 0.5 * wk * (p + q)
        dc[:, 2::2] = 0.5j * wk * (p - q)
        return self.to_real(dc.T).T


@dataclass(frozen=True)
class HarmonicSet(RealLayout):
    """Explicit set of harmonic indices of the fundamental ``w0 = ratio * Omega``.

    Parameters
    ----------
    indices
        Sorted unique non-negative integers containing 0.
    ratio
        The fundamental as a ratio of the reference speed, ``w0 / Omega`` (> 0, exact:
        int, :class:`fractions.Fraction` or a string such as ``"1/2"``). A frequency
        ``p Omega`` is index ``p / ratio`` when that is an integer
        (:meth:`index_of`).
    fundamental
        What the fundamental is, in words (``"shaft"``, ``"mesh"``, ...); default
        ``"shaft"`` for ratio 1, else ``"mesh"`` for an integer ratio, else
        ``"subharmonic"``.
    n_time
        AFT samples per fundamental period (default :func:`default_n_time`).
    """

    indices: tuple[int, ...]
    ratio: Fraction = Fraction(1)
    fundamental: str = "shaft"
    n_time: int = field(default=0)

    def __init__(self, indices, ratio=1, fundamental: str | None = None,
                 n_time: int | None = None) -> None:
        try:
            arr = [int(i) for i in indices]
        except (TypeError, ValueError) as exc:
            raise ValueError(f"harmonics.indices = {indices!r}: must be integers") from exc
        if any(i != j for i, j in zip(arr, indices, strict=True)):
            raise ValueError(f"harmonics.indices = {indices!r}: must be integers")
        if len(arr) == 0 or 0 not in arr:
            raise ValueError(f"harmonics.indices = {list(arr)}: must contain 0 (the mean)")
        if min(arr) < 0:
            raise ValueError(f"harmonics.indices = {list(arr)}: must be >= 0")
        if arr != sorted(set(arr)):
            raise ValueError(f"harmonics.indices = {list(arr)}: must be sorted and unique")
        r = as_ratio(ratio, "harmonics.ratio")
        if fundamental is None:
            fundamental = "shaft" if r == 1 else "mesh" if r.denominator == 1 else \
                "subharmonic"
        if not isinstance(fundamental, str) or not fundamental:
            raise ValueError(f"harmonics.fundamental = {fundamental!r}: must be a name "
                             "(e.g. 'shaft', 'mesh')")
        hmax = max(arr)
        n = default_n_time(hmax) if n_time is None else int(n_time)
        if n <= 2 * hmax:
            raise ValueError(
                f"harmonics.n_time = {n}: must be > 2 * max index = {2 * hmax}")
        object.__setattr__(self, "indices", tuple(arr))
        object.__setattr__(self, "ratio", r)
        object.__setattr__(self, "fundamental", fundamental)
        object.__setattr__(self, "n_time", n)

    # ------------------------------------------------------------------ builders
    @classmethod
    def build(cls, n_teeth: int, mesh_harmonics: int, external_orders=(),
              sideband_order: int = 1, max_index: int | None = None,
              n_time: int | None = None, kind: str = "combinations") -> HarmonicSet:
        """Harmonic set carrying the mesh harmonics, external orders and sidebands.

        Parameters
        ----------
        n_teeth
            Tooth count Z of the gear whose shaft speed is Omega.
        mesh_harmonics
            Number of mesh harmonics kZ kept (k = 1 .. mesh_harmonics).
        external_orders
            Shaft orders of the external excitation (positive integers). Empty:
            the fundamental is the mesh frequency and the set is {0, 1, ..., H}
            whatever ``kind``.
        sideband_order
            Highest combination order s of the external orders (see ``kind``).
        max_index
            Indices above it are dropped.
        kind
            ``"combinations"``: every index the excitation creates up to order s,
            ``kZ + sum c_i e_i`` with ``0 <= k <= mesh_harmonics`` and
            ``sum |c_i| <= s`` (:func:`combination_offsets`), the fewest unknowns.
            ``"bands"``: every index of the excitation's lattice (multiples of
            ``g = gcd(e_i)`` away from a mesh harmonic) within the reach of order s,
            ``|kZ - n| <= s max(e_i)``: the order-s combinations and the indices
            between them that take more combinations (on the pump, Z = 76,
            e = {1, 2, 4}: Z - 15 needs order 5, Z - 16 order 4). ``"contiguous"``:
            ``{0, 1, ..., H Z + s max(e_i)}``, every index up to the largest of the
            other two (docs/convergence.md, "Harmonic sets", for when each is cheaper).
        """
        if kind not in SET_KINDS:
            raise ValueError(f"harmonics.kind = {kind!r}: must be one of {', '.join(SET_KINDS)}")
        if int(n_teeth) != n_teeth or n_teeth < 1:
            raise ValueError(f"harmonics.n_teeth = {n_teeth!r}: must be an integer >= 1")
        if int(mesh_harmonics) != mesh_harmonics or mesh_harmonics < 0:
            raise ValueError(
                f"harmonics.mesh_harmonics = {mesh_harmonics!r}: must be an integer >= 0")
        if int(sideband_order) != sideband_order or sideband_order < 0:
            raise ValueError(
                f"harmonics.sideband_order = {sideband_order!r}: must be an integer >= 0")
        ext = [int(e) for e in external_orders]
        if any(e != f or e < 1 for e, f in zip(ext, external_orders, strict=True)):
            raise ValueError(
                f"harmonics.external_orders = {list(external_orders)!r}: must be integers >= 1")
        z, h, s = int(n_teeth), int(mesh_harmonics), int(sideband_order)
        if not ext:
            idx = set(range(h + 1))
            fundamental, ratio = "mesh", z
        else:
            ext = sorted(set(ext))
            if kind == "combinations":
                offsets = combination_offsets(ext, s) | set(ext)
            else:
                g = math.gcd(*ext)
                reach = max(s * ext[-1], ext[-1])       # the external orders themselves
                offsets = set(range(g, reach + 1, g))
            idx = {0} | offsets
            for k in range(1, h + 1):
                idx.add(k * z)
                for c in offsets:
                    idx.add(abs(k * z + c))
                    idx.add(abs(k * z - c))
            if kind == "contiguous":
                idx = set(range(max(idx) + 1))
            fundamental, ratio = "shaft", 1
        if max_index is not None:
            if int(max_index) != max_index or max_index < 0:
                raise ValueError(f"harmonics.max_index = {max_index!r}: must be an integer >= 0")
            idx = {i for i in idx if i <= max_index}
        return cls(sorted(idx), ratio=ratio, fundamental=fundamental, n_time=n_time)

    # ------------------------------------------------------------------ helpers
    #: one fundamental: a periodic response (Floquet theory, one-period post-processing)
    periodic: ClassVar[bool] = True

    @property
    def dimension(self) -> int:
        """Number of base frequencies: 1."""
        return 1

    @property
    def frequency_index(self) -> tuple[int, ...]:
        """Frequency of each index in units of the fundamental: the indices."""
        return self.indices

    @property
    def max_index(self) -> int:
        return self.indices[-1]

    @property
    def contiguous(self) -> bool:
        """True for the contiguous set ``{0, 1, ..., K}``."""
        return self.indices[-1] == len(self.indices) - 1

    def index_of(self, ratio) -> int | None:
        """Harmonic index of the frequency ``ratio * Omega`` (``ratio / self.ratio``), or
        None if that is not an integer or not in the set."""
        q = as_ratio(ratio, "frequency ratio", positive=False) / self.ratio
        if q.denominator != 1:
            return None
        return int(q) if int(q) in self.indices else None

    def step_of(self, ratio, name: str) -> int:
        """Harmonic index of the base frequency ``ratio * Omega`` of ``name`` (whether or
        not the set holds it): ``ratio / self.ratio``, refused unless a positive integer
        (the fundamental must divide every base frequency)."""
        q = as_ratio(ratio, f"{name} base frequency ratio") / self.ratio
        if q.denominator != 1:
            raise ValueError(
                f"harmonics.ratio = {self.ratio}: the fundamental w0 = {self.ratio} Omega "
                f"does not divide the base frequency {ratio} Omega of {name} (ratio {q}); "
                f"use a common submultiple (hbm.common_fundamental)")
        return int(q)

    def element_step(self, ratio, harmonics, label: str) -> int:
        """Harmonic index of an element's base frequency ``ratio * Omega`` (:meth:`step_of`)
        with its parameters' top harmonic (of ``harmonics``, the harmonics of its base
        frequency it holds) checked against the AFT grid; a warning names the harmonics
        the set does not hold."""
        step = self.step_of(ratio, label)
        top = max(harmonics, default=0) * step
        if 2 * top >= self.n_time:
            raise ValueError(
                f"harmonics.n_time = {self.n_time}: too few samples for harmonic "
                f"{max(harmonics, default=0)} of {label} (index {top}); need > {2 * top}")
        missing = [m for m in harmonics if m * step not in self.indices]
        if missing:
            logger.warning("%s: harmonics %s of its base frequency are not in the harmonic "
                           "set; their direct contribution is only seen through products",
                           label, sorted(set(missing)))
        return step

    def base_phase(self, step: int, n_time: int | None = None) -> np.ndarray:
        """The phase ``step * tau`` (rad) of a base frequency of index ``step`` on a grid of
        ``n_time`` samples of one period (default the AFT's)."""
        return self.time_grid(n_time) * step

    def fundamental_rad_s(self, omega: float) -> float:
        """Fundamental angular frequency ``w0 = ratio * Omega`` (rad/s)."""
        return self.rate * omega

    @property
    def integer_ratio(self) -> int:
        """``w0 / Omega`` as an int (shaft orders per harmonic index); refused when the
        fundamental is not a whole multiple of the reference speed."""
        r = self.ratio
        if r.denominator != 1:
            raise ValueError(f"harmonics.ratio = {r}: the fundamental is not a whole "
                             "multiple of the reference speed")
        return r.numerator

    @property
    def rate(self) -> float:
        """``w0 / Omega`` as a float (for an integer ratio, the integer itself)."""
        r = self.ratio
        return float(r.numerator) if r.denominator == 1 else float(r)

    def aft_matrices(self, n_time: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Synthesis ``E`` (N, n_real) and Galerkin analysis ``A`` (n_real, N).

        ``x(tau_j) = E @ u`` on ``tau_j = 2 pi j / N`` (tau = w0 t) and
        ``u = A @ x(tau)``; ``A @ E = I`` for N > 2 max index.
        """
        n = self.n_time if n_time is None else int(n_time)
        e = self.synthesis_rows(2.0 * np.pi * np.arange(n) / n)
        return e, self.galerkin_columns(e, n)

    def grid_rows(self, nodes: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
        """Rows of the synthesis matrix at the samples ``nodes`` of a grid of ``shape``
        (``(N,)``): :meth:`synthesis_rows` at ``tau = 2 pi nodes / N``."""
        return self.synthesis_rows(2.0 * np.pi * nodes / shape[-1])

    def multiplication_matrix(self, s: np.ndarray) -> np.ndarray:
        """Real-layout matrix of ``x -> Galerkin(s(tau) x(tau))`` on a grid of samples
        ``s`` (N,): ``A diag(s) E`` built from the DFT of s by index gathering (circular
        convolution), O(N log N + n_real^2) (:meth:`RealLayout.product_matrix`)."""
        n = s.size
        sh = np.fft.fft(s) / n
        k = self.index_array
        return self.product_matrix(sh[k % n], sh[(k[:, None] - k[None, 1:]) % n],
                                   sh[(k[:, None] + k[None, 1:]) % n])

    def synthesis_rows(self, tau: np.ndarray) -> np.ndarray:
        """Rows of the synthesis matrix at normalised times ``tau`` (rad), (m, n_real):
        ``[1, cos k tau, -sin k tau, ...]``, so that ``x(tau) = rows @ u``."""
        tau = np.asarray(tau, dtype=float)
        k = np.asarray(self.indices[1:], dtype=float)
        e = np.empty((tau.size, self.n_real))
        e[:, 0] = 1.0
        e[:, 1::2] = np.cos(np.outer(tau, k))
        e[:, 2::2] = -np.sin(np.outer(tau, k))
        return e

    @cached_property
    def index_array(self) -> np.ndarray:
        """The indices as an integer array (built once: converting the tuple costs as
        much as an FFT of the AFT grid)."""
        k = np.asarray(self.indices)
        k.setflags(write=False)
        return k

    @cached_property
    def _columns(self) -> slice | np.ndarray:
        """Where the indices 1.. sit in a half spectrum: a slice for a contiguous set
        (no gather), else the index array."""
        k = self.index_array
        return slice(1, k.size) if self.contiguous else k[1:]

    def synthesize(self, xr: np.ndarray, n_time: int | None = None) -> np.ndarray:
        """Samples ``x(tau_j)`` on ``tau_j = 2 pi j / N`` from the real layout, by FFT.

        Equal to ``E @ xr`` (:meth:`aft_matrices`) for any ``N``, aliasing included, in
        ``O(N log N)``; ``xr`` may carry leading axes (..., n_real).
        """
        n = self.n_time if n_time is None else int(n_time)
        k = self.index_array
        if 2 * k[-1] < n:                     # no aliasing: one real inverse FFT
            xr = np.asarray(xr, dtype=float)
            spec = np.zeros(xr.shape[:-1] + (n // 2 + 1,), dtype=complex)
            spec[..., 0] = xr[..., 0] * n
            # the real layout (Re x_k, Im x_k) pairs are the complex coefficients
            spec[..., self._columns] = _as_complex(xr[..., 1:]) * (0.5 * n)
            return np.fft.irfft(spec, n, axis=-1)
        xc = self.to_complex(xr)
        spec = np.zeros(xc.shape[:-1] + (n,), dtype=complex)
        spec[..., 0] += xc[..., 0]
        half = 0.5 * xc[..., 1:]
        _add_along_last(spec, k[1:] % n, half)
        _add_along_last(spec, (-k[1:]) % n, half.conj())
        return np.fft.ifft(spec, axis=-1).real * n

    def analyse(self, x: np.ndarray) -> np.ndarray:
        """Galerkin coefficients (real layout) of samples ``x`` (..., N), by FFT.

        Equal to ``A @ x`` (:meth:`aft_matrices`): ``x_0 = mean``, ``x_k = 2/N sum_j
        x_j exp(-i k tau_j)``.
        """
        x = np.asarray(x, dtype=float)
        n = x.shape[-1]
        k = self.index_array
        if 2 * k[-1] < n:
            spec = np.fft.rfft(x, axis=-1)
            out = np.empty(x.shape[:-1] + (self.n_real,))
            out[..., 0] = spec[..., 0].real / n
            _as_complex(out[..., 1:])[...] = spec[..., self._columns] * (2.0 / n)
            return out
        spec = np.fft.fft(x, axis=-1)
        xc = spec[..., k % n] * (2.0 / n)
        xc[..., 0] = spec[..., 0].real / n
        return self.to_real(xc)

    def time_grid(self, n_time: int | None = None) -> np.ndarray:
        """Normalised time ``tau = w0 t`` of the AFT samples over one period (rad)."""
        n = self.n_time if n_time is None else int(n_time)
        return 2.0 * np.pi * np.arange(n) / n


def _add_along_last(a: np.ndarray, idx: np.ndarray, v: np.ndarray) -> None:
    """``a[..., idx] += v`` with repeated indices accumulated (aliased harmonics)."""
    if np.unique(idx).size == idx.size:
        a[..., idx] += v
        return
    for i, col in zip(idx, np.moveaxis(v, -1, 0), strict=True):
        a[..., i] += col


def mul_rows(h: np.ndarray, j: np.ndarray) -> np.ndarray:
    """Rows of a real-layout matrix multiplied by the complex ``h_k`` (``h_0`` real).

    ``j`` has the real layout ``[x_0, Re x_k1, Im x_k1, ...]`` along its first axis;
    the result is the real layout of ``h_k x_k`` for every column.
    """
    out = np.empty_like(j)
    hr, hi = h.real[1:, None], h.imag[1:, None]
    jr, ji = j[1::2], j[2::2]
    out[0] = h[0].real * j[0]
    out[1::2] = hr * jr - hi * ji
    out[2::2] = hi * jr + hr * ji
    return out


def complex_mul(h: np.ndarray, xr: np.ndarray) -> np.ndarray:
    """Real layout of ``h_k x_k`` for a real-layout vector ``xr`` (see :func:`mul_rows`)."""
    xr = np.asarray(xr, dtype=float)
    out = np.empty(xr.shape)
    out[0] = h[0].real * xr[0]
    _as_complex(out[1:])[...] = h[1:] * _as_complex(xr[1:])
    return out


def _as_complex(a: np.ndarray) -> np.ndarray:
    """The pairs ``(Re, Im)`` along the last axis of a real array as complex numbers: a
    view when the last axis is contiguous (writing into it writes ``a``), else a copy."""
    if a.strides[-1] == a.itemsize and a.dtype == np.float64:
        return a.view(np.complex128)
    return a[..., 0::2] + 1j * a[..., 1::2]


def real_blocks(z: np.ndarray, nr: int) -> np.ndarray:
    """Real DOF-major form (m n_real, m n_real) of a per-harmonic complex operator
    ``z`` (nS, m, m), in the real layout of this module (index 0 real, then Re/Im)."""
    m = z.shape[1]
    j4 = np.zeros((m, nr, m, nr))
    re = np.concatenate([[0], np.arange(1, nr, 2)])
    im = np.arange(2, nr, 2)
    j4[:, re, :, re] = z.real
    j4[:, re[1:], :, im] = -z[1:].imag
    j4[:, im, :, re[1:]] = z[1:].imag
    j4[:, im, :, im] = z[1:].real
    return j4.reshape(m * nr, m * nr)


def index_positions(source: HarmonicSet, target: HarmonicSet) -> np.ndarray:
    """Position in ``target.indices`` of each index of ``source``: where each of its
    frequencies lies in ``target``, whose fundamental must divide ``source``'s (the same
    fundamental with more harmonics, or a submultiple such as a period-2 set).

    Raises
    ------
    ValueError
        If ``target``'s fundamental does not divide ``source``'s, or a frequency of
        ``source`` is not in ``target``.
    """
    q = source.ratio / target.ratio
    if q.denominator != 1:
        raise ValueError(f"harmonic sets: the fundamental {target.ratio} does not divide "
                         f"{source.ratio}")
    where = {k: i for i, k in enumerate(target.indices)}
    try:
        return np.array([where[int(q) * k] for k in source.indices])
    except KeyError as exc:
        raise ValueError(f"harmonic sets: index {exc} of the source set is not in the "
                         "target set") from exc


def embed_coefficients(x: np.ndarray, source: HarmonicSet, target: HarmonicSet) -> np.ndarray:
    """Real-layout coefficients ``(..., source.n_real)`` of signals on ``source`` as
    coefficients on ``target`` ``(..., target.n_real)``: each moved to the index of its
    frequency (:func:`index_positions`), the others 0. Units are those of ``x``."""
    c = source.to_complex(np.asarray(x, dtype=float))
    out = np.zeros(c.shape[:-1] + (target.n_harmonics,), dtype=complex)
    out[..., index_positions(source, target)] = c
    return target.to_real(out)
