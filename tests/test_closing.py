"""Tests of the closing flows (paper 000, sec. 4; paper 001, Thm. 2) against independent checks:
central finite differences, fixed points, monotone decrease, a naive fix, exact closures."""

from __future__ import annotations

import numpy as np
import pytest

from elastic_motion.closing import (
    close_curve,
    closing_gap,
    closing_gradient,
    closing_mask,
    project_closed_rd,
)
from elastic_motion.curves import (
    DiscreteCurve,
    SRVFunction,
    curve_distance,
    inverse_srv_transform,
    srv_distance,
    srv_transform,
)
from elastic_motion.groups import SO3, Euclidean, PowerGroup, ProductGroup, animation_group

SO3G = SO3()


def smooth_curve(group, n, seed=0, scale=1.0, t=None):
    """A smooth open curve: SRV = a few random cosines, integrated from a random start."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 1.0, n + 1) if t is None else t
    mid = 0.5 * (t[:-1] + t[1:])
    q = sum(
        np.outer(np.cos((k + 1) * np.pi * mid + rng.uniform(0, 6)), rng.normal(size=group.dim))
        for k in range(3)
    )
    start = group.exp(rng.normal(size=group.dim) * 0.5)
    return inverse_srv_transform(SRVFunction(scale * q, t, start, group))


def weighted_group():
    return ProductGroup([Euclidean(3, weight=[0.5, 2.0, 1.0]), PowerGroup(SO3(), 4, [1.0, 2.0, 0.5, 1.5])])


def central_differences(srv, eps=1e-6, **kw):
    q = np.array(srv.q)
    out = np.zeros_like(q)
    for i in range(q.shape[0]):
        for k in range(q.shape[1]):
            qp, qm = q.copy(), q.copy()
            qp[i, k] += eps
            qm[i, k] -= eps
            fp = closing_gradient(SRVFunction(qp, srv.t, srv.start, srv.group), **kw).phi
            fm = closing_gradient(SRVFunction(qm, srv.t, srv.start, srv.group), **kw).phi
            out[i, k] = (fp - fm) / (2 * eps)
    return out


FACTOR_CASES = {
    "all": None,
    "so3-copies": [False, [True, True, False, True]],
    # height only; copy 0 closed up to rotations about y (swing), copy 2 free
    "swing": [[False, True, False], np.array([1, 0, 1] + [1] * 3 + [0] * 3 + [1] * 3, dtype=bool)],
}


@pytest.mark.parametrize("factors", list(FACTOR_CASES))
@pytest.mark.parametrize("c1", [False, True])
@pytest.mark.parametrize("uniform", [True, False])
def test_exact_gradient_matches_central_differences(factors, c1, uniform):
    g = weighted_group()
    t = (
        None
        if uniform
        else np.concatenate([[0.0], np.sort(np.random.default_rng(3).uniform(0, 1, 8)), [1.0]])
    )
    curve = smooth_curve(g, 9, seed=1, scale=0.9, t=t)
    srv = srv_transform(curve)
    kw = dict(factors=FACTOR_CASES[factors], c1=c1)
    res = closing_gradient(srv, **kw)
    partials = res.gradient * srv.dt[:, None]
    fd = central_differences(srv, **kw)
    assert res.phi > 0.1
    err = np.abs(fd - partials).max() / np.abs(fd).max()
    assert err < 1e-6, err


def test_general_dexp_and_corollary_4_8_agree_for_bi_invariant_metric():
    # SO(3)^J with per-joint weights: the inner product is bi-invariant on each copy
    g = PowerGroup(SO3(), 5, [1.0, 0.3, 2.0, 1.0, 4.0])
    srv = srv_transform(smooth_curve(g, 30, seed=2, scale=1.5))
    gen = closing_gradient(srv, log_term="general")
    cor = closing_gradient(srv, log_term="bi-invariant")
    np.testing.assert_allclose(cor.gradient, gen.gradient, rtol=0, atol=1e-12 * np.abs(gen.gradient).max())
    # same for the swing residual (closed up to rotations about z on copy 1)
    mask = np.ones(15, dtype=bool)
    mask[5] = False
    gen = closing_gradient(srv, factors=mask, log_term="general").gradient
    cor = closing_gradient(srv, factors=mask, log_term="bi-invariant").gradient
    np.testing.assert_allclose(cor, gen, rtol=0, atol=1e-12 * np.abs(gen).max())
    # ... and the agreement is not trivial: (dexp^{-1}_l)^† moves vectors other than l
    rng = np.random.default_rng(0)
    ell, v = rng.normal(size=(2, 3))
    np.testing.assert_allclose(SO3G.dexp_inv_dual(ell, ell), ell, atol=1e-14)
    assert np.abs(SO3G.dexp_inv_dual(ell, v) - v).max() > 0.1


def test_paper_gradient_converges_to_exact_one_as_grid_refines():
    g = PowerGroup(SO3(), 3)

    def curve(n):
        t = np.linspace(0, 1, n + 1)
        v = np.stack(
            [
                np.outer(np.sin(2 * t + k), [2.0, 1.0, 0.4]) + np.outer(np.cos(3 * t), [0.1, 1, 0.3])
                for k in range(3)
            ],
            1,
        )
        return DiscreteCurve(SO3G.exp(v), g)

    errs = []
    for n in (10, 20, 40, 80, 160):
        c = curve(n)
        exact = closing_gradient(c).gradient
        paper = closing_gradient(c, gradient="paper").gradient
        dt = np.diff(c.t)
        errs.append(np.sqrt(np.sum((exact - paper) ** 2 * dt[:, None]) / np.sum(exact**2 * dt[:, None])))
    errs = np.array(errs)
    assert errs[0] > 1e-2  # the two differ on a coarse grid ...
    assert errs[-1] < 5e-3  # ... and converge, at first order
    np.testing.assert_allclose(errs[:-1] / errs[1:], 2.0, rtol=0.05)


def closed_so3_curve(n=40):
    """A curve in R^3 x SO(3)^2 that returns to its start (periodic rotation vectors)."""
    g = animation_group(2, [1.0, 2.0], 0.5)
    t = np.linspace(0, 1, n + 1)
    s, c = np.sin(2 * np.pi * t), 1 - np.cos(2 * np.pi * t)
    pos = np.stack([s, 0.3 * c, 0.2 * s * c], 1)
    rot = np.stack(
        [
            SO3G.exp(np.outer(s, [0.5, 1.0, 0.2]) + np.outer(c, [0.3, 0, 1])),
            SO3G.exp(np.outer(c, [1.0, 0.2, 0.1])),
        ],
        1,
    )
    return DiscreteCurve(g.join_points([pos, rot]), g)


def test_closed_curve_is_a_fixed_point():
    c = closed_so3_curve()
    assert closing_gap(c).gap < 1e-12
    grad = closing_gradient(c)
    assert grad.phi < 1e-24
    assert np.abs(grad.gradient).max() < 1e-11
    for method in ("gauss-newton", "gradient"):
        res = close_curve(c, method=method, tol=1e-10)
        assert res.iterations == 0 and res.converged
        np.testing.assert_array_equal(res.curve.values, c.values)


@pytest.mark.parametrize("gradient", ["exact", "paper"])
def test_gradient_flow_decreases_gap_monotonically(gradient):
    g = animation_group(4, [1.0, 2.0, 0.5, 1.0], 0.8)
    c = smooth_curve(g, 60, seed=4, scale=1.0)
    res = close_curve(c, method="gradient", gradient=gradient, tol=1e-4, max_iter=400)
    assert res.gap_initial > 1.0
    assert res.converged, res.message
    assert np.all(np.diff(res.objective_history) < 0)  # every accepted step decreases Phi
    assert np.all(np.diff(res.history) <= 0)
    assert res.gap <= 1e-4
    # the returned curve is closed: last sample = first sample
    assert closing_gap(res.curve).gap <= 1.01e-4
    np.testing.assert_array_equal(res.curve.values[0], c.values[0])


def test_gauss_newton_converges_quadratically_and_closes_exactly():
    g = animation_group(6, np.linspace(0.5, 2, 6), 1.0)
    c = smooth_curve(g, 120, seed=5, scale=1.2)
    res = close_curve(c, tol=1e-12)
    assert res.converged and res.iterations <= 6, res.history
    h = res.history
    assert h[0] > 1.0
    # quadratic: gap_{k+1} <= C gap_k^2 once in the basin
    assert h[-1] < 1e-12
    assert h[-2] ** 2 * 10 > h[-1]
    assert np.all(np.diff(res.objective_history) < 0)
    gap = closing_gap(res.curve)
    assert gap.gap < 1e-11 and gap.rotation_gaps.max() < 1e-11
    np.testing.assert_allclose(res.curve.values[-1], res.curve.values[0], atol=1e-11)


def naive_fix(curve):
    """Distribute the seam gap linearly in time: c'_i = exp(-t_i log r) c_i (closes exactly)."""
    g = curve.group
    ell = g.difference(curve.values[0], curve.values[-1])  # log(c_n c_0^{-1})
    return DiscreteCurve(g.compose(g.exp(-curve.t[:, None] * ell), curve.values), g, curve.t)


@pytest.mark.parametrize("seed", [6, 7])
def test_closing_changes_the_curve_less_than_a_naive_fix(seed):
    g = animation_group(5, [1.0, 2.0, 0.5, 1.0, 1.0], 1.0)
    c = smooth_curve(g, 100, seed=seed, scale=0.7)
    naive = naive_fix(c)
    assert closing_gap(naive).gap < 1e-10
    gn = close_curve(c, tol=1e-10)
    gd = close_curve(c, method="gradient", tol=1e-6, max_iter=500)
    d_naive = curve_distance(c, naive)
    assert gn.gap_initial > 0.5
    assert curve_distance(c, gn.curve) < 0.9 * d_naive
    assert curve_distance(c, gd.curve) < 0.9 * d_naive
    # Gauss-Newton is the (first-order) minimal-norm projection: no farther than the flow
    assert curve_distance(c, gn.curve) <= curve_distance(c, gd.curve) * 1.01


def test_factors_close_only_what_is_asked():
    g = animation_group(3, None, 1.0)
    c = smooth_curve(g, 80, seed=8)
    pos0 = g.split_points(c.values)[0]
    # close the rotations only: the root position keeps its samples (keep_free)
    res = close_curve(c, factors=[False, True], tol=1e-10)
    pos, rot = g.split_points(res.curve.values)
    np.testing.assert_array_equal(pos, pos0)
    np.testing.assert_allclose(rot[-1], rot[0], atol=1e-10)
    assert np.abs(pos[-1] - pos[0]).max() > 0.1
    # height (y) only, root copy closed up to rotations about y, copy 2 free
    mask = np.array([0, 1, 0] + [1, 0, 1] + [1, 1, 1] + [0, 0, 0], dtype=bool)
    res = close_curve(c, factors=mask, tol=1e-10)
    pos, rot = g.split_points(res.curve.values)
    assert abs(pos[-1, 1] - pos[0, 1]) < 1e-10
    np.testing.assert_array_equal(pos[:, [0, 2]], pos0[:, [0, 2]])
    r0 = rot[-1, 0] @ rot[0, 0].T
    np.testing.assert_allclose(r0 @ [0, 1, 0], [0, 1, 0], atol=1e-10)  # a rotation about y ...
    assert np.linalg.norm(SO3G.log(r0)) > 0.05  # ... that is not the identity (heading kept)
    np.testing.assert_allclose(rot[-1, 1], rot[0, 1], atol=1e-10)
    np.testing.assert_array_equal(rot[:, 2], g.split_points(c.values)[1][:, 2])  # free copy kept
    assert res.rotation_gaps[2] == 0 and closing_gap(c, factors=mask).rotation_gaps[0] > 0


def test_c1_closing_matches_seam_velocities():
    g = animation_group(3, [1.0, 2.0, 0.5], 1.0)
    c = smooth_curve(g, 90, seed=9, scale=0.8)
    c0 = close_curve(c, tol=1e-9)
    c1 = close_curve(c, c1=True, tol=1e-9)
    assert c0.converged and c1.converged
    assert c1.gap < 1e-9 and c1.velocity_gap < 1e-9
    assert c0.velocity_gap > 1e-3  # C0 closing leaves a velocity jump
    # check against the curve itself: last and first steps (fully closed: Ad_r = id)
    xi = srv_transform(c1.curve)
    qn = np.linalg.norm(xi.q, axis=1)
    np.testing.assert_allclose(qn[-1] * xi.q[-1], qn[0] * xi.q[0], atol=1e-7)


def test_c1_with_free_heading_matches_rotated_velocity():
    g = PowerGroup(SO3(), 2)
    c = smooth_curve(g, 60, seed=10, scale=1.0)
    mask = np.array([1, 0, 1, 1, 1, 1], dtype=bool)
    res = close_curve(c, factors=mask, c1=True, tol=1e-10)
    assert res.converged
    rot = res.curve.values
    r = rot[-1, 0] @ rot[0, 0].T  # a rotation about y
    np.testing.assert_allclose(r @ [0, 1, 0], [0, 1, 0], atol=1e-9)
    xi_first = SO3G.log(rot[1, 0] @ rot[0, 0].T)
    xi_last = SO3G.log(rot[-1, 0] @ rot[-2, 0].T)
    np.testing.assert_allclose(xi_last, r @ xi_first, atol=1e-9)


def arc(n, fraction, d=2, weight=1.0):
    t = np.linspace(0, 1, n + 1)
    a = 2 * np.pi * fraction * t
    pts = np.stack(
        [np.cos(a), np.sin(a) + 0.3 * np.sin(3 * a)] + [0.2 * np.sin(a * (k + 2)) for k in range(d - 2)], 1
    )
    return DiscreteCurve(pts, Euclidean(d, weight=weight))


def test_project_closed_rd_closes_2d_outline_like_gauss_newton():
    c = arc(200, 0.8)
    res = project_closed_rd(c)
    assert res.converged and res.gap < 1e-10 and res.iterations <= 8
    np.testing.assert_allclose(res.curve.values[-1], res.curve.values[0], atol=1e-10)
    gn = close_curve(c, tol=1e-10)
    np.testing.assert_allclose(gn.curve.values, res.curve.values, atol=1e-8)
    # a closed outline is a fixed point
    closed = arc(200, 1.0)
    fix = project_closed_rd(closed)
    assert fix.iterations == 0
    np.testing.assert_array_equal(fix.curve.values, closed.values)


def test_project_closed_rd_with_weights_and_mask():
    c = arc(100, 0.7, d=4, weight=[1.0, 4.0, 0.5, 2.0])
    mask = np.array([True, True, False, True])
    res = project_closed_rd(c, factors=mask)
    assert res.converged
    v = res.curve.values
    np.testing.assert_allclose(v[-1, mask], v[0, mask], atol=1e-9)
    np.testing.assert_array_equal(v[:, 2], c.values[:, 2])  # free coordinate kept
    gn = close_curve(c, factors=mask, tol=1e-10)
    np.testing.assert_allclose(gn.curve.values, v, atol=1e-8)
    # the projection moves q less than scaling the curve down would: compare with naive fix
    naive = DiscreteCurve(c.values - np.outer(c.t, c.values[-1] - c.values[0]) * mask, c.group, c.t)
    assert srv_distance(srv_transform(c), res.srv) < srv_distance(srv_transform(c), srv_transform(naive))


def test_seam_rotation_by_pi_raises_clear_error():
    g = PowerGroup(SO3(), 2)
    t = np.linspace(0, 1, 21)
    ang = np.stack([np.outer(t, [0, 0, np.pi]), np.outer(np.sin(3 * t), [0.2, 0.1, 0])], 1)
    c = DiscreteCurve(SO3G.exp(ang), g)
    with pytest.raises(ValueError, match=r"cut locus.*") as exc:
        close_curve(c)
    assert "copy 0" in str(exc.value)
    with pytest.raises(ValueError, match="LeftArm"):
        close_curve(c, rotation_names=["LeftArm", "Head"])
    with pytest.raises(ValueError, match="cut locus"):
        closing_gap(c)
    # leaving that copy free is fine; just below pi closes (no NaN anywhere)
    res = close_curve(c, factors=[False, True])
    assert res.converged and np.isfinite(res.curve.values).all()
    ang[:, 0, 2] *= 1 - 1e-3
    res = close_curve(DiscreteCurve(SO3G.exp(ang), g), tol=1e-9)
    assert res.converged and np.isfinite(res.curve.values).all()


def test_bad_input_errors_name_the_argument():
    g = PowerGroup(SO3(), 2)
    two = DiscreteCurve(g.identity((2,)), g)
    with pytest.raises(ValueError, match=r"curve: expected at least 3 samples.*got 2"):
        close_curve(two)
    with pytest.raises(ValueError, match="at least 3"):
        project_closed_rd(DiscreteCurve(np.zeros((2, 2)), Euclidean(2)))
    vals = SO3G.exp(np.random.default_rng(0).normal(size=(10, 2, 3)))
    vals[4, 1, 0, 0] = np.nan
    with pytest.raises(ValueError, match="finite"):
        close_curve(DiscreteCurve(vals, g))
    c = smooth_curve(g, 10)
    with pytest.raises(ValueError, match="method"):
        close_curve(c, method="newton")
    with pytest.raises(ValueError, match="gradient"):
        close_curve(c, gradient="continuous")
    with pytest.raises(ValueError, match=r"factors: an SO\(3\) copy"):
        close_curve(c, factors=np.array([1, 0, 0, 1, 1, 1], dtype=bool))
    with pytest.raises(ValueError, match="factors"):
        closing_mask(animation_group(2), [True])
    with pytest.raises(ValueError, match="R\\^d"):
        project_closed_rd(c)
    with pytest.raises(ValueError, match="curve"):
        close_curve(np.zeros((5, 3)))
    with pytest.raises(ValueError, match="rotation_names"):
        close_curve(c, rotation_names=["a"])


def test_closing_mask_forms():
    g = animation_group(3)
    np.testing.assert_array_equal(closing_mask(g), np.ones(12, bool))
    m = closing_mask(g, [[False, True, False], [False, True, True]])
    np.testing.assert_array_equal(m, [0, 1, 0, 0, 0, 0, 1, 1, 1, 1, 1, 1])
    m = closing_mask(g, [True, np.zeros(9, bool)])
    np.testing.assert_array_equal(m, [1, 1, 1] + [0] * 9)
    np.testing.assert_array_equal(closing_mask(PowerGroup(SO3(), 2), [True, False]), [1, 1, 1, 0, 0, 0])
    coords = [True] * 3 + [False] * 9  # a plain list over the 12 coordinates
    np.testing.assert_array_equal(closing_mask(g, coords), coords)
