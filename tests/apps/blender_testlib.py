"""Shared checks of the Blender add-on's tests: a result against its inputs, from the figures
that ``blender_addon_rigs.measure`` takes inside Blender (metres, degrees)."""

from __future__ import annotations

import math


def _horizontal(a, b):
    return math.hypot(a[0] - b[0], a[1] - b[1])


def check_stands_where_the_input_stood(got, inputs, op):
    """The result ``got`` against the inputs' figures: the hips start where the first input's
    did (2 cm) and travel as far (loop: within 5 % of its travel; blend: within 5 % of the
    range of the inputs'), the body upright (hips -> head under 10 deg from world up on
    average), the feet on its floor (1 cm)."""
    first = inputs[0]
    assert _horizontal(got["start"], first["start"]) < 0.02, (got["start"], first["start"])
    travels = [m["travel"] for m in inputs]
    if op == "loop":
        assert abs(got["travel"] - first["travel"]) <= 0.05 * first["travel"], (got["travel"], travels)
    else:
        assert 0.95 * min(travels) <= got["travel"] <= 1.05 * max(travels), (got["travel"], travels)
    assert got["tilt"] < 10.0, (got["tilt"], [m["tilt"] for m in inputs])
    assert abs(got["floor"] - first["floor"]) < 0.01, (got["floor"], first["floor"])
