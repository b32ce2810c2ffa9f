"""Shared by the database tests: whether Dask is installed, and the marker of tests that need it."""

from __future__ import annotations

import pytest

try:
    import distributed  # noqa: F401

    HAVE_DASK = True
except ImportError:  # the `cluster` extra is not installed
    HAVE_DASK = False

#: Skips a test when ``dask[distributed]`` (the extra ``cluster``) is missing.
needs_dask = pytest.mark.skipif(not HAVE_DASK, reason="needs dask[distributed] (extra 'cluster')")
