"""The retrieval study's distance (issue 15, ``docs/database.md``, "Retrieval quality"): the pose
term beside the SRV (``preparation.pose_arrays``, ``balanced_pose_weight``, ``with_pose_term``)
and the phase-free matching of the database (``distance_matrix(cyclic=True)``)."""

from __future__ import annotations

import numpy as np
import pytest

from elastic_motion.apps.database.preparation import balanced_pose_weight, pose_arrays, with_pose_term
from elastic_motion.errors import OptionError
from elastic_motion.motion import Motion, Skeleton
from elastic_motion.motion.rotations import axis_rotation, euler_to_matrix


def _skeleton() -> Skeleton:
    rot = ("Zrotation", "Yrotation", "Xrotation")
    return Skeleton(
        ["Hips", "Spine", "Leg"],
        [-1, 0, 0],
        [[0, 0, 0], [0, 0.3, 0], [0.1, -0.1, 0]],
        [("Xposition", "Yposition", "Zposition", *rot), rot, rot],
        end_site_parents=[1, 2],
        end_site_offsets=[[0, 0.2, 0], [0, -0.5, 0]],
    )


def _motion(angles: np.ndarray) -> Motion:
    f = len(angles)
    root = np.stack([np.zeros(f), np.full(f, 0.9), np.linspace(0, 1, f)], axis=1)
    return Motion(_skeleton(), 30.0, root, euler_to_matrix(angles, "ZYX"), metres_per_unit=1.0)


def test_pose_arrays_formula():
    rng = np.random.default_rng(0)
    m = _motion(rng.uniform(-2.5, 2.5, (6, 3, 3)))
    w = np.array([5.0, 2.0, 0.5])
    got = pose_arrays(m, w)
    r = m.rotations
    want = np.stack(
        [
            np.concatenate(
                [
                    np.sqrt(w[j]) * ((r[f, j] + r[f + 1, j]) / 2 - np.eye(3)).ravel() / np.sqrt(2)
                    for j in (1, 2)
                ]
            )
            for f in range(5)
        ]
    )
    assert got.shape == (5, 18)
    np.testing.assert_allclose(got, want, atol=1e-14)


@pytest.mark.parametrize("angle", [0.1, 1.0, 3.0])
def test_pose_distance_is_the_chord_of_the_angle(angle):
    """Two still poses a rotation ``angle`` apart about one axis: ``2 sin(angle / 2)`` (the
    angle for small angles), times ``sqrt(w)``; continuous through 180 degrees."""
    a = _motion(np.zeros((2, 3, 3)))
    b = a.replace(rotations=a.rotations.copy())
    b.rotations[:, 2] = axis_rotation(np.array([angle, angle]), "Z")
    w = np.array([1.0, 1.0, 4.0])
    d = np.linalg.norm(pose_arrays(a, w) - pose_arrays(b, w))
    assert d == pytest.approx(2.0 * 2.0 * np.sin(angle / 2), rel=1e-12)


def test_balanced_weight_equalises_mean_pair_distances():
    rng = np.random.default_rng(1)
    s = rng.normal(size=(7, 5, 4)) * 3.0
    p = rng.normal(size=(7, 5, 6)) + 2.0
    lam = balanced_pose_weight(list(s), list(p))
    pairs = [(k, m) for k in range(7) for m in range(k + 1, 7)]
    srv = np.mean([np.sum((s[k] - s[m]) ** 2) for k, m in pairs])
    pose = np.mean([np.sum((p[k] - p[m]) ** 2) for k, m in pairs])
    assert lam * pose == pytest.approx(srv, rel=1e-12)
    # the augmented arrays: squared distances add, the pose term weighted by lam
    a, b = with_pose_term(s[0], p[0], lam), with_pose_term(s[1], p[1], lam)
    assert a.flags.c_contiguous and a.shape == (5, 10)
    want = np.sum((s[0] - s[1]) ** 2) + lam * np.sum((p[0] - p[1]) ** 2)
    assert np.sum((a - b) ** 2) == pytest.approx(want)


def test_balanced_weight_edge_cases():
    s = [np.ones((3, 2)), np.zeros((3, 2))]
    assert balanced_pose_weight(s, [np.ones((3, 4))] * 2) == 0.0
    with pytest.raises(OptionError):
        balanced_pose_weight(s[:1], [np.ones((3, 4))])
    with pytest.raises(OptionError, match=r"poses: .*item 1 has \(2, 4\)"):  # named, before any stack
        balanced_pose_weight(s, [np.ones((3, 4)), np.ones((2, 4))])
    with pytest.raises(OptionError):
        with_pose_term(s[0], np.ones((3, 4)), -1.0)
    with pytest.raises(OptionError):
        pose_arrays(_motion(np.zeros((3, 3, 3))), np.ones(2))


def test_cyclic_matrix_is_phase_free():
    """A window and the same window started at another phase (a cyclic shift of its cells) are
    at distance 0; never farther than the fixed-endpoint DP; symmetric."""
    from elastic_motion.apps.database import distance_matrix
    from elastic_motion.warp import WarpOptions

    rng = np.random.default_rng(2)
    t = (np.arange(16) + 0.5) / 16
    base = np.stack([np.sin(2 * np.pi * t), np.cos(2 * np.pi * t), 0.3 * np.sin(4 * np.pi * t)], axis=1)
    q = [base, np.roll(base, 5, axis=0), base + 0.3 * rng.normal(size=base.shape), rng.normal(size=(16, 3))]
    d = distance_matrix(q, WarpOptions("dp", 4), cyclic=True)
    plain = distance_matrix(q, WarpOptions("dp", 4))
    assert d[0, 1] == pytest.approx(0.0, abs=1e-12) and plain[0, 1] > 0.5
    # symmetric: each pair solved both ways (distance_matrix mirrors its rows, so ask per pair)
    from elastic_motion.apps.database.tiles import pair_distances

    pairs = np.array([(a, b) for a in range(4) for b in range(4) if a != b])
    both = pair_distances(q, q, pairs, WarpOptions("dp", 4), cyclic=True)
    flip = {(a, b): x for (a, b), x in zip(pairs.tolist(), both, strict=True)}
    for (a, b), x in flip.items():
        assert x == pytest.approx(flip[(b, a)], rel=1e-9, abs=1e-12)
        assert x == pytest.approx(d[a, b], rel=1e-9, abs=1e-12)
    assert np.all(d <= plain + 1e-12)


def test_pose_arrays_average_the_two_frames_of_each_cell():
    """A cell's pose is the mean of its two frames' (each frame's pose measured on a still
    motion): the map R -> (R - I) / sqrt(2) is linear in R."""
    rng = np.random.default_rng(4)
    ang = rng.uniform(-2.5, 2.5, (2, 3, 3))
    w = np.array([1.0, 3.0, 0.25])
    moving = pose_arrays(_motion(ang), w)
    still = [pose_arrays(_motion(np.stack([a, a])), w) for a in ang]
    np.testing.assert_allclose(moving, 0.5 * (still[0] + still[1]), atol=1e-14)
    assert not np.allclose(still[0], still[1])
