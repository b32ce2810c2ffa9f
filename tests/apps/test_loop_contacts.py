"""Tests of the contacts kept by the loop (apps.loop_contacts): the grid a high-rate clip is
closed on, the lift of the grid's correction to every frame, the release of contacts that
conflict with closure, and the real 120 fps clips where rows every few frames skated."""

from __future__ import annotations

import numpy as np
import pytest
from test_loop_window import periodic

from elastic_motion.apps.loop import loop_motion
from elastic_motion.apps.loop_contacts import ROW_BUDGET, contact_grid, grid_step, lift_correction
from elastic_motion.groups import SO3
from elastic_motion.motion import select_frames

SO3G = SO3()


def test_contact_grid_spacing_and_ends():
    g = contact_grid(575, 120.0, 1 / 30)
    assert g[0] == 0 and g[-1] == 574
    assert set(np.diff(g)) <= {3, 4, 5} and np.diff(g).mean() == pytest.approx(4.0, rel=0.02)
    np.testing.assert_array_equal(contact_grid(40, 30.0, 1 / 30), np.arange(40))  # at the grid rate
    np.testing.assert_array_equal(contact_grid(40, 120.0, 0.0), np.arange(40))  # 0: every frame
    assert contact_grid(2, 120.0, 1 / 30).tolist() == [0, 1]


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
    plain = loop_motion(path, contacts="report")
    kept = loop_motion(path, contacts="keep")
    info = kept.contacts_kept
    # 1368 rows on every frame: above the budget, so a 60 fps grid (every 2nd frame)
    assert kept.closing.converged and info["grid_fps"] == pytest.approx(60.0, rel=0.01)
    assert info["rows"] <= ROW_BUDGET
    assert info["released"] == [] and info["gave_way"] == []
    assert kept.seam_after.seam_angle_max_deg < 1e-3
    before = kept.skating_before.mean_speed
    assert plain.skating_after.mean_speed > 2.0 * before
    assert kept.skating_after.mean_speed < 1.1 * before


@pytest.mark.mocap
def test_contacts_that_conflict_with_closure_are_released_and_named(mocap_dir):
    """CMU 09_11, whole clip: it ends on the right foot where it started in the air; that
    contact cannot hold in a closed loop, is released, the others are kept."""
    path = mocap_dir / "cmu/bvh/09_11.bvh"
    plain = loop_motion(path, contacts="report")
    kept = loop_motion(path, contacts="keep")
    info = kept.contacts_kept
    assert kept.closing.converged and "dropped" not in info
    released = {(r["joint"], r["frames"][1]) for r in info["released"]}
    assert released and all(stop == kept.motion.n_frames for _, stop in released)
    assert {j for j, _ in released} <= {"RightFoot", "RightToeBase"}
    assert any("contact released" in n and "RightFoot" in n for n in kept.notes)
    assert kept.seam_after.seam_angle_max_deg < 1e-3
    # the kept contacts hold: the left foot skates about as in the input (a large change of
    # this clip, 0.7 m, bends between the 30 fps grid frames), the plain loop twice as much
    sk_in, sk_out = kept.skating_before.per_joint, kept.skating_after.per_joint
    assert sk_out["LeftFoot"] <= 1.2 * sk_in["LeftFoot"]
    assert plain.skating_after.per_joint["LeftFoot"] > 2 * sk_out["LeftFoot"]


@pytest.mark.mocap
def test_kept_feet_do_not_push_the_hands_into_the_floor(mocap_dir):
    """DeepMimic cartwheel (no hand joints, so no hand contacts): with the feet kept, closing
    moves the hand-stand frames; the body is raised there so nothing goes 1 cm under the floor."""
    res = loop_motion(mocap_dir / "deepmimic/humanoid3d_cartwheel.txt")
    assert res.contacts_kept["lifted_max_m"] > 0.05  # the elbows' end sites went ~12 cm under
    assert res.skating_after.below_floor <= 0.01
    assert res.seam_after.seam_angle_max_deg < 1e-3 and res.seam_after.seam_position_max_m < 1e-9


@pytest.mark.mocap
def test_contacts_that_nearly_hold_are_closed_exactly_from_there(mocap_dir):
    """CMU 49_08 (cartwheels), frames 231-569: the constrained projection stalls with every
    contact within a few mm; the loop is closed exactly from there instead of releasing or
    dropping contacts."""
    path = mocap_dir / "cmu/bvh/49_08.bvh"
    res = loop_motion(path, window=(231, 569))
    info = res.contacts_kept
    assert info["polished"] is not None and "mm" in info["polished"]
    assert info["released"] == [] and "dropped" not in info
    assert all(g["largest_miss_m"] <= 0.01 for g in info["gave_way"])  # within a centimetre
    assert res.closing.converged and res.seam_after.seam_angle_max_deg < 1e-3
    assert any("closed exactly from there" in n for n in res.notes)
    # the change is measured from the input (not from where the solver stopped)
    plain = loop_motion(path, window=(231, 569), contacts="report")
    assert res.closing.change > plain.closing.change


def test_a_heel_lifting_at_the_start_leaves_its_last_contact_to_the_toe():
    """A foot whose toe crosses the seam while its heel is planted on the last frame but not
    on the first: the heel's last contact gets no rows (rows on both fought over the rigid
    foot and stalled the solver); the toe's are relative to the last frame."""
    from elastic_motion.apps.loop_contacts import contact_rows
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
    assert {r.anchor for r in rows if r.name == "foot" and r.frame >= 40} == {-1, 49}
    mask[:5, 0] = True  # the heel planted at the start too: both cross the seam
    heel = [r for r in rows_of(mask) if r.name == "knee"]
    assert {r.anchor for r in heel if r.frame >= 40} == {-1, 49}


@pytest.mark.mocap
def test_kept_contacts_are_bounded_and_checked(mocap_dir):
    from elastic_motion import limits
    from elastic_motion.errors import OptionError

    path = mocap_dir / "deepmimic/humanoid3d_run.txt"
    with pytest.raises(OptionError, match="contact_step"):
        loop_motion(path, contact_step=-0.1)
    rows = loop_motion(path, contact_step=0.0).contacts_kept["rows"]
    assert rows > 6
    with (
        limits.override(max_constraint_rows=rows // 2),
        pytest.raises(OptionError, match="max_constraint_rows"),
    ):
        loop_motion(path, contact_step=0.0)
