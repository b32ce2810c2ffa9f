"""The general elastic metric G^{a,b} for curves in R^d, d >= 2: the cone construction of
Bauer, Charon, Klassen, Kurtek, Needham & Pierron (2024) (issue 33)."""

from __future__ import annotations

import numpy as np
import pytest

from elastic_motion.curves import (
    DiscreteCurve,
    SRVFunction,
    common_refinement,
    reparametrize_srv,
    srv_transform,
)
from elastic_motion.elastic_metrics import (
    ab_cone_inverse,
    ab_cone_transform,
    cone_distance2,
    cone_warp_distance,
    elastic_ab_distance,
    elastic_ab_distance_rd,
    elastic_ab_geodesic,
)
from elastic_motion.groups import Euclidean
from elastic_motion.warp import optimal_warp


def helix(n, k=2.0, r=0.3, rise=1.0, phase=0.0):
    t = np.linspace(0, 1, n + 1)
    return np.column_stack([r * np.cos(k * np.pi * t + phase), r * np.sin(k * np.pi * t + phase), rise * t])


def wiggle(n, k=3.0, amp=0.25, grow=0.0):
    t = np.linspace(0, 1, n + 1)
    return np.column_stack([t, amp * np.sin(k * np.pi * t) * (1 + grow * t)])


def gab_norm2(c, h, a, b, t=None):
    """G^{a,b}_c(h, h) of paper 001, eq. 4, written from its definition for a polyline in R^d:
    int a^2 |D_s h - <D_s h, v> v|^2 + b^2 <D_s h, v>^2 ds (the normal part in R^d)."""
    t = np.linspace(0, 1, len(c)) if t is None else t
    vel = np.diff(c, axis=0) / np.diff(t)[:, None]
    speed = np.linalg.norm(vel, axis=1)
    tan = vel / speed[:, None]
    dsh = (np.diff(h, axis=0) / np.diff(t)[:, None]) / speed[:, None]
    tang = np.sum(dsh * tan, axis=1)
    nor2 = np.sum(dsh**2, axis=1) - tang**2
    return float(np.sum((a**2 * nor2 + b**2 * tang**2) * speed * np.diff(t)))


def rotation(seed):
    q, r = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


C0, C1 = helix(60), helix(60, k=3, r=0.4, rise=0.8, phase=0.5)
AB = [(1.0, 0.5), (0.5, 1.0), (1.0, 1.0), (2.0, 0.5)]


def test_a_3d_curve_is_accepted_distance_and_geodesic():
    """On main a 3-D curve was refused ("expected plane curve samples of shape (n+1, 2)")."""
    r = elastic_ab_distance(C0, C1, 0.5, 1.0)
    assert r.construction == "cone" and r.dim == 3 and np.isfinite(r.distance) and r.distance > 0.1
    t = np.linspace(0, 1, 61)
    np.testing.assert_allclose(elastic_ab_geodesic(r, 0.0, t_out=t), C0 - C0[0], atol=1e-12)
    phi = np.interp(t, r.warp.vertices[:, 0], r.warp.vertices[:, 1])
    c1_phi = np.column_stack([np.interp(phi, t, C1[:, k]) for k in range(3)]) - C1[0]
    np.testing.assert_allclose(elastic_ab_geodesic(r, 1.0, t_out=t), c1_phi, atol=1e-9)


def test_srv_case_in_r3():
    """a = 1, b = 1/2: the transform is the SRVT (zero last column) and the distance the SRV one."""
    q, _ = ab_cone_transform(C0, 1.0, 0.5)
    srv0 = srv_transform(DiscreteCurve(C0, Euclidean(3))).q
    srv1 = srv_transform(DiscreteCurve(C1, Euclidean(3))).q
    np.testing.assert_allclose(q[:, :3], srv0, atol=1e-13)
    np.testing.assert_allclose(q[:, 3], 0.0, atol=1e-13)
    for method in ("dp", "dp+refine"):
        r = elastic_ab_distance(C0, C1, 1.0, 0.5, method=method)
        assert r.distance == pytest.approx(optimal_warp(srv0, srv1, method=method).distance, rel=1e-9)


@pytest.mark.parametrize(("a", "b"), [(1.0, 0.5), (0.5, 1.0), (1.0, 1.0), (0.3, 2.0)])
def test_pullback_of_the_cone_transform_is_gab(a, b):
    """|dF(h)|^2 by central differences = G^{a,b}_c(h, h) written from its definition."""
    rng = np.random.default_rng(1)
    c = helix(40, k=2.5, r=0.4)
    h = rng.normal(size=c.shape)
    eps = 1e-6
    dq = (ab_cone_transform(c + eps * h, a, b)[0] - ab_cone_transform(c - eps * h, a, b)[0]) / (2 * eps)
    lhs = float(np.sum(dq**2) / 40)
    assert lhs == pytest.approx(gab_norm2(c, h, a, b), rel=1e-6)


@pytest.mark.parametrize(("a", "b"), [(0.5, 1.0), (2.0, 0.5), (3.0, 0.4)])
def test_pullback_of_the_metric_cone_is_gab_for_every_a_b(a, b):
    """d_C(F(c + eps h), F(c - eps h))^2 / (2 eps)^2 -> G^{a,b}(h, h), a > 2b included."""
    rng = np.random.default_rng(2)
    c = helix(40, k=2.5, r=0.4)
    h = rng.normal(size=c.shape)
    eps = 1e-5
    d2 = cone_warp_distance(c - eps * h, c + eps * h, a, b, [[0.0, 0.0], [1.0, 1.0]]) ** 2
    assert d2 / (2 * eps) ** 2 == pytest.approx(gab_norm2(c, h, a, b), rel=1e-4)


@pytest.mark.parametrize(
    ("a", "b", "c1"), [(0.5, 1.0, C1), (1.0, 1.0, C1), (2.0, 0.5, helix(60, k=2.3, r=0.35))]
)
def test_geodesic_length_in_gab_is_the_distance(a, b, c1):
    """The G^{a,b} length of the geodesic (the metric integrated along the path, with no use
    of the transform) equals the reported distance.  (For a > 2b the pair is chosen with
    matched tangents less than pi / lambda apart: a geodesic through the cone's apex leaves
    the immersions, where G^{a,b} is singular.)"""
    r = elastic_ab_distance(C0, c1, a, b)
    grid = _merged_grid(r)
    s = np.linspace(0.0, 1.0, 201)
    path = [elastic_ab_geodesic(r, x) for x in s]
    length = 0.0
    for k in range(len(s) - 1):
        mid = elastic_ab_geodesic(r, 0.5 * (s[k] + s[k + 1]))
        length += np.sqrt(gab_norm2(mid, path[k + 1] - path[k], a, b, t=grid))
    assert length == pytest.approx(r.distance, rel=1e-4)


def _merged_grid(r):
    dd = r.q1.shape[1]
    moved = reparametrize_srv(SRVFunction(r.q1, r.t1, np.zeros(dd), Euclidean(dd)), r.warp.vertices)
    return common_refinement([(r.q0, r.t0), (moved.q, moved.t)])[0]


@pytest.mark.parametrize(("a", "b"), AB)
def test_invariances_rotation_translation_reparametrisation(a, b):
    d = elastic_ab_distance(C0, C1, a, b).distance
    rot = rotation(3)
    moved = (C0 @ rot.T, C1 @ rot.T + [1.0, -2.0, 0.5])
    # the DP on the grid is invariant to rounding; the refinement off the grid stops at its
    # relative energy tolerance, where the last bits of a rotated input may leave it elsewhere
    assert elastic_ab_distance(*moved, a, b, method="dp").distance == pytest.approx(
        elastic_ab_distance(C0, C1, a, b, method="dp").distance, rel=1e-9
    )
    assert elastic_ab_distance(*moved, a, b).distance == pytest.approx(d, rel=1e-5)
    # c1 o gamma: the same samples on other parameters; the distance to c1 is 0, to c0 unchanged
    tg = np.linspace(0, 1, 61) ** 1.3
    assert elastic_ab_distance(C1, C1, a, b, t1=tg).distance < 1e-6
    # unchanged up to the solver: its DP grids (the break points) differ
    assert elastic_ab_distance(C0, C1, a, b, t1=tg).distance == pytest.approx(d, rel=2e-2)


def test_srv_action_of_the_transform():
    """F(c o gamma) = sqrt(gamma') F(c) o gamma (so elastic_motion.warp applies)."""
    t = np.linspace(0, 1, 41)
    tg = t**1.7  # c o gamma has the samples c[i] at parameters tg[i]: gamma(tg[i]) = t[i]
    c = helix(40, k=2.5, r=0.4)
    q, _ = ab_cone_transform(c, 0.5, 1.0)
    moved = reparametrize_srv(SRVFunction(q, t, np.zeros(4), Euclidean(4)), np.column_stack([tg, t]))
    np.testing.assert_allclose(moved.t, tg, atol=1e-14)
    np.testing.assert_allclose(moved.q, ab_cone_transform(c, 0.5, 1.0, t=tg)[0], atol=1e-12)


def test_d2_the_planar_path_is_kept_and_the_cone_agrees_with_it():
    c0, c1 = wiggle(80), wiggle(80, k=2, grow=0.3)
    for a, b in [(1.0, 0.5), (0.5, 1.0), (0.4, 0.5)]:
        planar = elastic_ab_distance(c0, c1, a, b)
        assert planar.construction == "planar" and planar.q0.shape == (80, 2)
        # at the planar warp the cone distance is the planar F_{a,b} one (small turning: no lift)
        assert cone_warp_distance(c0, c1, a, b, planar.warp.vertices) == pytest.approx(
            planar.distance, rel=1e-9
        )
    cone = elastic_ab_distance_rd(c0, c1, 1.0, 0.5, method="dp")
    assert cone.distance == pytest.approx(
        elastic_ab_distance(c0, c1, 1.0, 0.5, method="dp").distance, rel=1e-9
    )


def test_inverse_and_cone_distance():
    c = helix(50)
    q, t = ab_cone_transform(c, 0.5, 1.0)
    np.testing.assert_allclose(ab_cone_inverse(q, 0.5, 1.0, t, start=c[0]), c, atol=1e-12)
    u = np.array([[1.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    w = np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])
    # lambda = 1/2: a right angle develops to pi/4; opposite tangents to pi/2
    np.testing.assert_allclose(cone_distance2([1.0, 1.0], u, [1.0, 1.0], w, 0.5), [2 - np.sqrt(2), 2.0])
    # lambda = 2: opposite tangents go through the apex
    np.testing.assert_allclose(cone_distance2([1.0, 1.0], u, [1.0, 2.0], w, 2.0), [4.0, 9.0])


def test_bad_input():
    with pytest.raises(ValueError, match="a <= 2b"):
        ab_cone_transform(C0, 2.0, 0.5)
    with pytest.raises(ValueError, match="same R"):
        elastic_ab_distance(C0, np.column_stack([C1, C1[:, :1]]), 1.0, 0.5)
    with pytest.raises(ValueError, match="positive finite weight"):
        elastic_ab_distance(C0, C1, 0.0, 0.5)
    with pytest.raises(ValueError, match="length 0"):
        elastic_ab_distance(np.ones((5, 3)), C1, 1.0, 0.5)


@pytest.mark.parametrize(("a", "b"), [(1.0, 1.0), (2.0, 0.5)])
def test_the_warp_minimises_the_exact_cone_energy(a, b):
    """The solver runs on factors of the cone's cross term: no small change of the warp found
    lowers the exact distance (the chordal F_{a,b} warp is 0.4-5 % off on these curves)."""
    r = elastic_ab_distance(C0, C1, a, b)
    v = r.warp.vertices
    rng = np.random.default_rng(4)
    for _ in range(20):
        w = v.copy()
        w[1:-1, 1] += 2e-3 * rng.normal(size=len(v) - 2) * np.minimum(np.diff(v[:-1, 1]), np.diff(v[1:, 1]))
        assert cone_warp_distance(C0, C1, a, b, w) >= r.distance * (1 - 1e-9)
    if a <= 2 * b:  # the warp of the chordal distance of the R^(d+1) transform: worse
        q0, q1 = ab_cone_transform(C0, a, b)[0], ab_cone_transform(C1, a, b)[0]
        chordal = optimal_warp(q0, q1).vertices
        assert cone_warp_distance(C0, C1, a, b, chordal) > r.distance * 1.002
