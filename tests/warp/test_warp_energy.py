"""warp_energy: the one exact scoring function of the discrete objective, and warp algebra."""

from __future__ import annotations

import numpy as np
import pytest

from elastic_motion.curves import SRVFunction, reparametrize_srv
from elastic_motion.groups import Euclidean
from elastic_motion.warp import (
    compose_warps,
    identity_energy,
    invert_warp,
    shift_seed,
    warp_at,
    warp_energy,
)


def random_grid(n: int, rng: np.random.Generator) -> np.ndarray:
    w = rng.uniform(0.3, 1.7, n)
    t = np.concatenate([[0.0], np.cumsum(w) / w.sum()])
    t[-1] = 1.0
    return t


def random_warp(k: int, rng: np.random.Generator) -> np.ndarray:
    x = np.concatenate([[0.0], np.sort(rng.uniform(0, 1, k)), [1.0]])
    y = np.concatenate([[0.0], np.sort(rng.uniform(0, 1, k)), [1.0]])
    return np.column_stack([x, y])


def quadrature(q0, t0, q1, t1, v, m=400_000):
    """Independent check: midpoint rule on a fine uniform sampling of the integrand."""
    s = (np.arange(m) + 0.5) / m
    x, y = v[:, 0], v[:, 1]
    piece = np.clip(np.searchsorted(x, s, side="right") - 1, 0, len(x) - 2)
    slope = (y[piece + 1] - y[piece]) / (x[piece + 1] - x[piece])
    phi = np.interp(s, x, y)
    a = np.clip(np.searchsorted(t0, s, side="right") - 1, 0, len(q0) - 1)
    b = np.clip(np.searchsorted(t1, phi, side="right") - 1, 0, len(q1) - 1)
    r = q0[a] - np.sqrt(slope)[:, None] * q1[b]
    return float(np.mean(np.einsum("ij,ij->i", r, r)))


def test_warp_energy_matches_fine_quadrature():
    rng = np.random.default_rng(1)
    for n0, n1, d, k in [(7, 5, 3, 3), (20, 31, 2, 6), (13, 13, 5, 0)]:
        t0, t1 = random_grid(n0, rng), random_grid(n1, rng)
        q0, q1 = rng.normal(size=(n0, d)), rng.normal(size=(n1, d))
        v = random_warp(k, rng)
        exact = warp_energy(q0, q1, v, t0, t1)
        approx = quadrature(q0, t0, q1, t1, v)
        assert exact == pytest.approx(approx, rel=2e-3)


def test_identity_warp_gives_l2_distance():
    rng = np.random.default_rng(2)
    t = random_grid(40, rng)
    q0, q1 = rng.normal(size=(40, 4)), rng.normal(size=(40, 4))
    expected = float(np.sum(np.sum((q0 - q1) ** 2, axis=1) * np.diff(t)))
    e = warp_energy(q0, q1, [[0.0, 0.0], [1.0, 1.0]], t, t)
    assert e == pytest.approx(expected, rel=1e-12)
    assert identity_energy(q0, q1, t, t) == pytest.approx(expected, rel=1e-12)


def test_energy_equals_distance_to_exactly_warped_srv():
    """E(phi) = ||q0 - q1 * phi||^2 with the action of the curves layer (independent route)."""
    rng = np.random.default_rng(3)
    n0, n1, d = 17, 23, 3
    t0, t1 = random_grid(n0, rng), random_grid(n1, rng)
    q0, q1 = rng.normal(size=(n0, d)), rng.normal(size=(n1, d))
    v = random_warp(5, rng)
    warped = reparametrize_srv(SRVFunction(q1, t1, np.zeros(d), Euclidean(d)), v)
    # ||q0 - q1*phi||^2 on the merged grid of t0 and warped.t
    tm = np.union1d(t0, warped.t)
    mid = 0.5 * (tm[1:] + tm[:-1])
    a = np.searchsorted(t0, mid, side="right") - 1
    b = np.searchsorted(warped.t, mid, side="right") - 1
    r = q0[a] - warped.q[b]
    expected = float(np.sum(np.einsum("ij,ij->i", r, r) * np.diff(tm)))
    assert warp_energy(q0, q1, v, t0, t1) == pytest.approx(expected, rel=1e-10)


def test_flat_piece_and_srv_function_input():
    rng = np.random.default_rng(4)
    q0, q1 = rng.normal(size=(10, 2)), rng.normal(size=(12, 2))
    v = np.array([[0.0, 0.0], [0.3, 0.4], [0.5, 0.4], [1.0, 1.0]])  # flat on [0.3, 0.5]
    e = warp_energy(q0, q1, v)
    assert e == pytest.approx(quadrature(q0, np.linspace(0, 1, 11), q1, np.linspace(0, 1, 13), v), rel=2e-3)
    s0 = SRVFunction(q0, np.linspace(0, 1, 11), np.zeros(2), Euclidean(2))
    s1 = SRVFunction(q1, np.linspace(0, 1, 13), np.zeros(2), Euclidean(2))
    assert warp_energy(s0, s1, v) == e


def test_invert_and_compose():
    rng = np.random.default_rng(5)
    a, b = random_warp(4, rng), random_warp(6, rng)
    s = np.linspace(0, 1, 101)
    ab = compose_warps(a, b)
    np.testing.assert_allclose(warp_at(ab, s), warp_at(a, warp_at(b, s)), atol=1e-12)
    ident = compose_warps(invert_warp(a), a)
    np.testing.assert_allclose(warp_at(ident, s), s, atol=1e-12)
    # the action composes: (q * a) * b = q * (a o b)
    q, t = rng.normal(size=(9, 2)), np.linspace(0, 1, 10)
    g = Euclidean(2)
    qa = reparametrize_srv(SRVFunction(q, t, np.zeros(2), g), a)
    qab = reparametrize_srv(qa, b)
    direct = reparametrize_srv(SRVFunction(q, t, np.zeros(2), g), ab)
    x = (np.arange(999) + 0.5) / 999
    vals1 = qab.q[np.searchsorted(qab.t, x, side="right") - 1]
    vals2 = direct.q[np.searchsorted(direct.t, x, side="right") - 1]
    np.testing.assert_allclose(vals1, vals2, atol=1e-9)
    with pytest.raises(ValueError, match="flat"):
        invert_warp([[0, 0], [0.5, 0.5], [0.7, 0.5], [1, 1]])


def test_shift_seed_is_a_cyclic_rotation():
    rng = np.random.default_rng(6)
    q, t = rng.normal(size=(8, 2)), random_grid(8, rng)
    qs, ts = shift_seed(q, t, 0.37)
    x = (np.arange(1000) + 0.5) / 1000
    lhs = qs[np.searchsorted(ts, x, side="right") - 1]
    rhs = q[np.searchsorted(t, (x + 0.37) % 1.0, side="right") - 1]
    np.testing.assert_array_equal(lhs, rhs)
