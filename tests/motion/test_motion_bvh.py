"""BVH reading and writing: real files, every channel layout, round trips."""

from __future__ import annotations

import os
import re
import stat

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from motion_testlib import CMU_BVH, NaiveBvh, bandai_files, geodesic_deg

from elastic_motion.motion import (
    Motion,
    Skeleton,
    forward_kinematics,
    read_asf_amc,
    read_bvh,
    read_deepmimic,
    rotation_channel_fit,
    write_bvh,
)
from elastic_motion.motion.bvh import guess_units, snap_fps
from elastic_motion.motion.rotations import euler_to_matrix

pytestmark = pytest.mark.filterwarnings("error")


def _header(path):
    text = path.read_text()
    frames = int(re.search(r"Frames:\s*(\d+)", text).group(1))
    frame_time = float(re.search(r"Frame Time:\s*(\S+)", text).group(1))
    joints = len(re.findall(r"^\s*(?:ROOT|JOINT)\s", text, flags=re.M))
    channels = [ln.split()[2:] for ln in text.splitlines() if ln.strip().startswith("CHANNELS")]
    return frames, frame_time, joints, channels


def _all_bvh(mocap):
    return [mocap / "cmu" / "bvh" / f for f in CMU_BVH] + bandai_files(mocap)


def test_every_real_bvh_file_matches_its_header(mocap_dir):
    files = _all_bvh(mocap_dir)
    assert len(files) == 23
    for path in files:
        m = read_bvh(path)
        frames, frame_time, joints, channels = _header(path)
        assert m.n_frames == frames, path.name
        assert m.n_joints == joints, path.name
        assert [list(c) for c in m.skeleton.channels] == channels, path.name
        assert m.skeleton.n_channels == sum(len(c) for c in channels)
        expected_fps = 30.0 if ("30hz" in path.name or "bandai" in str(path)) else 120.0
        assert m.fps == expected_fps, path.name
        assert abs(1.0 / m.fps - frame_time) < 1e-6
        assert m.up_axis == "y"


@pytest.mark.parametrize("name", CMU_BVH)
def test_fk_agrees_with_pybvh_on_cmu_files(mocap_dir, name):
    pybvh = pytest.importorskip("pybvh")
    path = mocap_dir / "cmu" / "bvh" / name
    m = read_bvh(path)
    ref = pybvh.read_bvh_file(path, world_up="+y")
    assert ref.frame_count == m.n_frames
    assert [n.name for n in ref.nodes if not n.is_end_site()] == list(m.skeleton.names)
    np.testing.assert_allclose(forward_kinematics(m), ref.joint_positions(), rtol=0, atol=1e-9)


def test_fk_agrees_with_naive_reference_on_bandai_position_channels(mocap_dir):
    # pybvh does not model position channels on non-root joints: use the naive parser.
    path = mocap_dir / "bandai" / "dataset-1_dash_normal_001.bvh"
    m = read_bvh(path)
    assert m.joint_translations is not None
    ref = NaiveBvh(path)
    pos = forward_kinematics(m)
    for f in (0, 7, m.n_frames - 1):
        expected = ref.positions(f)
        got = {n: pos[f, k] for k, n in enumerate(m.skeleton.names)}
        for n in expected:
            np.testing.assert_allclose(got[n], expected[n], atol=1e-9, err_msg=n)


# ------------------------------------------------------------------------------------------
# Channel layouts and syntax
# ------------------------------------------------------------------------------------------
SYNTHETIC = """HIERARCHY
ROOT Hips {
\tOFFSET 1 2 3
  CHANNELS 6 Zrotation Xposition Yposition Xrotation Zposition Yrotation
  JOINT Spine
  {
    OFFSET 0 .5 0
    CHANNELS 0
    JOINT Neck { OFFSET 0 1. 0 CHANNELS 3 Xrotation Yrotation Zrotation
      End Site { OFFSET 0 1 0 }
    }
  }

  JOINT Leg
  {
    OFFSET 1 -1 0
    CHANNELS 4 Yposition Zrotation Xposition Xrotation
    End Site
    {
      OFFSET 0 -2 0
    }
    End Site { OFFSET 0 0 1e-1 }
  }
}
MOTION
Frames:\t3
Frame Time: .25

10 .5 -.25 20 1. 30    40 50 60    -1.5 70 2.5 80
-10 .5 -.25 -20 1. 30  -40 50 -60  -1.5 -70 2.5 -80

0 0 0 0 0 0  0 0 0  0 0 0 0
"""


@pytest.mark.parametrize("newline", ["\n", "\r\n", "\r"])
def test_mixed_channel_layouts_and_free_syntax(tmp_path, newline):
    path = tmp_path / "syn.bvh"
    path.write_bytes(SYNTHETIC.replace("\n", newline).encode())
    m = read_bvh(path, units="m")
    sk = m.skeleton
    assert sk.names == ("Hips", "Spine", "Neck", "Leg")
    assert [len(c) for c in sk.channels] == [6, 0, 3, 4]
    assert sk.euler_orders == ("ZXY", "XYZ", "XYZ", "ZXY")
    assert m.n_frames == 3 and m.fps == 4.0
    np.testing.assert_array_equal(sk.end_site_parents, [2, 3, 3])
    np.testing.assert_allclose(sk.end_site_offsets[2], [0, 0, 0.1])
    # Root: position channels replace the offset; rotation Z(10) X(20) Y(30) intrinsic.
    np.testing.assert_allclose(m.root_translation[0], [0.5, -0.25, 1.0])
    np.testing.assert_allclose(
        m.rotations[0, 0], euler_to_matrix(np.radians([10, 20, 30]), "ZXY"), atol=1e-15
    )
    # Leg: Yposition and Xposition channels; Z keeps the offset's 0.
    np.testing.assert_allclose(m.joint_translations[0, 3], [2.5, -1.5, 0.0])
    np.testing.assert_allclose(m.joint_translations[:, 1], [[0, 0.5, 0]] * 3)
    np.testing.assert_allclose(
        m.rotations[1, 3], euler_to_matrix(np.radians([-70, -80, 0]), "ZXY"), atol=1e-15
    )
    # Forward kinematics against the naive per-frame reference.
    (tmp_path / "ref.bvh").write_text(SYNTHETIC)
    ref = NaiveBvh(tmp_path / "ref.bvh")
    pos = forward_kinematics(m)
    for f in range(3):
        expected = ref.positions(f)
        for k, n in enumerate(sk.names):
            np.testing.assert_allclose(pos[f, k], expected[n], atol=1e-12)


def test_one_rotation_channel_means_that_axis(tmp_path):
    text = (
        "HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nCHANNELS 1 Yrotation\nJOINT k\n{\nOFFSET 0 0 1\n"
        "CHANNELS 2 Xrotation Zrotation\nEnd Site\n{\nOFFSET 0 0 1\n}\n}\n}\nMOTION\nFrames: 1\n"
        "Frame Time: 0.1\n90 90 0\n"
    )
    (tmp_path / "a.bvh").write_text(text)
    m = read_bvh(tmp_path / "a.bvh")
    assert m.skeleton.euler_orders == ("YXZ", "XZY")
    np.testing.assert_allclose(m.root_translation, [[0, 0, 0]])
    pos = forward_kinematics(m, end_sites=True)[0]
    # root turns +90 about y: child at z=1 goes to x=1; the child turns +90 about x:
    # its end site (0,0,1) -> (0,-1,0) locally, unchanged by the root's y turn.
    np.testing.assert_allclose(pos, [[0, 0, 0], [1, 0, 0], [1, -1, 0]], atol=1e-15)


# ------------------------------------------------------------------------------------------
# Writing
# ------------------------------------------------------------------------------------------
ROUND_TRIP = ["cmu/bvh/131_01.bvh", "cmu/bvh/07_01.bvh", "bandai/dataset-1_dash_normal_001.bvh"]


@pytest.mark.parametrize("rel", ROUND_TRIP)
def test_round_trip_is_lossless(mocap_dir, tmp_path, rel):
    m = read_bvh(mocap_dir / rel)
    out = write_bvh(m, tmp_path / "out.bvh")
    r = read_bvh(out)
    assert r.skeleton.names == m.skeleton.names
    assert r.skeleton.channels == m.skeleton.channels
    np.testing.assert_array_equal(r.skeleton.offsets, m.skeleton.offsets)
    np.testing.assert_array_equal(r.skeleton.end_site_offsets, m.skeleton.end_site_offsets)
    assert (r.n_frames, r.fps, r.metres_per_unit) == (m.n_frames, m.fps, m.metres_per_unit)
    assert geodesic_deg(m.rotations, r.rotations).max() < 1e-6
    np.testing.assert_allclose(r.root_translation, m.root_translation, atol=1e-7)
    if m.joint_translations is not None:
        np.testing.assert_allclose(r.joint_translations, m.joint_translations, atol=1e-7)


def test_synthetic_round_trip_with_every_layout(tmp_path):
    (tmp_path / "syn.bvh").write_text(SYNTHETIC)
    m = read_bvh(tmp_path / "syn.bvh")
    r = read_bvh(write_bvh(m, tmp_path / "out.bvh"))
    assert r.skeleton.channels == m.skeleton.channels
    assert geodesic_deg(m.rotations, r.rotations).max() < 1e-6
    np.testing.assert_allclose(
        forward_kinematics(r, end_sites=True), forward_kinematics(m, end_sites=True), atol=1e-7
    )


def test_random_rotations_round_trip_to_1e6_degrees(tmp_path):
    rng = np.random.default_rng(5)
    f, j = 200, 4
    orders = ["ZXY", "XYZ", "YZX", "ZYX"]
    sk = Skeleton(
        names=["a", "b", "c", "d"],
        parents=[-1, 0, 1, 1],
        offsets=rng.normal(size=(4, 3)),
        channels=[("Xposition", "Yposition", "Zposition", *(f"{a}rotation" for a in orders[0]))]
        + [tuple(f"{a}rotation" for a in o) for o in orders[1:]],
    )
    # include rotations near gimbal lock (middle angle 90 degrees)
    angles = rng.uniform(-np.pi, np.pi, (f, j, 3))
    angles[:50, :, 1] = np.pi / 2 - 10.0 ** rng.uniform(-9, -3, (50, j))
    rot = np.stack([euler_to_matrix(angles[:, k], orders[k]) for k in range(j)], axis=1)
    m = Motion(sk, 60.0, rng.normal(size=(f, 3)), rot)
    r = read_bvh(write_bvh(m, tmp_path / "r.bvh"))
    assert geodesic_deg(m.rotations, r.rotations).max() < 1e-6


def test_asf_amc_and_deepmimic_convert_to_bvh(mocap_dir, tmp_path):
    d = mocap_dir / "cmu" / "asfamc"
    for m in (
        read_asf_amc(d / "02.asf", d / "02_01.amc"),
        read_deepmimic(mocap_dir / "deepmimic" / "humanoid3d_walk.txt"),
    ):
        r = read_bvh(write_bvh(m, tmp_path / f"{m.name}.bvh"), units=m.metres_per_unit)
        assert r.skeleton.names == m.skeleton.names and r.n_frames == m.n_frames and r.fps == m.fps
        np.testing.assert_allclose(
            forward_kinematics(r, end_sites=True), forward_kinematics(m, end_sites=True), atol=1e-6
        )


def test_skeleton_not_depth_first_is_written_depth_first(tmp_path):
    rng = np.random.default_rng(6)
    sk = Skeleton(
        names=["r", "a", "b", "a1"],
        parents=[-1, 0, 0, 1],  # a1 (child of a) after b: not depth-first
        offsets=rng.normal(size=(4, 3)),
        channels=[("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation")]
        + [("Zrotation", "Yrotation", "Xrotation")] * 3,
    )
    m = Motion(sk, 30.0, rng.normal(size=(5, 3)), euler_to_matrix(rng.uniform(-1, 1, (5, 4, 3)), "ZYX"))
    r = read_bvh(write_bvh(m, tmp_path / "x.bvh"))
    assert r.skeleton.names == ("r", "a", "a1", "b")
    perm = [0, 1, 3, 2]
    np.testing.assert_allclose(forward_kinematics(r), forward_kinematics(m)[:, perm], atol=1e-7)


def test_writer_keeps_one_channel_and_writes_the_nearest_rotation_it_holds(tmp_path):
    text = (
        "HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nCHANNELS 3 Xposition Yposition Zposition\nJOINT k\n{\n"
        "OFFSET 0 1 0\nCHANNELS 1 Zrotation\nEnd Site\n{\nOFFSET 0 1 0\n}\n}\n}\nMOTION\nFrames: 2\n"
        "Frame Time: 0.1\n0 0 0 10\n0 0 0 20\n"
    )
    (tmp_path / "k.bvh").write_text(text)
    m = read_bvh(tmp_path / "k.bvh")
    r = read_bvh(write_bvh(m, tmp_path / "same.bvh"))  # a pure Z rotation fits one channel
    assert r.skeleton.channels[1] == ("Zrotation",)
    tilted = m.rotations.copy()
    tilted[:, 1] = tilted[:, 1] @ euler_to_matrix(np.array([0.0, 0.3, 0.0]), "ZYX")
    bad = m.replace(rotations=tilted, source=())
    assert rotation_channel_fit(bad) == {"k": pytest.approx(np.degrees(0.3))}
    r = read_bvh(write_bvh(bad, tmp_path / "near.bvh"))  # the Z rotation it holds, the tilt dropped
    assert r.skeleton.channels[1] == ("Zrotation",)
    np.testing.assert_allclose(r.rotations, m.rotations, atol=1e-9)
    r = read_bvh(write_bvh(bad, tmp_path / "ok.bvh", euler_orders="ZYX"))
    assert r.skeleton.channels[1] == ("Zrotation", "Yrotation", "Xrotation")
    assert geodesic_deg(bad.rotations, r.rotations).max() < 1e-6


def test_writer_never_overwrites_an_input_and_writes_atomically(mocap_dir, tmp_path):
    src = tmp_path / "in.bvh"
    src.write_bytes((mocap_dir / "bandai" / "dataset-1_dash_normal_001.bvh").read_bytes())
    before = src.read_bytes()
    m = read_bvh(src)
    with pytest.raises(ValueError, match="refusing to overwrite the input file"):
        write_bvh(m, src)
    with pytest.raises(ValueError, match="refusing"):
        write_bvh(m, tmp_path / "." / "in.bvh")  # same file by another name
    assert src.read_bytes() == before
    out = write_bvh(m, tmp_path / "out.bvh")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in.bvh", "out.bvh"]  # no temp left
    assert stat.S_IMODE(os.stat(out).st_mode) != 0o600  # not mkstemp's private mode
    with pytest.raises(OSError):
        write_bvh(m, tmp_path / "missing" / "out.bvh")
    assert not (tmp_path / "missing").exists()


def test_units_are_guessed_from_skeleton_size(mocap_dir, tmp_path):
    assert read_bvh(mocap_dir / "cmu" / "bvh" / "131_01.bvh").units == "cmu"
    assert read_bvh(mocap_dir / "bandai" / "dataset-1_run_normal_001.bvh").units == "cm"
    dm = read_deepmimic(mocap_dir / "deepmimic" / "humanoid3d_run.txt")
    assert guess_units(dm.skeleton) == 1.0
    m = read_bvh(mocap_dir / "cmu" / "bvh" / "131_01.bvh", units="inch")
    assert m.metres_per_unit == 0.0254
    assert read_bvh(mocap_dir / "cmu" / "bvh" / "131_01.bvh", units=0.5).metres_per_unit == 0.5
    with pytest.raises(ValueError, match="units: expected one of"):
        read_bvh(mocap_dir / "cmu" / "bvh" / "131_01.bvh", units="furlong")


def test_snap_fps():
    assert snap_fps(0.0083333) == 120.0
    assert snap_fps(0.0333333) == 30.0
    assert snap_fps(1 / 29.97) == pytest.approx(29.97)
    assert snap_fps(0.01) == 100.0


def test_convert_to_bvh(mocap_dir, tmp_path):
    from elastic_motion.motion import convert_to_bvh

    out = convert_to_bvh(
        mocap_dir / "deepmimic" / "humanoid3d_spin.txt", tmp_path / "spin.bvh", euler_orders="ZXY"
    )
    m = read_bvh(out)
    assert m.n_frames == 107 and m.fps == 24 and m.units == "m"
    assert set(m.skeleton.euler_orders) == {"ZXY"}


@given(
    st.lists(st.floats(allow_nan=False, allow_infinity=False, width=64), min_size=1, max_size=30),
    st.sampled_from(["%r", "%.4f", "%.8f", "%.17g", "%.3e", "%g"]),
)
@settings(max_examples=200, deadline=None, derandomize=True)
def test_fast_number_parser_equals_python_float(values, fmt):
    from elastic_motion.motion.bvh import _POW10, _parse_frames_fast

    toks = [fmt % v for v in values]
    buf = np.frombuffer((" ".join(toks) + "\n").encode(), dtype=np.uint8)
    out = np.full(len(toks), np.nan)
    if _parse_frames_fast(buf, len(toks), 1, _POW10, out) == 0:  # else: the general path
        expected = np.array([float(t) for t in toks])
        np.testing.assert_array_equal(out, expected)
        np.testing.assert_array_equal(np.signbit(out), np.signbit(expected))


def test_values_beyond_the_fast_parser_take_the_general_path(tmp_path):
    text = SYNTHETIC.replace("10 .5 -.25 20", "10 0.12345678901234567 -2.5e-30 20")
    (tmp_path / "long.bvh").write_text(text)
    m = read_bvh(tmp_path / "long.bvh")
    assert m.root_translation[0, 0] == 0.12345678901234567
    assert m.root_translation[0, 1] == -2.5e-30


@given(st.lists(st.floats(-1e6, 1e6, allow_nan=False), min_size=1, max_size=20), st.integers(0, 9))
@settings(max_examples=100, deadline=None, derandomize=True)
def test_frame_formatter_rounds_like_printf(values, decimals):
    from elastic_motion.motion.bvh import _format_rows

    text = _format_rows(np.array([values]), decimals)
    toks = text.split()
    assert text.endswith("\n") and len(toks) == len(values)
    for tok, v in zip(toks, values, strict=True):
        assert abs(float(tok) - float(f"{v:.{decimals}f}")) <= 1.01 * 10.0**-decimals
        assert tok != "-0" and not (tok.endswith("0") and "." in tok) and not tok.endswith(".")
