"""The rom stage of an FE machine and the cached ROM read back.

:func:`reduce_and_store` reduces an ``fem.FEModel`` onto the 6 DOF of every gear body
(Craig–Bampton, ``reduction``), validates it against the full model coupled by every
mesh (Fig. 9) and writes, in the rom cache entry, ``rom.h5`` (with the basis), what the
export needs of the FE model, computed once from the distributed ``P T`` by
:mod:`fem.post` for the machine's radiating part — ``radiation.h5`` and ``housing.h5``
— and ``nodes.h5``, the basis rows of the machine's load nodes. :func:`load_rom_data`
reads that entry back as :class:`RomData`, dense and without PETSc.
"""
from __future__ import annotations

import json
import logging
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

logger = logging.getLogger(__name__)

__all__ = ["RomData", "NODES_FILE", "ROM_FILE", "reduce_and_store", "load_rom_data",
           "read_node_rows", "rom_stage_inputs"]

ROM_FILE = "rom.h5"


def rom_stage_inputs(r) -> dict:
    """The ``[rom]`` values the rom stage builds from (its cache key): the number of
    component modes or the resolved cut-off, the factorisation, and the check, whose
    frequency ``check_hz`` counts only when it sets the check (``n_check`` not given).
    ``cutoff_factor`` reaches the stage through the resolved cut-off; a run whose speed
    range moves ``check_hz`` keeps a cached ROM whose check it does not change."""
    keys = ("n_cm", "cutoff", "n_check", "factorization", "out_of_core")
    out = {k: getattr(r, k) for k in keys}
    if r.n_check is None:
        out["check_hz"] = r.check_hz
    return out
#: Basis rows of the load nodes: ``rows`` (int), ``basis_rows`` (rows x n_r), attributes
#: ``nodes`` (JSON: node -> its 6 reduced indices, -1 for a fixed DOF) and ``n_fe``.
NODES_FILE = "nodes.h5"


def _km(machine: Any) -> float | tuple[float, ...]:
    """The machine's mean mesh stiffness: one number for one mesh (the ROM files keep
    their scalar ``km_mean``), else one per mesh."""
    km = tuple(machine.mean_mesh_stiffness())
    return km[0] if len(km) == 1 else km


def reduce_and_store(machine: Any, model: Any, folder: Path) -> None:
    """Craig–Bampton ROM (``rom.h5`` with basis), the radiation and field data of the
    machine's radiating part (``radiation.h5``, ``housing.h5``; :mod:`fem.post`) and the
    basis rows of its load nodes (``nodes.h5``); collective on the model's communicator,
    rank 0 writes the files.

    The coupled quantities stored in rom.h5 (frequencies, mesh energy, C, and the Fig. 9
    validation) use the scene's mean mesh stiffness at build time; the hbm stage
    recomputes frequencies, mesh energies and C for the current k̄ and ξ
    (:func:`load_rom_data`).
    """
    import h5py

    from fem import post
    from reduction import build_rom, craig_bampton, save_rom, validate_rom, validate_to

    scene = machine.scene
    r = scene.rom
    km, xi = _km(machine), scene.damping.modal_ratio
    if r.cutoff is None and r.n_cm is None:
        raise ValueError("rom.n_cm = None and rom.cutoff = None: the scene loader resolves "
                         "the cut-off (study.scene.frequency.resolve_rom)")
    kw = {"f_cut_hz": r.cutoff} if r.cutoff else {"n_modes": r.n_cm}
    cb = craig_bampton(model.M, model.K, model.gear_dofs, factor=r.factorization,
                       out_of_core=r.out_of_core, **kw)
    rom = build_rom(cb, model.G, km, xi)
    if r.n_check is None and r.check_hz:      # every coupled mode up to the excitation
        rom.validation = validate_to(rom, model.M, model.K, model.gear_dofs, model.G, km,
                                     r.check_hz)
    elif r.n_check:
        rom.validation = validate_rom(rom, model.M, model.K, model.gear_dofs, model.G, km,
                                      min(r.n_check, rom.n_r))
    # collective: each rank writes its basis rows with their partition-independent keys
    save_rom(folder / ROM_FILE, rom, row_keys=model.row_keys())
    part = machine.radiating_part
    if part is not None:
        # collective: each rank its facets and part nodes, rank 0 gathers and writes (no
        # serial FE model); the export reads these files instead of the FE model
        PT = post.field_operator(model, rom.T)
        post.radiation_data(model, PT, folder / post.RADIATION_FILE, part=part)
        post.housing_data(model, PT, folder / post.HOUSING_FILE, part=part)
        PT.destroy()
    if rom.T.getComm().tompi4py().rank != 0:
        return
    nodes = {n: [int(i) for i in model.node_dofs[n]] for n in machine.load_nodes
             if n in model.node_dofs}
    rows = sorted({i for v in nodes.values() for i in v if i >= 0})
    with h5py.File(folder / ROM_FILE, "r") as f:
        basis_rows = f["rom/basis"][rows, :] if rows else np.zeros((0, rom.n_r))
    with h5py.File(folder / NODES_FILE, "w") as f:
        f["rows"] = np.asarray(rows, dtype=np.int64)
        f["basis_rows"] = basis_rows
        f.attrs["nodes"] = json.dumps(nodes)
        f.attrs["n_fe"] = int(model.K.getSize()[0])


@dataclass
class RomData:
    """What the hbm and export stages need of a cached ROM (dense, no PETSc).

    Attributes
    ----------
    folder : Path
        The rom cache entry (``rom.h5``, ``nodes.h5``, ``radiation.h5``, ``housing.h5``).
    M, K, C : numpy.ndarray (n_r, n_r)
        Reduced mass, stiffness (no mesh) and the modal damping for the scene's k̄, ξ.
    G : numpy.ndarray (n_r, E)
        One line-of-action direction per gear mesh (eq. 11).
    frequencies_hz, mesh_energy : numpy.ndarray (n_r,)
        Coupled frequencies (eq. 17) and mesh energies (eq. 31) for the scene's k̄.
    km_mean : float or tuple
        The k̄ they were computed with (one number for one mesh).
    n_cm : int
        Fixed-interface modes kept.
    validation : reduction.Validation or None
        Fig. 9 comparison made when the ROM was built.
    node_rows : dict[str, numpy.ndarray]
        Basis rows (6, n_r) of each load node: node DOF = ``node_rows[n] @ q``.
    radiation : dict or None
        The cached ``radiation.h5`` (:func:`fem.post.read_radiation`), None without one.
    """

    folder: Path
    M: np.ndarray
    K: np.ndarray
    C: np.ndarray
    G: np.ndarray
    frequencies_hz: np.ndarray
    mesh_energy: np.ndarray
    km_mean: Any
    n_cm: int
    validation: Any
    node_rows: dict[str, np.ndarray]
    radiation: dict | None = None

    def mesh_softening(self, xi: float, f_min: float = 0.0, mesh: int = 0
                       ) -> tuple[float, float]:
        """The dynamic-factor peak of mesh ``mesh`` near the mode with most mesh energy at
        or above ``f_min`` [Hz] and its shift under k̄/2, ``(Hz, f½/f)`` (T.33,
        :func:`reduction.mesh_softening`), for modal damping ratio ``xi``."""
        from reduction import mesh_softening

        return mesh_softening(self.M, self.K, self.G, self.km_mean, xi, f_min=f_min,
                              mesh=mesh)

    def housing(self) -> Any:
        """The radiating part's field data (``housing.h5``, :func:`fem.post.read_housing`:
        nodes, cells and the rows of ``P T`` in blocks)."""
        from fem.post import HOUSING_FILE, read_housing

        return read_housing(self.folder / HOUSING_FILE)


def read_node_rows(folder: Path) -> dict[str, np.ndarray]:
    """The basis rows of the load nodes (``nodes.h5``): node -> (6, n_r), zero rows for
    fixed DOF."""
    import h5py

    with h5py.File(Path(folder) / NODES_FILE, "r") as f:
        rows = list(f["rows"][()])
        br = f["basis_rows"][()]
        nodes = json.loads(f.attrs["nodes"])
    pos = {r: i for i, r in enumerate(rows)}
    out = {}
    for name, dofs in nodes.items():
        m = np.zeros((6, br.shape[1]))
        for j, d in enumerate(dofs):
            if d >= 0:
                m[j] = br[pos[d]]
        out[name] = m  # (6, n_r): node DOF = m @ q
    return out


def load_rom_data(machine: Any, rom_dir: Path) -> RomData:
    """Dense ROM of the rom cache entry ``rom_dir`` with C (eq. 18–19), coupled
    frequencies (eq. 17) and mesh energies (eq. 31) for the scene's k̄ and ξ."""
    from fem.post import RADIATION_FILE, read_radiation
    from reduction import coupled_modes, load_rom, mesh_energy, modal_damping

    rom_dir = Path(rom_dir)
    rom = load_rom(rom_dir / ROM_FILE)
    km, xi = _km(machine), machine.scene.damping.modal_ratio
    C = modal_damping(rom.M, rom.K, rom.G, km, xi)                  # eq. (18-19)
    modes = coupled_modes(rom.M, rom.K, rom.G, km)                   # eq. (17)
    rho = mesh_energy(rom.M, rom.K, rom.G, km)                       # eq. (31)
    return RomData(rom_dir, rom.M, rom.K, C, rom.G, modes.frequencies_hz, rho, km,
                   rom.n_cm, rom.validation, read_node_rows(rom_dir),
                   read_radiation(rom_dir / RADIATION_FILE))
