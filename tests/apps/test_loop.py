"""Tests of motion looping (paper 000, sec. 5.4): real clips close, the loop convention holds,
C1 matches velocities, the Euler baseline degrades on flips, bad input gives clear errors."""

from __future__ import annotations

import numpy as np
import pytest
from loop_testlib import chain_skeleton

from elastic_motion.apps.loop import loop_motion
from elastic_motion.apps.loop import notes as loop_notes
from elastic_motion.apps.loop.seam_choice import SEAM_C0_KEPT, SEAM_C1_TAKEN
from elastic_motion.apps.metrics import foot_joints, seam_metrics
from elastic_motion.apps.prepare import UNITS_TO_METRES
from elastic_motion.closing import close_curve
from elastic_motion.curves import curve_distance
from elastic_motion.errors import OptionError
from elastic_motion.groups import SO3
from elastic_motion.motion import (
    Motion,
    drop_tpose,
    finger_joints,
    forward_kinematics,
    from_lie_curve,
    read_motion,
    select_frames,
    to_lie_curve,
)
from elastic_motion.motion.looping import cycle_transform, repeat_motion
from elastic_motion.notes import of_kind

SO3G = SO3()

CASES = {
    "dm_run": "deepmimic/humanoid3d_run.txt",
    "dm_cartwheel": "deepmimic/humanoid3d_cartwheel.txt",
    "dm_backflip": "deepmimic/humanoid3d_backflip.txt",
    "cmu_backflip": "cmu/asfamc/backflip.amc",
}


def load(mocap_dir, key):
    return drop_tpose(read_motion(mocap_dir / CASES.get(key, key)))


def closed_set(motion):
    fingers = set(finger_joints(motion.skeleton))
    return [n for n in motion.skeleton.names if n not in fingers]


def test_seam_velocity_jump_ratio_against_the_clip_own_changes():
    """The root accelerates uniformly along x (x_k = 0.01 k^2, nothing turns): every step
    changes every point's velocity by 0.02 fps, and travel moves frame 0 to the last frame's
    floor position, so the seam's jump is from the last step, 0.01 (2F - 3), to the first,
    0.01: (2F - 4) 0.01 fps, F - 2 times the clip's own change, at every point."""
    f, fps = 20, 30.0
    k = np.arange(f, dtype=float)
    root = np.stack([0.01 * k**2, np.full(f, 0.9), np.zeros(f)], 1)
    m = Motion(chain_skeleton(), fps, root, np.tile(np.eye(3), (f, 4, 1, 1)), metres_per_unit=1.0)
    s = seam_metrics(m)
    assert s.seam_velocity_max_m_s == pytest.approx((2 * f - 4) * 0.01 * fps)
    assert s.seam_velocity_jump_ratio == pytest.approx(f - 2)
    # against an original whose velocity changes twice as fast inside: half the ratio
    m2 = m.replace(root_translation=np.stack([0.02 * k**2, np.full(f, 0.9), np.zeros(f)], 1))
    assert seam_metrics(m, original=m2).seam_velocity_jump_ratio == pytest.approx((f - 2) / 2)


# ------------------------------------------------------------------------------ real data


@pytest.mark.mocap
@pytest.mark.parametrize("key", list(CASES))
def test_loop_closes_real_clips_and_keeps_travel(mocap_dir, key):
    res = loop_motion(load(mocap_dir, key), window=None, force=True)
    m = res.original  # prepared: metres, Y-up
    before = seam_metrics(m, joints=closed_set(m))
    assert before.seam_angle_max_deg == res.seam_before.seam_angle_max_deg
    assert res.closing.converged, res.closing.message
    after = seam_metrics(res.motion, original=m, joints=res.closed_joints)
    assert before.seam_angle_max_deg > 5.0
    assert after.seam_angle_max_deg < 1e-3
    assert after.seam_position_max_m < 1e-4
    assert after.seam_position_max_m < 1e-3 * before.seam_position_max_m
    out = res.motion
    # first frame untouched; floor-plane root trajectory kept sample by sample
    np.testing.assert_allclose(out.rotations[0], m.rotations[0], atol=1e-12)
    np.testing.assert_allclose(out.root_translation[:, [0, 2]], m.root_translation[:, [0, 2]], atol=0)
    assert abs(out.root_translation[-1, 1] - out.root_translation[0, 1]) < 1e-6  # height closed
    # repeated three times, the seams are as continuous as the closing residual
    rep = repeat_motion(out, 3)
    pos = forward_kinematics(rep) * (m.metres_per_unit or 1.0)
    f = m.n_frames
    last = forward_kinematics(out)[-1] * (m.metres_per_unit or 1.0)
    np.testing.assert_allclose(pos[f - 1], last, atol=1e-4)  # next cycle starts at the last frame
    joints = [m.skeleton.index(n) for n in res.closed_joints[1:]]
    for k in (1, 2):
        np.testing.assert_allclose(rep.rotations[k * (f - 1), joints], out.rotations[-1, joints], atol=1e-5)
    jump = np.linalg.norm(np.diff(pos, axis=0), axis=-1).max(axis=1)
    assert jump[f - 2] <= 1.5 * jump.max()  # the seam step is an ordinary step


@pytest.mark.mocap
def test_cmu_cartwheels_49_08_long_clip(mocap_dir):
    m = drop_tpose(read_motion(mocap_dir / "cmu/bvh/49_08.bvh"))
    res = loop_motion(
        m, contacts="report", window=None, force=True
    )  # the projection alone (kept contacts: test_loop_contacts)
    m = res.original  # prepared: metres, Y-up
    assert res.closing.converged and res.closing.iterations <= 15
    assert res.closing.kkt_residual < 1e-8  # the default solver: the nearest closed curve
    assert set(res.free_joints) == set(finger_joints(m.skeleton))
    after = seam_metrics(res.motion, original=m, joints=res.closed_joints)
    assert after.seam_angle_max_deg < 1e-3
    # free finger joints keep their samples (they flip by 180 degrees in this file)
    fingers = [m.skeleton.index(n) for n in res.free_joints]
    np.testing.assert_array_equal(res.motion.rotations[:, fingers], m.rotations[:, fingers])
    # the heading change of one cycle is left free in "travel" (not forced to 0)
    assert abs(res.heading_change) > np.radians(5)
    assert np.linalg.norm(res.displacement) > 0.5  # metres: the character travels on


@pytest.mark.mocap
def test_inplace_closes_position_and_heading(mocap_dir):
    m = load(mocap_dir, "dm_run")
    res = loop_motion(m, root="inplace", window=None, force=True)
    out = res.motion
    np.testing.assert_allclose(out.root_translation[-1], out.root_translation[0], atol=1e-6)
    np.testing.assert_allclose(out.rotations[-1], out.rotations[0], atol=1e-6)
    assert res.heading_change == 0.0
    rot, shift = cycle_transform(out, "inplace")
    np.testing.assert_array_equal(rot, np.eye(3))
    np.testing.assert_array_equal(shift, 0.0)


def test_treadmill_removes_the_travel_at_a_constant_rate():
    """``treadmill``: the first frame unchanged, the last back on the first's floor position
    and heading, heights and joint rotations kept; a straight walk at constant speed becomes
    one whose root stays put (the constant rate), a turn is undone a fraction per frame."""
    from elastic_motion.motion.looping import treadmill
    from elastic_motion.motion.rotations import axis_rotation

    m = synthetic()
    f = m.n_frames
    s = np.arange(f) / (f - 1)
    upright = m.rotations.copy()
    upright[:, 0] = np.eye(3)  # the root faces one way
    walk = m.replace(
        rotations=upright,
        root_translation=np.column_stack([0.3 + 0.0 * s, 0.9 + 0.05 * np.sin(7 * s), 2.0 * s]),
    )
    flat, dist, turn = treadmill(walk)
    assert dist == pytest.approx(2.0) and turn == pytest.approx(0.0, abs=1e-12)
    np.testing.assert_allclose(flat.root_translation[:, [0, 2]], np.tile([0.3, 0.0], (f, 1)), atol=1e-12)
    np.testing.assert_array_equal(flat.root_translation[:, 1], walk.root_translation[:, 1])
    np.testing.assert_array_equal(flat.rotations[:, 1:], walk.rotations[:, 1:])
    # a turn of 0.6 rad about y over the clip, on a circle: undone at a constant rate
    yaw = axis_rotation(0.6 * s, "Y")
    rots = walk.rotations.copy()
    rots[:, 0] = yaw @ walk.rotations[0, 0]
    arc = np.column_stack([np.sin(0.6 * s), 0.9 + 0.0 * s, np.cos(0.6 * s) - 1.0])
    flat, dist, turn = treadmill(walk.replace(rotations=rots, root_translation=arc))
    assert turn == pytest.approx(0.6, rel=1e-9) and dist == pytest.approx(
        np.hypot(np.sin(0.6), np.cos(0.6) - 1)
    )
    np.testing.assert_allclose(flat.rotations[:, 0], np.tile(walk.rotations[0, 0], (f, 1, 1)), atol=1e-12)
    np.testing.assert_allclose(flat.root_translation[0], arc[0], atol=1e-12)
    np.testing.assert_allclose(flat.root_translation[-1], arc[0], atol=1e-12)
    # a middle frame, from a tilted first pose: frame k turned back by Y(-0.6 s_k) about the
    # straight line from the first floor position to the last (the formula of `treadmill`)
    tilt = axis_rotation(np.array(0.4), "X")
    rots[:, 0] = yaw @ tilt
    flat, _, turn = treadmill(walk.replace(rotations=rots, root_translation=arc))
    assert turn == pytest.approx(0.6, rel=1e-9)
    k = f // 3
    back = axis_rotation(np.array(-0.6 * s[k]), "Y")
    line = np.array([0.0, 0.0, 0.0]) + s[k] * (arc[-1] * [1, 0, 1] - arc[0] * [1, 0, 1])
    np.testing.assert_allclose(
        flat.root_translation[k], back @ (arc[k] - line) + arc[0] * [1, 0, 1], atol=1e-12
    )
    np.testing.assert_allclose(flat.rotations[:, 0], np.tile(tilt, (f, 1, 1)), atol=1e-12)
    # on_belt undoes it exactly (the belt's travel and turn put back)
    from elastic_motion.motion.looping import on_belt

    turned = walk.replace(rotations=rots, root_translation=arc)
    back_on = on_belt(flat, turned)
    np.testing.assert_allclose(back_on.root_translation, arc, atol=1e-12)
    np.testing.assert_allclose(back_on.rotations, turned.rotations, atol=1e-12)
    with pytest.raises(ValueError, match="frames"):
        on_belt(select_frames(flat, np.arange(5)), turned)


@pytest.mark.mocap
def test_inplace_loop_keeps_contacts_on_a_treadmill(mocap_dir):
    """The DeepMimic run travels 2.9 m: in place with its contacts kept, the body jumped back
    1.1 m between two frames of its flight (root 34 m/s); on the treadmill the root never
    moves faster than the input's own root does, the seam closes and the note says why the
    planted feet move."""
    m = load(mocap_dir, "dm_run")
    res = loop_motion(m, root="inplace", window=None, force=True)
    assert res.contacts_kept is not None and res.contacts_kept.treadmill["travel_m"] > 2.5
    (note,) = of_kind(res.notes, loop_notes.TREADMILL)
    assert str(note).startswith("contacts kept on a treadmill") and note.data["travel_m"] > 2.5
    out = res.motion

    def root_speed(x):
        return np.linalg.norm(np.diff(x.root_translation, axis=0), axis=1).max() * x.fps * x.metres_per_unit

    assert root_speed(out) < root_speed(m)
    np.testing.assert_allclose(out.root_translation[-1], out.root_translation[0], atol=1e-6)
    assert res.seam_after.seam_angle_max_deg < 1e-3
    # in the world the planted feet move back with the belt (about the run's 3.5 m/s); with
    # the belt's motion taken out they slip as little as the input's do
    belt = res.skating_on_treadmill
    assert res.skating_after.mean_speed > 2.0 and belt.mean_speed < 1.1 * res.skating_before.mean_speed
    assert res.summary()["skating_on_treadmill"]["skating_mean_m_s"] == pytest.approx(belt.mean_speed)
    # travel keeps the planted feet where they are: no treadmill there
    travel = loop_motion(m, root="travel", window=None, force=True)
    assert travel.contacts_kept.treadmill is None and travel.skating_on_treadmill is None
    assert "treadmill" not in travel.summary()["contacts_kept"]


@pytest.mark.mocap
def test_dropped_contacts_close_the_clip_itself_not_its_treadmill(mocap_dir, monkeypatch):
    """When the kept contacts cannot be solved (dropped), the in-place loop is the clip closed
    without them, as with ``contacts="report"``: not the treadmilled clip, whose travel would
    be gone without a note."""
    import dataclasses

    import elastic_motion.apps.loop.close as close_mod

    m = load(mocap_dir, "dm_run")
    keep = close_mod.close_keeping_contacts

    def dropped(*args, **kwargs):
        closing = keep(*args, **kwargs)
        kept = closing.kept.replace(dropped="contacts dropped (forced); closed without them")
        return dataclasses.replace(closing, motion=None, kept=kept)

    monkeypatch.setattr(close_mod, "close_keeping_contacts", dropped)
    out = loop_motion(m, root="inplace", window=None, force=True)
    plain = loop_motion(m, root="inplace", contacts="report", window=None, force=True)
    np.testing.assert_allclose(out.motion.root_translation, plain.motion.root_translation, atol=1e-9)
    assert not any("treadmill" in str(n) for n in out.notes) and not of_kind(out.notes, loop_notes.TREADMILL)
    assert of_kind(out.notes, loop_notes.DROPPED)


@pytest.mark.mocap
def test_auto_seam_keeps_c0_when_c1_is_worse(mocap_dir):
    """The DeepMimic get-up (a clip that cannot repeat), frames 59-174: the C0 seam has a hitch
    (3.8x at an elbow), but closed C1 the loop whips a wrist at 52 m/s on its last step. The
    default keeps the C0 loop and says why, without suggesting C1."""
    res = loop_motion(mocap_dir / "deepmimic/humanoid3d_getup_facedown.txt", window=(59, 174), force=True)
    assert not res.c1 and res.seam == "c0"
    assert not of_kind(res.notes, loop_notes.HITCH)
    (note,) = of_kind(res.notes, SEAM_C0_KEPT)
    text = str(note)
    assert text.startswith("a hitch at the seam") and "closed C1 too (c1='auto') and not taken" in text
    assert "it whips a limb" in text and "--seam c1" not in text
    assert note.data["ratio"] > 1.5 and any(w.startswith("it whips a limb") for w in note.data["c1_refused"])
    plain = loop_motion(
        mocap_dir / "deepmimic/humanoid3d_getup_facedown.txt", window=(59, 174), seam="c0", force=True
    )
    np.testing.assert_allclose(res.motion.rotations, plain.motion.rotations, atol=1e-12)
    with pytest.raises(OptionError, match="seam"):
        loop_motion(plain.motion, seam="yes", window=None, force=True)
    with pytest.raises(OptionError, match=r"^c1: unknown option \['c1'\] of LoopOptions"):
        loop_motion(plain.motion, c1=True, window=None, force=True)


@pytest.mark.mocap
@pytest.mark.parametrize("key", ["dm_run", "dm_cartwheel"])
@pytest.mark.parametrize("root", ["travel", "inplace"])
def test_c1_matches_seam_velocities_c0_does_not(mocap_dir, key, root):
    m = load(mocap_dir, key)
    c0 = loop_motion(m, root=root, seam="c0", window=None, force=True)
    c1 = loop_motion(m, root=root, seam="c1", window=None, force=True)
    assert c1.closing.converged
    s0 = seam_metrics(c0.motion, original=m, root=root, joints=c0.closed_joints)
    s1 = seam_metrics(c1.motion, original=m, root=root, joints=c1.closed_joints)
    assert s0.seam_angle_max_deg < 1e-3 and s1.seam_angle_max_deg < 1e-3
    assert s0.seam_angular_velocity_max_deg_s > 100.0
    assert s1.seam_angular_velocity_max_deg_s < 1e-2
    # what an animator sees: the cartwheel's C0 seam jerks the wrist 2.7-3x harder than any
    # quick move inside the clip, and a note says so; C1 is within the clip's own (the run's
    # C0 seam is too: no note)
    hitch = [str(n) for n in of_kind(c0.notes, loop_notes.HITCH)]
    assert all(h.startswith("a hitch at the seam") for h in hitch)
    assert s1.seam_velocity_jump_ratio < 1.0 and not of_kind(c1.notes, loop_notes.HITCH)
    auto = loop_motion(m, root=root, window=None, force=True)  # the default, seam="auto"
    if key == "dm_cartwheel":
        assert s0.seam_velocity_jump_ratio > 2.5 and s0.seam_velocity_jump_point == "right_wrist"
        assert len(hitch) == 1 and "right_wrist" in hitch[0] and "--seam c1" in hitch[0]
        # the default closes C1 too and takes it: smoother, no more change or skating
        (taken,) = of_kind(auto.notes, SEAM_C1_TAKEN)
        assert auto.c1 and str(taken).startswith("seam C1 (c1='auto')")
        np.testing.assert_allclose(auto.motion.rotations, c1.motion.rotations, atol=1e-12)
    else:
        assert s0.seam_velocity_jump_ratio < 1.0 and not hitch
        # no hitch: the default is the C0 loop, untouched
        assert not auto.c1 and not of_kind(auto.notes, SEAM_C1_TAKEN, SEAM_C0_KEPT)
        assert not any("c1='auto'" in str(n) for n in auto.notes)
        np.testing.assert_allclose(auto.motion.rotations, c0.motion.rotations, atol=1e-12)
    if root == "inplace":
        # everything closed, so the FK velocities match too, up to second order in the step:
        # the seam's one-frame velocity change is a fraction of the largest inside the clip
        # (the run's C0 seam is no rougher than its frames either: its kept contacts ride a
        # treadmill, 2.3 m/s against 7.0 inside; without it the body jumped, 6.7 m/s)
        p = forward_kinematics(c1.motion) * c1.motion.metres_per_unit
        inside = np.linalg.norm(np.diff(p, n=2, axis=0), axis=2).max() * c1.motion.fps
        assert s1.seam_velocity_max_m_s < 0.25 * inside
        assert s1.seam_velocity_max_m_s < 0.6 * s0.seam_velocity_max_m_s


@pytest.mark.mocap
@pytest.mark.parametrize("key", ["dm_backflip", "dm_cartwheel"])
def test_euler_baseline_degrades_on_flips(mocap_dir, key):
    # a flip turns the root by 2 pi: the unwrapped Euler angles end 2 pi away from where they
    # started, and closing them undoes the flip (paper 000, sec. 5.4: the character floats)
    m = load(mocap_dir, key)
    lie = loop_motion(m, contacts="report", window=None, force=True)  # the two projections alone
    eul = loop_motion(
        m, method="euler-elastic", solver="gauss-newton", window=None, force=True
    )  # paper 001's projection
    assert lie.closing.converged and eul.closing.converged
    dl = seam_metrics(lie.motion, original=m)
    de = seam_metrics(eul.motion, original=m)
    assert de.seam_angle_max_deg < 1e-3  # the Euler curve is closed too ...
    assert de.deviation_mean_m > 10 * dl.deviation_mean_m  # ... by undoing the motion
    assert de.deviation_max_m > 1.0
    root_turn_lie = np.linalg.norm(
        SO3G.log(lie.motion.rotations[1:, 0] @ np.swapaxes(lie.motion.rotations[:-1, 0], -1, -2)), axis=-1
    ).sum()
    root_turn_eul = np.linalg.norm(
        SO3G.log(eul.motion.rotations[1:, 0] @ np.swapaxes(eul.motion.rotations[:-1, 0], -1, -2)), axis=-1
    ).sum()
    assert root_turn_lie > 5.0 and root_turn_eul < 0.7 * root_turn_lie  # the flip is gone


def naive_closed(motion, closed):
    """Spread each closed joint's seam rotation linearly over time (root position kept)."""
    t = np.linspace(0, 1, motion.n_frames)
    ell = SO3G.difference(motion.rotations[0], motion.rotations[-1])
    ell[~closed] = 0.0
    return motion.replace(rotations=SO3G.compose(SO3G.exp(-t[:, None, None] * ell[None]), motion.rotations))


@pytest.mark.mocap
@pytest.mark.parametrize("key", ["dm_cartwheel", "dm_backflip", "cmu_backflip"])
def test_joint_closing_moves_less_than_naive_fix(mocap_dir, key):
    m = load(mocap_dir, key)
    closed = np.array([n in closed_set(m) for n in m.skeleton.names])
    closed[0] = False  # joints only: root orientation and position free
    curve = to_lie_curve(m)
    res = close_curve(curve, factors=np.concatenate([np.zeros(3, bool), np.repeat(closed, 3)]), tol=1e-9)
    lie = from_lie_curve(res.curve, m)
    naive = naive_closed(m, closed)
    names = list(m.skeleton.names)
    for out in (lie, naive):
        assert (
            seam_metrics(
                out, root="inplace", joints=[n for n, c in zip(names, closed, strict=True) if c]
            ).seam_angle_max_deg
            < 1e-6
        )
    assert curve_distance(curve, res.curve) < curve_distance(curve, to_lie_curve(naive))
    dl = seam_metrics(lie, original=m, root="inplace").deviation_mean_m
    dn = seam_metrics(naive, original=m, root="inplace").deviation_mean_m
    assert dl < dn


# ------------------------------------------------------------------------- synthetic clips


def synthetic(f=40, closed=False, seam_pi=False):
    t = np.linspace(0, 1, f)
    ph = 2 * np.pi * t if closed else 1.7 * np.pi * t
    rv = np.zeros((f, 4, 3))
    rv[:, 0] = np.outer(np.sin(ph), [0.1, 0.3, 0.05]) + np.outer(t if not closed else 0 * t, [0, 0.5, 0])
    rv[:, 1] = np.outer(np.sin(ph), [0.8, 0, 0.1])
    rv[:, 2] = np.outer(1 - np.cos(ph), [0.6, 0, 0])
    rv[:, 3] = np.outer(np.sin(2 * ph), [0.2, 0.1, 0])
    if seam_pi:
        rv[:, 3] = np.outer(t, [0, 0, np.pi])
    root = np.stack([2.0 * t, 0.9 + 0.05 * np.sin(ph), 0.3 * t], 1)
    return Motion(chain_skeleton(), 30.0, root, SO3G.exp(rv), metres_per_unit=1.0, name="synthetic")


def test_looping_clip_is_a_fixed_point_and_metrics_vanish():
    m = synthetic(closed=True)
    s = seam_metrics(m, original=m)
    assert s.seam_angle_max_deg < 1e-9 and s.seam_position_max_m < 1e-12
    assert s.deviation_max_m == 0.0
    res = loop_motion(m, tol=1e-8, window=None, force=True)
    assert res.closing.iterations == 0
    np.testing.assert_allclose(res.motion.rotations, m.rotations, atol=1e-12)


def test_synthetic_travel_loop_and_repeat():
    m = synthetic()
    res = loop_motion(m, tol=1e-10, window=None, force=True)
    out = res.motion
    s = seam_metrics(out, original=m)
    assert s.seam_angle_max_deg < 1e-6 and s.seam_position_max_m < 1e-8
    assert np.degrees(abs(res.heading_change)) > 10  # the root turns about y by 0.5 rad per cycle
    rep = repeat_motion(out, 3)
    assert rep.n_frames == 3 * (m.n_frames - 1) + 1
    rot, _ = cycle_transform(out)
    np.testing.assert_allclose(rot @ [0, 1, 0], [0, 1, 0], atol=1e-12)  # about the up axis
    np.testing.assert_allclose(rep.root_translation[m.n_frames - 1], out.root_translation[-1], atol=1e-9)
    np.testing.assert_allclose(rep.rotations[m.n_frames - 1, 0], out.rotations[-1, 0], atol=1e-9)
    assert foot_joints(m) == [3]


def test_bad_input_gives_clear_errors():
    m = synthetic()
    with pytest.raises(ValueError, match=r"expected at least 3 frames.*got 2"):
        loop_motion(
            m.replace(rotations=m.rotations[:2], root_translation=m.root_translation[:2]),
            window=None,
            force=True,
        )
    rot = m.rotations.copy()
    rot[7, 2, 0, 0] = np.nan
    with pytest.raises(ValueError, match=r"synthetic.rotations: expected finite values"):
        loop_motion(m.replace(rotations=rot), window=None, force=True)
    with pytest.raises(ValueError, match=r"foot.*cut locus"):
        loop_motion(synthetic(seam_pi=True), root="inplace", window=None, force=True)
    # leaving the joint free is the documented way out; its samples are kept
    res = loop_motion(synthetic(seam_pi=True), root="inplace", free_joints=["foot"], window=None, force=True)
    assert res.free_joints == ("foot",) and np.isfinite(res.motion.rotations).all()
    with pytest.raises(ValueError, match="root"):
        loop_motion(m, root="floating", window=None, force=True)
    with pytest.raises(ValueError, match="method"):
        loop_motion(m, method="quaternion", window=None, force=True)
    with pytest.raises(ValueError, match="free_joints"):
        loop_motion(m, free_joints=["nose"], window=None, force=True)
    with pytest.raises(ValueError, match="original"):
        seam_metrics(m, original=synthetic(f=30))


def test_repeat_is_bounded_before_allocation():
    """loop --repeat 100000 asked for 10 GB; repeat_motion checks the result's size first."""
    from elastic_motion import limits

    m = synthetic()
    with limits.override(max_frames=10 * (m.n_frames - 1) + 1):
        assert repeat_motion(m, 10).n_frames == 10 * (m.n_frames - 1) + 1
        with pytest.raises(ValueError, match=r"^cycles: expected a repeated clip of frames at most"):
            repeat_motion(m, 11)


def test_the_closing_reports_its_iterations(tmp_path, monkeypatch):
    """``progress("closing", k, 0)`` after each KKT iteration, from the API and the command
    line (whose bar is the callback)."""
    calls = []
    res = loop_motion(
        synthetic(), progress=lambda *a: calls.append(a), contacts="off", seam="c0", window=None, force=True
    )
    assert res.closing.iterations >= 1
    assert calls == [("closing", k, 0) for k in range(1, res.closing.iterations + 1)]

    from elastic_motion.cli import main
    from elastic_motion.cli_commands import loop as loop_cli
    from elastic_motion.motion import write_bvh

    class Spy:
        def __init__(self):
            self.calls = []

        def __call__(self, *a):
            self.calls.append(a)

        def close(self):
            self.calls.append("closed")

    spy = Spy()
    monkeypatch.setattr(loop_cli, "progress_for", lambda command, args: spy)
    clip = write_bvh(synthetic(), tmp_path / "clip.bvh")
    argv = ["loop", str(clip), "-o", str(tmp_path / "out.bvh"), "--contacts", "off", "--window", "whole"]
    assert main([*argv, "--force", "-q"]) == 0
    assert spy.calls[0] == ("closing", 1, 0) and spy.calls[-1] == "closed"


@pytest.mark.mocap
def test_a_whole_clip_that_whips_a_limb_says_where_and_what_to_do(mocap_dir):
    """The Bandai tired walk ends 61 deg from the pose it starts in: closed whole, its right
    toe, lifting off in the last frames, whips at 9.3 m/s (the input's fastest point 3.8):
    a note names it and the auto window; the auto window's loop has no such note."""
    path = mocap_dir / "bandai" / "dataset-1_walk_tired_001.bvh"
    whole = loop_motion(path, seam="c0", window=None, force=True)
    (note,) = of_kind(whole.notes, loop_notes.WHIP)
    assert note.data["point"] == "Toes_R" and note.data["speed_m_s"] == pytest.approx(9.31, abs=0.005)
    text = str(note)
    assert text.startswith("fast point: Toes_R moves 9.31 m/s at frames 245-246 of the loop, 2.5x")
    assert "--window auto" in text and "ends 61 deg and 0.56 m from the pose it starts in" in text
    auto = loop_motion(path, window="auto", seam="c0", force=True)
    assert not of_kind(auto.notes, loop_notes.WHIP)


# ----------------------------------------------------------------- options, records, notes


@pytest.mark.parametrize(
    ("field", "value", "match"),
    [
        ("root", "floating", r"^root: expected 'travel' or 'inplace'"),
        ("seam", True, r"^seam: expected one of \['auto', 'c0', 'c1'\]"),
        ("method", "quaternion", r"^method: expected one of \['lie', 'euler-elastic'\]"),
        ("solver", "newton", r"^solver: expected one of \['kkt', 'gauss-newton', 'gradient'\]"),
        ("tol", -1.0, r"^tol: expected a non-negative number"),
        ("max_iter", 2.5, r"^max_iter: expected a non-negative integer"),
        ("candidates", 0, r"^candidates: expected a positive integer"),
        ("contacts", "plant", r"^contacts: expected one of \['keep', 'report', 'off'\]"),
        ("contact_step", float("nan"), r"^contact_step: expected a non-negative number of seconds"),
        (
            "joint_limits",
            "sometimes",
            r"^joint_limits: expected one of \['keep', 'report', 'off'\], a JointL",
        ),
        ("limit_tol", -0.5, r"^limit_tol: expected a non-negative number of degrees"),
        ("window", "best", r"^window: expected 'safe', 'auto', None or \(start, stop\) frames; got 'best'"),
        ("free_joints", "toes", r"^free_joints: expected 'fingers', None or a list of joint names"),
        ("translation_weight", 0.0, r"^translation_weight: expected a positive number or None"),
        ("change_bound", 0.0, r"^change_bound: expected a positive number of metres"),
        ("force", "yes", r"^force: expected True or False"),
        ("prepare", {"drop_tpose": False}, r"^prepare: expected PrepareOptions or None; got dict"),
    ],
)
def test_loop_options_name_the_bad_option(field, value, match):
    from elastic_motion.apps.loop import LoopOptions

    with pytest.raises(OptionError, match=match):
        LoopOptions(**{field: value})
    with pytest.raises(OptionError, match=r"^min_length: expected only with window='auto'.*the whole clip"):
        LoopOptions(min_length=0.5, window=None)
    with pytest.raises(OptionError, match=match):  # the same check through an override
        loop_motion(synthetic(), **{"force": True, field: value})


def test_loop_options_normalise_and_cross_check():
    from elastic_motion.apps.loop import LoopOptions

    o = LoopOptions(method="euler", window="whole", free_joints=["foot"], joint_weights=np.ones(4))
    assert o.method == "euler-elastic" and o.window is None and o.free_joints == ("foot",)
    assert o.joint_weights == (1.0, 1.0, 1.0, 1.0) and o.contact_mode == "report"
    assert LoopOptions().contact_mode == "keep" and LoopOptions(contacts="none").contacts == "off"
    assert LoopOptions(window=[2, 30]).window == (2, 30)
    with pytest.raises(OptionError, match=r"^contacts: 'keep' needs method='lie' and solver='kkt'"):
        LoopOptions(contacts="keep", solver="gradient")
    # the default contacts follow the solver (an override of the solver alone is fine)
    assert LoopOptions().replace(solver="gradient").contact_mode == "report"


def test_overrides_are_the_options_object():
    """``loop_motion(m, **fields)`` is ``loop_motion(m, LoopOptions(**fields))``: the same loop,
    the same report; overrides change an options object given too; unknown keywords (the old
    ``c1=``) are refused, naming them."""
    from elastic_motion.apps.loop import LoopOptions

    m = synthetic()
    fields = dict(root="inplace", seam="c1", contacts="off", tol=1e-8)
    a = loop_motion(m, **fields, force=True)
    b = loop_motion(m, LoopOptions(**fields), force=True)
    c = loop_motion(
        m, LoopOptions(root="inplace", seam="c0"), seam="c1", contacts="off", tol=1e-8, force=True
    )
    for other in (b, c):
        np.testing.assert_array_equal(other.motion.rotations, a.motion.rotations)
        np.testing.assert_array_equal(other.motion.root_translation, a.motion.root_translation)
        sa, so = a.summary(), other.summary()
        sa["closing"].pop("time_s"), so["closing"].pop("time_s")
        assert so == sa
    assert a.c1 and a.seam == "c1" and a.summary()["c1"] is True and a.root == "inplace"
    with pytest.raises(OptionError, match=r"^rot: unknown option \['rot'\] of LoopOptions"):
        loop_motion(m, rot="inplace", window=None, force=True)
    with pytest.raises(OptionError, match=r"^options: expected a LoopOptions; got dict"):
        loop_motion(m, {"root": "inplace"}, force=True)


def test_kept_contacts_summary_is_the_report_dict_and_round_trips():
    """``KeptContacts.summary()`` is the report's ``contacts_kept``: the same keys in the same
    order, the optional ones only when set; ``from_summary`` gives the record back."""
    from elastic_motion.apps.loop import KeptContacts

    gave = {"joint": "LeftFoot", "frames": [3, 9], "largest_miss_m": 0.002}
    kept = KeptContacts(
        rows=12, grid_frames=40, grid_fps=30.0, converged=True, polished=None,
        released=({**gave, "why": "missed most when the projection with it failed"},),
        lifted_early=({"joint": "RightToe", "frames": [35, 40]},),
        floor_pins=({"joint": "Head", "frame": 7},),
        gave_way=(gave,), planted_by_ik={"skating_before_m_s": 0.1, "skating_after_m_s": 0.05,
                                         "max_position_change_m": 0.01},
        lifted_max_m=0.0, treadmill={"travel_m": 2.9, "turn_deg": 1.0},
    )  # fmt: skip
    s = kept.summary()
    assert list(s) == [
        "rows", "grid_frames", "grid_fps", "converged", "polished", "released", "lifted_early",
        "floor_pins", "gave_way", "planted_by_ik", "lifted_max_m", "treadmill",
    ]  # fmt: skip
    assert s["gave_way"] == [gave] and s["polished"] is None
    assert KeptContacts.from_summary(s) == kept
    dropped = KeptContacts(rows=3, grid_frames=10, grid_fps=30.0, converged=False, dropped="contacts dropped")
    d = dropped.summary()
    assert list(d)[-1] == "dropped" and "lifted_max_m" not in d and "treadmill" not in d
    assert KeptContacts.from_summary(d) == dropped


def test_the_seam_stage_reads_the_notes_kinds_not_their_words():
    """``choose_seam``: the C1 loop is refused when it whips a limb the C0 loop did not, by
    the notes' kind ``loop.whip`` whatever their text; the C0 loop kept loses its hitch note
    (kind ``loop.hitch``) for the note that says why, other notes kept whatever their words."""
    import dataclasses

    from elastic_motion.apps.loop.seam_choice import choose_seam
    from elastic_motion.notes import Note

    c0 = loop_motion(synthetic(), seam="c0", contacts="off", window=None, force=True)
    assert c0.seam_after.seam_velocity_jump_ratio > 0
    smoother = dataclasses.replace(
        c0.seam_after, seam_velocity_jump_ratio=c0.seam_after.seam_velocity_jump_ratio / 2
    )
    hitch = Note(loop_notes.HITCH, "the hitch, in any words")
    lookalike = Note("loop.other", "a hitch at the seam (not a hitch note) fast point")
    c0 = dataclasses.replace(c0, notes=(*c0.notes, hitch, lookalike))
    c1 = dataclasses.replace(c0, seam="c1", seam_after=smoother, notes=(lookalike,))
    taken = choose_seam(c0, c1)
    assert taken.c1 and of_kind(taken.notes, SEAM_C1_TAKEN)  # a text starting "fast point" is no whip
    whip = Note(loop_notes.WHIP, "a wrist at 52 m/s", {"point": "wrist"})
    kept = choose_seam(c0, dataclasses.replace(c1, notes=(whip,)))
    assert not kept.c1
    (why,) = of_kind(kept.notes, SEAM_C0_KEPT)
    assert "it whips a limb (a wrist at 52 m/s)" in str(why)
    assert hitch not in kept.notes and lookalike in kept.notes
    # both whip: not a reason to refuse C1
    both = choose_seam(
        dataclasses.replace(c0, notes=(*c0.notes, whip)), dataclasses.replace(c1, notes=(whip,))
    )
    assert both.c1


def test_notes_are_notes_with_kinds_and_the_report_lists_their_texts():
    from elastic_motion.notes import Note

    m = synthetic().replace(metres_per_unit=0.01)  # prepared: "lengths from cm to metres"
    res = loop_motion(m, seam="c0", window=None, force=True)
    assert res.notes and all(isinstance(n, Note) for n in res.notes)
    assert of_kind(res.notes, UNITS_TO_METRES)
    assert res.summary()["notes"] == [str(n) for n in res.notes]
