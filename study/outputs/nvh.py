"""Noise and vibration views of a continuation branch: mesh load per order, its
peak-to-peak value, the housing's equivalent radiated power (ERP) per order, and
the CSV export of the curves.

Computed once at export for every continuation point: the mesh load f_LoA(t)
(eq. 13) on the fine AFT grid of :func:`hbm.time_series`, its Fourier amplitudes at
the harmonic indices of the set, and (FE scenes) the ERP of every harmonic from
the ROM coordinates q̃_k recovered from the point (:meth:`hbm.HBMProblem.recover`)
and the cached radiation matrix W (:mod:`study.outputs.acoustics`).
"""
from __future__ import annotations

import csv
import io
import logging
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path

import numpy as np

from core.files import atomic_write
from core.processes import forked_map
from study.outputs.acoustics import (
    P_REF,
    V_REF,
    PowerForm,
    erp_harmonics,
    power_db,
    velocity_level_db,
)
from study.outputs.fields import accelerometer_rows
from study.outputs.points import point_at

logger = logging.getLogger(__name__)

__all__ = ["NVH", "compute_nvh", "write_nvh_group", "write_curves_csv", "CONTACT_NAMES",
           "order_label"]

CONTACT_NAMES = ("permanent contact", "single-sided impacts", "double-sided impacts")


def order_label(order, n_teeth: int) -> str:
    """Name of a shaft order: ``"Z"``, ``"2Z"``, sidebands ``"Z+2"``, ``"2Z−1"``, and the
    plain number for orders far below the mesh frequency (external orders); half orders
    of a period-2 response as fractions (``"1/2"``, ``"Z−1/2"``, ``"3Z/2"``)."""
    q = Fraction(order).limit_denominator(64)
    z = int(n_teeth)
    k = round(q / z)
    e = q - k * z

    def text(x: Fraction) -> str:
        return str(x.numerator) if x.denominator == 1 else f"{x.numerator}/{x.denominator}"
    h = 2 * q / z
    if h.denominator == 1 and h.numerator % 2 == 1:          # an odd multiple of Z/2
        return "Z/2" if h == 1 else f"{h.numerator}Z/2"
    if k == 0:
        return text(q)
    base = "Z" if k == 1 else f"{k}Z"
    if e == 0:
        return base
    return f"{base}{'+' if e > 0 else '−'}{text(abs(e))}"


@dataclass
class NVH:
    """Per-point NVH quantities of a branch (n points, n_h harmonics).

    Attributes
    ----------
    harmonics : (n_h,) int
        Harmonic indices of the set.
    orders : (n_h,) float
        Shaft orders of those harmonics (index × w0 / Omega).
    mesh_load_amplitude : (n, n_h) float
        |f̃_k| of the mesh load at each harmonic [N].
    mesh_load_ptp : (n,) float
        Peak-to-peak mesh load over the period [N].
    erp : (n, n_h) float or None
        ERP of each harmonic [W] (FE scenes with radiation data).
    erp_total : (n,) float or None
        Σ_k ERP_k [W].
    rho, c : float
        Air density [kg/m³] and speed of sound [m/s] used.
    accel_names : tuple of str
        Virtual accelerometers (``[[outputs.accelerometer]]``).
    accel_velocity : (n_acc, n, n_h) complex or None
        Their velocity amplitude per harmonic [m/s].
    accel_position, accel_direction : (n_acc, 3) float or None
        Snapped positions (outer facet centres) [m] and unit measuring directions.
    """

    harmonics: np.ndarray
    orders: np.ndarray
    mesh_load_amplitude: np.ndarray
    mesh_load_ptp: np.ndarray
    erp: np.ndarray | None
    erp_total: np.ndarray | None
    rho: float
    c: float
    accel_names: tuple = ()
    accel_velocity: np.ndarray | None = None
    accel_position: np.ndarray | None = None
    accel_direction: np.ndarray | None = None
    #: several gear meshes (a train): their names, and per mesh the amplitudes (n, E, n_h;
    #: NaN on a torus) and peak-to-peak loads (n, E); the fields above are mesh 0's
    mesh_names: tuple = ()
    amplitude_per_mesh: np.ndarray | None = None
    ptp_per_mesh: np.ndarray | None = None
    #: a train: the name of every harmonic's order (its shaft or mesh combination,
    #: :func:`study.outputs.train.order_names`), in the order of ``harmonics``
    order_names: tuple = ()

    def order_name(self, j: int, n_teeth: int) -> str:
        """The name of harmonic ``j``'s order: a train's (``stage1``, ``2 stage2``), else
        :func:`order_label` (``Z``, ``2Z−1``)."""
        return self.order_names[j] if self.order_names else order_label(self.orders[j],
                                                                         n_teeth)

    @property
    def erp_db(self) -> np.ndarray | None:
        return None if self.erp is None else power_db(self.erp)

    @property
    def erp_total_db(self) -> np.ndarray | None:
        return None if self.erp_total is None else power_db(self.erp_total)


def orders_of(hs) -> np.ndarray:
    """Shaft orders (of the reference shaft) of the set's harmonics: integers for an integer
    fundamental, else floats (a train's hunting fundamental, or a torus's frequencies)."""
    if not hs.periodic:
        return np.asarray(hs.frequency_index, dtype=float) * float(hs.ratio)
    idx = np.asarray(hs.indices, dtype=int)
    if hs.ratio.denominator == 1:
        return idx * hs.integer_ratio
    return idx * float(hs.ratio)


def _train_nvh(result) -> NVH:
    """Mesh-load amplitudes and peak-to-peak values of every mesh of a problem with several
    gear meshes: over one period of a periodic set; on a torus, the peak-to-peak along
    the time line over :data:`hbm.post.torus.LINE_PERIODS` base periods of the mesh (the
    amplitudes per harmonic vector are not computed there: NaN)."""
    from hbm import time_series
    from hbm.post.torus import line_series

    pb, br = result.problem, result.branch
    hs = pb.harmonics
    idx = np.asarray(hs.indices, dtype=int)
    n, n_el, n_h = len(br), len(pb.elements), len(hs.indices)
    amp = np.full((n, n_el, n_h), np.nan)
    ptp = np.zeros((n, n_el))
    for i in range(n):
        pt = point_at(result, i)
        for e in range(n_el):
            if hs.periodic:
                f = time_series(pb, pt, element=e).load
                c = np.fft.rfft(f) / f.size
                c[1:] *= 2.0
                amp[i, e] = np.abs(c[idx])
            else:
                f = line_series(pb, pt, element=e).load
            ptp[i, e] = float(np.ptp(f))
    out = NVH(idx, orders_of(hs), amp[:, 0], ptp[:, 0], None, None,
              result.scene.acoustics.air_density, result.scene.acoustics.sound_speed,
              mesh_names=tuple(el.name for el in pb.elements), amplitude_per_mesh=amp,
              ptp_per_mesh=ptp)
    if result.scene.is_train:
        from study.outputs.train import order_name, order_names, train_frequencies

        meshes, shafts = train_frequencies(result)
        names = order_names(meshes, shafts, max_harmonic=max(result.scene.hbm.mesh_harmonics, 1))
        out.order_names = tuple(order_name(Fraction(int(k)) * hs.ratio, names)
                                for k in hs.frequency_index)
    return out


def _torus_total(W: np.ndarray, qk: np.ndarray, freq: np.ndarray, rho: float,
                 c: float) -> float:
    """Total ERP of a response on a torus, whose harmonic vectors may share a frequency
    (``k·r`` equal, or opposite: the conjugate): their amplitudes at each distinct
    frequency ``|k·r| ω_0`` are added before the power is taken (powers of distinct
    frequencies add)."""
    groups: dict[float, np.ndarray] = {}
    for j, w in enumerate(freq):
        if w == 0:
            continue
        q = qk[:, j] if w > 0 else qk[:, j].conj()
        key = float(abs(w))
        groups[key] = groups[key] + q if key in groups else q.copy()
    if not groups:
        return 0.0
    keys = sorted(groups)
    return float(np.sum(erp_harmonics(W, np.column_stack([groups[k] for k in keys]),
                                      np.asarray(keys), rho, c)))


def _housing_nvh(result, out: NVH) -> NVH:
    """The housing's ERP per harmonic (and in all) and the accelerometers' velocities at
    every point, from the ROM coordinates ``q̃_k = HBMProblem.recover(point)`` of the
    coupled response (every mesh at once), or its modal coordinates
    (``HBMProblem.modal_coordinates``, ``q̃_k = phi eta_k``) with ``phi^T W phi``, and
    the cached radiation data of the machine's radiating part (``result.rom.radiation``);
    ``out`` unchanged without it."""
    pb, br = result.problem, result.branch
    rad = getattr(result.rom, "radiation", None) if result.rom is not None else None
    if rad is None:
        return out
    hs = pb.harmonics
    idx = np.asarray(hs.frequency_index, dtype=int)       # the indices of a periodic set
    n = len(br)
    ac = result.scene.acoustics
    erp = np.zeros((n, idx.size))
    total = None if hs.periodic else np.zeros(n)
    accels = result.scene.outputs.accelerometers
    W = rad["W"]
    if accels:
        arows, apos, adir = accelerometer_rows(accels, rad)
        avel = np.zeros((len(accels), n, idx.size), dtype=complex)
    # in the modes of the coupled system (an "loa" condensation with modal damping) the
    # radiation matrix and the accelerometer rows are carried over once: one product per
    # point instead of two (the coordinates themselves are never formed)
    modal = pb.sums_modally
    if modal:
        W = pb.phi.T @ W @ pb.phi
        W = 0.5 * (W + W.T)
        if accels:
            arows = arows @ pb.phi
    W = PowerForm(W)

    def point_rows(i: int):
        pt = point_at(result, i)
        qk = pb.modal_coordinates(pt) if modal else pb.recover(pt)
        w = idx * hs.fundamental_rad_s(pt.omega)
        return (erp_harmonics(W, qk, w, ac.air_density, ac.sound_speed),
                None if total is None else _torus_total(W, qk, w, ac.air_density,
                                                        ac.sound_speed),
                1j * w[None, :] * (arows @ qk) if accels else None)

    # the points are independent: shared with forked processes (the other cores)
    for i, (e, t, a) in enumerate(forked_map(point_rows, n)):
        erp[i] = e
        if total is not None:
            total[i] = t
        if accels:
            avel[:, i] = a
    if total is None:             # distinct frequencies: the powers add (acoustics module)
        total = erp.sum(axis=1)
    if n:
        logger.info("ERP of the housing: %.1f to %.1f dB re 1 pW over the branch",
                    float(power_db(total).min()), float(power_db(total).max()))
    out.erp, out.erp_total = erp, total
    if accels:
        out.accel_names = tuple(a.name for a in accels)
        out.accel_velocity, out.accel_position, out.accel_direction = avel, apos, adir
    return out


def compute_nvh(result) -> NVH:
    """NVH quantities at every point of ``result.branch``: the mesh loads per order (every
    mesh of a train) and, for a machine with a radiating part, the housing's ERP and the
    accelerometers (:func:`_housing_nvh`)."""
    from hbm import time_series

    pb, br = result.problem, result.branch
    if len(pb.elements) > 1 or not pb.harmonics.periodic:
        return _housing_nvh(result, _train_nvh(result))
    hs = pb.harmonics
    idx = np.asarray(hs.indices, dtype=int)
    n = len(br)
    amp = np.zeros((n, idx.size))
    ptp = np.zeros(n)
    ac = result.scene.acoustics
    for i in range(n):
        pt = point_at(result, i)
        ts = time_series(pb, pt)
        f = ts.load
        c = np.fft.rfft(f) / f.size
        c[1:] *= 2.0
        amp[i] = np.abs(c[idx])
        ptp[i] = float(np.ptp(f))
    out = NVH(idx, orders_of(hs), amp, ptp, None, None, ac.air_density, ac.sound_speed)
    return _housing_nvh(result, out)


def write_nvh_group(f, nvh: NVH, radiation: dict | None = None) -> None:
    """Write ``/nvh`` of results.h5 (docs/results-format.md)."""
    g = f.create_group("nvh")
    g["harmonics"] = nvh.harmonics.astype(np.int64)
    g["orders"] = (nvh.orders.astype(np.int64) if nvh.orders.dtype.kind in "iu"
                   else nvh.orders)
    if nvh.amplitude_per_mesh is not None:     # several meshes: (n, E, n_h) and (n, E)
        g.attrs["elements"] = list(nvh.mesh_names)
        g["mesh_load_amplitude"] = nvh.amplitude_per_mesh
        g["mesh_load_ptp"] = nvh.ptp_per_mesh
    else:
        g["mesh_load_amplitude"] = nvh.mesh_load_amplitude
        g["mesh_load_ptp"] = nvh.mesh_load_ptp
    g["mesh_load_amplitude"].attrs["unit"] = "N"
    g["mesh_load_ptp"].attrs["unit"] = "N"
    if nvh.erp is None:
        return
    g.attrs["air_density"] = nvh.rho
    g.attrs["sound_speed"] = nvh.c
    g.attrs["reference_power"] = P_REF
    g.attrs["radiation_efficiency"] = 1.0
    g["erp"] = nvh.erp
    g["erp"].attrs["unit"] = "W"
    g["erp_total"] = nvh.erp_total
    g["erp_total"].attrs["unit"] = "W"
    g["erp_db"] = nvh.erp_db
    g["erp_total_db"] = nvh.erp_total_db
    for k in ("erp_db", "erp_total_db"):
        g[k].attrs["unit"] = "dB re 1e-12 W"
    if nvh.accel_velocity is not None:
        import h5py


        a = g.create_group("accelerometers")
        a["names"] = np.array(nvh.accel_names, dtype=h5py.string_dtype())
        a["position"] = nvh.accel_position
        a["direction"] = nvh.accel_direction
        a["velocity"] = nvh.accel_velocity
        a["velocity"].attrs["unit"] = "m/s"
        a["velocity_level_db"] = velocity_level_db(nvh.accel_velocity)
        a["velocity_order_db"] = 20 * np.log10(np.maximum(
            np.abs(nvh.accel_velocity) / np.sqrt(2), V_REF * 1e-5) / V_REF)
        a.attrs["reference_velocity"] = V_REF
    if radiation is not None:
        r = g.create_group("radiation")
        r["W"] = radiation["W"]
        r["W"].attrs["unit"] = "m^2"
        for k in ("area", "n_facets", "part", "quadrature_degree"):
            r.attrs[k] = radiation[k]


def write_curves_csv(path: Path, branch, nvh: NVH) -> Path:
    """``curves.csv``: one row per continuation point (atomic write)."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["point", "speed_rpm", "mesh_load_std_N", "mesh_load_max_N",
                "mesh_load_peak_to_peak_N", "erp_dB_re_1pW", "contact_class", "contact",
                "stable"])
    db = nvh.erp_total_db
    mesh = branch.element(0)
    for i in range(len(branch)):
        cls = int(mesh.contact[i])
        w.writerow([i, f"{branch.rpm[i]:.6f}", f"{mesh.mesh_load_std[i]:.8g}",
                    f"{mesh.mesh_load_max[i]:.8g}", f"{nvh.mesh_load_ptp[i]:.8g}",
                    "" if db is None else f"{db[i]:.4f}", cls, CONTACT_NAMES[cls],
                    int(bool(branch.stable[i]))])
    path = Path(path)
    text = buf.getvalue()
    if nvh.ptp_per_mesh is not None:       # several meshes: their own columns
        text = _per_mesh_columns(text, branch, nvh)
    with atomic_write(path, "w") as fh:
        fh.write(text)
    logger.info("wrote %s", path)
    return path


def _per_mesh_columns(text: str, branch, nvh: NVH) -> str:
    """``curves.csv`` of several meshes: the columns above (the first mesh's) followed by
    ``<mesh>_std_N``, ``<mesh>_max_N``, ``<mesh>_peak_to_peak_N``, ``<mesh>_contact_class``
    for every mesh."""
    rows = text.splitlines()
    head = [f"{n}_{c}" for n in nvh.mesh_names
            for c in ("std_N", "max_N", "peak_to_peak_N", "contact_class")]
    out = [rows[0] + "," + ",".join(head)]
    curves = [branch.element(e) for e in range(len(nvh.mesh_names))]
    for i, row in enumerate(rows[1:]):
        cells = []
        for e, cur in enumerate(curves):
            cells += [f"{cur.mesh_load_std[i]:.8g}", f"{cur.mesh_load_max[i]:.8g}",
                      f"{nvh.ptp_per_mesh[i, e]:.8g}", str(int(cur.contact[i]))]
        out.append(row + "," + ",".join(cells))
    return "\n".join(out) + "\n"
