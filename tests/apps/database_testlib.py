"""Shared by the database tests: whether Dask is installed, the marker of tests that need it,
small synthetic clips (``synthetic_motion``, ``write_clips``) and the check that a run on a
cluster is the serial run bit for bit."""

from __future__ import annotations

import signal
from pathlib import Path

import numpy as np
import pytest

from elastic_motion.motion import Motion, Skeleton, write_bvh
from elastic_motion.motion.rotations import euler_to_matrix

try:
    import distributed  # noqa: F401

    HAVE_DASK = True
except ImportError:  # the `cluster` extra is not installed
    HAVE_DASK = False

#: Skips a test when ``dask[distributed]`` (the extra ``cluster``) is missing.
needs_dask = pytest.mark.skipif(not HAVE_DASK, reason="needs dask[distributed] (extra 'cluster')")


def assert_same_as_serial(res, serial, *, min_motions: int = 2) -> None:
    """``res`` (a ``compute_matrix`` result, e.g. of a cluster) is ``serial`` bit for bit: every
    matrix, and the SRV cache (names, paths, groups, info, skipped files, weights, arrays)."""
    from elastic_motion.apps.database.cache import SRVCache

    assert res.complete and len(res.names) == len(serial.names) >= min_motions
    assert set(res.distances) == set(serial.distances)
    for r in serial.distances:
        assert np.asarray(res.distances[r]).tobytes() == np.asarray(serial.distances[r]).tobytes()
    a, b = (SRVCache.load(Path(x.out_dir) / "srv_cache.npz") for x in (res, serial))
    assert (a.names, a.paths, a.groups.tolist(), a.info, a.skipped) == (
        b.names,
        b.paths,
        b.groups.tolist(),
        b.info,
        b.skipped,
    )
    assert a.group_weights == b.group_weights and a.pose_weights == b.pose_weights
    assert a.group_rest == b.group_rest  # each group's rest pose, from the same first motion
    for r in a.q:
        assert all(x.tobytes() == y.tobytes() for x, y in zip(a.q[r], b.q[r], strict=True))


def assert_local_cluster_is_serial(folder: Path, tmp_path: Path, settings) -> None:
    """A forced ``engine="local"`` run over ``folder`` reads its files on the workers and is
    the serial run bit for bit (:func:`assert_same_as_serial`)."""
    from elastic_motion.apps.database import compute_matrix

    serial = compute_matrix([folder], tmp_path / "serial", settings)
    local = compute_matrix([folder], tmp_path / "local", settings, engine="local", force_cluster=True)
    assert local.report["runs"][-1]["read_where"] == "workers"
    assert_same_as_serial(local, serial)


def synthetic_motion(kind: int, variant: int, *, frames: int = 30, extra_joint: bool = False) -> Motion:
    """A 4-joint (5 with ``extra_joint``) clip: ``kind`` sets frequency/amplitude, ``variant``
    a time warp and a small phase change."""
    names = ["Hips", "Spine", "LeftLeg", "RightLeg"] + (["Head"] if extra_joint else [])
    parents = [-1, 0, 0, 0] + ([1] if extra_joint else [])
    offsets = [[0, 0, 0], [0, 0.3, 0], [0.1, -0.1, 0], [-0.1, -0.1, 0]] + (
        [[0, 0.3, 0]] if extra_joint else []
    )
    rot = ("Zrotation", "Yrotation", "Xrotation")
    channels = [("Xposition", "Yposition", "Zposition", *rot)] + [rot] * (len(names) - 1)
    sk = Skeleton(
        names, parents, offsets, channels, end_site_parents=[2, 3], end_site_offsets=[[0, -0.5, 0]] * 2
    )
    s = np.linspace(0.0, 1.0, frames)
    s = s + 0.08 * variant * np.sin(np.pi * s) / (1 + variant)  # time warp
    freq, amp = [(1.0, 0.6), (2.0, 0.25), (1.5, 0.4)][kind]
    ph = 0.05 * variant
    j = len(names)
    ang = np.zeros((frames, j, 3))
    for k in range(j):
        ang[:, k, 2] = amp * np.sin(2 * np.pi * freq * s + ph + k)
        ang[:, k, 1] = 0.3 * amp * np.cos(2 * np.pi * freq * s + k)
    root = np.stack([0.02 * np.sin(4 * np.pi * s), 0.9 + 0.02 * s, (1.0 + 0.3 * kind) * s], axis=1)
    return Motion(sk, 30.0, root, euler_to_matrix(ang, "ZYX"), metres_per_unit=1.0)


def write_clips(folder: Path, *, kinds: tuple[int, ...], variants: int, frames: int, step: int) -> None:
    """``k{kind}_v{v}.bvh`` in ``folder``: :func:`synthetic_motion` of each kind and variant,
    ``frames + step * v`` frames."""
    for kind in kinds:
        for v in range(variants):
            write_bvh(synthetic_motion(kind, v, frames=frames + step * v), folder / f"k{kind}_v{v}.bvh")


@pytest.fixture
def fail_on_blocking_read():
    """A read that blocks (a FIFO opened) fails the test after 60 s instead of hanging the
    suite; a test module makes it autouse with ``pytestmark``."""

    def fail(signum, frame):
        raise TimeoutError("blocked: a FIFO was opened")

    old = signal.signal(signal.SIGALRM, fail)
    signal.alarm(60)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, old)
