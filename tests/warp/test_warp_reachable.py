"""Curves with very different cell counts: the DP grid is refined so that a warp exists.

A short clip against a long take gave "landmarks: no warp on the DP grid meets the hard
windows" although no landmarks were asked for: with slopes in [1/10, 10] no path of DP
steps joins the corners of a 6 x 690 grid.
"""

from __future__ import annotations

import numpy as np
import pytest

from elastic_motion.warp import optimal_warp, warp_energy


def srv(n: int, seed: int, d: int = 3) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return rng.normal(size=(n, d))


@pytest.mark.parametrize(("n0", "n1"), [(6, 690), (690, 6), (7, 40)])
def test_short_against_long_has_an_exact_warp(n0, n1):
    q0, q1 = srv(n0, 1), srv(n1, 2)
    res = optimal_warp(q0, q1, method="dp")
    assert np.isfinite(res.distance)
    # the reported energy is the exact energy of the returned warp
    assert res.energy == pytest.approx(warp_energy(q0, q1, res.vertices), rel=1e-10)
    # and no worse than the identity (a feasible warp the DP could always have taken)
    assert res.energy <= warp_energy(q0, q1, np.array([[0.0, 0.0], [1.0, 1.0]])) + 1e-12


def test_an_infeasible_grid_names_the_slopes_not_landmarks():
    q0, q1 = srv(6, 1), srv(690, 2)
    u = np.linspace(0, 1, 7)
    with pytest.raises(ValueError, match=r"^neighbourhood: no increasing warp on the DP grid of 6 x 690"):
        optimal_warp(q0, q1, method="dp", grid=(u, np.linspace(0, 1, 691)))


def test_the_dp_table_is_bounded_before_allocation():
    """Two 100k-frame clips ended in a MemoryError; the table's size is checked first."""
    from elastic_motion import limits

    q0, q1 = srv(50, 1), srv(60, 2)
    with limits.override(max_dp_nodes=51 * 61):
        assert np.isfinite(optimal_warp(q0, q1, method="dp").distance)
    with limits.override(max_dp_nodes=51 * 61 - 1), pytest.raises(ValueError, match=r"51 x 61 nodes"):
        optimal_warp(q0, q1, method="dp")
