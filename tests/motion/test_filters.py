"""The frame filters of :mod:`elastic_motion.motion.filters` give scipy.ndimage's numbers to the
last bit, and the package no longer imports scipy.ndimage (issue 34: a third of the bare
Python's start-up)."""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest
from scipy import ndimage

from elastic_motion.motion.filters import gaussian_frames, max_frames, min_frames, percentile_frames

SRC = Path(__file__).resolve().parents[2] / "src" / "elastic_motion"


def _same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    return a.shape == b.shape and np.array_equal(a.view(np.int64), b.view(np.int64))


def _cases(seed: int, count: int):
    rng = np.random.default_rng(seed)
    for _ in range(count):
        n = int(rng.integers(2, 260))
        shape = (n, *rng.integers(1, 4, size=int(rng.integers(0, 3))).tolist())
        yield rng, rng.standard_normal(shape) * 10.0 ** rng.uniform(-3, 3)


def test_gaussian_is_scipys_to_the_bit():
    for rng, x in _cases(0, 150):
        sigma = float(rng.uniform(0.05, 60.0))  # kernels wider than the clip too
        truncate = float(rng.choice([4.0, 2.5]))
        want = ndimage.gaussian_filter1d(x, sigma, axis=0, mode="nearest", truncate=truncate)
        assert _same_bits(gaussian_frames(x, sigma, truncate=truncate), want), (x.shape, sigma)


def test_percentile_max_min_are_scipys():
    for rng, x in _cases(1, 120):
        size = 2 * int(rng.integers(0, 70)) + 1
        pct = float(rng.choice([0.0, 10.0, 37.5, 50.0, 100.0, rng.uniform(0, 100)]))
        footprint = (size,) + (1,) * (x.ndim - 1)
        want = ndimage.percentile_filter(x, pct, size=footprint, mode="nearest")
        assert _same_bits(percentile_frames(x, pct, size), want), (x.shape, pct, size)
        assert _same_bits(max_frames(x, size), ndimage.maximum_filter1d(x, size, axis=0))
        assert _same_bits(min_frames(x, size), ndimage.minimum_filter1d(x, size, axis=0))


def test_edge_cases_and_errors():
    x = np.arange(5.0)
    assert gaussian_frames(x, 0.0) is x and gaussian_frames(x[:1], 3.0).shape == (1,)
    with pytest.raises(ValueError, match="sigma_frames"):
        gaussian_frames(x, float("nan"))
    with pytest.raises(ValueError, match="odd"):
        max_frames(x, 4)
    with pytest.raises(ValueError, match="percentile"):
        percentile_frames(x, 101.0, 3)


def test_no_module_of_the_package_imports_scipy_ndimage():
    """Contacts, leg IK, the clean-up and the blend's anchoring smooth with these filters: no
    import of scipy.ndimage anywhere in the package, at the top of a module or in a function."""
    found = []
    for path in sorted(SRC.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = []
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module:
                names = [node.module] + [f"{node.module}.{a.name}" for a in node.names]
            if any(n == "scipy.ndimage" or n.startswith("scipy.ndimage.") for n in names):
                found.append(f"{path.relative_to(SRC)}:{node.lineno}")
    assert found == []
