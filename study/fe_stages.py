"""FE stages of the pipeline (``scene.kind = "fe"``): mesh, FE model, ROM, the HBM
problem on the ROM, the ``rom/`` group of results.h5 and housing fields (the ROM plots
are :func:`study.plots_modes.rom_plots`).

Everything that needs gmsh, dolfinx, petsc4py or slepc4py is imported inside the
functions, so that importing this module (or running a lumped scene) loads none of
them. Scene values reach the FE packages as their parameter dataclasses, built by
:func:`study.fe_params.fe_parameters`.
"""
from __future__ import annotations

import dataclasses
import json
import logging
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from study.fe_params import FEParams, fe_parameters
from study.model import build_problem
from study.outputs import fields
from study.outputs.points import nearest_point
from study.pipeline.parallel import world
from study.scene.errors import SceneError

logger = logging.getLogger(__name__)

__all__ = ["FEParams", "fe_parameters", "mesh_stage", "fe_stage", "rom_stage", "rom_problem",
           "write_rom_group", "housing_fields", "NODE_NAMES"]

#: Named FE nodes whose basis rows are kept with the ROM (loads act there).
NODE_NAMES = tuple(f"{s}/station_{k}" for s in ("in", "out") for k in range(1, 7)) + \
    ("in/coupling", "out/coupling", "in/gear", "out/gear")


# --------------------------------------------------------------------------- stages

def mesh_stage(scene, folder: Path) -> None:
    """Build and mesh the pump; write ``pump.msh`` and ``mesh.json`` (groups, centres)."""
    from geometry import build_pump, gmsh_session, write_msh

    p = fe_parameters(scene.fe, scene.gear)
    with gmsh_session():
        try:
            meshed = build_pump(p.pump, p.mesh)
        except (ValueError, RuntimeError) as exc:  # sizes refused, or quality too low
            raise SceneError(f"meshing: {exc}") from exc
        write_msh(folder / "pump.msh")
        q = meshed.quality
        info = {"groups": {k: [int(v[0]), int(v[1])] for k, v in meshed.groups.items()},
                "centres": {k: [float(x) for x in np.asarray(v).ravel()]
                            for k, v in meshed.centres.items()},
                "quality": {k: (float(v) if isinstance(v, (int, float, np.number)) else str(v))
                            for k, v in dataclasses.asdict(q).items()
                            if not isinstance(v, (dict, list, tuple))}}
    (folder / "mesh.json").write_text(json.dumps(info, indent=1))


def fe_stage(scene, mesh_dir: Path, comm=None):
    """FE model of the pump from the cached mesh (``fem.FEModel``); collective on
    ``comm`` (default ``MPI.COMM_WORLD``): its rank 0 reads the mesh file, DOLFINx
    partitions it over the ranks and every rank assembles its part."""
    import gmsh
    from mpi4py import MPI

    from fem import build_pump_model, load_gmsh_mesh
    from geometry import gmsh_session

    p = fe_parameters(scene.fe, scene.gear)
    info = json.loads((Path(mesh_dir) / "mesh.json").read_text())
    groups = {k: (int(v[0]), int(v[1])) for k, v in info["groups"].items()}
    centres = {k: np.asarray(v, dtype=float) for k, v in info["centres"].items()}
    comm = MPI.COMM_WORLD if comm is None else comm
    with gmsh_session():
        gmsh.clear()
        if comm.rank == 0:  # the other ranks receive their cells from rank 0
            gmsh.merge(str(Path(mesh_dir) / "pump.msh"))
        fe_mesh = load_gmsh_mesh(None, comm, 0, groups=groups, centres=centres)
    return build_pump_model(None, p.materials, p.gears, p.bearings, p.drive, fe_mesh=fe_mesh,
                            rotors=p.rotors)


def rom_stage(scene, model, folder: Path, progress: bool = False) -> None:
    """Craig–Bampton ROM (``rom.h5`` with basis), what the export needs of the FE model
    computed once from the distributed ``P T`` — the radiation data of the housing's outer
    surface (``radiation.h5``) and its field data (``housing.h5``: nodes, cells, rows of
    ``P T``; :mod:`fem.post`) — and the basis rows of the load nodes (``nodes.h5``);
    collective on the model's communicator, rank 0 writes the files.

    The coupled quantities stored in rom.h5 (frequencies, mesh energy, C, and the
    Fig. 9 validation) use the scene's mean mesh stiffness at build time; the hbm
    stage recomputes frequencies, mesh energies and C for the current k̄ and ξ.
    """
    import h5py

    from fem import post
    from reduction import build_rom, craig_bampton, save_rom, validate_rom

    r = scene.rom
    km, xi = scene.mesh_stiffness.mean, scene.damping.modal_ratio
    kw = {"f_cut_hz": r.cutoff} if r.cutoff else {"n_modes": r.n_cm}
    cb = craig_bampton(model.M, model.K, model.gear_dofs, factor=r.factorization,
                       out_of_core=r.out_of_core, **kw)
    rom = build_rom(cb, model.G, km, xi)
    if r.n_check > 0:
        rom.validation = validate_rom(rom, model.M, model.K, model.gear_dofs, model.G, km,
                                      min(r.n_check, rom.n_r))
    # collective: each rank writes its basis rows with their partition-independent keys
    save_rom(folder / "rom.h5", rom, row_keys=model.row_keys())
    # collective: each rank its facets and housing nodes, rank 0 gathers and writes
    # (no serial FE model); the export reads these files instead of the FE model
    PT = post.field_operator(model, rom.T)
    post.radiation_data(model, PT, folder / post.RADIATION_FILE)
    post.housing_data(model, PT, folder / post.HOUSING_FILE)
    PT.destroy()
    if rom.T.getComm().tompi4py().rank != 0:
        return
    nodes = {n: [int(i) for i in model.node_dofs[n]] for n in NODE_NAMES if n in model.node_dofs}
    rows = sorted({i for v in nodes.values() for i in v if i >= 0})
    with h5py.File(folder / "rom.h5", "r") as f:
        basis_rows = f["rom/basis"][rows, :] if rows else np.zeros((0, rom.n_r))
    with h5py.File(folder / "nodes.h5", "w") as f:
        f["rows"] = np.asarray(rows, dtype=np.int64)
        f["basis_rows"] = basis_rows
        f.attrs["nodes"] = json.dumps(nodes)
        f.attrs["n_fe"] = int(model.K.getSize()[0])


@dataclass
class RomData:
    """What the hbm/export stages need of a cached ROM (dense, no PETSc)."""

    folder: Path
    M: np.ndarray
    K: np.ndarray
    C: np.ndarray
    G: np.ndarray
    frequencies_hz: np.ndarray
    mesh_energy: np.ndarray
    km_mean: float
    n_cm: int
    validation: Any
    node_rows: dict[str, np.ndarray]
    radiation: dict | None = None


def _node_rows(folder: Path) -> dict[str, np.ndarray]:
    import h5py

    with h5py.File(folder / "nodes.h5", "r") as f:
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


def rom_forcing(scene, rows: dict[str, np.ndarray], n_r: int) -> tuple[dict, dict]:
    """External forcing on the ROM per shaft order: constant and Ω²-proportional parts.

    Order 0: the impeller load torque T about +z on ``out/coupling`` (balanced by the
    motor spring on the input: mesh load F_s = T/r_b). Aerodynamic loads (eq. 1):
    node load ``[F, M] e^{iφ}`` on ``{shaft}/station_k`` projected with the basis rows,
    ``f_r = T_nodeᵀ f``. Unbalance (eq. 2–3): ``f_x = −m Ω² sin(Ωt + φ)``,
    ``f_y = −m Ω² cos(Ωt + φ)`` spread evenly on the six stations of the shaft,
    i.e. Ω²-coefficients ``(i m e^{iφ}, −m e^{iφ})/6`` at order 1.
    """
    const: dict[int, np.ndarray] = {0: np.zeros(n_r, complex)}
    om2: dict[int, np.ndarray] = {}
    const[0] += rows["out/coupling"].T @ np.array([0, 0, 0, 0, 0, scene.load.torque])
    for a in scene.external.aero:
        f = np.concatenate([a.force, a.torque]) * np.exp(1j * a.phase)
        v = rows[f"{a.shaft}/station_{a.station}"].T @ f
        const[a.order] = const.get(a.order, np.zeros(n_r, complex)) + v
    for u in scene.external.unbalance:
        c = u.m_unb * np.exp(1j * u.phase) / 6.0
        f = np.array([1j * c, -c, 0, 0, 0, 0])
        for k in range(1, 7):
            v = rows[f"{u.shaft}/station_{k}"].T @ f
            om2[1] = om2.get(1, np.zeros(n_r, complex)) + v
    const[0] = const[0].real.astype(complex)
    return const, om2


def load_rom_data(scene, rom_dir: Path) -> RomData:
    """Dense ROM with C, coupled frequencies and mesh energies for the scene's k̄, ξ."""
    from reduction import coupled_modes, load_rom, mesh_energy, modal_damping

    rom = load_rom(Path(rom_dir) / "rom.h5")
    km, xi = scene.mesh_stiffness.mean, scene.damping.modal_ratio
    C = modal_damping(rom.M, rom.K, rom.G, km, xi)                  # eq. (18-19)
    modes = coupled_modes(rom.M, rom.K, rom.G, km)                   # eq. (17)
    rho = mesh_energy(rom.M, rom.K, rom.G, km)                       # eq. (31)
    return RomData(Path(rom_dir), rom.M, rom.K, C, rom.G, modes.frequencies_hz, rho, km,
                   rom.n_cm, rom.validation, _node_rows(Path(rom_dir)),
                   _load_radiation(Path(rom_dir)))


def _load_radiation(folder: Path) -> dict | None:
    """Datasets and attributes of the cached ``radiation.h5`` (None when absent)."""
    from fem.post import RADIATION_FILE, read_radiation

    return read_radiation(folder / RADIATION_FILE)


def rom_problem(scene, rom_dir: Path):
    """(HBMProblem, RomData) of an FE scene from its cached ROM."""
    rd = load_rom_data(scene, rom_dir)
    const, om2 = rom_forcing(scene, rd.node_rows, rd.M.shape[0])
    return build_problem(scene, rd.M, rd.C, rd.K, rd.G, const, om2), rd


def write_rom_group(f, result) -> None:
    """Copy the cached ROM's dense datasets into results.h5 ``/rom`` (no basis) and
    replace the coupled quantities by those of the run's k̄ and ξ."""
    import h5py

    rd = result.rom
    with h5py.File(rd.folder / "rom.h5", "r") as src:
        g = f.create_group("rom")
        for k, v in src["rom"].attrs.items():
            g.attrs[k] = v
        for name in src["rom"]:
            if name != "basis":
                src.copy(src["rom"][name], g, name=name)
    for name, val in (("C", rd.C), ("frequencies_hz", rd.frequencies_hz),
                      ("mesh_energy", rd.mesh_energy)):
        del g[name]
        g[name] = val
    g.attrs["km_mean"] = rd.km_mean
    g.attrs["xi_run"] = result.scene.damping.modal_ratio


def housing_fields(result) -> list[Path]:
    """Housing-only XDMF files at the scene's ``housing_field_rpm`` speeds (study.fields):
    time series of the dynamic displacement (no aliasing), complex amplitudes per order,
    normal velocity and ERP density per order on the outer surface.

    From the cached ROM alone (``housing.h5`` and ``radiation.h5`` of the rom stage): no
    FE model and no mesh file. Rank 0 writes; the files are the same whatever the number
    of ranks that reduced the model."""
    return world().root_call(_write_housing_fields, result)


def _write_housing_fields(result) -> list[Path]:
    from fem.post import HOUSING_FILE, read_housing

    sc = result.scene
    hd = read_housing(result.rom.folder / HOUSING_FILE)
    paths = []
    for rpm in sc.outputs.housing_field:
        _, pt = nearest_point(result, rpm)
        qk = result.problem.recover(pt)                      # (n_r, nS) complex
        paths += fields.write_housing_fields(Path(result.out), pt.rpm, hd, result.rom.radiation,
                                             qk, result.problem.harmonics, pt.omega, sc)
    return paths
