"""OpenCASCADE solid of a box housing with its tagged surfaces: the pump's, and any box
whose end walls carry one bored boss per shaft (the gearbox's, :mod:`geometry.gearbox`).
"""

from __future__ import annotations

import logging

import gmsh
import numpy as np

from .model import PartEntities
from .params import DEFAULT_CENTRE_DISTANCE, Bore, BoxHousing, HousingParams

log = logging.getLogger(__name__)

_TOL = 1e-6  # m, matching tolerance on OCC bounding boxes


def bore_axes(centre_distance: float) -> dict[str, float]:
    """``x`` of the bore axis of each shaft of the pump (``y = 0``) [m]."""
    return {"in": 0.0, "out": float(centre_distance)}


def pump_box(params: HousingParams,
             centre_distance: float = DEFAULT_CENTRE_DISTANCE) -> BoxHousing:
    """The pump housing as a :class:`BoxHousing` (see :func:`build_housing`)."""
    p = params
    return BoxHousing(
        x_range=p.x_range(centre_distance), y0=-0.5 * p.height_y, height_y=p.height_y,
        z0=0.0, length_z=p.length_z, wall=p.wall_thickness, boss_length=p.boss_length,
        bores=tuple(Bore(s, xc, 0.0, p.bore_radius, p.boss_radius)
                    for s, xc in bore_axes(centre_distance).items()),
        foot_width=p.foot_width, foot_depth=p.foot_depth, foot_height=p.foot_height,
        foot_overhang=p.foot_overhang, rib_z=p.rib_centres(), rib_thickness=p.rib_thickness,
        rib_height=p.rib_height)


def build_housing(params: HousingParams,
                  centre_distance: float = DEFAULT_CENTRE_DISTANCE) -> PartEntities:
    """Add the pump housing solid to the current gmsh OCC model and find its surfaces.

    Box ``x ∈ a/2 ± length_x/2``, ``y ∈ ±height_y/2``, ``z ∈ [0, length_z]``,
    hollowed to ``wall_thickness``; one boss with a through bore per shaft on
    each end wall (bore axes at ``x = 0`` and ``x = a``, ``y = 0``); four corner
    feet under the bottom face; ``rib_count`` plates on the top face.

    Parameters
    ----------
    params : HousingParams
        Housing dimensions [m]; validated here.
    centre_distance : float
        Centre distance ``a`` between the two bore axes [m].

    Returns
    -------
    PartEntities
        Volume tag, surfaces ``housing/bore_{s}_{a|b}`` and ``housing/feet``,
        and the bore centres. The OCC model is synchronised on return.
    """
    params.validate(centre_distance)
    return build_box_housing(pump_box(params, centre_distance))


def build_box_housing(box: BoxHousing) -> PartEntities:
    """Add a :class:`BoxHousing` solid to the current gmsh OCC model and find its
    surfaces: ``housing/bore_{shaft}_{a|b}`` with the bore centres, ``housing/feet``
    (the four bolted faces under the feet). The OCC model is synchronised on return.

    Raises
    ------
    RuntimeError
        The boolean operations gave more than one solid, or a bore or a foot face was
        not found.
    """
    occ = gmsh.model.occ
    t = box.wall
    x0, x1 = box.x_range
    lx, hy, lz = x1 - x0, box.height_y, box.length_z
    y0, z0, bl = box.y0, box.z0, box.boss_length
    zt = z0 + lz

    solid_box = occ.addBox(x0, y0, z0, lx, hy, lz)
    adds: list[tuple[int, int]] = []
    for b in box.bores:
        adds.append((3, occ.addCylinder(b.x, b.y, z0 - bl, 0, 0, bl, b.boss_radius)))
        adds.append((3, occ.addCylinder(b.x, b.y, zt, 0, 0, bl, b.boss_radius)))
    yf = y0 - box.foot_height
    fx = (x0 - box.foot_overhang, x1 + box.foot_overhang - box.foot_width)
    fz = (z0, zt - box.foot_depth)
    for xa in fx:
        for za in fz:
            adds.append((3, occ.addBox(xa, yf, za, box.foot_width, box.foot_height,
                                       box.foot_depth)))
    for zc in box.rib_z:
        adds.append((3, occ.addBox(x0, y0 + hy, zc - 0.5 * box.rib_thickness, lx,
                                   box.rib_height, box.rib_thickness)))
    solid, _ = occ.fuse([(3, solid_box)], adds)
    cuts = [(3, occ.addBox(x0 + t, y0 + t, z0 + t, lx - 2 * t, hy - 2 * t, lz - 2 * t))]
    eps = 0.5 * t
    za0, za1 = box.bore_a_z
    zb0, zb1 = box.bore_b_z
    for b in box.bores:
        cuts.append((3, occ.addCylinder(b.x, b.y, za0 - eps, 0, 0, za1 - za0 + 2 * eps,
                                        b.radius)))
        cuts.append((3, occ.addCylinder(b.x, b.y, zb0 - eps, 0, 0, zb1 - zb0 + 2 * eps,
                                        b.radius)))
    result, _ = occ.cut(solid, cuts)
    vols = [tag for d, tag in result if d == 3]
    if len(vols) != 1:
        raise RuntimeError(f"housing: boolean operations gave {len(vols)} volumes, expected "
                           "one connected solid")
    vol = vols[0]
    occ.synchronize()

    faces = [tag for d, tag in gmsh.model.getBoundary([(3, vol)], oriented=False) if d == 2]
    bboxes = {tag: gmsh.model.getBoundingBox(2, tag) for tag in faces}
    part = PartEntities(volume=vol)
    for b in box.bores:
        xc, yc, rb = b.x, b.y, b.radius
        for end, (za, zb) in (("a", box.bore_a_z), ("b", box.bore_b_z)):
            hit = [tag for tag, bb in bboxes.items()
                   if abs(bb[0] - (xc - rb)) < _TOL and abs(bb[3] - (xc + rb)) < _TOL
                   and abs(bb[1] - (yc - rb)) < _TOL and abs(bb[4] - (yc + rb)) < _TOL
                   and abs(bb[2] - za) < _TOL and abs(bb[5] - zb) < _TOL]
            if not hit:
                raise RuntimeError(f"housing: no surface found for bore {b.shaft}_{end}")
            key = f"housing/bore_{b.shaft}_{end}"
            part.surfaces[key] = hit
            part.centres[key] = np.array([xc, yc, 0.5 * (za + zb)])
    feet = [tag for tag, bb in bboxes.items()
            if abs(bb[1] - yf) < _TOL and abs(bb[4] - yf) < _TOL]
    if len(feet) != 4:
        raise RuntimeError(f"housing: found {len(feet)} foot faces, expected 4")
    part.surfaces["housing/feet"] = sorted(feet)
    log.debug("housing: volume %d, %d faces", vol, len(faces))
    return part
