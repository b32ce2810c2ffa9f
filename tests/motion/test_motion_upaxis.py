"""Up-axis detection (``motion.axes``), the BVH reader's default label, and ``set_up_axis``.

Every real clip of the shared data is Y-up as read; each is also turned Z-up (the Blender
convention), X-up and upside down by a world rotation, and the detector must name the
turned axis every time. Synthetic clips cover the fallbacks (no human skeleton, a margin
below the threshold, an upside-down file) without the shared data.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from motion_testlib import ASF_AMC, CMU_BVH, bandai_files, deepmimic_files

from elastic_motion.motion import (
    Motion,
    Skeleton,
    UpAxisEstimate,
    detect_up_axis,
    forward_kinematics,
    is_lying_down,
    read_asf_amc,
    read_bvh,
    read_deepmimic,
    set_up_axis,
    up_axis_warning,
    write_bvh,
)
from elastic_motion.motion.axes import DIRECTIONS, MIN_MARGIN
from elastic_motion.motion.rotations import axis_rotation

#: World rotations taking +y to the named direction (proper rotations, det = +1).
TURNS = {
    "+y": np.eye(3),
    "+z": np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]]),  # Blender's import: (x, y, z) -> (x, -z, y)
    "+x": np.array([[0.0, 1, 0], [-1, 0, 0], [0, 0, 1]]),
    "-y": np.diag([1.0, -1, -1]),
}


def turned(m: Motion, rot: np.ndarray) -> Motion:
    """The whole clip rotated by ``rot`` in the world (root orientation and translation)."""
    rotations = m.rotations.copy()
    rotations[:, 0] = rot @ m.rotations[:, 0]
    return m.replace(rotations=rotations, root_translation=m.root_translation @ rot.T)


# ------------------------------------------------------------------------------------------
# A small synthetic human walking along +z, Y-up, metres
# ------------------------------------------------------------------------------------------
_ROT = ("Zrotation", "Xrotation", "Yrotation")
_JOINTS = [  # name, parent, offset
    ("Hips", -1, (0, 0, 0)),
    ("LeftUpLeg", 0, (0.1, -0.05, 0)),
    ("LeftLeg", 1, (0, -0.42, 0)),
    ("LeftFoot", 2, (0, -0.42, 0)),
    ("RightUpLeg", 0, (-0.1, -0.05, 0)),
    ("RightLeg", 4, (0, -0.42, 0)),
    ("RightFoot", 5, (0, -0.42, 0)),
    ("Spine", 0, (0, 0.2, 0)),
    ("Chest", 7, (0, 0.25, 0)),
    ("Head", 8, (0, 0.3, 0)),
    ("LeftArm", 8, (0.18, 0.2, 0)),
    ("LeftForeArm", 10, (0, -0.3, 0)),
    ("RightArm", 8, (-0.18, 0.2, 0)),
    ("RightForeArm", 12, (0, -0.3, 0)),
]


def human(n: int = 61, fps: float = 30.0) -> Motion:
    sk = Skeleton(
        names=[j[0] for j in _JOINTS],
        parents=[j[1] for j in _JOINTS],
        offsets=[j[2] for j in _JOINTS],
        channels=[("Xposition", "Yposition", "Zposition", *_ROT)] + [_ROT] * (len(_JOINTS) - 1),
        end_site_parents=[3, 6, 9, 11, 13],
        end_site_offsets=[(0, -0.06, 0.14), (0, -0.06, 0.14), (0, 0.15, 0), (0, -0.25, 0), (0, -0.25, 0)],
    )
    t = np.arange(n) / fps
    w = 2 * np.pi * 1.0 * t
    rot = np.tile(np.eye(3), (n, sk.n_joints, 1, 1))
    rot[:, 1] = axis_rotation(-0.4 * np.sin(w), "X")
    rot[:, 4] = axis_rotation(0.4 * np.sin(w), "X")
    rot[:, 2] = axis_rotation(0.5 * np.maximum(np.sin(w + 0.5), 0.0), "X")
    rot[:, 5] = axis_rotation(0.5 * np.maximum(-np.sin(w + 0.5), 0.0), "X")
    rot[:, 10] = axis_rotation(0.3 * np.sin(w), "X")
    rot[:, 12] = axis_rotation(-0.3 * np.sin(w), "X")
    root = np.stack([np.zeros(n), np.full(n, 0.95), 1.2 * t], axis=1)
    return Motion(sk, fps, root, rot, metres_per_unit=1.0, name="human")


def chain(n: int = 20) -> Motion:
    """Not a human: a three-joint chain (no torso and legs below a branching joint)."""
    sk = Skeleton(["a", "b", "c"], [-1, 0, 1], [(0, 0, 0), (0, 0, 1), (0, 0, 1)], [("Xposition",)] + [()] * 2)
    root = np.zeros((n, 3))
    root[:, 0] = np.linspace(0, 1, n)
    return Motion(sk, 30.0, root, np.tile(np.eye(3), (n, 3, 1, 1)))


# ------------------------------------------------------------------------------------------
# Detection
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("want", list(TURNS))
def test_synthetic_human_is_detected_in_every_orientation(want):
    est = detect_up_axis(turned(human(), TURNS[want]))
    assert isinstance(est, UpAxisEstimate)
    assert est.direction == want and not est.ambiguous, est.reason
    assert est.confidence > 0.5
    assert set(est.scores) == set(DIRECTIONS)
    assert max(est.scores, key=est.scores.get) == want
    assert {"body_axis", "floor", "balance", "rest_pose", "root_travel"} <= set(est.evidence)
    assert want in est.reason
    assert est.up_axis == (want[1] if want[0] == "+" else "y")
    assert est.fallback == (want[0] == "-")


@pytest.mark.parametrize("where", ["offsets", "root", "one frame"])
def test_a_body_too_large_to_judge_is_ambiguous_without_a_numpy_warning(where):
    """Numbers near 1e300 (valid in a file) overflow the cues' sums: the estimate is ambiguous,
    and no RuntimeWarning escapes (the fuzzing found them on reading such files)."""
    m = human()
    if where == "offsets":
        sk = m.skeleton
        m = m.replace(
            skeleton=Skeleton(
                sk.names,
                sk.parents,
                sk.offsets * 1e250,
                sk.channels,
                sk.end_site_parents,
                sk.end_site_offsets * 1e250,
            )
        )
    else:
        root = m.root_translation.copy()
        root[(slice(None) if where == "root" else 31), 1] = 1e300
        m = m.replace(root_translation=root)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        est = detect_up_axis(m)
    assert est.ambiguous and est.up_axis == "y"


def test_ambiguous_or_upside_down_falls_back_to_y():
    chained = detect_up_axis(chain())
    assert chained.ambiguous and chained.fallback and chained.up_axis == "y"
    assert "no torso and two legs" in chained.reason
    strict = detect_up_axis(turned(human(), TURNS["+z"]), min_margin=10.0)
    assert strict.direction == "+z" and strict.ambiguous and strict.up_axis == "y"
    assert strict.reason.startswith("ambiguous")
    upside = detect_up_axis(turned(human(), TURNS["-y"]))
    assert upside.sign == -1 and not upside.ambiguous and upside.fallback and upside.up_axis == "y"
    assert "upside-down" in upside.reason
    with pytest.raises(ValueError, match="min_margin"):
        detect_up_axis(human(), min_margin=-1)
    with pytest.raises(ValueError, match="max_frames"):
        detect_up_axis(human(), max_frames=0)


def test_lying_down_and_warning():
    m = human()
    assert not is_lying_down(m) and up_axis_warning(m) is None
    z_as_y = turned(m, TURNS["+z"])  # Z-up positions labelled Y-up: lying on the floor
    assert is_lying_down(z_as_y)
    msg = up_axis_warning(z_as_y)
    assert msg is not None and "+z" in msg and "labelled y-up" in msg
    relabelled = z_as_y.replace(up_axis="z")
    assert not is_lying_down(relabelled) and up_axis_warning(relabelled) is None
    assert not is_lying_down(chain()) and up_axis_warning(chain()) is None
    with pytest.raises(ValueError, match="max_tilt_deg"):
        is_lying_down(m, max_tilt_deg=0)


# ------------------------------------------------------------------------------------------
# The reader's default label
# ------------------------------------------------------------------------------------------
def test_read_bvh_labels_the_detected_axis(tmp_path):
    m = human()
    z = set_up_axis(m, "z")
    back = read_bvh(write_bvh(z, tmp_path / "z.bvh"))
    assert back.up_axis == "z"  # detected; positions as in the file
    np.testing.assert_allclose(forward_kinematics(back), forward_kinematics(z), atol=1e-7)
    assert read_bvh(tmp_path / "z.bvh", up_axis="y").up_axis == "y"  # forced
    assert read_bvh(write_bvh(m, tmp_path / "y.bvh")).up_axis == "y"
    assert read_bvh(write_bvh(chain(), tmp_path / "c.bvh")).up_axis == "y"  # fallback
    with pytest.raises(ValueError, match=r"up_axis: expected 'x', 'y', 'z' or None .*c\.bvh.*'Y'"):
        read_bvh(tmp_path / "c.bvh", up_axis="Y")


# ------------------------------------------------------------------------------------------
# set_up_axis
# ------------------------------------------------------------------------------------------
def test_set_up_axis_z_to_y_undoes_blenders_conversion():
    m = human()
    z = turned(m, TURNS["+z"]).replace(up_axis="z")  # what Blender's BVH import makes of m
    y = set_up_axis(z, "y")
    assert y.up_axis == "y"
    np.testing.assert_allclose(forward_kinematics(y), forward_kinematics(m), atol=1e-12)
    np.testing.assert_allclose(y.rotations, m.rotations, atol=1e-12)
    # the world rotation used is proper (handedness kept): p_y = R p_z
    r = np.linalg.lstsq(
        forward_kinematics(z).reshape(-1, 3), forward_kinematics(y).reshape(-1, 3), rcond=None
    )[0].T
    np.testing.assert_allclose(r, [[1, 0, 0], [0, 0, 1], [0, -1, 0]], atol=1e-9)
    assert np.isclose(np.linalg.det(r), 1.0)
    # heading: a Blender character faces -Y; Y-up, it faces +z (the BVH convention)
    np.testing.assert_allclose(r @ [0, -1, 0], [0, 0, 1], atol=1e-12)
    for a in "xyz":  # every pair of axes: a proper quarter turn, undone by the way back
        for b in "xyz":
            there = set_up_axis(m.replace(up_axis=a), b)
            np.testing.assert_allclose(np.linalg.det(there.rotations[:, 0]), 1.0)
            np.testing.assert_allclose(set_up_axis(there, a).rotations, m.rotations, atol=1e-12)


# ------------------------------------------------------------------------------------------
# Every real clip
# ------------------------------------------------------------------------------------------
def _real_clips(mocap):
    for name in CMU_BVH:
        yield name, read_bvh(mocap / "cmu" / "bvh" / name)
    for p in bandai_files(mocap):
        yield p.name, read_bvh(p)
    for asf, amc in ASF_AMC:
        yield amc, read_asf_amc(mocap / "cmu" / "asfamc" / asf, mocap / "cmu" / "asfamc" / amc)
    for p in deepmimic_files(mocap):
        yield p.name, read_deepmimic(p)


@pytest.mark.mocap
def test_every_real_clip_is_detected_in_every_orientation(mocap_dir):
    seen = 0
    margins = {}
    lying = set()
    for name, m in _real_clips(mocap_dir):
        seen += 1
        assert m.up_axis == "y", name  # the BVH reader's default label, the other formats' convention
        for want, rot in TURNS.items():
            est = detect_up_axis(turned(m, rot))
            assert est.direction == want and not est.ambiguous, (name, want, est.reason)
            margins[name] = est.confidence
        if is_lying_down(m):
            lying.add(name)
        assert is_lying_down(turned(m, TURNS["+z"])), name  # a Z-up file read as Y-up
    assert seen == len(CMU_BVH) + 12 + len(ASF_AMC) + 20 == 47
    # body mostly horizontal or upside down as recorded: cartwheels, crawling, getting up
    assert lying == {
        "49_08.bvh",
        "humanoid3d_cartwheel.txt",
        "humanoid3d_crawl.txt",
        "humanoid3d_getup_facedown.txt",
        "humanoid3d_getup_faceup.txt",
    }
    # every clip clear of the ambiguity margin (the least: DeepMimic getup_facedown, 0.316,
    # face down with its hands, now joints of the torso, on the floor)
    assert min(margins.values()) > max(MIN_MARGIN, 0.31), sorted(margins.items(), key=lambda kv: kv[1])[:3]


@pytest.mark.mocap
def test_z_up_cmu_file_is_read_z_up(mocap_dir, tmp_path):
    m = read_bvh(mocap_dir / "cmu" / "bvh" / "131_03.bvh")
    path = write_bvh(set_up_axis(m, "z"), tmp_path / "131_03_z.bvh")
    back = read_bvh(path)
    assert back.up_axis == "z" and back.units == "cmu"
    np.testing.assert_allclose(
        forward_kinematics(set_up_axis(back, "y")), forward_kinematics(m), atol=1e-6 * 20
    )


# ------------------------------------------------------------------------------------------
# The cues' fast reductions, against numpy's own (issue 34: the up-axis check of each input)
# ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("seed", range(6))
def test_masked_median_is_nanmedian_to_the_bit(seed: int):
    from elastic_motion.motion.axes import _masked_median

    rng = np.random.default_rng(seed)
    rows, n = int(rng.integers(1, 40)), int(rng.integers(1, 12))
    values = rng.normal(size=(rows, n, 3)) * 10.0 ** rng.integers(-3, 3)
    if seed % 2:  # ties, as quantised velocities have
        values = np.round(values, 1)
    mask = rng.random((rows, n)) < rng.uniform(0.1, 0.9)
    mask[np.arange(rows), rng.integers(0, n, rows)] = True  # at least one per row
    want = np.nanmedian(np.where(mask[..., None], values, np.nan), axis=1)
    got = _masked_median(values, mask)
    assert got.shape == want.shape and np.array_equal(got, want)


@pytest.mark.parametrize("seed", range(6))
def test_hull_distance_is_the_masked_minimum_to_the_bit(seed: int):
    from elastic_motion.motion.axes import _N_HULL_DIRECTIONS, _hull_distance

    rng = np.random.default_rng(seed)
    f, n = int(rng.integers(1, 50)), int(rng.integers(1, 30))
    points, q = rng.normal(size=(f, n, 2)), rng.normal(size=(f, 2))
    mask = rng.random((f, n)) < rng.uniform(0.0, 0.5)  # frames without support too
    angles = np.arange(_N_HULL_DIRECTIONS) * (2 * np.pi / _N_HULL_DIRECTIONS)
    dirs = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    proj = np.where(mask[..., None], points @ dirs.T, np.inf)
    want = np.maximum((proj.min(axis=1) - q @ dirs.T).max(axis=1), 0.0)
    assert np.array_equal(_hull_distance(points, mask, q, dirs), want)
