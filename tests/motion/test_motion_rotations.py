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
