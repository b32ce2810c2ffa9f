"""Tests of discrete curves and the SRV transform: round trips, invariances, known values."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from elastic_motion.curves import (
    DiscreteCurve,
    SRVFunction,
    blend,
    curve_distance,
    inverse_srv_transform,
    reparametrize_curve,
    reparametrize_srv,
    srv_distance,
    srv_transform,
    weighted_blend,
)
from elastic_motion.groups import SO3, Euclidean, PowerGroup, animation_group

GROUPS = {
    "R3": Euclidean(3),
    "R5-weighted": Euclidean(5, weight=[1, 2, 3, 4, 5]),
    "SO3": SO3(),
    "SO3^4": PowerGroup(SO3(), 4, weights=[1.0, 0.5, 2.0, 3.0]),
    "R3xSO3^6": animation_group(6, joint_weights=np.linspace(0.5, 2, 6), translation_weight=4.0),
}


def smooth_curve(group, n, seed=0, t=None, amp=1.0):
    """A smooth random curve: exp of a sum of sines, sampled at ``t``."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 1, n) if t is None else t
    coef = rng.normal(size=(4, group.dim)) * amp
    v = sum(coef[k] * np.sin((k + 1) * np.pi * t[:, None] + k) for k in range(4)) / 2
    return DiscreteCurve(group.exp(v), group, t)


def random_grid(n, seed):
    rng = np.random.default_rng(seed)
    steps = rng.uniform(0.2, 1.0, n - 1)
    t = np.concatenate([[0], np.cumsum(steps)])
    t /= t[-1]
    t[-1] = 1.0
    return t


@pytest.mark.parametrize("name", GROUPS)
def test_srv_round_trip_is_exact(name):
    g = GROUPS[name]
    c = smooth_curve(g, 200, t=random_grid(200, 1))
    srv = srv_transform(c)
    assert srv.q.shape == (199, g.dim)
    back = inverse_srv_transform(srv)
    scale = np.abs(c.values).max()
    np.testing.assert_allclose(back.values, c.values, rtol=0, atol=1e-12 * scale)
    np.testing.assert_array_equal(back.t, c.t)
    # and the other way round: R(R^{-1}(q)) = q
    np.testing.assert_allclose(srv_transform(back).q, srv.q, atol=1e-11)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 10_000), n=st.integers(2, 40), stand_still=st.integers(0, 5))
def test_srv_round_trip_with_standing_still(seed, n, stand_still):
    g = GROUPS["R3xSO3^6"]
    rng = np.random.default_rng(seed)
    values = smooth_curve(g, n, seed=seed, amp=rng.uniform(0.1, 2)).values.copy()
    for _ in range(stand_still):  # repeat samples: intervals where nothing moves
        i = int(rng.integers(0, n - 1))
        values[i + 1] = values[i]
    c = DiscreteCurve(values, g)
    srv = srv_transform(c)
    assert np.isfinite(srv.q).all()
    still = np.all(values[1:] == values[:-1], axis=1)
    np.testing.assert_array_equal(srv.q[still], 0.0)
    np.testing.assert_allclose(inverse_srv_transform(srv).values, values, atol=1e-12)


def test_srv_of_straight_line_is_constant():
    # c(t) = a + t v in R^3: xi = v, q = v / sqrt|v|
    a, v = np.array([1.0, -2.0, 0.5]), np.array([3.0, 4.0, 0.0])
    t = random_grid(30, 2)
    c = DiscreteCurve(a + t[:, None] * v, Euclidean(3), t)
    q = srv_transform(c).q
    np.testing.assert_allclose(q, np.broadcast_to(v / np.sqrt(5.0), q.shape), atol=1e-12)
    # weights enter as orthonormal coordinates sqrt(w) xi / sqrt(|xi|_w)
    w = np.array([4.0, 1.0, 9.0])
    cw = DiscreteCurve(c.values, Euclidean(3, weight=w), t)
    xi = np.sqrt(w) * v
    np.testing.assert_allclose(srv_transform(cw).q[0], xi / np.sqrt(np.linalg.norm(xi)), atol=1e-12)


def test_srv_of_one_parameter_subgroup_in_so3():
    # c(t) = exp(t w) R0 rotates at constant angular velocity w: q = w / sqrt|w| (weight 1)
    w = np.array([0.3, -1.2, 2.0])
    r0 = SO3().exp(np.array([0.1, 0.2, 0.3]))
    t = np.linspace(0, 1, 50)
    c = DiscreteCurve(SO3().exp(t[:, None] * w) @ r0, SO3(), t)
    np.testing.assert_allclose(
        srv_transform(c).q, np.broadcast_to(w / np.linalg.norm(w) ** 0.5, (49, 3)), atol=1e-12
    )
    # with weight 4 the norm doubles: q = 2 w / sqrt(2 |w|)
    c4 = DiscreteCurve(c.values, SO3(weight=4.0), t)
    np.testing.assert_allclose(srv_transform(c4).q[0], 2 * w / np.sqrt(2 * np.linalg.norm(w)), atol=1e-12)


@pytest.mark.parametrize("name", ["SO3", "SO3^4", "R3xSO3^6", "R3"])
def test_srv_right_translation_invariance(name):
    # Lemma 3.6: R(c g) = R(c) for a constant g
    g = GROUPS[name]
    c = smooth_curve(g, 60, seed=3)
    h = g.exp(np.random.default_rng(4).normal(size=g.dim))
    shifted = DiscreteCurve(g.compose(c.values, h), g, c.t)
    np.testing.assert_allclose(srv_transform(shifted).q, srv_transform(c).q, atol=1e-12)
    # ... but not left translation invariance for non-abelian groups (a real check that
    # compose's argument order is right)
    if name.startswith("SO3"):
        left = DiscreteCurve(g.compose(h, c.values), g, c.t)
        assert np.abs(srv_transform(left).q - srv_transform(c).q).max() > 1e-3


def _pl_warp():
    return np.array([[0.0, 0.0], [0.3, 0.15], [0.55, 0.6], [1.0, 1.0]])


@pytest.mark.parametrize("name", ["R3", "SO3^4", "R3xSO3^6"])
def test_distance_invariance_under_common_warp_converges(name):
    g = GROUPS[name]
    phi = _pl_warp()
    errors = []
    for n in (50, 100, 200, 400, 800):
        c0, c1 = smooth_curve(g, n, seed=5), smooth_curve(g, n, seed=6)
        d = curve_distance(c0, c1)
        dw = curve_distance(reparametrize_curve(c0, phi), reparametrize_curve(c1, phi))
        errors.append(abs(dw - d) / d)
    errors = np.array(errors)
    # resampling error shrinks with the grid, roughly first order or better
    assert np.all(np.diff(errors) < 0), errors
    assert errors[-1] < errors[0] / 8, errors
    assert errors[-1] < 5e-3


def test_exact_srv_action_keeps_distance_and_matches_curve_resampling():
    g = GROUPS["R3xSO3^6"]
    c0, c1 = smooth_curve(g, 40, seed=7, t=random_grid(40, 8)), smooth_curve(g, 40, seed=9)
    s0, s1 = srv_transform(c0), srv_transform(c1)
    phi = _pl_warp()
    # exact action: d(q0*phi, q1*phi) = d(q0, q1) exactly (change of variables)
    np.testing.assert_allclose(
        srv_distance(reparametrize_srv(s0, phi), reparametrize_srv(s1, phi)), srv_distance(s0, s1), rtol=1e-12
    )
    # the curve of q0*phi is c0 o phi: sampled on c0's grid it equals geodesic resampling
    cw = inverse_srv_transform(reparametrize_srv(s0, phi))
    np.testing.assert_allclose(cw.evaluate(c0.t), reparametrize_curve(c0, phi).values, atol=1e-12)
    # identity warp is the identity
    np.testing.assert_allclose(reparametrize_srv(s0, c0.t).q, s0.q, atol=1e-15)
    # sqrt(phi') factor: a linear speed-up by 2 on [0, 1/2] then 2/3 on [1/2, 1]
    warp = np.array([[0, 0], [0.25, 0.5], [1, 1]])
    line = DiscreteCurve(np.linspace(0, 1, 5)[:, None] * np.array([[1.0, 0, 0]]), Euclidean(3))
    qw = reparametrize_srv(srv_transform(line), warp)
    np.testing.assert_allclose(qw.q[qw.t[:-1] < 0.25, 0], np.sqrt(2.0))
    np.testing.assert_allclose(qw.q[qw.t[:-1] >= 0.25, 0], np.sqrt(2.0 / 3.0))


def test_flat_warp_gives_zero_velocity():
    g = Euclidean(2)
    c = DiscreteCurve(np.random.default_rng(1).normal(size=(11, 2)), g)
    phi = np.array([[0, 0], [0.4, 0.5], [0.6, 0.5], [1, 1]])  # stands still on [0.4, 0.6]
    qw = reparametrize_srv(srv_transform(c), phi)
    flat = (qw.t[:-1] >= 0.4) & (qw.t[1:] <= 0.6)
    np.testing.assert_array_equal(qw.q[flat], 0.0)
    np.testing.assert_allclose(
        inverse_srv_transform(qw).evaluate(np.array([0.4, 0.5, 0.6])),
        np.repeat(c.evaluate(np.array([0.5])), 3, 0),
        atol=1e-12,
    )


@pytest.mark.parametrize("name", ["R3", "SO3", "R3xSO3^6"])
def test_blend_end_points_and_geodesic_property(name):
    g = GROUPS[name]
    c0, c1 = smooth_curve(g, 80, seed=10), smooth_curve(g, 80, seed=11, amp=0.7)
    np.testing.assert_allclose(blend(c0, c1, 0.0, t_out=c0.t).values, c0.values, atol=1e-12)
    np.testing.assert_allclose(blend(c0, c1, 1.0, t_out=c1.t).values, c1.values, atol=1e-12)
    d = curve_distance(c0, c1)
    for s in (0.25, 0.5, 0.8):
        cs = blend(c0, c1, s)
        qs = srv_transform(cs)
        # the SRV path is a straight line: q_s = (1-s) q0 + s q1, so distances split as s : 1-s
        np.testing.assert_allclose(srv_distance(srv_transform(c0), qs), s * d, rtol=1e-9)
        np.testing.assert_allclose(srv_distance(qs, srv_transform(c1)), (1 - s) * d, rtol=1e-9)
        # start point on the group geodesic exp(s log(c1(0) c0(0)^-1)) c0(0)
        np.testing.assert_allclose(cs.values[0], g.interpolate(c0.values[0], c1.values[0], s), atol=1e-12)


def test_blend_with_warp_hits_warped_curve():
    g = GROUPS["R3xSO3^6"]
    c0, c1 = smooth_curve(g, 60, seed=12), smooth_curve(g, 60, seed=13)
    phi = _pl_warp()
    np.testing.assert_allclose(
        blend(c0, c1, 1.0, phi, t_out=c0.t).values, reparametrize_curve(c1, phi).values, atol=1e-12
    )


def test_weighted_blend_three_curves_in_rd_is_affine():
    # in R^d the SRV mean is explicit: q = sum w_k q_k, start = sum w_k c_k(0)
    g = Euclidean(2)
    cs = [smooth_curve(g, 30, seed=s) for s in (1, 2, 3)]
    w = np.array([0.2, 0.5, 0.3])
    m = weighted_blend(cs, w, t_out=cs[0].t)
    q = sum(wk * srv_transform(c).q for wk, c in zip(w, cs, strict=True))
    np.testing.assert_allclose(srv_transform(m).q, q, atol=1e-12)
    np.testing.assert_allclose(m.values[0], sum(wk * c.values[0] for wk, c in zip(w, cs, strict=True)))


def test_srv_distance_on_different_grids_is_exact():
    g = Euclidean(1)
    a = SRVFunction(np.array([[1.0], [3.0]]), [0, 0.5, 1], np.zeros(1), g)
    b = SRVFunction(np.array([[2.0], [0.0], [1.0]]), [0, 0.25, 0.75, 1], np.zeros(1), g)
    # cells: [0,.25]: 1-2, [.25,.5]: 1-0, [.5,.75]: 3-0, [.75,1]: 3-1
    expected = np.sqrt(0.25 * (1 + 1 + 9 + 4))
    assert srv_distance(a, b) == pytest.approx(expected, rel=1e-15)
    # projection to a coarser grid averages
    np.testing.assert_allclose(b.on_grid(np.array([0, 0.5, 1])).q[:, 0], [1.0, 0.5])


def test_agreement_with_fdasrsf_curve_to_q():
    cf = pytest.importorskip("fdasrsf.curve_functions")
    T = 101
    c = smooth_curve(Euclidean(3), T, seed=14)
    ours = srv_transform(c).q
    xi = ours * np.linalg.norm(ours, axis=1, keepdims=True)  # q |q| = velocity per cell
    q_fd, _len_fd, lenq_fd = cf.curve_to_q(np.array(c.values.T), scale=False)
    # fdasrsf: node-valued central differences taken with spacing 1/T although the samples
    # are 1/(T-1) apart, so its velocity is T/(T-1) times ours; q = v/sqrt|v|
    v_nodes = T / (T - 1) * 0.5 * (xi[:-1] + xi[1:])
    expected = v_nodes / np.sqrt(np.linalg.norm(v_nodes, axis=1, keepdims=True))
    np.testing.assert_allclose(q_fd.T[1:-1], expected, atol=1e-10)
    # its documented normalisation: scale=True divides by the L2 norm sqrt(sum |q|^2 / T)
    q_fd_unit, _, _ = cf.curve_to_q(np.array(c.values.T), scale=True)
    np.testing.assert_allclose(q_fd_unit, q_fd / np.sqrt(np.sum(q_fd**2) / T), atol=1e-12)
    # both approximate the same continuous L2 norm (its 1/T and its velocity factor cancel)
    assert lenq_fd == pytest.approx(srv_transform(c).norm(), rel=1e-2)


def test_evaluate_is_exact_on_samples_and_geodesic_between():
    g = SO3()
    c = smooth_curve(g, 10, seed=15)
    np.testing.assert_allclose(c.evaluate(c.t), c.values, atol=1e-14)
    mid = c.evaluate(0.5 * (c.t[3] + c.t[4]))
    np.testing.assert_allclose(mid, g.interpolate(c.values[3], c.values[4], 0.5), atol=1e-14)
    # halfway on the geodesic: equal angle to both ends
    a = np.linalg.norm(g.difference(c.values[3], mid))
    b = np.linalg.norm(g.difference(mid, c.values[4]))
    assert a == pytest.approx(b, rel=1e-12)


# --------------------------------------------------------------------------- bad input


def test_bad_input_errors_name_the_argument():
    g = Euclidean(2)
    vals = np.zeros((4, 2))
    with pytest.raises(ValueError, match=r"t: expected strictly increasing parameters; t\[2\]"):
        DiscreteCurve(vals, g, [0, 0.5, 0.5, 1])
    with pytest.raises(ValueError, match="t: expected parameters from 0 to 1"):
        DiscreteCurve(vals, g, [0, 0.5, 0.7, 0.9])
    with pytest.raises(ValueError, match="t: expected 4 parameters"):
        DiscreteCurve(vals, g, [0, 1])
    with pytest.raises(ValueError, match=r"values: expected an array of shape \(\.\.\., 2\)"):
        DiscreteCurve(np.zeros((4, 3)), g)
    with pytest.raises(ValueError, match="values: expected finite values"):
        DiscreteCurve(np.array([[0, 0], [np.inf, 0.0]]), g)
    with pytest.raises(ValueError, match="values: expected at least 2 samples"):
        DiscreteCurve(np.zeros((1, 2)), g)
    c = DiscreteCurve(np.random.default_rng(0).normal(size=(4, 2)), g)
    with pytest.raises(ValueError, match="phi: expected an increasing warp"):
        reparametrize_curve(c, [0, 0.6, 0.4, 1])
    with pytest.raises(ValueError, match="phi: expected a warp fixing the ends"):
        reparametrize_curve(c, [0, 0.3, 0.6, 0.9])
    with pytest.raises(ValueError, match="phi: expected warp samples of shape"):
        reparametrize_curve(c, np.zeros((2, 3)))
    other = DiscreteCurve(np.zeros((4, 3)), Euclidean(3))
    with pytest.raises(
        ValueError, match=r"srv1: expected a curve in the same group as srv0 \(Euclidean\(2\)\)"
    ):
        curve_distance(c, other)
    with pytest.raises(ValueError, match="weights: expected weights summing to 1"):
        weighted_blend([c, c], [0.5, 0.6])
    with pytest.raises(ValueError, match="s: expected a finite blend weight"):
        blend(c, c, np.nan)
    with pytest.raises(ValueError, match=r"q: expected shape \(n, 2\)"):
        SRVFunction(np.zeros((3, 3)), np.linspace(0, 1, 4), np.zeros(2), g)


def test_merged_grid_has_no_rounding_cells_and_blend_srv_is_exact():
    """Issue 13: warps' vertices and pre-images agree only up to rounding; merged grids must
    not keep cells of width 1e-16 (the old 3-curve blend's SRV was off by 0.3 on one)."""
    from elastic_motion.curves import MERGE_TOL, common_refinement
    from elastic_motion.warp import optimal_warp

    g = Euclidean(2)
    n, rng = 47, np.random.default_rng(2)
    t = np.linspace(0, 1, n + 1)
    cs = [
        DiscreteCurve(np.column_stack([t, 0.3 * np.sin((k + 2 + rng.uniform()) * np.pi * t + k)]), g)
        for k in range(3)
    ]
    qs = [srv_transform(c) for c in cs]
    warps = [None] + [optimal_warp(qs[0].q, q.q, method="dp").vertices for q in qs[1:]]
    srvs = [q if w is None else reparametrize_srv(q, w) for q, w in zip(qs, warps, strict=True)]
    assert all(np.diff(s.t).min() > MERGE_TOL for s in srvs)
    grid, vals = common_refinement([(s.q, s.t) for s in srvs])
    assert np.diff(grid).min() > MERGE_TOL
    w = np.array([0.3, 0.3, 0.4])
    out = weighted_blend(cs, w, warps)
    assert np.diff(out.t).min() > MERGE_TOL
    np.testing.assert_allclose(srv_transform(out).q, np.einsum("k,kij->ij", w, np.stack(vals)), atol=1e-10)
    # distances on merged grids stay exact
    assert srv_distance(srvs[1], srvs[2]) == pytest.approx(
        np.sqrt(np.sum(np.sum((vals[1] - vals[2]) ** 2, axis=1) * np.diff(grid)))
    )
