"""Dynamic programming: optimality on its grid, exact recovery, pruning, coarse to fine."""

from __future__ import annotations

import numpy as np
import pytest
from warp_testlib import all_paths

from elastic_motion.curves import SRVFunction, reparametrize_srv
from elastic_motion.groups import Euclidean
from elastic_motion.warp import coprime_steps, dp_kernels, optimal_warp, warp_energy
from elastic_motion.warp import dp as warp_dp


def random_grid(n: int, rng: np.random.Generator) -> np.ndarray:
    w = rng.uniform(0.3, 1.7, n)
    t = np.concatenate([[0.0], np.cumsum(w) / w.sum()])
    t[-1] = 1.0
    return t


@pytest.mark.parametrize(
    ("n0", "n1", "max_step", "uniform"), [(6, 6, 3, True), (5, 7, 3, False), (7, 5, 4, False)]
)
def test_dp_equals_brute_force(n0, n1, max_step, uniform):
    rng = np.random.default_rng(n0 * 10 + n1)
    t0 = np.linspace(0, 1, n0 + 1) if uniform else random_grid(n0, rng)
    t1 = np.linspace(0, 1, n1 + 1) if uniform else random_grid(n1, rng)
    q0, q1 = rng.normal(size=(n0, 3)), rng.normal(size=(n1, 3))
    steps = coprime_steps(max_step)
    paths = all_paths(n0, n1, steps)
    assert len(paths) > 20
    energies = [
        warp_energy(q0, q1, np.column_stack([t0[[p[0] for p in path]], t1[[p[1] for p in path]]]), t0, t1)
        for path in paths
    ]
    res = optimal_warp(q0, q1, t0=t0, t1=t1, neighbourhood=max_step, method="dp")
    assert res.energy == pytest.approx(min(energies), rel=1e-12, abs=1e-14)
    assert res.diagnostics.energy_dp == pytest.approx(res.energy)
    assert res.distance == pytest.approx(np.sqrt(res.energy))


def test_dp_custom_grid_brute_force():
    """A DP grid that is not the break points: the edge cost walks the merged breaks."""
    rng = np.random.default_rng(7)
    q0, q1 = rng.normal(size=(9, 2)), rng.normal(size=(11, 2))
    u, v = np.array([0, 0.2, 0.45, 0.5, 0.8, 1.0]), np.array([0, 0.1, 0.3, 0.66, 0.9, 1.0])
    paths = all_paths(5, 5, coprime_steps(2))
    best = min(
        warp_energy(q0, q1, np.column_stack([u[[p[0] for p in path]], v[[p[1] for p in path]]]))
        for path in paths
    )
    res = optimal_warp(q0, q1, grid=(u, v), neighbourhood=2, method="dp")
    assert res.energy == pytest.approx(best, rel=1e-12)


def test_recovers_warp_applied_exactly():
    """q0 = q1 * gamma exactly (curves layer action): the DP finds gamma with energy 0."""
    rng = np.random.default_rng(8)
    n1, d = 60, 4
    q1 = np.cumsum(rng.normal(size=(n1, d)), axis=0) / 5 + 1.0
    t1 = np.linspace(0, 1, n1 + 1)
    # vertices of gamma on t1 nodes in the range, so gamma is a path on the DP grid
    gamma = np.array([[0, 0], [0.2, t1[6]], [0.5, t1[33]], [0.75, t1[40]], [1, 1]])
    warped = reparametrize_srv(SRVFunction(q1, t1, np.zeros(d), Euclidean(d)), gamma)
    res = optimal_warp(warped.q, q1, t0=warped.t, t1=t1)
    assert res.energy < 1e-20
    s = np.linspace(0, 1, 501)
    np.testing.assert_allclose(np.interp(s, *res.vertices.T), np.interp(s, *gamma.T), atol=1e-12)


def test_pruning_and_row_kernel_do_not_change_the_result():
    rng = np.random.default_rng(9)
    n = 240
    t = np.linspace(0, 1, n + 1)
    c = np.cumsum(rng.normal(size=(n + 1, 5)), axis=0)
    q1 = np.diff(c, axis=0) * n
    q1 /= np.sqrt(np.linalg.norm(q1, axis=1))[:, None]
    q0 = np.roll(q1, 3, axis=0) + 0.1 * rng.normal(size=q1.shape)
    steps = coprime_steps(10)
    lmd = warp_dp.LandmarkTables(None, None, False)
    full = warp_dp.solve_dp(q0, t, q1, t, lmd, warp_dp.DPPlan(steps, band=20, prune=False))
    pruned = warp_dp.solve_dp(q0, t, q1, t, lmd, warp_dp.DPPlan(steps, band=20, prune=True))
    assert pruned.value == pytest.approx(full.value, rel=1e-12)
    np.testing.assert_array_equal(pruned.vertices, full.vertices)
    assert pruned.nodes < full.nodes
    # the row-vectorised kernel (uniform grids) and the scalar kernel fill the same table
    pb = warp_dp.DPProblem(q0, t, q1, t, t, t)
    lo = np.zeros(n + 1, dtype=np.int64)
    hi = np.full(n + 1, n, dtype=np.int64)
    taps = warp_dp._taps(pb, steps)
    lm_args = lmd.kernel_args(pb.u, pb.v)
    h_scalar, _ = dp_kernels.dp_solve(
        pb.u, pb.v, pb.t0, pb.t1, pb.c0, pb.c1, pb.G, pb.P0, pb.P1, steps, taps, lo, hi, lm_args
    )
    h_rows, _ = dp_kernels.dp_solve_rows(pb.u, pb.v, pb.P0, pb.P1, pb.G, steps, taps, lo, hi, lm_args)
    np.testing.assert_allclose(h_rows, h_scalar, rtol=1e-12, atol=1e-13)
    c2f = optimal_warp(q0, q1, coarse_to_fine=True)
    assert c2f.energy >= full.value * (1 - 1e-12)
    assert c2f.diagnostics.levels >= 2


def test_default_neighbourhood_is_fdasrsf_set():
    steps = coprime_steps(10)
    assert steps.shape == (63, 2)
    assert {tuple(s) for s in steps} >= {(1, 1), (1, 10), (10, 9), (7, 3)}


def test_not_worse_than_fdasrsf_dp_on_same_grid():
    """Same node grid, a superset of its slopes and the exact edge cost: never higher."""
    cf = pytest.importorskip("fdasrsf.curve_functions")
    rng = np.random.default_rng(10)
    n = 60
    t = np.linspace(0, 1, n + 1)
    s = t[:-1] + 0.5 / n
    base = np.column_stack([np.cos(4 * s), np.sin(3 * s), s**2])
    q1 = base + 0.05 * rng.normal(size=base.shape)
    q0 = np.column_stack([np.cos(4 * s**1.3), np.sin(3 * s**1.3), s**2.6])
    # fdasrsf samples the SRVF at the n+1 nodes: give it q[i] at t[i] (left-endpoint rule)
    f0 = np.vstack([q0, q0[-1:]]).T.copy()
    f1 = np.vstack([q1, q1[-1:]]).T.copy()
    gam = cf.optimum_reparam_curve(f0, f1, 0.0, "DP")
    e_fd = warp_energy(q0, q1, np.column_stack([t, gam]))
    ours = optimal_warp(q0, q1)
    assert ours.energy <= e_fd * (1 + 1e-12)
