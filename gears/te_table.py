"""Measured or third-party mesh data as Fourier series: the ``table`` source.

A CSV file gives the transmission error and/or the mesh stiffness against the mesh
position, the roll angle of gear 1 or the roll distance along the line of action;
:func:`read_mesh_table` reads and checks it, :func:`table_series` fits the mesh
harmonics the caller asks for (docs/gears.md, "Tables", equations X.1–X.3). Pure Python
and NumPy, SI inside.

File format: optional ``#`` comment lines, one header row, then one row of numbers per
sample. The header names one abscissa column and at least one value column, each with
its unit as a suffix:

=====================================================  ===============================
abscissa (one of)                                      values (one or both)
=====================================================  ===============================
``mesh_position`` (mesh periods)                       ``te_um``, ``te_m``
``roll_angle_deg``, ``roll_angle_rad`` (gear 1 turns)  ``stiffness_N_per_um``,
``roll_distance_mm``, ``roll_distance_um`` (along the  ``stiffness_N_per_m``
line of action)
=====================================================  ===============================

The samples must cover a whole number of mesh periods: either with the end point
(the last position one whole span after the first, the last value repeating the first
within 2 % of the peak-to-peak) or without it (evenly spaced, the span one step longer
than the last minus the first position).
"""
from __future__ import annotations

import csv
import math
import numbers
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from core.errors import InputError

from .excitation import Series

__all__ = ["MeshTable", "read_mesh_table", "mesh_table", "table_series"]

#: abscissa column -> (kind, factor to its SI unit: mesh periods, rad, m)
ABSCISSAE = {
    "mesh_position": ("mesh", 1.0), "roll_angle_deg": ("angle", math.pi / 180.0),
    "roll_angle_rad": ("angle", 1.0), "roll_distance_mm": ("distance", 1e-3),
    "roll_distance_um": ("distance", 1e-6),
}
#: value column -> (quantity, factor to SI)
VALUES = {"te_um": ("te", 1e-6), "te_m": ("te", 1.0),
          "stiffness_N_per_um": ("stiffness", 1e6), "stiffness_N_per_m": ("stiffness", 1.0)}
#: Largest mismatch of the repeated end sample, as a fraction of the peak-to-peak.
PERIODIC_TOLERANCE = 0.02


@dataclass(frozen=True)
class MeshTable:
    """Samples of the mesh over whole mesh periods (SI).

    Attributes
    ----------
    position : tuple of float
        Mesh position of each sample (mesh periods), increasing, from 0, end point
        excluded.
    periods : int
        Mesh periods the samples span.
    te, stiffness : tuple of float or None
        Transmission error (m) and mesh stiffness (N/m) at each position.
    source : str
        Where the samples came from (a file name), for messages.
    """

    position: tuple[float, ...]
    periods: int
    te: tuple[float, ...] | None = None
    stiffness: tuple[float, ...] | None = None
    source: str = "table"


def mesh_table(position: np.ndarray, *, te: np.ndarray | None = None,
               stiffness: np.ndarray | None = None, abscissa: str = "mesh_position",
               teeth: int | None = None, base_pitch: float | None = None,
               source: str = "table") -> MeshTable:
    """Check samples and bring them to mesh periods over a whole span (X.1).

    Parameters
    ----------
    position : array_like
        Abscissa in the unit of ``abscissa`` (a key of :data:`ABSCISSAE`).
    te, stiffness : array_like, optional
        Values in SI (m, N/m).
    abscissa : str
        ``mesh_position``, ``roll_angle_deg|rad`` (needs ``teeth``: one mesh period is
        2π/z_1 of gear 1's rotation) or ``roll_distance_mm|um`` (needs ``base_pitch``,
        p_bt in m: one mesh period is one base pitch along the line of action).
    teeth : int, optional
        z_1.
    base_pitch : float, optional
        p_bt (m).
    source : str
        Name used in error messages.
    """
    if abscissa not in ABSCISSAE:
        raise InputError.of(f"{source}: abscissa", abscissa,
                            f"must be one of {', '.join(ABSCISSAE)}")
    kind, factor = ABSCISSAE[abscissa]
    x = np.asarray(position, dtype=float).ravel() * factor
    if kind == "angle":
        if (teeth is None or isinstance(teeth, bool) or not isinstance(teeth, numbers.Integral)
                or teeth < 1):
            raise InputError.of(f"{source}: teeth", teeth, f"must be z_1 (an integer >= 1) "
                                f"to read {abscissa}")
        x = x * teeth / (2.0 * math.pi)
    elif kind == "distance":
        if base_pitch is None or not (math.isfinite(base_pitch) and base_pitch > 0):
            raise InputError.of(f"{source}: base_pitch", base_pitch, "must be p_bt > 0 (m) "
                                f"to read {abscissa}")
        x = x / base_pitch
    if te is None and stiffness is None:
        raise InputError(f"{source}: no value column: give te and/or stiffness",
                         field=f"{source}: columns", allowed="te_*, stiffness_*")
    if x.size < 2 or not np.all(np.isfinite(x)):
        raise InputError.of(f"{source}: {abscissa}", x.size, "needs at least 2 finite "
                            "samples")
    step = np.diff(x)
    if not np.all(step > 0):
        bad = int(np.argmax(step <= 0)) + 2
        raise InputError(f"{source}: {abscissa} must increase strictly from sample to "
                         f"sample; sample {bad} does not", field=f"{source}: {abscissa}",
                         value=float(x[bad - 1]), allowed="increasing")
    columns = {"te": te, "stiffness": stiffness}
    arrays = {}
    for name, values in columns.items():
        if values is None:
            continue
        v = np.asarray(values, dtype=float).ravel()
        if v.size != x.size or not np.all(np.isfinite(v)):
            raise InputError.of(f"{source}: {name}", f"{v.size} values", f"must be "
                                f"{x.size} finite numbers, one per position")
        if name == "stiffness" and not np.all(v > 0):
            raise InputError.of(f"{source}: stiffness", float(v.min()), "must be > 0",
                                unit="N/m")
        arrays[name] = v
    span = x[-1] - x[0]
    periods = round(span)
    closed = periods >= 1 and abs(span - periods) <= 1e-6 * max(periods, 1)
    if closed:                       # end point included: it must repeat the first
        for name, v in arrays.items():
            ptp = float(np.ptp(v))
            if abs(v[-1] - v[0]) > PERIODIC_TOLERANCE * ptp + 1e-300:
                raise InputError(
                    f"{source}: {name} is not periodic over the mesh period: the samples "
                    f"at {x[0]:g} and {x[-1]:g} mesh periods differ by {abs(v[-1] - v[0]):.4g}"
                    f" (SI), more than {100 * PERIODIC_TOLERANCE:g} % of its peak-to-peak "
                    f"{ptp:.4g}", field=f"{source}: {name}", value=float(v[-1] - v[0]),
                    allowed="last sample = first sample")
        x, arrays = x[:-1], {k: v[:-1] for k, v in arrays.items()}
    else:                            # end point excluded: one more even step closes it
        periods = round(span + step.mean())
        uneven = np.ptp(step) > 1e-6 * step.mean()
        if periods < 1 or uneven or abs(span + step.mean() - periods) > 1e-6 * periods:
            raise InputError(
                f"{source}: the samples span {span:.6g} mesh periods"
                + (" unevenly" if uneven else "") + ": a table must cover a whole number "
                "of mesh periods (with its end point repeating the first sample, or evenly "
                "spaced without it); it is not periodic over the mesh period",
                field=f"{source}: {abscissa}", value=float(span),
                allowed="a whole number of mesh periods")
    x = x - x[0]
    return MeshTable(position=tuple(float(v) for v in x), periods=int(periods),
                     te=tuple(float(v) for v in arrays["te"]) if "te" in arrays else None,
                     stiffness=(tuple(float(v) for v in arrays["stiffness"])
                                if "stiffness" in arrays else None),
                     source=source)


def read_mesh_table(path: str | Path, *, teeth: int | None = None,
                    base_pitch: float | None = None) -> MeshTable:
    """Read a CSV mesh table (format: module docstring) and check it (:func:`mesh_table`).

    Parameters
    ----------
    path : str or Path
    teeth : int, optional
        z_1, needed for a roll-angle abscissa.
    base_pitch : float, optional
        p_bt (m), needed for a roll-distance abscissa.
    """
    path = Path(path)
    name = path.name
    try:
        lines = path.read_text().splitlines()
    except OSError as exc:
        raise InputError(f"{path}: cannot be read ({exc.strerror})", field=str(path)) from exc
    rows = [row for row in csv.reader(ln for ln in lines if ln.strip()
                                      and not ln.lstrip().startswith("#"))]
    if len(rows) < 2:
        raise InputError(f"{name}: needs a header row and samples", field=name)
    header = [h.strip() for h in rows[0]]
    abscissae = [h for h in header if h in ABSCISSAE]
    unknown = [h for h in header if h not in ABSCISSAE and h not in VALUES]
    if unknown:
        raise InputError.of(f"{name}: column", unknown[0], "must be one of "
                            f"{', '.join([*ABSCISSAE, *VALUES])}")
    if len(abscissae) != 1:
        raise InputError(f"{name}: {len(abscissae)} abscissa columns ({', '.join(abscissae)})"
                         f": must be exactly one of {', '.join(ABSCISSAE)}",
                         field=f"{name}: columns", value=abscissae,
                         allowed=", ".join(ABSCISSAE))
    quantities = [VALUES[h][0] for h in header if h in VALUES]
    if len(set(quantities)) != len(quantities):
        raise InputError(f"{name}: a quantity is given twice ({', '.join(header)})",
                         field=f"{name}: columns")
    try:
        data = np.array([[float(v) for v in row] for row in rows[1:]])
    except ValueError as exc:
        raise InputError(f"{name}: not a number in the samples ({exc})",
                         field=name) from exc
    if data.ndim != 2 or data.shape[1] != len(header):
        raise InputError(f"{name}: every row must have {len(header)} values", field=name)
    values = {VALUES[h][0]: data[:, j] * VALUES[h][1] for j, h in enumerate(header)
              if h in VALUES}
    return mesh_table(data[:, header.index(abscissae[0])], abscissa=abscissae[0],
                      teeth=teeth, base_pitch=base_pitch, source=name, **values)


def table_series(table: MeshTable, quantity: str, n_harmonics: int) -> Series:
    """Mean and the first n mesh harmonics of a table's ``quantity`` (``"te"`` or
    ``"stiffness"``), by least squares on its samples (X.2–X.3)::

        x(θ) ≈ x̄ + Σ_{k=1..n} a_k cos(kθ + φ_k),   θ = 2π × mesh position

    For evenly spaced samples over whole periods this is the DFT of (T.31). Refused with
    fewer distinct mesh positions per period than 2n + 1 (the harmonics asked are not
    determined by the samples).
    """
    if quantity not in ("te", "stiffness"):
        raise InputError.of("quantity", quantity, "must be 'te' or 'stiffness'")
    values = getattr(table, quantity)
    if values is None:
        raise InputError(f"{table.source}: has no {quantity} column", field=quantity)
    if (isinstance(n_harmonics, bool) or not isinstance(n_harmonics, numbers.Integral)
            or n_harmonics < 1):
        raise InputError.of("n_harmonics", n_harmonics, "must be an integer >= 1")
    x = np.asarray(table.position)
    distinct = np.unique(np.round((x % 1.0) * 1e9)).size
    if distinct < 2 * n_harmonics + 1:
        raise InputError.of("n_harmonics", n_harmonics,
                            f"needs at least {2 * n_harmonics + 1} samples per mesh period; "
                            f"{table.source} has {distinct} (at most "
                            f"{max((distinct - 1) // 2, 0)} harmonics)")
    k = np.arange(1, n_harmonics + 1)
    theta = 2.0 * math.pi * x[:, None] * k[None, :]
    basis = np.hstack([np.ones((x.size, 1)), np.cos(theta), np.sin(theta)])
    coef, *_ = np.linalg.lstsq(basis, np.asarray(values), rcond=None)
    a, b = coef[1:n_harmonics + 1], coef[n_harmonics + 1:]
    # a cos + b sin = A cos(θ + φ) with A = √(a² + b²), φ = atan2(−b, a)
    return (float(coef[0]), tuple(float(v) for v in np.hypot(a, b)),
            tuple(float(v) for v in np.arctan2(-b, a)))
