"""Forward kinematics: conventions on a hand-made skeleton, plausibility on every real file."""

from __future__ import annotations

import re

import numpy as np
from motion_testlib import ASF_AMC, CMU_BVH, bandai_files, deepmimic_files

from elastic_motion.motion import (
    Motion,
    Skeleton,
    drop_tpose,
    forward_kinematics,
    global_rotations,
    merge_root,
    read_asf_amc,
    read_motion,
    to_metres,
)
from elastic_motion.motion.rotations import axis_rotation


def test_conventions_on_a_two_joint_skeleton():
    sk = Skeleton(
        names=["root", "child"],
        parents=[-1, 0],
        offsets=[[0, 0, 0], [1, 0, 0]],
        channels=[("Xposition", "Yposition", "Zposition", "Zrotation"), ("Xrotation",)],
        end_site_parents=[1],
        end_site_offsets=[[0, 1, 0]],
    )
    rot = np.stack([axis_rotation(np.pi / 2, "Z"), axis_rotation(np.pi / 2, "X")])[None]
    m = Motion(sk, 30.0, [[1.0, 2.0, 3.0]], rot)
    pos = forward_kinematics(m, end_sites=True)
    # child = root + Rz(90) (1,0,0); end = child + Rz(90) Rx(90) (0,1,0)
    np.testing.assert_allclose(pos[0], [[1, 2, 3], [1, 3, 3], [1, 3, 4]], atol=1e-15)
    np.testing.assert_allclose(global_rotations(m)[0, 1], rot[0, 0] @ rot[0, 1], atol=1e-15)
    assert forward_kinematics(m).shape == (1, 2, 3)


def _walks(mocap):
    b = mocap / "cmu" / "bvh"
    d = mocap / "cmu" / "asfamc"
    return (
        [b / f for f in ("07_01.bvh", "08_02.bvh", "09_11.bvh", "107_02_30hz.bvh", "108_01_30hz.bvh")]
        + [b / f for f in ("131_01.bvh", "131_02.bvh")]
        + [d / "02_01.amc"]
        + [p for p in bandai_files(mocap) if re.search(r"_(walk|run|dash)_", p.name)]
        + [mocap / "deepmimic" / "humanoid3d_walk.txt", mocap / "deepmimic" / "humanoid3d_run.txt"]
        + sorted((mocap / "deepmimic" / "walker").glob("*.txt"))
    )


def _points(m: Motion):
    sk = m.skeleton
    names = list(sk.names) + [sk.names[p] for p in sk.end_site_parents]
    return forward_kinematics(m, end_sites=True), names


def test_walks_are_plausible_in_metres(mocap_dir):
    files = _walks(mocap_dir)
    assert len(files) == 26
    for path in files:
        m = to_metres(drop_tpose(read_motion(path)))
        if m.skeleton.names[0] == "joint_Root":  # Bandai: a fixed reference root above the hips
            m = merge_root(m)
        assert m.up_axis == "y"
        pts, names = _points(m)
        height = pts[..., 1]
        floor = height.min()
        feet = [k for k, n in enumerate(names) if re.search(r"foot|toe|ankle", n, re.I)]
        heads = [k for k, n in enumerate(names) if re.fullmatch(r"head|neck", n, re.I)]
        # the lowest point of a walk is a foot
        assert height[:, feet].min() - floor < 0.01, path.name
        # some foot near the floor in (nearly) every frame (runs have flight phases)
        near = (height[:, feet].min(axis=1) - floor) < 0.15
        assert near.mean() > 0.7, (path.name, near.mean())
        # the hips at a human height: catches wrong units and wrong up axes
        hips = height[:, 0] - floor
        assert 0.6 < hips.mean() < 1.2, (path.name, hips.mean())
        assert (height[:, heads[-1]] > height[:, 0]).mean() > 0.99, path.name


def _constant_bones(m: Motion) -> float:
    sk = m.skeleton
    pts, _ = _points(m)
    parents = np.concatenate([sk.parents[1:], sk.end_site_parents])
    child = np.concatenate([np.arange(1, sk.n_joints), sk.n_joints + np.arange(sk.end_site_parents.size)])
    seg = np.linalg.norm(pts[:, child] - pts[:, parents], axis=-1)
    return float(np.ptp(seg, axis=0).max())


def test_bone_lengths_are_constant(mocap_dir):
    d = mocap_dir / "cmu" / "asfamc"
    for asf, amc in ASF_AMC:
        assert _constant_bones(read_asf_amc(d / asf, d / amc)) < 1e-9
    for name in CMU_BVH[:4]:
        assert _constant_bones(read_motion(mocap_dir / "cmu" / "bvh" / name)) < 1e-9
    for path in deepmimic_files(mocap_dir)[:5]:
        assert _constant_bones(read_motion(path)) < 1e-9


def test_fk_handles_joint_translations(mocap_dir):
    # Bandai joints carry their translation in position channels (not the offsets).
    m = read_motion(bandai_files(mocap_dir)[0])
    sk = m.skeleton
    pos = forward_kinematics(m)
    k = sk.index("Spine")
    p = sk.parents[k]
    glob = global_rotations(m)
    expected = pos[:, p] + np.einsum("fij,fj->fi", glob[:, p], m.joint_translations[:, k])
    np.testing.assert_allclose(pos[:, k], expected, atol=1e-12)
    assert np.abs(m.joint_translations[:, k] - sk.offsets[k]).max() < 1e-3  # ~ the offset here
    assert np.abs(m.joint_translations[:, 1] - sk.offsets[1]).max() > 10  # but not the hips
