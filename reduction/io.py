"""HDF5 storage of a ROM (layout in docs/results-format.md, section ``rom/``).

Rank 0 writes the dense ROM data; the basis ``T`` is written as the dataset
``rom/basis`` (n_fe × n_r) by rows, each rank writing its own rows in turn
(serial h5py, no parallel HDF5 needed), so it is never gathered on one process.
The file is written under a temporary name in the target folder and
``os.replace``d when complete (:func:`core.files.atomic_write`, on rank 0).
"""

from __future__ import annotations

import contextlib
import logging

import h5py
import numpy as np
from petsc4py import PETSc

from core.files import atomic_write
from reduction.rom import ROM
from reduction.validate import Validation

log = logging.getLogger(__name__)

FORMAT_VERSION = 1


def save_rom(path, rom: ROM, comm=None, write_basis: bool = True, row_keys=None) -> None:
    """Write ``rom`` to ``path`` (HDF5), atomically; collective on ``comm``.

    Parameters
    ----------
    path : str or Path
        Target file; its folder must exist.
    rom : ROM
        The model; ``rom.T`` is needed when ``write_basis``.
    comm : mpi4py communicator, optional
        Defaults to the communicator of ``rom.T`` or ``COMM_WORLD``.
    write_basis : bool
        Also write ``rom/basis`` (reconstruction data).
    row_keys : array of int, optional
        Partition-independent key of each of this rank's basis rows
        (``fem.FEModel.row_keys``), written as ``rom/row_keys``: the basis can then be
        read onto another partition or number of ranks (:func:`load_basis`).
    """
    if write_basis and rom.T is None:
        raise ValueError("rom.T = None: write_basis=True needs the basis")
    if comm is None:
        comm = rom.T.getComm().tompi4py() if rom.T is not None else PETSc.COMM_WORLD.tompi4py()
    if hasattr(comm, "tompi4py"):
        comm = comm.tompi4py()
    if write_basis and row_keys is not None:
        r0, r1 = rom.T.getOwnershipRange()
        row_keys = np.asarray(row_keys, dtype=np.int64)
        if row_keys.shape != (r1 - r0,):
            raise ValueError(f"row_keys.shape = {row_keys.shape}: must be ({r1 - r0},), "
                             "one key per owned row of the basis")
    with contextlib.ExitStack() as rank0:
        tmp = None
        if comm.rank == 0:  # rank 0 owns the temporary file and renames it at the end
            tmp = rank0.enter_context(atomic_write(path))
            with h5py.File(tmp, "w") as f:
                _write_dense(f, rom, write_basis)
        tmp = comm.bcast(tmp, root=0)
        if write_basis:
            r0, r1 = rom.T.getOwnershipRange()
            for rank in range(comm.size):
                if rank == comm.rank:
                    with h5py.File(tmp, "r+") as f:
                        f["rom/basis"][r0:r1, :] = rom.T.getDenseArray()
                        if row_keys is not None:
                            if "row_keys" not in f["rom"]:
                                f["rom"].create_dataset("row_keys",
                                                        shape=(rom.T.getSize()[0],),
                                                        dtype=np.int64)
                            f["rom/row_keys"][r0:r1] = row_keys
                comm.Barrier()
    if comm.rank == 0:
        log.info("ROM written to %s", path)
    comm.Barrier()


def _write_dense(f: h5py.File, rom: ROM, write_basis: bool) -> None:
    g = f.create_group("rom")
    g.attrs["format_version"] = FORMAT_VERSION
    g.attrs["n_cm"] = int(rom.n_cm)
    g.attrs["n_r"] = int(rom.n_r)
    km = np.asarray(rom.km_mean, dtype=float)
    g.attrs["km_mean"] = float(km) if km.ndim == 0 else km
    g.attrs["coordinate_order"] = "q = (q_c, eta): gear DOF first, then modal amplitudes"
    for name in ("M", "K", "C", "frequencies_hz", "mesh_energy", "fixed_interface_hz", "xi"):
        g.create_dataset(name, data=np.asarray(getattr(rom, name), dtype=float))
    G = np.asarray(rom.G, dtype=float)  # one mesh: the 1-D G of format 1
    g.create_dataset("G", data=G[:, 0] if G.ndim == 2 and G.shape[1] == 1 else G)
    g.create_dataset("gear_dofs", data=np.array(rom.gear_dof_names, dtype="S"))
    g.create_dataset("gear_dof_indices", data=np.asarray(rom.gear_dofs, dtype=np.int64))
    if rom.validation is not None:
        v = g.create_group("validation")
        for name in ("full_hz", "rom_hz", "relative_error"):
            v.create_dataset(name, data=np.asarray(getattr(rom.validation, name)))
        v.create_dataset("validity_hz", data=float(rom.validation.validity_hz))
        v.attrs["tol"] = float(rom.validation.tol)
    if write_basis:
        n_fe = rom.T.getSize()[0]
        g.create_dataset(
            "basis", shape=(n_fe, rom.n_r), dtype=float,
            chunks=(min(n_fe, max(1, 65536 // max(rom.n_r, 1))), rom.n_r),
        )


def load_rom(path) -> ROM:
    """Read the dense part of a ROM (every rank may call it); ``T`` is None."""
    with h5py.File(path, "r") as f:
        g = f["rom"]
        d = {k: g[k][()] for k in ("M", "K", "C", "G", "frequencies_hz", "mesh_energy",
                                   "fixed_interface_hz", "xi")}
        if d["G"].ndim == 1:  # one mesh
            d["G"] = d["G"].reshape(-1, 1)
        km = np.asarray(g.attrs["km_mean"], dtype=float)
        names = tuple(s.decode() for s in g["gear_dofs"][()])
        val = None
        if "validation" in g:
            v = g["validation"]
            val = Validation(v["full_hz"][()], v["rom_hz"][()], v["relative_error"][()],
                             float(v["validity_hz"][()]), float(v.attrs["tol"]))
        return ROM(gear_dof_names=names, n_cm=int(g.attrs["n_cm"]),
                   km_mean=float(km) if km.ndim == 0 else km,
                   gear_dofs=g["gear_dof_indices"][()], validation=val, T=None, **d)


def load_basis(path, comm=None, row_range: tuple[int, int] | None = None,
               row_keys=None) -> PETSc.Mat:
    """Read ``rom/basis`` into a distributed dense PETSc matrix (collective).

    Parameters
    ----------
    path : str or Path
        File written by :func:`save_rom` with the basis.
    comm : PETSc.Comm, optional
        Defaults to ``PETSc.COMM_WORLD``.
    row_range : (int, int), optional
        This rank's rows ``[r0, r1)``; give the ownership range of the FE
        matrices to reconstruct on their layout. Default: PETSc's split.
    row_keys : array of int, optional
        Keys of this rank's rows (``fem.FEModel.row_keys``): the rows are looked up by
        key in ``rom/row_keys``, so the basis may come from another partition. Without
        them the file's rows are taken in order (same numbering as when written).
    """
    comm = comm or PETSc.COMM_WORLD
    with h5py.File(path, "r") as f:
        ds = f["rom/basis"]
        n_fe, n_r = ds.shape
        nloc = PETSc.DECIDE if row_range is None else row_range[1] - row_range[0]
        T = PETSc.Mat().createDense(((nloc, n_fe), (PETSc.DECIDE, n_r)), comm=comm)
        T.setUp()
        r0, r1 = T.getOwnershipRange()
        if row_keys is None:
            T.getDenseArray()[:] = ds[r0:r1, :]
        else:
            if "row_keys" not in f["rom"]:
                raise ValueError(f"{path}: no rom/row_keys; load it without row_keys on the "
                                 "partition it was written from")
            T.getDenseArray()[:] = _rows_by_key(ds, f["rom/row_keys"][()],
                                                np.asarray(row_keys, dtype=np.int64), r1 - r0)
    T.assemble()
    return T


def _rows_by_key(ds, file_keys: np.ndarray, keys: np.ndarray, n_local: int,
                 chunk: int = 65536) -> np.ndarray:
    """Rows of ``ds`` whose ``file_keys`` are ``keys`` (in that order), read in chunks of
    ``chunk`` rows so that memory stays at this rank's rows plus one chunk."""
    if keys.shape != (n_local,):
        raise ValueError(f"row_keys.shape = {keys.shape}: must be ({n_local},)")
    order = np.argsort(file_keys, kind="stable")
    sk = file_keys[order]
    pos = np.minimum(np.searchsorted(sk, keys), max(sk.size - 1, 0))
    if keys.size and (sk.size == 0 or np.any(sk[pos] != keys)):
        raise ValueError("row_keys: some keys are not in rom/row_keys (another model?)")
    rows = order[pos]                                  # file row of each local row
    srt = np.argsort(rows, kind="stable")
    rs = rows[srt]
    out = np.empty((keys.size, ds.shape[1]))
    for start in range(0, ds.shape[0], chunk):
        lo, hi = np.searchsorted(rs, [start, start + chunk])
        if lo == hi:
            continue
        block = ds[start:min(start + chunk, ds.shape[0]), :]
        out[srt[lo:hi]] = block[rs[lo:hi] - start]
    return out
