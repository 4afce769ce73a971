"""The fixed-interface problem of Craig–Bampton on ``K``, ``M`` themselves, without
copies of the interior blocks.

The fixed-interface modes (eq. 6) and the static modes (eq. 7) need ``K_ii``, ``M_ii``.
Extracting them (``MatCreateSubMatrix``) copies two matrices of the size of ``K``, ``M``
(2.5 GiB at 1.5 M DOF, docs/scale.md). Instead, the interface rows and columns of ``K``
and ``M`` are overwritten in place,

    K̃ = [[K_ii, 0], [0, I]],    M̃ = [[M_ii, 0], [0, 0]]      (interface last, for show)

so that ``K̃ x = λ M̃ x`` has the fixed-interface pairs of eq. (6) (interface entries 0)
plus ``n_c`` infinite eigenvalues, which shift-invert at 0 maps to θ = 0, never wanted;
``K̃ X = −[K_ic; 0]`` gives Ψ with zero interface rows. The overwritten entries are
saved first (the ``n_c`` rows and the ``n_c`` columns as stored, a few thousand values)
and written back on exit, so ``K`` and ``M`` come back bit for bit, also after an error.
The sparsity pattern is unchanged throughout (PETSc zeroes entries, it does not drop
them), so no allocation happens in place.
"""
from __future__ import annotations

from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np
from petsc4py import PETSc


@dataclass
class SavedEntries:
    """The entries of one matrix that :func:`interface_eliminated` overwrites (this
    rank's part).

    Attributes
    ----------
    rows : list of (int, ndarray, ndarray)
        Owned interface rows: global row, column indices, values as stored.
    column_rows : list of ndarray
        Per interface column ``k``: the owned global rows with a stored entry there.
    column_values : list of ndarray
        Per interface column ``k``: those entries.
    """

    rows: list
    column_rows: list
    column_values: list


def save_entries(A: PETSc.Mat, dofs: np.ndarray) -> SavedEntries:
    """The interface rows and columns of ``A`` as stored (collective).

    Parameters
    ----------
    A : PETSc.Mat
        Assembled AIJ matrix.
    dofs : ndarray of int
        Global interface indices, the same array on every rank.
    """
    r0, r1 = A.getOwnershipRange()
    it = PETSc.IntType
    rows = []
    for d in dofs[(dofs >= r0) & (dofs < r1)]:
        cols, vals = A.getRow(int(d))
        rows.append((int(d), np.array(cols, dtype=it), np.array(vals)))
    comm = A.getComm()
    is_r = PETSc.IS().createStride(r1 - r0, r0, 1, comm=comm)
    is_c = PETSc.IS().createGeneral(
        (dofs if comm.getRank() == 0 else np.empty(0, dtype=np.int64)).astype(it), comm=comm)
    C = A.createSubMatrix(is_r, is_c)  # the n_c columns, this rank's rows
    ia, ja, va = C.getValuesCSR()
    for obj in (C, is_r, is_c):
        obj.destroy()
    row_of = r0 + np.repeat(np.arange(r1 - r0), np.diff(ia))
    ja = np.asarray(ja)
    column_rows = [row_of[ja == k].astype(it) for k in range(dofs.size)]
    column_values = [np.array(va[ja == k]) for k in range(dofs.size)]
    return SavedEntries(rows, column_rows, column_values)


def restore_entries(A: PETSc.Mat, dofs: np.ndarray, saved: SavedEntries) -> None:
    """Write the saved entries back into ``A`` and assemble it (collective)."""
    ins = PETSc.InsertMode.INSERT_VALUES
    for k, d in enumerate(dofs):
        rows = saved.column_rows[k]
        if rows.size:
            A.setValues(rows, np.array([d], dtype=PETSc.IntType),
                        saved.column_values[k].reshape(-1, 1), addv=ins)
    for row, cols, vals in saved.rows:
        A.setValues(row, cols, vals, addv=ins)
    A.assemble()


@contextmanager
def interface_eliminated(K: PETSc.Mat, M: PETSc.Mat, dofs: np.ndarray):
    """``K``, ``M`` turned into ``K̃``, ``M̃`` (module docstring) inside the block,
    restored bit for bit on exit (collective).

    Parameters
    ----------
    K, M : PETSc.Mat
        Assembled AIJ stiffness and mass, same row layout.
    dofs : ndarray of int
        Global interface indices, the same array on every rank.

    Yields
    ------
    SavedEntries
        The saved entries of ``K`` (for :func:`interface_columns`).
    """
    saved = [save_entries(A, dofs) for A in (K, M)]
    r0, r1 = K.getOwnershipRange()
    own = dofs[(dofs >= r0) & (dofs < r1)].astype(PETSc.IntType)
    try:
        K.zeroRowsColumns(own, diag=1.0)
        M.zeroRowsColumns(own, diag=0.0)
        yield saved[0]
    finally:
        for A, s in zip((K, M), saved, strict=True):
            restore_entries(A, dofs, s)


def interface_columns(K: PETSc.Mat, dofs: np.ndarray, saved: SavedEntries) -> PETSc.Mat:
    """Dense ``[K_ic; 0]`` (n × n_c, the row layout of ``K``): the saved interface
    columns of ``K`` with the interface rows zeroed — the right-hand side of eq. (7) on
    the layout of ``K̃``."""
    r0, r1 = K.getOwnershipRange()
    n = K.getSize()[0]
    B = PETSc.Mat().createDense(((r1 - r0, n), (PETSc.DECIDE, dofs.size)), comm=K.getComm())
    B.setUp()
    Bl = B.getDenseArray()
    Bl[:] = 0.0
    for k in range(dofs.size):
        Bl[saved.column_rows[k] - r0, k] = saved.column_values[k]
    own = dofs[(dofs >= r0) & (dofs < r1)]
    Bl[own - r0, :] = 0.0
    B.assemble()
    return B
