"""Bad input: a clear ValueError that names the problem."""

from __future__ import annotations

import numpy as np
import pytest

from elastic_motion.warp import Landmarks, optimal_warp, warp_energy

RNG = np.random.default_rng(0)
Q0 = RNG.normal(size=(20, 3))
Q1 = RNG.normal(size=(25, 3))


def test_landmarks_outside_unit_interval():
    with pytest.raises(ValueError, match=r"theta1.*\[0, 1\].*pair 1"):
        optimal_warp(Q0, Q1, landmarks=[[0.2, 0.3], [0.5, 1.2]])
    with pytest.raises(ValueError, match=r"theta0.*\[0, 1\]"):
        Landmarks([-0.1], [0.2])


def test_crossing_landmarks_name_the_pairs():
    with pytest.raises(ValueError, match=r"pairs 0 .* and 2 .* cross"):
        optimal_warp(Q0, Q1, landmarks=[[0.2, 0.7], [0.4, 0.8], [0.6, 0.5]])
    with pytest.raises(ValueError, match=r"same theta0"):
        Landmarks([0.3, 0.3], [0.2, 0.4])


def test_nan_in_q():
    bad = Q0.copy()
    bad[4, 1] = np.nan
    with pytest.raises(ValueError, match=r"q0.*finite.*\(4, 1\)"):
        optimal_warp(bad, Q1)
    with pytest.raises(ValueError, match="q1"):
        warp_energy(Q0, np.full((5, 3), np.inf), [[0, 0], [1, 1]])


def test_mismatched_dimensions_and_shapes():
    with pytest.raises(ValueError, match=r"same dimension D.*\(20, 3\).*\(25, 4\)"):
        optimal_warp(Q0, RNG.normal(size=(25, 4)))
    with pytest.raises(ValueError, match="t0"):
        optimal_warp(Q0, Q1, t0=np.linspace(0, 1, 20))
    with pytest.raises(ValueError, match="shape"):
        optimal_warp(np.zeros((2, 3, 4)), Q1)


def test_bad_options():
    with pytest.raises(ValueError, match="method"):
        optimal_warp(Q0, Q1, method="bfgs")
    with pytest.raises(ValueError, match="penalty"):
        optimal_warp(Q0, Q1, landmarks=[[0.5, 0.5]], penalty="huber")
    with pytest.raises(ValueError, match="windows"):
        optimal_warp(Q0, Q1, landmarks=[[0.5, 0.5]], penalty="window")
    with pytest.raises(ValueError, match="windows"):
        optimal_warp(Q0, Q1, landmarks=[[0.5, 0.5]], windows=[0.1, 0.2])
    with pytest.raises(ValueError, match="lam"):
        optimal_warp(Q0, Q1, landmarks=[[0.5, 0.5]], lam=-1)
    with pytest.raises(ValueError, match="neighbourhood"):
        optimal_warp(Q0, Q1, neighbourhood=0)
    with pytest.raises(ValueError, match="phi"):
        warp_energy(Q0, Q1, [[0, 0], [0.5, 0.6], [0.7, 0.4], [1, 1]])
