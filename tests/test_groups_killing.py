"""The SO(3) inner product against the Killing form (issue 13: the docstring said -1/4)."""

from __future__ import annotations

import re

import numpy as np

import elastic_motion.groups as groups
from elastic_motion.groups import SO3


def _ad(g, x):
    """Matrix of ad_x = [x, .] in the coordinate basis, from the group's own bracket."""
    return np.column_stack([g.bracket(x, e) for e in np.eye(g.dim)])


def test_inner_product_is_minus_half_the_killing_form():
    g = SO3()
    rng = np.random.default_rng(0)
    m = re.search(r"``(-1/\d)`` of the Cartan-Killing form", groups.__doc__)
    assert m is not None, "the groups docstring must state the factor"
    num, den = m.group(1).split("/")
    factor = float(num) / float(den)
    for _ in range(5):
        x, y = rng.normal(size=3), rng.normal(size=3)
        killing = np.trace(_ad(g, x) @ _ad(g, y))  # B(x, y) = tr(ad_x ad_y)
        assert np.isclose(g.inner(x, y), factor * killing, rtol=1e-12)
        assert np.isclose(g.inner(x, y), -0.5 * killing, rtol=1e-12)
