"""General elastic metrics G^{a,b} through the F_{a,b} transform (issue 13)."""

from __future__ import annotations

import numpy as np
import pytest

from elastic_motion.curves import DiscreteCurve, srv_transform
from elastic_motion.elastic_metrics import ab_inverse, ab_transform, elastic_ab_distance, elastic_ab_geodesic
from elastic_motion.groups import Euclidean
from elastic_motion.warp import optimal_warp


def wiggle(n, k=3.0, amp=0.25, grow=0.0):
    t = np.linspace(0, 1, n + 1)
    return np.column_stack([t, amp * np.sin(k * np.pi * t) * (1 + grow * t)])


def test_a1_b_half_is_the_srv_transform_and_distance():
    c0, c1 = wiggle(80), wiggle(80, k=2, grow=0.3)
    q, _ = ab_transform(c0, 1.0, 0.5)
    np.testing.assert_allclose(q, srv_transform(DiscreteCurve(c0, Euclidean(2))).q, atol=1e-13)
    r = elastic_ab_distance(c0, c1, 1.0, 0.5)
    s0 = srv_transform(DiscreteCurve(c0, Euclidean(2))).q
    s1 = srv_transform(DiscreteCurve(c1, Euclidean(2))).q
    assert r.distance == pytest.approx(optimal_warp(s0, s1).distance, rel=5e-4)  # dp+refine: a local polish
    exact = elastic_ab_distance(c0, c1, 1.0, 0.5, method="dp").distance
    assert exact == pytest.approx(optimal_warp(s0, s1, method="dp").distance, rel=1e-12)


@pytest.mark.parametrize(("a", "b"), [(1.0, 0.5), (2.0, 0.3), (0.5, 1.0), (1.0, 1.0)])
def test_pullback_of_l2_is_the_elastic_metric(a, b):
    """|dF(h)|^2 = int a^2 <D_s h, n>^2 + b^2 <D_s h, v>^2 ds (paper 001, eq. 4), by finite
    differences of F against the metric written from its definition."""
    rng = np.random.default_rng(0)
    c = wiggle(40, k=2.5, amp=0.4)
    t = np.linspace(0, 1, 41)
    h = rng.normal(size=c.shape)
    eps = 1e-6
    dq = (ab_transform(c + eps * h, a, b)[0] - ab_transform(c - eps * h, a, b)[0]) / (2 * eps)
    lhs = np.sum(np.sum(dq**2, axis=1) * np.diff(t))
    vel = np.diff(c, axis=0) / np.diff(t)[:, None]
    speed = np.linalg.norm(vel, axis=1)
    tan = vel / speed[:, None]
    nor = np.column_stack([-tan[:, 1], tan[:, 0]])
    dsh = (np.diff(h, axis=0) / np.diff(t)[:, None]) / speed[:, None]  # D_s h per cell
    ds = speed * np.diff(t)
    rhs = np.sum((a**2 * np.sum(dsh * nor, 1) ** 2 + b**2 * np.sum(dsh * tan, 1) ** 2) * ds)
    assert lhs == pytest.approx(rhs, rel=1e-6)


def test_norm_is_length_and_inverse_round_trip():
    c = wiggle(200, k=3.3, amp=0.4)  # turning < pi / lambda per cell: the lift is continuous
    for a, b in [(1.0, 0.5), (3.0, 0.5), (0.4, 2.0)]:
        q, t = ab_transform(c, a, b)
        length = np.sum(np.linalg.norm(np.diff(c, axis=0), axis=1))
        assert np.sum(np.sum(q**2, axis=1) * np.diff(t)) == pytest.approx(4 * b**2 * length, rel=1e-12)
        th0 = np.arctan2(*(c[1] - c[0])[::-1])
        np.testing.assert_allclose(ab_inverse(q, a, b, t, start=c[0], theta0=th0), c, atol=1e-12)


def test_match_changes_with_a_over_b_and_geodesic_ends():
    c0, c1 = wiggle(100), wiggle(100, k=2, grow=0.3)
    res = {ab: elastic_ab_distance(c0, c1, *ab) for ab in [(1.0, 0.5), (4.0, 0.5), (0.25, 0.5)]}
    phis = [r.warp.phi for r in res.values()]
    assert np.abs(phis[0] - phis[1]).max() > 0.01 and np.abs(phis[0] - phis[2]).max() > 0.01
    r = res[(4.0, 0.5)]
    g0 = elastic_ab_geodesic(r, 0.0, t_out=np.linspace(0, 1, 101))
    np.testing.assert_allclose(g0, c0 - c0[0], atol=1e-12)


def test_bad_input():
    c = wiggle(40)
    for a, b in [(0.0, 0.5), (-1.0, 0.5), (1.0, 0.0), (1.0, -2.0), (np.nan, 0.5), (1.0, np.inf)]:
        with pytest.raises(ValueError, match="positive finite weight"):
            ab_transform(c, a, b)
    with pytest.raises(ValueError, match="length 0"):
        ab_transform(np.ones((5, 2)), 1.0, 0.5)
    with pytest.raises(ValueError, match=r"\(n\+1, 2\)"):
        ab_transform(np.ones((5, 3)), 1.0, 0.5)
    rep = np.insert(c, 4, c[4], axis=0)  # a repeated sample: one cell with q = 0
    q, _ = ab_transform(rep, 2.0, 0.5)
    assert np.isfinite(q).all() and (np.linalg.norm(q, axis=1) == 0).sum() == 1
    th0 = np.arctan2(*(rep[1] - rep[0])[::-1])
    np.testing.assert_allclose(ab_inverse(q, 2.0, 0.5, start=rep[0], theta0=th0), rep, atol=1e-12)
