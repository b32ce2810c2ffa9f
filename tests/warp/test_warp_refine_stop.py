"""The refinement's stopping rule (issue 34): it stops when the energy decreased by less than
``tol`` (relative) per iteration over the last ``window`` iterations; on real walks it stops
on that rule (not on ``max_iter``, as it did before on some of them) after a descent that
gains about 1 % over the DP (0.3 % before on CMU 131)."""

from __future__ import annotations

import numpy as np
import pytest

from elastic_motion.defaults import DEFAULT_REFINE_MAX_ITER, DEFAULT_REFINE_TOL, DEFAULT_REFINE_WINDOW
from elastic_motion.warp import WarpSolverOptions, optimal_warp
from elastic_motion.warp.dp import DPProblem
from elastic_motion.warp.refine import RefineOptions, refine_warp


def smooth_pair(n: int, d: int = 3, seed: int = 5) -> tuple[np.ndarray, np.ndarray]:
    """``c0 = c1 o gamma`` for smooth random curves in R^d, SRV arrays on n cells."""
    rng = np.random.default_rng(seed)
    amp = rng.normal(size=(4, d)) / np.arange(1, 5)[:, None]
    phase = rng.uniform(0, 2 * np.pi, (4, d))

    def curve(x: np.ndarray) -> np.ndarray:
        k = np.arange(1, 5)[None, :, None]
        return np.sum(amp[None] * np.sin(np.pi * k * x[:, None, None] + phase[None]), axis=1)

    t = np.linspace(0.0, 1.0, n + 1)

    def srv(c: np.ndarray) -> np.ndarray:
        v = np.diff(c, axis=0) * n
        return v / np.sqrt(np.linalg.norm(v, axis=1))[:, None]

    return srv(curve(t + 0.3 * np.sin(np.pi * t) ** 2 * (t - 0.4))), srv(curve(t))


def test_the_stated_defaults_are_the_options_defaults():
    assert RefineOptions().tol == WarpSolverOptions().tol == DEFAULT_REFINE_TOL == 1e-7
    assert RefineOptions().max_iter == WarpSolverOptions().max_iter == DEFAULT_REFINE_MAX_ITER
    assert RefineOptions().window == DEFAULT_REFINE_WINDOW == 20


def test_stops_when_the_relative_decrease_over_the_window_falls_below_tol():
    """The descent is deterministic, so ``max_iter = j`` gives the energy ``E[j]`` of iteration
    j: the rule ``E[k - w] - E[k] < w tol |E[k]|`` holds at the stop k and not at k - 1."""
    q0, q1 = smooth_pair(60)
    t = np.linspace(0.0, 1.0, 61)
    pb = DPProblem(q0, t, q1, t, t, t)
    start = optimal_warp(q0, q1, method="dp").vertices
    tol, w = 1e-6, 4
    res = refine_warp(pb, start, tol=tol, window=w)
    k = res.iterations
    assert res.stop == "tol" and w < k < res.evaluations

    def energy(j: int) -> float:
        return refine_warp(pb, start, tol=tol, window=w, max_iter=j).energy

    assert energy(k) == res.energy
    assert energy(k - w) - energy(k) < w * tol * abs(energy(k))
    assert energy(k - 1 - w) - energy(k - 1) >= w * tol * abs(energy(k - 1))


def test_tolerance_zero_never_stops_on_the_rule_and_a_large_one_after_one_window():
    q0, q1 = smooth_pair(40)
    t = np.linspace(0.0, 1.0, 41)
    pb = DPProblem(q0, t, q1, t, t, t)
    start = optimal_warp(q0, q1, method="dp").vertices
    for w in (1, 3, 7):
        res = refine_warp(pb, start, tol=1.0, window=w)  # no window decreases the energy by w * 100 %
        assert (res.iterations, res.stop) == (w, "tol")
    res = refine_warp(pb, start, tol=0.0, max_iter=60)
    assert res.stop != "tol"
    assert res.iterations == 60 or res.stop in ("line search", "stationary")


def cmu_pair_srv(mocap_dir, names: tuple[str, str], n: int) -> tuple[np.ndarray, np.ndarray]:
    """Two CMU clips as in ``benchmarks/warp.py``: T-pose dropped, metres, n + 1 frames over
    their duration, SRV of the SO(3)^31 x R^3 curve (shape (n, 96))."""
    motion = pytest.importorskip("elastic_motion.motion")
    from elastic_motion.curves import srv_transform

    out = []
    for name in names:
        mo = motion.to_metres(motion.drop_tpose(motion.read_motion(mocap_dir / "cmu" / "bvh" / name)))
        times = np.asarray(mo.times)
        mo = motion.resample_at_times(mo, times, np.linspace(times[0], times[-1], n + 1), fps=mo.fps)
        out.append(srv_transform(motion.to_lie_curve(mo)).q)
    return out[0], out[1]


@pytest.mark.mocap
@pytest.mark.parametrize(
    ("names", "gain"),
    [
        (("07_01.bvh", "08_02.bvh"), 0.012),  # measured 1.44 %; before issue 34 1.07 %
        (("131_01.bvh", "131_02.bvh"), 0.008),  # measured 1.03 %; before issue 34 0.29 %
    ],
)
def test_the_descent_does_not_stop_in_a_stall_on_real_walks(mocap_dir, names, gain):
    """The benchmark's CMU pairs at N = 400: the default refinement converges (stops on its
    tolerance, well before ``max_iter``) and lowers the DP's energy by about 1 %."""
    q0, q1 = cmu_pair_srv(mocap_dir, names, 400)
    dp = optimal_warp(q0, q1, method="dp")
    ref = optimal_warp(q0, q1)
    assert ref.diagnostics.refine_stop == "tol"
    assert ref.diagnostics.iterations < 0.9 * DEFAULT_REFINE_MAX_ITER
    assert ref.energy < (1.0 - gain) * dp.energy


def test_the_kernels_binary_search_is_numpys_searchsorted():
    """The refinement's landmark term finds pieces with its own loop (no array-math import)."""
    from elastic_motion.warp.refine_kernels import _search_left

    rng = np.random.default_rng(3)
    y = np.concatenate([[0.0], np.sort(rng.random(40)), [1.0]])
    y[10] = y[11]  # a flat piece: the first index wins, as in numpy
    for v in [*rng.random(200), *y, -0.5, 1.5]:
        assert _search_left(y, v) == np.searchsorted(y, v), v
