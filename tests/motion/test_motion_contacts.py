"""Contacts with the floor (elastic_motion.motion.contacts) and skating measured on them."""

from __future__ import annotations

import numpy as np
import pytest

from elastic_motion.apps.metrics import contact_skating
from elastic_motion.apps.prepare import load_motion
from elastic_motion.motion import Motion, Skeleton
from elastic_motion.motion.contacts import (
    FLOOR_NOT_LEVEL,
    MISSED_STANCES,
    MISSED_STANCES_NOTE,
    NEVER_NEAR_FLOOR,
    NO_CONTACT_JOINTS,
    ContactOptions,
    contact_joints,
    detect_contacts,
)
from elastic_motion.notes import of_kind

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
    assert c.notes[0].kind == NEVER_NEAR_FLOOR and c.notes[0].data == {"joints": ["LeftHand"]}
    assert str(c.notes[0]) == "never near the floor in this clip: ['LeftHand']"
    assert c.summary()["notes"] == [str(n) for n in c.notes]  # a report lists the texts
    ev = c.events()
    assert [e[2] for e in ev] == ["strike", "lift", "strike", "lift"]
    assert ev[0][0] == pytest.approx(10 / 30)


def test_a_stance_above_the_contact_height_is_named_in_the_notes():
    """The second stance 5 cm above the first, in a clip too short (2 s) to tell a floor that
    rises: not a contact with the default thresholds, but the notes say where and how high;
    a higher ``height_enter`` counts it."""
    height, x = stance_swing(fps=45.0)
    height[60:85] = 0.05
    c = detect_contacts(foot_motion(height, x, fps=45.0))
    assert c.floor_offset is None and c.intervals("LeftFoot") == [(10, 40)]
    note = of_kind(c.notes, MISSED_STANCES)
    assert len(note) == 1 and "LeftFoot 1 (the first at 1.36 s), 0.050-0.050 m above" in str(note[0])
    assert str(note[0]).startswith(MISSED_STANCES_NOTE)
    found = note[0].data["joints"]["LeftFoot"]
    assert found["count"] == 1 and found["first_s"] == pytest.approx(61 / 45.0)
    assert found["lowest"] == found["highest"] == pytest.approx(0.05)
    raised = detect_contacts(
        foot_motion(height, x, fps=45.0), ContactOptions(height_enter=0.06, height_exit=0.08)
    )
    assert raised.intervals("LeftFoot") == [(10, 40), (60, 85)]
    assert not of_kind(raised.notes, MISSED_STANCES)
    height[60:85] = 0.15  # a foot held still 15 cm up is not a stance: no note
    notes = detect_contacts(foot_motion(height, x, fps=45.0)).notes
    assert not of_kind(notes, MISSED_STANCES)


def test_a_heel_raised_on_a_planted_toe_is_no_missed_stance():
    """The second stance on the ball of the foot: the ankle 5 cm up and still, its toe
    planted (CMU 131_02 walks slowly so). The ankle is no contact there, the toe is, and the
    notes do not call the ankle's stretch a missed stance; without the toe among the
    candidates they do."""
    fps = 45.0
    height, x = stance_swing(fps=fps)
    raised = np.zeros(height.shape[0], dtype=bool)
    raised[60:85] = True
    height[raised] = 0.05
    m = foot_motion(height, x, fps=fps)
    sk = m.skeleton
    toe = Skeleton(
        names=[*sk.names, "LeftToe"],
        parents=[*sk.parents, 1],
        offsets=np.vstack([sk.offsets, [0.15, 0.0, 0.0]]),
        channels=[*sk.channels, []],
    )
    rot = np.tile(np.eye(3), (m.n_frames, 5, 1, 1))
    th = np.arcsin(0.05 / 0.15)  # the foot turned down about z puts the toe 5 cm below the ankle
    rot[raised, 1] = [[np.cos(th), np.sin(th), 0], [-np.sin(th), np.cos(th), 0], [0, 0, 1]]
    m = Motion(toe, fps, m.root_translation, rot, metres_per_unit=1.0, name="toe")
    c = detect_contacts(m)
    assert c.intervals("LeftFoot") == [(10, 40)]
    # (the toe slides 9 mm as the foot turns flat again after frame 84)
    assert c.intervals("LeftToe") == [(10, 40), (60, 84)]
    assert not of_kind(c.notes, MISSED_STANCES)
    alone = detect_contacts(m, joints=["LeftFoot"])
    note = of_kind(alone.notes, MISSED_STANCES)
    assert len(note) == 1 and "LeftFoot 1 (the first at 1.36 s), 0.050-0.050 m above" in str(note[0])


def test_a_floor_that_rises_is_followed():
    """Six stances on a floor that rises 6 cm over 6 s (a slope, a capture that drifts; CMU
    08_02 rises as much in 2.6 s): every stance is a contact, measured from the floor of its
    frame, and the depth below the floor is measured from it too."""
    n, fps = 180, 30.0
    planted = np.zeros(n, dtype=bool)
    for a in range(5, n, 30):
        planted[a : a + 18] = True
    rise = 0.06 * np.arange(n) / (n - 1)
    height = rise + np.where(planted, 0.0, 0.25)
    x = np.concatenate([[0.0], np.cumsum(np.where(planted[1:] & planted[:-1], 0.0, 1.5 / fps))])
    c = detect_contacts(foot_motion(height, x, fps=fps))
    assert c.intervals("LeftFoot") == [(a, a + 18) for a in range(5, n, 30)]
    assert c.floor_offset is not None and np.ptp(c.floor_offset) == pytest.approx(0.06, abs=0.015)
    # the floor of each frame follows the stances (within the smoothing)
    np.testing.assert_allclose(c.floor_heights()[planted], rise[planted], atol=0.012)
    assert c.summary()["floor_rise_m"] == pytest.approx(np.ptp(c.floor_offset))
    assert not of_kind(c.notes, MISSED_STANCES)
    (level,) = of_kind(c.notes, FLOOR_NOT_LEVEL)
    assert str(level).startswith("the floor is not level") and level.data["rise"] == np.ptp(c.floor_offset)
    # a foot 3 cm into the last stance's floor is 3 cm below it, not above the first's
    sunk = height.copy()
    sunk[-20:-5] -= 0.03
    sk = contact_skating(foot_motion(sunk, x, fps=fps), c)
    assert sk.below_floor == pytest.approx(0.03, abs=0.012)
    # level (the same clip without the rise): no offset, as before
    level = detect_contacts(foot_motion(height - rise, x, fps=fps))
    assert level.floor_offset is None and level.intervals("LeftFoot") == c.intervals("LeftFoot")
    # asked for one floor height (a loop's), the rising floor is not followed
    flat = detect_contacts(foot_motion(height, x, fps=fps), ContactOptions(follow_floor=False))
    assert flat.floor_offset is None and len(flat.intervals("LeftFoot")) < 6
    with pytest.raises(ValueError, match="follow_floor"):
        ContactOptions(follow_floor=1)
    # on a subset of frames the offset goes with them
    sub = c.select_frames(np.arange(0, n, 3))
    np.testing.assert_array_equal(sub.floor_heights(), c.floor_heights()[::3])


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
    assert (
        c.joints == ()
        and not c.any
        and c.notes[0].kind == NO_CONTACT_JOINTS
        and "no joint" in str(c.notes[0])
    )
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
def test_the_stances_of_a_rising_floor_are_contacts(mocap_dir):
    """CMU 08_02: the floor rises about 6 cm over the clip. Measured from one floor height,
    the left foot's second and third stances (3.4 and 5.9 cm up) were no contacts; measured
    from the floor of their frames, every stance is."""
    m = load_motion(mocap_dir / "cmu/bvh/08_02.bvh")[0]
    c = detect_contacts(m)
    assert c.floor_offset is not None and 0.04 < np.ptp(c.floor_offset) < 0.08
    left = c.intervals("LeftFoot")
    assert len(left) == 3 and left[1][0] / m.fps == pytest.approx(1.2, abs=0.05)
    assert not of_kind(c.notes, MISSED_STANCES)
