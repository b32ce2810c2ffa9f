"""Contacts with the floor (elastic_motion.motion.contacts) and skating measured on them."""

from __future__ import annotations

import numpy as np
import pytest

from elastic_motion.apps.metrics import contact_skating
from elastic_motion.apps.prepare import load_motion
from elastic_motion.motion import Motion, Skeleton
from elastic_motion.motion.contacts import (
    MISSED_STANCES_NOTE,
    ContactOptions,
    contact_joints,
    detect_contacts,
)

ROOT = ("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")


def foot_motion(height: np.ndarray, x: np.ndarray, fps: float = 30.0) -> Motion:
    """Hips above a 'LeftFoot' 1 m below them: the foot's height is ``height`` and its
    horizontal position ``x`` (metres), frame by frame; a 'Head' that never touches."""
    f = height.shape[0]
    sk = Skeleton(
        names=["Hips", "LeftFoot", "Head", "LeftHand"],
        parents=[-1, 0, 0, 0],
        offsets=np.array([[0, 0, 0], [0, -1.0, 0], [0, 0.6, 0], [0.3, 0.2, 0]]),
        channels=[ROOT, [], [], []],
    )
    root = np.column_stack([x, 1.0 + height, np.zeros(f)])
    return Motion(sk, fps, root, np.tile(np.eye(3), (f, 4, 1, 1)), metres_per_unit=1.0, name="foot")


def stance_swing(n=90, fps=30.0):
    """Foot planted (height 0, no travel) on frames [10, 40) and [60, 85), lifted 25 cm and
    moving at 1.5 m/s otherwise."""
    planted = np.zeros(n, dtype=bool)
    planted[10:40] = planted[60:85] = True
    height = np.where(planted, 0.0, 0.25)
    step = np.where(planted[1:] & planted[:-1], 0.0, 1.5 / fps)
    return height, np.concatenate([[0.0], np.cumsum(step)])


def test_planted_intervals_are_found_exactly():
    height, x = stance_swing()
    c = detect_contacts(foot_motion(height, x))
    assert c.joints == ("LeftFoot", "LeftHand")
    assert c.intervals("LeftFoot") == [(10, 40), (60, 85)]
    assert c.intervals("LeftHand") == []
    assert c.floor == pytest.approx(0.0, abs=1e-12)
    assert "never near the floor" in c.notes[0] and "LeftHand" in c.notes[0]
    ev = c.events()
    assert [e[2] for e in ev] == ["strike", "lift", "strike", "lift"]
    assert ev[0][0] == pytest.approx(10 / 30)


def test_a_stance_above_the_contact_height_is_named_in_the_notes():
    """The second stance 5 cm above the first (a floor that rises, as in CMU 07_01 and 08_02):
    not a contact with the default thresholds, but the notes say where and how high; a
    higher ``height_enter`` counts it."""
    height, x = stance_swing()
    height[60:85] = 0.05
    c = detect_contacts(foot_motion(height, x))
    assert c.intervals("LeftFoot") == [(10, 40)]
    note = [n for n in c.notes if n.startswith(MISSED_STANCES_NOTE)]
    assert len(note) == 1 and "LeftFoot 1 (the first at 2.03 s), 0.050-0.050 m above" in note[0]
    raised = detect_contacts(foot_motion(height, x), ContactOptions(height_enter=0.06, height_exit=0.08))
    assert raised.intervals("LeftFoot") == [(10, 40), (60, 85)]
    assert not any(n.startswith(MISSED_STANCES_NOTE) for n in raised.notes)
    height[60:85] = 0.15  # a foot held still 15 cm up is not a stance: no note
    assert not any(n.startswith(MISSED_STANCES_NOTE) for n in detect_contacts(foot_motion(height, x)).notes)


def test_hysteresis_and_minimum_duration():
    n = 120
    rng = np.random.default_rng(3)
    height = np.full(n, 0.3)
    x = np.zeros(n)
    height[20:80] = 0.045 + 0.01 * rng.uniform(-1, 1, 60)  # hovering between enter and exit
    height[20:25] = 0.0  # enters here
    height[100:102] = 0.0  # a 2-frame blip: shorter than 0.1 s
    c = detect_contacts(foot_motion(height, x))
    runs = c.intervals("LeftFoot")
    assert runs == [(20, 80)]  # stays in contact while under the exit height, no flicker
    # without hysteresis (exit = enter) the hovering part is not a contact
    strict = detect_contacts(foot_motion(height, x), ContactOptions(height_exit=0.03))
    assert strict.intervals("LeftFoot") == [(20, 25)]


def test_a_sliding_foot_is_not_a_contact_but_skates():
    n = 60
    height = np.zeros(n)
    x = np.arange(n) * (2.0 / 30)  # 2 m/s on the floor: skating, not planted
    c = detect_contacts(foot_motion(height, x))
    assert not c.any
    planted = detect_contacts(foot_motion(height, np.zeros(n)))
    assert planted.intervals("LeftFoot") == [(0, n)]
    # measured against the planted contacts, the sliding motion skates at 2 m/s
    sk = contact_skating(foot_motion(height, x), planted)
    assert sk.mean_speed == pytest.approx(2.0, rel=1e-9) and sk.steps == n - 1
    assert contact_skating(foot_motion(height, np.zeros(n)), planted).mean_speed == 0.0


def test_depth_below_floor():
    n = 40
    height = np.zeros(n)
    c = detect_contacts(foot_motion(height, np.zeros(n)))
    lower = height.copy()
    lower[5] = -0.07
    sk = contact_skating(foot_motion(lower, np.zeros(n)), c)
    assert sk.below_floor == pytest.approx(0.07, rel=1e-9)
    assert contact_skating(foot_motion(height, np.zeros(n)), c).below_floor == 0.0


def test_no_candidate_joints_and_bad_input():
    m = foot_motion(np.zeros(10), np.zeros(10))
    c = detect_contacts(m, joints=[])
    assert c.joints == () and not c.any and "no joint" in c.notes[0]
    with pytest.raises(ValueError, match="unknown"):
        detect_contacts(m, joints=["Tail"])
    with pytest.raises(ValueError, match="hysteresis"):
        ContactOptions(height_enter=0.1, height_exit=0.05)
    with pytest.raises(ValueError, match="frames like the motion"):
        contact_skating(foot_motion(np.zeros(12), np.zeros(12)), c)


@pytest.mark.mocap
@pytest.mark.parametrize(
    ("rel", "feet", "hands_touch"),
    [
        ("cmu/bvh/07_01.bvh", ("LeftFoot", "RightFoot"), False),
        ("cmu/bvh/49_08.bvh", ("LeftFoot", "RightFoot"), True),  # cartwheels: hands on the floor
        ("deepmimic/humanoid3d_walk.txt", ("left_ankle", "right_ankle"), False),
        ("bandai/dataset-1_walk_normal_001.bvh", ("Foot_L", "Foot_R"), False),
        ("cmu/asfamc/02_01.amc", ("lfoot", "rfoot"), False),
    ],
)
def test_real_clips(mocap_dir, rel, feet, hands_touch):
    m, _ = load_motion(mocap_dir / rel)
    c = detect_contacts(m)
    cand = [m.skeleton.names[j] for j in contact_joints(m)]
    assert set(feet) <= set(cand)
    for foot in feet:
        assert c.intervals(foot), foot  # every foot is planted at some point
    hands = [n for n in c.joints if "hand" in n.lower() or "wrist" in n.lower()]
    assert bool(any(c.intervals(h) for h in hands)) == hands_touch
    # the input skates little while planted (mocap noise), far less than walking speed
    assert contact_skating(m, c).mean_speed < 0.25
    if "walk" in rel:  # the feet alternate: both down together only briefly (double support)
        k0, k1 = c.joints.index(feet[0]), c.joints.index(feet[1])
        both = (c.mask[:, k0] & c.mask[:, k1]).mean()
        assert both < 0.5


@pytest.mark.mocap
def test_the_stances_of_a_rising_floor_are_named(mocap_dir):
    """CMU 08_02: the floor rises about 6 cm over the clip; the left foot's second stance
    (1.2-1.6 s) stands 3.4 cm above its first and is no contact, which the notes say."""
    m = load_motion(mocap_dir / "cmu/bvh/08_02.bvh")[0]
    c = detect_contacts(m)
    assert not c.mask[int(1.3 * m.fps) : int(1.5 * m.fps), c.joints.index("LeftFoot")].any()
    note = next(n for n in c.notes if n.startswith(MISSED_STANCES_NOTE))
    assert "LeftFoot 2 (the first at 1.19 s)" in note
