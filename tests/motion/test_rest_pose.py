"""Rest poses (:mod:`elastic_motion.motion.rest_pose`): a change of rest frames keeps the world
motion exactly; re-expressing towards a reference undoes a known change; the preparation
re-expresses an input from another conversion, and only then."""

from __future__ import annotations

import numpy as np
import pytest

from elastic_motion.groups import SO3
from elastic_motion.motion import Motion, Skeleton, forward_kinematics, global_rotations, read_motion
from elastic_motion.motion.rest_pose import change_rest_frames, rest_frames_towards, rest_pose_difference

SO3G = SO3()


def branching(frames: int = 12, seed: int = 0) -> Motion:
    """A root with three children (a hip-like branch), chains below, end sites, and per-frame
    translations on one joint (a six-channel joint)."""
    rng = np.random.default_rng(seed)
    names = ("root", "a", "a1", "b", "b1", "c")
    parents = [-1, 0, 1, 0, 3, 0]
    offsets = rng.normal(size=(6, 3)) * 0.2
    chans = (("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation"),) + (
        ("Zrotation", "Yrotation", "Xrotation"),
    ) * 5
    chans = (
        chans[:3]
        + (("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation"),)
        + chans[4:]
    )
    sk = Skeleton(names, parents, offsets, chans, [2, 4, 5], rng.normal(size=(3, 3)) * 0.1)
    rot = SO3G.exp(rng.normal(size=(frames, 6, 3)))
    jt = np.repeat(offsets[None], frames, axis=0) + rng.normal(size=(frames, 6, 3)) * 0.01
    return Motion(sk, 30.0, rng.normal(size=(frames, 3)), rot, joint_translations=jt, metres_per_unit=1.0)


def test_a_change_of_rest_frames_keeps_the_world_motion():
    """Positions (joints and end sites) unchanged to rounding, global rotations ``G C``: the
    formula checked against the globals, whatever the rotations."""
    m = branching()
    c = SO3G.exp(np.random.default_rng(1).normal(size=(6, 3)))
    out = change_rest_frames(m, c)
    np.testing.assert_allclose(
        forward_kinematics(out, end_sites=True), forward_kinematics(m, end_sites=True), atol=1e-12
    )
    np.testing.assert_allclose(global_rotations(out), global_rotations(m) @ c[None], atol=1e-12)
    with pytest.raises(ValueError, match=r"frames: expected shape \(6, 3, 3\)"):
        change_rest_frames(m, c[:5])
    with pytest.raises(ValueError, match="frames"):  # a scaling is no change of frames
        change_rest_frames(m, 2.0 * c)


def test_towards_a_reference_undoes_a_known_change():
    """B is A in turned rest frames: re-expressed towards A, its bones point as A's again and
    a joint with bones in several directions gets exactly the inverse turn back (its
    rotations are A's); a single bone's twist is free (smallest rotation)."""
    a = branching(seed=2)
    c = SO3G.exp(np.random.default_rng(3).normal(size=(6, 3)))
    b = change_rest_frames(a, c)
    assert rest_pose_difference(a.skeleton, b.skeleton)[0] > 20.0
    back = rest_frames_towards(b.skeleton, a.skeleton)
    np.testing.assert_allclose(back[0], c[0].T, atol=1e-9)  # the root: three bones
    again = change_rest_frames(b, back)
    assert rest_pose_difference(a.skeleton, again.skeleton)[0] < 1e-6
    np.testing.assert_allclose(again.rotations[:, 0], a.rotations[:, 0], atol=1e-9)
    np.testing.assert_allclose(
        forward_kinematics(again, end_sites=True), forward_kinematics(a, end_sites=True), atol=1e-12
    )
    angle, bone = rest_pose_difference(a.skeleton, b.skeleton, min_length=10.0)
    assert (angle, bone) == (0.0, "")  # every bone shorter than that: none compared


@pytest.mark.mocap
def test_two_conversions_of_cmu_are_brought_to_one_rest_pose(mocap_dir):
    """CMU 107_02_30hz and 07_01 share their joint names, not their rest pose (feet 160
    degrees apart): re-expressed, 07_01's bones point as 107_02's (within 1e-5 degrees) and it
    moves exactly as before; 07_01 and 08_02 (one conversion) are left as they are."""
    from elastic_motion.apps.blend import blend_motions
    from elastic_motion.apps.prepare import REST_POSE_CHANGED, prepare_motions
    from elastic_motion.notes import of_kind

    bvh = mocap_dir / "cmu" / "bvh"
    a, b = read_motion(bvh / "107_02_30hz.bvh"), read_motion(bvh / "07_01.bvh")
    angle, bone = rest_pose_difference(a.skeleton, b.skeleton, min_length=0.05 / b.metres_per_unit)
    assert angle == pytest.approx(160.0, abs=0.1) and bone in ("RightFoot", "LeftFoot")
    moved = change_rest_frames(b, rest_frames_towards(b.skeleton, a.skeleton))
    assert rest_pose_difference(a.skeleton, moved.skeleton, min_length=0.05 / b.metres_per_unit)[0] < 1e-5
    np.testing.assert_allclose(forward_kinematics(moved), forward_kinematics(b), atol=1e-9)
    prep = prepare_motions([bvh / "107_02_30hz.bvh", bvh / "07_01.bvh"])
    (note,) = of_kind(prep.notes, REST_POSE_CHANGED)
    assert str(note).startswith("07_01: rest pose unlike 107_02_30hz's (bone")
    assert note.data["input"] == "07_01" and note.data["like"] == "107_02_30hz"
    assert note.data["bone"] == bone and note.data["angle_deg"] == pytest.approx(angle)
    assert note.data["after_deg"] < 1
    same = prepare_motions([bvh / "07_01.bvh", bvh / "08_02.bvh"])
    assert not of_kind(same.notes, REST_POSE_CHANGED)
    # the blend stands: the hips at the inputs' height (a blend in the two rest poses sat
    # 0.17 m above the floor, the clean-up settling it by 0.7 m)
    res = blend_motions(prep, 0.5, warp="dp")
    hips = [np.median(m.root_translation[:, 1]) for m in (*prep.motions, res.motion)]
    assert abs(hips[2] - (hips[0] + hips[1]) / 2) < 0.05


def test_towards_matches_bones_by_name_and_handles_lines_and_boneless_joints():
    """Bones are matched by the child's name (siblings in another order: the same frames);
    two opposite bones (shoulders) still give their turn; micrometre bones are left out with
    ``min_length``; a joint without a bone to compare turns with its parent."""
    names = ("root", "l", "r", "hand", "finger")
    parents = [-1, 0, 0, 1, 3]
    off = np.array([[0, 0, 0], [1.0, 0, 0], [-1.0, 0, 0], [0, -0.5, 0], [0, 0, 0]])  # finger: 0 long
    chans = (("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation"),) + (
        ("Zrotation", "Yrotation", "Xrotation"),
    ) * 4
    ref = Skeleton(names, parents, off, chans)
    turn = SO3G.exp(np.array([0.0, np.pi / 2, 0.0]))  # 90 degrees about y
    sk = Skeleton(names, parents, off @ turn.T, chans)
    c = rest_frames_towards(sk, ref)
    np.testing.assert_allclose(c[0] @ off[1], turn @ off[1], atol=1e-12)  # opposite bones: still turned
    np.testing.assert_allclose(c[3], c[1], atol=1e-12)  # the hand's only bone has no length
    # siblings listed the other way round: the same frames, joint by joint
    swapped = Skeleton(
        ("root", "r", "l", "hand", "finger"), [-1, 0, 0, 2, 3], off[[0, 2, 1, 3, 4]] @ turn.T, chans
    )
    c2 = rest_frames_towards(swapped, ref)
    np.testing.assert_allclose(c2[[0, 2, 1, 3, 4]], c, atol=1e-12)
    # a micrometre bone in another direction decides nothing once left out
    tiny = off.copy()
    tiny[2] = [0.0, 1e-6, 0.0]
    c3 = rest_frames_towards(Skeleton(names, parents, tiny, chans), ref, min_length=1e-3)
    np.testing.assert_allclose(c3[0], np.eye(3), atol=1e-12)


@pytest.mark.mocap
def test_one_conversion_gives_identity_frames_and_hands_turn_with_their_forearms(mocap_dir):
    """07_01 and 08_02 (one conversion) need no turn once micrometre bones are left out (with
    them the hips turned 180 degrees); 07_01 towards 107_02_30hz turns each hand, whose bones
    have no length, with its forearm."""
    bvh = mocap_dir / "cmu" / "bvh"
    a, b, x = (read_motion(bvh / f) for f in ("07_01.bvh", "08_02.bvh", "107_02_30hz.bvh"))
    shortest = 0.05 / b.metres_per_unit
    same = rest_frames_towards(b.skeleton, a.skeleton, min_length=shortest)
    assert np.degrees(np.linalg.norm(SO3G.log(same), axis=-1)).max() < 30.0
    c = rest_frames_towards(a.skeleton, x.skeleton, min_length=shortest)
    names = a.skeleton.names
    for side in ("Left", "Right"):
        np.testing.assert_allclose(
            c[names.index(f"{side}Hand")], c[names.index(f"{side}ForeArm")], atol=1e-12
        )
