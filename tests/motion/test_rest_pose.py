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
    from elastic_motion.apps.prepare import prepare_motions

    bvh = mocap_dir / "cmu" / "bvh"
    a, b = read_motion(bvh / "107_02_30hz.bvh"), read_motion(bvh / "07_01.bvh")
    angle, bone = rest_pose_difference(a.skeleton, b.skeleton, min_length=0.05 / b.metres_per_unit)
    assert angle == pytest.approx(160.0, abs=0.1) and bone in ("RightFoot", "LeftFoot")
    moved = change_rest_frames(b, rest_frames_towards(b.skeleton, a.skeleton))
    assert rest_pose_difference(a.skeleton, moved.skeleton, min_length=0.05 / b.metres_per_unit)[0] < 1e-5
    np.testing.assert_allclose(forward_kinematics(moved), forward_kinematics(b), atol=1e-9)
    prep = prepare_motions([bvh / "107_02_30hz.bvh", bvh / "07_01.bvh"])
    assert any("07_01: rest pose unlike 107_02_30hz's (bone" in n for n in prep.notes)
    same = prepare_motions([bvh / "07_01.bvh", bvh / "08_02.bvh"])
    assert not any("rest pose" in n for n in same.notes)
    # the blend stands: the hips at the inputs' height (a blend in the two rest poses sat
    # 0.17 m above the floor, the clean-up settling it by 0.7 m)
    res = blend_motions(prep, 0.5, warp="dp")
    hips = [np.median(m.root_translation[:, 1]) for m in (*prep.motions, res.motion)]
    assert abs(hips[2] - (hips[0] + hips[1]) / 2) < 0.05
