"""Exactness of the DP's constraints and of its landmark term (issue 13, smaller defects).

- ``windows=0`` is an exact hard constraint that the DP can meet on its grid: it must not be
  refused as infeasible because ``phi`` on a linear piece is rounded.
- The landmark term of a DP edge follows the erratum of paper 001 eq. 27-28 (``docs/warp.md``,
  "Landmark erratum"): a pair is charged on the edge whose *domain* holds ``theta0``.  Two
  checks that do not re-use the solver's own scoring: the DP table value against the exact
  objective of the returned warp, and the DP optimum against a brute-force enumeration of
  every grid path scored by :func:`warp_energy` + :func:`landmark_cost`.
"""

from __future__ import annotations

import numpy as np
import pytest
from warp_testlib import all_paths

from elastic_motion.warp import Landmarks, landmark_cost, optimal_warp, warp_at, warp_energy
from elastic_motion.warp.dp import DPPlan, LandmarkTables, as_steps, solve_dp
from elastic_motion.warp.landmarks import make_penalty


def test_zero_window_is_met_not_refused():
    rng = np.random.default_rng(0)
    n0, n1 = 30, 70
    q0, q1 = rng.normal(size=(n0, 2)), rng.normal(size=(n1, 2))
    t0, t1 = np.linspace(0, 1, n0 + 1), np.linspace(0, 1, n1 + 1)
    # node pairs reachable with slopes in [1/10, 10]; (1, 7) was refused by the old kernel
    for i, j in [(1, 7), (3, 10), (7, 19), (11, 40), (20, 43), (29, 67)]:
        for penalty in ("window", "squared"):
            res = optimal_warp(q0, q1, landmarks=[[t0[i], t1[j]]], windows=0.0, penalty=penalty)
            assert abs(warp_at(res.vertices, t0[i]) - t1[j]) <= 1e-12
            assert np.isfinite(res.energy)


def test_zero_window_symmetric_form():
    rng = np.random.default_rng(1)
    q0, q1 = rng.normal(size=(30, 2)), rng.normal(size=(70, 2))
    res = optimal_warp(q0, q1, landmarks=[[1 / 30, 0.1]], windows=0.0, penalty="window", symmetric=True)
    assert abs(warp_at(res.vertices, 1 / 30) - 0.1) <= 1e-12


def _open_pair(n0: int, n1: int):
    t0, t1 = np.linspace(0, 1, n0 + 1), np.linspace(0, 1, n1 + 1)

    def srv(t, y):
        c = np.column_stack([t, y(t)])
        v = np.diff(c, axis=0) / np.diff(t)[:, None]
        return v / np.sqrt(np.linalg.norm(v, axis=1))[:, None]

    return srv(t0, lambda x: 0.4 * np.sin(5 * np.pi * x)), srv(t1, lambda x: 0.4 * np.sin(3 * np.pi * x))


# theta0 in one DP edge's domain, theta1 in a *later* edge's range for most paths: the paper's
# rule (charge on the edge whose range holds theta1) and the erratum's differ here
LM = Landmarks([0.27, 0.61], [0.52, 0.83])


def test_dp_table_value_is_the_exact_objective_of_its_warp():
    """The DP's own value equals the exact energy of the warp it returns (wrong rule: not)."""
    q0, q1 = _open_pair(40, 50)
    t0, t1 = np.linspace(0, 1, 41), np.linspace(0, 1, 51)
    for lam, sym in [(3.0, False), (3.0, True), (40.0, False)]:
        spec = make_penalty("squared", lam, None, len(LM))
        out = solve_dp(q0, t0, q1, t1, LandmarkTables(LM, spec, sym), DPPlan(as_steps(10), band=20))
        exact = warp_energy(q0, q1, out.vertices) + landmark_cost(out.vertices, LM, lam=lam, symmetric=sym)
        assert out.value == pytest.approx(exact, rel=1e-10, abs=1e-12), (lam, sym)


@pytest.fixture(scope="module")
def all_paths_scored():
    n0, n1 = 8, 9
    q0, q1 = _open_pair(n0, n1)
    t0, t1 = np.linspace(0, 1, n0 + 1), np.linspace(0, 1, n1 + 1)
    verts = []
    for path in all_paths(n0, n1, as_steps(3)):  # 1434 paths
        p = np.array(path)
        verts.append(np.column_stack([t0[p[:, 0]], t1[p[:, 1]]]))
    return q0, q1, verts, [warp_energy(q0, q1, v) for v in verts]


# pairs off the nodes; with these, the paper's rule (charge the edge whose range holds theta1,
# at phi(theta0) of that edge's line) makes the DP return a warp 0.06 - 0.3 above the optimum
@pytest.mark.parametrize("pairs", [[[0.3, 0.2], [0.6, 0.8]], [[0.2, 0.5]]])
@pytest.mark.parametrize("symmetric", [False, True])
def test_dp_equals_brute_force_over_all_grid_paths(all_paths_scored, pairs, symmetric):
    """Independent check: enumerate every grid path, score it exactly, compare the minimum."""
    q0, q1, verts, elastic = all_paths_scored
    lm, lam = Landmarks.from_pairs(pairs), 25.0
    best = min(
        e + landmark_cost(v, lm, lam=lam, symmetric=symmetric) for e, v in zip(elastic, verts, strict=True)
    )
    res = optimal_warp(q0, q1, neighbourhood=3, landmarks=lm, lam=lam, symmetric=symmetric, method="dp")
    assert res.energy == pytest.approx(best, rel=1e-12)
