"""Recover known warps on real curves: a CMU walk in SO(3)^31 x R^3 and a 2D outline."""

from __future__ import annotations

import numpy as np
import pytest

from elastic_motion.curves import SRVFunction, reparametrize_srv, srv_transform
from elastic_motion.groups import Euclidean
from elastic_motion.warp import optimal_warp


def cell_average(q: np.ndarray, t: np.ndarray, n: int) -> np.ndarray:
    """L2 projection of a piecewise constant q (on t) onto n uniform cells."""
    cum = np.vstack([np.zeros((1, q.shape[1])), np.cumsum(q * np.diff(t)[:, None], axis=0)])
    grid = np.linspace(0, 1, n + 1)
    vals = np.column_stack([np.interp(grid, t, cum[:, k]) for k in range(q.shape[1])])
    return np.diff(vals, axis=0) * n


def cmu_walk_srv(mocap_dir, n: int) -> np.ndarray:
    motion = pytest.importorskip("elastic_motion.motion")
    mo = motion.drop_tpose(motion.read_motion(mocap_dir / "cmu" / "bvh" / "07_01.bvh"))
    times = mo.times
    target = np.linspace(times[0], times[-1], n + 1)
    mo = motion.resample_at_times(mo, times, target, fps=mo.fps)
    return srv_transform(motion.to_lie_curve(mo)).q


GAMMA = np.column_stack([np.linspace(0, 1, 41), np.linspace(0, 1, 41) ** 1.4])  # smooth, known


@pytest.mark.mocap
def test_recovers_known_warp_on_cmu_walk(mocap_dir):
    n = 200
    q1 = cmu_walk_srv(mocap_dir, n)
    assert q1.shape == (n, 96)  # SO(3)^31 x R^3
    t = np.linspace(0, 1, n + 1)
    warped = reparametrize_srv(SRVFunction(q1, t, np.zeros(96), Euclidean(96)), GAMMA)
    q0 = cell_average(warped.q, warped.t, n)
    res = optimal_warp(q0, q1, method="dp+refine")
    truth = np.interp(t, *GAMMA.T)
    assert np.abs(res.phi - truth).max() < 3.0 / n  # within the grid resolution
    assert res.energy < 0.05 * optimal_warp(q0, q1, neighbourhood=[[1, 1]], method="dp").energy


def test_recovers_known_warp_on_2d_outline():
    n = 256
    s = np.linspace(0, 1, 2049)
    a = 2 * np.pi * s
    r = 1 + 0.3 * np.maximum(np.cos(5 * a), 0) ** 3 + 0.1 * np.cos(a)
    poly = np.column_stack([r * np.cos(a), r * np.sin(a)])  # hand-like outline, fine polygon

    def srv(param):
        c = np.column_stack([np.interp(param, s, poly[:, 0]), np.interp(param, s, poly[:, 1])])
        v = np.diff(c, axis=0) * n
        return v / np.sqrt(np.linalg.norm(v, axis=1))[:, None]

    t = np.linspace(0, 1, n + 1)
    truth = 0.5 * t + 0.5 * t**2
    q0, q1 = srv(truth), srv(t)  # c0 = c1 o gamma
    res = optimal_warp(q0, q1)
    assert np.abs(res.phi - truth).max() < 3.0 / n
