"""Closed curves: projection (paper 001 Thm. 2), closed geodesics and distance, eq. 22 matching."""

from __future__ import annotations

import numpy as np
import pytest

from elastic_motion.closed_curves import (
    ClosedMatchOptions,
    _normal_coeffs,
    _normal_field,
    _normal_gram,
    closed_curve_srv,
    closed_distance,
    closed_geodesic,
    closed_geodesic_curves,
    closure_residual,
    match_closed,
    project_closed,
    swap_closed_match,
    tangent_part,
)
from elastic_motion.errors import OptionError
from elastic_motion.warp import WarpOptions, shift_seed, warp_energy


def polar_outline(n: int, bumps: int = 5, amp: float = 0.35, phase: float = 0.0, rot: float = 0.0):
    """Samples (n+1, 2) of a closed star-like outline, uniform in the polar angle."""
    s = (np.arange(n + 1) / n + rot) % 1.0
    s[-1] = s[0]
    a = 2 * np.pi * s
    r = 1.0 + amp * np.cos(bumps * a + phase) ** 2 + 0.15 * np.sin(a)
    return np.column_stack([r * np.cos(a), 0.8 * r * np.sin(a)])


def srv_of(xy):
    return closed_curve_srv(xy).q


def test_closure_derivative_and_normal_gram_match_finite_differences():
    rng = np.random.default_rng(0)
    n, D = 30, 3
    q, v = rng.normal(size=(n, D)), rng.normal(size=(n, D))
    h = rng.uniform(0.5, 1.5, n)
    h /= h.sum()
    eps = 1e-6
    fd = (closure_residual(q + eps * v, h) - closure_residual(q - eps * v, h)) / (2 * eps)
    # dF_k[v] = <U_k(q), v>_L2 (paper 001, eq. 11 is the gradient of F_k)
    np.testing.assert_allclose(_normal_coeffs(q, v, h), fd, rtol=1e-7)
    U = np.stack([_normal_field(q, e) for e in np.eye(D)])  # (D, n, D)
    gram = np.einsum("i,kij,lij->kl", h, U, U)
    np.testing.assert_allclose(_normal_gram(q, h), gram, rtol=1e-12)
    w = tangent_part(q, v, h)
    np.testing.assert_allclose(_normal_coeffs(q, w, h), 0.0, atol=1e-12)
    np.testing.assert_allclose(tangent_part(q, w, h), w, atol=1e-12)


def test_projection_closes_batched():
    rng = np.random.default_rng(1)
    q = srv_of(polar_outline(80))[None] + 0.2 * rng.normal(size=(4, 80, 2))
    h = np.full(80, 1 / 80)
    qc, res = project_closed(q, h)
    assert qc.shape == q.shape and (res < 1e-13).all()
    assert np.abs(closure_residual(qc, h)).max() < 1e-12


def test_geodesic_is_closed_converges_and_is_symmetric():
    a, b = srv_of(polar_outline(60)), srv_of(polar_outline(60, bumps=4, phase=0.4))
    d = []
    for K in (4, 8, 16):
        g = closed_geodesic(a, b, n_steps=K)
        assert g.converged and g.max_gap < 1e-12
        np.testing.assert_array_equal(g.path[0], a)
        np.testing.assert_array_equal(g.path[-1], b)
        assert g.distance > g.open_distance  # the straight line leaves M
        assert g.distance**2 <= g.energy * (1 + 1e-12)
        d.append(g.distance)
    # chords of a curve: increasing in K, error O(K^-2)
    assert d[0] < d[1] < d[2]
    assert 2.5 < (d[1] - d[0]) / (d[2] - d[1]) < 6.0
    back = closed_geodesic(b, a, n_steps=16)
    assert back.distance == pytest.approx(d[2], rel=1e-9)
    # the discrete geodesic equation: the acceleration is normal to M at every interior point
    h = np.full(60, 1 / 60)
    acc = g.path[2:] - 2 * g.path[1:-1] + g.path[:-2]
    tan = tangent_part(g.path[1:-1], acc, h)
    assert np.sqrt(np.sum(tan**2)) < 1e-6 * np.sqrt(np.sum(acc**2))
    curves = closed_geodesic_curves(g)
    assert all(np.abs(c[-1] - c[0]).max() < 1e-12 for c in curves)


def test_scaled_curve_geodesic_is_the_straight_line():
    """q1 = c q0 stays closed along the straight line: d_M = |1 - c| ||q0||, exactly."""
    a = srv_of(polar_outline(50))
    g = closed_geodesic(a, 1.7 * a, n_steps=8)
    norm = np.sqrt(np.sum(a**2) / 50)
    assert g.distance == pytest.approx(0.7 * norm, rel=1e-12)
    assert g.open_distance == pytest.approx(0.7 * norm, rel=1e-12)


def test_geodesic_agrees_with_an_independent_constrained_optimiser():
    from scipy.optimize import minimize

    n, K = 10, 4
    a = srv_of(polar_outline(n, bumps=2, amp=0.3))
    b = srv_of(polar_outline(n, bumps=3, amp=0.3, phase=0.5))
    h = np.full(n, 1 / n)
    ours = closed_geodesic(a, b, n_steps=K, tol=1e-12)

    def energy(x):
        p = np.concatenate([a[None], x.reshape(K - 1, n, 2), b[None]])
        d = np.diff(p, axis=0)
        return K * np.einsum("i,kij,kij->", h, d, d)

    cons = {"type": "eq", "fun": lambda x: closure_residual(x.reshape(K - 1, n, 2), h).ravel()}
    s = np.linspace(0, 1, K + 1)[1:-1, None, None]
    x0 = ((1 - s) * a + s * b).ravel()
    ref = minimize(energy, x0, constraints=[cons], method="SLSQP", options={"ftol": 1e-14, "maxiter": 500})
    assert ref.success
    assert ours.energy == pytest.approx(ref.fun, rel=1e-7)


def test_distance_on_different_grids_and_reparametrisation_invariance():
    xy = polar_outline(64)
    a = srv_of(xy)
    b = srv_of(polar_outline(48, bumps=4, phase=0.3))
    d = closed_distance(a, b)
    # same curves, q1 refined (every cell split in two): the same distance
    t1 = np.linspace(0, 1, 49)
    t2 = np.linspace(0, 1, 97)
    b2 = b[np.searchsorted(t1, t2[:-1], side="right") - 1]
    assert closed_distance(a, b2, t1=t2) == pytest.approx(d, rel=1e-9)


def test_swap_closed_match_is_exact():
    a, b = srv_of(polar_outline(40)), srv_of(polar_outline(50, bumps=4))
    ta, tb = np.linspace(0, 1, 41), np.linspace(0, 1, 51)
    psi = np.array([[0, 0], [0.3, 0.2], [0.55, 0.6], [1, 1]])
    sigma = 0.37
    bs, tbs = shift_seed(b, tb, sigma)
    e = warp_energy(a, bs, psi, ta, tbs)
    tau, phi = swap_closed_match(psi, sigma)
    as_, tas = shift_seed(a, ta, tau)
    assert warp_energy(b, as_, phi, tb, tas) == pytest.approx(e, rel=1e-12)


def test_match_is_symmetric_and_lowers_the_closed_energy():
    a = srv_of(polar_outline(80))
    b = srv_of(polar_outline(80, bumps=5, amp=0.45, phase=0.25, rot=0.21))
    ab, ba = match_closed(a, b), match_closed(b, a)
    assert ab.distance == pytest.approx(ba.distance, rel=1e-6)
    assert ab.energy <= ab.energy_open_step
    assert ab.distance >= ab.open_distance
    assert ab.geodesic.max_gap < 1e-10


def test_match_recovers_a_known_seed():
    xy = polar_outline(120, bumps=3)
    q = srv_of(xy)
    t = np.linspace(0, 1, 121)
    q0, t0 = shift_seed(q, t, 0.25)
    m = match_closed(q0, q, t0=t0, closed_iter=1)
    assert min(abs(m.seed_shift - 0.25), 1 - abs(m.seed_shift - 0.25)) < 2 / 120
    assert m.distance < 0.02


def test_bad_input():
    xy = polar_outline(40)
    open_xy = xy.copy()
    open_xy[-1] += [0.05, 0.0]
    with pytest.raises(ValueError, match=r"not closed: its end is 0.05 from its start"):
        closed_curve_srv(open_xy)
    q = closed_curve_srv(open_xy, close=True).q
    assert np.abs(closure_residual(q, np.full(40, 1 / 40))).max() < 1e-12
    a = srv_of(xy)
    with pytest.raises(ValueError, match="not closed"):
        closed_geodesic(a, srv_transform_open(open_xy))
    with pytest.raises(ValueError, match="length 0"):
        closed_curve_srv(np.zeros((10, 2)))
    # repeated samples: cells with q = 0, still closed and usable
    rep = np.insert(xy, 7, xy[7], axis=0)[:-1]
    rep[-1] = rep[0]
    qr = closed_curve_srv(rep).q
    assert (np.linalg.norm(qr, axis=1) == 0).sum() == 1
    assert np.isfinite(closed_distance(a, qr))
    with pytest.raises(ValueError, match="shape and grid"):
        closed_geodesic(a, a[:-1])


def srv_transform_open(xy):
    v = np.diff(xy, axis=0) * (len(xy) - 1)
    return v / np.sqrt(np.linalg.norm(v, axis=1))[:, None]


def test_first_variation_of_the_closed_energy_is_the_end_velocity():
    """d/de E(q0, q1_e) = 2 <alpha'(1), v> (envelope theorem): what the closed descent uses."""
    a, b = srv_of(polar_outline(40)), srv_of(polar_outline(40, bumps=4, phase=0.4))
    h = np.full(40, 1 / 40)
    rng = np.random.default_rng(3)
    v = tangent_part(b, rng.normal(size=b.shape), h)
    g = closed_geodesic(a, b, n_steps=8, tol=1e-12)
    eps = 1e-5
    e = [
        closed_geodesic(a, project_closed(b + s * v, h)[0], n_steps=8, tol=1e-12).energy for s in (eps, -eps)
    ]
    fd = (e[0] - e[1]) / (2 * eps)
    assert fd == pytest.approx(2 * np.einsum("i,ij,ij->", h, g.velocity_end, v), rel=1e-5)


def test_closed_descent_lowers_the_energy_of_the_open_match():
    a = srv_of(polar_outline(80))
    b = srv_of(polar_outline(80, bumps=5, amp=0.45, phase=0.25, rot=0.21))
    m = match_closed(a, b, closed_iter=3)
    assert m.closed_steps >= 1 and m.energy < m.energy_open_step


@pytest.mark.parametrize(
    ("field", "value"),
    [("n_steps", 0), ("closed_iter", 1.5), ("warp", "dp"), ("lam", -1.0), ("penalty", "cubic")],
)
def test_match_options_validation_names_the_option(field, value):
    with pytest.raises(OptionError) as exc:
        ClosedMatchOptions(**{field: value})
    assert exc.value.option == field
    with pytest.raises(OptionError) as exc:
        ClosedMatchOptions(warp=WarpOptions(method="none"))
    assert exc.value.option == "warp"


def test_match_overrides_equal_the_options_object():
    a = srv_of(polar_outline(40))
    b = srv_of(polar_outline(40, bumps=5, amp=0.45, phase=0.25, rot=0.21))
    lm = [[0.2, 0.3]]

    def same(x, y):
        assert x.energy == y.energy and x.seed_shift == y.seed_shift and x.seed_from == y.seed_from
        np.testing.assert_array_equal(x.vertices, y.vertices)

    kw = dict(lam=0.5, symmetric=True, closed_iter=1, n_steps=4)
    same(
        match_closed(a, b, landmarks=lm, **kw),
        match_closed(a, b, options=ClosedMatchOptions(**kw), landmarks=lm),
    )
    warp = WarpOptions(method="dp", neighbourhood=6)
    base = ClosedMatchOptions(warp=warp, closed_iter=0, n_steps=4)
    same(match_closed(a, b, options=warp, closed_iter=0, n_steps=4), match_closed(a, b, options=base))
    same(
        match_closed(a, b, options=base, closed_iter=1),
        match_closed(a, b, options=ClosedMatchOptions(warp=warp, n_steps=4, closed_iter=1)),
    )
    assert match_closed(a, b, options=base).closed_steps == 0
    with pytest.raises(OptionError, match="unknown option") as exc:
        match_closed(a, b, closed_steps=2)
    assert exc.value.option == "closed_steps"
