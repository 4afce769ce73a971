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
from fractions import Fraction
from pathlib import Path

import numpy as np

from study.scene.errors import SceneError

logger = logging.getLogger(__name__)

__all__ = ["field_orders", "frames_per_mesh_period", "check_outputs", "write_housing_fields",
           "accelerometer_rows", "harmonic_orders", "order_tag", "SNAP_DISTANCE"]

#: Largest distance from an accelerometer position to its outer facet centre [m].
SNAP_DISTANCE = 0.010


def _mesh_ratios(scene) -> list[Fraction]:
    """Mesh frequencies over the reference speed, ``Z_1 ρ_1`` of every mesh of the scene's
    machine (the pump: ``[Z]``)."""
    from machines import machine_for

    return [m.frequency_ratio for m in machine_for(scene).gear_meshes]


def harmonic_orders(harmonics) -> list[Fraction]:
    """Shaft order (of the reference shaft, exact) of every harmonic of the set: its
    frequency index times the set's ratio (negative or zero for some torus harmonics)."""
    return [Fraction(int(k)) * harmonics.ratio for k in harmonics.frequency_index]


def _plain(o: Fraction) -> int | Fraction:
    """A whole order as an int (the pump's orders and field names stay integers)."""
    return int(o) if o.denominator == 1 else o


def order_tag(order) -> str:
    """The order in field names: ``76``, and ``437_61`` for the order 437/61 of a train."""
    o = Fraction(order)
    return str(o.numerator) if o.denominator == 1 else f"{o.numerator}_{o.denominator}"


def field_orders(scene, harmonics) -> list:
    """Shaft orders of the per-order fields: the scene's ``field_orders``, else every
    mesh's harmonics ``k Z_e ρ_e`` and the external orders present in the harmonic set (a
    train's order k of shaft s at ``k ρ_s``; ints for whole orders, Fractions for a
    train's others)."""
    if scene.outputs.field_orders:
        return list(scene.outputs.field_orders)
    have = [o for o in harmonic_orders(harmonics) if o > 0]
    meshes = _mesh_ratios(scene)
    ext = {Fraction(o) for o in _external_orders(scene)}
    return [_plain(o) for o in have
            if any((o / f).denominator == 1 for f in meshes) or o in ext]


def _external_orders(scene) -> list:
    """The external excitation's orders of the reference shaft: the scene's
    ``external.orders`` for a pair, ``k ρ_s`` for order k of shaft s of a train."""
    if not getattr(scene, "is_train", False):
        return list(scene.external.orders)
    from machines import machine_for

    return list(machine_for(scene).layout.order_frequencies().values())


def _max_order(harmonics) -> Fraction:
    """The highest shaft order of the set (its largest frequency index)."""
    return max(abs(Fraction(int(k))) for k in harmonics.frequency_index) * harmonics.ratio


def frames_per_mesh_period(scene, harmonics) -> int:
    """Frames per mesh period (of the first mesh) of the housing time series (scene value,
    else 4 samples per period of the highest harmonic kept)."""
    n = scene.outputs.housing_frames_per_mesh_period
    if n:
        return int(n)
    return max(4, math.ceil(4 * _max_order(harmonics) / _mesh_ratios(scene)[0]))


def check_outputs(scene, harmonics, rom=None) -> None:
    """Refuse field orders outside the harmonic set, aliasing frame rates and
    accelerometers away from the housing's outer surface (SceneError); nothing to check
    for a machine without a radiating part (the scene loader refused those outputs)."""
    from machines import machine_for

    if machine_for(scene).radiating_part is None:
        return
    have = sorted({_plain(o) for o in harmonic_orders(harmonics) if o > 0})
    bad = [o for o in scene.outputs.field_orders if o not in have]
    if bad:
        shown = [str(o) for o in have]
        raise SceneError(f"outputs.field_orders = {list(scene.outputs.field_orders)}: orders "
                         f"{bad} are not in the harmonic set (allowed: "
                         f"[{', '.join(shown)}])")
    n = scene.outputs.housing_frames_per_mesh_period
    max_order = _plain(_max_order(harmonics))
    need = math.ceil((2 * max_order + 1) / _mesh_ratios(scene)[0])
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


#: Fields written per complex amplitude z: Re z, Im z, |z| and arg z [deg].
_COMPLEX_PARTS = ("re", "im", "mag", "phase_deg")


def _complex_fields(prefix: str, z: np.ndarray) -> dict[str, np.ndarray]:
    """``{prefix}_re``, ``_im``, ``_mag``, ``_phase_deg`` of the complex array ``z``."""
    parts = (z.real, z.imag, np.abs(z), np.degrees(np.angle(z)))
    return {f"{prefix}_{p}": v for p, v in zip(_COMPLEX_PARTS, parts, strict=True)}


def write_housing_fields(out: Path, rpm: float, hd, rad: dict | None, qk: np.ndarray,
                         harmonics, omega: float, scene) -> list[Path]:
    """Write the three XDMF files of one speed (module docstring); returns their paths.

    The displacement is ``u = u_rows q`` at the housing's nodes, ``u_rows`` read block by
    block from the cached ROM's ``housing.h5`` (no FE model, no mesh file): per block the
    time series is ``u_rows q(t_j)`` with the modal time series
    ``q(t) = Re Σ_{k>0} q̃_k e^{i k ω₀ t}`` and the amplitude of order o is ``u_rows q̃_o``.

    Parameters
    ----------
    hd : fem.post.fields.HousingData
        The housing's nodes, cells and rows (``fem.post.read_housing``).
    rad : dict or None
        The ROM's radiation data (``radiation.h5``): the surface file is written with it.
    qk : (n_r, n_h) complex
        ROM coordinates per harmonic of the point.
    harmonics : hbm HarmonicSet
    omega : float
        Shaft speed Ω [rad/s].
    """
    out = Path(out)
    idx = np.asarray(harmonics.frequency_index)         # the indices of a periodic set
    w0 = harmonics.fundamental_rad_s(omega)
    tag = f"{rpm:.0f}rpm"
    nf = frames_per_mesh_period(scene, harmonics)
    n_frames = nf * scene.outputs.housing_mesh_periods
    t_mesh = 2 * np.pi / (float(_mesh_ratios(scene)[0]) * omega)
    times = [j * t_mesh / nf for j in range(n_frames)]
    dyn = idx != 0                                       # the mean is removed
    q_t = (qk[:, dyn] @ np.exp(1j * np.outer(idx[dyn] * w0, times))).real  # (n_r, n_frames)
    pos = {_plain(o): j for j, o in enumerate(harmonic_orders(harmonics)) if o > 0}
    sel = [(o, pos[o]) for o in field_orders(scene, harmonics) if o in pos]
    paths = _write_volume_fields(out, tag, hd, times, q_t,
                                 {o: qk[:, j] for o, j in sel})
    logger.info("wrote %s (%d frames, %d per mesh period, %d mesh periods)", paths[0],
                n_frames, nf, scene.outputs.housing_mesh_periods)
    if rad is not None:
        ac = scene.acoustics
        vn = {o: 1j * idx[j] * w0 * (rad["facet_rows"] @ qk[:, j]) for o, j in sel}
        paths.append(_write_surface_fields(out / f"housing_surface_{tag}.xdmf", rad,
                                           hd.part_tag, vn, ac.air_density, ac.sound_speed))
    logger.info("wrote per-order housing fields for orders %s at %s",
                ", ".join(str(o) for o, _ in sel) or "-", tag)
    return paths


def _write_volume_fields(out: Path, tag: str, hd, times: list[float], q_t: np.ndarray,
                         q_orders: dict[int, np.ndarray]) -> list[Path]:
    """``housing_<tag>.xdmf`` (``u_rows q(t_j)`` per frame) and ``housing_orders_<tag>.xdmf``
    (``u_rows q̃_o`` per order), filled block of nodes by block from ``housing.h5``."""
    from fem.post.fields import BLOCK_BYTES
    from fem.post.xdmf import xdmf_writer

    part_id = np.full(hd.cells.shape[0], hd.part_tag, np.int64)
    paths = [out / f"housing_{tag}.xdmf", out / f"housing_orders_{tag}.xdmf"]
    q_sel = np.column_stack(list(q_orders.values())) if q_orders else np.zeros((hd.n_r, 0))
    # one real product per block gives the frames and the orders' real and imaginary parts
    # (a complex product, r cast to complex, varied in the last bit from run to run)
    n_t, n_o = len(times), len(q_orders)
    q_all = np.hstack([q_t, q_sel.real, q_sel.imag])             # (n_r, n_t + 2 n_o)
    # float64 per node of a block: rows 3 n_r, the frames twice (product, transposed copy),
    # per order the product, the complex amplitude and its four fields (2 + 2 + 4)
    nodes = BLOCK_BYTES // (8 * 3 * (hd.n_r + 2 * n_t + 8 * n_o))
    with xdmf_writer(paths[0], hd.points, "tetra10", hd.cells, times) as ts, \
            xdmf_writer(paths[1], hd.points, "tetra10", hd.cells) as od:
        ts.add("part_id", part_id, "Cell")
        disp = [ts.create("displacement", frame=j) for j in range(len(times))]
        amp = {f"u_o{order_tag(o)}_{p}": od.create(f"u_o{order_tag(o)}_{p}")
               for o in q_orders for p in _COMPLEX_PARTS}
        od.add("part_id", part_id, "Cell")
        for a, b, rows in hd.row_blocks(max(1, nodes)):
            u = rows.reshape(-1, hd.n_r) @ q_all                   # (3 (b - a), n_t + 2 n_o)
            u_t = np.ascontiguousarray(u[:, :n_t].T)                # (n_t, 3 (b - a))
            for j, ds in enumerate(disp):
                ds[a:b] = u_t[j].reshape(-1, 3)
            for i, o in enumerate(q_orders):
                z = u[:, n_t + i] + 1j * u[:, n_t + n_o + i]
                for name, v in _complex_fields(f"u_o{order_tag(o)}", z.reshape(-1, 3)).items():
                    amp[name][a:b] = v
    return paths


def _write_surface_fields(path: Path, rad: dict, part_tag: int, vn: dict[int, np.ndarray],
                          rho: float, c: float) -> Path:
    """``housing_surface_<rpm>rpm.xdmf``: facet areas, and per order the normal velocity
    ``vn`` at the facet centres and the ERP density ``½ ρ c |ṽ_n|²``."""
    from fem.post.xdmf import write_xdmf

    cdata: dict[str, np.ndarray] = {
        "part_id": np.full(rad["facet_nodes"].shape[0], part_tag, np.int64),
        "area": rad["facet_area"]}
    for o, v in vn.items():
        cdata.update(_complex_fields(f"vn_o{order_tag(o)}", v))
        cdata[f"erp_density_o{order_tag(o)}"] = 0.5 * rho * c * np.abs(v) ** 2
    return write_xdmf(path, rad["points"], "triangle6", rad["facet_nodes"], cell_data=cdata)
