"""WarpSolverOptions and RefineOptions: validation names the option, keyword overrides equal
the options object, unknown keywords are refused."""

from __future__ import annotations

import numpy as np
import pytest

from elastic_motion.errors import OptionError
from elastic_motion.warp import Landmarks, WarpOptions, WarpSolverOptions, optimal_warp
from elastic_motion.warp.dp import DPProblem, LandmarkTables
from elastic_motion.warp.landmarks import make_penalty
from elastic_motion.warp.refine import RefineOptions, refine_warp


def pair(n0: int = 40, n1: int = 33, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    m0 = (np.arange(n0) + 0.5) / n0
    m1 = (np.arange(n1) + 0.5) / n1
    a = rng.normal(size=(3, 2))
    q0 = sum(np.outer(np.cos((k + 1) * np.pi * m0 + k), a[k]) for k in range(3))
    q1 = sum(np.outer(np.cos((k + 1) * np.pi * m1**1.3 + k), a[k]) for k in range(3)) + 0.1
    return q0, q1


def same(a, b):
    assert a.energy == b.energy and a.landmark_cost == b.landmark_cost
    np.testing.assert_array_equal(a.vertices, b.vertices)
    assert a.diagnostics.method == b.diagnostics.method and a.diagnostics.max_step == b.diagnostics.max_step


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("method", "none"),
        ("band", 0),
        ("tol", -1e-3),
        ("max_iter", -1),
        ("max_iter", 2.5),
        ("seeds", "q0"),
        ("lam", -1.0),
        ("lam", float("inf")),
        ("penalty", "cubic"),
        ("grid", 3.0),
    ],
)
def test_solver_options_validation_names_the_option(field, value):
    with pytest.raises(OptionError) as exc:
        WarpSolverOptions(**{field: value})
    assert exc.value.option == field


def test_solver_options_cross_checks_and_defaults():
    grid = (np.linspace(0, 1, 11), np.linspace(0, 1, 9))
    with pytest.raises(OptionError) as exc:
        WarpSolverOptions(grid=grid, closed=True)
    assert exc.value.option == "grid"
    with pytest.raises(OptionError) as exc:
        WarpSolverOptions(grid=grid, coarse_to_fine=True)
    assert exc.value.option == "coarse_to_fine"
    with pytest.raises(ValueError, match=r"^grid\[0\]: expected parameters from 0 to 1"):
        WarpSolverOptions(grid=([0.0, 0.5], [0.0, 1.0]))
    with pytest.raises(ValueError, match=r"^neighbourhood"):
        WarpSolverOptions(neighbourhood=0)
    with pytest.raises(ValueError, match=r"^neighbourhood"):
        WarpSolverOptions(neighbourhood=np.array([[1, 0]]))
    o = WarpSolverOptions(method=None, neighbourhood=None, coarse_to_fine=None)
    assert (o.method, o.neighbourhood, o.coarse_to_fine) == ("dp+refine", 10, False)
    assert o.band_width(10) == 20 and o.replace(band=3).band_width(10) == 3
    w = WarpOptions(method="dp", neighbourhood=4, coarse_to_fine=True).solver_options()
    assert (w.method, w.neighbourhood, w.coarse_to_fine) == ("dp", 4, True)


def test_overrides_equal_the_options_object():
    q0, q1 = pair()
    lm = Landmarks([0.3, 0.6], [0.4, 0.55])
    kw = dict(method="dp", neighbourhood=4, lam=2.0, penalty="abs", windows=0.2, symmetric=True)
    same(
        optimal_warp(q0, q1, landmarks=lm, **kw), optimal_warp(q0, q1, WarpSolverOptions(**kw), landmarks=lm)
    )
    # overrides change the fields of a given options object
    base = WarpSolverOptions(method="dp", lam=2.0)
    same(
        optimal_warp(q0, q1, base, landmarks=lm, neighbourhood=4),
        optimal_warp(q0, q1, base.replace(neighbourhood=4), landmarks=lm),
    )
    assert optimal_warp(q0, q1, base, neighbourhood=4).diagnostics.max_step == 4
    # the app-level WarpOptions fills method, neighbourhood, coarse_to_fine; lam etc. are overrides
    same(
        optimal_warp(q0, q1, WarpOptions(method="dp", neighbourhood=4), landmarks=lm, lam=2.0),
        optimal_warp(q0, q1, WarpSolverOptions(method="dp", neighbourhood=4, lam=2.0), landmarks=lm),
    )
    refine = dict(method="refine", tol=1e-3, max_iter=3)
    same(optimal_warp(q0, q1, **refine), optimal_warp(q0, q1, WarpSolverOptions(**refine)))


def test_unknown_overrides_are_refused():
    q0, q1 = pair()
    with pytest.raises(OptionError, match="unknown option") as exc:
        optimal_warp(q0, q1, neighborhood=4)
    assert exc.value.option == "neighborhood"
    with pytest.raises(OptionError) as exc:
        optimal_warp(q0, q1, WarpOptions(), landmark_weight=3.0)  # an app-level field
    assert exc.value.option == "landmark_weight"
    with pytest.raises(OptionError, match="WarpOptions") as exc:
        optimal_warp(q0, q1, {"method": "dp"})
    assert exc.value.option == "options"


@pytest.mark.parametrize(
    ("field", "value"),
    [("tol", -1.0), ("jitter", float("nan")), ("max_iter", -1), ("memory", 0), ("window", 1.5)],
)
def test_refine_options_validation_names_the_option(field, value):
    with pytest.raises(OptionError) as exc:
        RefineOptions(**{field: value})
    assert exc.value.option == field


def test_refine_overrides_equal_the_options_object():
    q0, q1 = pair(30, 30, seed=3)
    t = np.linspace(0, 1, 31)
    pb = DPProblem(q0, t, q1, t, t, t)
    start = np.array([[0.0, 0.0], [1.0, 1.0]])
    lm = Landmarks([0.5], [0.45])
    lmd = LandmarkTables(lm, make_penalty("squared", 1.0, None, 1), False)
    a = refine_warp(pb, start, lmd, tol=1e-9, max_iter=20, memory=3, jitter=0.0)
    b = refine_warp(pb, start, lmd, RefineOptions(tol=1e-9, max_iter=20, memory=3, jitter=0.0))
    assert a.energy == b.energy and a.iterations == b.iterations and a.stop == b.stop
    np.testing.assert_array_equal(a.vertices, b.vertices)
    assert refine_warp(pb, start, lmd, max_iter=2).iterations == 2
    with pytest.raises(OptionError, match="unknown option"):
        refine_warp(pb, start, lmd, history=5)
