"""Blends: the end points of the geodesic, timing, placement, bad input, metrics, real data."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from blend_testlib import walker

from elastic_motion.apps.align import align_motions
from elastic_motion.apps.blend import NOTE_ANCHOR, BlendOptions, blend_motions
from elastic_motion.apps.distance import distance_table
from elastic_motion.apps.metrics import bone_length_error, foot_joints, foot_sliding
from elastic_motion.apps.prepare import JOINTS_DROPPED, RESAMPLED, PrepareOptions, prepare_motions
from elastic_motion.errors import OptionError
from elastic_motion.groups import SO3
from elastic_motion.motion import (
    drop_joints,
    drop_tpose,
    forward_kinematics,
    read_bvh,
    read_motion,
    resample,
    trim,
    write_bvh,
)
from elastic_motion.warp import WarpOptions

SO3G = SO3()
METHODS = [
    ("euler-linear", "none"),
    ("euler-elastic", "none"),
    ("euler-elastic", "dp"),
    ("lie", "none"),
    ("lie", "dp"),
]


def _angle(r0, r1):
    return np.linalg.norm(SO3G.log(np.swapaxes(r0, -1, -2) @ r1), axis=-1)


@pytest.fixture(scope="module")
def pair():
    a = walker(duration=2.0, freq=1.0, amp=0.5, speed=1.0, name="A")
    b = walker(duration=2.6, freq=1.3, amp=0.7, speed=1.4, phase=0.4, yaw=0.7, scale=1.1, name="B")
    return a, b


@pytest.mark.parametrize(("method", "warp"), METHODS)
def test_weight_zero_gives_a(pair, method, warp):
    a, b = pair
    res = blend_motions([a, b], 0.0, method=method, warp=warp, metrics=False)
    m = res.motion
    assert m.n_frames == a.n_frames and m.fps == a.fps
    assert _angle(m.rotations, a.rotations).max() < 1e-6
    np.testing.assert_allclose(m.root_translation, a.root_translation, atol=1e-6)
    np.testing.assert_allclose(m.skeleton.offsets, a.skeleton.offsets, atol=1e-12)


@pytest.mark.parametrize(("method", "warp"), METHODS)
def test_weight_one_gives_b_at_its_own_timing(pair, method, warp):
    a, b = pair
    res = blend_motions([a, b], 1.0, method=method, warp=warp, metrics=False)
    pb = res.prepared.motions[1]  # B placed like A
    m = res.motion
    assert m.n_frames == pb.n_frames
    assert abs(m.duration - b.duration) < 1e-9
    tol = 1e-6 if warp == "none" else 2e-3
    assert _angle(m.rotations, pb.rotations).max() < tol
    np.testing.assert_allclose(m.root_translation, pb.root_translation, atol=tol)
    np.testing.assert_allclose(m.skeleton.offsets, b.skeleton.offsets, atol=1e-12)  # skeleton="blend"


def test_halfway_blend_duration_skeleton_and_fingers(pair):
    a, b = pair
    # (the blended clock's duration: the ends kept whole)
    res = blend_motions([a, b], 0.5, method="lie", warp="dp", metrics=True, trim_ends=False)
    m = res.motion
    assert abs(m.duration - 0.5 * (a.duration + b.duration)) <= 1.0 / a.fps
    assert m.skeleton.names == a.skeleton.names
    np.testing.assert_allclose(m.skeleton.offsets, 0.5 * (a.skeleton.offsets + b.skeleton.offsets))
    assert "LeftHandIndex1" in res.prepared.extra_joints  # finger joint: blended frame by frame
    assert np.isfinite(m.rotations).all()
    assert res.timing[0] == 0.0 and res.timing[-1] == 1.0 and (np.diff(res.timing) > 0).all()
    met = res.metrics.summary()
    # (feet: the blend's feet measured like the inputs', issue 29)
    assert set(met) == {"foot_sliding", "bone_length_error", "distances", "feet"}
    assert met["bone_length_error"]["result"]["max_relative"] < 1e-9
    assert res.metrics.bone_length_error.max_relative < 1e-9
    d = met["distances"]
    assert d["labels"] == ["A", "B"]
    d_ab = d["between_inputs"][0][1]
    d_ra, d_rb = d["result_to_inputs"]
    # on the SRV geodesic with the warp, the result sits about halfway
    assert d_ra < 0.8 * d_ab and d_rb < 0.8 * d_ab
    assert d_ra + d_rb < 1.25 * d_ab


def test_blend_is_placed_like_a(pair):
    a, b = pair  # B walks 0.7 rad off A's direction
    res = blend_motions([a, b], 0.5, metrics=False)
    pb = res.prepared.motions[1]
    np.testing.assert_allclose(pb.root_translation[0, [0, 2]], a.root_translation[0, [0, 2]], atol=1e-9)
    travel = pb.root_translation[-1] - pb.root_translation[0]
    assert abs(travel[0]) < 1e-6 * np.linalg.norm(travel)  # now walks along +z like A
    assert pb.root_translation[0, 1] == pytest.approx(b.root_translation[0, 1])  # height kept
    path = res.motion.root_translation
    assert abs(path[-1, 0] - path[0, 0]) < 0.02 and path[-1, 2] > path[0, 2] + 1.0
    unplaced = blend_motions(
        [a, b], 0.5, prepare=PrepareOptions(align=False), metrics=False
    ).motion.root_translation
    assert abs(unplaced[-1, 0] - unplaced[0, 0]) > 0.3


def test_a_walk_backwards_is_named(pair):
    """A clip that faces away from its way of travel unlike the other (a walk backwards) gets
    a note: its blend would face between the two (a crab walk); a walk turned another way
    (the pair's B) is no such case, nor a clip that stands."""
    from elastic_motion.apps.prepare import FACING_DIFFERS, prepare_motions
    from elastic_motion.notes import of_kind

    a, b = pair
    back = walker(duration=2.0, freq=1.0, amp=0.5, speed=-1.0, name="back")
    (note,) = of_kind(prepare_motions([a, back]).notes, FACING_DIFFERS)
    assert str(note).startswith("back: faces 180 deg away from its way of travel compared with A")
    assert note.data["input"] == "back" and note.data["apart_deg"] == pytest.approx(180, abs=0.5)
    assert not of_kind(prepare_motions([a, b]).notes, FACING_DIFFERS)
    still = walker(duration=2.0, freq=1.0, amp=0.5, speed=0.0, name="still")
    assert not of_kind(prepare_motions([a, still]).notes, FACING_DIFFERS)
    # a walk turned 2 rad, not placed like A: it still faces its way (a sign or axis slip in
    # the facing would see it 131 degrees off)
    turned = walker(duration=2.0, freq=1.0, amp=0.5, speed=1.0, yaw=2.0, name="turned")
    assert not of_kind(prepare_motions([a, turned], PrepareOptions(align=False)).notes, FACING_DIFFERS)


def test_an_extrapolated_clock_keeps_its_shape_where_it_runs_forwards():
    """Extrapolating past B, the blended clock ``T' = -0.5 d_A + 1.5 d_B phi'`` runs backwards
    where B's warp is flat and far forwards where it is steep (B's whole step in a tenth of
    A's time). Played uniformly (before), that steep tenth got a tenth of the frames and the
    root jumped (35 m/s on CMU walks); now the backward rate is held at a tenth of the mean
    and the steep part keeps its share: 2.6 of 2.78 s, rescaled to the blended 2 s."""
    from elastic_motion.apps.blend.timing import blended_clock

    ident = np.array([[0.0, 0.0], [1.0, 1.0]])
    phi = np.array([[0.0, 0.0], [0.5, 0.05], [0.6, 0.95], [1.0, 1.0]])
    u, note = blended_clock([ident, phi], np.array([-0.5, 1.5]), np.array([2.0, 2.0]), 30.0)
    assert u[0] == 0.0 and u[-1] == 1.0 and (np.diff(u) > 0).all() and u.size == 61
    steep = ((u >= 0.5) & (u <= 0.6)).mean()
    assert steep == pytest.approx(2.6 / 2.78, abs=0.03)
    assert "does not increase on 90 % of the curve" in note
    # an increasing clock is left as it is: no note
    u, note = blended_clock([ident, phi], np.array([0.5, 0.5]), np.array([2.0, 2.0]), 30.0)
    assert note == ""
    assert ((u >= 0.5) & (u <= 0.6)).mean() == pytest.approx(1.0 / 2.0, abs=0.03)  # T' = 1 + phi', 1 s of 2


def test_extrapolation_needs_the_flag(pair):
    a, b = pair
    with pytest.raises(ValueError, match=r"s = 1.3 is outside \[0, 1\].*extrapolate=True"):
        blend_motions([a, b], 1.3, metrics=False)
    res = blend_motions([a, b], 1.3, extrapolate=True, metrics=False)
    assert np.isfinite(res.motion.rotations).all() and res.motion.n_frames > 2
    with pytest.raises(ValueError, match="summing to 1"):
        blend_motions([a, b], [0.5, 0.6], metrics=False)


def test_three_way_weighted_mean(pair):
    a, b = pair
    c = walker(duration=2.3, freq=1.15, amp=0.6, speed=1.2, name="C")
    res = blend_motions([a, b, c], [0.5, 0.3, 0.2], metrics=False, trim_ends=False)
    assert len(res.warps) == 3
    m = res.motion
    expected = 0.5 * a.duration + 0.3 * b.duration + 0.2 * c.duration
    assert abs(m.duration - expected) < 0.15  # the template's warps are not recentred
    only_a = blend_motions([a, b, c], [1.0, 0.0, 0.0], warp="none", metrics=False)
    assert _angle(only_a.motion.rotations, a.rotations).max() < 1e-6
    with pytest.raises(ValueError, match="expected two motions"):
        blend_motions([a, b, c], [0.4, 0.3, 0.3], landmarks="auto")
    with pytest.raises(ValueError, match=r"in \[0, 1\] for 3 motions"):
        blend_motions([a, b, c], [1.2, -0.1, -0.1], extrapolate=True)


def test_different_skeletons_name_the_joints(pair):
    a, b = pair
    b2 = drop_joints(b, ["LeftHand"])
    with pytest.raises(ValueError, match=r"only in A: \['LeftHand', 'LeftHandIndex1'\].*joints='common'"):
        blend_motions([a, b2], 0.5, metrics=False)
    res = blend_motions([a, b2], 0.5, prepare=PrepareOptions(joints="common"), metrics=False)
    assert "LeftHand" not in res.motion.skeleton.names
    assert any(n.kind == JOINTS_DROPPED and "joints not shared by all inputs" in str(n) for n in res.notes)
    # the same skeleton under other names (a CMU ASF file against a BVH conversion of it):
    # no joint is shared, so the message says to rename, not to keep the shared joints
    sk = b.skeleton
    renamed = b.replace(skeleton=dataclasses.replace(sk, names=tuple(f"j{k}" for k in range(sk.n_joints))))
    with pytest.raises(ValueError, match=r"share 0 joints from the root on: the skeletons name") as err:
        blend_motions([a, renamed], 0.5, metrics=False)
    assert "joints='common'" not in str(err.value)


def test_different_frame_rates_are_resampled(pair):
    a, b = pair
    b60 = resample(b, 60.0)
    res = blend_motions([a, b60], 0.5, metrics=False)
    assert res.motion.fps == a.fps
    assert any(n.kind == RESAMPLED and "resampled from 60 to 30 fps" in str(n) for n in res.notes)


def test_landmarks_pull_the_warp(pair):
    a, b = pair
    lm = [(0.6, 1.5), (1.4, 2.1)]
    res = align_motions(a, b, landmarks=lm, warp=WarpOptions(landmark_weight=1000.0))
    np.testing.assert_allclose(res.time_in_b([0.6, 1.4]), [1.5, 2.1], atol=0.05)
    free = align_motions(a, b)
    assert free.distance <= res.distance + 1e-9
    auto = align_motions(a, b, landmarks="auto")
    assert len(auto.landmarks) >= 1
    with pytest.raises(ValueError, match=r"pair 0 has time 9 s in B, outside its duration"):
        align_motions(a, b, landmarks=[(0.5, 9.0)])
    with pytest.raises(ValueError, match="not in increasing order"):
        align_motions(a, b, landmarks=[(0.5, 1.5), (1.0, 1.0)])
    with pytest.raises(ValueError, match="expected a time warp"):
        blend_motions([a, b], 0.5, warp="none", landmarks=[(0.5, 0.5)])


def test_bad_arguments(pair):
    a, b = pair
    with pytest.raises(ValueError, match="at least 2 motions"):
        blend_motions([a], 0.5)
    with pytest.raises(ValueError, match="method: expected one of"):
        blend_motions([a, b], 0.5, method="quaternion")
    with pytest.raises(ValueError, match="warp: expected one of"):
        blend_motions([a, b], 0.5, warp="dtw")


def test_metrics_on_a_clean_motion(pair):
    a, _ = pair
    assert [a.skeleton.names[j] for j in foot_joints(a)] == ["LeftFoot", "RightFoot"]
    fs = foot_sliding(a)
    assert fs.speed.shape == (a.n_frames - 1, 2) and fs.units == "m"
    assert bone_length_error(a).max_relative < 1e-12
    longer = a.replace(
        skeleton=a.skeleton.__class__(
            a.skeleton.names,
            a.skeleton.parents,
            a.skeleton.offsets * 1.1,
            a.skeleton.channels,
            a.skeleton.end_site_parents,
            a.skeleton.end_site_offsets,
        )
    )
    assert bone_length_error(longer, a).max_relative == pytest.approx(0.1, rel=1e-9)
    # a bone of a micrometre in the reference (CMU's LHipJoint) has no relative error to give
    k = a.skeleton.names.index("LeftHandIndex1")
    micro = a.skeleton.offsets.copy()
    micro[k] *= 2e-5
    ref = a.skeleton.__class__(
        a.skeleton.names, a.skeleton.parents, micro, a.skeleton.channels,
        a.skeleton.end_site_parents, a.skeleton.end_site_offsets,
    )  # fmt: skip
    err = bone_length_error(a, ref)
    assert err.max_relative < 1e-12 and err.n_bones == bone_length_error(a).n_bones - 1


def test_foot_sliding_from_given_lowest_heights(pair):
    """``lowest`` moves the touch threshold exactly: its own lowest heights change nothing,
    2 cm higher is the same as a 2 cm larger ``contact_height``; a wrong shape is refused."""
    a, _ = pair
    fs = foot_sliding(a)
    up = "xyz".index(a.up_axis)
    p = forward_kinematics(a)[:, foot_joints(a), up] * a.metres_per_unit
    np.testing.assert_array_equal(fs.lowest, p.min(axis=0))
    same = foot_sliding(a, lowest=fs.lowest)
    np.testing.assert_array_equal(same.contact, fs.contact)
    assert same.mean_speed == fs.mean_speed
    higher = foot_sliding(a, lowest=fs.lowest + 0.02)
    np.testing.assert_array_equal(higher.contact, foot_sliding(a, contact_height=0.07).contact)
    assert higher.contact.sum() > fs.contact.sum()
    with pytest.raises(ValueError, match="lowest: expected 2 finite heights"):
        foot_sliding(a, lowest=np.zeros(3))
    one = a.replace(root_translation=a.root_translation[:1], rotations=a.rotations[:1])
    with pytest.raises(ValueError, match="lowest: expected 2 finite heights"):
        foot_sliding(one, lowest=[np.nan, 0.0])
    np.testing.assert_array_equal(foot_sliding(one).lowest, p[0])
    lo = fs.lowest.copy()
    assert foot_sliding(a, lowest=lo).lowest is not lo  # the result's own copy


def test_distance_table_is_symmetric(pair):
    a, b = pair
    t = distance_table([a, b, a], labels=["a", "b", "a2"])
    np.testing.assert_allclose(t.matrix, t.matrix.T)
    assert t.matrix[0, 2] < 1e-9 and t.matrix[0, 1] > 0.1
    assert (t.matrix <= t.unwarped + 1e-9).all()


def test_written_blend_reads_back(pair, tmp_path):
    a, b = pair
    res = blend_motions([a, b], 0.5, metrics=False)
    path = write_bvh(res.motion, tmp_path / "blend.bvh")
    back = read_bvh(path, units="m")
    assert back.skeleton.names == res.motion.skeleton.names and back.n_frames == res.motion.n_frames
    np.testing.assert_allclose(forward_kinematics(back), forward_kinematics(res.motion), atol=1e-6)


@pytest.mark.mocap
def test_cmu_obstacle_walks_by_every_method(mocap_dir):
    """Paper 000 Fig. 4 / paper 001 Fig. 6: the warp matters; the Lie blend with warp slides
    less than the linear Euler blend and sits near the middle of the geodesic."""
    a = trim(drop_tpose(read_motion(mocap_dir / "cmu/bvh/107_02_30hz.bvh")), 1.0, 3.4)
    b = trim(drop_tpose(read_motion(mocap_dir / "cmu/bvh/108_01_30hz.bvh")), 1.3, 4.8)
    prep = prepare_motions([a, b])
    assert prep.motions[1].metres_per_unit == 1.0
    out = {}
    for method, warp, lm in [
        ("euler-linear", "none", None),
        ("lie", "none", None),
        ("lie", "dp", None),
        ("euler-elastic", "dp", "auto"),
    ]:
        # the geodesic property is of the blend itself: no clean-up here (test_cleanup.py)
        res = blend_motions([a, b], 0.5, method=method, warp=warp, landmarks=lm, metrics=True, contacts="off")
        assert res.motion.n_joints == 31 and np.isfinite(res.motion.rotations).all()
        out[(method, warp)] = res.metrics.summary()
    lie_dp = out[("lie", "dp")]
    d = lie_dp["distances"]
    d_ab = d["between_inputs"][0][1]
    assert max(d["result_to_inputs"]) < 0.62 * d_ab
    assert max(out[("lie", "none")]["distances"]["result_to_inputs"]) > max(d["result_to_inputs"])
    slide = {k: v["foot_sliding"]["result"]["mean_speed_m_s"] for k, v in out.items()}
    assert slide[("lie", "dp")] < slide[("euler-linear", "none")]


def test_pose_anchor_removes_a_slow_drift_from_the_inputs_mean_pose(pair):
    """``anchor_poses`` pulls a blend's joints back to the aligned inputs' weighted geodesic
    mean by the slow part of the difference: a constant offset of the knee goes entirely
    (a wrong sign would double it), a fast wiggle (frame-rate alternation) stays."""
    from elastic_motion.apps.blend.anchor import anchor_poses
    from elastic_motion.apps.blend.sampling import sample_rotations

    a = walker(duration=2.0, freq=1.0, amp=0.5, speed=1.0, name="A")
    b = walker(duration=2.0, freq=1.0, amp=0.7, speed=1.0, phase=0.3, name="B")
    f = a.n_frames
    times = [a.times, b.times]
    w = np.array([0.3, 0.7])
    joints = np.arange(a.n_joints)
    ra, rb = (sample_rotations(m, joints, t) for m, t in zip((a, b), times, strict=True))
    mean = ra @ SO3G.exp(0.7 * SO3G.log(np.swapaxes(ra, -1, -2) @ rb))
    knee = list(a.skeleton.names).index("LeftLeg")
    offset = np.zeros((f, a.n_joints, 3))
    offset[:, knee, 0] = 0.25  # a constant drift: 14.3 degrees
    body = a.replace(rotations=mean @ SO3G.exp(offset))
    out, drift, lift = anchor_poses(body, [a, b], times, w)
    np.testing.assert_allclose(out.rotations, mean, atol=1e-9)
    assert drift == pytest.approx(np.degrees(0.25), rel=1e-9)
    np.testing.assert_array_equal(out.root_translation, body.root_translation)  # at the inputs' height
    assert lift == 0.0
    wiggle = offset.copy()
    wiggle[:, knee, 0] = 0.02 * (-1.0) ** np.arange(f)
    out2, _, _ = anchor_poses(a.replace(rotations=mean @ SO3G.exp(wiggle)), [a, b], times, w)
    left = SO3G.log(np.swapaxes(mean[:, knee], -1, -2) @ out2.rotations[:, knee])[:, 0]
    # the fast part is the blend's own: kept (its frame-to-frame swing, whatever the edges add)
    assert np.median(np.abs(np.diff(left))) / 2 > 0.95 * 0.02
    # a drift of every speed: exactly its 1 s Gaussian (sigma in seconds, at the clip's fps) goes
    from scipy.ndimage import gaussian_filter1d

    tt = np.arange(f) / a.fps
    slow = offset.copy()
    slow[:, knee, 0] = 0.2 * np.sin(2 * np.pi * 0.4 * tt) + 0.05 * np.sin(2 * np.pi * 3.0 * tt)
    out3, _, _ = anchor_poses(a.replace(rotations=mean @ SO3G.exp(slow)), [a, b], times, w)
    kept = SO3G.log(np.swapaxes(mean[:, knee], -1, -2) @ out3.rotations[:, knee])[:, 0]
    x = slow[:, knee, 0]
    np.testing.assert_allclose(kept, x - gaussian_filter1d(x, 1.0 * a.fps, mode="nearest"), atol=1e-9)
    # the root height likewise, from the inputs' weighted mean height (B 4 cm lower, played
    # 10 % slower); its horizontal path is kept
    b2 = b.replace(root_translation=b.root_translation - [0.0, 0.04, 0.0])
    times2 = [a.times, 0.9 * a.times]
    mean_h = 0.3 * a.root_translation[:, 1] + 0.7 * np.interp(times2[1], b2.times, b2.root_translation[:, 1])
    root = a.root_translation.copy()
    root[:, 1] = mean_h + 0.1 + x  # 10 cm too high, and a drift of every speed
    out4, _, lift = anchor_poses(a.replace(root_translation=root), [a, b2], times2, w)
    np.testing.assert_allclose(
        out4.root_translation[:, 1] - mean_h, x - gaussian_filter1d(x, a.fps, mode="nearest"), atol=1e-12
    )
    np.testing.assert_array_equal(out4.root_translation[:, [0, 2]], root[:, [0, 2]])
    assert lift == pytest.approx(np.abs(0.1 + gaussian_filter1d(x, a.fps, mode="nearest")).max(), rel=1e-12)


def test_euler_anchor_removes_the_slow_part_of_the_angles_drift():
    """``anchor_euler`` works in the Euler method's own space: each angle's difference from the
    inputs' mean loses exactly its 1 s Gaussian (a constant offset entirely, a wrong sign would
    double it), and so does the root's height; the root's horizontal position is never touched."""
    from scipy.ndimage import gaussian_filter1d

    from elastic_motion.apps.blend.anchor import anchor_euler

    fps, f, j = 30.0, 90, 4
    rng = np.random.default_rng(3)
    mean = rng.normal(size=(f, 3 + 3 * j))
    tt = np.arange(f) / fps
    drift = np.zeros((f, 3 + 3 * j))
    drift[:, :3] = 0.5  # the root: its horizontal position kept whatever its offset
    drift[:, 1] = 0.07  # its height (y up): removed entirely
    drift[:, 3] = 0.3  # constant: removed entirely
    drift[:, 4] = 0.2 * np.sin(2 * np.pi * 0.4 * tt) + 0.05 * np.sin(2 * np.pi * 3.0 * tt)
    out, largest, lift = anchor_euler(mean + drift, mean, fps, up=1)
    np.testing.assert_allclose(out[:, [0, 2]], mean[:, [0, 2]] + 0.5, atol=1e-12)
    np.testing.assert_allclose(out[:, 1], mean[:, 1], atol=1e-12)
    assert lift == pytest.approx(0.07, rel=1e-12)
    np.testing.assert_allclose(out[:, 3], mean[:, 3], atol=1e-12)
    x = drift[:, 4]
    slow = gaussian_filter1d(x, fps, mode="nearest")
    np.testing.assert_allclose(out[:, 4] - mean[:, 4], x - slow, atol=1e-12)
    np.testing.assert_allclose(out[:, 5:], mean[:, 5:], atol=1e-12)
    assert largest == pytest.approx(np.degrees(0.3), rel=1e-12)


@pytest.mark.parametrize("method", ["lie", "euler-elastic"])
def test_anchor_off_gives_the_plain_srv_blend(pair, method):
    """``anchor=False``: no note, no correction; the anchored blend differs from it only by a
    slow change (the fast part of the motion is the SRV blend's own)."""
    plain = blend_motions(list(pair), 0.5, method=method, warp="dp", contacts="off", anchor=False)
    anchored = blend_motions(list(pair), 0.5, method=method, warp="dp", contacts="off")
    assert plain.pose_anchor_deg is None and not any(n.kind == NOTE_ANCHOR for n in plain.notes)
    assert anchored.pose_anchor_deg is not None and anchored.pose_anchor_deg > 0.1
    assert anchored.summary()["pose_anchor_deg"] == anchored.pose_anchor_deg
    change = SO3G.log(np.swapaxes(plain.motion.rotations, -1, -2) @ anchored.motion.rotations)
    assert np.abs(change).max() > 1e-3
    # a 1 s Gaussian leaves frame-to-frame steps far below the change itself
    assert np.abs(np.diff(change, axis=0)).max() < 0.1 * np.abs(change).max()
    # the root's horizontal path is the SRV blend's; its height changes slowly, if at all
    pr, ar = plain.motion.root_translation, anchored.motion.root_translation
    np.testing.assert_allclose(pr[:, [0, 2]], ar[:, [0, 2]], atol=1e-12)
    sink = ar[:, 1] - pr[:, 1]
    assert np.abs(sink).max() == pytest.approx(anchored.height_anchor_m, rel=1e-9, abs=1e-12)
    assert np.abs(np.diff(sink)).max() <= 0.1 * np.abs(sink).max() + 1e-12
    assert anchored.summary()["height_anchor_m"] == anchored.height_anchor_m and plain.height_anchor_m is None


def test_anchored_blend_stays_at_the_inputs_height(mocap_dir):
    """Bandai happy x sad, Lie + warp, no clean-up: the plain SRV blend's root sinks by 8 cm
    over the clip and its toes go 6.9 cm under the inputs' floor (the inputs: 0.2 and 0.1 cm);
    with the poses anchored at that height, 8.9 cm. Anchored to the inputs' mean root height
    too, the blend ends within 1 cm of their mean and its lowest point is 1.1 cm under."""
    from elastic_motion.motion.contacts import detect_contacts

    files = [mocap_dir / "bandai" / f"dataset-1_walk_{s}_001.bvh" for s in ("happy", "sad")]
    if not all(p.is_file() for p in files):
        pytest.skip("Bandai walks not found")
    res = blend_motions(files, 0.5, method="lie", warp="dp", contacts="off")
    plain = blend_motions(res.prepared, 0.5, method="lie", warp="dp", contacts="off", anchor=False)
    ms = res.prepared.motions
    end = np.mean([m.root_translation[-1, 1] for m in ms]) * ms[0].metres_per_unit

    floor = np.mean([detect_contacts(m).floor for m in ms])  # the inputs' floor (m)

    def below(m):  # how far its lowest point (end sites too) goes under the inputs' floor
        return floor - (forward_kinematics(m, end_sites=True)[..., 1] * m.metres_per_unit).min()

    assert plain.motion.root_translation[-1, 1] * plain.motion.metres_per_unit < end - 0.05
    assert below(plain.motion) > 0.05
    poses_only = res.motion.replace(root_translation=plain.motion.root_translation)
    assert below(poses_only) > 0.05  # what the height anchoring is for
    assert abs(res.motion.root_translation[-1, 1] * res.motion.metres_per_unit - end) < 0.01
    assert below(res.motion) < 0.015
    assert 0.05 < res.height_anchor_m < 0.15 and "and 8." in str(
        next(n for n in res.notes if n.kind == NOTE_ANCHOR)
    )


def test_extrapolated_blends_are_not_anchored(pair):
    """Beyond the inputs the mean pose is extrapolated too: no anchor (it bent Bandai knees 48
    degrees backwards at s = 1.5); the note says so."""
    res = blend_motions(list(pair), 1.5, method="lie", warp="dp", extrapolate=True, contacts="off")
    (note,) = (n for n in res.notes if n.kind == NOTE_ANCHOR)
    assert str(note) == "poses not anchored: the weights extrapolate beyond the inputs" and not note.data
    inside = blend_motions(list(pair), 0.7, method="lie", warp="dp", contacts="off")
    (note,) = (n for n in inside.notes if n.kind == NOTE_ANCHOR)
    assert str(note).startswith("poses anchored") and note.data["pose_deg"] == inside.pose_anchor_deg


@pytest.mark.parametrize("method", ["lie", "euler-elastic"])
def test_blend_knees_bend_no_further_back_than_the_inputs(mocap_dir, method):
    """Bandai normal x tired, with the warp: the SRV blend's knees drifted up to 16 (Lie) and
    29 (Euler) degrees backwards where both inputs stand straight (never backwards);
    anchored, they stay within 3 degrees of straight, and the blend keeps its distance to the
    inputs."""
    from elastic_motion.apps.cleanup import find_legs
    from elastic_motion.motion.ik import _angle as angle_between
    from elastic_motion.motion.ik import _bend_axis_local
    from elastic_motion.motion.kinematics import joint_positions_and_rotations

    files = [mocap_dir / "bandai" / f"dataset-1_walk_{s}_001.bvh" for s in ("normal", "tired")]
    if not all(p.is_file() for p in files):
        pytest.skip("Bandai walks not found")
    res = blend_motions(files, 0.5, method=method, warp="dp", contacts="off", trim_ends=False)
    assert any(n.kind == NOTE_ANCHOR and n.data for n in res.notes)

    def signed_bends(m):
        pos, glob = joint_positions_and_rotations(m.skeleton.parents, m.local_translations(), m.rotations)
        out = []
        for leg in find_legs(m)[0]:
            a, b, c = pos[:, leg.hip], pos[:, leg.knee], pos[:, leg.ankle]
            hinge = glob[:, leg.knee] @ _bend_axis_local(glob[:, leg.knee], a, b, c)
            sign = np.sign(np.einsum("fi,fi->f", np.cross(c - a, b - a), hinge))
            out.append(np.degrees(np.pi - angle_between(a - b, c - b)) * sign)
        return np.concatenate(out)

    inputs_min = min(signed_bends(m).min() for m in res.prepared.motions)
    assert inputs_min > -1.0
    assert signed_bends(res.motion).min() > -3.0
    plain = blend_motions(
        res.prepared, 0.5, method=method, warp="dp", contacts="off", anchor=False, trim_ends=False
    )
    assert signed_bends(plain.motion).min() < -10.0  # what the anchoring is for
    d = distance_table(
        [*res.prepared.motions, res.motion], prepare=PrepareOptions(joints="common", drop_tpose=False)
    ).matrix
    assert max(d[2, 0], d[2, 1]) < 1.15 * d[0, 1] / 2


@pytest.mark.parametrize(
    ("changes", "option", "message"),
    [
        ({"method": "quaternion"}, "method", "expected one of"),
        ({"warp": "dtw"}, "warp", "expected one of"),
        ({"skeleton": "last"}, "skeleton", "expected 'blend' or 'first'"),
        ({"contacts": "sometimes"}, "contacts", "expected one of ['keep', 'report', 'off']"),
        ({"weight_curve": "0:0,1:2"}, "weight_curve", "expected weights s in [0, 1]"),
        ({"landmarks": "manual"}, "landmarks", "expected None, 'auto' or pairs"),
        ({"landmarks": [(0.1, 0.2, 0.3)]}, "landmarks", "of shape (M, 2)"),
        ({"landmarks": "auto", "warp": "none"}, "landmarks", "expected a time warp"),
        ({"landmarks": [(0.5, 0.5)], "cycles": True}, "landmarks", "expected no landmarks with cycles"),
        ({"max_pairs": 0}, "max_pairs", "expected None or an integer >= 1"),
        ({"landmark_kinds": "left_knee_passes"}, "landmark_kinds", "expected a sequence of event kinds"),
        ({"prepare": {"joints": "common"}}, "prepare", "expected PrepareOptions"),
        ({"contact_options": 0.03}, "contact_options", "expected ContactOptions"),
        ({"anchor": "no"}, "anchor", "expected True or False"),
        ({"metrics": 1}, "metrics", "expected True or False"),
    ],
)
def test_blend_options_name_the_bad_option(changes, option, message):
    """Every option is validated when the options are made, and the error names it (the
    command line shows the flag instead)."""
    with pytest.raises(OptionError) as err:
        BlendOptions(**changes)
    assert err.value.option == option and message in err.value.message


def test_blend_options_are_converted_once():
    """Names and old spellings are converted where the options are made: a warp method to
    WarpOptions, "euler" to "euler-elastic", "auto" contacts to "keep", landmark pairs and a
    weight curve to tuples (so options compare and hash)."""
    o = BlendOptions(method="euler", warp="dp", contacts="auto", landmarks=np.array([[0.5, 0.6]]))
    assert o.method == "euler-elastic" and o.warp == WarpOptions(method="dp") and o.contacts == "keep"
    assert o.landmarks == ((0.5, 0.6),) and BlendOptions(landmarks="none").landmarks is None
    assert BlendOptions(weight_curve="0:0,0.5:0.2,1:1").weight_curve == ((0.0, 0.0), (0.5, 0.2), (1.0, 1.0))
    assert hash(o) == hash(o.replace()) and o == o.replace()
    assert o.to_json()["warp"] == WarpOptions(method="dp").to_json() and o.to_json()["landmarks"] == (
        (0.5, 0.6),
    )
    assert BlendOptions(loop=True).matches_cycles and not BlendOptions().matches_cycles


def test_overrides_give_the_blend_of_the_options_object(pair):
    """``blend_motions(ms, s, method=..., ...)`` is ``blend_motions(ms, s, BlendOptions(...))``;
    overrides change the options given; an unknown keyword is refused, naming it."""
    a, b = pair
    opts = BlendOptions(method="euler-elastic", warp="dp", contacts="off", anchor=False)
    by_options = blend_motions([a, b], 0.4, opts)
    by_keywords = blend_motions([a, b], 0.4, method="euler-elastic", warp="dp", contacts="off", anchor=False)
    changed = blend_motions(
        [a, b], 0.4, BlendOptions(method="lie", contacts="off"), method="euler", warp="dp", anchor=False
    )
    assert by_options.options == by_keywords.options == changed.options == opts
    for res in (by_keywords, changed):
        np.testing.assert_array_equal(res.motion.rotations, by_options.motion.rotations)
        np.testing.assert_array_equal(res.motion.root_translation, by_options.motion.root_translation)
        assert res.summary() == by_options.summary()
    with pytest.raises(OptionError, match=r"^metric: unknown option \['metric'\] of BlendOptions"):
        blend_motions([a, b], 0.4, metric=True)
    with pytest.raises(OptionError, match=r"^options: expected a BlendOptions"):
        blend_motions([a, b], 0.4, WarpOptions())
