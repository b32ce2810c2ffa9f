"""The default method reaches the elastic distance; ``optimal_warp(options=...)`` (issue 13)."""

from __future__ import annotations

import numpy as np
import pytest

from elastic_motion.warp import WarpOptions, optimal_warp, warp_energy
from elastic_motion.warp.options import DEFAULT_METHOD

#: Elastic distance of paper 001's open pair (sec. 4.1, Fig. 3: three vs two extrema), as built
#: in ``examples/warp_2d.py``; dp+refine at N = 800 gives 0.62926, N = 1600 0.62925.
ELASTIC_DISTANCE = 0.629


def paper_open_pair(n: int) -> tuple[np.ndarray, np.ndarray]:
    t = np.linspace(0.0, 1.0, n + 1)

    def srv(c):
        v = np.diff(c, axis=0) * n
        return v / np.sqrt(np.linalg.norm(v, axis=1))[:, None]

    c0 = np.column_stack([t, 0.25 * np.sin(3 * np.pi * t)])
    c1 = np.column_stack([t, 0.25 * np.sin(2 * np.pi * t) * (1 + 0.3 * t)])
    return srv(c0), srv(c1)


def test_default_method_converges_to_the_elastic_distance():
    assert DEFAULT_METHOD == "dp+refine" and WarpOptions().method == "dp+refine"
    dists = []
    for n in (100, 200, 400):
        q0, q1 = paper_open_pair(n)
        res = optimal_warp(q0, q1)
        assert res.diagnostics.method == "dp+refine"
        assert res.distance == pytest.approx(ELASTIC_DISTANCE, rel=5e-3)
        assert res.distance**2 == pytest.approx(warp_energy(q0, q1, res.vertices), rel=1e-12)
        dists.append(res.distance)
        # the DP alone is stuck 17 % above: the best warp is steeper than slope 10 somewhere
        assert optimal_warp(q0, q1, method="dp").distance > 1.15 * ELASTIC_DISTANCE
    assert dists[2] <= dists[0] + 1e-6
    # the optimal warp really leaves [1/10, 10]: that is why the DP cannot reach it
    slopes = np.diff(res.vertices[:, 1]) / np.diff(res.vertices[:, 0])
    assert slopes.max() > 10 or slopes.min() < 0.1


def test_options_fill_the_solver_keywords():
    q0, q1 = paper_open_pair(60)
    opts = WarpOptions(method="dp", neighbourhood=4)
    a = optimal_warp(q0, q1, options=opts)
    b = optimal_warp(q0, q1, method="dp", neighbourhood=4)
    assert a.diagnostics.method == "dp" and a.diagnostics.max_step == 4
    assert a.energy == b.energy
    # an explicit keyword that agrees is accepted; one that disagrees is an error
    assert optimal_warp(q0, q1, options=opts, method="dp").energy == a.energy
    with pytest.raises(ValueError, match="method"):
        optimal_warp(q0, q1, options=opts, method="dp+refine")
    with pytest.raises(ValueError, match="neighbourhood"):
        optimal_warp(q0, q1, options=opts, neighbourhood=10)
    with pytest.raises(ValueError, match="coarse_to_fine"):
        optimal_warp(q0, q1, options=opts, coarse_to_fine=True)
    with pytest.raises(ValueError, match="none"):
        optimal_warp(q0, q1, options=WarpOptions(method="none"))
    with pytest.raises(ValueError, match="WarpOptions"):
        optimal_warp(q0, q1, options={"method": "dp"})
    c = optimal_warp(q0, q1, options=WarpOptions(coarse_to_fine=True))
    assert c.diagnostics.method == "dp+refine"
