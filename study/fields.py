"""Housing fields for ParaView and virtual accelerometers (FE scenes).

At each ``outputs.housing_field_rpm`` speed three XDMF files are written, all on the
housing alone (its cells of the second-order mesh, ``part_id`` = its volume tag as
cell data):

* ``housing_<rpm>rpm.xdmf``: time series of the housing's dynamic displacement
  (mean over the period removed; the shafts are not in the file, so their rigid and
  torsional swing does not hide the housing's elastic motion), sampled at
  ``housing_frames_per_mesh_period`` frames per mesh period over
  ``housing_mesh_periods`` mesh periods (default: 4 samples per period of the
  highest harmonic kept, so nothing aliases);
* ``housing_orders_<rpm>rpm.xdmf``: per selected shaft order the complex amplitude
  ``ũ`` of the displacement (``u_o<order>_re``, ``_im``, ``_mag`` = |ũ_i| per
  component, ``_phase_deg`` per component) [m, deg];
* ``housing_surface_<rpm>rpm.xdmf``: the outer surface (``triangle6``) with, per
  order and per facet, the normal velocity ``ṽ_n = i ω_k n·ũ`` at the facet centre
  (``vn_o<order>_re``, ``_im``, ``_mag``, ``_phase_deg``) [m/s, deg] and the ERP
  density ``½ ρ c |ṽ_n|²`` (``erp_density_o<order>``) [W/m²].

Amplitudes follow the project's convention ``x(t) = Re Σ_k x̃_k e^{i k ω₀ t}``.

Accelerometers (``[[outputs.accelerometer]]``) are snapped to the nearest outer
facet centre; their velocity ``ṽ_k = i ω_k d·ũ_k`` along the direction d (the facet
normal by default) is computed at every continuation point (``/nvh/accelerometers``).
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from study.errors import SceneError
from study.surface_facets import node_blocks

logger = logging.getLogger(__name__)

__all__ = ["field_orders", "frames_per_mesh_period", "check_outputs", "HousingMesh",
           "housing_mesh", "write_housing_fields", "accelerometer_rows", "V_REF",
           "velocity_level_db", "SNAP_DISTANCE"]

#: Reference velocity of velocity levels (ISO 1683) [m/s].
V_REF = 1e-9
#: Largest distance from an accelerometer position to its outer facet centre [m].
SNAP_DISTANCE = 0.010
#: XDMF/VTK order of the 10 nodes of a P2 tetrahedron from the DOLFINx (basix) order:
#: vertices, then the edge nodes of edges 01, 12, 02, 03, 13, 23 (basix edges 5, 2, 4, 3, 1, 0).
TET10_VTK = np.array([0, 1, 2, 3, 9, 6, 8, 7, 5, 4])


def velocity_level_db(v_amp: np.ndarray, axis: int = -1) -> np.ndarray:
    """Velocity level ``20 log10(v_rms / 1 nm/s)`` [dB] of harmonics of amplitudes
    ``|ṽ_k|`` summed along ``axis`` (``v_rms² = Σ |ṽ_k|²/2``), floored at −100 dB."""
    ms = 0.5 * np.sum(np.abs(v_amp) ** 2, axis=axis)
    return 10.0 * np.log10(np.maximum(ms, (V_REF * 1e-5) ** 2) / V_REF ** 2)


def field_orders(scene, harmonics) -> list[int]:
    """Shaft orders of the per-order fields: the scene's ``field_orders``, else the
    mesh orders kZ and the external orders present in the harmonic set."""
    have = [int(i) * harmonics.integer_ratio for i in harmonics.indices if i > 0]
    if scene.outputs.field_orders:
        return list(scene.outputs.field_orders)
    z = scene.gear.teeth
    ext = set(scene.external.orders)
    return [o for o in have if o % z == 0 or o in ext]


def frames_per_mesh_period(scene, harmonics) -> int:
    """Frames per mesh period of the housing time series (scene value, else 4 samples
    per period of the highest harmonic kept)."""
    n = scene.outputs.housing_frames_per_mesh_period
    if n:
        return int(n)
    max_order = harmonics.max_index * harmonics.integer_ratio
    return max(4, math.ceil(4 * max_order / scene.gear.teeth))


def check_outputs(scene, harmonics, rom=None) -> None:
    """Refuse field orders outside the harmonic set, aliasing frame rates and
    accelerometers away from the housing's outer surface (SceneError)."""

    if scene.scene.kind != "fe":
        return
    have = sorted(int(i) * harmonics.integer_ratio for i in harmonics.indices if i > 0)
    bad = [o for o in scene.outputs.field_orders if o not in have]
    if bad:
        raise SceneError(f"outputs.field_orders = {list(scene.outputs.field_orders)}: orders "
                         f"{bad} are not in the harmonic set (allowed: {have})")
    n = scene.outputs.housing_frames_per_mesh_period
    max_order = harmonics.max_index * harmonics.integer_ratio
    need = math.ceil((2 * max_order + 1) / scene.gear.teeth)
    if n and n < need:
        raise SceneError(f"outputs.housing_frames_per_mesh_period = {n}: aliases the highest "
                         f"harmonic kept (shaft order {max_order}); must be >= {need} "
                         "(more than 2 frames per period of that order), or 0 for automatic")
    if rom is not None and scene.outputs.accelerometers:
        rad = getattr(rom, "radiation", None)
        if rad is None:
            raise SceneError("outputs.accelerometer: the ROM has no housing surface data "
                             "(radiation.h5); reduce it again (geardyn reduce)")
        accelerometer_rows(scene.outputs.accelerometers, rad)


def accelerometer_rows(accels, rad: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rows ``a`` (n_acc × n_r) with ``d·u(x) = a q`` at each accelerometer, its snapped
    position (facet centre) and its unit direction; SceneError when a position lies
    farther than ``SNAP_DISTANCE`` plus the facet's radius from the nearest outer facet
    centre (i.e. clearly off the surface)."""

    cen, nrm, urows = rad["facet_centroid"], rad["facet_normal"], rad["facet_u_rows"]
    rows, pos, dirs = [], [], []
    for i, a in enumerate(accels):
        p = np.asarray(a.position, dtype=float)
        d2 = np.sum((cen - p) ** 2, axis=1)
        j = int(np.argmin(d2))
        dist = math.sqrt(float(d2[j]))
        radius = float(np.max(np.linalg.norm(rad["points"][rad["facet_nodes"][j, :3]] - cen[j],
                                             axis=1)))
        if dist > SNAP_DISTANCE + radius:
            raise SceneError(
                f"outputs.accelerometer[{i}].position_mm = {[round(x * 1e3, 3) for x in p]}: "
                f"{dist * 1e3:.1f} mm from the housing's outer surface (nearest facet centre "
                f"{[round(x * 1e3, 2) for x in cen[j]]} mm, facet radius "
                f"{radius * 1e3:.1f} mm); must be within {SNAP_DISTANCE * 1e3:g} mm of the "
                "surface")
        d = np.asarray(a.direction, dtype=float)
        d = nrm[j] if not np.any(d) else d / np.linalg.norm(d)
        rows.append(d @ urows[j])
        pos.append(cen[j])
        dirs.append(d)
    n_r = urows.shape[2]
    return (np.array(rows).reshape(-1, n_r), np.array(pos).reshape(-1, 3),
            np.array(dirs).reshape(-1, 3))


@dataclass
class HousingMesh:
    """The housing's second-order cells and the ROM basis at its nodes.

    Attributes
    ----------
    points : (n_p, 3) float
        Housing geometry nodes [m].
    cells : (n_c, 10) int
        ``Tetrahedron_10`` connectivity (XDMF/VTK order) into ``points``.
    part_id : (n_c,) int
        Volume tag of each cell.
    basis : (n_p, 3, n_r) float
        Displacement at each node per unit ROM coordinate (``u = basis @ q``) [m].
    """

    points: np.ndarray
    cells: np.ndarray
    part_id: np.ndarray
    basis: np.ndarray


def housing_mesh(model, PT, part: str = "housing") -> HousingMesh | None:
    """:class:`HousingMesh` of ``part`` on rank 0 (``None`` on the other ranks);
    collective on ``model.comm``.

    Each rank takes its owned cells of ``part`` and the basis rows at their nodes from
    the distributed ``P T`` (:func:`study.acoustics.block_u_rows`); rank 0 gathers
    them, merges the nodes shared by several ranks and orders nodes and cells by the
    input mesh's node numbers, so the mesh does not depend on the partition.

    Parameters
    ----------
    model : fem.FEModel
    PT : PETSc dense Mat
        ``P T``: the reduction basis on the P2 DOF of ``model.V``.
    part : str
        Volume group.
    """
    from study.acoustics import block_u_rows

    fm = model.fe_mesh
    mesh = fm.mesh
    comm = mesh.comm
    tag = fm.tag(part, 3)
    cells = np.sort(fm.cell_tags.find(tag))
    cells = cells[cells < mesh.topology.index_map(3).size_local]         # owned only
    cg = mesh.geometry.dofmap
    conn = (np.stack([cg.links(c) for c in cells]) if cells.size
            else np.zeros((0, 10), dtype=np.int64))                      # DOLFINx order
    used = np.unique(conn)
    blocks = node_blocks(mesh, model.V, cells)[used]
    rows = block_u_rows(model, PT, blocks[:, None], np.ones(1))          # (n_u, 3, n_r)
    ids = np.asarray(mesh.geometry.input_global_indices, dtype=np.int64)
    parts = comm.gather((ids[used], mesh.geometry.x[used], rows, ids[conn]), root=0)
    if comm.rank != 0:
        return None
    node_ids, x, basis, cell_ids = (np.concatenate(a) for a in zip(*parts, strict=True))
    uid, first = np.unique(node_ids, return_index=True)
    cell_ids = cell_ids[np.lexsort(np.sort(cell_ids[:, :4], axis=1).T[::-1])]
    conn = np.searchsorted(uid, cell_ids)[:, TET10_VTK]
    return HousingMesh(x[first].copy(), conn, np.full(conn.shape[0], tag, np.int64),
                       basis[first])


def _complex_fields(prefix: str, z: np.ndarray) -> dict[str, np.ndarray]:
    return {f"{prefix}_re": z.real, f"{prefix}_im": z.imag, f"{prefix}_mag": np.abs(z),
            f"{prefix}_phase_deg": np.degrees(np.angle(z))}


def write_housing_fields(out: Path, rpm: float, hm: HousingMesh, rad: dict | None,
                         qk: np.ndarray, harmonics, omega: float, scene) -> list[Path]:
    """Write the three XDMF files of one speed (module docstring); returns their paths.

    Parameters
    ----------
    qk : (n_r, n_h) complex
        ROM coordinates per harmonic of the point.
    harmonics : hbm HarmonicSet
    omega : float
        Shaft speed Ω [rad/s].
    """
    from study.xdmf import write_xdmf

    out = Path(out)
    idx = np.asarray(harmonics.indices)
    w0 = harmonics.fundamental_rad_s(omega)
    z = scene.gear.teeth
    tag = f"{rpm:.0f}rpm"
    paths = []
    # time series of the dynamic displacement (k > 0 only: the mean is removed)
    nf = frames_per_mesh_period(scene, harmonics)
    n_frames = nf * scene.outputs.housing_mesh_periods
    t_mesh = 2 * np.pi / (z * omega)
    dyn = idx > 0
    uk = np.einsum("pcr,rk->pck", hm.basis, qk[:, dyn])             # (n_p, 3, n_dyn)
    frames = []
    for j in range(n_frames):
        t = j * t_mesh / nf
        frames.append((t, {"displacement": (uk * np.exp(1j * idx[dyn] * w0 * t)).real.sum(-1)}))
    paths.append(write_xdmf(out / f"housing_{tag}.xdmf", hm.points, "tetra10", hm.cells,
                            cell_data={"part_id": hm.part_id}, frames=frames))
    logger.info("wrote %s (%d frames, %d per mesh period, %d mesh periods)", paths[-1],
                n_frames, nf, scene.outputs.housing_mesh_periods)
    # complex amplitude per selected order
    orders = field_orders(scene, harmonics)
    pos = {int(k) * harmonics.integer_ratio: j for j, k in enumerate(idx)}
    sel = [(o, pos[o]) for o in orders if o in pos]
    pdata = {}
    for o, j in sel:
        pdata.update(_complex_fields(f"u_o{o}", uk[:, :, int(np.sum(dyn[:j]))]))
    paths.append(write_xdmf(out / f"housing_orders_{tag}.xdmf", hm.points, "tetra10", hm.cells,
                            point_data=pdata, cell_data={"part_id": hm.part_id}))
    if rad is not None:
        cdata: dict[str, np.ndarray] = {
            "part_id": np.full(rad["facet_nodes"].shape[0], hm.part_id[0], np.int64),
            "area": rad["facet_area"]}
        ac = scene.acoustics
        for o, j in sel:
            vn = 1j * idx[j] * w0 * (rad["facet_rows"] @ qk[:, j])
            cdata.update(_complex_fields(f"vn_o{o}", vn))
            cdata[f"erp_density_o{o}"] = 0.5 * ac.air_density * ac.sound_speed * np.abs(vn) ** 2
        paths.append(write_xdmf(out / f"housing_surface_{tag}.xdmf", rad["points"], "triangle6",
                                rad["facet_nodes"], cell_data=cdata))
    logger.info("wrote per-order housing fields for orders %s at %s",
                ", ".join(str(o) for o, _ in sel) or "-", tag)
    return paths
