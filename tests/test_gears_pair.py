"""gears.pair: the gear-pair frame of Fig. 1 and G of eq. (11) against the motion of the
base-circle tangent points (spur) and of the pitch point (helical: rigid motions of the
pair give no approach), for both senses of rotation and both helix hands; the pair
geometry against a textbook spur pair and the ISO/TR 6336-30 helical example."""
from __future__ import annotations

import math

import numpy as np
import pytest

from gears import (
    GearPair,
    basic_rack_factor,
    inverse_involute,
    involute,
    line_of_action_vector,
    mesh_stiffness,
    pair_frame,
    theoretical_single_stiffness,
)

ALPHA, RB1, RB2 = math.radians(20.0), 46.984e-3, 40.0e-3


@pytest.mark.parametrize("sense", [1, -1])
def test_line_of_action_from_base_circle_tangent_points(sense: int) -> None:
    """Gear 1 drives about +z (sense 1) or −z (sense −1): the line of action is the
    tangent through T_1 = r_b1 (cos α, ±sin α, 0), and Gᵀ q_c is the approach of the two
    flanks along n, the gear DOF expressed in the pair frame."""
    a = (RB1 + RB2) / math.cos(ALPHA)
    R = pair_frame(ALPHA, sense=sense)
    n = np.array([-math.sin(ALPHA), sense * math.cos(ALPHA), 0.0])
    np.testing.assert_allclose(R[:, 1], n, atol=1e-15)
    np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-15)
    assert np.linalg.det(R) == pytest.approx(1.0)
    np.testing.assert_array_equal(R[:, 2], [0.0, 0.0, 1.0])   # the shaft axis stays e_z
    c1, c2 = np.zeros(3), np.array([a, 0.0, 0.0])
    t1 = RB1 * np.array([math.cos(ALPHA), sense * math.sin(ALPHA), 0.0])
    t2 = c2 - RB2 * np.array([math.cos(ALPHA), sense * math.sin(ALPHA), 0.0])
    assert abs(np.dot(t2 - t1, n) + a * math.sin(ALPHA)) < 1e-15  # both on the line along n
    assert abs(np.cross(t2 - t1, n)[2]) < 1e-15
    # a driving rotation of gear 1 (about sense·e_z) moves its flank at T_1 along +n
    np.testing.assert_allclose(np.cross(sense * np.array([0, 0, 1.0]), t1 - c1), RB1 * n,
                               atol=1e-15)
    G = line_of_action_vector(ALPHA, 0.0, RB1, RB2, sense=sense)
    rng = np.random.default_rng(1)
    for _ in range(5):
        u1, th1, u2, th2 = rng.normal(size=(4, 3)) * [[1e-5], [1e-4], [1e-5], [1e-4]]
        delta = n @ ((u1 + np.cross(th1, t1 - c1)) - (u2 + np.cross(th2, t2 - c2)))
        q_c = np.concatenate([R.T @ u1, R.T @ th1, R.T @ u2, R.T @ th2])
        assert abs(G @ q_c - delta) < 1e-12 * np.abs(q_c).max()


def test_eq11_helical_entries_hand_and_sense() -> None:
    alpha, beta, rb1, rb2 = 0.35, 0.2, 0.05, 0.04
    G = line_of_action_vector(alpha, beta, rb1, rb2)
    ta, tb = math.tan(alpha), math.tan(beta)
    # eq. (11) with its θ_x' entries of the opposite sign (docs/theory.md §1)
    expected = [0, 1, tb, -rb1 * ta * tb, -rb1 * tb, rb1, 0, -1, -tb, -rb2 * ta * tb,
                -rb2 * tb, rb2]
    np.testing.assert_array_equal(G, expected)
    # the other hand is tan β -> −tan β
    np.testing.assert_array_equal(line_of_action_vector(alpha, beta, rb1, rb2, hand=-1),
                                  line_of_action_vector(alpha, -beta, rb1, rb2))
    # the other sense of rotation: the same machine turned by π about the global x axis
    # (Q, proper: displacements and rotations turn alike) gives the same approach
    Q = np.diag([1.0, -1.0, -1.0])
    R1, R2 = pair_frame(alpha), pair_frame(alpha, sense=-1)
    G2 = line_of_action_vector(alpha, beta, rb1, rb2, sense=-1)
    rng = np.random.default_rng(2)
    for _ in range(5):
        v = rng.normal(size=(4, 3))
        q1 = np.concatenate([R1.T @ x for x in v])
        q2 = np.concatenate([R2.T @ (Q @ x) for x in v])
        assert G2 @ q2 == pytest.approx(G @ q1, rel=1e-13)


@pytest.mark.parametrize("sense", [1, -1])
@pytest.mark.parametrize("hand", [1, -1])
def test_helical_g_is_the_motion_of_the_pitch_point_and_ignores_rigid_motions(
        sense: int, hand: int) -> None:
    """A helical pair (β = 0.2 rad): Gᵀ q_c is the approach of the two gears at the pitch
    point along the flank normal ``n + s tan β e_z'`` (s the axial entry of G), for any
    motion of the gear centres; a rigid motion of the whole pair (common translation and
    rotation about any point) gives Δ = 0. Eq. (11) as printed, with +r_b tan α tan β on
    θ_x', fails both by ~1e-2 of the motion here."""
    alpha, beta, rb1, rb2 = 0.35, 0.2, 0.05, 0.04
    a = (rb1 + rb2) / math.cos(alpha)
    G = line_of_action_vector(alpha, beta, rb1, rb2, hand=hand, sense=sense)
    printed = G.copy()
    printed[[3, 9]] *= -1.0
    R = pair_frame(alpha, sense=sense)
    c1, c2 = np.zeros(3), np.array([a, 0.0, 0.0])
    pitch = np.array([rb1 / math.cos(alpha), 0.0, 0.0])
    normal = R @ np.array([0.0, 1.0, G[2]])
    assert G[2] == pytest.approx(sense * hand * math.tan(beta), rel=1e-15)
    rng = np.random.default_rng(3)
    worst = 0.0
    for _ in range(5):
        u1, th1, u2, th2 = rng.normal(size=(4, 3))
        delta = normal @ ((u1 + np.cross(th1, pitch - c1)) - (u2 + np.cross(th2, pitch - c2)))
        q_c = np.concatenate([R.T @ u1, R.T @ th1, R.T @ u2, R.T @ th2])
        assert abs(G @ q_c - delta) < 1e-14
        worst = max(worst, abs(printed @ q_c - delta))
        t, w, p = rng.normal(size=(3, 3))
        q_c = np.concatenate([R.T @ (t + np.cross(w, c1 - p)), R.T @ w,
                              R.T @ (t + np.cross(w, c2 - p)), R.T @ w])
        assert abs(G @ q_c) < 1e-14
    assert worst > 1e-3


def test_bad_frame_and_vector_input_is_refused() -> None:
    with pytest.raises(ValueError, match=r"rb2 = 0.0 m: must be finite and > 0"):
        line_of_action_vector(0.35, 0.2, 0.05, 0.0)
    with pytest.raises(ValueError, match=r"alpha = 1.6 rad"):
        pair_frame(1.6)
    with pytest.raises(ValueError, match=r"sense = 0: must be 1 or -1"):
        line_of_action_vector(0.35, 0.0, 0.05, 0.05, sense=0)
    with pytest.raises(ValueError, match=r"hand = 2: must be 1 or -1"):
        line_of_action_vector(0.35, 0.0, 0.05, 0.05, hand=2)


def test_textbook_spur_pair() -> None:
    # z1 = z2 = 20, m = 5 mm, α = 20°, standard rack: ε_α = 1.557 (textbook value)
    p = GearPair((20, 20), 5e-3, math.radians(20.0), 0.05)
    assert p.pitch_radii == (0.05, 0.05)
    assert p.base_radii[0] == pytest.approx(0.05 * math.cos(math.radians(20.0)), rel=1e-15)
    assert p.tip_radii == pytest.approx((0.055, 0.055), rel=1e-15)
    assert p.root_radii == pytest.approx((0.04375, 0.04375), rel=1e-15)
    assert p.centre_distance == 0.1 and p.working_pressure_angle == p.pressure_angle
    assert p.transverse_contact_ratio == pytest.approx(1.557, abs=2e-3)
    assert p.overlap_ratio == 0.0
    assert p.total_contact_ratio == p.transverse_contact_ratio
    s_a, s_e = p.path
    assert s_e - s_a == pytest.approx(p.path_length, rel=1e-14)
    np.testing.assert_array_equal(p.frame(), pair_frame(p.pressure_angle))
    np.testing.assert_array_equal(p.line_of_action_vector(),
                                  line_of_action_vector(p.pressure_angle, 0.0, *p.base_radii))
    # given tip and root diameters replace the rack's
    q = GearPair((20, 20), 5e-3, math.radians(20.0), 0.05, tip_diameters=(0.108, 0.11),
                 root_diameters=(0.088, 0.0875))
    assert q.tip_radii == (0.054, 0.055) and q.root_radii == (0.044, 0.04375)
    assert q.transverse_contact_ratio < p.transverse_contact_ratio


def test_profile_shift_moves_the_working_centre_distance() -> None:
    for inv in (1e-6, 0.0149, 0.05, 0.3):
        assert involute(inverse_involute(inv)) == pytest.approx(inv, rel=1e-14)
    p = GearPair((17, 40), 4e-3, math.radians(20.0), 0.03, profile_shift=(0.4, 0.1))
    a_w, a = p.working_pressure_angle, p.transverse_pressure_angle
    assert involute(a_w) == pytest.approx(
        involute(a) + 2 * math.tan(a) * 0.5 / 57, rel=1e-13)
    assert p.centre_distance == pytest.approx(0.114 * math.cos(a) / math.cos(a_w), rel=1e-15)
    assert 0.114 < p.centre_distance < 0.114 + 0.5 * 4e-3     # less than (x1 + x2) m
    # x1 = −x2: the standard centre distance
    assert GearPair((17, 40), 4e-3, math.radians(20.0), 0.03,
                    profile_shift=(0.3, -0.3)).centre_distance == 0.114


def test_iso_tr_6336_30_helical_example() -> None:
    """ISO/TR 6336-30:2017 example 1 (z = 17/103, m_n = 8 mm, α_n = 20°, β = 15.8°,
    x = 0.145/0, b = 100 mm, rack with h_fP = 1.4 m_n, a = 500 mm): the reference values
    z_n = 18.905/114.543, c'_th = 17.85584, c' = 12.37047, c_γα = 17.46485 N/(mm·µm)."""
    p = GearPair((17, 103), 8e-3, math.radians(20.0), 0.1, helix_angle=math.radians(15.8),
                 profile_shift=(0.145, 0.0))
    assert p.centre_distance == pytest.approx(0.5, abs=5e-6)   # x_1 rounded to 3 digits
    assert p.virtual_teeth == pytest.approx((18.905, 114.543), abs=1e-3)
    assert p.overlap_ratio == pytest.approx(0.1 * math.sin(math.radians(15.8)) / (math.pi * 8e-3),
                                            rel=1e-15)
    c_th = theoretical_single_stiffness(p.virtual_teeth, p.profile_shift)
    assert c_th == pytest.approx(17.85584, rel=1e-6)
    c_b = basic_rack_factor(1.4, p.pressure_angle)
    assert c_b == pytest.approx(0.9, rel=1e-15)
    c1 = c_th * 0.8 * c_b * math.cos(p.helix_angle)
    assert c1 == pytest.approx(12.37047, rel=1e-6)
    # c_γα from this pair's ε_α (1.5495; 1.5491 in the reference, which fixes a = 500)
    assert p.transverse_contact_ratio == pytest.approx(1.5491, abs=1e-3)
    assert mesh_stiffness(c1, p.transverse_contact_ratio) == pytest.approx(17.46485, rel=1e-3)


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"teeth": (3, 20)}, r"teeth\[1\] = 3: must be an integer >= 5"),
    ({"teeth": (20, 20.5)}, r"teeth\[2\] = 20.5"),
    ({"module": -1e-3}, r"module = -0.001 m: must be finite and > 0"),
    ({"face_width": 0.0}, r"face_width = 0.0 m: must be finite and > 0"),
    ({"helix_angle": -0.1}, r"helix_angle = -0.1 rad"),
    ({"hand": 0}, r"hand = 0: must be 1 or -1"),
    ({"profile_shift": (0.0, float("nan"))}, r"profile_shift\[2\] = nan"),
    ({"tip_diameters": (0.09, 0.11)}, r"tip radius of gear 1 = 0.045 m: must be > its base"),
    ({"root_diameters": (0.12, 0.08)}, r"root radius of gear 1 = 0.06 m: must be > 0 and <"),
])
def test_bad_pair_input_is_refused(kwargs: dict, message: str) -> None:
    base = {"teeth": (20, 20), "module": 5e-3, "pressure_angle": math.radians(20.0),
            "face_width": 0.05}
    with pytest.raises(ValueError, match=message):
        GearPair(**{**base, **kwargs})
