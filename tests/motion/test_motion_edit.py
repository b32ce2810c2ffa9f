"""Editing utilities: T-pose, joints, resampling, trimming, placement, units."""

from __future__ import annotations

import numpy as np
import pytest
from motion_testlib import CMU_BVH, TPOSE_FIRST, bandai_files, geodesic_deg

from elastic_motion.motion import (
    align_heading,
    drop_joints,
    drop_tpose,
    finger_joints,
    forward_kinematics,
    has_reference_root,
    has_tpose_first_frame,
    merge_root,
    place_on_floor,
    read_asf_amc,
    read_bvh,
    read_motion,
    resample,
    select_joints,
    set_up_axis,
    to_metres,
    trim,
)
from elastic_motion.motion.rotations import axis_rotation


@pytest.fixture(scope="module")
def walk(mocap_dir):
    return read_bvh(mocap_dir / "cmu" / "bvh" / "131_01.bvh")


def test_tpose_first_frame_is_detected_exactly_where_the_readme_says(mocap_dir):
    for name in CMU_BVH:
        m = read_bvh(mocap_dir / "cmu" / "bvh" / name)
        assert has_tpose_first_frame(m) == (name[:-4] in TPOSE_FIRST), name
        dropped = drop_tpose(m)
        assert dropped.n_frames == m.n_frames - (name[:-4] in TPOSE_FIRST)
        np.testing.assert_array_equal(dropped.rotations[-1], m.rotations[-1])
    for path in bandai_files(mocap_dir)[:3] + [mocap_dir / "deepmimic" / "humanoid3d_walk.txt"]:
        assert not has_tpose_first_frame(read_motion(path)), path.name
    m = read_bvh(mocap_dir / "cmu" / "bvh" / "131_01.bvh")
    assert drop_tpose(m, force=True).n_frames == m.n_frames - 1


def test_resample_to_a_divisor_rate_picks_frames(walk):
    r = resample(walk, 30)
    assert r.fps == 30 and r.n_frames == (walk.n_frames - 1) // 4 + 1
    np.testing.assert_array_equal(r.rotations, walk.rotations[::4])
    np.testing.assert_allclose(r.root_translation, walk.root_translation[::4], atol=1e-12)
    assert r.duration == pytest.approx(walk.duration, abs=1 / 30)


def test_resample_up_is_geodesic(walk):
    m = trim(walk, 1.0, 2.0)
    up = resample(m, 240)
    assert up.n_frames == 2 * m.n_frames - 1
    np.testing.assert_array_equal(up.rotations[::2], m.rotations)
    mid = up.rotations[1::2]
    a, b = m.rotations[:-1], m.rotations[1:]
    # the midpoint is halfway along the geodesic: equal angles to both ends, summing to the gap
    np.testing.assert_allclose(geodesic_deg(a, mid), geodesic_deg(mid, b), atol=1e-8)
    np.testing.assert_allclose(2 * geodesic_deg(a, mid), geodesic_deg(a, b), atol=1e-8)
    np.testing.assert_allclose(
        up.root_translation[1::2], 0.5 * (m.root_translation[:-1] + m.root_translation[1:])
    )
    with pytest.raises(ValueError, match="fps: expected a positive frame rate"):
        resample(m, 0)


def test_trim_by_time(walk):
    t = trim(walk, 1.0, 2.0)
    assert t.n_frames == 121  # 1.0 s .. 2.0 s at 120 Hz, both ends included
    np.testing.assert_array_equal(t.rotations[0], walk.rotations[120])
    assert trim(walk, stop=0.5).n_frames == 61
    assert trim(walk, start=walk.duration).n_frames == 1
    with pytest.raises(ValueError, match="start, stop"):
        trim(walk, 100.0)


def test_fingers_are_found_and_dropped(mocap_dir):
    m = read_bvh(mocap_dir / "cmu" / "bvh" / "49_08.bvh")
    fingers = finger_joints(m.skeleton)
    assert fingers == [
        "LeftFingerBase",
        "LeftHandIndex1",
        "LThumb",
        "RightFingerBase",
        "RightHandIndex1",
        "RThumb",
    ]
    d = drop_joints(m, ["LeftFingerBase", "LThumb", "RightFingerBase", "RThumb"])  # subtrees go too
    assert d.n_joints == 25 and not set(fingers) & set(d.skeleton.names)
    pos, dpos = forward_kinematics(m), forward_kinematics(d)
    keep = [m.skeleton.index(n) for n in d.skeleton.names]
    np.testing.assert_array_equal(dpos, pos[:, keep])
    # the dropped children became end sites of the hands, at the same places
    hand = d.skeleton.index("LeftHand")
    sites = forward_kinematics(d, end_sites=True)[:, d.n_joints :]
    lhand_sites = [d.n_joints + e for e, p in enumerate(d.skeleton.end_site_parents) if p == hand]
    assert len(lhand_sites) == 2
    full = forward_kinematics(d, end_sites=True)
    np.testing.assert_allclose(
        full[:, lhand_sites[0]], pos[:, m.skeleton.index("LeftFingerBase")], atol=1e-12
    )
    assert sites.shape[1] == d.skeleton.end_site_parents.size
    asf = mocap_dir / "cmu" / "asfamc"
    amc = read_asf_amc(asf / "02.asf", asf / "02_01.amc")
    assert finger_joints(amc.skeleton) == ["lfingers", "lthumb", "rfingers", "rthumb"]


def test_select_joints_needs_whole_chains(walk):
    with pytest.raises(ValueError, match="its parent"):
        select_joints(walk, ["Hips", "LeftKnee"])
    with pytest.raises(ValueError, match="root"):
        select_joints(walk, ["LHipJoint"])
    with pytest.raises(KeyError, match="no joint named"):
        drop_joints(walk, ["Tail"])
    legs = select_joints(walk, ["Hips", "LHipJoint", "LeftHip", "LeftKnee"])
    assert legs.skeleton.names == ("Hips", "LHipJoint", "LeftHip", "LeftKnee")


def test_align_heading_removes_yaw_and_floor_translation(walk):
    m = to_metres(walk)
    a = align_heading(m, frame=10)
    np.testing.assert_allclose(a.root_translation[10, [0, 2]], [0, 0], atol=1e-12)
    np.testing.assert_allclose(a.root_translation[:, 1], m.root_translation[:, 1], atol=1e-12)  # heights kept
    fwd = a.rotations[10, 0] @ [0, 0, 1]
    assert abs(fwd[0]) < 1e-12 and fwd[2] > 0  # facing +z
    # a rigid motion of the whole clip: joint distances and heights unchanged
    p, q = forward_kinematics(m), forward_kinematics(a)
    np.testing.assert_allclose(q[..., 1], p[..., 1], atol=1e-12)
    dp = np.linalg.norm(p[:, :, None] - p[:, None, :5], axis=-1)
    dq = np.linalg.norm(q[:, :, None] - q[:, None, :5], axis=-1)
    np.testing.assert_allclose(dq, dp, atol=1e-12)
    # a copy of the walk turned about the vertical and moved aligns to the same thing
    ry = axis_rotation(2.0, "Y")
    rot = m.rotations.copy()
    rot[:, 0] = ry @ rot[:, 0]
    moved = m.replace(rotations=rot, root_translation=m.root_translation @ ry.T + [3.0, 0.0, -7.0])
    b = align_heading(moved, frame=10)
    np.testing.assert_allclose(forward_kinematics(b), q, atol=1e-9)
    assert np.abs(forward_kinematics(moved) - p).max() > 1.0


def test_place_on_floor_and_up_axis(walk):
    m = to_metres(walk)
    f = place_on_floor(m)
    assert forward_kinematics(f, end_sites=True)[..., 1].min() == pytest.approx(0.0, abs=1e-12)
    z = set_up_axis(m, "z")
    assert z.up_axis == "z"
    np.testing.assert_allclose(forward_kinematics(z)[..., 2], forward_kinematics(m)[..., 1], atol=1e-12)
    assert forward_kinematics(place_on_floor(z), end_sites=True)[..., 2].min() == pytest.approx(0, abs=1e-12)


def test_to_metres_scales_lengths(walk):
    m = to_metres(walk)
    assert m.metres_per_unit == 1.0 and m.units == "m"
    np.testing.assert_allclose(
        forward_kinematics(m), forward_kinematics(walk) * walk.metres_per_unit, atol=1e-12
    )
    with pytest.raises(ValueError, match="metres_per_unit is unknown"):
        to_metres(walk.replace(metres_per_unit=None))


def test_merge_root_keeps_fk(mocap_dir):
    m = read_motion(bandai_files(mocap_dir)[-1])
    assert has_reference_root(m)
    g = merge_root(m)
    assert not has_reference_root(g)  # the hips are the root now
    assert g.skeleton.names[0] == "Hips" and g.n_joints == m.n_joints - 1
    np.testing.assert_allclose(
        forward_kinematics(g, end_sites=True), forward_kinematics(m, end_sites=True)[:, 1:]
    )
    assert np.ptp(g.root_translation[:, 2]) > 100  # the walk moves the new root (cm)
    with pytest.raises(ValueError, match="exactly one child"):
        merge_root(g)
