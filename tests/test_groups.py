"""Tests of the Lie group layer: every formula against an independent computation."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.linalg import expm, logm
from scipy.spatial.transform import Rotation

from elastic_motion.groups import (
    SO3,
    Euclidean,
    PowerGroup,
    ProductGroup,
    animation_group,
    hat,
    vee,
)

SO3G = SO3()


def unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def rotvec_close(a: np.ndarray, b: np.ndarray, atol: float) -> bool:
    """Rotation vectors equal, allowing v ~ -v at angle pi (where log is two-valued)."""
    diff = np.abs(a - b).max(axis=-1)
    at_pi = np.abs(np.linalg.norm(b, axis=-1) - np.pi) < 1e-7
    flipped = np.abs(a + b).max(axis=-1)
    return bool(np.all(np.where(at_pi, np.minimum(diff, flipped), diff) <= atol))


# ---------------------------------------------------------------------------------- SO(3)


def test_hat_vee_and_bracket():
    rng = np.random.default_rng(0)
    x, y = rng.normal(size=(2, 50, 3))
    np.testing.assert_allclose(hat(x) @ y[..., None], np.cross(x, y)[..., None], atol=1e-14)
    np.testing.assert_allclose(vee(hat(x)), x, atol=0)
    # [hat x, hat y] = hat(x × y): the bracket in coordinates is the cross product
    hx, hy = hat(x), hat(y)
    np.testing.assert_allclose(hx @ hy - hy @ hx, hat(SO3G.bracket(x, y)), atol=1e-13)


def test_exp_matches_matrix_exponential_and_scipy():
    rng = np.random.default_rng(1)
    v = rng.normal(size=(200, 3)) * rng.uniform(0, 3, size=(200, 1))
    r = SO3G.exp(v)
    np.testing.assert_allclose(r, Rotation.from_rotvec(v).as_matrix(), atol=1e-14)
    for k in range(5):
        np.testing.assert_allclose(r[k], expm(hat(v[k])), atol=1e-13)


@pytest.mark.parametrize(
    "angle",
    [
        0.0,
        1e-12,
        1e-9,
        1e-6,
        1e-4,
        0.01,
        0.5,
        1.0,
        2.0,
        2.4,
        2.6,
        3.0,
        np.pi - 1e-4,
        np.pi - 1e-6,
        np.pi - 1e-9,
        np.pi - 1e-12,
        np.pi,
    ],
)
def test_log_adversarial_angles(angle):
    rng = np.random.default_rng(2)
    axes = np.concatenate([np.eye(3), -np.eye(3), unit(np.ones((1, 3))), unit(rng.normal(size=(200, 3)))])
    v = axes * angle
    r = Rotation.from_rotvec(v).as_matrix()
    got = SO3G.log(r)
    assert rotvec_close(got, v, 1e-9)
    # and against scipy's own log on the same matrices
    assert rotvec_close(got, Rotation.from_matrix(r).as_rotvec(), 1e-9)
    # exp(log(R)) = R, whichever branch was returned at pi
    np.testing.assert_allclose(SO3G.exp(got), r, atol=1e-12)


@settings(max_examples=300, deadline=None)
@given(
    axis=st.lists(st.floats(-1, 1, allow_nan=False), min_size=3, max_size=3).filter(
        lambda a: np.linalg.norm(a) > 1e-3
    ),
    log_angle=st.floats(-12, np.log10(np.pi)),
    near_pi=st.booleans(),
)
def test_log_random_and_adversarial(axis, log_angle, near_pi):
    angle = 10.0**log_angle
    if near_pi:  # distance to pi from 1e-12 to ~pi
        angle = np.pi - min(angle, np.pi)
    v = unit(np.asarray(axis)) * angle
    r = Rotation.from_rotvec(v).as_matrix()
    assert rotvec_close(SO3G.log(r), v, 1e-9)


def test_log_exp_round_trip_batched_shapes():
    rng = np.random.default_rng(3)
    v = unit(rng.normal(size=(4, 5, 6, 3))) * rng.uniform(0, np.pi - 1e-3, size=(4, 5, 6, 1))
    np.testing.assert_allclose(SO3G.log(SO3G.exp(v)), v, atol=1e-12)
    assert SO3G.exp(v).shape == (4, 5, 6, 3, 3)
    assert SO3G.exp(v[0, 0, 0]).shape == (3, 3)


def test_log_matches_matrix_logarithm():
    rng = np.random.default_rng(4)
    for v in rng.normal(size=(5, 3)):
        r = SO3G.exp(v)
        np.testing.assert_allclose(hat(SO3G.log(r)), np.real(logm(r)), atol=1e-10)


def _fd_dexp(u, v, eps=1e-6):
    """Central difference of log(exp(u + e v) exp(u)^{-1}) / e: the right-trivialised dexp."""
    p = SO3G.difference(SO3G.exp(u), SO3G.exp(u + eps * v))
    m = SO3G.difference(SO3G.exp(u), SO3G.exp(u - eps * v))
    return (p - m) / (2 * eps)


@pytest.mark.parametrize("scale", [0.0, 1e-8, 1e-3, 0.009, 0.011, 0.5, 2.0, 3.0])
def test_dexp_against_finite_differences(scale):
    rng = np.random.default_rng(5)
    u = unit(rng.normal(size=(20, 3))) * scale
    v = rng.normal(size=(20, 3))
    np.testing.assert_allclose(SO3G.dexp(u, v), _fd_dexp(u, v), atol=2e-8)
    # the series of eq. 15 to high order as a second, independent reference
    hu = hat(u)
    series = np.zeros((20, 3, 3))
    term = np.broadcast_to(np.eye(3), (20, 3, 3)).copy()
    for k in range(40):
        series += term / np.prod(np.arange(1, k + 2, dtype=float))
        term = hu @ term
    np.testing.assert_allclose(SO3G.dexp(u, v), (series @ v[..., None])[..., 0], atol=1e-12)
    # dexp_u(u) = u, dexp_inv inverts dexp
    np.testing.assert_allclose(SO3G.dexp(u, u), u, atol=1e-14)
    np.testing.assert_allclose(SO3G.dexp_inv(u, SO3G.dexp(u, v)), v, atol=1e-11)


def test_dexp_duals_are_adjoints_for_weighted_inner_product():
    rng = np.random.default_rng(6)
    g = animation_group(4, joint_weights=[0.5, 1.0, 2.0, 3.0], translation_weight=7.0)
    u = rng.normal(size=(10, g.dim))
    a, b = rng.normal(size=(2, 10, g.dim))
    np.testing.assert_allclose(
        g.inner(g.dexp_inv(u, a), b), g.inner(a, g.dexp_inv_dual(u, b)), rtol=1e-12, atol=1e-12
    )
    np.testing.assert_allclose(
        g.inner(g.dexp(u, a), b), g.inner(a, g.dexp_dual(u, b)), rtol=1e-12, atol=1e-12
    )
    x = g.exp(rng.normal(size=(10, g.dim)))
    np.testing.assert_allclose(g.inner(g.adjoint(x, a), b), g.inner(a, g.adjoint_dual(x, b)), rtol=1e-12)
    # the bi-invariant case of Cor. 4.8: (dexp_u^{-1})^† u = u
    np.testing.assert_allclose(g.dexp_inv_dual(u, u), u, atol=1e-12)


def test_adjoint_conjugates_exponentials():
    rng = np.random.default_rng(7)
    r = SO3G.exp(rng.normal(size=(10, 3)))
    v = rng.normal(size=(10, 3))
    lhs = SO3G.exp(SO3G.adjoint(r, v))
    rhs = r @ SO3G.exp(v) @ np.swapaxes(r, -1, -2)
    np.testing.assert_allclose(lhs, rhs, atol=1e-13)


def test_project_and_check_points():
    rng = np.random.default_rng(8)
    r = SO3G.exp(rng.normal(size=(30, 3)))
    noisy = r + rng.normal(scale=1e-4, size=r.shape)  # as read from a file with 4 digits
    fixed = SO3G.check_points(noisy, "rotations")
    np.testing.assert_allclose(
        np.swapaxes(fixed, -1, -2) @ fixed, np.broadcast_to(np.eye(3), r.shape), atol=1e-13
    )
    np.testing.assert_allclose(np.linalg.det(fixed), 1.0, atol=1e-13)
    assert np.abs(fixed - r).max() < 1e-3
    # the projection is the closest rotation: closer than the original rotation itself
    assert np.all(
        np.linalg.norm(fixed - noisy, axis=(1, 2)) <= np.linalg.norm(r - noisy, axis=(1, 2)) + 1e-15
    )
    # exact rotations pass through untouched
    np.testing.assert_array_equal(SO3G.check_points(r, "r"), r)
    # one matrix, not a stack: the same projection (a reflection's det fixed to +1)
    np.testing.assert_allclose(SO3G.project(noisy[3]), SO3G.project(noisy)[3], atol=1e-15)
    assert np.linalg.det(SO3G.project(-r[0])) == pytest.approx(1.0)
    bad = r.copy()
    bad[7] *= 1.5
    with pytest.raises(ValueError, match=r"rotations: .*index \(7,\)"):
        SO3G.check_points(bad, "rotations")
    refl = r.copy()
    refl[3] = -refl[3]
    with pytest.raises(ValueError, match=r"det"):
        SO3G.check_points(refl, "rotations")


def test_accumulate_matches_loop():
    rng = np.random.default_rng(9)
    steps = SO3G.exp(rng.normal(size=(20, 4, 3)) * 0.3)
    start = SO3G.exp(rng.normal(size=(4, 3)))
    out = PowerGroup(SO3G, 4).accumulate(steps, start)
    ref = [start]
    for s in steps:
        ref.append(s @ ref[-1])
    np.testing.assert_allclose(out, np.stack(ref), atol=1e-13)
    e = Euclidean(2)
    np.testing.assert_allclose(
        e.accumulate(np.ones((3, 2)), np.array([1.0, 2.0])), [[1, 2], [2, 3], [3, 4], [4, 5]]
    )


# ----------------------------------------------------------------------- products, weights


def test_product_split_join_and_exp_log():
    rng = np.random.default_rng(10)
    g = animation_group(5, joint_weights=np.arange(1, 6), translation_weight=0.25)
    assert g.dim == 3 + 15 and g.point_shape == (3 + 45,)
    np.testing.assert_array_equal(g.weights, np.r_[np.full(3, 0.25), np.repeat(np.arange(1, 6), 3)])
    v = rng.normal(size=(7, g.dim))
    p = g.exp(v)
    trans, rots = g.split_points(p)
    assert trans.shape == (7, 3) and rots.shape == (7, 5, 3, 3)
    np.testing.assert_allclose(trans, v[:, :3])
    np.testing.assert_allclose(rots, SO3G.exp(v[:, 3:].reshape(7, 5, 3)), atol=1e-15)
    np.testing.assert_array_equal(g.join_points([trans, rots]), p)
    np.testing.assert_allclose(g.log(p), v, atol=1e-12)
    # compose/inverse: p p^{-1} = e
    np.testing.assert_allclose(g.compose(p, g.inverse(p)), np.broadcast_to(g.identity(), p.shape), atol=1e-14)
    # weighted norm: translation weight 0.25, joint k weight k+1
    expected = 0.25 * np.sum(v[:, :3] ** 2, 1) + np.sum(
        np.arange(1, 6)[None, :] * np.sum(v[:, 3:].reshape(7, 5, 3) ** 2, -1), 1
    )
    np.testing.assert_allclose(g.norm(v) ** 2, expected)
    np.testing.assert_allclose(np.sum(g.to_orthonormal(v) ** 2, -1), expected)


def test_weighted_mean_of_two_points_is_geodesic_point():
    rng = np.random.default_rng(11)
    g = animation_group(3)
    p = g.exp(rng.normal(size=(2, g.dim)))
    for s in (0.0, 0.3, 1.0):
        m = g.weighted_mean(p, [1 - s, s])
        np.testing.assert_allclose(m, g.interpolate(p[0], p[1], s), atol=1e-12)


def test_bad_arguments_name_themselves():
    with pytest.raises(ValueError, match="weights: expected one weight per copy"):
        PowerGroup(SO3G, 3, weights=[1.0, 2.0])
    with pytest.raises(ValueError, match="weight"):
        SO3(weight=-1)
    with pytest.raises(ValueError, match="d: expected a positive integer"):
        Euclidean(0)
    with pytest.raises(ValueError, match=r"x: expected an array of shape \(\.\.\., 3\)"):
        hat(np.zeros((4, 2)))
    with pytest.raises(ValueError, match="factors"):
        ProductGroup([])
    with pytest.raises(ValueError, match="values: expected finite"):
        Euclidean(2).check_points([[0.0, np.nan]], "values")


def test_so3_dexp_matrix_is_dexp():
    """One home for dexp's closed form: the matrix applies like dexp itself, across the
    series threshold and up to 2 pi; and it is the derivative of exp (finite differences)."""
    rng = np.random.default_rng(7)
    g = SO3()
    angles = np.array([0.0, 1e-9, 1e-3, 0.99e-2, 1.01e-2, 0.5, 2.0, np.pi - 1e-6, 5.0])
    axes = rng.normal(size=(angles.size, 3))
    u = axes / np.linalg.norm(axes, axis=1, keepdims=True) * angles[:, None]
    v = rng.normal(size=u.shape)
    mats = g.dexp_matrix(u)
    np.testing.assert_allclose(np.einsum("kij,kj->ki", mats, v), g.dexp(u, v), atol=1e-14)
    k = 6  # d/de exp(u + e v) exp(u)^-1 = hat(dexp_u v)
    eps = 1e-6
    d = (g.exp(u[k] + eps * v[k]) - g.exp(u[k] - eps * v[k])) / (2 * eps) @ g.exp(u[k]).T
    np.testing.assert_allclose(vee(d), mats[k] @ v[k], atol=1e-8)
