"""The displacement-field error of the convergence study (``housing_err``).

At the first ``outputs.housing_field_rpm`` speed the HBM point is re-solved, its ROM
coordinates ``q_k`` recovered and the field ``u_k = T q_k`` rebuilt from the cached
basis ``rom/basis`` (all FE unknowns but the named 6-DOF link nodes). The basis is
read in blocks of rows (``ROW_BLOCK``), never whole: only the field itself
(``n_fe`` × harmonics, complex) is held, in the partition-independent order of the
basis row keys (``rom/row_keys``), so two ROMs reduced on different partitions of
the same mesh compare row by row (docs/architecture.md).
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np

from study.outputs.points import nearest_point

logger = logging.getLogger(__name__)

__all__ = ["HousingField", "housing_field", "field_error", "ROW_BLOCK"]

#: Basis rows read at once (16384 rows × n_r doubles: 14 MB for n_r = 112).
ROW_BLOCK = 16384
_FRAMES = 64  # time samples per period of the largest-amplitude search


@dataclass
class HousingField:
    """Complex displacement amplitudes per harmonic index at the housing speed.

    ``amplitudes`` maps a harmonic index to the (n_fe,) complex field [m], rows in
    the order of the basis row keys (file order when the ROM has none), link-node rows
    zeroed; ``max_amplitude`` is the largest displacement over one period [m].
    """

    rpm: float
    n_fe: int
    amplitudes: dict
    max_amplitude: float


def housing_field(result, rpm: float) -> HousingField:
    """Re-solve the HBM point at ``rpm``, recover q and rebuild u = T q from rom.h5."""
    from hbm import ConvergenceError

    _, pt = nearest_point(result, rpm)
    prob = result.problem
    try:
        pt = prob.solve(rpm, x0=pt.unknowns, tol=result.scene.continuation.tolerance)
    except ConvergenceError as exc:
        logger.warning("housing: no HBM point exactly at %g rpm (%s); using the branch "
                       "point at %.6g rpm", rpm, exc, pt.rpm)
    q = prob.recover(pt)                                      # (n_r, nS)
    hs = prob.harmonics      # keys: the indices (vectors on a torus); waves: frequencies
    keys = [int(k) if hs.periodic else tuple(int(x) for x in k) for k in hs.indices]
    U, u_max = _field_by_blocks(result.rom.folder, q, [int(k) for k in hs.frequency_index])
    return HousingField(float(pt.rpm), U.shape[0], {k: U[:, i] for i, k in enumerate(keys)},
                        u_max)


def _field_by_blocks(folder, q: np.ndarray, idx: list[int]) -> tuple[np.ndarray, float]:
    """``U = T q`` (n_fe, nS) in row-key order and its largest value over one period,
    reading ``rom/basis`` ``ROW_BLOCK`` rows at a time."""
    import h5py

    with h5py.File(folder / "nodes.h5", "r") as f:
        link = np.asarray(f["rows"][()], dtype=np.int64)     # 6-DOF link nodes, file rows
    wave = np.exp(1j * np.outer(idx, 2 * np.pi * np.arange(_FRAMES) / _FRAMES))  # (nS, 64)
    with h5py.File(folder / "rom.h5", "r") as f:
        ds = f["rom/basis"]                                   # (n_fe, n_r)
        n_fe = ds.shape[0]
        U = np.empty((n_fe, q.shape[1]), dtype=complex)
        u_max = 0.0
        for a in range(0, n_fe, ROW_BLOCK):
            b = min(a + ROW_BLOCK, n_fe)
            Ub = ds[a:b, :] @ q
            Ub[link[(link >= a) & (link < b)] - a] = 0.0     # rotations of the link nodes
            u_max = max(u_max, float(np.abs((Ub @ wave).real).max(initial=0.0)))
            U[a:b] = Ub
        keys = f["rom/row_keys"][()] if "row_keys" in f["rom"] else None
    if keys is not None:
        U = U[np.argsort(keys, kind="stable")]
    return U, u_max


def field_error(ref: HousingField, f: HousingField) -> tuple[float, str]:
    """Relative L2 error over space and one period (Parseval), or of the max amplitude."""
    if ref.n_fe != f.n_fe:
        return abs(f.max_amplitude - ref.max_amplitude) / ref.max_amplitude, "max amplitude"
    num = den = 0.0
    for k in set(ref.amplitudes) | set(f.amplitudes):
        w = 1.0 if not np.any(k) else 0.5
        a = ref.amplitudes.get(k)
        b = f.amplitudes.get(k)
        a = np.zeros(ref.n_fe) if a is None else a
        b = np.zeros(ref.n_fe) if b is None else b
        num += w * float(np.vdot(b - a, b - a).real)
        den += w * float(np.vdot(a, a).real)
    return math.sqrt(num / den) if den > 0 else 0.0, "L2 field"
