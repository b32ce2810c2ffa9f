"""Euler / quaternion conversions against scipy (the independent reference)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from elastic_motion.motion.rotations import (
    axis_rotation,
    euler_to_matrix,
    matrix_to_euler,
    quaternion_to_matrix,
)

ORDERS = ["".join(p) for p in itertools.permutations("XYZ")]


@pytest.mark.parametrize("order", ORDERS)
def test_euler_to_matrix_is_intrinsic_like_scipy(order):
    rng = np.random.default_rng(0)
    a = rng.uniform(-np.pi, np.pi, (200, 3))
    expected = Rotation.from_euler(order, a).as_matrix()
    np.testing.assert_allclose(euler_to_matrix(a, order), expected, atol=1e-14)
    # intrinsic = product in listed order: R = R_a0 @ R_a1 @ R_a2
    prod = (
        axis_rotation(a[:, 0], order[0]) @ axis_rotation(a[:, 1], order[1]) @ axis_rotation(a[:, 2], order[2])
    )
    np.testing.assert_allclose(euler_to_matrix(a, order), prod, atol=1e-14)


@pytest.mark.parametrize("order", ORDERS)
def test_matrix_to_euler_inverts_and_matches_scipy(order):
    mats = Rotation.random(500, random_state=1).as_matrix()
    e = matrix_to_euler(mats, order)
    np.testing.assert_allclose(euler_to_matrix(e, order), mats, atol=1e-13)
    assert np.all(np.abs(e[:, 1]) <= np.pi / 2 + 1e-15)
    np.testing.assert_allclose(e, Rotation.from_matrix(mats).as_euler(order), atol=1e-9)


@pytest.mark.parametrize("order", ORDERS)
def test_matrix_to_euler_at_and_near_gimbal_lock(order):
    rng = np.random.default_rng(2)
    a = rng.uniform(-np.pi, np.pi, (400, 3))
    a[:, 1] = np.pi / 2 * np.sign(rng.uniform(-1, 1, 400))
    a[:200, 1] -= np.sign(a[:200, 1]) * 10.0 ** rng.uniform(-12, -6, 200)
    mats = euler_to_matrix(a, order)
    back = euler_to_matrix(matrix_to_euler(mats, order), order)
    np.testing.assert_allclose(back, mats, atol=1e-12)


def test_axis_rotation_is_right_handed():
    ex, ey, ez = np.eye(3)
    np.testing.assert_allclose(axis_rotation(np.pi / 2, "Z") @ ex, ey, atol=1e-15)
    np.testing.assert_allclose(axis_rotation(np.pi / 2, "X") @ ey, ez, atol=1e-15)
    np.testing.assert_allclose(axis_rotation(np.pi / 2, "Y") @ ez, ex, atol=1e-15)


def test_quaternion_is_scalar_first_and_normalised():
    rng = np.random.default_rng(3)
    q = rng.normal(size=(50, 4))  # (w, x, y, z), not unit length
    expected = Rotation.from_quat(q[:, [1, 2, 3, 0]]).as_matrix()  # scipy: scalar last
    np.testing.assert_allclose(quaternion_to_matrix(q), expected, atol=1e-14)
    np.testing.assert_allclose(quaternion_to_matrix(3.0 * q), expected, atol=1e-14)
    # 90 degrees about z: w = cos 45, z = sin 45
    qz = np.array([np.cos(np.pi / 4), 0, 0, np.sin(np.pi / 4)])
    np.testing.assert_allclose(quaternion_to_matrix(qz), axis_rotation(np.pi / 2, "Z"), atol=1e-15)
    with pytest.raises(ValueError, match="non-zero"):
        quaternion_to_matrix(np.zeros((2, 4)))


def test_bad_order_is_a_value_error_naming_the_argument():
    with pytest.raises(ValueError, match="order: expected three distinct axes"):
        euler_to_matrix(np.zeros(3), "XXY")


# --- quaternions of glTF (issue 31) and the DOF rotations of joint limits (issue 33) -------


def _random_rotations(n: int, seed: int) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    r = Rotation.random(n, random_state=seed).as_matrix()
    # every branch of Shepperd's method: near the identity and near half turns about x, y, z
    half = [Rotation.from_rotvec(np.pi * 0.999 * e).as_matrix() for e in np.eye(3)]
    return np.concatenate([r, np.eye(3)[None], np.stack(half)])


def test_matrix_to_quaternion_round_trips_and_equals_scipy():
    from scipy.spatial.transform import Rotation

    from elastic_motion.motion.rotations import matrix_to_quaternion, quaternion_to_matrix

    m = _random_rotations(200, 3)
    q = matrix_to_quaternion(m)
    assert (q[:, 0] >= 0).all() and np.allclose(np.linalg.norm(q, axis=1), 1.0)
    assert np.abs(quaternion_to_matrix(q) - m).max() < 1e-12
    ref = Rotation.from_matrix(m).as_quat()[:, [3, 0, 1, 2]]  # scipy: (x, y, z, w), w sign free
    ref *= np.where(ref[:, :1] < 0, -1.0, 1.0)
    assert np.abs(q - ref).max() < 1e-12


def test_quaternion_slerp_is_the_so3_geodesic_on_the_shorter_arc():
    from elastic_motion.groups import SO3
    from elastic_motion.motion.rotations import matrix_to_quaternion, quaternion_slerp, quaternion_to_matrix

    g = SO3()
    m0, m1 = _random_rotations(50, 4)[:50], _random_rotations(50, 5)[:50]
    q0, q1 = matrix_to_quaternion(m0), matrix_to_quaternion(m1)
    q1 = np.where(np.sum(q0 * q1, axis=1, keepdims=True) > 0, -q1, q1)  # the longer way round given
    for u in (0.0, 0.3, 1.0):
        got = quaternion_to_matrix(quaternion_slerp(q0, q1, np.full(50, u)))
        want = m0 @ g.exp(u * g.log(np.swapaxes(m0, -1, -2) @ m1))  # R0 exp(u log(R0^T R1))
        assert np.abs(got - want).max() < 1e-9, u
    near = quaternion_slerp(q0, q0 + 1e-9, np.full(50, 0.5))  # the linear branch
    assert np.allclose(np.linalg.norm(near, axis=1), 1.0) and np.abs(near - q0).max() < 1e-8


@pytest.mark.parametrize("axes", ["XYZ", "XZ", "Y", "ZYX"])
def test_dof_rotation_inverts_dof_angles(axes):
    from elastic_motion.motion.joint_limits import dof_angles, dof_rotation

    frame = SO3_FRAME
    rng = np.random.default_rng(len(axes))
    ang = rng.uniform(-1.2, 1.2, size=(40, 3))
    k = len(axes)  # the dof axes' angles come first; the missing axes' last
    r = dof_rotation(ang, frame, axes)
    assert np.abs(dof_angles(r, frame, axes) - ang[:, :k]).max() < 1e-9
    # the same turns one after another about the frame's axes, in the listed (fixed-axis) order
    full = axes + "".join(a for a in "XYZ" if a not in axes)
    want = np.stack([np.eye(3)] * 40)
    for i, a in enumerate(full):
        want = axis_rotation(ang[:, i], a) @ want
    assert np.abs(r - frame @ want @ frame.T).max() < 1e-12


SO3_FRAME = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]) @ np.array(
    [[1.0, 0.0, 0.0], [0.0, 0.8, -0.6], [0.0, 0.6, 0.8]]
)
