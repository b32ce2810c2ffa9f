"""Inverse kinematics: two-bone leg IK reaches its targets with rigid bones, minimal
rotations, the root correction brings far targets within reach."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "apps"))
from blend_testlib import walker

from elastic_motion.apps.metrics import bone_length_error
from elastic_motion.groups import SO3
from elastic_motion.motion import forward_kinematics, global_rotations
from elastic_motion.motion.ik import (
    leg_chain,
    root_correction,
    rotation_between,
    solve_legs,
    two_bone_ik,
)

RNG = np.random.default_rng(16)


def _legs(m):
    return [
        leg_chain(m.skeleton, "LeftUpLeg", "LeftLeg", "LeftFoot"),
        leg_chain(m.skeleton, "RightUpLeg", "RightLeg", "RightFoot"),
    ]


def test_rotation_between_is_the_smallest_turn():
    u = RNG.normal(size=(50, 3))
    v = RNG.normal(size=(50, 3))
    r = rotation_between(u, v)
    ru = np.einsum("fij,fj->fi", r, u)
    cos = np.einsum("fi,fi->f", ru, v) / np.linalg.norm(ru, axis=1) / np.linalg.norm(v, axis=1)
    np.testing.assert_allclose(cos, 1.0, atol=1e-12)
    # the angle turned is the angle between u and v (nothing more), the axis is normal to both
    ang = np.linalg.norm(SO3().log(r), axis=1)
    want = np.arccos(np.einsum("fi,fi->f", u, v) / np.linalg.norm(u, axis=1) / np.linalg.norm(v, axis=1))
    np.testing.assert_allclose(ang, want, atol=1e-10)
    # antiparallel: a half turn
    r = rotation_between(np.array([[1.0, 0, 0]]), np.array([[-2.0, 0, 0]]))
    np.testing.assert_allclose(r[0] @ [1.0, 0, 0], [-1.0, 0, 0], atol=1e-12)


def test_two_bone_ik_reaches_a_reachable_target_and_keeps_the_plane_rigid():
    n = 200
    a = RNG.normal(size=(n, 3))
    th = RNG.normal(size=(n, 3))
    b = a + 0.45 * th / np.linalg.norm(th, axis=1, keepdims=True)
    sh = RNG.normal(size=(n, 3))
    c = b + 0.4 * sh / np.linalg.norm(sh, axis=1, keepdims=True)
    # targets at distances 0.1 .. 0.84 from the hip (all reachable: |l1 - l2| = 0.05, l1 + l2 = 0.85)
    dirs = RNG.normal(size=(n, 3))
    t = a + RNG.uniform(0.1, 0.84, size=(n, 1)) * dirs / np.linalg.norm(dirs, axis=1, keepdims=True)
    r_hip, r_knee = two_bone_ik(a, b, c, t)
    knee = a + np.einsum("fij,fj->fi", r_hip, b - a)
    ankle = knee + np.einsum("fij,fj->fi", r_knee, c - b)
    np.testing.assert_allclose(ankle, t, atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(knee - a, axis=1), 0.45, atol=1e-12)


def test_two_bone_ik_stretches_towards_an_unreachable_target():
    a = np.zeros((1, 3))
    b = np.array([[0.0, -0.45, 0.05]])
    c = np.array([[0.0, -0.85, 0.0]])
    l1 = np.linalg.norm(b - a)
    l2 = np.linalg.norm(c - b)
    t = np.array([[0.3, -1.5, 0.2]])
    r_hip, r_knee = two_bone_ik(a, b, c, t)
    ankle = a[0] + r_hip[0] @ (b - a)[0] + r_knee[0] @ (c - b)[0]
    d = t[0] / np.linalg.norm(t[0])
    np.testing.assert_allclose(ankle / np.linalg.norm(ankle), d, atol=1e-9)
    assert np.linalg.norm(ankle) == pytest.approx((l1 + l2) * (1 - 1e-4), rel=1e-9)


def test_two_bone_ik_of_a_straight_leg_bends_about_the_given_axis():
    a = np.zeros((1, 3))
    b = np.array([[0.0, -0.4, 0.0]])
    c = np.array([[0.0, -0.8, 0.0]])
    t = np.array([[0.0, -0.6, 0.0]])
    r_hip, r_knee = two_bone_ik(a, b, c, t, bend_axis=np.array([[1.0, 0.0, 0.0]]))
    knee = r_hip[0] @ b[0]
    ankle = knee + r_knee[0] @ (c - b)[0]
    np.testing.assert_allclose(ankle, t[0], atol=1e-9)
    assert abs(knee[0]) < 1e-12 and abs(knee[2]) > 0.1  # bent in the y-z plane


def test_solve_legs_moves_the_ankles_keeps_bones_and_foot_orientation():
    m = walker(duration=1.0)
    legs = _legs(m)
    p = forward_kinematics(m)
    g = global_rotations(m)
    f = m.n_frames
    la, ra = m.skeleton.index("LeftFoot"), m.skeleton.index("RightFoot")
    tl = p[:, la] + np.array([0.03, 0.04, -0.05])
    tr = np.full((f, 3), np.nan)
    tr[5:10] = p[5:10, ra] + np.array([-0.02, 0.05, 0.06])
    out = solve_legs(m, legs, [tl, tr])
    q = forward_kinematics(out)
    np.testing.assert_allclose(q[:, la], tl, atol=1e-7)
    np.testing.assert_allclose(q[5:10, ra], tr[5:10], atol=1e-7)  # arccos near a straight leg
    # frames without a target are untouched; so are the root and every other joint's rotation
    np.testing.assert_array_equal(out.rotations[:5, legs[1].hip], m.rotations[:5, legs[1].hip])
    moved = {legs[0].hip, legs[0].knee, legs[0].ankle, legs[1].hip, legs[1].knee, legs[1].ankle}
    others = [j for j in range(m.n_joints) if j not in moved]
    np.testing.assert_array_equal(out.rotations[:, others], m.rotations[:, others])
    assert bone_length_error(out).max_relative < 1e-12
    np.testing.assert_allclose(global_rotations(out)[:, la], g[:, la], atol=1e-12)


def test_root_correction_brings_far_targets_within_reach():
    m = walker(duration=1.0)
    legs = _legs(m)
    p = forward_kinematics(m)
    la = m.skeleton.index("LeftFoot")
    t = p[:, la].copy()
    t[10:20, 1] -= 0.1  # 10 cm below where a straight-ish leg can reach
    off = root_correction(m, legs[:1], [t], sigma=0.05)
    assert np.abs(off[:3]).max() < 1e-3 and off[10:20, 1].max() < -0.05
    fixed = m.replace(root_translation=m.root_translation + off)
    out = solve_legs(fixed, legs[:1], [t])
    np.testing.assert_allclose(forward_kinematics(out)[10:20, la], t[10:20], atol=2e-3)


def test_two_bone_ik_straightens_a_hyperextended_knee_instead_of_mirroring_it():
    # a knee bent forward by 6 degrees, straight, then bent backwards by 6 degrees (blends of
    # two walks do that), the ankle to come 5 cm nearer the hip: with the hinge axis known,
    # every frame bends the knee forward by the same angle (the old rule mirrored the bend of
    # a backward knee: a jump of twice the bend where the leg passes straight)
    th = np.radians(np.linspace(6.0, -6.0, 13))
    down = np.array([0.0, -1.0, 0.0])
    fwd = np.array([0.0, 0.0, 1.0])
    thigh = 0.45 * (np.cos(th / 2)[:, None] * down + np.sin(th / 2)[:, None] * fwd)
    shin = 0.4 * (np.cos(th / 2)[:, None] * down - np.sin(th / 2)[:, None] * fwd)
    a = np.zeros((13, 3))
    b, c = a + thigh, a + thigh + shin
    t = np.tile([[0.0, -0.80, 0.0]], (13, 1))
    hinge = np.tile([[-1.0, 0.0, 0.0]], (13, 1))  # (c - a) x (b - a) of a forward bend
    r_hip, r_knee = two_bone_ik(a, b, c, t, hinge)
    knee = a + np.einsum("fij,fj->fi", r_hip, b - a)
    ankle = knee + np.einsum("fij,fj->fi", r_knee, c - b)
    np.testing.assert_allclose(ankle, t, atol=1e-9)
    assert (knee[:, 2] > 0.05).all()  # bent forward
    np.testing.assert_allclose(knee, np.broadcast_to(knee[6], knee.shape), atol=1e-9)


def test_the_hinge_axis_is_the_way_the_knee_bends_most():
    # first bent frame slightly backwards, all others well forward: the hinge follows the many
    from elastic_motion.motion.ik import _bend_axis_local

    th = np.radians(np.array([-4.0, 30.0, 40.0, 50.0, 35.0]))
    down, fwd = np.array([0.0, -1.0, 0.0]), np.array([0.0, 0.0, 1.0])
    thigh = 0.45 * (np.cos(th / 2)[:, None] * down + np.sin(th / 2)[:, None] * fwd)
    shin = 0.4 * (np.cos(th / 2)[:, None] * down - np.sin(th / 2)[:, None] * fwd)
    a = np.zeros((5, 3))
    axis = _bend_axis_local(np.tile(np.eye(3), (5, 1, 1)), a, a + thigh, a + thigh + shin)
    np.testing.assert_allclose(axis, [-1.0, 0.0, 0.0], atol=1e-12)


def test_solve_legs_without_the_hinge_keeps_each_frames_bend_plane():
    """A knee bent the other way from the clip's hinge: with the hinge, IK to the ankle's own
    position bends it forward (decimetres at the knee); without, nothing moves."""
    m = walker(duration=1.0)
    legs = _legs(m)
    knee = m.skeleton.index("LeftLeg")
    bent_back = m.rotations.copy()
    # the walker's knee bends about +x, and is straight in frames 13-27: bend it backwards
    bent_back[15:19, knee] = SO3().exp(np.array([-0.25, 0.0, 0.0]))
    m2 = m.replace(rotations=bent_back)
    p = forward_kinematics(m2)
    la = m2.skeleton.index("LeftFoot")
    target = np.full((m2.n_frames, 3), np.nan)
    target[15:19] = p[15:19, la]
    keep = solve_legs(m2, legs[:1], [target], hinge=False)
    np.testing.assert_allclose(forward_kinematics(keep), p, atol=1e-9)
    flip = solve_legs(m2, legs[:1], [target], hinge=True)
    assert np.linalg.norm(forward_kinematics(flip)[15:19, knee] - p[15:19, knee], axis=-1).max() > 0.05
