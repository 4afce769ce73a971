"""Write the housing of a two-stage spur gearbox (three parallel shafts) as a STEP file.

The CAD a user would bring, made here with gmsh's OpenCASCADE kernel: a closed cast box
with a boss and a bearing bore per shaft on each end wall, vertical ribs under the bosses,
two ribs on the top, a split-line flange with bolt holes around the box at the shaft
plane, and four feet with bolt holes. Written in millimetres (``geometry.cad.write_step``).

The gear train is the two-stage reducer of issue 36: stage 1 23:61, stage 2 19:67, both
at module 2 mm, spur, standard centre distances ``a = m (z1 + z2) / 2``:

    stage 1: a1 = 2 (23 + 61) / 2 = 84 mm     input shaft  ``in``  at x = 0
    stage 2: a2 = 2 (19 + 67) / 2 = 86 mm     intermediate ``mid`` at x = 84 mm
    overall ratio 61/23 * 67/19 = 9.35        output shaft ``out`` at x = 170 mm

All shaft axes are parallel to z in the plane y = 0 (the frame of docs/architecture.md).
Bearings: 6205 (outer diameter 52 mm, width 15) on ``in``, 6206 (62, 16) on ``mid``,
6208 (80, 18) on ``out``; seat ``{shaft}_a`` in the end wall at z < 0, ``{shaft}_b`` in
the one at z > the cavity length. The seats, the feet's plane and what a scene states
about them are printed with ``--describe`` and come from :func:`seats` and
:func:`feet_mount`.

Usage::

    python scripts/gearbox_housing_step.py out/gearbox_housing.step [--describe]
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import asdict, dataclass
from pathlib import Path

import gmsh

from geometry.cad import write_step
from geometry.locate import BearingSeat, Mount
from geometry.session import gmsh_session

SHAFTS = ("in", "mid", "out")


@dataclass(frozen=True)
class GearboxHousing:
    """Dimensions of the housing [m] and its gear train (see the module docstring)."""

    module: float = 0.002
    teeth: tuple[tuple[int, int], tuple[int, int]] = ((23, 61), (19, 67))
    stage_z: tuple[float, float] = (0.035, 0.082)  # gear mid-planes (stage 1, stage 2)
    face_widths: tuple[float, float] = (0.020, 0.025)
    cavity_length: float = 0.120  # inside, along z
    gear_clearance: float = 0.012  # cavity wall to the gear tips, radially
    wall: float = 0.008
    bore_radii: tuple[float, float, float] = (0.026, 0.031, 0.040)
    bearing_widths: tuple[float, float, float] = (0.015, 0.016, 0.018)
    boss_thickness: float = 0.012  # radial, around the bore
    boss_length: float = 0.012  # outwards from the end wall
    rib_thickness: float = 0.008
    top_rib_height: float = 0.010
    flange_thickness: float = 0.014
    flange_width: float = 0.020  # beyond the side walls (x); beyond the end walls: boss
    flange_bolt_radius: float = 0.0045
    flange_bolts_per_side: int = 3
    foot_size: tuple[float, float, float] = (0.060, 0.016, 0.040)  # x, y (height), z
    foot_overhang: float = 0.025
    foot_bolt_radius: float = 0.0055

    @property
    def centre_distances(self) -> tuple[float, float]:
        """Stage centre distances [m]: m (z1 + z2) / 2."""
        return tuple(self.module * (z1 + z2) / 2 for z1, z2 in self.teeth)

    @property
    def shaft_x(self) -> tuple[float, float, float]:
        """x of the shaft axes [m] (y = 0)."""
        a1, a2 = self.centre_distances
        return (0.0, a1, a1 + a2)

    def tip_radius(self, z: int) -> float:
        """Tip radius of a standard gear of z teeth [m]: m (z + 2) / 2."""
        return self.module * (z + 2) / 2

    def cavity(self) -> tuple[tuple[float, float], tuple[float, float], tuple[float, float]]:
        """Inner box (x, y, z ranges) [m]: the gear tips plus the clearance."""
        x = self.shaft_x
        (z1, z2), (z3, z4) = self.teeth
        gears = [(x[0], z1), (x[1], z2), (x[1], z3), (x[2], z4)]
        lo = min(xc - self.tip_radius(z) for xc, z in gears) - self.gear_clearance
        hi = max(xc + self.tip_radius(z) for xc, z in gears) + self.gear_clearance
        h = max(self.tip_radius(z) for _, z in gears) + self.gear_clearance
        return (lo, hi), (-h, h), (0.0, self.cavity_length)

    def seat_z(self) -> tuple[float, float]:
        """z of the bearing centres in end walls a and b [m] (middle of the bores)."""
        bore = self.wall + self.boss_length
        return (-0.5 * bore, self.cavity_length + 0.5 * bore)


def build(p: GearboxHousing) -> int:
    """Add the housing solid to the current gmsh model (OCC, metres); its volume tag."""
    occ = gmsh.model.occ
    (cx0, cx1), (cy0, cy1), (cz0, cz1) = p.cavity()
    t, bl = p.wall, p.boss_length
    x0, x1, y0, y1, z0, z1 = cx0 - t, cx1 + t, cy0 - t, cy1 + t, cz0 - t, cz1 + t
    adds = []
    for xs, rb in zip(p.shaft_x, p.bore_radii, strict=True):
        rboss = rb + p.boss_thickness
        adds.append(occ.addCylinder(xs, 0, z0 - bl, 0, 0, bl, rboss))
        adds.append(occ.addCylinder(xs, 0, z1, 0, 0, bl, rboss))
        top = -rboss + 0.004  # ribs under the bosses, into them
        for za in (z0 - bl, z1):
            adds.append(occ.addBox(xs - p.rib_thickness / 2, y0, za, p.rib_thickness,
                                   top - y0, bl))
    for k in (1, 2):  # two ribs across the top
        zc = z0 + k * (z1 - z0) / 3
        adds.append(occ.addBox(x0, y1, zc - p.rib_thickness / 2, x1 - x0, p.top_rib_height,
                               p.rib_thickness))
    fw, ft = p.flange_width, p.flange_thickness
    adds.append(occ.addBox(x0 - fw, -ft / 2, z0 - bl, x1 - x0 + 2 * fw, ft, z1 - z0 + 2 * bl))
    fx, fy, fz = p.foot_size
    feet_x = (x0 - p.foot_overhang, x1 + p.foot_overhang - fx)
    for xa in feet_x:
        for za in (z0, z1 - fz):
            adds.append(occ.addBox(xa, y0 - fy, za, fx, fy, fz))
    box = occ.addBox(x0, y0, z0, x1 - x0, y1 - y0, z1 - z0)
    solid, _ = occ.fuse([(3, box)], [(3, a) for a in adds])
    cuts = [occ.addBox(cx0, cy0, cz0, cx1 - cx0, cy1 - cy0, cz1 - cz0)]
    eps = 0.002
    for xs, rb in zip(p.shaft_x, p.bore_radii, strict=True):
        cuts.append(occ.addCylinder(xs, 0, z0 - bl - eps, 0, 0, bl + t + 2 * eps, rb))
        cuts.append(occ.addCylinder(xs, 0, z1 - t - eps, 0, 0, bl + t + 2 * eps, rb))
    n = p.flange_bolts_per_side
    for xb in (x0 - fw / 2, x1 + fw / 2):
        for k in range(n):
            zb = z0 + (k + 0.5) * (z1 - z0) / n
            cuts.append(occ.addCylinder(xb, -ft / 2 - eps, zb, 0, ft + 2 * eps, 0,
                                        p.flange_bolt_radius))
    for xb in (feet_x[0] + p.foot_overhang / 2, feet_x[1] + fx - p.foot_overhang / 2):
        for za in (z0, z1 - fz):
            cuts.append(occ.addCylinder(xb, y0 - fy - eps, za + fz / 2, 0, fy + 2 * eps, 0,
                                        p.foot_bolt_radius))
    result, _ = occ.cut(solid, [(3, c) for c in cuts])
    occ.synchronize()
    vols = [tag for d, tag in result if d == 3]
    if len(vols) != 1:
        raise RuntimeError(f"gearbox housing: {len(vols)} volumes, expected one solid")
    return vols[0]


def seats(p: GearboxHousing) -> list[BearingSeat]:
    """The six bearing seats as a scene states them: axis point, direction, radius and
    bearing width; names ``{shaft}_{a|b}``."""
    za, zb = p.seat_z()
    return [BearingSeat(f"{s}_{end}", point=(xs, 0.0, z), direction=(0.0, 0.0, 1.0),
                        radius=rb, width=w)
            for s, xs, rb, w in zip(SHAFTS, p.shaft_x, p.bore_radii, p.bearing_widths,
                                    strict=True)
            for end, z in (("a", za), ("b", zb))]


def feet_mount(p: GearboxHousing, per_patch: bool = False) -> Mount:
    """The feet's bolted faces: the plane under the feet, normal -y."""
    (_, _), (cy0, _), (_, _) = p.cavity()
    y = cy0 - p.wall - p.foot_size[1]
    return Mount("feet", plane=((0.0, y, 0.0), (0.0, -1.0, 0.0)), per_patch=per_patch)


def write(path: str | Path, p: GearboxHousing | None = None) -> Path:
    """Write the housing as STEP (mm) to ``path``."""
    p = GearboxHousing() if p is None else p
    with gmsh_session():
        return write_step(path, lambda: build(p))


def describe(p: GearboxHousing) -> dict:
    """The train, the seats and the feet as plain data (mm), for a scene file."""
    mm = 1e3
    return {
        "centre_distances_mm": [a * mm for a in p.centre_distances],
        "shaft_x_mm": [x * mm for x in p.shaft_x],
        "teeth": [list(t) for t in p.teeth],
        "seats": [{"name": s.name, "point_mm": [v * mm for v in s.point],
                   "direction": list(s.direction), "radius_mm": s.radius * mm,
                   "width_mm": s.width * mm} for s in seats(p)],
        "feet_plane_mm": {"point": [v * mm for v in feet_mount(p).plane[0]],
                          "normal": list(feet_mount(p).plane[1])},
        "parameters_m": asdict(p),
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("path", help="target .step file")
    ap.add_argument("--describe", action="store_true",
                    help="print the gear train, seats and feet (JSON, mm)")
    args = ap.parse_args(argv)
    p = GearboxHousing()
    write(args.path, p)
    print(f"wrote {args.path}")
    if args.describe:
        print(json.dumps(describe(p), indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
