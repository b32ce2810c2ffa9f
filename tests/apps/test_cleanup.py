"""Foot-skate clean-up: carried contacts, plants enforced by IK, bone lengths kept, the
blend's report; real walks skate no more than their inputs."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from blend_testlib import walker

from elastic_motion.apps.blend import NOTE_CLEANUP, BlendOptions, blend_motions
from elastic_motion.apps.cleanup import (
    NOTE_SKIPPED,
    CleanupOptions,
    _ease,
    carry_contacts,
    cleanup_footskate,
    find_legs,
    settle_offset,
)
from elastic_motion.apps.metrics import bone_length_error, contact_skating
from elastic_motion.apps.metrics.floor import foot_quality
from elastic_motion.motion import drop_tpose, forward_kinematics, read_motion, trim
from elastic_motion.motion.contacts import ContactOptions, Contacts

IDENTITY = np.array([[0.0, 0.0], [1.0, 1.0]])


def _contacts(names, mask, fps=30.0, floor=0.0):
    mask = np.asarray(mask, dtype=bool)
    return Contacts(
        tuple(names), np.zeros(len(names), dtype=np.int64), mask, floor, np.zeros(len(names)), fps, "y"
    )


def test_carried_contacts_vote_with_the_weights():
    f = 31
    ma = np.zeros((f, 1), dtype=bool)
    mb = np.zeros((f, 1), dtype=bool)
    ma[5:20] = True
    mb[10:25] = True
    ca, cb = _contacts(["LeftFoot"], ma), _contacts(["LeftFoot"], mb)
    u = np.linspace(0.0, 1.0, f)
    half = carry_contacts([ca, cb], [IDENTITY, IDENTITY], u, [1.0, 1.0], [0.5, 0.5], fps=30.0)
    np.testing.assert_array_equal(np.flatnonzero(half.mask[:, 0]), np.arange(10, 20))  # both agree
    mostly_a = carry_contacts([ca, cb], [IDENTITY, IDENTITY], u, [1.0, 1.0], [0.7, 0.3], fps=30.0)
    np.testing.assert_array_equal(mostly_a.mask[:, 0], ma[:, 0])
    # a warp carries B's contact: B's frames 10..25 are A's 5..20 under phi(u) = u + 1/6
    shift = np.array([[0.0, 0.0], [0.1, 0.1 + 5 / 30], [0.9, 0.9 + 2 / 30], [1.0, 1.0]])
    carried = carry_contacts([ca, cb], [IDENTITY, shift], u, [1.0, 1.0], [0.5, 0.5], fps=30.0)
    assert carried.mask[6:19, 0].all() and not carried.mask[:3, 0].any()


def test_a_floor_that_is_not_level_is_carried_with_the_frames():
    """A's floor rises 6 cm over its frames, B's is level: the blend's floor offset is the
    weighted sum of each input's at its warped frame (B's warp delays it by 5 frames)."""
    f = 31
    mask = np.zeros((f, 1), dtype=bool)
    rise = np.linspace(0.0, 0.06, f)
    ca = dataclasses.replace(_contacts(["LeftFoot"], mask), floor_offset=rise)
    cb = _contacts(["LeftFoot"], mask, floor=0.01)
    u = np.linspace(0.0, 1.0, f)
    out = carry_contacts([ca, cb], [IDENTITY, IDENTITY], u, [1.0, 1.0], [0.25, 0.75], fps=30.0)
    np.testing.assert_allclose(out.floor_offset, 0.25 * rise, atol=1e-12)
    np.testing.assert_allclose(out.floor_heights(), 0.75 * 0.01 + 0.25 * rise, atol=1e-12)
    # A warped (its frame idx of u is 5 frames later, clipped at the end)
    late = np.array([[0.0, 5 / 30], [25 / 30, 1.0], [1.0, 1.0]])
    out = carry_contacts([cb, ca], [IDENTITY, late], u, [1.0, 1.0], [0.5, 0.5], fps=30.0)
    idx = np.clip(np.rint(np.interp(u, late[:, 0], late[:, 1]) * 30).astype(int), 0, f - 1)
    np.testing.assert_allclose(out.floor_offset, 0.5 * rise[idx], atol=1e-12)
    # a weight curve (per frame): each frame's own weights
    wa = np.linspace(0.0, 1.0, f)
    curve = np.column_stack([wa, 1.0 - wa])
    out = carry_contacts([ca, cb], [IDENTITY, IDENTITY], u, [1.0, 1.0], curve, fps=30.0)
    np.testing.assert_allclose(out.floor_offset, wa * rise, atol=1e-12)
    # level inputs: a level result
    assert (
        carry_contacts([cb, cb], [IDENTITY, IDENTITY], u, [1.0, 1.0], [0.5, 0.5], fps=30.0).floor_offset
        is None
    )


def test_ease_keeps_known_values_and_fades_out_continuously():
    v = np.zeros((40, 1))
    known = np.zeros(40, dtype=bool)
    known[10:20] = True
    v[10:20] = 1.0
    out = _ease(v, known, 5)[:, 0]
    np.testing.assert_array_equal(out[10:20], 1.0)
    assert out[4] == 0.0 and out[25] == 0.0 and 0 < out[7] < out[8] < out[9] < 1
    assert np.abs(np.diff(out)).max() < 0.35


def test_cleanup_plants_the_foot_and_keeps_bone_lengths():
    m = walker(duration=1.5)  # the synthetic walker's feet slide all the time
    names = ("LeftFoot", "RightFoot")
    mask = np.zeros((m.n_frames, 2), dtype=bool)
    mask[8:20, 0] = True
    mask[24:38, 1] = True
    c = _contacts(names, mask, floor=float(forward_kinematics(m, end_sites=True)[..., 1].min()) - 0.05)
    before = contact_skating(m, c)
    res = cleanup_footskate(m, c, smooth=0.0)
    assert res.applied and set(res.legs) == set(names)
    assert before.mean_speed > 0.3
    assert res.skating_after.mean_speed < 1e-6 * max(before.mean_speed, 1.0)
    assert bone_length_error(res.motion).max_relative < 1e-9
    assert res.max_position_change > 0.01 and res.max_rotation_change_deg > 1
    # smoothing the change trades a little skating for smaller velocity changes
    smooth = cleanup_footskate(m, c, smooth=0.05)
    assert 0 < smooth.skating_after.mean_speed < 0.5 * before.mean_speed


def test_cleanup_strength_goes_part_of_the_way_and_keeps_the_floor():
    m = walker(duration=1.5)
    names = ("LeftFoot", "RightFoot")
    mask = np.zeros((m.n_frames, 2), dtype=bool)
    mask[8:20, 0] = True
    mask[24:38, 1] = True
    low = float(forward_kinematics(m, end_sites=True)[..., 1].min())
    c = _contacts(names, mask, floor=low - 0.05)
    before = contact_skating(m, c).mean_speed
    full, half = (cleanup_footskate(m, c, smooth=0.0, strength=x) for x in (1.0, 0.5))
    assert half.strength == 0.5 and half.summary()["strength"] == 0.5
    # half way to the plants: about half the skating left, a smaller change
    assert 0.35 * before < half.skating_after.mean_speed < 0.65 * before
    assert half.max_position_change < 0.7 * full.max_position_change
    none = cleanup_footskate(m, c, smooth=0.0, strength=0.0)
    np.testing.assert_allclose(none.motion.rotations, m.rotations, atol=1e-12)
    # the floor is enforced in full whatever the fraction
    under = _contacts(names, mask, floor=low + 0.03)
    assert cleanup_footskate(m, under, smooth=0.0, strength=0.0).skating_after.below_floor < 1e-6
    with pytest.raises(ValueError, match="strength"):
        cleanup_footskate(m, c, strength=1.5)


def test_settle_offset_formula_floor_mean_interpolation_and_seconds():
    """Independently of the clean-up: on each frame the mean over the planted joints of
    ``floor + ground - height``, linear between such frames (held at the ends), then a
    Gaussian of ``sigma`` seconds (``sigma * fps`` frames); bounded so that no planted joint
    goes more than 1 cm under its ground (exactly, also after the smoothing), and by the
    ``lower`` / ``upper`` given (the floor bound winning over ``upper``)."""
    from scipy.ndimage import gaussian_filter1d

    m = walker(duration=1.5)
    legs, _ = find_legs(m)
    names = ("LeftFoot", "RightFoot")
    idx = [m.skeleton.index(n) for n in names]
    mask = np.zeros((m.n_frames, 2), dtype=bool)
    mask[8:20, 0] = True
    mask[16:30, 1] = True  # both planted on 16..19: their mean
    floor, ground = 0.1, np.array([0.03, 0.05])
    c = Contacts(names, np.array(idx), mask, floor, ground, m.fps, "y")
    h = forward_kinematics(m)[:, idx, 1]
    gap = np.where(mask, floor + ground - h, np.nan)
    need = np.nansum(gap, axis=1) / np.maximum(mask.sum(axis=1), 1)
    known = mask.any(axis=1)
    f = np.arange(m.n_frames)
    raw = np.interp(f, f[known], need[known])
    bound = np.where(known, np.nanmax(np.where(mask, gap, -np.inf), axis=1) - 0.01, -np.inf)
    assert (bound > raw).any()  # the floor bound is exercised (on 16..19)
    np.testing.assert_allclose(settle_offset(m, c, legs, sigma=0.0), np.maximum(raw, bound), atol=1e-12)
    smooth = settle_offset(m, c, legs, sigma=0.2)
    assert (smooth >= bound - 1e-12).all()  # no planted joint more than 1 cm under its ground
    # farther than the smoothing's width (6 frames) from where it crosses the bound: the plain
    # Gaussian of the bounded mean
    plain = gaussian_filter1d(np.maximum(raw, bound), 0.2 * m.fps, mode="nearest")
    crossed = np.flatnonzero(plain < bound)
    assert crossed.size
    free = np.abs(f[:, None] - crossed[None, :]).min(axis=1) > 6
    assert free.sum() > 10
    np.testing.assert_allclose(smooth[free], plain[free], atol=1e-12)
    assert np.abs(np.diff(smooth)).max() * m.fps < 1.0  # slow: under 1 m/s
    # given bounds hold, the floor's winning over an upper bound below it
    lower, upper = np.full(m.n_frames, -0.02), np.full(m.n_frames, -0.01)
    both = settle_offset(m, c, legs, sigma=0.2, lower=lower, upper=upper)
    assert (both >= np.maximum(lower, bound) - 1e-12).all()
    conflict = np.flatnonzero(bound > upper)  # the floor wins there, eased over 6 frames
    assert conflict.size
    away = np.abs(f[:, None] - conflict[None, :]).min(axis=1) > 6
    assert away.sum() > 10 and (both[away] <= upper[away] + 1e-12).all()


def test_settle_moves_the_body_down_to_the_floor_not_the_stance_knees():
    m = walker(duration=1.5)
    legs, _ = find_legs(m)
    names = ("LeftFoot", "RightFoot")
    mask = np.zeros((m.n_frames, 2), dtype=bool)
    mask[8:20, 0] = True
    mask[24:38, 1] = True
    pos = forward_kinematics(m)
    idx = [m.skeleton.index(n) for n in names]
    ground = np.array([pos[mask[:, k], j, 1].mean() for k, j in enumerate(idx)])
    c = Contacts(names, np.array(idx), mask, 0.0, ground, 30.0, "y")
    root = m.root_translation.copy()
    root[:, 1] -= 0.04  # the blend sank 4 cm into the floor
    sunk = m.replace(root_translation=root)
    base = settle_offset(m, c, legs, sigma=0.5)
    # a vertical shift of the motion comes back in full (and only it)
    np.testing.assert_allclose(settle_offset(sunk, c, legs, sigma=0.5), base + 0.04, atol=1e-12)
    # unsmoothed, each planted frame's offset puts its planted joint at its ground height
    raw = settle_offset(sunk, c, legs, sigma=0.0)
    np.testing.assert_allclose(pos[8:20, idx[0], 1] - 0.04 + raw[8:20], ground[0], atol=1e-12)
    np.testing.assert_allclose(pos[24:38, idx[1], 1] - 0.04 + raw[24:38], ground[1], atol=1e-12)
    # the clean-up then lifts the body back: the sunk motion is cleaned exactly like the
    # original, where without settling its stance knees bend to lift the feet
    settled = cleanup_footskate(sunk, c, smooth=0.0, settle=0.5)
    lift = base + 0.04
    assert settled.settle_offset == pytest.approx(lift[np.argmax(np.abs(lift))], abs=1e-12)
    assert settled.summary()["settle_offset_m"] == settled.settle_offset
    same = cleanup_footskate(m, c, smooth=0.0, settle=0.5).motion
    given = cleanup_footskate(sunk, c, smooth=0.0, settle=settle_offset(sunk, c, legs, sigma=0.5))
    np.testing.assert_array_equal(given.motion.rotations, settled.motion.rotations)
    for bad in (-1.0, float("nan"), np.zeros(3), [0.0, 0.0], True, "0.5"):
        with pytest.raises(ValueError, match="settle: expected"):
            cleanup_footskate(sunk, c, settle=bad)
    with pytest.raises(ValueError, match="sigma: expected"):
        settle_offset(sunk, c, legs, sigma=-1.0)
    np.testing.assert_allclose(settled.motion.rotations, same.rotations, atol=1e-9)
    np.testing.assert_allclose(settled.motion.root_translation, same.root_translation, atol=1e-9)
    plain = cleanup_footskate(sunk, c, smooth=0.0)
    assert plain.settle_offset == 0.0
    knees = [leg.knee for leg in legs]
    rel = np.swapaxes(same.rotations[:, knees], -1, -2) @ plain.motion.rotations[:, knees]
    bend = np.degrees(np.arccos(np.clip((np.trace(rel, axis1=-2, axis2=-1) - 1) / 2, -1, 1)))
    assert bend.max() > 5.0
    assert bone_length_error(settled.motion).max_relative < 1e-9
    no_contacts = Contacts(names, np.array(idx), np.zeros_like(mask), 0.0, ground, 30.0, "y")
    assert not settle_offset(sunk, no_contacts, legs, sigma=0.5).any()


def test_cleanup_lifts_a_foot_out_of_the_floor():
    m = walker(duration=1.0)
    low = float(forward_kinematics(m, end_sites=True)[..., 1].min())
    c = _contacts(("LeftFoot",), np.zeros((m.n_frames, 1), dtype=bool), floor=low + 0.03)
    c = Contacts(c.joints, c.joint_indices, c.mask, c.floor, c.ground_height, c.fps, "y")
    # no contact at all and nothing below the floor: nothing to enforce
    c_low = _contacts(("LeftFoot",), np.zeros((m.n_frames, 1), dtype=bool), floor=low - 0.01)
    assert not cleanup_footskate(m, c_low).applied
    # no contact, feet below the floor: they are lifted out of it
    lifted = cleanup_footskate(m, c, smooth=0.0)
    assert lifted.applied and lifted.skating_after.below_floor < 1e-6 < lifted.skating_before.below_floor
    mask = np.zeros((m.n_frames, 1), dtype=bool)
    mask[3:8] = True
    c = _contacts(("LeftFoot",), mask, floor=low + 0.03)
    res = cleanup_footskate(m, c, smooth=0.0)
    sub = m.skeleton.subtree(m.skeleton.index("LeftFoot"))
    left = sub + [m.n_joints + e for e, p in enumerate(m.skeleton.end_site_parents) if p in sub]
    assert forward_kinematics(res.motion, end_sites=True)[:, left, 1].min() > low + 0.03 - 1e-6


def test_blend_cleans_up_by_default_and_says_so():
    a = walker(duration=2.0, name="A")
    b = walker(duration=2.4, freq=1.2, speed=1.3, phase=0.3, name="B")
    opts = ContactOptions(speed_enter=3.0, speed_exit=4.0, height_enter=0.1, height_exit=0.15)
    res = blend_motions([a, b], 0.5, contact_options=opts)
    assert res.cleanup is not None and res.cleanup.applied and res.before_cleanup is not None
    s = res.summary()["cleanup"]
    assert s["skating_after"]["skating_mean_m_s"] < s["skating_before"]["skating_mean_m_s"]
    assert any(n.kind == NOTE_CLEANUP and str(n).startswith("clean-up:") for n in res.notes)
    off = blend_motions([a, b], 0.5, contacts="off")
    assert off.cleanup is None and off.summary()["cleanup"] is None
    np.testing.assert_allclose(off.motion.rotations, res.before_cleanup.rotations)
    one = blend_motions([a, b], 1.0)
    assert one.cleanup is None and any(n.kind == NOTE_CLEANUP and "weight of 1" in str(n) for n in one.notes)
    with pytest.raises(ValueError, match="contacts"):
        blend_motions([a, b], 0.5, contacts="sometimes")


def test_blend_without_contacts_skips_the_cleanup():
    a = walker(duration=1.0, name="A")
    b = walker(duration=1.2, freq=1.2, name="B")
    res = blend_motions([a, b], 0.5, contact_options=ContactOptions(max_ground_offset=0.0, height_enter=0.0))
    assert res.cleanup is None and any(
        n.kind == NOTE_CLEANUP and "no contacts found" in str(n) for n in res.notes
    )


#: Thresholds under which the synthetic walkers have contacts (their feet slide all the time).
WALKER_CONTACTS = ContactOptions(speed_enter=3.0, speed_exit=4.0, height_enter=0.1, height_exit=0.15)


@pytest.fixture(scope="module")
def walkers():
    return walker(duration=2.0, name="A"), walker(duration=2.4, freq=1.2, speed=1.3, phase=0.3, name="B")


def test_contacts_auto_is_keep(walkers):
    """``contacts="auto"`` (the old name) is the clean-up of ``"keep"``: the same options, the
    same motion; ``contacts=ContactOptions(...)`` (the old way to give thresholds) is refused
    with a pointer to ``contact_options``."""
    assert BlendOptions(contacts="auto") == BlendOptions(contacts="keep")
    assert BlendOptions(contacts="auto").contacts == "keep" and BlendOptions(contacts=None).contacts == "off"
    auto = blend_motions(list(walkers), 0.5, contacts="auto", contact_options=WALKER_CONTACTS)
    keep = blend_motions(list(walkers), 0.5, contacts="keep", contact_options=WALKER_CONTACTS)
    assert auto.cleanup.applied and auto.options.contacts == "keep"
    np.testing.assert_array_equal(auto.motion.rotations, keep.motion.rotations)
    np.testing.assert_array_equal(auto.motion.root_translation, keep.motion.root_translation)
    with pytest.raises(ValueError, match=r"contacts: .*contact_options="):
        BlendOptions(contacts=WALKER_CONTACTS)


def test_contacts_report_measures_without_changing_the_blend(walkers):
    """``contacts="report"``: the blend is the one of ``"off"``, and its skating against the
    contacts carried from the inputs is measured (the skating ``"keep"`` starts from)."""
    report = blend_motions(list(walkers), 0.5, contacts="report", contact_options=WALKER_CONTACTS)
    off = blend_motions(list(walkers), 0.5, contacts="off", contact_options=WALKER_CONTACTS)
    keep = blend_motions(list(walkers), 0.5, contacts="keep", contact_options=WALKER_CONTACTS)
    np.testing.assert_array_equal(report.motion.rotations, off.motion.rotations)
    np.testing.assert_array_equal(report.motion.root_translation, off.motion.root_translation)
    assert report.before_cleanup is None and off.cleanup is None
    measured = report.cleanup
    assert measured is not None and not measured.applied and measured.motion is report.motion
    assert measured.skating_before.mean_speed == pytest.approx(
        keep.cleanup.skating_before.mean_speed, rel=1e-12
    )
    assert measured.skating_after.mean_speed > 0.05  # the walkers' feet slide
    assert measured.max_position_change == 0.0 and measured.legs == ()
    (note,) = (n for n in report.notes if n.kind == NOTE_CLEANUP)
    assert str(note).startswith("clean-up: not applied (contacts 'report')")
    assert note.data["skating_m_s"] == measured.skating_after.mean_speed
    assert report.summary()["cleanup"]["applied"] is False


def test_cleanup_options_overrides_and_validation():
    """``cleanup_footskate(m, c, smooth=0.0)`` is ``cleanup_footskate(m, c, CleanupOptions(smooth=0.0))``;
    an unknown keyword and a bad value are errors naming the option."""
    m = walker(duration=1.5)
    mask = np.zeros((m.n_frames, 2), dtype=bool)
    mask[8:20, 0] = True
    mask[24:38, 1] = True
    c = _contacts(
        ("LeftFoot", "RightFoot"), mask, floor=float(forward_kinematics(m, end_sites=True)[..., 1].min())
    )
    by_keywords = cleanup_footskate(m, c, smooth=0.0, strength=0.5, knee_hinge=False)
    by_options = cleanup_footskate(m, c, CleanupOptions(smooth=0.0, strength=0.5, knee_hinge=False))
    np.testing.assert_array_equal(by_keywords.motion.rotations, by_options.motion.rotations)
    assert by_keywords.strength == 0.5 and by_keywords.smooth == 0.0
    with pytest.raises(ValueError, match="smoothing"):
        cleanup_footskate(m, c, smoothing=0.1)
    for name, bad in (
        ("blend_time", -0.1),
        ("smooth", float("nan")),
        ("strength", -0.5),
        ("knee_hinge", "yes"),
        ("ease_swing", "no"),
    ):
        with pytest.raises(ValueError, match=f"^{name}: expected"):
            CleanupOptions(**{name: bad})
    no_legs = cleanup_footskate(m, _contacts(("Head",), mask[:, :1]), legs=[])
    assert not no_legs.applied and [n.kind for n in no_legs.notes][-1] == NOTE_SKIPPED
    assert no_legs.summary()["notes"][-1] == "clean-up skipped: no contacts of the legs' ankle or toe joints"


@pytest.mark.mocap
def test_real_walks_are_measured_like_their_inputs(mocap_dir):
    """CMU 107_02 x 108_01: the blend, measured by the inputs' own measure (its own contacts,
    skids), skids no more and skates at most 1.1x the lesser input; the floor and the bones
    kept."""
    a = trim(drop_tpose(read_motion(mocap_dir / "cmu/bvh/107_02_30hz.bvh")), 1.0, 3.4)
    b = trim(drop_tpose(read_motion(mocap_dir / "cmu/bvh/108_01_30hz.bvh")), 1.3, 4.8)
    res = blend_motions([a, b], 0.5, method="lie", warp="dp")
    cl = res.cleanup
    assert cl is not None and cl.applied
    inputs = [foot_quality(m) for m in res.prepared.motions]
    out = foot_quality(res.motion)
    assert out.skid_count <= max(q.skid_count for q in inputs)
    assert out.skating.mean_speed <= 1.1 * min(q.skating.mean_speed for q in inputs)
    assert out.below_floor_m <= 0.01
    assert any(n.kind == NOTE_CLEANUP and "contact plan planted" in str(n) for n in res.notes)
    assert bone_length_error(res.motion).max_relative < 1e-9


def test_floor_raises_are_eased_in_and_out():
    from elastic_motion.motion.edit import eased_envelope as _envelope
    from elastic_motion.motion.edit import smoothstep as _smoothstep

    x = np.zeros(21)
    x[10] = 0.04  # the foot one frame 4 cm under the floor
    x[13] = 0.01
    env = _envelope(x, 4)
    assert (env >= x).all() and env[10] == 0.04
    # eased like the plants: smoothstep weights over 4 frames on either side, nothing beyond
    np.testing.assert_allclose(env[6:10], 0.04 * _smoothstep(1.0 - np.arange(4, 0, -1) / 5.0))
    assert env[5] == 0.0 and env[18] == 0.0 and env[11] == pytest.approx(0.04 * _smoothstep(0.8))
    assert np.abs(np.diff(env)).max() < 0.5 * 0.04


def test_given_plants_are_reached_fixed_frames_kept_and_exact_feet_left_alone():
    """The loop's use of the clean-up: plants given per frame (not the run's mean), seam
    frames that must not change, and targets already met (to rounding) are not touched."""
    m = walker(duration=1.5)
    names = ("LeftFoot", "RightFoot")
    f = m.n_frames
    mask = np.zeros((f, 2), dtype=bool)
    mask[:12, 0] = True  # a contact reaching the first (fixed) frame
    mask[24:38, 1] = True
    c = _contacts(names, mask, floor=-np.inf)
    p = forward_kinematics(m)
    la, ra = m.skeleton.index("LeftFoot"), m.skeleton.index("RightFoot")
    plants = {"LeftFoot": np.full((f, 3), np.nan), "RightFoot": np.full((f, 3), np.nan)}
    plants["LeftFoot"][:12] = p[:12, la] + 1e-12  # already where the rows put it
    plants["RightFoot"][24:38] = p[24:38, ra] + np.array([0.02, 0.0, -0.01])  # 2 cm off, per frame
    plants["RightFoot"][30, 1] = np.nan  # no row: the joint's own height
    res = cleanup_footskate(m, c, plants=plants, smooth=0.0, fixed=(0, f - 1), knee_hinge=False)
    q = forward_kinematics(res.motion)
    np.testing.assert_allclose(q[24:38, ra, [0, 2]], plants["RightFoot"][24:38][:, [0, 2]], atol=1e-7)
    np.testing.assert_allclose(q[30, ra, 1], p[30, ra, 1], atol=1e-7)
    # the left leg's targets were met: not one of its joints turned (IK would bend the knee)
    hip, knee = m.skeleton.index("LeftUpLeg"), m.skeleton.index("LeftLeg")
    np.testing.assert_array_equal(res.motion.rotations[:, [hip, knee, la]], m.rotations[:, [hip, knee, la]])
    np.testing.assert_array_equal(res.motion.rotations[[0, -1]], m.rotations[[0, -1]])
    np.testing.assert_array_equal(res.motion.root_translation[[0, -1]], m.root_translation[[0, -1]])
    with pytest.raises(ValueError, match="plants"):
        cleanup_footskate(m, c, plants={"RightFoot": np.zeros((f - 1, 3))})


@pytest.mark.mocap
def test_arms_are_found_from_the_hands_parent_named_like_an_elbow(mocap_dir):
    from elastic_motion.apps.cleanup import find_arms

    cmu = read_motion(mocap_dir / "cmu/bvh/49_08.bvh")
    sk = cmu.skeleton
    (left,) = find_arms(cmu, ["LeftHand", "LeftFoot", "NoSuchJoint"])
    assert [sk.names[j] for j in (left.hip, left.knee, left.ankle)] == ["LeftArm", "LeftForeArm", "LeftHand"]
    assert left.toe == -1
    asf = read_motion(mocap_dir / "cmu/asfamc/backflip.amc")
    arms = find_arms(asf, ["lhand", "lwrist", "rwrist"])  # lhand's parent is the wrist: no chain
    assert [asf.skeleton.names[a.knee] for a in arms] == ["lradius", "rradius"]


def test_a_foots_two_plants_agree_with_its_own_direction_the_longer_run_leading():
    """Where ankle and toe are both planted, the joint with the longer run keeps its own mean
    and the other is put at the foot's mean floor vector from it (heights untouched)."""
    from elastic_motion.apps.cleanup import _plants, _rigid_foot_plants

    f = 40
    pa = np.zeros((f, 3))
    pa[:, 2] = np.linspace(0.0, 0.39, f)  # the whole foot slides 1 cm a frame along z
    pa[:, 1] = 0.08
    foot = np.array([0.01, -0.04, 0.12])
    pt = pa + foot
    ma = np.zeros(f, dtype=bool)
    mt = np.zeros(f, dtype=bool)
    mt[0:30] = True  # the toe's run is the longer: it leads
    ma[20:30] = True
    floor = [0, 2]
    plant_a, plant_t = _plants(pa, ma, None, 1), _plants(pt, mt, None, 1)
    toe_mean = pt[0:30].mean(axis=0)[floor]
    _rigid_foot_plants(pa, plant_a, ma, pt, plant_t, mt, 1)
    np.testing.assert_allclose(plant_t[0:30][:, floor], np.tile(toe_mean, (30, 1)), atol=1e-12)
    np.testing.assert_allclose(plant_a[20:30][:, floor], np.tile(toe_mean - foot[floor], (10, 1)), atol=1e-12)
    np.testing.assert_array_equal(plant_a[20:30, 1], pa[20:30, 1])  # heights are the joints' own
    # the ankle's run the longer: the ankle leads, the toe follows over all of its own run
    ma[:] = False
    mt[:] = False
    ma[5:35] = True
    mt[25:38] = True
    plant_a, plant_t = _plants(pa, ma, None, 1), _plants(pt, mt, None, 1)
    _rigid_foot_plants(pa, plant_a, ma, pt, plant_t, mt, 1)
    ankle_mean = pa[5:35].mean(axis=0)[floor]
    np.testing.assert_allclose(plant_a[5:35][:, floor], np.tile(ankle_mean, (30, 1)), atol=1e-12)
    np.testing.assert_allclose(
        plant_t[25:38][:, floor], np.tile(ankle_mean + foot[floor], (13, 1)), atol=1e-12
    )
    np.testing.assert_array_equal(plant_t[25:38, 1], pt[25:38, 1])
    # a short toe contact bridging two heel contacts follows the one it shares most with
    ma[:] = False
    mt[:] = False
    ma[0:15] = True
    ma[20:35] = True
    mt[10:22] = True  # 5 frames with the first heel contact, 2 with the second
    plant_a, plant_t = _plants(pa, ma, None, 1), _plants(pt, mt, None, 1)
    _rigid_foot_plants(pa, plant_a, ma, pt, plant_t, mt, 1)
    first = pa[0:15].mean(axis=0)[floor]
    np.testing.assert_allclose(plant_t[10:22][:, floor], np.tile(first + foot[floor], (12, 1)), atol=1e-12)


@pytest.mark.mocap
def test_an_euler_blends_skated_foot_is_planted_not_twisted(mocap_dir):
    """CMU 131_01 x 131_02 by the Euler baseline: the blend's left toe moves 46 cm (and 13 cm
    up) in a carried contact in which the ankle is planted for its last 40 frames. The means
    of the two runs pointed the foot 67 deg away from the blend's own (and from both inputs');
    with the plants of a rigid foot the clean-up turns no joint by more than about 39 deg (70
    without: the ankles, also when the clean-up's trial with plants at the middle of the blend's
    feet's ends, :func:`~elastic_motion.apps.blend.contact_plan.at_ends`, does not make the foot
    rigid again)."""
    a = read_motion(mocap_dir / "cmu/bvh/131_01.bvh")
    b = read_motion(mocap_dir / "cmu/bvh/131_02.bvh")
    res = blend_motions([a, b], 0.5, method="euler-elastic", warp="dp")
    cl = res.cleanup
    assert cl is not None and cl.applied
    assert cl.max_rotation_change_deg < 42.0
    assert cl.skating_after.mean_speed < 0.9 * cl.skating_before.mean_speed
    assert cl.skating_after.below_floor <= 0.01


@pytest.mark.mocap
def test_a_foot_the_blend_holds_high_is_not_pulled_down(mocap_dir):
    """CMU 131_01's rise from a crouch blended with 131_02's walk by the Euler baseline: the
    blend holds its right foot 36 cm up where the plan plants it (its hip posed wrong). Pulled
    down to the inputs' heights it folded the knees by 60-90 deg and sank the root; the plan
    keeps a foot held that high at its own heights, locked in the floor plane only. (The stance
    is 131_02's alone: at 50 % it swings, :mod:`~elastic_motion.apps.blend.contact_plan`
    "Output interval"; at 60 % 131_02 carries the blend and it is planted.)"""
    a = trim(read_motion(mocap_dir / "cmu/bvh/131_01.bvh"), 3.3, 6.2)
    b = trim(read_motion(mocap_dir / "cmu/bvh/131_02.bvh"), 7.0, 9.9)
    res = blend_motions([a, b], [0.4, 0.6], method="euler-elastic", warp="dp")
    before, after = res.before_cleanup, res.motion
    j = after.skeleton.index("RightAnkle")
    assert res.cleanup.contacts.mask[40, res.cleanup.contacts.joints.index("RightAnkle")]
    h0, h1 = forward_kinematics(before)[40, j, 1], forward_kinematics(after)[40, j, 1]
    assert h0 > 0.3 and abs(h1 - h0) < 0.02
    assert after.root_translation[40, 1] > before.root_translation[40, 1] - 0.05


def test_a_swing_raise_is_eased_in_and_out_not_a_jump_at_the_release():
    """Issue 29's distance row: a contact plan's least swing height begins where the plan
    releases the foot; raised in one frame there, the knee snapped by tens of degrees (DeepMimic
    walk x run: the clean-up's own move d(R, R0) 1.05 of d(A, B) / 2, 0.46 eased). The raise
    keeps the least height and changes by at most a third of itself a frame."""
    m = walker(duration=1.5)
    names = ("LeftFoot", "RightFoot")
    ankle = m.skeleton.names.index("LeftFoot")
    mask = np.zeros((m.n_frames, 2), dtype=bool)
    mask[8:20, 0] = True
    c = _contacts(names, mask, floor=float(forward_kinematics(m, end_sites=True)[..., 1].min()) - 0.05)
    planted = cleanup_footskate(m, c, smooth=0.0).motion
    y0 = forward_kinematics(planted)[:, ankle, 1]
    least = np.full(m.n_frames, np.nan)
    least[20:30] = y0[20:30] + 0.05  # 5 cm above where the plant alone leaves the swinging ankle
    res = cleanup_footskate(m, c, smooth=0.0, swing_heights={"LeftFoot": least})
    y = forward_kinematics(res.motion)[:, ankle, 1]
    assert (y[20:30] >= least[20:30] - 1e-6).all()
    raise_ = y - y0
    assert raise_.max() == pytest.approx(0.05, abs=1e-6)
    assert np.abs(np.diff(raise_)).max() < 0.05 / 3
    assert np.abs(raise_[:12]).max() < 1e-9  # eased within blend_time (0.15 s: 5 frames) only
