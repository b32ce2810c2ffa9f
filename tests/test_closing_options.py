"""ClosingOptions: validation names the option, keyword overrides equal the options object,
unknown keywords and keywords a solver does not read are refused, per-solver defaults."""

from __future__ import annotations

import numpy as np
import pytest

from elastic_motion.closing import (
    CLOSING_METHODS,
    ClosingOptions,
    close_curve,
    project_closed,
    project_closed_rd,
)
from elastic_motion.closing.options import DEFAULT_MAX_ITER, DEFAULT_TOL
from elastic_motion.curves import SRVFunction, inverse_srv_transform
from elastic_motion.errors import OptionError
from elastic_motion.groups import SO3, Euclidean, PowerGroup, ProductGroup


def smooth_curve(group, n, seed=0):
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 1.0, n + 1)
    mid = 0.5 * (t[:-1] + t[1:])
    q = sum(
        np.outer(np.cos((k + 1) * np.pi * mid + rng.uniform(0, 6)), rng.normal(size=group.dim))
        for k in range(3)
    )
    return inverse_srv_transform(SRVFunction(q, t, group.exp(rng.normal(size=group.dim) * 0.5), group))


def lie_curve():
    return smooth_curve(ProductGroup([Euclidean(3), PowerGroup(SO3(), 2)]), 30, seed=1)


def same_result(a, b):
    assert a.message == b.message and a.iterations == b.iterations and a.method == b.method
    for name in ("history", "velocity_history", "objective_history", "steps"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    np.testing.assert_array_equal(a.curve.values, b.curve.values)
    np.testing.assert_array_equal(a.srv.q, b.srv.q)


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("method", "newton-raphson"),
        ("tol", -1.0),
        ("tol", float("nan")),
        ("kkt_tol", -1e-3),
        ("max_iter", 1.5),
        ("max_iter", -1),
        ("stall_iterations", -2),
        ("max_backtracks", 0.5),
        ("c1_weight", 0.0),
        ("cut_locus_tol", -1e-6),
        ("gradient", "continuous"),
        ("log_term", "left"),
        ("step", 0.0),
        ("armijo", 1.0),
        ("rotation_names", "LeftArm"),
    ],
)
def test_validation_names_the_option(field, value):
    with pytest.raises(OptionError) as exc:
        ClosingOptions(**{field: value})
    assert exc.value.option == field and str(exc.value).startswith(f"{field}: ")


def test_defaults_per_solver():
    assert CLOSING_METHODS == ("kkt", "gauss-newton", "gradient", "newton")
    assert ClosingOptions().method == "kkt" and ClosingOptions().tolerance == 1e-9
    assert ClosingOptions(method="gauss-newton").tolerance == 1e-6
    assert ClosingOptions(method="newton").iterations == 50 == DEFAULT_MAX_ITER["newton"]
    assert ClosingOptions(method="gradient", tol=1e-3, max_iter=7).tolerance == 1e-3
    assert ClosingOptions(max_iter=7).iterations == 7 and set(DEFAULT_TOL) == set(CLOSING_METHODS)
    names = ClosingOptions(rotation_names=["a", "b"]).rotation_names
    assert names == ("a", "b")
    assert ClosingOptions().replace(c1=True).c1 is True
    with pytest.raises(OptionError, match="armijo"):
        ClosingOptions().replace(armijo=-1.0)
    # each solver's own default method and tolerance
    curve = lie_curve()
    assert close_curve(curve, max_iter=0).message == "reached max_iter = 0"
    assert close_curve(curve).method == "gauss-newton"
    assert project_closed(curve).method == "kkt"


def test_overrides_equal_the_options_object():
    curve = lie_curve()
    mask = np.array([0, 1, 0, 1, 1, 1, 0, 0, 0], dtype=bool)
    kw = dict(factors=mask, c1=True, tol=1e-10, max_iter=30, rotation_names=["a", "b"])
    same_result(close_curve(curve, **kw), close_curve(curve, ClosingOptions(method="gauss-newton", **kw)))
    grad = dict(method="gradient", gradient="paper", step=0.5, armijo=1e-3, max_iter=12)
    same_result(close_curve(curve, **grad), close_curve(curve, ClosingOptions(**grad)))
    same_result(
        project_closed(curve, **kw, stall_iterations=6, kkt_tol=1e-7),
        project_closed(curve, ClosingOptions(**kw, stall_iterations=6, kkt_tol=1e-7)),
    )
    # overrides change the fields of a given options object
    base = ClosingOptions(factors=mask, c1=True)
    same_result(project_closed(curve, base, tol=1e-6), project_closed(curve, base.replace(tol=1e-6)))
    assert project_closed(curve, base, max_iter=1).iterations == 1 < project_closed(curve, base).iterations
    rd = smooth_curve(Euclidean(3), 40, seed=2)
    same_result(
        project_closed_rd(rd, factors=[True, False, True], tol=1e-12, max_iter=5),
        project_closed_rd(
            rd, ClosingOptions(method="newton", factors=[True, False, True], tol=1e-12, max_iter=5)
        ),
    )
    # fields a solver does not read are ignored in an options object (one object for every solver)
    same_result(project_closed(curve, ClosingOptions(gradient="paper", step=0.1)), project_closed(curve))


def test_unknown_or_unused_overrides_are_refused():
    curve = lie_curve()
    with pytest.raises(OptionError, match="unknown option") as exc:
        close_curve(curve, tolerance=1e-3)
    assert exc.value.option == "tolerance"
    with pytest.raises(OptionError) as exc:
        project_closed(curve, gradient="paper")  # a flow's option
    assert exc.value.option == "gradient"
    with pytest.raises(OptionError) as exc:
        close_curve(curve, stall_iterations=3)  # the projection's option
    assert exc.value.option == "stall_iterations"
    with pytest.raises(OptionError) as exc:
        project_closed_rd(smooth_curve(Euclidean(2), 20), c1=True)
    assert exc.value.option == "c1"
    with pytest.raises(OptionError, match="method"):
        project_closed(curve, ClosingOptions(method="gradient"))
    with pytest.raises(OptionError, match="method"):
        close_curve(curve, ClosingOptions())  # "kkt" is project_closed's
    with pytest.raises(OptionError, match="ClosingOptions") as exc:
        close_curve(curve, {"tol": 1e-3})
    assert exc.value.option == "options"
