"""Shared test fixtures.

Real motion capture lives in ``../shared/mocap`` beside the repository (or wherever
``ELASTIC_MOTION_MOCAP`` points).  Tests that need it take the ``mocap_dir`` fixture,
which skips them when the folder is absent.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parents[1]
MOCAP_DIR = Path(os.environ.get("ELASTIC_MOTION_MOCAP", REPO_ROOT.parent / "shared" / "mocap"))


@pytest.fixture(scope="session")
def mocap_dir() -> Path:
    """Path of the shared real-data folder; skips the test when it is absent."""
    if not MOCAP_DIR.is_dir():
        pytest.skip(f"real motion-capture folder not found: {MOCAP_DIR}")
    return MOCAP_DIR
