"""Events of a motion (knee crossings, foot contacts) and their pairing into landmarks."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from blend_testlib import walker

from elastic_motion.apps.landmark_detection import auto_landmarks
from elastic_motion.apps.landmarks import (
    GAIT_KINDS,
    Event,
    contact_events,
    detect_events,
    find_leg_joints,
    pair_by_phase,
    pair_events,
)
from elastic_motion.motion import Skeleton, drop_tpose, read_motion, trim


def _skeleton(names):
    n = len(names)
    return Skeleton(names, [-1] + list(range(n - 1)), np.ones((n, 3)), [()] * n)


@pytest.mark.parametrize(
    ("names", "left_knee", "right_ankle"),
    [
        (("Hips", "LeftUpLeg", "LeftLeg", "RightUpLeg", "RightLeg", "RightFoot"), "LeftLeg", "RightFoot"),
        (("root", "lfemur", "ltibia", "rfemur", "rtibia", "rfoot"), "ltibia", "rfoot"),
        (
            ("root", "left_hip", "left_knee", "right_hip", "right_knee", "right_ankle"),
            "left_knee",
            "right_ankle",
        ),
        (("Hips", "UpperLeg_L", "LowerLeg_L", "UpperLeg_R", "LowerLeg_R", "Foot_R"), "LowerLeg_L", "Foot_R"),
        (("Hips", "LeftHip", "LeftKnee", "RightHip", "RightKnee", "RightAnkle"), "LeftKnee", "RightAnkle"),
        (
            ("mixamorig:Hips", "mixamorig:LeftUpLeg", "mixamorig:LeftLeg", "x", "y", "mixamorig:RightFoot"),
            "mixamorig:LeftLeg",
            "mixamorig:RightFoot",
        ),
    ],
)
def test_leg_joints_by_name(names, left_knee, right_ankle):
    legs = find_leg_joints(_skeleton(names))
    assert legs.left_knee == left_knee
    assert legs.right_ankle == right_ankle


def test_leg_joints_ignore_lookalikes():
    legs = find_leg_joints(_skeleton(("Hips", "LHipJoint", "lowerback", "LeftShoulder", "lhand", "Leg")))
    assert legs.left_hip is None and legs.left_knee is None and legs.right_knee is None


def test_knee_crossings_of_a_synthetic_walk():
    m = walker(duration=3.0, fps=30.0, freq=1.0)
    ev = detect_events(m, ["left_knee_passes", "right_knee_passes"])
    left = [e.time for e in ev if e.kind == "left_knee_passes"]
    right = [e.time for e in ev if e.kind == "right_knee_passes"]
    np.testing.assert_allclose(left, [1.0, 2.0], atol=0.02)
    np.testing.assert_allclose(right, [0.5, 1.5, 2.5], atol=0.02)
    assert all(isinstance(e, Event) and 0 <= e.frame < m.n_frames for e in ev)
    assert [e.time for e in ev] == sorted(e.time for e in ev)


def test_knee_crossings_do_not_depend_on_heading():
    a = detect_events(walker(duration=3.0, yaw=0.0), ["left_knee_passes"])
    b = detect_events(walker(duration=3.0, yaw=2.0), ["left_knee_passes"])
    np.testing.assert_allclose([e.time for e in a], [e.time for e in b], atol=1e-9)


def test_unknown_kind_and_missing_joints_are_explained():
    m = walker()
    with pytest.raises(ValueError, match="unknown event kind 'elbow'"):
        detect_events(m, ["elbow"])
    sk = _skeleton(("root", "a", "b"))
    from elastic_motion.motion import Motion

    bare = Motion(sk, 30.0, np.zeros((5, 3)), np.tile(np.eye(3), (5, 3, 1, 1)))
    with pytest.raises(ValueError, match="no joint found for left_hip"):
        detect_events(bare, ["left_knee_passes"])


def test_pairing_in_order_and_dropping_crossings():
    ea = [Event("left_knee_passes", t, 0) for t in (0.2, 1.2, 2.2)] + [Event("left_foot_contact", 0.5, 0)]
    eb = [Event("left_knee_passes", t, 0) for t in (0.4, 1.0)] + [Event("left_foot_contact", 1.5, 0)]
    pairs = pair_events(ea, eb, ["left_knee_passes"])
    assert [(a.time, b.time) for a, b in pairs] == [(0.2, 0.4), (1.2, 1.0)]
    assert len(pair_events(ea, eb, ["left_knee_passes"], max_pairs=1)) == 1
    # merged by time in A: (0.2, 0.4), (0.5, 1.5), (1.2, 1.0); the last would make the warp go
    # back in B, so it is dropped
    mixed = pair_events(ea, eb, ["left_knee_passes", "left_foot_contact"])
    assert [(a.time, b.time) for a, b in mixed] == [(0.2, 0.4), (0.5, 1.5)]


def test_auto_landmarks_of_two_walks_with_different_rhythm():
    a = walker(duration=3.2, freq=1.0)
    b = walker(duration=3.2, freq=1.25, phase=0.3)
    pairs = auto_landmarks(a, b, ["left_knee_passes"])
    # left knee passes at k / f - phase / (2 pi f); A has 3, B 4: the k-th meets the k-th, B's
    # last has no partner (the prior warp maps A's 3 cycles onto B's first 3)
    tb = [(k - 0.3 / (2 * np.pi)) / 1.25 for k in (1, 2, 3, 4) if (k - 0.3 / (2 * np.pi)) / 1.25 < 3.2]
    assert len(pairs) == 3
    np.testing.assert_allclose([p[0] for p in pairs], [1.0, 2.0, 3.0], atol=0.02)
    np.testing.assert_allclose([p[1] for p in pairs], tb[:3], atol=0.02)


def _ev(kind, times):
    return [Event(kind, t, round(30 * t)) for t in times]


def test_phase_pairing_skips_an_extra_step_that_in_order_pairing_gets_wrong():
    # B starts a cycle earlier: its first strike has no partner in A. In order, A's first
    # strike would meet B's first (a cycle apart); by phase it meets B's second.
    ea = _ev("left_heel_strike", [0.5, 1.5, 2.5])
    eb = _ev("left_heel_strike", [0.3, 1.3, 2.3, 3.3])
    prior = np.array([[0.0, 0.0], [1.0, 1.0]])  # A 0..3 s -> B 0..4 s: t -> 4/3 t
    in_order = pair_events(ea, eb, ["left_heel_strike"])
    assert (in_order[0][0].time, in_order[0][1].time) == (0.5, 0.3)
    pr = pair_by_phase(ea, eb, prior, 3.0, 4.0, ["left_heel_strike"])
    # the identity prior predicts 0.67, 2.0, 3.33 s: only the last has a B strike within a
    # sixth of a cycle (0.15 s); the others are left unpaired rather than paired wrongly
    assert pr.times == [(2.5, 3.3)]
    # with the right prior (B runs a cycle ahead), every A strike meets the B strike one cycle on
    prior = np.array([[0.0, 0.0], [0.5 / 3, 1.3 / 4], [2.5 / 3, 3.3 / 4], [1.0, 1.0]])
    pr = pair_by_phase(ea, eb, prior, 3.0, 4.0, ["left_heel_strike"])
    assert pr.times == [(0.5, 1.3), (1.5, 2.3), (2.5, 3.3)]
    assert [d["kind"] for d in pr.details] == ["left_heel_strike"] * 3
    assert all(abs(d["offset_s"]) < 0.2 and "prediction" in d["why"] for d in pr.details)
    assert [(s["motion"], s["time_s"]) for s in pr.skipped] == [("B", 0.3)]


def test_phase_pairing_never_pairs_far_events_and_keeps_kinds_apart():
    ea = _ev("left_heel_strike", [1.0, 2.0]) + _ev("right_heel_strike", [1.5])
    eb = _ev("left_heel_strike", [1.05, 2.6]) + _ev("right_heel_strike", [1.45])
    ident = np.array([[0.0, 0.0], [1.0, 1.0]])
    pr = pair_by_phase(ea, eb, ident, 3.0, 3.0, ["left_heel_strike", "right_heel_strike"])
    # 2.0 vs 2.6 is more than a third of the left period (1 s) off: not paired
    assert pr.times == [(1.0, 1.05), (1.5, 1.45)]
    assert {(s["motion"], s["time_s"]) for s in pr.skipped} == {("A", 2.0), ("B", 2.6)}
    assert pr.tolerance_s["left_heel_strike"] == pytest.approx(0.15 * np.median([1.0, 1.55]))


def test_pairs_of_different_kinds_that_cross_are_dropped():
    ea = _ev("left_heel_strike", [1.0]) + _ev("left_toe_off", [1.2])
    eb = _ev("left_heel_strike", [1.25]) + _ev("left_toe_off", [1.15])
    ident = np.array([[0.0, 0.0], [1.0, 1.0]])
    pr = pair_by_phase(ea, eb, ident, 3.0, 3.0, ["left_heel_strike", "left_toe_off"])
    # (1.2, 1.15) is the closer pair; (1.0, 1.25) would cross it
    assert pr.times == [(1.2, 1.15)]
    assert any("crosses" in s["why"] for s in pr.skipped)


def _evu(kind, times, fps=30.0):
    """Events from a per-frame detector: known to half a frame."""
    return [Event(kind, t, round(fps * t), 0.5 / fps) for t in times]


def test_pairs_the_prior_meets_within_the_timing_uncertainty_are_dropped():
    ea = _evu("left_heel_strike", [1.0, 2.0])
    eb = _evu("left_heel_strike", [1.01, 2.1])
    ident = np.array([[0.0, 0.0], [1.0, 1.0]])
    pr = pair_by_phase(ea, eb, ident, 3.0, 3.0, ["left_heel_strike"])
    w = 0.5 / 30 + 0.5 / 30  # half a frame of A carried by the prior (slope 1), half of B
    # 1.0 -> 1.01 s is 10 ms off the prior, inside the +-33 ms window: dropped, with the reason
    assert [(d["time_s"], d["time_b_s"]) for d in pr.dropped] == [(1.0, 1.01)]
    assert pr.dropped[0]["window_s"] == pytest.approx(w)
    assert "timing uncertainty" in pr.dropped[0]["why"]
    # 2.0 -> 2.1 s is 100 ms off: pinned at the window's edge nearest the prior, not at 2.1
    assert pr.times == [(2.0, pytest.approx(2.1 - w))]
    d = pr.details[0]
    assert (d["time_b_s"], d["offset_s"]) == (2.1, pytest.approx(0.1))
    assert d["target_b_s"] == pytest.approx(2.1 - w) and "edge" in d["why"]
    # the report keeps dropped pairs apart from the unpaired events
    summary = pr.summary()
    assert len(summary["dropped"]) == 1 and not any(x.get("dropped") for x in summary["skipped"])
    # an event early of the prediction is pinned at the window's other edge
    pr = pair_by_phase(ea[1:], _evu("left_heel_strike", [1.9]), ident, 3.0, 3.0, ["left_heel_strike"])
    assert pr.times == [(2.0, pytest.approx(1.9 + w))]


def test_the_window_carries_the_uncertainty_of_a_through_the_prior():
    # B runs at half speed: half a frame of A is a whole frame of B
    ea = _evu("left_heel_strike", [1.0])
    eb = _evu("left_heel_strike", [2.04])
    slow = np.array([[0.0, 0.0], [1.0, 1.0]])  # A 0..3 s -> B 0..6 s
    pr = pair_by_phase(ea, eb, slow, 3.0, 6.0, ["left_heel_strike"])
    w = 2 * 0.5 / 30 + 0.5 / 30
    assert pr.times == [] and pr.dropped[0]["window_s"] == pytest.approx(w)  # 40 ms < 50 ms
    pr = pair_by_phase(ea, _evu("left_heel_strike", [2.1]), slow, 3.0, 6.0, ["left_heel_strike"])
    assert pr.times == [(1.0, pytest.approx(2.1 - w))]


def test_times_without_uncertainty_are_pinned_where_they_are():
    ident = np.array([[0.0, 0.0], [1.0, 1.0]])
    ea = _ev("left_heel_strike", [1.0, 2.0])
    eb = _ev("left_heel_strike", [1.01, 2.1])
    pr = pair_by_phase(ea, eb, ident, 3.0, 3.0, ["left_heel_strike"])
    assert pr.times == [(1.0, 1.01), (2.0, 2.1)] and pr.dropped == ()


def test_events_know_their_timing_uncertainty():
    m = walker(duration=2.0)
    for e in contact_events(m):
        assert e.uncertainty == pytest.approx(0.5 / m.fps)
    knees = [e for e in detect_events(m, ["left_knee_passes", "right_knee_passes"])]
    assert knees and all(0.0 <= e.uncertainty <= 1.0 / m.fps for e in knees)


def test_contact_events_are_gait_kinds():
    ev = contact_events(walker(duration=2.0))
    assert all(e.kind in GAIT_KINDS for e in ev)


@pytest.mark.mocap
def test_events_on_real_walks(mocap_dir):
    m = trim(drop_tpose(read_motion(mocap_dir / "cmu/bvh/107_02_30hz.bvh")), 1.0, 3.4)
    ev = detect_events(m)
    kinds = [e.kind for e in ev]
    # a steady walk: knee crossings and foot contacts alternate sides, about 2 steps per second
    left = [e.time for e in ev if e.kind == "left_knee_passes"]
    assert 2 <= len(left) <= 3
    assert 0.6 < np.diff(left).mean() < 1.2
    assert kinds.count("left_foot_contact") >= 2 and kinds.count("right_foot_contact") >= 2
    # DeepMimic walk: its own joint names
    dm = read_motion(mocap_dir / "deepmimic/humanoid3d_walk.txt")
    ev = detect_events(dm)
    assert {"left_knee_passes", "left_foot_contact", "right_knee_passes"} <= {e.kind for e in ev}


@pytest.mark.mocap
def test_gait_events_on_a_real_walk_alternate_feet(mocap_dir):
    from elastic_motion.apps.prepare import prepare_motions

    m = prepare_motions(
        [trim(drop_tpose(read_motion(mocap_dir / "cmu/bvh/107_02_30hz.bvh")), 1.0, 3.4)]
    ).motions[0]
    ev = [e for e in contact_events(m) if e.kind.endswith("heel_strike")]
    sides = [e.kind.split("_")[0] for e in ev]
    assert len(ev) >= 3 and all(x != y for x, y in itertools.pairwise(sides))


@pytest.mark.mocap
def test_auto_landmarks_on_the_obstacle_walks_drop_what_the_prior_meets(mocap_dir):
    from elastic_motion.apps.blend import NOTE_LANDMARKS, blend_motions

    a = trim(drop_tpose(read_motion(mocap_dir / "cmu/bvh/107_02_30hz.bvh")), 1.0, 3.4)
    b = trim(drop_tpose(read_motion(mocap_dir / "cmu/bvh/108_01_30hz.bvh")), 1.3, 4.8)
    res = blend_motions([a, b], 0.5, method="euler-elastic", warp="dp", landmarks="auto", contacts="off")
    rep = res.summary()["landmark_pairing"]
    # 30 fps: strikes and toe-offs the warp without landmarks meets within a frame are dropped,
    # the others pinned at their window's edge; the report says which and why
    assert rep["pairs"] and rep["dropped"]
    assert all(abs(d["offset_s"]) > d["window_s"] > 0 for d in rep["pairs"])
    assert all(abs(d["offset_s"]) <= d["window_s"] for d in rep["dropped"])
    assert [list(p) for p in res.landmarks] == [[d["time_a_s"], d["target_b_s"]] for d in rep["pairs"]]
    assert any(n.kind == NOTE_LANDMARKS and str(n).startswith("landmarks auto: dropped") for n in res.notes)


def test_a_knee_crossings_uncertainty_is_the_linear_interpolation_error():
    """A parabola: second differences ``2 q``, so the zero interpolated between frames k and
    k + 1 is off by at most ``2 q / (8 |d[k+1] - d[k]|)`` frames; the true zero is within it."""
    from elastic_motion.apps.landmarks import _crossings

    q, p, r = 0.05, 0.5, -3.0
    f = np.arange(20, dtype=float)
    d = q * f**2 + p * f + r
    ((frame, err),) = _crossings(d, 0.1, upward=True)
    k = int(np.floor(frame))
    assert err == pytest.approx(2 * q / (8 * abs(d[k + 1] - d[k])))
    true_zero = (-p + np.sqrt(p * p - 4 * q * r)) / (2 * q)
    assert abs(frame - true_zero) <= err
    assert abs(frame - true_zero) > 0.25 * err  # the bound is not loose by more than 4x
