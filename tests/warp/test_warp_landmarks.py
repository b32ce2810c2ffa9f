"""Landmarks: soft pull, hard windows, the symmetric form, decomposable penalties."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from elastic_motion.warp import Landmarks, invert_warp, landmark_cost, optimal_warp, warp_at


def open_pair(n: int = 80):
    """Two open planar curves: three extrema versus two (paper 001, sec. 4.1)."""
    s = (np.arange(n) + 0.5) / n
    t = np.linspace(0, 1, n + 1)

    def srv(y):
        c = np.column_stack([t, y(t)])
        v = np.diff(c, axis=0) * n
        return v / np.sqrt(np.linalg.norm(v, axis=1))[:, None]

    q0 = srv(lambda x: 0.3 * np.sin(5 * np.pi * x))
    q1 = srv(lambda x: 0.3 * np.sin(4 * np.pi * x))
    return q0, q1, s


def test_landmark_is_approached_as_lambda_grows():
    q0, q1, _ = open_pair()
    lm = Landmarks([0.5], [0.3])
    free = optimal_warp(q0, q1)
    gaps = [abs(warp_at(free.vertices, 0.5) - 0.3)]
    for lam in [1.0, 10.0, 100.0, 1e4]:
        res = optimal_warp(q0, q1, landmarks=lm, lam=lam)
        gaps.append(abs(res.phi[40] - 0.3))
        assert res.energy == pytest.approx(res.distance**2 + res.landmark_cost)
    assert all(b <= a + 1e-12 for a, b in itertools.pairwise(gaps))
    assert gaps[-1] < 0.02 < gaps[0]


def test_landmark_charged_by_domain_erratum():
    """The feature term of a warp equals lam (phi(theta0) - theta1)^2 at the DP optimum.

    A consistency check of the re-scoring only; the tests that fail with the paper's charging
    rule are in ``test_warp_exactness.py`` (DP table value, brute force over all grid paths).
    """
    q0, q1, _ = open_pair(50)
    lm = Landmarks([0.31, 0.77], [0.4, 0.7])
    res = optimal_warp(q0, q1, landmarks=lm, lam=3.0, method="dp")
    x = warp_at(res.vertices, lm.theta0)
    assert res.landmark_cost == pytest.approx(3.0 * np.sum((x - lm.theta1) ** 2), rel=1e-12)
    assert res.energy == pytest.approx(res.diagnostics.energy_dp, rel=1e-12)


def test_hard_windows_are_never_violated():
    rng = np.random.default_rng(11)
    for trial in range(4):
        n = 40
        q0, q1 = rng.normal(size=(n, 2)), rng.normal(size=(n + 7, 2))
        th0 = np.array([0.2, 0.5, 0.8]) + rng.uniform(-0.05, 0.05, 3)
        th1 = th0 + rng.uniform(-0.1, 0.1, 3)
        d = 0.03
        for penalty in ["window", "squared"]:
            for method in ["dp", "dp+refine"]:
                res = optimal_warp(
                    q0,
                    q1,
                    landmarks=np.column_stack([th0, th1]),
                    windows=d,
                    penalty=penalty,
                    lam=0.5,
                    method=method,
                )
                gap = np.abs(warp_at(res.vertices, th0) - th1)
                assert (gap <= d + 1e-12).all(), (trial, penalty, method, gap)
                assert np.isfinite(res.energy)


def test_symmetric_form_is_symmetric_under_swapping():
    q0, q1, _ = open_pair(60)
    lm = Landmarks([0.25, 0.7], [0.35, 0.6])
    a = optimal_warp(q0, q1, landmarks=lm, lam=5.0, symmetric=True, method="dp")
    b = optimal_warp(q1, q0, landmarks=lm.swapped(), lam=5.0, symmetric=True, method="dp")
    assert a.energy == pytest.approx(b.energy, rel=1e-9)
    assert a.landmark_cost == pytest.approx(b.landmark_cost, rel=1e-9)
    s = np.linspace(0, 1, 301)
    np.testing.assert_allclose(warp_at(invert_warp(b.vertices), s), warp_at(a.vertices, s), atol=1e-9)
    # the symmetric term holds the inverse term too
    one_sided = landmark_cost(a.vertices, lm, lam=5.0)
    assert a.landmark_cost > one_sided


def test_penalties_builtin_and_callable():
    q0, q1, _ = open_pair(50)
    lm = Landmarks([0.5], [0.3])
    sq = optimal_warp(q0, q1, landmarks=lm, lam=20.0, method="dp")
    cb = optimal_warp(q0, q1, landmarks=lm, lam=20.0, penalty=lambda x, c: (x - c) ** 2, method="dp")
    # the callable is tabulated for the DP (4096 intervals): same warp up to table error
    assert cb.energy == pytest.approx(sq.energy, rel=1e-5)
    ab = optimal_warp(q0, q1, landmarks=lm, lam=20.0, penalty="abs", method="dp")
    gap = abs(warp_at(ab.vertices, 0.5) - 0.3)
    assert ab.landmark_cost == pytest.approx(20.0 * gap, rel=1e-12)


def test_landmark_at_the_ends():
    q0, q1, _ = open_pair(30)
    res = optimal_warp(q0, q1, landmarks=[[0.0, 0.1], [1.0, 1.0]], lam=2.0)
    assert res.landmark_cost == pytest.approx(2.0 * 0.01)
    with pytest.raises(ValueError, match="hard windows"):
        optimal_warp(q0, q1, landmarks=[[0.0, 0.1]], penalty="window", windows=0.05)
