"""Tests of the best-cycle search (apps.loop.window_candidates + loop_motion(window=...)): the dissimilarity,
the period, the candidates, the chosen window on real cartwheels, the contacts report and the
bad inputs of issue 11."""

from __future__ import annotations

import json

import numpy as np
import pytest
from loop_testlib import chain_skeleton

from elastic_motion.apps.loop import loop_motion
from elastic_motion.apps.loop import notes as loop_notes
from elastic_motion.apps.loop.window_candidates import cycle_candidates, estimate_period, pose_dissimilarity
from elastic_motion.apps.metrics import seam_metrics
from elastic_motion.errors import OptionError
from elastic_motion.groups import SO3
from elastic_motion.motion import Motion, drop_tpose, read_motion
from elastic_motion.notes import of_kind

SO3G = SO3()


def periodic(f=150, period=40, fps=30.0, lead=17, names=("root", "hip", "knee", "foot")):
    """A gait-like clip of period ``period`` frames after a non-periodic lead-in of ``lead`` frames."""
    k = np.arange(f, dtype=float)
    ph = 2 * np.pi * (k - lead) / period
    ramp = np.clip((k - lead) / 5.0, -1.0, 0.0)  # lead-in: amplitude grows, then steady
    amp = 1.0 + 0.8 * ramp
    rv = np.zeros((f, 4, 3))
    rv[:, 0] = np.outer(amp * np.sin(ph), [0.05, 0.0, 0.05])
    rv[:, 1] = np.outer(amp * np.sin(ph), [0.7, 0, 0.1])
    rv[:, 2] = np.outer(amp * (1 - np.cos(ph)), [0.5, 0, 0])
    rv[:, 3] = np.outer(amp * np.sin(2 * ph), [0.2, 0.1, 0])
    root = np.stack([0.02 * k, 0.9 + 0.03 * amp * np.sin(2 * ph), 0 * k], 1)
    return Motion(chain_skeleton(names), fps, root, SO3G.exp(rv), metres_per_unit=1.0, name="periodic")


def test_dissimilarity_is_a_squared_distance_of_pose_and_velocity():
    m = periodic()
    d = pose_dissimilarity(m)
    assert d.shape == (m.n_frames, m.n_frames)
    np.testing.assert_allclose(d, d.T, atol=1e-9)
    assert np.all(np.diag(d) == 0) and d.min() >= 0
    # independent: chordal distances of the rotations + tilt + height, velocity term tau = 0.1 s
    a, b = 30, 95
    r = m.rotations
    pose = np.sum((r[a, 1:] - r[b, 1:]) ** 2) + np.sum((r[a, 0, 1] - r[b, 0, 1]) ** 2)
    pose += (m.root_translation[a, 1] - m.root_translation[b, 1]) ** 2

    def vel(i):
        x = np.concatenate([r[:, 1:].reshape(m.n_frames, -1), r[:, 0, 1], m.root_translation[:, 1:2]], 1)
        return (x[i + 1] - x[i - 1]) / 2 * m.fps

    expect = pose + 0.1**2 * np.sum((vel(a) - vel(b)) ** 2)
    assert d[a, b] == pytest.approx(expect, rel=1e-9)
    # heading-blind in "travel": turning the whole clip about the up axis changes nothing
    turn = SO3G.exp(np.array([0.0, 0.7, 0.0]))
    rot = m.rotations.copy()
    rot[:, 0] = turn @ rot[:, 0]
    np.testing.assert_allclose(pose_dissimilarity(m.replace(rotations=rot)), d, atol=1e-9)
    # in place too (the treadmill takes out a window's turn), but there the turning rate counts
    inplace = pose_dissimilarity(m, root="inplace")
    np.testing.assert_allclose(
        pose_dissimilarity(m.replace(rotations=rot), root="inplace"), inplace, atol=1e-9
    )
    turning = m.rotations.copy()
    turning[:, 0] = (
        SO3G.exp(np.outer(0.3 * np.sin(np.arange(m.n_frames) / 7.0), [0.0, 1.0, 0.0])) @ turning[:, 0]
    )
    assert not np.allclose(pose_dissimilarity(m.replace(rotations=turning), root="inplace"), inplace)
    np.testing.assert_allclose(pose_dissimilarity(m.replace(rotations=turning)), d, atol=1e-9)


def test_a_frozen_stretch_is_not_a_candidate_window():
    """A pause closes with no change at all: windows that move less than 30 % of the clip's
    busier half are left out (unless every window is that still)."""
    m = periodic(f=150, period=40)
    still = m.replace(  # frames 90..149 frozen on frame 90's pose
        rotations=np.concatenate([m.rotations[:90], np.repeat(m.rotations[90:91], 60, axis=0)]),
        root_translation=np.concatenate(
            [m.root_translation[:90], np.repeat(m.root_translation[90:91], 60, 0)]
        ),
    )
    cand = cycle_candidates(still, min_length=0.5)
    assert cand.quiet_excluded and cand.windows
    assert all(a < 80 for a, _ in cand.windows)  # each window holds mostly moving frames
    frozen = still.replace(rotations=np.repeat(m.rotations[:1], 150, 0), root_translation=np.zeros((150, 3)))
    assert not cycle_candidates(frozen, min_length=0.5).quiet_excluded  # all still: all candidates


def test_yaw_rate_and_active_windows_formulas():
    """The turning rate about the up axis is +omega (rad/s) for a root turning at omega,
    also on the end frames; a window moves when its mean speed is at least 0.3 times the mean
    over the busier half of the frames."""
    from elastic_motion.apps.loop.window_candidates import _active_windows, _yaw_rate

    fps, omega = 30.0, 0.8
    t = np.arange(20) / fps
    r0 = SO3G.exp(np.outer(omega * t, [0.0, 1.0, 0.0]))
    np.testing.assert_allclose(_yaw_rate(r0, 1, fps), omega, rtol=1e-9)
    np.testing.assert_allclose(_yaw_rate(np.swapaxes(r0, -1, -2), 1, fps), -omega, rtol=1e-9)
    speed = np.array([0.0, 0.0, 0.0, 0.0, 2.0, 2.0, 4.0, 4.0])  # busier half: 3.0 on average
    a, b = np.array([0, 2, 2, 4]), np.array([3, 4, 5, 7])
    # means (frames a..b, both ends) 0, 0.67, 1.0, 3.0 against 0.3 * 3.0 = 0.9
    np.testing.assert_array_equal(_active_windows(speed, a, b), [False, False, True, True])


def test_in_place_windows_ignore_the_travel_the_treadmill_takes_out():
    """With root "inplace" the floor-plane position is not a feature (only its velocity): the
    treadmill closes it whatever it was. A walk travelling along x has the same period in
    place as travelling (with the position, every lag beyond a step looked dissimilar)."""
    m = periodic(f=150, period=40)
    walk = m.replace(root_translation=m.root_translation + np.outer(np.arange(150) * 0.04, [1.0, 0.0, 0.0]))
    assert cycle_candidates(walk, root="inplace").period == pytest.approx(40 / 30.0, abs=1.5 / 30)
    d = pose_dissimilarity(walk, root="inplace")
    shifted = walk.replace(root_translation=walk.root_translation + [0.3, 0.0, 0.0])
    np.testing.assert_allclose(pose_dissimilarity(shifted, root="inplace"), d, atol=1e-9)


@pytest.mark.mocap
def test_auto_windows_of_real_clips_move_and_in_place_ones_are_whole_cycles(mocap_dir):
    """CMU 131_01 (a walk that stops) with a 1 s minimum: the auto window was the last second
    of standing (root 0.05 m/s); the DeepMimic run in place: ranked with the travel counted
    as change, a 13-frame step won over the 25-frame cycle."""
    from elastic_motion.apps.prepare import prepare_motions

    walk = prepare_motions([mocap_dir / "cmu/bvh/131_01.bvh"]).motions[0]
    cand = cycle_candidates(walk, min_length=1.0)
    speed = np.linalg.norm(np.diff(walk.root_translation[:, [0, 2]], axis=0), axis=1) * walk.fps
    assert cand.quiet_excluded
    assert all(speed[a : b - 1].mean() > 0.3 for a, b in cand.windows)
    run = loop_motion(mocap_dir / "deepmimic/humanoid3d_run.txt", window="auto", root="inplace", force=True)
    assert (run.window.start, run.window.stop) == (0, run.prepared.motions[0].n_frames)


def test_period_and_candidates_of_a_periodic_clip():
    m = periodic(period=40)
    d = pose_dissimilarity(m)
    assert estimate_period(d, m.fps) == pytest.approx(40 / m.fps)
    c = cycle_candidates(m)
    assert c.min_length_default and c.min_length == pytest.approx(0.9 * 40 / m.fps)
    a, b = c.windows[0]
    assert (b - 1 - a) % 40 == 0 and a >= 17  # a whole number of periods, after the lead-in
    assert c.scores[0] < 1e-9
    # a clip that does not repeat has no period: default half the clip
    one = periodic(f=30, period=200, lead=0)
    assert estimate_period(pose_dissimilarity(one), one.fps) is None
    assert cycle_candidates(one).min_length == pytest.approx(0.5 * 29 / one.fps)


def test_auto_window_loops_one_period_with_almost_no_change():
    m = periodic()
    whole = loop_motion(m, seam="c0", window=None, force=True)
    res = loop_motion(m, window="auto", seam="c0", force=True)
    w = res.window
    assert (w.stop - 1 - w.start) % 40 == 0 and w.start >= 17
    assert res.motion.n_frames == w.stop - w.start
    assert w.deviation_max_m < 1e-6 < whole.seam_after.deviation_max_m
    assert w.whole["deviation_max_m"] == pytest.approx(whole.seam_after.deviation_max_m, rel=1e-6)
    s = res.summary()
    json.dumps(s)
    assert s["window"]["start_frame"] == w.start and s["window"]["length_s"] == pytest.approx(w.length)
    # an explicit window
    res2 = loop_motion(m, window=(20, 100), seam="c0", force=True)
    assert res2.motion.n_frames == 80 and res2.window.start == 20
    np.testing.assert_allclose(res2.motion.rotations[0], m.rotations[20], atol=1e-12)


def test_bad_windows_give_clear_errors():
    m = periodic(f=40, period=200, lead=0)
    with pytest.raises(OptionError, match=r"no longer than the clip \(1\.300 s, 40 frames\); got 5\.000 s"):
        loop_motion(m, window="auto", min_length=5.0, force=True)
    with pytest.raises(OptionError, match="min_length"):
        loop_motion(m, window="auto", min_length=-1.0, force=True)
    with pytest.raises(OptionError, match="window"):
        loop_motion(m, window="best", force=True)
    with pytest.raises(OptionError, match="window"):
        loop_motion(m, window=(30, 20), force=True)
    with pytest.raises(OptionError, match="contacts"):
        loop_motion(m, contacts="plant", window=None, force=True)
    # a minimum length bounds the auto window's choice: refused where it would be ignored
    with pytest.raises(OptionError, match=r"^min_length: expected only with window='auto'.*the whole clip"):
        loop_motion(m, min_length=0.5, window=None, force=True)
    with pytest.raises(OptionError, match=r"^min_length: expected only with window='auto'.*window=\(0, 30\)"):
        loop_motion(m, window=(0, 30), min_length=0.5, force=True)


def test_the_window_report_says_where_its_minimum_length_came_from():
    m = periodic(f=150, period=40)
    rules = {
        None: "90 % of the period",
        0.5: "given",
    }
    for given, rule in rules.items():
        w = loop_motion(m, window="auto", min_length=given, contacts="off", force=True).window.summary()
        assert w["min_length_rule"] == rule and w["min_length_from_period"] == (given is None)
    lone = periodic(f=60, period=400, lead=0)  # no repetition: half the clip
    w = loop_motion(lone, window="auto", contacts="off", force=True).window.summary()
    assert w["period_s"] is None and not w["min_length_from_period"]
    assert w["min_length_rule"] == "half the clip (no period found)"
    assert w["quiet_windows_excluded"] is False  # a clip that moves all along


def test_contacts_reported_or_skipped():
    m = periodic()
    res = loop_motion(m, window=None, force=True)
    assert res.contacts is not None and res.contacts.joints == ("foot",)
    assert res.skating_before is not None and res.skating_after is not None
    assert res.summary()["skating_after"]["skating_mean_m_s"] == res.skating_after.mean_speed
    # no joint that can touch the floor: skipped, and the report says so
    bare = periodic(names=("root", "a", "b", "c"))
    res = loop_motion(bare, window=None, force=True)
    assert res.skating_before is None
    (skipped,) = of_kind(res.notes, loop_notes.CONTACTS_SKIPPED)
    assert "contacts skipped" in str(skipped)
    assert loop_motion(m, contacts="off", window=None, force=True).contacts is None


@pytest.mark.mocap
def test_auto_window_of_cmu_cartwheels_changes_a_third_of_the_whole_clip(mocap_dir):
    m = drop_tpose(read_motion(mocap_dir / "cmu/bvh/49_08.bvh"))
    res = loop_motion(m, window="auto", candidates=2, contacts="report", force=True)  # the projections alone
    w = res.window
    assert res.closing.converged and res.closing.kkt_residual < 1e-8
    assert w.deviation_max_m <= w.whole["deviation_max_m"] / 3
    assert w.length >= w.min_length - 1e-9
    after = seam_metrics(res.motion, original=res.original, joints=res.closed_joints)
    assert after.seam_angle_max_deg < 1e-3
    assert after.deviation_max_m == pytest.approx(w.deviation_max_m)


def test_contact_rows_jacobian_matches_central_differences():
    from elastic_motion.apps.loop.contact_rows import ContactConstraints, Row
    from elastic_motion.motion.contacts import Contacts

    m = periodic(f=50)
    mask = np.zeros((50, 1), dtype=bool)
    mask[10:25] = True  # an interior contact
    mask[40:] = True  # a contact reaching the last frame: rows relative to it
    contacts = Contacts(("foot",), np.array([3]), mask, 0.0, np.array([0.0]), m.fps, "y")
    # two rows on the foot's end site (point J + 0): an absolute height, a relative position
    sites = [
        Row(4, "foot end site", (30, 31), 30, 1, -1, 0.0),
        Row(4, "foot end site", (35, 36), 35, 0, 49, 0.0),
        Row(2, "knee from the foot", (36, 37), 36, 2, 49, 0.0, 3),  # relative to another joint
    ]
    cc = ContactConstraints(m, contacts, more_rows=sites)
    rng = np.random.default_rng(1)
    rot = m.rotations @ SO3G.exp(rng.normal(size=(m.n_frames, 4, 3)) * 0.1)
    eu = m.root_translation + rng.normal(size=(m.n_frames, 3)) * 0.01
    g, frames, d_rot, d_eu = cc.evaluate(rot, eu)
    assert (frames[:, 1] == 49).any() and (frames[:, 1] == -1).any()
    np.testing.assert_allclose(g, cc.residual(rot, eu), atol=1e-12)
    eps = 1e-6
    for r in [*range(0, len(cc), 5), len(cc) - 2, len(cc) - 1]:
        for s_ in range(2):
            f = frames[r, s_]
            if f < 0:
                continue
            for b in range(4):
                for k in range(3):
                    w = np.zeros(3)
                    w[k] = eps
                    rp, rm = rot.copy(), rot.copy()
                    rp[f, b] = SO3G.exp(w) @ rot[f, b]
                    rm[f, b] = SO3G.exp(-w) @ rot[f, b]
                    fd = (cc.residual(rp, eu)[r] - cc.residual(rm, eu)[r]) / (2 * eps)
                    assert d_rot[r, s_, b, k] == pytest.approx(fd, abs=1e-7)
            for k in range(3):
                ep, em_ = eu.copy(), eu.copy()
                ep[f, k] += eps
                em_[f, k] -= eps
                fd = (cc.residual(rot, ep)[r] - cc.residual(rot, em_)[r]) / (2 * eps)
                assert d_eu[r, s_, k] == pytest.approx(fd, abs=1e-7)


@pytest.mark.mocap
def test_contacts_kept_plant_the_deepmimic_run(mocap_dir):
    path = mocap_dir / "deepmimic/humanoid3d_run.txt"
    plain = loop_motion(path, contacts="report", window=None, force=True)
    kept = loop_motion(path, window=None, force=True)  # the default: contacts kept
    assert kept.closing.converged and kept.closing.kkt_residual < 1e-8
    assert kept.contacts_kept.rows > 0 and kept.contacts_kept.dropped is None
    assert kept.seam_after.seam_angle_max_deg < 1e-3
    # skating during the input's contacts: the plain loop slides, the kept one as the input
    assert plain.skating_after.mean_speed > 1.5 * plain.skating_before.mean_speed
    assert kept.skating_after.mean_speed <= 1.1 * kept.skating_before.mean_speed
    assert kept.summary()["contacts_kept"]["gave_way"] == []
    assert kept.summary()["contacts_kept"] == kept.contacts_kept.summary()
    with pytest.raises(OptionError, match="contacts"):
        loop_motion(path, contacts="keep", solver="gauss-newton", window=None, force=True)


def test_contacts_that_give_way_are_reported():
    from elastic_motion.apps.loop.contact_rows import ContactConstraints
    from elastic_motion.motion.contacts import Contacts

    m = periodic(f=50)
    mask = np.zeros((50, 1), dtype=bool)
    mask[10:25] = True
    contacts = Contacts(("foot",), np.array([3]), mask, 0.0, np.array([0.0]), m.fps, "y")
    cc = ContactConstraints(m, contacts)
    assert cc.gave_way(m.rotations, m.root_translation) == []  # the input meets its own contacts
    rot = m.rotations.copy()
    rot[22, 1] = SO3G.exp(np.array([0.0, 0.0, 0.1])) @ rot[22, 1]  # the hip moves in a sampled frame
    (miss,) = cc.gave_way(rot, m.root_translation)
    assert miss["joint"] == "foot" and miss["frames"] == [10, 25]
    assert 0.05 < miss["largest_miss_m"] < 0.1  # about 0.1 rad times the 0.8 m leg
