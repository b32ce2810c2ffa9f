"""DeepMimic clips: every file, timing, quaternion order and normalisation, skeleton."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from motion_testlib import deepmimic_files
from scipy.spatial.transform import Rotation

from elastic_motion.motion import (
    deepmimic_skeleton,
    forward_kinematics,
    read_deepmimic,
    read_motion,
    read_urdf_skeleton,
)
from elastic_motion.motion.deepmimic import DEEPMIMIC_FIXED_JOINTS, DEEPMIMIC_JOINTS

KNOWN_FPS = {
    "humanoid3d_walk": 30,
    "humanoid3d_backflip": 16,
    "humanoid3d_spin": 24,
    "humanoid3d_cartwheel": 60,
}


def test_every_clip_loads_with_its_frame_count_and_rate(mocap_dir):
    files = deepmimic_files(mocap_dir)
    assert len(files) == 20
    for path in files:
        frames = json.loads(path.read_text())["Frames"]
        m = read_motion(path)
        d = np.array([fr[0] for fr in frames])
        rate = 1.0 / np.median(d[:-1])
        assert m.fps == pytest.approx(round(rate)), path.name
        assert m.n_joints == 15 and m.metres_per_unit == 1.0 and m.up_axis == "y"  # with the fixed wrists
        if path.stem == "humanoid3d_roll":  # one 2-frame gap: resampled onto a uniform grid
            assert m.n_frames == math.floor(d[:-1].sum() * m.fps + 1e-6) + 1 == 121
        else:
            assert m.n_frames == len(frames), path.name
        if path.stem in KNOWN_FPS:
            assert m.fps == KNOWN_FPS[path.stem]


def test_roll_is_resampled_at_the_right_times(mocap_dir):
    path = mocap_dir / "deepmimic" / "humanoid3d_roll.txt"
    raw = read_deepmimic(path, resample_uniform=False)
    m = read_deepmimic(path)
    assert raw.n_frames == 121
    # uniform frame i sits at i / 60 s; the file's frames at the running sum of durations
    durations = np.array([fr[0] for fr in json.loads(path.read_text())["Frames"]])
    src_t = np.concatenate([[0.0], np.cumsum(durations[:-1])])
    for c in range(3):
        np.testing.assert_allclose(
            m.root_translation[:, c], np.interp(m.times, src_t, raw.root_translation[:, c]), atol=1e-12
        )
    assert np.abs(m.root_translation[20] - raw.root_translation[20]).max() > 1e-3  # shifted


def _reference_positions(frame: list[float]) -> dict[str, np.ndarray]:
    """Per-frame FK straight from the JSON layout with scipy (scalar-first quaternions)."""
    sk = deepmimic_skeleton()
    offsets = {n: sk.offsets[k].copy() for k, n in enumerate(sk.names)}  # (read-only arrays)
    local, col = {}, 4
    for name, _, revolute in DEEPMIMIC_JOINTS:
        if revolute:
            local[name] = Rotation.from_rotvec([0, 0, frame[col]])
            col += 1
        else:
            local[name] = Rotation.from_quat(np.roll(frame[col : col + 4], -1))  # scipy: scalar last
            col += 4
    glob = {"root": local["root"]}
    pos = {"root": np.array(frame[1:4])}
    for name, parent, _ in DEEPMIMIC_JOINTS[1:]:
        pos[name] = pos[parent] + glob[parent].apply(offsets[name])
        glob[name] = glob[parent] * local[name]
    for name, parent in DEEPMIMIC_FIXED_JOINTS:  # the wrists: fixed, not in the frames
        pos[name] = pos[parent] + glob[parent].apply(offsets[name])
    return pos


def test_fk_agrees_with_reference_and_quaternions_are_normalised(mocap_dir, tmp_path):
    path = mocap_dir / "deepmimic" / "humanoid3d_kick.txt"  # far-from-unit quaternions
    data = json.loads(path.read_text())
    q = np.array([fr[16:20] for fr in data["Frames"]])  # right hip
    assert np.abs(np.linalg.norm(q, axis=1) - 1).max() > 0.4  # the quirk is real
    m = read_deepmimic(path)
    pos = forward_kinematics(m)
    for f in (0, 10, len(data["Frames"]) - 1):
        ref = _reference_positions(data["Frames"][f])
        for k, name in enumerate(m.skeleton.names):
            np.testing.assert_allclose(pos[f, k], ref[name], atol=1e-9, err_msg=name)
    # Scaling every quaternion changes nothing.
    scaled = [
        [*fr[:4], *(3 * np.array(fr[4:8])), *fr[8:12], *(0.5 * np.array(fr[12:16])), *fr[16:]]
        for fr in data["Frames"]
    ]
    p = tmp_path / "scaled.txt"
    p.write_text(json.dumps({"Loop": "wrap", "Frames": scaled}))
    np.testing.assert_allclose(read_deepmimic(p).rotations, m.rotations, atol=1e-14)


def test_builtin_skeleton_is_the_urdf_at_quarter_scale(mocap_dir):
    built_in = deepmimic_skeleton()
    urdf = read_urdf_skeleton(mocap_dir / "deepmimic" / "humanoid.urdf")
    assert urdf.names == built_in.names
    np.testing.assert_array_equal(urdf.parents, built_in.parents)
    np.testing.assert_allclose(urdf.offsets, built_in.offsets, atol=1e-15)
    np.testing.assert_allclose(urdf.end_site_offsets, built_in.end_site_offsets, atol=1e-15)
    # thigh 1.686184 x 0.25 m
    assert built_in.offsets[built_in.index("right_knee")][1] == pytest.approx(-0.421546)
    m = read_deepmimic(
        mocap_dir / "deepmimic" / "humanoid3d_run.txt", urdf=mocap_dir / "deepmimic" / "humanoid.urdf"
    )
    assert m.source[1].endswith("humanoid.urdf")


def test_knees_bend_one_way_about_z(mocap_dir):
    m = read_deepmimic(mocap_dir / "deepmimic" / "humanoid3d_walk.txt")
    knee = m.rotations[:, m.skeleton.index("left_knee")]
    np.testing.assert_allclose(knee[:, 2], [[0, 0, 1]] * m.n_frames, atol=1e-15)  # axis z
    angle = np.arctan2(knee[:, 1, 0], knee[:, 0, 0])
    assert angle.max() <= 0 and angle.min() < -0.5  # URDF limits [-3.14, 0]
