"""Where the bearing seats and mounts of an imported part are, without editing the CAD.

A bearing seat is given by its axis (a point on it at the bearing centre, a direction,
the seat radius and the bearing's axial width) or by the name of a face group in the
file; a mount (feet, bolt faces) by a group name, a box, or a plane. This module holds
those requests, the reports of what was found, and the geometry both search paths use:
a part's boundary as *candidates* (an OpenCASCADE face, or a smooth patch of mesh facets:
sample points, outward normals, area), a cylinder fit, and the ranking of the nearest
candidates named when nothing fits. The searches themselves are in
:mod:`geometry.cadfaces` (CAD faces) and :mod:`geometry.meshsurface` (mesh facets).

All lengths in metres. Never imports gmsh.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

import numpy as np

from core.errors import InputError

#: Seat surfaces: a bore (concave: the material lies outside the radius, the outward
#: normal points to the axis; housings) or a journal (convex; shafts).
SEAT_SURFACES = ("bore", "journal")
#: Default radial and axial tolerance of a seat: the larger of these [m] and fraction of
#: the radius.
SEAT_TOL_ABS = 2e-4
SEAT_TOL_REL = 0.02
#: Largest angle [deg] between a surface normal and the radial direction on a seat, and
#: between a mount face normal and the plane normal.
SEAT_NORMAL_DEG = 30.0
MOUNT_NORMAL_DEG = 5.0
#: Default distance tolerance of a mount plane or box [m].
MOUNT_TOL = 1e-4
#: Number of nearest candidates named when nothing fits.
N_CANDIDATES = 3

_NAME = re.compile(r"[A-Za-z0-9][\w-]*")


def _vec(value: object, fld: str, unit: bool = False) -> np.ndarray:
    try:
        v = np.asarray(value, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        v = np.zeros(0)
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise InputError.of(fld, value, "must be 3 finite numbers", unit="" if unit else "m")
    if unit:
        n = float(np.linalg.norm(v))
        if n == 0:
            raise InputError.of(fld, value, "must be a non-zero direction")
        v = v / n
    return v


def _positive(value: object, fld: str) -> float:
    if (isinstance(value, bool) or not isinstance(value, (int, float))
            or not math.isfinite(value) or value <= 0):
        raise InputError.of(fld, value, "must be > 0", unit="m")
    return float(value)


@dataclass(frozen=True)
class BearingSeat:
    """A bearing seat to find on a part: by its axis, or by a face-group name.

    Attributes
    ----------
    name : str
        Seat name; the surface group is ``{part}/bore_{name}`` (``{part}/journal_{name}``
        for a journal), which with ``name = "in_a"`` is the pump's ``housing/bore_in_a``.
    point : (3,) floats, optional
        Bearing centre on the axis [m]; the seat node is placed here.
    direction : (3,) floats, optional
        Axis direction (normalised here).
    radius : float, optional
        Seat radius [m] (bore: the bearing's outer radius).
    width : float, optional
        Axial width [m] of the bearing, centred at ``point``: faces lying mostly inside
        this window are the seat (whole CAD faces; mesh facets inside it).
    group : str, optional
        Name of a face group in the file instead of (or besides) the axis: a physical
        surface of a ``.msh``, a node set of an Abaqus ``.inp``, a face name of a STEP
        file. Without ``point`` the axis and centre are fitted.
    part : str
        The part the seat belongs to.
    surface : str
        ``"bore"`` or ``"journal"`` (:data:`SEAT_SURFACES`).
    tolerance : float, optional
        Radial and axial tolerance [m]; default ``max(SEAT_TOL_ABS, SEAT_TOL_REL * r)``.
    """

    name: str
    point: tuple[float, float, float] | None = None
    direction: tuple[float, float, float] | None = None
    radius: float | None = None
    width: float | None = None
    group: str | None = None
    part: str = "housing"
    surface: str = "bore"
    tolerance: float | None = None

    @property
    def group_name(self) -> str:
        """The physical surface group made for the seat."""
        return f"{self.part}/{'bore' if self.surface == 'bore' else 'journal'}_{self.name}"

    @property
    def by_axis(self) -> bool:
        """True when the seat is searched by its axis (not by a group name)."""
        return self.group is None

    def tol(self) -> float:
        """Radial and axial tolerance [m]."""
        if self.tolerance is not None:
            return float(self.tolerance)
        return max(SEAT_TOL_ABS, SEAT_TOL_REL * float(self.radius or 0.0))

    def validate(self, where: str) -> None:
        """Raise :class:`InputError` naming ``{where}.<field>``."""
        if not isinstance(self.name, str) or not _NAME.fullmatch(self.name):
            raise InputError.of(f"{where}.name", self.name,
                                "must be a name of letters, digits, '_' or '-'")
        if self.surface not in SEAT_SURFACES:
            raise InputError.of(f"{where}.surface", self.surface,
                                f"must be one of {', '.join(map(repr, SEAT_SURFACES))}")
        axis = {"point": self.point, "direction": self.direction, "radius": self.radius,
                "width": self.width}
        if self.group is None:
            missing = [k for k, v in axis.items() if v is None]
            if missing:
                raise InputError(f"{where}: {', '.join(missing)} missing; a seat is given "
                                 "by point, direction, radius and width, or by group",
                                 field=f"{where}.{missing[0]}")
        elif not isinstance(self.group, str) or not self.group:
            raise InputError.of(f"{where}.group", self.group, "must be a non-empty name")
        if self.point is not None:
            _vec(self.point, f"{where}.point")
        if self.direction is not None:
            _vec(self.direction, f"{where}.direction", unit=True)
        if self.radius is not None:
            _positive(self.radius, f"{where}.radius")
        if self.width is not None:
            _positive(self.width, f"{where}.width")
        if self.tolerance is not None:
            _positive(self.tolerance, f"{where}.tolerance")

    def axis(self) -> tuple[np.ndarray, np.ndarray]:
        """(point, unit direction) of the given axis."""
        return (np.asarray(self.point, dtype=float),
                _vec(self.direction, "direction", unit=True))


@dataclass(frozen=True)
class Mount:
    """A mount region (feet, bolt faces) to find on a part.

    Give ``group`` (a face group in the file), or ``plane`` and/or ``box``: the faces
    lying in the plane (normals parallel to it) and inside the box.

    Attributes
    ----------
    name : str
        Mount name; its surface group is ``{part}/{name}`` (``"feet"`` gives the pump's
        ``housing/feet``), or with ``per_patch`` one group ``{part}/{name}_{k}`` per
        connected patch (k = 1, 2, ... in the order of the patch centres' x, y, z), the
        form springs to ground need (one spring node per foot).
    group : str, optional
    plane : ((3,), (3,)) floats, optional
        A point on the plane [m] and its normal.
    box : ((3,), (3,)) floats, optional
        Lower and upper corners [m].
    part : str
    tolerance : float
        Distance tolerance to the plane and the box [m].
    per_patch : bool
    """

    name: str
    group: str | None = None
    plane: tuple[tuple[float, float, float], tuple[float, float, float]] | None = None
    box: tuple[tuple[float, float, float], tuple[float, float, float]] | None = None
    part: str = "housing"
    tolerance: float = MOUNT_TOL
    per_patch: bool = False

    @property
    def group_name(self) -> str:
        """The physical surface group of the whole mount (without ``per_patch``)."""
        return f"{self.part}/{self.name}"

    def validate(self, where: str) -> None:
        """Raise :class:`InputError` naming ``{where}.<field>``."""
        if not isinstance(self.name, str) or not _NAME.fullmatch(self.name):
            raise InputError.of(f"{where}.name", self.name,
                                "must be a name of letters, digits, '_' or '-'")
        given = [k for k in ("group", "plane", "box") if getattr(self, k) is not None]
        if not given or ("group" in given and len(given) > 1):
            raise InputError(f"{where}: give group, or plane and/or box (given: "
                             f"{', '.join(given) or 'none'})", field=f"{where}.group")
        if self.plane is not None:
            try:
                p, n = self.plane
            except (TypeError, ValueError):
                raise InputError.of(f"{where}.plane", self.plane,
                                    "must be (point, normal)") from None
            _vec(p, f"{where}.plane[0]")
            _vec(n, f"{where}.plane[1]", unit=True)
        if self.box is not None:
            try:
                lo, hi = (_vec(c, f"{where}.box") for c in self.box)
            except (TypeError, ValueError):
                raise InputError.of(f"{where}.box", self.box,
                                    "must be (lower corner, upper corner)") from None
            if np.any(lo >= hi):
                raise InputError.of(f"{where}.box", self.box,
                                    "lower corner must be below the upper one in x, y, z")
        _positive(self.tolerance, f"{where}.tolerance")


@dataclass
class Candidate:
    """A piece of a part's boundary the searches test: an OCC face or a mesh patch.

    Attributes
    ----------
    label : str
        ``"face 17 (Cylinder)"``, ``"patch 4 (212 facets)"``.
    points : numpy.ndarray, shape (k, 3)
        Points on the surface [m] (for faces: on its boundary curves and a parameter grid).
    normals : numpy.ndarray, shape (m, 3)
        Outward unit normals at ``normal_points``.
    normal_points : numpy.ndarray, shape (m, 3)
    area : float
        [m^2]
    rim : numpy.ndarray, shape (j, 3)
        Points of the trimmed surface only (boundary curves / facet corners): its extent.
    """

    label: str
    points: np.ndarray
    normals: np.ndarray
    normal_points: np.ndarray
    area: float
    rim: np.ndarray


@dataclass
class SeatReport:
    """What was found for one :class:`BearingSeat`.

    Attributes
    ----------
    name, group : str
        Seat name and the surface group made.
    found : list[str]
        Labels of the faces (or ``"<n> facets"``) making the seat.
    area : float
        [m^2]
    radius_given, radius_measured : float
        [m]; measured = cylinder fitted to the found surface (``nan`` if not given).
    axis_offset : float
        Distance [m] of the given point from the fitted axis (0 when the axis is fitted).
    tilt_deg : float
        Angle between the given and the fitted axis [deg].
    axial_range : (float, float)
        Extent of the found surface along the axis, from the centre [m].
    centre : numpy.ndarray, shape (3,)
        Where the seat node goes [m]: the given point, or the fitted axis at the middle of
        the surface.
    axis : numpy.ndarray, shape (3,)
        Unit axis (given, or fitted).
    """

    name: str
    group: str
    found: list[str]
    area: float
    radius_given: float
    radius_measured: float
    axis_offset: float
    tilt_deg: float
    axial_range: tuple[float, float]
    centre: np.ndarray
    axis: np.ndarray

    def summary(self) -> str:
        """One line: what, where, how well it fits."""
        lo, hi = self.axial_range
        given = ("" if math.isnan(self.radius_given)
                 else f" (given {self.radius_given * 1e3:.3f} mm)")
        return (f"seat '{self.name}' -> {self.group}: {', '.join(self.found)}; area "
                f"{self.area * 1e6:.1f} mm^2, radius {self.radius_measured * 1e3:.3f} mm"
                f"{given}, axis offset {self.axis_offset * 1e3:.3f} mm, tilt "
                f"{self.tilt_deg:.3f} deg, axial extent [{lo * 1e3:.2f}, {hi * 1e3:.2f}] mm")


@dataclass
class MountReport:
    """What was found for one :class:`Mount`.

    Attributes
    ----------
    name : str
    groups : list[str]
        The surface group(s) made: one, or one per patch (``per_patch``).
    found : list[str]
    area : float
        [m^2]
    centres : list[numpy.ndarray]
        Area centroid of each group [m].
    areas : list[float]
        Area of each group [m^2].
    """

    name: str
    groups: list[str]
    found: list[str]
    area: float
    centres: list[np.ndarray] = field(default_factory=list)
    areas: list[float] = field(default_factory=list)

    def summary(self) -> str:
        """One line."""
        return (f"mount '{self.name}' -> {', '.join(self.groups)}: {len(self.found)} "
                f"face(s) ({', '.join(self.found[:6])}{', ...' if len(self.found) > 6 else ''})"
                f", area {self.area * 1e6:.1f} mm^2")


def axis_coordinates(x: np.ndarray, point: np.ndarray, direction: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Axial coordinate and distance from the axis of points ``x`` (k, 3) [m]."""
    d = np.asarray(x, dtype=float) - point
    s = d @ direction
    r = np.linalg.norm(d - np.outer(s, direction), axis=1)
    return s, r


def radial_directions(x: np.ndarray, point: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """Unit vectors from the axis to points ``x`` (zero on the axis)."""
    d = np.asarray(x, dtype=float) - point
    d = d - np.outer(d @ direction, direction)
    n = np.linalg.norm(d, axis=1, keepdims=True)
    return np.divide(d, n, out=np.zeros_like(d), where=n > 0)


def fit_circle(xy: np.ndarray) -> tuple[np.ndarray, float]:
    """Least-squares circle through 2-D points: algebraic fit (Kasa), then Gauss-Newton
    on the geometric distances. Returns (centre (2,), radius)."""
    x, y = xy[:, 0], xy[:, 1]
    A = np.column_stack([x, y, np.ones_like(x)])
    sol, *_ = np.linalg.lstsq(A, x * x + y * y, rcond=None)
    c = 0.5 * sol[:2]
    r = math.sqrt(max(sol[2] + c @ c, 0.0))
    for _ in range(10):
        d = xy - c
        rho = np.linalg.norm(d, axis=1)
        if np.any(rho == 0):
            break
        J = np.column_stack([-d / rho[:, None], -np.ones_like(rho)])
        step, *_ = np.linalg.lstsq(J, -(rho - r), rcond=None)
        c, r = c + step[:2], r + step[2]
        if np.abs(step).max() < 1e-14 * max(r, 1e-30):
            break
    return c, float(r)


def perpendicular_frame(direction: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors completing ``direction`` to a right-handed frame."""
    a = np.eye(3)[int(np.argmin(np.abs(direction)))]
    e1 = np.cross(direction, a)
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(direction, e1)


def fit_cylinder(points: np.ndarray, normals: np.ndarray | None = None,
                 direction: np.ndarray | None = None
                 ) -> tuple[np.ndarray, np.ndarray, float, float]:
    """Cylinder through surface points: axis, radius and RMS radial deviation.

    The axis direction is ``direction`` when given, else the direction the normals are
    most perpendicular to (least eigenvector of sum n n^T: a cylinder's normals are all
    normal to its axis); the axis position and radius are a circle fit of the points
    projected on the plane normal to it (:func:`fit_circle`).

    Returns
    -------
    (point (3,), direction (3,), radius, rms)
        ``point`` is the axis point nearest the points' centroid.
    """
    pts = np.asarray(points, dtype=float)
    centroid = pts.mean(axis=0)

    def circle(a: np.ndarray) -> tuple[np.ndarray, float, np.ndarray]:
        e1, e2 = perpendicular_frame(a)
        d = pts - centroid
        c2, r = fit_circle(np.column_stack([d @ e1, d @ e2]))
        point = centroid + c2[0] * e1 + c2[1] * e2
        _, rho = axis_coordinates(pts, point, a)
        return point, r, rho - r

    if direction is None:
        if normals is None or len(normals) < 2:
            raise ValueError("fit_cylinder: needs normals or a direction")
        w, v = np.linalg.eigh(np.asarray(normals).T @ np.asarray(normals))
        if w[1] < 1e-3 * w[2]:
            raise ValueError("fit_cylinder: the normals span less than ~4 deg of arc; "
                             "they do not fix an axis")
        direction = _refine_axis(v[:, 0], circle)
    direction = np.asarray(direction, dtype=float) / np.linalg.norm(direction)
    point, r, res = circle(direction)
    return point, direction, r, float(np.sqrt(np.mean(res ** 2)))


def _refine_axis(a0: np.ndarray, circle) -> np.ndarray:
    """The axis direction near ``a0`` that minimises the circle-fit residuals (the normals
    of flat facets tilt off a cylinder's axis: their estimate is only a start)."""
    from scipy.optimize import least_squares

    e1, e2 = perpendicular_frame(a0)

    def axis(t: np.ndarray) -> np.ndarray:
        a = a0 + t[0] * e1 + t[1] * e2
        return a / np.linalg.norm(a)

    sol = least_squares(lambda t: circle(axis(t))[2], np.zeros(2), x_scale=1e-3,
                        xtol=1e-15, ftol=1e-15, gtol=1e-15)
    return axis(sol.x)


def _seat_geometry(c: Candidate, seat: BearingSeat) -> dict:
    """What the seat tests measure on a candidate (see :func:`seat_match`)."""
    p, a = seat.axis()
    tol, r, w = seat.tol(), float(seat.radius), float(seat.width)
    _, rho = axis_coordinates(c.points, p, a)
    s_rim, _ = axis_coordinates(c.rim, p, a)
    lo, hi = float(s_rim.min()), float(s_rim.max())
    overlap = min(hi, 0.5 * w) - max(lo, -0.5 * w)
    radial = radial_directions(c.normal_points, p, a)
    cos = np.einsum("ij,ij->i", c.normals, radial)
    sign = -1.0 if seat.surface == "bore" else 1.0
    facing = bool(len(cos)) and float((sign * cos).min()) >= math.cos(
        math.radians(SEAT_NORMAL_DEG))
    return {"p": p, "a": a, "tol": tol, "r": r, "w": w, "rho": rho, "lo": lo, "hi": hi,
            "overlap": overlap, "cos": cos, "facing": facing,
            "dev": float(np.abs(rho - r).max())}


def seat_match(c: Candidate, seat: BearingSeat) -> bool:
    """Whether candidate ``c`` is (part of) ``seat``.

    A match lies on the seat's cylinder within the tolerance (every point), faces the
    axis for a bore (outward normals within :data:`SEAT_NORMAL_DEG` of the inward radial
    direction; outwards for a journal) and lies mostly in the axial window: its overlap
    with ``[-width/2, width/2]`` is at least half of its own extent or of the width.
    """
    g = _seat_geometry(c, seat)
    return (g["dev"] <= g["tol"] and g["facing"]
            and g["overlap"] >= 0.5 * min(g["hi"] - g["lo"], g["w"]) - g["tol"])


def seat_miss(c: Candidate, seat: BearingSeat) -> tuple[float, str]:
    """How far a candidate that is not the seat is from it: a score (lower is nearer)
    and a description (its own cylinder, when it is one: radius, axis offset and tilt)."""
    g = _seat_geometry(c, seat)
    p, a, r, tol, lo, hi = g["p"], g["a"], g["r"], g["tol"], g["lo"], g["hi"]
    gap = max(0.0, 0.5 * min(hi - lo, g["w"]) - g["overlap"])
    side = ("facing the axis" if float(np.median(g["cos"])) < 0
            else "facing away from the axis")
    penalty = 0.0 if g["facing"] else 1.0
    try:  # a cylinder of its own? then say where its axis is
        fp, fa, fr, rms = fit_cylinder(c.points, c.normals)
    except ValueError:
        rms = math.inf
    if rms <= tol and fr < 1e3 * r:
        _, off = axis_coordinates(p[None, :], fp, fa)
        tilt = math.acos(min(1.0, abs(float(fa @ a))))
        return ((abs(fr - r) + float(off[0]) + gap) / r + tilt + penalty,
                f"cylinder of radius {fr * 1e3:.3f} mm, its axis {off[0] * 1e3:.3f} mm from "
                f"the point and {math.degrees(tilt):.2f} deg off, axial [{lo * 1e3:.2f}, "
                f"{hi * 1e3:.2f}] mm from the point, {side}")
    rho = g["rho"]
    return ((g["dev"] + gap) / r + penalty + 1.0,
            f"not a cylinder; {rho.min() * 1e3:.3f}-{rho.max() * 1e3:.3f} mm from the "
            f"axis, axial [{lo * 1e3:.2f}, {hi * 1e3:.2f}] mm from the point, {side}")


def nearest_text(scored: list[tuple[float, str, str]], n: int = N_CANDIDATES) -> str:
    """``"; nearest: <label> (<shape>), ..."`` of the ``n`` lowest scores."""
    if not scored:
        return "; the part has no face near it"
    best = sorted(scored, key=lambda t: t[0])[:n]
    return "; nearest candidates: " + "; ".join(f"{lab}: {shape}" for _, lab, shape in best)


def seat_report(seat: BearingSeat, found: list[str], area: float, points: np.ndarray,
                normals: np.ndarray, rim: np.ndarray) -> SeatReport:
    """Fit the found surface and report it (given axis, or fitted when by group).

    Parameters
    ----------
    points : numpy.ndarray, shape (k, 3)
        Points on the found surface [m].
    normals : numpy.ndarray, shape (m, 3)
        Unit normals on it (they fix the axis direction of a free fit).
    rim : numpy.ndarray
        Points bounding the found surface (its axial extent).
    """
    if seat.point is not None and seat.direction is not None:
        p, a = seat.axis()
        fp, fa, r, _ = fit_cylinder(points, direction=a)
        try:
            free = fit_cylinder(points, normals)
            tilt = math.degrees(math.acos(min(1.0, abs(float(free[1] @ a)))))
        except ValueError:  # too short an arc to fit its own axis
            tilt = float("nan")
        _, off = axis_coordinates(p[None, :], fp, a)
        centre, axis, offset = p, a, float(off[0])
    else:
        fp, fa, r, _ = fit_cylinder(points, normals,
                                    None if seat.direction is None else seat.axis()[1])
        s, _ = axis_coordinates(rim, fp, fa)
        centre = fp + 0.5 * (s.min() + s.max()) * fa
        axis, tilt, offset = fa, 0.0, 0.0
        if seat.point is not None:
            _, off = axis_coordinates(np.asarray(seat.point, float)[None, :], fp, fa)
            offset = float(off[0])
            centre = np.asarray(seat.point, dtype=float)
    s, _ = axis_coordinates(rim, centre, axis)
    return SeatReport(
        name=seat.name, group=seat.group_name, found=found, area=float(area),
        radius_given=float("nan") if seat.radius is None else float(seat.radius),
        radius_measured=float(r), axis_offset=offset, tilt_deg=float(tilt),
        axial_range=(float(s.min()), float(s.max())), centre=np.asarray(centre, float),
        axis=np.asarray(axis, float))


def check_seat_fit(report: SeatReport, seat: BearingSeat, where: str) -> None:
    """Refuse a seat found by group whose measured radius or axis differs from the given
    one by more than the tolerance."""
    tol = seat.tol()
    if seat.radius is not None and abs(report.radius_measured - seat.radius) > tol:
        raise InputError.of(f"{where}.radius", seat.radius,
                            f"group {seat.group!r} is a cylinder of radius "
                            f"{report.radius_measured:.6g} m, more than the tolerance "
                            f"{tol:.3g} m away", unit="m")
    if seat.point is not None and report.axis_offset > tol:
        raise InputError.of(f"{where}.point", seat.point,
                            f"lies {report.axis_offset:.4g} m from the axis of group "
                            f"{seat.group!r} (tolerance {tol:.3g} m)", unit="m")


def seat_misses(seat: BearingSeat, lo: np.ndarray, hi: np.ndarray, where: str) -> None:
    """Refuse a seat whose cylinder (axis segment of the width, at the radius) lies
    outside the part's bounding box ``lo``..``hi`` [m]."""
    p, a = seat.axis()
    r, w, tol = float(seat.radius), float(seat.width), seat.tol()
    ends = np.array([p - 0.5 * w * a, p + 0.5 * w * a])
    # half extent of a disc of radius r normal to a, per coordinate
    ext = r * np.sqrt(np.clip(1.0 - a * a, 0.0, 1.0))
    s_lo = ends.min(axis=0) - ext - tol
    s_hi = ends.max(axis=0) + ext + tol
    if np.any(s_hi < lo) or np.any(s_lo > hi):
        box = (f"[{', '.join(f'{v:.4g}' for v in lo)}] .. "
               f"[{', '.join(f'{v:.4g}' for v in hi)}] m")
        raise InputError.of(f"{where}.point", tuple(float(v) for v in p),
                            f"the seat (radius {r:.4g} m, width {w:.4g} m along "
                            f"{tuple(round(float(v), 6) for v in a)}) misses part "
                            f"'{seat.part}', whose bounding box is {box}", unit="m")


def plane_match(c: Candidate, mount: Mount) -> tuple[bool, float, str]:
    """Whether candidate ``c`` lies in ``mount.plane`` (and ``mount.box``); a score."""
    tol = mount.tolerance
    ok, score, parts = True, 0.0, []
    if mount.plane is not None:
        p = np.asarray(mount.plane[0], dtype=float)
        n = _vec(mount.plane[1], "plane[1]", unit=True)
        dist = (c.points - p) @ n
        cos = np.abs(c.normals @ n) if len(c.normals) else np.zeros(1)
        flat = float(cos.min()) >= math.cos(math.radians(MOUNT_NORMAL_DEG))
        dev = float(np.abs(dist).max())
        ok = dev <= tol and flat
        score += float(np.abs(dist).mean()) + (0.0 if flat else 1.0)
        parts.append(f"{dist.mean() * 1e3:.3f} mm from the plane (spread "
                     f"{np.ptp(dist) * 1e3:.3f} mm), normal "
                     f"{math.degrees(math.acos(min(1.0, float(cos.mean())))):.1f} deg off")
    if mount.box is not None:
        lo, hi = (np.asarray(v, dtype=float) for v in mount.box)
        out = np.maximum(lo - tol - c.rim, 0.0) + np.maximum(c.rim - hi - tol, 0.0)
        inside = float(out.max()) == 0.0
        ok = ok and inside
        score += float(out.max())
        centre = c.rim.mean(axis=0)
        parts.append(f"extent [{', '.join(f'{v:.4g}' for v in c.rim.min(axis=0))}] .. "
                     f"[{', '.join(f'{v:.4g}' for v in c.rim.max(axis=0))}] m"
                     + ("" if inside else f" (centre {np.round(centre, 4).tolist()})"))
    return ok, (0.0 if ok else score), "; ".join(parts)
