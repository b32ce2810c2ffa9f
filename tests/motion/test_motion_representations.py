"""Lie-group and Euler-angle curves of a motion, and the default weights."""

from __future__ import annotations

import numpy as np
import pytest
from motion_testlib import geodesic_deg

from elastic_motion.curves import DiscreteCurve
from elastic_motion.groups import SO3, Euclidean
from elastic_motion.motion import (
    Motion,
    Skeleton,
    default_joint_weights,
    default_translation_weight,
    drop_joints,
    drop_tpose,
    finger_joints,
    from_euler_curve,
    from_lie_curve,
    read_motion,
    skeleton_diameter,
    to_euler_curve,
    to_lie_curve,
    unwrap_euler,
)
from elastic_motion.motion.rotations import euler_to_matrix


@pytest.fixture(scope="module")
def walk(mocap_dir):
    return drop_tpose(read_motion(mocap_dir / "cmu" / "bvh" / "07_01.bvh"))


def _tiny() -> Skeleton:
    # root -> a (length 3) -> b (length 4) -> end site (length 1); root -> c (length 2)
    return Skeleton(
        names=["root", "a", "b", "c"],
        parents=[-1, 0, 1, 0],
        offsets=[[0, 0, 0], [3, 0, 0], [0, 4, 0], [0, 0, 2]],
        channels=[("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation")]
        + [("Zrotation", "Yrotation", "Xrotation")] * 3,
        end_site_parents=[2],
        end_site_offsets=[[1, 0, 0]],
    )


def test_default_joint_weights_follow_subtree_bone_length():
    w = default_joint_weights(_tiny())
    # moved bone lengths: root 3+4+1+2 = 10, a 4+1 = 5, b 1, c 0 (floored); mean 16/4 = 4
    np.testing.assert_allclose(w, [2.5, 1.25, 0.25, 0.01])


def test_default_weights_on_cmu(walk):
    sk = walk.skeleton
    w = default_joint_weights(sk)
    assert w.shape == (31,) and w.min() > 0
    assert np.argmax(w) == 0
    assert w.mean() == pytest.approx(1.0, abs=0.01)
    for k in range(1, sk.n_joints):  # a parent moves everything its child moves, and more
        assert w[sk.parents[k]] >= w[k]
    assert w[sk.index("LeftUpLeg")] > w[sk.index("LeftLeg")] > w[sk.index("LeftFoot")]
    assert max(w[sk.index(n)] for n in finger_joints(sk)) < 0.15 * w[sk.index("LeftUpLeg")]


def test_diameter_and_translation_weight():
    sk = _tiny()
    # longest bone path: end site -> b -> a -> root -> c = 1 + 4 + 3 + 2
    assert skeleton_diameter(sk) == pytest.approx(10.0)
    assert default_translation_weight(sk) == pytest.approx(4 / 5.0**2)


def test_diameter_is_about_body_height(walk):
    d = skeleton_diameter(walk.skeleton) * walk.metres_per_unit
    assert 1.5 < d < 2.6


def test_lie_curve_round_trip_and_layout(walk):
    c = to_lie_curve(walk)
    j = walk.n_joints
    assert isinstance(c, DiscreteCurve)
    assert c.values.shape == (walk.n_frames, 3 + 9 * j)
    np.testing.assert_allclose(c.t, np.linspace(0, 1, walk.n_frames))
    np.testing.assert_array_equal(c.values[:, :3], walk.root_translation)
    np.testing.assert_array_equal(c.values[5, 3 + 9 * 2 : 3 + 9 * 3].reshape(3, 3), walk.rotations[5, 2])
    w = default_joint_weights(walk.skeleton)
    np.testing.assert_allclose(c.group.weights[:3], default_translation_weight(walk.skeleton))
    np.testing.assert_allclose(c.group.weights[3:].reshape(j, 3), np.repeat(w[:, None], 3, axis=1))
    back = from_lie_curve(c, like=walk)
    np.testing.assert_array_equal(back.rotations, walk.rotations)
    np.testing.assert_array_equal(back.root_translation, walk.root_translation)
    assert back.fps == walk.fps and back.skeleton is walk.skeleton and back.source == ()
    custom = to_lie_curve(walk, np.full(j, 2.0), translation_weight=0.5)
    np.testing.assert_allclose(custom.group.weights, [0.5] * 3 + [2.0] * 3 * j)
    with pytest.raises(ValueError, match="joint_weights: expected one weight per joint"):
        to_lie_curve(walk, np.ones(3))


def test_from_lie_curve_with_other_sample_count_keeps_duration(walk):
    c = to_lie_curve(walk)
    fine = c.evaluate(np.linspace(0, 1, 2 * walk.n_frames - 1))
    m = from_lie_curve(DiscreteCurve(fine, group=c.group), like=walk)
    assert m.n_frames == 2 * walk.n_frames - 1
    assert m.duration == pytest.approx(walk.duration)
    np.testing.assert_allclose(m.rotations[::2], walk.rotations, atol=1e-12)
    # non-uniform parameters are evaluated on a uniform grid
    t = np.linspace(0, 1, walk.n_frames) ** 2
    warped = DiscreteCurve(c.evaluate(t), group=c.group, t=t)
    m2 = from_lie_curve(warped, like=walk)
    np.testing.assert_allclose(m2.rotations[[0, -1]], walk.rotations[[0, -1]], atol=1e-12)
    with pytest.raises(ValueError, match="expected a curve in R\\^3 x SO\\(3\\)\\^31"):
        from_lie_curve(DiscreteCurve(np.zeros((3, 5)), group=Euclidean(5)), like=walk)


def test_translation_and_rotation_balance_on_walks(mocap_dir):
    """With the default weights neither part of the SRV norm dominates a walk."""
    so3 = SO3()
    for rel in (
        "cmu/bvh/07_01.bvh",
        "cmu/bvh/08_02.bvh",
        "cmu/asfamc/02_01.amc",
        "deepmimic/humanoid3d_walk.txt",
    ):
        m = drop_tpose(read_motion(mocap_dir / rel))
        m = drop_joints(m, finger_joints(m.skeleton))
        w = default_joint_weights(m.skeleton)
        v = np.diff(m.root_translation, axis=0) * m.fps
        omega = so3.log(np.swapaxes(m.rotations[:-1], -1, -2) @ m.rotations[1:]) * m.fps
        trans = default_translation_weight(m.skeleton) * np.sum(v**2, axis=1).mean()
        rot = np.sum(w * np.sum(omega**2, axis=2), axis=1).mean()
        assert 0.25 < trans / rot < 4.0, (rel, trans / rot)


def test_euler_curve_round_trip_and_layout(walk):
    c = to_euler_curve(walk)
    j = walk.n_joints
    assert isinstance(c.group, Euclidean) and c.values.shape == (walk.n_frames, 3 + 3 * j)
    np.testing.assert_array_equal(c.values[:, :3], walk.root_translation)
    # joint 4's angles, in its file order (ZYX), radians
    np.testing.assert_allclose(
        euler_to_matrix(c.values[:, 3 + 12 : 3 + 15], walk.skeleton.euler_orders[4]),
        walk.rotations[:, 4],
        atol=1e-12,
    )
    back = from_euler_curve(c, like=walk)
    assert geodesic_deg(back.rotations, walk.rotations).max() < 1e-9
    np.testing.assert_array_equal(back.root_translation, walk.root_translation)
    # continuous: no jumps of more than 90 degrees between frames outside the flipping fingers
    body = [k for k, n in enumerate(walk.skeleton.names) if n not in finger_joints(walk.skeleton)]
    steps = np.abs(np.diff(c.values[:, 3:].reshape(-1, j, 3), axis=0))[:, body]
    assert steps.max() < np.pi / 2


def test_unwrap_euler_chooses_the_continuous_branch():
    t = np.linspace(0, 1, 101)
    # middle angle sweeps through 90 degrees; first angle through 180 (wraps)
    true = np.stack([np.radians(150 + 60 * t), np.radians(80 + 20 * t), np.radians(-30 + 0 * t)], axis=1)
    mats = euler_to_matrix(true, "ZYX")[:, None]
    sk = Skeleton(["r"], [-1], [[0, 0, 0]], [("Zrotation", "Yrotation", "Xrotation")])
    m = Motion(sk, 100.0, np.zeros((101, 3)), mats)
    c = to_euler_curve(m)
    np.testing.assert_allclose(c.values[:, 3:], true, atol=1e-9)
    raw = np.stack([true[0], true[0] + [np.pi, np.pi, np.pi]])  # second frame on the other branch
    raw[1, 1] = np.pi - true[0, 1]
    np.testing.assert_allclose(unwrap_euler(raw[:, None])[:, 0], [true[0], true[0]], atol=1e-12)


def test_curves_refuse_moving_non_root_joints(mocap_dir):
    from elastic_motion.motion import merge_root

    bandai = read_motion(mocap_dir / "bandai" / "dataset-1_walk_normal_002.bvh")
    with pytest.raises(ValueError, match="merge_root"):
        to_lie_curve(bandai)
    with pytest.raises(ValueError, match="joint 'Hips' moves through its position channels"):
        to_euler_curve(bandai)
    merged = merge_root(bandai)  # the remaining position channels hold (nearly) the offsets
    back = from_lie_curve(to_lie_curve(merged), like=merged)
    np.testing.assert_allclose(back.root_translation, merged.root_translation)
    np.testing.assert_array_equal(back.joint_translations, merged.joint_translations)
