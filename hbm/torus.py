"""A harmonic basis of several independent base frequencies: multi-dimensional harmonic
balance with a multi-dimensional AFT on a torus grid (docs/hbm.md, "Several base
frequencies"; docs/theory.md §14, T.36-T.40).

A gear train's shafts and meshes turn at rational multiples of the reference speed Omega,
so every response is periodic with the common period of all of them (the hunting period,
:func:`hbm.basis.common_fundamental`). With hunting-tooth ratios (23:61 then 19:67) that
period holds thousands of mesh periods: a :class:`hbm.basis.HarmonicSet` over it needs
harmonic indices in the hundred thousands and an AFT grid of millions of samples. Here
each of ``d`` base frequencies ``w_j = r_j Omega`` (``r_j`` exact, e.g. the two mesh
frequencies and the shaft orders that excite) gets its own phase ``theta_j`` and a signal
is a function on the torus::

    x(theta) = Re sum_{k in S} x_k exp(i k . theta),     theta_j = w_j t + theta_j(0),

over a sparse set ``S`` of integer vectors ``k`` (each with its conjugate implied, the
first non-zero component > 0, the zero vector first: the real layout of
:class:`hbm.basis.RealLayout`). The time derivative is ``d/dt = sum_j w_j d/dtheta_j``, so
harmonic ``k`` has the frequency ``(k . r) Omega``: the harmonic balance is the one of the
periodic case with ``k w0`` replaced by ``k . w`` (possibly negative, or zero for ``k != 0``
when the bases are commensurate), and the AFT samples the torus on a grid of
``N_1 x ... x N_d`` points and goes to the coefficients by a d-dimensional real FFT
(``numpy.fft.rfftn``). This is the multi-dimensional HBM of quasi-periodic responses
(Schilder, Vogt, Schreiber and Osinga 2006; Guskov, Sinou and Thouverez 2008,
"Multi-dimensional harmonic balance applied to rotor dynamics"; Krack and Gross 2019,
"Harmonic Balance for Nonlinear Vibration Problems", ch. 5 — the approach followed, the
code is this module's own).

Restricted to the time line ``theta = r Omega t`` the torus solution is the response in
time. When the bases are commensurate (always, for a gear train: their ratios are
rational) the line closes after the common period and the torus solution holds the
periodic responses of every relative phase of the bases at once (docs/theory.md T.39-T.40).

:class:`TorusBasis` satisfies :class:`hbm.basis.Basis`, so :class:`hbm.HBMProblem`, the
condensations and :mod:`hbm.krylov` take it in place of a :class:`HarmonicSet`. Builders:
:meth:`TorusBasis.build` (carrier bases with their harmonics, sideband bases with their
orders) and :func:`train_basis` (meshes and shafts of a gear train).
"""

from __future__ import annotations

import itertools
import logging
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from fractions import Fraction
from functools import cached_property
from typing import ClassVar

import numpy as np

from .basis import HarmonicSet, RealLayout, as_ratio, common_fundamental

logger = logging.getLogger(__name__)

__all__ = ["TorusBasis", "canonical", "default_grid_size", "train_basis"]

#: Largest torus grid the statistics refine to (samples in all).
STATS_MAX_SAMPLES = 1 << 20


def canonical(k) -> tuple[int, ...]:
    """The representative of ``{k, -k}`` whose first non-zero component is positive (the
    zero vector itself)."""
    k = tuple(int(v) for v in k)
    for v in k:
        if v != 0:
            return k if v > 0 else tuple(-u for u in k)
    return k


def default_grid_size(top: int) -> int:
    """Samples along one base of the torus grid for a largest harmonic ``top`` of it: the
    periodic rule (:func:`hbm.basis.default_n_time`) along each base, the smallest power
    of two >= max(8, 8 top + 4).

    A product of two signals reaches 2 top, and projecting it back onto harmonics <= top
    without aliasing needs N > 3 top; the kinks of a dead zone add a slowly decaying tail,
    hence the margin. Measured (tests/test_hbm_torus.py, docs/hbm.md): with contact loss
    4 top + 4 leaves an aliasing error of 1.6e-4 on the mesh-load std where 8 top + 4 has
    1e-5; in permanent contact (smooth products) 4 top + 4 gives the same solution to
    1e-12 at 2^-d of the samples — pass such a grid explicitly there."""
    need = max(8, 8 * int(top) + 4)
    return int(2 ** int(np.ceil(np.log2(need))))


def _vector(value, d: int, name: str) -> tuple[int, ...]:
    """``value`` as an integer vector of length ``d`` (refused naming ``name``)."""
    try:
        k = tuple(value)
        ints = tuple(int(v) for v in k)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} = {value!r}: must be a vector of {d} integers") from exc
    if len(ints) != d or any(isinstance(v, bool) or int(v) != v for v in k):
        raise ValueError(f"{name} = {value!r}: must be a vector of {d} integers")
    return ints


@dataclass(frozen=True)
class TorusBasis(RealLayout):
    """Harmonics of ``d`` independent base frequencies ``w_j = r_j Omega`` (see the module).

    Parameters
    ----------
    bases
        The ``r_j`` (exact positive ratios of Omega, distinct: int, Fraction or a string
        such as ``"437/61"``).
    indices
        The integer vectors ``k`` (length d) of the set; each is taken as its canonical
        representative (first non-zero component > 0, :func:`canonical`); must hold the
        zero vector; a vector given twice (or with its negative) is refused. Stored sorted.
    grid
        Samples ``(N_1, ..., N_d)`` of the AFT along each base, each ``N_j > 2 max |k_j|``
        (no two retained harmonics alias); default :func:`default_grid_size` of each (the
        periodic rule along each base).
    names
        A name per base (``"mesh 1"``, ``"shaft 2"``), default ``"base j"``.
    vectors
        ``{ratio: vector}``: the lattice vector of a frequency ``ratio * Omega`` used for an
        element's base frequency or an excitation key given as a ratio, where the rule of
        :meth:`vector_of` is ambiguous (e.g. a mesh at 23 Omega with the bases 23 and 1).

    Notes
    -----
    The frequency of index ``k`` is ``frequency_index[k] * ratio * Omega`` with ``ratio``
    the common fundamental of the bases and ``frequency_index = k . (r / ratio)`` an
    integer: the problem's ``kS`` (:class:`hbm.HBMProblem`), so that the receptances and
    the time derivative are those of the periodic case.
    """

    bases: tuple[Fraction, ...]
    indices: tuple[tuple[int, ...], ...]
    grid: tuple[int, ...]
    names: tuple[str, ...]
    vectors: tuple[tuple[Fraction, tuple[int, ...]], ...]
    fundamental: str = "torus"
    #: several bases: a quasi-periodic (torus) response; Floquet theory does not apply
    periodic: ClassVar[bool] = False

    def __init__(self, bases, indices, grid=None, names=None, vectors=None) -> None:
        if isinstance(bases, (str, bytes)) or not isinstance(bases, Sequence) or not bases:
            raise ValueError(f"torus.bases = {bases!r}: must be a non-empty list of "
                             "frequency ratios")
        rs = tuple(as_ratio(r, f"torus.bases[{j}]") for j, r in enumerate(bases))
        if len(set(rs)) != len(rs):
            raise ValueError(f"torus.bases = {[str(r) for r in rs]}: must be distinct (two "
                             "equal frequencies are one base)")
        d = len(rs)
        if names is None:
            names = tuple(f"base {j + 1}" for j in range(d))
        names = tuple(names)
        if len(names) != d or not all(isinstance(n, str) and n for n in names) \
                or len(set(names)) != d:
            raise ValueError(f"torus.names = {names!r}: must be {d} distinct non-empty "
                             "strings")
        seen: dict[tuple[int, ...], object] = {}
        for i, k in enumerate(indices):
            c = canonical(_vector(k, d, f"torus.indices[{i}]"))
            if c in seen:
                raise ValueError(f"torus.indices[{i}] = {tuple(k)}: the harmonic {c} (or its "
                                 f"conjugate) is given twice (also as {seen[c]})")
            seen[c] = tuple(k)
        zero = (0,) * d
        if zero not in seen:
            raise ValueError(f"torus.indices: must contain the zero vector {zero} (the mean)")
        idx = tuple(sorted(seen))
        top = np.max(np.abs(np.array(idx)), axis=0)
        if grid is None:
            grid = tuple(default_grid_size(t) for t in top)
        grid = _vector(grid, d, "torus.grid")
        for j, (n, t) in enumerate(zip(grid, top, strict=True)):
            if n <= 2 * t:
                raise ValueError(f"torus.grid[{j}] = {n} ({names[j]}): must be > 2 * max |k_{j}|"
                                 f" = {2 * t} (else two harmonics alias)")
        vecs = []
        for ratio, vec in dict(vectors or {}).items():
            r = as_ratio(ratio, "torus.vectors key")
            v = _vector(vec, d, f"torus.vectors[{ratio}]")
            if sum((vj * rj for vj, rj in zip(v, rs, strict=True)), Fraction(0)) != r:
                raise ValueError(f"torus.vectors[{ratio}] = {v}: its frequency "
                                 f"k . r = {sum(a * b for a, b in zip(v, rs, strict=True))} "
                                 f"is not {r}")
            vecs.append((r, v))
        object.__setattr__(self, "bases", rs)
        object.__setattr__(self, "indices", idx)
        object.__setattr__(self, "grid", grid)
        object.__setattr__(self, "names", names)
        object.__setattr__(self, "vectors", tuple(vecs))
        object.__setattr__(self, "fundamental", "torus")

    # ------------------------------------------------------------------ builders
    @classmethod
    def build(cls, bases: Mapping[str, object], harmonics: Mapping[str, int],
              sidebands: Mapping[str, Sequence[int]] | None = None, sideband_order: int = 1,
              order: int | None = None, grid=None, vectors=None) -> TorusBasis:
        """The set of carrier harmonics with their sidebands.

        Parameters
        ----------
        bases
            ``{name: ratio}`` in the order of the torus axes (e.g. the meshes, then the
            shafts whose orders excite).
        harmonics
            ``{name: H}`` for the carrier bases (a mesh: its harmonics): every
            ``m`` with ``|m_j| <= H_j``, and ``sum_j |m_j| <= order`` when ``order`` is
            given (combinations of carriers of total order at most ``order``).
        sidebands
            ``{name: orders}`` for the modulating bases (a shaft: its excited orders,
            positive integers), combined like :func:`hbm.basis.combination_offsets`:
            every ``sum_i c_i o_i e_j(i)`` with ``sum_i |c_i| <= sideband_order``.
        grid, vectors
            As the constructor.

        Returns
        -------
        TorusBasis
            Every canonical ``m + c`` (carrier set plus sideband offsets) with the zero
            vector.
        """
        names = list(bases)
        if not names:
            raise ValueError("torus.bases = {}: needs at least one base")
        sidebands = dict(sidebands or {})
        for key in list(harmonics) + list(sidebands):
            if key not in bases:
                raise ValueError(f"torus: {key!r} is not a base (bases: {names})")
        both = set(harmonics) & set(sidebands)
        if both:
            raise ValueError(f"torus: {sorted(both)} are both carrier and sideband bases")
        unused = [n for n in names if n not in harmonics and n not in sidebands]
        if unused:
            raise ValueError(f"torus: bases {unused} have neither harmonics nor sideband "
                             "orders")
        for key, h in harmonics.items():
            if isinstance(h, bool) or int(h) != h or h < 0:
                raise ValueError(f"torus.harmonics[{key!r}] = {h!r}: must be an integer >= 0")
        if order is not None and (isinstance(order, bool) or int(order) != order or order < 0):
            raise ValueError(f"torus.order = {order!r}: must be an integer >= 0")
        if isinstance(sideband_order, bool) or int(sideband_order) != sideband_order \
                or sideband_order < 0:
            raise ValueError(f"torus.sideband_order = {sideband_order!r}: must be an "
                             "integer >= 0")
        d = len(names)
        pos = {n: j for j, n in enumerate(names)}
        steps = []
        for key, orders in sidebands.items():
            for o in orders:
                if isinstance(o, bool) or int(o) != o or o < 1:
                    raise ValueError(f"torus.sidebands[{key!r}] = {list(orders)!r}: orders "
                                     "must be integers >= 1")
                e = [0] * d
                e[pos[key]] = int(o)
                steps.append(tuple(e))
        frontier = {(0,) * d}
        offsets = set(frontier)
        for _ in range(int(sideband_order)):
            frontier = {tuple(a + s * b for a, b in zip(v, e, strict=True))
                        for v in frontier for e in steps for s in (1, -1)}
            offsets |= frontier
        carriers = [n for n in names if n in harmonics]
        ranges = [range(-int(harmonics[n]), int(harmonics[n]) + 1) for n in carriers]
        idx = set()
        for m in itertools.product(*ranges):
            if order is not None and sum(abs(v) for v in m) > order:
                continue
            base = [0] * d
            for n, v in zip(carriers, m, strict=True):
                base[pos[n]] = v
            for c in offsets:
                idx.add(canonical(a + b for a, b in zip(base, c, strict=True)))
        return cls([bases[n] for n in names], sorted(idx), grid=grid, names=names,
                   vectors=vectors)

    # ------------------------------------------------------------------ the basis
    @property
    def dimension(self) -> int:
        """Number of base frequencies d."""
        return len(self.bases)

    @property
    def ratio(self) -> Fraction:
        """The common fundamental of the bases (:func:`hbm.basis.common_fundamental`): the
        unit of :attr:`frequency_index`; ``2 pi / (ratio Omega)`` is the period after which
        the time line closes on the torus (the hunting period of a train)."""
        return common_fundamental(*self.bases)

    @property
    def rate(self) -> float:
        """:attr:`ratio` as a float."""
        r = self.ratio
        return float(r.numerator) if r.denominator == 1 else float(r)

    def fundamental_rad_s(self, omega: float) -> float:
        """``ratio * Omega`` (rad/s), the unit of the harmonics' frequencies."""
        return self.rate * omega

    @cached_property
    def multiples(self) -> tuple[int, ...]:
        """Each base over the common fundamental, ``r_j / ratio`` (integers)."""
        r0 = self.ratio
        return tuple(int(r / r0) for r in self.bases)

    @cached_property
    def frequency_index(self) -> tuple[int, ...]:
        """``k . (r / ratio)`` of each index: its frequency in units of ``ratio Omega``
        (an integer; negative or zero for some ``k != 0``)."""
        n = self.multiples
        return tuple(sum(a * b for a, b in zip(k, n, strict=True)) for k in self.indices)

    @property
    def contiguous(self) -> bool:
        """Never: the torus path has no contiguous fast path."""
        return False

    @property
    def n_time(self) -> tuple[int, ...]:
        """The AFT grid (the problem passes it where a periodic basis has its sample
        count)."""
        return self.grid

    @property
    def n_samples(self) -> int:
        """Samples of the AFT grid in all, ``prod N_j``."""
        return math.prod(self.grid)

    @property
    def max_index(self) -> tuple[int, ...]:
        """Largest ``|k_j|`` along each base."""
        return tuple(int(v) for v in np.max(np.abs(self.index_array), axis=0))

    @cached_property
    def index_array(self) -> np.ndarray:
        """The indices as an integer array (n_harmonics, d)."""
        k = np.array(self.indices, dtype=np.int64).reshape(len(self.indices), self.dimension)
        k.setflags(write=False)
        return k

    def frequencies(self) -> np.ndarray:
        """``k . r`` of every index as floats (frequency over Omega)."""
        return np.asarray(self.frequency_index, dtype=float) * self.rate

    # ------------------------------------------------------------------ frequencies
    def vector_of(self, ratio, name: str) -> tuple[int, ...]:
        """The lattice vector of the frequency ``ratio * Omega`` of ``name`` (an element's
        base frequency, an excitation's key).

        An explicit entry of :attr:`vectors`; else the base equal to ``ratio`` (its own
        coordinate, multiplier 1); else the single base of which ``ratio`` is a whole
        multiple ``m`` (``m e_j``: a combination). Refused when no base or several bases
        qualify, naming them (give the vector in ``vectors``).
        """
        r = as_ratio(ratio, f"{name} frequency ratio")
        for key, vec in self.vectors:
            if key == r:
                return vec
        d = self.dimension
        exact = [j for j, b in enumerate(self.bases) if b == r]
        if exact:
            e = [0] * d
            e[exact[0]] = 1
            return tuple(e)
        cands = []
        for j, b in enumerate(self.bases):
            q = r / b
            if q.denominator == 1:
                e = [0] * d
                e[j] = int(q)
                cands.append(tuple(e))
        if len(cands) == 1:
            return cands[0]
        what = ("no base divides it" if not cands else
                f"it is a multiple of several bases: {cands}")
        bases = ", ".join(f"{n} = {b}" for n, b in zip(self.names, self.bases, strict=True))
        raise ValueError(f"torus: the frequency {r} Omega of {name} has no unique lattice "
                         f"vector on the bases ({bases}): {what}; give it in "
                         f"TorusBasis(vectors={{Fraction('{r}'): (...)}})")

    def index_of(self, key) -> tuple[int, ...] | None:
        """The index (a vector of the set) of an excitation key, or None when the set does
        not hold it: a frequency ratio (0, or resolved by :meth:`vector_of`) or a canonical
        lattice vector (a tuple of d integers)."""
        d = self.dimension
        if isinstance(key, tuple):
            k = _vector(key, d, "excitation key")
            if canonical(k) != k:
                raise ValueError(f"excitation key {k}: a lattice vector must be canonical "
                                 f"(first non-zero component > 0): give {canonical(k)} with "
                                 "the conjugate amplitude")
        else:
            r = as_ratio(key, "excitation frequency ratio", positive=False)
            k = (0,) * d if r == 0 else self.vector_of(r, "excitation")
        return k if k in self._positions else None

    @cached_property
    def _positions(self) -> dict[tuple[int, ...], int]:
        return {k: i for i, k in enumerate(self.indices)}

    def element_step(self, ratio, harmonics, label: str) -> tuple[int, ...]:
        """The lattice vector ``c`` of an element's base frequency (:meth:`vector_of`): its
        phase on the torus is ``c . theta`` (plus its own phase). Its parameters' harmonics
        ``m c`` must fit the grid along every base; a warning names those the set does not
        hold."""
        c = self.vector_of(ratio, label)
        top = max(harmonics, default=0)
        for j, (cj, n) in enumerate(zip(c, self.grid, strict=True)):
            if 2 * abs(top * cj) >= n:
                raise ValueError(
                    f"torus.grid[{j}] = {n} ({self.names[j]}): too few samples for harmonic "
                    f"{top} of {label} (component {top * cj}); need > {2 * abs(top * cj)}")
        missing = [m for m in harmonics if m and canonical(m * v for v in c)
                   not in self._positions]
        if missing:
            logger.warning("%s: harmonics %s of its base frequency are not in the torus set; "
                           "their direct contribution is only seen through products", label,
                           sorted(set(missing)))
        return c

    def base_phase(self, step, n_time=None) -> np.ndarray:
        """``c . theta`` (rad, in [0, 2 pi d)) on the grid ``n_time`` (default the AFT's),
        shape ``n_time``: each ``c_j theta_j`` reduced exactly on its axis."""
        grid = self.grid if n_time is None else tuple(n_time)
        frac = np.zeros(grid)
        for j, (cj, n) in enumerate(zip(step, grid, strict=True)):
            shape = [1] * len(grid)
            shape[j] = n
            frac = frac + ((int(cj) * np.arange(n)) % n / n).reshape(shape)
        return 2.0 * np.pi * frac

    # ------------------------------------------------------------------ AFT
    def _half_shape(self, grid: tuple[int, ...]) -> tuple[int, ...]:
        return grid[:-1] + (grid[-1] // 2 + 1,)

    def _flat(self, v: np.ndarray, grid: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray]:
        """Flat positions in the half spectrum of ``rfftn`` on ``grid`` of the vectors ``v``
        (..., d) and whether each is read conjugated (``-v`` is stored)."""
        n = np.asarray(grid, dtype=np.int64)
        vm = v % n
        neg = vm[..., -1] > n[-1] // 2
        vm = np.where(neg[..., None], (-v) % n, vm)
        flat = np.ravel_multi_index(tuple(np.moveaxis(vm, -1, 0)), self._half_shape(grid))
        if math.prod(self._half_shape(grid)) < 2 ** 31:
            flat = flat.astype(np.int32)          # the product tables are (nS, nS) of them
        return flat, neg

    def _placement(self, grid: tuple[int, ...]):
        """Where each harmonic's coefficient goes in the half spectrum (synthesis) and
        comes from (analysis) on ``grid`` (cached per grid)."""
        cache = self.__dict__.setdefault("_placement_cache", {})
        if grid not in cache:
            k = self.index_array[1:]
            for j, (n, t) in enumerate(zip(grid, np.max(np.abs(self.index_array), axis=0),
                                           strict=True)):
                if n <= 2 * t:
                    raise ValueError(f"torus grid {grid}: axis {j} ({self.names[j]}) needs "
                                     f"> {2 * t} samples")
            last = k[:, -1]
            ids = np.arange(1, len(self.indices))
            direct = last >= 0                   # k itself is in the half spectrum
            conj = last <= 0                     # -k is (both when k_d = 0)
            fa, _ = self._flat(k[direct], grid)
            fb, _ = self._flat(-k[conj], grid)
            negative = last[conj] < 0            # read conjugated from -k in the analysis
            cache[grid] = (ids[direct], fa, ids[conj], fb, ids[conj][negative],
                           fb[negative])
        return cache[grid]

    def synthesize(self, xr: np.ndarray, n_time=None) -> np.ndarray:
        """Samples ``x(theta)`` on the torus grid ``n_time`` (default the AFT's) from the
        real layout (..., n_real), by one inverse real d-dimensional FFT; shape
        ``(..., N_1, ..., N_d)``."""
        grid = self.grid if n_time is None else tuple(int(v) for v in n_time)
        ia, fa, ib, fb, _, _ = self._placement(grid)
        xc = self.to_complex(xr)
        lead = xc.shape[:-1]
        half = self._half_shape(grid)
        ntot = math.prod(grid)
        spec = np.zeros(lead + (math.prod(half),), dtype=complex)
        spec[..., 0] = xc[..., 0] * ntot
        spec[..., fa] = xc[..., ia] * (0.5 * ntot)
        spec[..., fb] = np.conj(xc[..., ib]) * (0.5 * ntot)
        axes = tuple(range(-len(grid), 0))
        return np.fft.irfftn(spec.reshape(lead + half), s=grid, axes=axes)

    def analyse(self, x: np.ndarray) -> np.ndarray:
        """Galerkin coefficients (real layout) of samples ``x`` (..., N_1, ..., N_d) by one
        real d-dimensional FFT: ``x_0`` the mean, ``x_k = 2 mean(x exp(-i k . theta))``."""
        x = np.asarray(x, dtype=float)
        d = self.dimension
        grid = x.shape[-d:]
        ia, fa, _, _, ineg, fneg = self._placement(grid)
        lead = x.shape[:-d]
        ntot = math.prod(grid)
        spec = np.fft.rfftn(x, axes=tuple(range(-d, 0))).reshape(lead + (-1,))
        xc = np.empty(lead + (self.n_harmonics,), dtype=complex)
        xc[..., 0] = spec[..., 0].real / ntot
        xc[..., ia] = spec[..., fa] * (2.0 / ntot)
        # harmonics with k_d < 0 are read from -k (conjugated); k_d = 0 already from k
        xc[..., ineg] = np.conj(spec[..., fneg]) * (2.0 / ntot)
        return self.to_real(xc)

    def grid_rows(self, nodes: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
        """Synthesis rows ``[1, cos k . theta, -sin k . theta, ...]`` at the flat grid
        points ``nodes`` of a grid of ``shape``, (m, n_real); phases reduced exactly on
        each axis."""
        idx = np.stack(np.unravel_index(np.asarray(nodes, dtype=np.int64), shape), axis=-1)
        return self._rows(idx, shape)

    def _rows(self, idx: np.ndarray, shape) -> np.ndarray:
        k = self.index_array[1:]
        n = np.asarray(shape, dtype=np.int64)
        frac = np.zeros((idx.shape[0], k.shape[0]))
        for j in range(self.dimension):
            frac += np.outer(idx[:, j], k[:, j]) % n[j] / n[j]
        ph = 2.0 * np.pi * frac
        e = np.empty((idx.shape[0], self.n_real))
        e[:, 0] = 1.0
        e[:, 1::2] = np.cos(ph)
        e[:, 2::2] = -np.sin(ph)
        return e

    def aft_matrices(self, n_time=None) -> tuple[np.ndarray, np.ndarray]:
        """Dense synthesis ``E`` (N_tot, n_real) over the flattened grid and Galerkin
        analysis ``A`` (n_real, N_tot); ``A @ E = I`` (for tests and small sets)."""
        grid = self.grid if n_time is None else tuple(n_time)
        ntot = math.prod(grid)
        e = self.grid_rows(np.arange(ntot), grid)
        return e, self.galerkin_columns(e, ntot)

    def multiplication_matrix(self, s: np.ndarray) -> np.ndarray:
        """Real-layout matrix of ``x -> Galerkin(s(theta) x(theta))`` on the grid of the
        samples ``s`` (N_1, ..., N_d): ``A diag(s) E`` from the d-dimensional DFT of s by
        index gathering (``s_hat[k - l]``, ``s_hat[k + l]`` on the grid, aliasing
        included as in the AFT itself)."""
        grid = s.shape
        sh = np.fft.rfftn(s).ravel() / s.size
        (f0, n0), (fm, nm), (fp, npl) = self._products(grid)

        def read(flat, neg):
            v = sh[flat]
            return np.where(neg, np.conj(v), v)

        return self.product_matrix(read(f0, n0), read(fm, nm), read(fp, npl))

    def _products(self, grid: tuple[int, ...]):
        """Half-spectrum positions of ``k``, ``k - l`` and ``k + l`` (cached per grid)."""
        cache = self.__dict__.setdefault("_products_cache", {})
        if grid not in cache:
            k = self.index_array
            f0 = self._flat(k, grid)
            fm = self._flat(k[:, None, :] - k[None, 1:, :], grid)
            fp = self._flat(k[:, None, :] + k[None, 1:, :], grid)
            cache[grid] = (f0, fm, fp)
        return cache[grid]

    def refined_grid(self, n_time=None) -> tuple[int, ...]:
        """A grid for statistics: ``n_time`` itself when a shape; an int ``f`` refines the
        AFT grid ``f`` times along every base; default twice along every base while the
        total stays within :data:`STATS_MAX_SAMPLES`, else the AFT grid."""
        if n_time is None:
            f = 2 if self.n_samples * 2 ** self.dimension <= STATS_MAX_SAMPLES else 1
        elif isinstance(n_time, (tuple, list)):
            grid = _vector(n_time, self.dimension, "statistics grid")
            self._placement(grid)            # checks the grid resolves the set
            return grid
        else:
            f = int(n_time)
            if f < 1:
                raise ValueError(f"statistics refinement = {n_time!r}: must be >= 1")
        return tuple(f * n for n in self.grid)

    # ------------------------------------------------------------------ the time line
    def line_rows(self, a: int, b: int, n: int) -> np.ndarray:
        """Synthesis rows (n, n_real) at ``tau_m = 2 pi a m / (b n)``, ``m = 0 .. n-1``, on
        the time line ``theta = r Omega t`` (``tau = ratio Omega t``): harmonic ``k`` at
        phase ``2 pi (p_k a m mod b n) / (b n)``, ``p_k`` its frequency index (exact
        integer reduction). Cached per ``(a, b, n)``."""
        cache = self.__dict__.setdefault("_line_cache", {})
        key = (int(a), int(b), int(n))
        if key not in cache:
            if len(cache) > 8:
                cache.clear()
            p = np.asarray(self.frequency_index[1:], dtype=np.int64)
            m = np.arange(n, dtype=np.int64)
            period = int(b) * int(n)
            ph = 2.0 * np.pi * (np.outer(m * int(a) % period, p % period) % period) / period
            e = np.empty((n, self.n_real))
            e[:, 0] = 1.0
            e[:, 1::2] = np.cos(ph)
            e[:, 2::2] = -np.sin(ph)
            cache[key] = e
        return cache[key]

    def line_set(self, n_time: int | None = None) -> HarmonicSet:
        """The periodic basis over the common period with the same frequencies: the
        harmonic set of indices ``|frequency_index|`` of the fundamental :attr:`ratio`
        (harmonics of equal frequency merge into one). With it the one-dimensional HBM
        over the hunting period solves the same response; its AFT needs
        ``n_time > 2 max |frequency_index|`` samples."""
        idx = sorted({abs(p) for p in self.frequency_index})
        return HarmonicSet(idx, ratio=self.ratio, fundamental="hunting", n_time=n_time)


def train_basis(meshes: Mapping[str, object], mesh_harmonics, shafts=None,
                sideband_order: int = 1, order: int | None = None, grid=None,
                vectors=None) -> TorusBasis:
    """The torus basis of a gear train: the meshes' frequencies as carrier bases with their
    harmonics, the exciting shafts' speeds as sideband bases with their orders.

    Parameters
    ----------
    meshes
        ``{name: mesh frequency over Omega}`` (``Z rho`` of either gear, exact), e.g.
        ``{"mesh 1": 23, "mesh 2": Fraction(437, 61)}``.
    mesh_harmonics
        Harmonics kept per mesh: an int for all, or ``{name: H}``.
    shafts
        ``{name: (speed over Omega, orders)}`` for the shafts whose orders excite (e.g.
        ``{"input": (1, (1, 2))}``); their combinations up to ``sideband_order`` modulate
        every carrier harmonic.
    order
        Largest total order ``sum |m_j|`` of the mesh combinations (None: every
        combination with ``|m_j| <= H_j``).
    grid, vectors
        As :class:`TorusBasis`.
    """
    bases = dict(meshes)
    if isinstance(mesh_harmonics, Mapping):
        harmonics = dict(mesh_harmonics)
    else:
        harmonics = {name: mesh_harmonics for name in meshes}
    sidebands = {}
    for name, spec in dict(shafts or {}).items():
        if name in bases:
            raise ValueError(f"train_basis: shaft {name!r} has the name of a mesh")
        try:
            speed, orders = spec
        except (TypeError, ValueError) as exc:
            raise ValueError(f"train_basis.shafts[{name!r}] = {spec!r}: must be (speed "
                             "ratio, orders)") from exc
        bases[name] = speed
        sidebands[name] = tuple(orders)
    return TorusBasis.build(bases, harmonics, sidebands=sidebands,
                            sideband_order=sideband_order, order=order, grid=grid,
                            vectors=vectors)
