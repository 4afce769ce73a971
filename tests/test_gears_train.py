"""gears.train: mesh phasing from the geometry (docs/theory.md §14.5, T.41-T.46) against
the closed form for an idler (issue 36 item 5c) and against a brute-force construction:
the involute flanks of the shared gear built point by point, the gear rotated, and the
instants found where the number of tooth pairs on each mesh's path of contact changes
(the middle of the ⌊ε_α⌋ + 1 zone is the phase origin of the scene's mesh stiffness)."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from core.errors import InputError
from gears import GearPair
from gears.train import (
    idler_phase_difference,
    mesh_phase,
    pitch_point_phase,
    relative_phase,
    tooth_half_angle,
)

TWO_PI = 2.0 * math.pi
ALPHA = math.radians(20.0)
MODULE = 2e-3


def _wrap(a: float) -> float:
    """Angle difference in (-pi, pi]."""
    return (a + math.pi) % TWO_PI - math.pi


class BruteForceMesh:
    """One mesh seen from its gear ``gear`` (1 drives, 2 is driven) of ``pair``: the
    loaded flanks of that gear's teeth as involutes built from the base circle (roll
    parameter u, no involute function), set so that the tooth thickness at the reference
    circle is the ISO one; the line of action through the pitch point C — found on the
    line of centres by dividing the centre distance in the ratio of the base radii — and
    tangent to the base circle on the side of the loaded flank."""

    def __init__(self, pair: GearPair, gear: int, centre_angle: float, tooth_angle: float):
        self.pair, self.gear = pair, gear
        i = gear - 1
        self.z = pair.teeth[i]
        self.rb = pair.base_radii[i]
        self.ra = pair.tip_radii[i]
        r = pair.pitch_radii[i]
        rb_other = pair.base_radii[1 - i]
        a = pair.centre_distance
        rc = a * self.rb / (self.rb + rb_other)               # |OC| from the geometry
        c = rc * np.array([math.cos(centre_angle), math.sin(centre_angle)])
        self.c = c
        off = math.acos(self.rb / rc)                          # tangents from C
        self.leading = gear == 1                               # driving: leading flank
        t_ang = centre_angle - off if self.leading else centre_angle + off
        t = self.rb * np.array([math.cos(t_ang), math.sin(t_ang)])
        # +s: from T_1 towards T_2 (away from this gear's T if it drives, towards it else)
        d = (c - t) / np.linalg.norm(c - t)
        self.s_dir = d if self.leading else -d
        self.normal = np.array([-d[1], d[0]])
        # s of C from T_1: |T_1 C| measured on the pair's gear 1
        line = a * math.sin(pair.working_pressure_angle)
        self.s_c = np.linalg.norm(c - t) if gear == 1 else line - np.linalg.norm(c - t)
        # thickness at the reference circle: s_t = m_t (pi/2 + 2 x tan alpha_n)
        s_t = pair.transverse_module * (0.5 * math.pi
                                        + 2 * pair.profile_shift[i] * math.tan(ALPHA))
        u_r = math.sqrt((r / self.rb) ** 2 - 1.0)
        polar_r = math.atan2(*self._involute(u_r)[::-1])        # polar angle at r
        half = 0.5 * s_t / r
        # trailing flank: polar angle grows with r; leading: mirror image
        self.offsets = []
        for j in range(self.z):
            psi = tooth_angle + TWO_PI * j / self.z
            self.offsets.append(psi + half - (-polar_r) if self.leading
                                else psi - half - polar_r)
        self.u_tip = math.sqrt((self.ra / self.rb) ** 2 - 1.0)

    def _involute(self, u: float) -> np.ndarray:
        rb = self.rb
        return np.array([rb * (math.cos(u) + u * math.sin(u)),
                         rb * (math.sin(u) - u * math.cos(u))])

    def _flank(self, u: float, offset: float, phi: float) -> np.ndarray:
        p = self._involute(u)
        if self.leading:
            p = np.array([p[0], -p[1]])
        a = offset + phi
        rot = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
        return rot @ p

    def contacts(self, phi: float) -> list[float]:
        """s (from T_1) of every loaded flank's crossing of the line of action within the
        path of contact, the gear turned by ``phi``."""
        s_a, s_e = self.pair.path
        out = []
        for off in self.offsets:
            def dist(u, off=off):
                return float((self._flank(u, off, phi) - self.c) @ self.normal)
            ends = (dist(0.0), dist(self.u_tip))
            if ends[0] * ends[1] > 0:
                continue
            u = brentq(dist, 0.0, self.u_tip, xtol=1e-15, rtol=1e-15)
            s = self.s_c + float((self._flank(u, off, phi) - self.c) @ self.s_dir)
            if s_a <= s <= s_e:
                out.append(s)
        return out

    def phase(self) -> float:
        """The mesh phase at phi = 0: the gear is turned over one pitch, the two angles
        where the number of pairs in contact changes are bisected, and the middle of the
        zone with one pair more is phase 0; the phase grows by Z phi."""
        pitch = TWO_PI / self.z
        phis = np.linspace(0.0, pitch, 241)
        counts = np.array([len(self.contacts(p)) for p in phis])
        more = counts.max()
        assert counts.min() == more - 1, counts
        edges = []
        for k in range(phis.size - 1):
            if counts[k] != counts[k + 1]:
                lo, hi = phis[k], phis[k + 1]
                for _ in range(60):
                    mid = 0.5 * (lo + hi)
                    if len(self.contacts(mid)) == counts[k]:
                        lo = mid
                    else:
                        hi = mid
                edges.append((0.5 * (lo + hi), counts[k + 1] == more))
        assert len(edges) == 2
        start = next(p for p, up in edges if up)
        end = next(p for p, up in edges if not up)
        width = (end - start) % pitch
        mid = start + 0.5 * width
        return (-self.z * mid) % TWO_PI


def _pair(z1: int, z2: int, x1: float = 0.0, x2: float = 0.0) -> GearPair:
    return GearPair(teeth=(z1, z2), module=MODULE, pressure_angle=ALPHA, face_width=0.02,
                    profile_shift=(x1, x2))


@pytest.mark.parametrize("gear", [1, 2])
@pytest.mark.parametrize("teeth,shift,centre,tooth", [
    ((23, 61), (0.0, 0.0), 0.3, 0.1),
    ((19, 67), (0.4, -0.1), 2.1, -0.7),
    ((31, 31), (0.25, 0.25), -1.0, 0.05),
])
def test_mesh_phase_against_brute_force(gear, teeth, shift, centre, tooth):
    """mesh_phase (T.44) equals the phase of the brute-force construction to 1e-9 rad,
    either gear of the pair, with profile shifts (working pressure angle != 20 deg)."""
    pair = _pair(*teeth, *shift)
    brute = BruteForceMesh(pair, gear, centre, tooth).phase()
    assert abs(_wrap(mesh_phase(pair, gear, centre, tooth) - brute)) < 1e-9


def test_idler_closed_form_and_brute_force():
    """An idler of 31 teeth driven by a 19-tooth gear and driving a 47-tooth gear, the two
    mates 128.3 degrees apart on it: the pitch-point phases differ by pi - Z Delta alpha
    (T.46), and the scene-convention phases (T.44) by the brute-force difference."""
    z = 31
    first, second = _pair(19, z), _pair(z, 47)          # idler driven, then driving
    a1, a2 = 0.4, 0.4 + math.radians(128.3)
    closed = idler_phase_difference(z, a2 - a1)
    pitch = (pitch_point_phase(second, 1, a2) - pitch_point_phase(first, 2, a1)) % TWO_PI
    assert abs(_wrap(pitch - closed)) < 1e-12
    # the tooth thickness of standard teeth at the reference circle: half the pitch
    assert abs(tooth_half_angle(first, 2, first.pitch_radii[1]) - math.pi / (2 * z)) < 1e-15
    rel = relative_phase((first, 2, a1), (second, 1, a2), tooth_angle=0.2)
    brute = (BruteForceMesh(second, 1, a2, 0.2).phase()
             - BruteForceMesh(first, 2, a1, 0.2).phase())
    assert abs(_wrap(rel - brute)) < 1e-9
    # the relative phase does not depend on where the idler's teeth are
    assert abs(_wrap(relative_phase((first, 2, a1), (second, 1, a2), 1.3) - rel)) < 1e-12


def test_idler_phase_numbers():
    """The closed form by hand: 20 teeth, mates 90 degrees apart: pi - 20 pi/2 = -9 pi = pi;
    21 teeth: pi - 21 pi/2 = pi/2 (mod 2 pi)."""
    assert abs(_wrap(idler_phase_difference(20, 0.5 * math.pi) - math.pi)) < 1e-12
    assert abs(_wrap(idler_phase_difference(21, 0.5 * math.pi) - 0.5 * math.pi)) < 1e-12


def test_refusals():
    pair = _pair(20, 40)
    with pytest.raises(InputError, match="gear"):
        mesh_phase(pair, 3, 0.0)
    with pytest.raises(InputError, match="centre_angle"):
        mesh_phase(pair, 1, float("nan"))
    with pytest.raises(InputError, match="teeth"):
        relative_phase((pair, 1, 0.0), (pair, 2, 1.0))
    with pytest.raises(InputError, match="radius"):
        tooth_half_angle(pair, 1, 0.5 * pair.base_radii[0])
