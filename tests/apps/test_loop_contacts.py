"""Tests of the contacts kept by the loop (apps.loop.kept_contacts, contact_rows, contact_grid):
the grid a high-rate clip is closed on, the lift of the grid's correction to every frame, the
release of contacts that conflict with closure, and the real 120 fps clips where rows every
few frames skated."""

from __future__ import annotations

import numpy as np
import pytest
from test_loop_window import periodic

from elastic_motion.apps.loop import loop_motion
from elastic_motion.apps.loop import notes as loop_notes
from elastic_motion.apps.loop.contact_grid import ROW_BUDGET, contact_grid, grid_step, lift_correction
from elastic_motion.apps.loop.kept_contacts import LIFT_TIME, GridClip, solve_with_contacts
from elastic_motion.groups import SO3
from elastic_motion.motion import select_frames
from elastic_motion.notes import of_kind

SO3G = SO3()


def test_contact_grid_spacing_and_ends():
    g = contact_grid(575, 120.0, 1 / 30)
    assert g[0] == 0 and g[-1] == 574
    assert set(np.diff(g)) <= {3, 4, 5} and np.diff(g).mean() == pytest.approx(4.0, rel=0.02)
    np.testing.assert_array_equal(contact_grid(40, 30.0, 1 / 30), np.arange(40))  # at the grid rate
    np.testing.assert_array_equal(contact_grid(40, 120.0, 0.0), np.arange(40))  # 0: every frame
    assert contact_grid(2, 120.0, 1 / 30).tolist() == [0, 1]
    # a C1 seam's cells are the clip's own first and last frame steps
    c = contact_grid(575, 120.0, 1 / 30, seam_cells=True)
    assert c[:2].tolist() == [0, 1] and c[-2:].tolist() == [573, 574]
    assert set(c[1:-1]) - {1, 573} <= set(g)
    np.testing.assert_array_equal(contact_grid(40, 30.0, 1 / 30, seam_cells=True), np.arange(40))


def test_grid_step_keeps_the_rows_within_budget():
    from elastic_motion.motion.contacts import Contacts

    mask = np.zeros((600, 2), dtype=bool)
    mask[:300] = True  # 600 contact frames: 1800 rows on every frame
    c = Contacts(("l", "r"), np.array([1, 2]), mask, 0.0, np.zeros(2), 120.0, "y")
    assert grid_step(c, 1 / 30, budget=2000) == 0.0  # within budget: every frame
    assert grid_step(c, 1 / 30, budget=1000) == pytest.approx(2 / 120)  # 900 rows
    assert grid_step(c, 1 / 30, budget=100) == pytest.approx(1 / 30)  # never coarser than step
    assert grid_step(c, 0.0, budget=100) == 0.0


def test_lift_correction_is_exact_on_the_grid_and_geodesic_between():
    m = periodic(f=61, fps=120.0)
    grid = contact_grid(m.n_frames, m.fps, 1 / 30)
    before = select_frames(m, grid)
    rng = np.random.default_rng(0)
    # a correction: a smooth left rotation per joint and a root offset, known at every frame
    w = rng.normal(size=(4, 3)) * 0.3
    t = np.arange(m.n_frames) / (m.n_frames - 1)
    corr = SO3G.exp(np.sin(np.pi * t)[:, None, None] * w[None])
    off = np.outer(np.sin(np.pi * t), [0.1, 0.02, -0.05])
    after = before.replace(
        rotations=corr[grid] @ before.rotations, root_translation=before.root_translation + off[grid]
    )
    out = lift_correction(m, grid, before, after)
    np.testing.assert_array_equal(out.rotations[grid], after.rotations)
    np.testing.assert_array_equal(out.root_translation[grid], after.root_translation)
    # between grid frames: the geodesic of the corrections (independent: slerp by axis-angle)
    f = grid[3] + 1
    a = (f - grid[3]) / (grid[4] - grid[3])
    d0, d1 = corr[grid[3]], corr[grid[4]]
    expect = SO3G.exp(a * SO3G.log(d1 @ d0.transpose(0, 2, 1))) @ d0 @ m.rotations[f]
    np.testing.assert_allclose(out.rotations[f], expect, atol=1e-12)
    np.testing.assert_allclose(
        out.root_translation[f], m.root_translation[f] + (1 - a) * off[grid[3]] + a * off[grid[4]], atol=1e-12
    )
    # a smooth correction is followed closely at every frame
    np.testing.assert_allclose(out.rotations, corr @ m.rotations, atol=5e-3)
    # the full grid: the result itself
    assert lift_correction(m, np.arange(m.n_frames), m, m) is m


@pytest.mark.mocap
def test_kept_contacts_of_a_120fps_clip_do_not_skate(mocap_dir):
    """CMU 07_01 (120 fps): closed on a 30 fps grid with every grid frame of a contact kept,
    the loop skates about as the input (rows every 4th frame of the clip itself skated)."""
    path = mocap_dir / "cmu/bvh/07_01.bvh"
    plain = loop_motion(path, contacts="report", seam="c0", window=None, force=True)
    kept = loop_motion(path, contacts="keep", seam="c0", window=None, force=True)
    info = kept.contacts_kept
    # 1368 rows on every frame: above the budget, so a 60 fps grid (every 2nd frame)
    assert kept.closing.converged and info.grid_fps == pytest.approx(60.0, rel=0.01)
    assert info.rows <= ROW_BUDGET
    assert info.released == () and info.gave_way == ()
    assert kept.seam_after.seam_angle_max_deg < 1e-3
    before = kept.skating_before.mean_speed
    assert plain.skating_after.mean_speed > 2.0 * before
    assert kept.skating_after.mean_speed < 1.1 * before
    # no knee flicker at the grid's rate: between grid frames a straight stance leg took up
    # the interpolated correction's millimetre of drift by bending its knee by degrees, on
    # grid frames not: the leg joints' offset from the input zigzagged from frame to frame
    # (95th percentile of its second difference 2.75 deg, 127 values over 1 deg; the IK now
    # runs smoothed over the grid's spacing, then exactly: 0.29 deg, 28)
    # the floor rises 4 cm under 07_01; a loop is periodic, so its contacts are found from one
    # floor height (held above the rising one, the loop gave way and went 3.8 cm under it)
    assert kept.contacts.floor_offset is None
    sk = kept.motion.skeleton
    legs = [sk.index(n) for n in ("LeftUpLeg", "LeftLeg", "RightUpLeg", "RightLeg")]
    rel = np.swapaxes(kept.original.rotations[:, legs], -1, -2) @ kept.motion.rotations[:, legs]
    zigzag = np.abs(np.diff(np.degrees(np.linalg.norm(SO3().log(rel), axis=-1)), 2, axis=0))
    assert np.percentile(zigzag, 95) < 1.0 and (zigzag > 1.0).sum() < 60


@pytest.mark.mocap
def test_a_c1_loop_keeps_its_contacts_on_a_coarse_grid(mocap_dir):
    """CMU 07_01 (120 fps), C1: closed on the contacts' grid like C0 (on every frame a long
    clip needs too many rows: CMU 01_01 18915, refused), the grid's first and last steps are
    the clip's own, so the clip's seam velocities match exactly."""
    res = loop_motion(mocap_dir / "cmu/bvh/07_01.bvh", seam="c1", window=None, force=True)
    info = res.contacts_kept
    assert res.closing.converged and info.grid_frames < res.motion.n_frames // 1.5
    assert res.seam_after.seam_angle_max_deg < 1e-3
    # C0 leaves a velocity jump of hundreds of deg/s at the seam
    assert res.seam_before.seam_angular_velocity_max_deg_s > 100.0
    assert res.seam_after.seam_angular_velocity_max_deg_s < 1e-3
    assert res.skating_after.mean_speed < 1.1 * res.skating_before.mean_speed


@pytest.mark.mocap
def test_a_contact_planted_at_the_end_but_not_the_start_lifts_early_without_sliding(mocap_dir):
    """CMU 09_11, whole clip: it ends on the right foot where it started in the air. Closing
    puts the first pose (foot in the air) on the last frame, so that contact is kept in the
    floor plane only over its last 0.15 s: the foot rises there without sliding (it was
    released before, and slid 1.1x the input's skating)."""
    path = mocap_dir / "cmu/bvh/09_11.bvh"
    plain = loop_motion(path, contacts="report", window=None, force=True)
    kept = loop_motion(path, contacts="keep", window=None, force=True)
    info = kept.contacts_kept
    assert kept.closing.converged and info.dropped is None and info.released == ()
    n = kept.motion.n_frames
    lifted = {g["joint"]: g["frames"] for g in info.lifted_early}
    assert set(lifted) == {"RightFoot", "RightToeBase"}
    assert all(b == n and n - a <= round(LIFT_TIME * 120) for a, b in lifted.values())
    lifted_notes = of_kind(kept.notes, loop_notes.LIFTED_EARLY)
    assert {n.data["joint"] for n in lifted_notes} == {"RightFoot", "RightToeBase"}
    assert any("lifted early" in str(note) and "RightFoot" in str(note) for note in lifted_notes)
    assert kept.seam_after.seam_angle_max_deg < 1e-3
    sk_in, sk_out = kept.skating_before.per_joint, kept.skating_after.per_joint
    for joint in ("LeftFoot", "RightFoot", "RightToeBase"):
        assert sk_out[joint] <= 1.05 * sk_in[joint]
    assert kept.skating_after.mean_speed <= 1.1 * kept.skating_before.mean_speed
    assert plain.skating_after.per_joint["LeftFoot"] > 2 * sk_out["LeftFoot"]


@pytest.mark.mocap
def test_feet_stay_planted_between_the_grid_frames_of_a_whole_cartwheel_clip(mocap_dir):
    """CMU 49_08 (120 fps) whole: closed on a 30 fps grid with a change of decimetres, the
    interpolated correction let planted feet drift between grid frames (skating 1.38x the
    input's); leg IK plants them on every frame, the seam untouched."""
    res = loop_motion(mocap_dir / "cmu/bvh/49_08.bvh", contacts="keep", window=None, force=True)
    info = res.contacts_kept
    assert info.grid_fps == pytest.approx(30.0, rel=0.02) and info.released == ()
    ik = info.planted_by_ik
    assert ik["skating_after_m_s"] < 0.9 * ik["skating_before_m_s"]
    assert res.skating_after.mean_speed <= 1.1 * res.skating_before.mean_speed
    # the feet by leg IK, the hands of the cartwheels by arm IK
    for joint in ("LeftFoot", "LeftToeBase", "RightFoot", "RightToeBase", "LeftHand", "RightHand"):
        assert res.skating_after.per_joint[joint] <= 1.05 * res.skating_before.per_joint[joint]
    assert res.seam_after.seam_angle_max_deg < 1e-3 and res.seam_after.seam_position_max_m < 1e-6
    assert res.skating_after.below_floor <= 0.01


def test_lifted_contacts_keep_the_floor_plane_and_drop_the_height_rows():
    from elastic_motion.apps.loop.contact_rows import contact_rows
    from elastic_motion.motion.contacts import Contacts

    m = periodic(f=50)
    mask = np.zeros((50, 1), dtype=bool)
    mask[40:] = True  # planted at the end, in the air at the start
    c = Contacts(("foot",), np.array([3]), mask, 0.0, np.zeros(1), m.fps, "y")
    full = contact_rows(m, c)
    lifted = contact_rows(m, c, lift_from={"foot": 45})
    up = 1
    assert {r.frame for r in full if r.axis == up} == set(range(40, 49))
    assert {r.frame for r in lifted if r.axis == up} == set(range(40, 45))
    horiz = [(r.frame, r.axis, r.anchor, r.target) for r in lifted if r.axis != up]
    assert horiz == [(r.frame, r.axis, r.anchor, r.target) for r in full if r.axis != up]
    assert {a for _, _, a, _ in horiz} == {49}


def test_contacts_are_lifted_first_and_the_worst_missed_released_after_a_failed_solve():
    """The release policy of apps.loop.kept_contacts.solve_with_contacts, with a stand-in solver: the
    contact at the seam is lifted from the start; a failed solve releases the contact it
    missed most (and only that); the next solve converges."""
    from types import SimpleNamespace

    from elastic_motion.motion.contacts import Contacts

    m = periodic(f=50)
    mask = np.zeros((50, 2), dtype=bool)
    mask[40:, 0] = True  # the foot: planted at the end, not at the start
    mask[10:20, 1] = True  # the knee: an interior contact
    c = Contacts(("foot", "knee"), np.array([3, 2]), mask, 0.0, np.zeros(2), m.fps, "y")
    flat = np.concatenate([m.root_translation, m.rotations.reshape(50, -1)], axis=1)
    missed = m.rotations.copy()
    missed[15, 1] = SO3G.exp(np.array([0.0, 0.0, 0.2])) @ missed[15, 1]  # the knee misses ~15 cm
    calls = []

    def solve(lie, extra):
        calls.append(extra)
        if len(calls) == 1:
            vals = np.concatenate([m.root_translation, missed.reshape(50, -1)], axis=1)
            return SimpleNamespace(converged=False, curve=SimpleNamespace(values=vals))
        return SimpleNamespace(converged=True, curve=SimpleNamespace(values=flat))

    solved = solve_with_contacts(GridClip(m, None, np.arange(50)), c, solve, max_release=8)
    res, extra, released, lifting = solved.result, solved.constraints, solved.released, list(solved.lifting)
    assert res.converged and len(calls) == 2
    lift_n = round(LIFT_TIME * m.fps)
    assert lifting == [{"joint": "foot", "frames": [50 - lift_n, 50]}]
    assert max(r.frame for r in calls[0].rows if r.name == "foot" and r.axis == 1) == 50 - lift_n - 1
    assert [(g["joint"], g["frames"]) for g in released] == [("knee", [10, 20])]
    assert "missed most" in released[0]["why"] and released[0]["largest_miss_m"] > 0.05
    assert {r.name for r in extra.rows} == {"foot"}


def test_the_lift_window_is_measured_in_the_clips_time_on_a_coarse_grid():
    """On grid frames (``select_frames`` keeps the clip's fps) the last LIFT_TIME of the clip
    is lifted, not LIFT_TIME worth of grid frames (4 times longer on every 4th frame)."""
    from types import SimpleNamespace

    from elastic_motion.motion.contacts import Contacts

    fine = periodic(f=121, fps=120.0)
    grid = contact_grid(fine.n_frames, fine.fps, 1 / 30)
    m = select_frames(fine, grid)
    mask = np.zeros((len(grid), 1), dtype=bool)
    mask[len(grid) // 2 :, 0] = True  # planted over the second half, not at the start
    c = Contacts(("foot",), np.array([3]), mask, 0.0, np.zeros(1), fine.fps, "y")
    flat = np.concatenate([m.root_translation, m.rotations.reshape(len(grid), -1)], axis=1)

    def solve(lie, extra):
        return SimpleNamespace(converged=True, curve=SimpleNamespace(values=flat))

    lifting = solve_with_contacts(GridClip(m, None, grid), c, solve, max_release=0).lifting
    start = grid[lifting[0]["frames"][0]]
    assert start == grid[np.searchsorted(grid, 121 - round(LIFT_TIME * 120))]
    assert 0 < (120 - start) / 120 <= LIFT_TIME + 1 / 30


def test_row_plants_are_the_rows_targets_and_released_contacts_are_dropped_whole():
    from elastic_motion.apps.loop.contact_grid import fine_contacts
    from elastic_motion.apps.loop.contact_rows import row_plants
    from elastic_motion.motion import forward_kinematics
    from elastic_motion.motion.contacts import Contacts

    m = periodic(f=60)
    mask = np.zeros((60, 2), dtype=bool)
    mask[5:20, 0] = True
    mask[45:, 0] = True
    mask[30:40, 1] = True
    c = Contacts(("foot", "knee"), np.array([3, 2]), mask, 0.0, np.zeros(2), m.fps, "y")
    p = forward_kinematics(m)
    # the input meets its own rows: its plants are where its joints are
    plants = row_plants(m, c, m)
    np.testing.assert_allclose(plants["foot"][5:20], p[5:20, 3], atol=1e-12)
    np.testing.assert_allclose(plants["knee"][30:40], p[30:40, 2], atol=1e-12)
    assert np.isnan(plants["foot"][25]).all() and np.isnan(plants["foot"][59]).all()  # the seam frame
    # a seam contact's floor-plane plant follows the loop's last frame
    moved = m.replace(root_translation=m.root_translation + np.array([0.3, 0.0, 0.0]))
    shifted = row_plants(m, c, moved)
    np.testing.assert_allclose(shifted["foot"][45:59, 0], p[45:59, 3, 0] + 0.3, atol=1e-12)
    np.testing.assert_allclose(shifted["foot"][45:59, 1], p[45:59, 3, 1], atol=1e-12)  # height absolute
    np.testing.assert_allclose(shifted["foot"][5:20], p[5:20, 3], atol=1e-12)
    # in the motion's own unit (rows are in metres): the same clip in centimetres
    from elastic_motion.motion.edit import to_metres

    cm = to_metres(m.replace(metres_per_unit=100.0)).replace(metres_per_unit=0.01)
    in_cm = row_plants(cm, c, cm.replace(root_translation=cm.root_translation + np.array([30.0, 0.0, 0.0])))
    np.testing.assert_allclose(in_cm["foot"][45:59, 0], 100 * (p[45:59, 3, 0] + 0.3), atol=1e-9)
    np.testing.assert_allclose(in_cm["foot"][5:20], 100 * p[5:20, 3], atol=1e-9)
    # released on a grid: every contact of the clip overlapping the released grid frames goes
    grid = np.arange(0, 60, 3)
    kept = fine_contacts(c, grid, [{"joint": "foot", "frames": [2, 4]}])  # grid frames 6..9
    assert not kept.mask[:, 0][5:20].any() and kept.mask[45:, 0].all()
    np.testing.assert_array_equal(kept.mask[:, 1], c.mask[:, 1])


@pytest.mark.mocap
def test_kept_feet_do_not_push_the_body_into_the_floor(mocap_dir):
    """CMU backflip (ASF/AMC): with the feet kept, closing moved the flight frames and put a
    foot 11 cm under the floor (the body was raised there by 12 cm, a hop). The points the
    loop takes under the floor are pinned at their deepest frames and the projection solved
    again: nothing goes under, and no body is raised."""
    res = loop_motion(mocap_dir / "cmu/asfamc/backflip.amc", window=None, force=True)
    info = res.contacts_kept
    assert info.floor_pins and all(0 < p["frame"] < res.motion.n_frames - 1 for p in info.floor_pins)
    assert info.lifted_max_m < 0.01
    assert res.skating_after.below_floor <= 0.01
    assert res.skating_after.mean_speed <= 1.1 * res.skating_before.mean_speed
    assert res.seam_after.seam_angle_max_deg < 1e-3 and res.seam_after.seam_position_max_m < 1e-9


def test_the_floor_per_frame_is_in_metres_whatever_the_clips_unit():
    """``floor_per_frame`` (metres): the floor, or the input's own lowest point there when
    lower, at most FLOOR_TOLERANCE under the floor; the same clip in centimetres gives the same
    metres (a unit factor applied twice, or not at all, would not)."""
    from elastic_motion.apps.loop.planting import FLOOR_TOLERANCE, floor_per_frame
    from elastic_motion.motion import forward_kinematics
    from elastic_motion.motion.contacts import Contacts
    from elastic_motion.motion.edit import to_metres

    m = periodic(f=60)
    lowest = forward_kinematics(m, end_sites=True)[..., 1].min(axis=1)
    floor = float(np.median(lowest)) + 0.005  # under the floor on some frames, deeper on others
    c = Contacts(("foot",), np.array([3]), np.zeros((60, 1), dtype=bool), floor, np.zeros(1), m.fps, "y")
    want = np.minimum(floor, np.maximum(lowest, floor - FLOOR_TOLERANCE))
    assert (want < floor).any() and (want == floor).any()
    np.testing.assert_allclose(floor_per_frame(m, c), want, atol=1e-12)
    cm = to_metres(m.replace(metres_per_unit=100.0)).replace(metres_per_unit=0.01)
    np.testing.assert_allclose(floor_per_frame(cm, c), want, atol=1e-9)


def test_floor_rows_pin_the_deepest_frame_of_each_dip_at_the_inputs_height():
    from elastic_motion.apps.loop.contact_rows import Row, floor_rows

    m = periodic(f=60)
    root = m.root_translation.copy()
    root[20:27, 1] -= np.array([0.1, 0.3, 0.5, 0.7, 0.6, 0.4, 0.2])  # the body dips, deepest at 23
    root[[0, 59], 1] -= 1.0  # the seam frames are never pinned
    closed = m.replace(root_translation=root)
    from elastic_motion.motion import forward_kinematics

    h_in = forward_kinematics(m, end_sites=True)[..., 1]
    h_out = forward_kinematics(closed, end_sites=True)[..., 1]
    floor = np.full(60, h_in.min() - 0.01)
    rows = floor_rows(m, closed, floor, [])
    under = {j for j in range(h_out.shape[1]) if (h_out[1:59, j] < floor[1:59] - 0.005).any()}
    assert {r.joint for r in rows} == under and under  # one row per point that dips (one run each)
    for r in rows:
        assert r.axis == 1 and r.anchor == -1 and r.frame == 20 + int(np.argmin(h_out[20:27, r.joint]))
        assert r.target == pytest.approx(h_in[r.frame, r.joint])
    assert any(r.joint == 4 and r.name == "foot end site above the floor" for r in rows)  # end sites too
    # a frame whose height a row already holds is not pinned again (the rest of its dip is:
    # the next round of the active set)
    held = [Row(r.joint, "x", (r.frame, r.frame + 1), r.frame, 1, -1, 0.0) for r in rows]
    again = floor_rows(m, closed, floor, held)
    assert again and not {(r.joint, r.frame) for r in again} & {(r.joint, r.frame) for r in held}


@pytest.mark.mocap
def test_the_hands_of_a_deepmimic_cartwheel_are_contacts_and_stay_planted(mocap_dir):
    """DeepMimic's wrists are fixed joints of the skeleton: the hands on the floor are
    contacts, kept by the loop (arm IK between rows), and no longer pushed under the floor
    (with the feet alone kept an elbow's end site went 12 cm under)."""
    res = loop_motion(mocap_dir / "deepmimic/humanoid3d_cartwheel.txt", seam="c0", window=None, force=True)
    found = res.contacts.all_intervals()
    assert found["right_wrist"] and found["left_wrist"]
    before, after = res.skating_before.per_joint, res.skating_after.per_joint
    for joint in ("right_wrist", "left_wrist", "right_ankle", "left_ankle"):
        assert after[joint] <= 1.05 * before[joint]
    assert res.contacts_kept.released == () and res.contacts_kept.lifted_max_m < 0.03
    assert res.skating_after.below_floor <= 0.01
    assert res.seam_after.seam_angle_max_deg < 1e-3


@pytest.mark.mocap
def test_contacts_that_nearly_hold_are_closed_exactly_from_there(mocap_dir):
    """CMU 49_08 (cartwheels), frames 231-569: the constrained projection stalls with every
    contact within a few mm; the loop is closed exactly from there instead of releasing or
    dropping contacts."""
    path = mocap_dir / "cmu/bvh/49_08.bvh"
    res = loop_motion(path, window=(231, 569), seam="c0", force=True)
    info = res.contacts_kept
    assert info.polished is not None and "mm" in info.polished
    assert info.released == () and info.dropped is None
    assert all(g["largest_miss_m"] <= 0.01 for g in info.gave_way)  # within a centimetre
    assert res.closing.converged and res.seam_after.seam_angle_max_deg < 1e-3
    (polished,) = of_kind(res.notes, loop_notes.POLISHED)
    assert "closed exactly from there" in str(polished)
    assert not of_kind(res.notes, loop_notes.SKATING_WARNING)
    # the change is measured from the input (not from where the solver stopped)
    plain = loop_motion(path, window=(231, 569), contacts="report", seam="c0", force=True)
    assert res.closing.change > plain.closing.change


@pytest.mark.mocap
def test_contacts_lost_by_the_exact_closing_are_released_not_all_dropped(mocap_dir):
    """CMU 131_03 ("start, hop, stop"), its last 2.2 s: the constrained projection stalls with
    the contacts within 8 mm, but closing exactly from there misses them by 24 mm (the final
    stance cannot stay planted on a seam 127 degrees away). Every contact was dropped and the
    loop skated 0.35 m/s against the input's 0.13; the worst are released instead and the rest
    kept."""
    res = loop_motion(mocap_dir / "cmu/bvh/131_03.bvh", window=(840, 1102), force=True)
    info = res.contacts_kept
    assert info.dropped is None and res.closing.converged
    assert 1 <= len(info.released) <= 6
    assert all(r["why"].startswith("missed most") for r in info.released)
    assert res.skating_after.mean_speed < 2.0 * res.skating_before.mean_speed
    assert res.seam_after.seam_angle_max_deg < 1e-3
    released = of_kind(res.notes, loop_notes.RELEASED)
    assert len(released) == len(info.released) and str(released[0]).startswith("contact released")
    # it still skates 1.7x the input (the released final stance slides to the seam): said
    warn = [str(n) for n in of_kind(res.notes, loop_notes.SKATING_WARNING)]
    assert len(warn) == 1 and warn[0].startswith("warning: the loop skates")
    assert "contacts released to close it" in warn[0] and "window='auto'" not in warn[0]
    plain = loop_motion(mocap_dir / "cmu/bvh/131_03.bvh", window=(840, 1102), contacts="report", force=True)
    warn = [str(n) for n in of_kind(plain.notes, loop_notes.SKATING_WARNING)]
    assert len(warn) == 1 and "contacts not kept (contacts='report'" in warn[0]


def test_a_heel_lifting_at_the_start_leaves_its_last_contact_to_the_toe():
    """A foot whose toe crosses the seam while its heel is planted on the last frame but not
    on the first: the heel's last contact gets no rows (rows on both fought over the rigid
    foot and stalled the solver); the toe's are relative to the last frame, its heights too
    (held absolutely they dropped a toe 2.1 cm in a CMU loop's last step)."""
    from elastic_motion.apps.loop.contact_rows import contact_rows
    from elastic_motion.motion.contacts import Contacts

    m = periodic(f=50)
    mask = np.zeros((50, 2), dtype=bool)
    mask[40:, :] = True  # the "knee" (heel) and the "foot" (toe), one body, planted at the end
    mask[:5, 1] = True  # only the toe planted at the start
    mask[10:20, 0] = True  # an interior heel contact keeps its rows

    def rows_of(mask):
        return contact_rows(
            m, Contacts(("knee", "foot"), np.array([2, 3]), mask, 0.0, np.zeros(2), m.fps, "y")
        )

    rows = rows_of(mask)
    heel = [r for r in rows if r.name == "knee"]
    assert heel and all(r.frame < 20 for r in heel)
    assert {r.anchor for r in rows if r.name == "foot" and r.frame >= 40} == {49}
    mask[:5, 0] = True  # the heel planted at the start too: both cross the seam
    heel = [r for r in rows_of(mask) if r.name == "knee"]
    assert {r.anchor for r in heel if r.frame >= 40} == {49}
    assert {r.axis for r in heel if r.frame >= 40} == {0, 1, 2}  # heights relative too
    # each relative row's target is the input's offset from the last frame (a sign slip fails)
    from elastic_motion.motion import forward_kinematics

    pos = forward_kinematics(m)
    for r in (r for r in heel if r.frame >= 40):
        assert r.target == pytest.approx(pos[r.frame, 2, r.axis] - pos[-1, 2, r.axis], abs=1e-12)
    # a contact on the last frame of a joint in the air on the first keeps absolute heights
    mask[:5, :] = False
    mask[40:, 0] = False
    assert {r.anchor for r in rows_of(mask) if r.name == "foot" and r.frame >= 40} == {-1, 49}


def test_a_heel_planted_with_its_toes_seam_contact_moves_with_the_toe():
    """A heel contact ending before the last frame while its toe's seam contact (relative to
    the last frame) has begun: its floor-plane rows are relative to the toe's last-frame
    position (the toe's own offsets and the heel's from the toe are the input's, so the foot
    moves as one piece), its heights absolute; a heel contact before the toe's is absolute."""
    from elastic_motion.apps.loop.contact_rows import contact_rows, row_plants
    from elastic_motion.motion import forward_kinematics
    from elastic_motion.motion.contacts import Contacts

    m = periodic(f=50)
    mask = np.zeros((50, 2), dtype=bool)
    mask[38:49, 0] = True  # the "knee" (heel): planted, lifted on the last frame
    mask[10:20, 0] = True  # an earlier heel contact
    mask[40:, 1] = True  # the "foot" (toe): planted to the last frame, in the air on the first
    c = Contacts(("knee", "foot"), np.array([2, 3]), mask, 0.0, np.zeros(2), m.fps, "y")
    rows = contact_rows(m, c)
    pos = forward_kinematics(m)
    heel = [r for r in rows if r.name == "knee" and r.frame >= 38]
    assert heel and {r.frame for r in heel} == set(range(38, 49))
    for r in heel:
        if r.axis == 1:  # height: absolute
            assert r.anchor == -1 and r.target == pytest.approx(pos[r.frame, 2, 1], abs=1e-12)
        else:  # floor plane: from the toe on the last frame (a wrong joint or sign fails)
            assert (r.anchor, r.anchor_joint) == (49, 3)
            assert r.target == pytest.approx(pos[r.frame, 2, r.axis] - pos[-1, 3, r.axis], abs=1e-12)
    assert all(r.anchor == -1 for r in rows if r.name == "knee" and r.frame < 20)
    # the plants: the whole foot follows the loop's last frame in the floor plane
    moved = m.replace(root_translation=m.root_translation + np.array([0.3, 0.0, 0.1]))
    plants = row_plants(m, c, moved)
    np.testing.assert_allclose(
        plants["knee"][38:49, [0, 2]], pos[38:49, 2][:, [0, 2]] + [0.3, 0.1], atol=1e-12
    )
    np.testing.assert_allclose(plants["knee"][38:49, 1], pos[38:49, 2, 1], atol=1e-12)
    np.testing.assert_allclose(
        plants["foot"][40:49, [0, 2]], pos[40:49, 3][:, [0, 2]] + [0.3, 0.1], atol=1e-12
    )
    # with a C1 seam the frame before the last has no rows (they would set the last step)
    assert all(r.frame < 48 for r in contact_rows(m, c, c1=True) if r.name == "knee")


@pytest.mark.mocap
def test_a_foot_whose_toe_lifts_at_the_seam_keeps_its_direction(mocap_dir):
    """Bandai normal walk, the auto window: the right toe is planted to the last frame and in
    the air on the first, its heel planted until the frame before. With the heel held where
    it was and the toe moved with the seam, the foot turned about the heel by 22 deg through
    the whole stance (and the solver stalled); moved as one piece, it turns by a few."""
    from scipy.spatial.transform import Rotation

    from elastic_motion.motion.kinematics import global_rotations

    res = loop_motion(mocap_dir / "bandai/dataset-1_walk_normal_001.bvh", window="auto", force=True)
    assert res.closing.converged and res.contacts_kept.gave_way == ()
    assert res.seam_after.seam_angle_max_deg < 1e-3
    j = res.motion.skeleton.index("Foot_R")
    a, b = res.contacts.intervals("Foot_R")[-1]
    g_loop, g_in = global_rotations(res.motion)[a:b, j], global_rotations(res.original)[a:b, j]
    turn = Rotation.from_matrix(g_loop) * Rotation.from_matrix(g_in).inv()
    assert np.degrees(np.linalg.norm(turn.as_rotvec(), axis=1)).max() < 8.0
    assert res.skating_after.mean_speed <= 1.1 * res.skating_before.mean_speed


@pytest.mark.mocap
def test_kept_contacts_are_bounded_and_checked(mocap_dir):
    from elastic_motion import limits
    from elastic_motion.errors import OptionError

    path = mocap_dir / "deepmimic/humanoid3d_run.txt"
    for bad in (-0.1, "0.1", float("nan")):
        with pytest.raises(OptionError, match="contact_step"):
            loop_motion(path, contact_step=bad, window=None, force=True)
    rows = loop_motion(path, contact_step=0.0, window=None, force=True).contacts_kept.rows
    assert rows > 6
    with (
        limits.override(max_constraint_rows=rows // 2),
        pytest.raises(OptionError, match="max_constraint_rows"),
    ):
        loop_motion(path, contact_step=0.0, window=None, force=True)


@pytest.mark.mocap
def test_a_contact_across_the_seam_does_not_pop_in_the_last_step(mocap_dir):
    """CMU 07_01, the window the loop picks: the right toe is planted across the seam, at
    4.5 cm on the first frame and 6.7 cm on the last. With its heights held absolutely the
    closing dropped it 2.1 cm in the last 1/120 s (2.6 m/s, the left toe 6.9 m/s against 4.3
    before); relative to the last frame, the last step is like the steps before it."""
    from elastic_motion.motion import forward_kinematics

    res = loop_motion(mocap_dir / "cmu" / "bvh" / "07_01.bvh", window="auto", force=True)
    m = res.motion
    p = forward_kinematics(m) * m.metres_per_unit
    for name, limit in (("RightToeBase", 0.3), ("LeftToeBase", 5.0)):
        k = m.skeleton.names.index(name)
        speed = np.linalg.norm(np.diff(p[-5:, k], axis=0), axis=1) * m.fps
        assert speed[-1] < limit and speed[-1] < 1.5 * speed[:-1].max(), (name, speed)


@pytest.mark.mocap
def test_a_polish_stalled_at_the_rounding_floor_keeps_the_contacts(mocap_dir):
    """The Bandai old walk: the constrained solve stalls with the contacts held within 0.0 mm,
    and the exact closing from there stops at the rounding floor of its optimality residual
    with the seam shut. That loop was thrown away ("contacts dropped ... gap 1.38e-07") and
    the clip closed without its contacts (skating 0.0924 -> 0.0946 m/s, 3.4 mm under the
    floor); it is kept."""
    res = loop_motion(mocap_dir / "bandai" / "dataset-1_walk_old_001.bvh", seam="c0", window=None, force=True)
    assert res.contacts_kept.dropped is None and res.contacts_kept.polished
    assert res.skating_after.mean_speed <= 1.01 * res.skating_before.mean_speed
    assert res.skating_after.below_floor <= res.skating_before.below_floor + 1e-4
    assert res.seam_after.seam_angle_max_deg < 1e-3
