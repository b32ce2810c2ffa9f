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
    select_frames,
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
    for bad in (0, -30.0, float("inf"), float("nan")):  # refused before a frame count is computed
        with pytest.raises(ValueError, match="fps: expected a positive frame rate"):
            resample(m, bad)


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


def test_lift_out_of_floor_raises_the_dips_smoothly_and_spares_fixed_frames():
    from elastic_motion.motion import lift_out_of_floor
    from elastic_motion.motion.skeleton import Motion, Skeleton

    sk = Skeleton(
        names=("root", "foot"), parents=[-1, 0], offsets=[[0, 0, 0], [0, -1.0, 0]],
        channels=(("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation"),
                  ("Zrotation", "Yrotation", "Xrotation")),
        end_site_parents=[1], end_site_offsets=[[0, -0.1, 0]],
    )  # fmt: skip
    f = 90
    root = np.zeros((f, 3))
    root[:, 1] = 1.2  # the end site at 0.1 above the floor
    root[40:45, 1] -= np.array([0.1, 0.2, 0.3, 0.2, 0.1])  # a dip to 0.2 below
    root[2, 1] -= 0.25  # a dip next to the fixed first frame
    m = Motion(sk, 30.0, root, np.broadcast_to(np.eye(3), (f, 2, 3, 3)).copy(), metres_per_unit=1.0)
    low = forward_kinematics(m, end_sites=True)[..., 1].min(axis=1)
    out, lift = lift_out_of_floor(m, 0.0, ease=0.1, fixed=(0, f - 1))
    new_low = forward_kinematics(out, end_sites=True)[..., 1].min(axis=1)
    assert np.all(new_low[30:60] >= -1e-12)  # the dip is out of the floor
    assert lift[42] == pytest.approx(0.2) and lift[41] >= 0.1 and lift[43] >= 0.1
    assert lift[0] == 0.0 and lift[-1] == 0.0 and 0.0 < lift[1] < lift[2]  # eased to the fixed frame
    assert lift[2] == pytest.approx(0.15)  # a third of the ease away from it: lifted in full
    assert np.all(lift[:1] == 0) and np.all(lift[50:] == 0)  # only around the dips
    assert np.abs(np.diff(lift)).max() < 0.2  # eased in: no step as big as the dip
    np.testing.assert_allclose(out.root_translation[:, [0, 2]], m.root_translation[:, [0, 2]])
    same, none = lift_out_of_floor(m, float(low.min()) - 1.0)  # nothing below: unchanged
    assert same is m and not none.any()
    # a per-frame floor (an original's own lowest point): nothing lifted where it was already low
    _, lift2 = lift_out_of_floor(m, np.minimum(0.0, low), fixed=(0, f - 1))
    assert not lift2.any()


def _synthetic(rot: np.ndarray, root: np.ndarray, fps: float = 30.0, jt: np.ndarray | None = None):
    """A motion of J joints in a chain from rotations (F, J, 3, 3) and root translation (F, 3)."""
    from elastic_motion.motion.skeleton import Motion, Skeleton

    j = rot.shape[1]
    sk = Skeleton(
        names=tuple(f"j{k}" for k in range(j)),
        parents=[-1, *range(j - 1)],
        offsets=[[0.0, 0.1 * (k > 0), 0.0] for k in range(j)],
        channels=(("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation"),)
        + (("Zrotation", "Yrotation", "Xrotation"),) * (j - 1),
    )
    return Motion(sk, fps, root, rot, joint_translations=jt, metres_per_unit=1.0)


def _geodesic(f: int, j: int, seed: int = 0) -> np.ndarray:
    """Constant-speed geodesics R_f = R_0 exp(f w) per joint, up to 0.1 rad per frame."""
    from elastic_motion.groups import SO3

    rng = np.random.default_rng(seed)
    so3 = SO3()
    r0 = so3.exp(rng.normal(size=(j, 3)))
    w = rng.uniform(-0.1, 0.1, size=(j, 3))
    return r0[None] @ so3.exp(np.arange(f)[:, None, None] * w[None])


def test_smooth_motion_keeps_linear_translation_and_constant_speed_rotation_exactly():
    from elastic_motion.motion.edit import smooth_motion

    f = 40
    t = np.arange(f)[:, None]
    root = np.array([0.3, 1.0, -0.2]) + t * np.array([0.02, 0.0, 0.05])  # linear in time
    jt = np.broadcast_to(np.array([0.0, 0.1, 0.0]) + 0.001 * t[:, None, :], (f, 3, 3)).copy()
    m = _synthetic(_geodesic(f, 3), root, jt=jt)
    for sigma in (0.5 / 30, 2.0 / 30, 100.0):  # half a frame, two, and a kernel cut at F - 1
        s = smooth_motion(m, sigma)
        np.testing.assert_allclose(s.root_translation, root, atol=1e-12)
        np.testing.assert_allclose(s.joint_translations, jt, atol=1e-12)
        np.testing.assert_allclose(s.rotations, m.rotations, atol=1e-10)  # ends included
    const = _synthetic(np.broadcast_to(m.rotations[:1], m.rotations.shape).copy(), np.ones((f, 3)))
    np.testing.assert_allclose(smooth_motion(const, 0.05).rotations, const.rotations, atol=1e-12)
    assert smooth_motion(m, 0.0) is m  # off: the motion itself


def test_smooth_motion_attenuates_frame_rate_noise_and_keeps_slow_motion():
    from elastic_motion.groups import SO3
    from elastic_motion.motion.edit import smooth_motion

    so3 = SO3()
    f, fps = 120, 30.0
    k = np.arange(f)
    slow = 0.3 * np.sin(2 * np.pi * k / 40.0)  # 0.75 Hz: a gait-like frequency
    alt = 0.02 * (-1.0) ** k  # the Nyquist frequency: frame-to-frame noise
    root = np.column_stack([slow + alt, np.ones(f), np.zeros(f)])
    axis = np.array([0.0, 0.0, 1.0])
    rot = so3.exp(((slow + alt)[:, None] * axis)[:, None, :])  # (F, 1, 3, 3) about z
    m = _synthetic(rot, root, fps)
    s = smooth_motion(m, 1.0 / fps)  # one frame: gain exp(-pi^2 / 2) ~ 0.007 at Nyquist
    angle = so3.log(s.rotations[:, 0])[:, 2]
    inner = slice(8, -8)  # away from the ends
    gain = np.exp(-2 * np.pi**2 * (1.0 / fps) ** 2 * (fps / 40.0) ** 2)  # 0.97 at 0.75 Hz
    for x in (s.root_translation[:, 0], angle):
        # the alternation (amplitude 0.02) is gone, the slow motion keeps its Gaussian gain
        np.testing.assert_allclose(x[inner], gain * slow[inner], atol=5e-4)
    # half a frame (the anti-aliasing default) attenuates less but still: about 0.58 at Nyquist
    s5 = smooth_motion(m, 0.5 / fps)
    slow5 = np.exp(-2 * np.pi**2 * (0.5 / 40.0) ** 2) * slow[inner]
    left = (s5.root_translation[inner, 0] - slow5) / alt[inner]
    assert 0.45 < np.median(left) < 0.7


def test_smooth_motion_at_some_frames_equals_the_whole_smoothing_there():
    """``frames=``: those frames bit for bit as the whole motion's smoothing (ends included,
    with joint translations), the others as they were; a geodesic resample of it at times
    whose bracketing frames (:func:`frames_read_at_times`) are those equals the resample of
    the whole smoothing; bad indices name the argument."""
    from elastic_motion.groups import SO3
    from elastic_motion.motion.edit import frames_read_at_times, resample_at_times, smooth_motion

    rng = np.random.default_rng(8)
    f, fps, sigma = 50, 120.0, 3.0 / 120.0
    root = np.cumsum(rng.normal(scale=0.01, size=(f, 3)), axis=0)
    rot = _geodesic(f, 3, seed=2) @ SO3().exp(rng.normal(scale=0.05, size=(f, 3, 3)))
    m = _synthetic(rot, root, fps, jt=rng.normal(size=(f, 3, 3)))
    whole = smooth_motion(m, sigma)
    at = np.array([0, 1, 7, 30, 48, 49])
    part = smooth_motion(m, sigma, frames=at[::-1])  # any order
    for name in ("rotations", "root_translation", "joint_translations"):
        got, ref, raw = getattr(part, name), getattr(whole, name), getattr(m, name)
        np.testing.assert_array_equal(got[at], ref[at])
        rest = np.setdiff1d(np.arange(f), at)
        np.testing.assert_array_equal(got[rest], raw[rest])
    target = np.sort(rng.uniform(0.0, m.times[-1], size=9))
    read = frames_read_at_times(m.times, target)
    assert read.size <= 18 and np.all(np.diff(read) > 0)
    sampled = resample_at_times(smooth_motion(m, sigma, frames=read), m.times, target, fps=30.0)
    ref = resample_at_times(whole, m.times, target, fps=30.0)
    np.testing.assert_array_equal(sampled.rotations, ref.rotations)
    np.testing.assert_array_equal(sampled.root_translation, ref.root_translation)
    with pytest.raises(ValueError, match="frames"):
        smooth_motion(m, sigma, frames=[0, f])
    with pytest.raises(ValueError, match="frames"):
        smooth_motion(m, sigma, frames=np.array([0.5]))


def test_smooth_motion_matches_a_gaussian_filter_inside_and_commutes_with_frames():
    from scipy.ndimage import gaussian_filter1d

    from elastic_motion.groups import SO3
    from elastic_motion.motion.edit import smooth_motion

    so3 = SO3()
    rng = np.random.default_rng(3)
    f, fps, sigma = 60, 120.0, 2.0 / 120.0
    root = np.cumsum(rng.normal(scale=0.01, size=(f, 3)), axis=0)
    rot = _geodesic(f, 2, seed=4) @ so3.exp(rng.normal(scale=0.05, size=(f, 2, 3)))
    m = _synthetic(rot, root, fps)
    s = smooth_motion(m, sigma)
    assert s.rotations.shape == (f, 2, 3, 3) and s.root_translation.shape == (f, 3)
    assert s.fps == fps and s.n_frames == f and s.skeleton is m.skeleton
    np.testing.assert_array_equal(m.root_translation, root)  # input untouched
    ref = gaussian_filter1d(root, 2.0, axis=0, truncate=4.0)  # same kernel away from the ends
    np.testing.assert_allclose(s.root_translation[8:-8], ref[8:-8], atol=1e-12)
    np.testing.assert_allclose(
        np.swapaxes(s.rotations, -1, -2) @ s.rotations,
        np.broadcast_to(np.eye(3), s.rotations.shape),
        atol=1e-12,
    )
    # bi-invariant: a constant rotation on the left (world) and on the right (rest pose)
    c, d = so3.exp(np.array([0.3, -1.2, 0.5])), so3.exp(np.array([-0.7, 0.2, 0.9]))
    s2 = smooth_motion(m.replace(rotations=c @ rot @ d), sigma)
    np.testing.assert_allclose(s2.rotations, c @ s.rotations @ d, atol=1e-10)
    # noise is reduced: the rotation steps between frames get smaller
    step = lambda r: np.linalg.norm(so3.log(np.swapaxes(r[:-1], -1, -2) @ r[1:]), axis=-1)  # noqa: E731
    assert step(s.rotations)[8:-8].std() < 0.5 * step(rot)[8:-8].std()
    with pytest.raises(ValueError, match="sigma"):
        smooth_motion(m, -1.0)
    with pytest.raises(ValueError, match="truncate"):
        smooth_motion(m, 0.1, truncate=0.0)


def test_fade_change_scales_the_change_and_keeps_fixed_frames_exactly():
    from elastic_motion.groups import SO3
    from elastic_motion.motion.edit import fade_change, fixed_frames_weight, smoothstep
    from elastic_motion.motion.skeleton import Motion, Skeleton

    w = fixed_frames_weight(21, (0, -1), 4)
    assert w[0] == 0.0 and w[-1] == 0.0 and (w[5:16] == 1.0).all()
    assert (np.diff(w[:6]) > 0).all() and np.allclose(w, w[::-1])  # rising, symmetric
    assert w[2] == pytest.approx(
        float(smoothstep(np.array(2 / 5))), abs=1e-15
    )  # smoothstep of d / (width + 1)
    sk = Skeleton(
        names=("root", "foot"), parents=[-1, 0], offsets=[[0, 0, 0], [0, -1.0, 0]],
        channels=(("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation"),
                  ("Zrotation", "Yrotation", "Xrotation")),
    )  # fmt: skip
    g = SO3()
    rng = np.random.default_rng(3)
    before = Motion(
        sk, 30.0, rng.normal(size=(21, 3)), g.exp(rng.normal(size=(21, 2, 3))), metres_per_unit=1.0
    )
    turn = np.array([0.0, 0.0, 0.8])  # a change about one axis: its angle scales with the weight
    after = before.replace(
        rotations=before.rotations @ g.exp(turn), root_translation=before.root_translation + [0.2, 0.0, 0.0]
    )
    out = fade_change(before, after, w)
    np.testing.assert_array_equal(out.rotations[[0, -1]], before.rotations[[0, -1]])
    np.testing.assert_array_equal(out.root_translation[[0, -1]], before.root_translation[[0, -1]])
    np.testing.assert_array_equal(out.rotations[10], after.rotations[10])
    rel = g.log(np.swapaxes(before.rotations, -1, -2) @ out.rotations)  # (21, 2, 3)
    np.testing.assert_allclose(rel, np.broadcast_to(w[:, None, None] * turn, rel.shape), atol=1e-12)
    np.testing.assert_allclose(
        out.root_translation[:, 0] - before.root_translation[:, 0], 0.2 * w, atol=1e-15
    )
    with pytest.raises(ValueError, match="weight"):
        fade_change(before, after, w[:-1])
    with pytest.raises(ValueError, match="after: expected 21 frames"):
        fade_change(before, select_frames(after, np.arange(20)), w)
    with pytest.raises(ValueError, match="fixed"):
        fixed_frames_weight(21, (0, 21), 4)
    # smooth_change: a constant change passes through its Gaussian whole (the root's too);
    # other frames or a non-finite width are named
    from elastic_motion.motion.edit import smooth_change

    sm = smooth_change(before, after, 3.0)
    np.testing.assert_allclose(
        g.log(np.swapaxes(before.rotations, -1, -2) @ sm.rotations), rel * 0 + turn, atol=1e-12
    )
    np.testing.assert_allclose(
        sm.root_translation - before.root_translation, np.tile([0.2, 0, 0], (21, 1)), atol=1e-15
    )
    with pytest.raises(ValueError, match="after: expected 21 frames"):
        smooth_change(before, select_frames(after, np.arange(20)), 3.0)
    with pytest.raises(ValueError, match="sigma_frames"):
        smooth_change(before, after, float("nan"))


@pytest.mark.parametrize("n, width", [(12, 3), (5, 10), (1, 4), (2, 2)])
def test_eased_envelope_is_the_largest_eased_bump_even_on_clips_shorter_than_its_width(n, width):
    """``out[i] = max_j w(|i - j|) x[j]`` with ``w(d) = smoothstep(1 - d / (width + 1))`` for
    ``d <= width`` (1 at 0), also when the clip is shorter than the easing."""
    from elastic_motion.motion.edit import eased_envelope, smoothstep

    x = np.random.default_rng(n + width).uniform(0.0, 1.0, n)
    want = np.array(
        [
            max(
                x[j] * (1.0 if i == j else float(smoothstep(np.array(1.0 - abs(i - j) / (width + 1.0)))))
                for j in range(n)
                if abs(i - j) <= width
            )
            for i in range(n)
        ]
    )
    np.testing.assert_allclose(eased_envelope(x, width), want, rtol=0, atol=1e-15)


def test_cubic_resampling_passes_through_the_frames_and_beats_geodesic_between_them():
    """Cubic resampling: exact at the frames, exact for a cubic root path, far closer than
    geodesic interpolation to a rotation whose angular speed varies, and proper rotations."""
    from elastic_motion.groups import SO3
    from elastic_motion.motion.edit import resample_at_times

    def resample_cubic(m, times, fps):
        return resample_at_times(m, m.times, times, fps=fps, interpolation="cubic")

    so3 = SO3()
    fps, f = 30.0, 31
    t = np.arange(f) / fps
    axis = np.array([0.3, 0.9, -0.3]) / np.linalg.norm([0.3, 0.9, -0.3])

    def rot_at(times: np.ndarray) -> np.ndarray:
        angle = 1.2 * np.sin(2 * np.pi * 1.5 * times)  # angular speed varies: geodesic cuts corners
        return so3.exp(angle[:, None] * axis[None, :])  # (F, 3, 3)

    def root_at(times: np.ndarray) -> np.ndarray:
        return np.stack([times**3 - times, 0.5 * times**2, 2.0 * times], axis=1)

    m = _synthetic(np.repeat(rot_at(t)[:, None], 2, axis=1), root_at(t), fps=fps)
    same = resample_cubic(m, t, fps=fps)
    np.testing.assert_allclose(same.rotations, m.rotations, atol=1e-12)
    np.testing.assert_allclose(same.root_translation, m.root_translation, atol=1e-12)

    mid = (np.arange(f - 1) + 0.5) / fps
    cub = resample_cubic(m, mid, fps=fps)
    geo = resample_at_times(m, m.times, mid, fps=fps)
    truth = rot_at(mid)
    err_c = geodesic_deg(cub.rotations[:, 0], truth).max()
    err_g = geodesic_deg(geo.rotations[:, 0], truth).max()
    assert err_c < 0.1 * err_g, (err_c, err_g)  # (0.08: the not-a-knot ends dominate)
    np.testing.assert_allclose(cub.root_translation, root_at(mid), atol=1e-10)  # cubic: exact
    np.testing.assert_allclose(np.linalg.det(cub.rotations), 1.0, atol=1e-12)
    np.testing.assert_allclose(
        cub.rotations @ np.swapaxes(cub.rotations, -1, -2),
        np.broadcast_to(np.eye(3), cub.rotations.shape),
        atol=1e-12,
    )
    # resample(interpolation="cubic") samples at i / fps above the clip's rate
    up = resample(m, 120.0, interpolation="cubic")
    assert up.n_frames == 121 and up.fps == 120.0
    np.testing.assert_allclose(up.rotations[::4], m.rotations, atol=1e-12)
    with pytest.raises(ValueError, match="interpolation"):
        resample(m, 60.0, interpolation="spline")
    with pytest.raises(ValueError, match="interpolation"):
        resample_at_times(m, m.times, mid, fps=fps, interpolation="spline")
    # an upsample is bounded before it allocates, naming the option and the limit
    from elastic_motion import limits
    from elastic_motion.errors import OptionError

    with pytest.raises(OptionError, match=r"fps: .*max_frames.*got 1000000001"):
        resample(m, 1e9, interpolation="cubic")
    with limits.override(max_samples=200), pytest.raises(OptionError, match=r"max_samples.*got 242"):
        resample(m, 120.0, interpolation="cubic")
