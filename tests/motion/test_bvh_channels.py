"""Every channel layout a BVH file may have writes back as it came (issue 32).

A joint may have 0 to 3 rotation channels in any order and position channels anywhere
(before or after the rotations, on any joint, some axes only). Reading a file and writing
it back must keep each joint's channels and give the same rotations and positions, at
any angle: a joint with two rotation channels whose second angle passes +-90 degrees used
to be refused. A computed rotation those channels cannot hold is written as the nearest
one they hold, and :func:`rotation_channel_fit` says by how much.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from motion_testlib import geodesic_deg
from scipy.optimize import minimize

from elastic_motion.motion import (
    Motion,
    Skeleton,
    forward_kinematics,
    read_bvh,
    rotation_channel_fit,
    write_bvh,
)
from elastic_motion.motion.rotations import euler_to_matrix, nearest_euler

ROT = ("Xrotation", "Yrotation", "Zrotation")
POS = ("Xposition", "Yposition", "Zposition")


def bvh_text(
    names: list[str],
    parents: list[int],
    offsets: np.ndarray,
    channels: list[tuple[str, ...]],
    values: np.ndarray,
    frame_time: float = 1 / 30,
) -> str:
    """The text of a BVH file, written here (not by ``write_bvh``, which is under test).

    Joints must be in depth-first order (``parents[j]`` an ancestor of ``j - 1`` or itself);
    ``values`` ``(F, C)`` are the frame lines, one column per channel in joint order.
    """
    out = ["HIERARCHY"]
    depth: list[int] = []
    open_: list[int] = []
    for j, p in enumerate(parents):
        while open_ and open_[-1] != p:
            k = open_.pop()
            out.append("\t" * depth[k] + "}")
        depth.append(0 if p < 0 else depth[p] + 1)
        ind = "\t" * depth[j]
        out.append(f"{ind}{'ROOT' if p < 0 else 'JOINT'} {names[j]}")
        out.append(f"{ind}{{")
        out.append(f"{ind}\tOFFSET {' '.join(repr(float(v)) for v in offsets[j])}")
        out.append(f"{ind}\tCHANNELS {len(channels[j])} {' '.join(channels[j])}".rstrip())
        if j == len(parents) - 1 or parents[j + 1] != j:  # a leaf: an end site
            out += [f"{ind}\tEnd Site", f"{ind}\t{{", f"{ind}\t\tOFFSET 0 1.5 0", f"{ind}\t}}"]
        open_.append(j)
    while open_:
        k = open_.pop()
        out.append("\t" * depth[k] + "}")
    out += ["MOTION", f"Frames: {values.shape[0]}", f"Frame Time: {frame_time!r}"]
    out += [" ".join(f"{v:.4f}" for v in row) for row in values]
    return "\n".join(out) + "\n"


@st.composite
def layouts(draw):
    """A small skeleton in depth-first order with any channel layout, and its frames."""
    n = draw(st.integers(1, 4))
    parents = [-1]
    chain = [0]  # the ancestors of the last joint and itself: depth-first parents
    for _ in range(1, n):
        p = draw(st.sampled_from(chain))
        chain = chain[: chain.index(p) + 1] + [len(parents)]
        parents.append(p)
    channels = []
    for _ in range(n):
        rot = draw(st.permutations(ROT))[: draw(st.integers(0, 3))]
        pos = draw(st.permutations(POS))[: draw(st.sampled_from([0, 0, 1, 2, 3]))]
        mixed = list(rot)
        for c in pos:  # position channels anywhere: before, between or after the rotations
            mixed.insert(draw(st.integers(0, len(mixed))), c)
        channels.append(tuple(mixed))
    frames = draw(st.integers(1, 5))
    n_ch = sum(len(c) for c in channels)
    special = st.sampled_from([90.0, -90.0, 180.0, -180.0, 89.9999, 90.0001, 270.0, 0.0])
    angle = st.one_of(special, st.floats(-720.0, 720.0))
    length = st.floats(-50.0, 50.0)
    kinds = [c in ROT for ch in channels for c in ch]
    values = np.array(
        [[draw(angle if is_rot else length) for is_rot in kinds] for _ in range(frames)]
    ).reshape(frames, n_ch)
    offsets = np.array(draw(st.lists(st.lists(length, min_size=3, max_size=3), min_size=n, max_size=n)))
    return [f"j{k}" for k in range(n)], parents, offsets, channels, np.round(values, 4)


@settings(
    max_examples=100,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(layouts())
def test_every_layout_writes_back_exactly(tmp_path, layout):
    names, parents, offsets, channels, values = layout
    src = tmp_path / "in.bvh"
    src.write_text(bvh_text(names, parents, offsets, channels, values))
    m = read_bvh(src, units="m")
    assert rotation_channel_fit(m) == {}  # a motion read from a file fits its own channels
    r = read_bvh(write_bvh(m, tmp_path / "out.bvh"), units="m")
    assert r.skeleton.channels == m.skeleton.channels == tuple(channels)
    np.testing.assert_allclose(r.rotations, m.rotations, rtol=0, atol=1e-9)
    span = 1.0 + np.abs(values).max(initial=0.0) + np.abs(offsets).sum()
    np.testing.assert_allclose(
        forward_kinematics(r, end_sites=True),
        forward_kinematics(m, end_sites=True),
        rtol=0,
        atol=1e-10 * span,
    )
    np.testing.assert_allclose(r.local_translations(), m.local_translations(), rtol=0, atol=1e-8)


def _chain(channels: list[tuple[str, ...]]) -> tuple[list[str], list[int], np.ndarray]:
    n = len(channels)
    offsets = np.zeros((n, 3))
    offsets[1:, 1] = 1.0
    return [f"j{k}" for k in range(n)], list(range(-1, n - 1)), offsets


def test_two_channels_past_90_degrees_and_one_channel_past_180_stay_continuous(tmp_path):
    """The second of two rotation channels sweeping through 90 and 180 degrees, a single
    channel spinning past 180: written with the same channels, continuous, same rotations."""
    f = 60
    sweep = np.linspace(-170.0, 350.0, f)  # through -90, 90, 180, 270
    channels = [
        ("Xposition", "Yposition", "Zposition", "Yrotation"),
        ("Xrotation", "Zrotation"),
        ("Zrotation",),
    ]
    values = np.zeros((f, 7))
    values[:, 3] = np.round(sweep, 4)  # one channel past 180
    values[:, 4] = np.round(30 * np.sin(np.linspace(0, 6, f)), 4)
    values[:, 5] = np.round(sweep, 4)  # second of two past +-90 and 180
    values[:, 6] = np.round(-sweep, 4)
    names, parents, offsets = _chain(channels)
    (tmp_path / "in.bvh").write_text(bvh_text(names, parents, offsets, channels, values))
    m = read_bvh(tmp_path / "in.bvh", units="m")
    out = write_bvh(m, tmp_path / "out.bvh")
    r = read_bvh(out, units="m")
    assert r.skeleton.channels == m.skeleton.channels
    assert geodesic_deg(r.rotations, m.rotations).max() < 1e-7
    frames = np.array([ln.split() for ln in out.read_text().splitlines()[-f:]], dtype=float)
    np.testing.assert_allclose(frames[:, 3:], values[:, 3:], atol=1e-7)  # continuous: the file's own
    assert np.abs(np.diff(frames[:, 3:], axis=0)).max() < 10.0


def test_three_channels_are_written_continuous_through_90_degrees(tmp_path):
    """The middle of three angles passing 90 degrees: no flip to the other Euler solution."""
    f = 40
    ang = np.zeros((f, 3))
    ang[:, 0] = np.linspace(0, 40, f)
    ang[:, 1] = np.linspace(60, 130, f)
    ang[:, 2] = np.linspace(-20, 20, f)
    channels = [("Zrotation", "Xrotation", "Yrotation")]
    names, parents, offsets = _chain(channels)
    (tmp_path / "in.bvh").write_text(bvh_text(names, parents, offsets, channels, np.round(ang, 4)))
    m = read_bvh(tmp_path / "in.bvh", units="m")
    out = write_bvh(m, tmp_path / "out.bvh")
    frames = np.array([ln.split() for ln in out.read_text().splitlines()[-f:]], dtype=float)
    assert np.abs(np.diff(frames, axis=0)).max() < 5.0
    assert geodesic_deg(read_bvh(out).rotations, m.rotations).max() < 1e-7


@pytest.mark.parametrize("axes", ["X", "Z", "XZ", "ZX", "XY", "YX", "YZ", "ZY"])
def test_nearest_euler_is_exact_on_its_family_and_nearest_off_it(axes):
    rng = np.random.default_rng(len(axes) * 7 + ord(axes[0]))
    order = axes + "".join(a for a in "XYZ" if a not in axes)
    n = len(axes)
    ang = np.zeros((400, 3))
    ang[:, :n] = rng.uniform(-np.pi, np.pi, (400, n))
    ang[:8, n - 1] = [np.pi / 2, -np.pi / 2, np.pi, -np.pi, 0.0, np.pi / 2 - 1e-12, 3.0, -3.0]
    rot = euler_to_matrix(ang, order)
    got = nearest_euler(rot, axes)
    back = np.zeros((400, 3))
    back[:, :n] = got
    np.testing.assert_allclose(euler_to_matrix(back, order), rot, atol=1e-14)
    # off the family: no rotation of the family is nearer than the one found
    off = euler_to_matrix(rng.uniform(-np.pi, np.pi, (5, 3)), order)
    got = nearest_euler(off, axes)
    for k in range(5):

        def dist(t, k=k):
            full = np.zeros(3)
            full[:n] = t
            return geodesic_deg(euler_to_matrix(full, order), off[k])

        best = min(
            minimize(dist, x0, method="Nelder-Mead", options={"xatol": 1e-10, "fatol": 1e-12}).fun
            for x0 in [got[k], *rng.uniform(-np.pi, np.pi, (2, n))]
        )
        assert dist(got[k]) <= best + 1e-6


def test_a_rotation_the_channels_cannot_hold_is_written_as_the_nearest_they_hold(tmp_path):
    """A computed motion leaving a 2-channel joint's family: the channels are kept, the
    nearest rotation written, and rotation_channel_fit gives the distance."""
    channels = [
        ("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation"),
        ("Xrotation", "Zrotation"),
    ]
    sk = Skeleton(["r", "k"], [-1, 0], [[0, 0, 0], [0, 1, 0]], channels, [1], [[0, 1, 0]])
    f = 20
    ang = np.zeros((f, 2, 3))
    ang[:, 1, 0] = np.linspace(-1, 1, f)
    ang[:, 1, 1] = np.linspace(1.0, 2.5, f)  # past 90 degrees
    ang[:, 1, 2] = 0.1  # a twist about y the channels cannot hold
    rot = np.stack([euler_to_matrix(ang[:, 0], "ZXY"), euler_to_matrix(ang[:, 1], "XZY")], axis=1)
    m = Motion(sk, 30.0, np.zeros((f, 3)), rot)
    fit = rotation_channel_fit(m)
    assert list(fit) == ["k"] and 1.0 < fit["k"] <= np.degrees(0.1) + 1e-9
    r = read_bvh(write_bvh(m, tmp_path / "k.bvh"))
    assert r.skeleton.channels == sk.channels
    gap = geodesic_deg(r.rotations[:, 1], m.rotations[:, 1])
    assert gap.max() == pytest.approx(fit["k"], abs=1e-6)
    # the nearest: the written rotation is no farther than the one without the twist
    assert (
        gap <= geodesic_deg(euler_to_matrix(ang[:, 1] * [1, 1, 0], "XZY"), m.rotations[:, 1]) + 1e-7
    ).all()
    # three channels on request
    r3 = read_bvh(write_bvh(m, tmp_path / "k3.bvh", euler_orders="ZYX"))
    assert geodesic_deg(r3.rotations, m.rotations).max() < 1e-6


def test_position_channels_are_added_for_a_move_along_an_axis_without_one(tmp_path):
    """A joint with a Yposition channel only, moved along x by a computation: written with
    the missing position channels (never refused, never dropped); unmoved: as it came."""
    channels = [("Xposition", "Yposition", "Zposition", "Yrotation"), ("Xrotation", "Yposition")]
    sk = Skeleton(["r", "k"], [-1, 0], [[0, 0, 0], [0.5, 1, 0]], channels, [1], [[0, 1, 0]])
    f = 5
    jt = np.tile([[0.0, 0.0, 0.0], [0.5, 1.0, 0.0]], (f, 1, 1))
    jt[:, 1, 1] = np.linspace(1, 2, f)
    rot = np.tile(np.eye(3), (f, 2, 1, 1))
    m = Motion(sk, 30.0, np.zeros((f, 3)), rot, joint_translations=jt)
    assert read_bvh(write_bvh(m, tmp_path / "same.bvh")).skeleton.channels == tuple(channels)
    jt2 = jt.copy()
    jt2[:, 1, 0] += np.linspace(0, 0.3, f)
    moved = m.replace(joint_translations=jt2)
    r = read_bvh(write_bvh(moved, tmp_path / "moved.bvh"))
    assert r.skeleton.channels[1] == ("Xrotation", "Yposition", "Xposition", "Zposition")
    np.testing.assert_allclose(r.local_translations(), moved.local_translations(), atol=1e-9)


def _biped_file(path, duration: float, freq: float, phase: float, speed: float) -> None:
    """A walking biped (Y up, metres) with 1-, 2- and 3-channel joints, unusual orders and a
    non-root joint's position channels after its rotation; a hand whose second of two
    rotation channels swings through 90 degrees."""
    names = ["Hips", "LeftUpLeg", "LeftLeg", "LeftFoot", "RightUpLeg", "RightLeg", "RightFoot"]
    names += ["Spine", "Head", "LeftHand"]
    parents = [-1, 0, 1, 2, 0, 4, 5, 0, 7, 7]
    offsets = np.array(
        [[0, 0, 0], [0.1, -0.05, 0], [0, -0.42, 0], [0, -0.42, 0], [-0.1, -0.05, 0], [0, -0.42, 0]]
        + [[0, -0.42, 0], [0, 0.2, 0], [0, 0.35, 0], [0.25, 0.25, 0]],
        dtype=float,
    )
    channels = [
        ("Xposition", "Yposition", "Zposition", "Yrotation", "Xrotation", "Zrotation"),
        ("Yrotation", "Xrotation", "Zrotation"),
        ("Zrotation", "Xrotation"),
        ("Xrotation",),
        ("Xrotation", "Yrotation", "Zrotation"),
        ("Xrotation", "Zrotation"),
        ("Xrotation",),
        ("Yrotation", "Xrotation", "Zrotation"),
        ("Yrotation", "Xposition", "Yposition", "Zposition"),
        ("Xrotation", "Zrotation"),
    ]
    t = np.arange(round(duration * 30) + 1) / 30
    w = 2 * np.pi * freq * t + phase
    hip = np.degrees(0.5 * np.sin(w))
    knee_l = np.degrees(0.6 * np.maximum(np.sin(w + 0.5), 0.0))
    knee_r = np.degrees(0.6 * np.maximum(-np.sin(w + 0.5), 0.0))
    zero = np.zeros_like(t)
    cols = [zero, zero + 0.95, speed * t, zero, zero, zero]  # Hips
    cols += [zero, -hip, zero, 5 * np.sin(w), knee_l, 10 * np.sin(w)]  # LeftUpLeg, LeftLeg
    cols += [zero, hip, zero, zero, knee_r, zero, 3 * np.sin(2 * w)]  # LeftFoot ... Spine (Y)
    cols += [zero, zero, 4 * np.sin(w), zero, zero + 0.35, zero]  # Spine, Head (position channels, still)
    cols += [20 * np.sin(w), 100 + 25 * np.sin(w)]  # LeftHand: Z through 90 degrees
    values = np.stack(cols, axis=1)
    assert values.shape[1] == sum(len(c) for c in channels)
    path.write_text(bvh_text(names, parents, offsets, channels, values))


def test_blend_and_loop_of_valid_files_with_two_channel_joints_exit_0(tmp_path, capsys):
    from elastic_motion.cli import main

    a, b = tmp_path / "a.bvh", tmp_path / "b.bvh"
    _biped_file(a, 2.0, 1.0, 0.0, 1.0)
    _biped_file(b, 2.4, 1.25, 0.3, 1.3)
    layout = read_bvh(a).skeleton.channels
    for argv in (
        ["blend", a, b, "-o", tmp_path / "ab.bvh", "--no-metrics", "--json", tmp_path / "ab.json", "-q"],
        ["loop", a, "-o", tmp_path / "loop.bvh", "--force", "-q"],
    ):
        code = main([str(x) for x in argv])
        err = capsys.readouterr().err
        assert code == 0, err
        out = read_bvh(argv[4] if argv[0] == "blend" else argv[3])
        assert out.skeleton.channels == layout  # the file's own channels, exactly
    # the blend leaves the hand's 2-channel family a little: the report says so and by how much
    notes = json.loads((tmp_path / "ab.json").read_text())["notes"]
    fit = [n for n in notes if "nearest rotations" in n]
    assert len(fit) == 1 and "LeftHand (Xrotation Zrotation)" in fit[0]


def test_the_mean_command_says_when_it_writes_nearest_rotations(tmp_path, capsys):
    """``mean`` writes with write_bvh like blend and loop: it keeps the 2-channel layout and
    its report says which joints got the nearest rotation they hold."""
    from elastic_motion.cli import main

    a, b = tmp_path / "a.bvh", tmp_path / "b.bvh"
    _biped_file(a, 2.0, 1.0, 0.0, 1.0)
    _biped_file(b, 2.4, 1.25, 0.3, 1.3)
    out, report = tmp_path / "mean.bvh", tmp_path / "mean.json"
    code = main([str(x) for x in ("mean", a, b, "-o", out, "--json", report, "-q")])
    assert code == 0, capsys.readouterr().err
    assert read_bvh(out).skeleton.channels == read_bvh(a).skeleton.channels
    notes = json.loads(report.read_text())["output_notes"]
    assert len(notes) == 1 and "LeftHand (Xrotation Zrotation)" in notes[0]
