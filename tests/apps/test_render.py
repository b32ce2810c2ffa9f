"""Pictures and videos: files are written (atomically), say what they should, refuse inputs."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest
from blend_testlib import walker
from PIL import Image

from elastic_motion.apps.align import align_motions
from elastic_motion.apps.loop import loop_motion
from elastic_motion.apps.render import (
    joint_rotation_curve,
    plot_foot_trajectories,
    plot_seam,
    plot_so3_curves,
    plot_warp,
    render,
    render_animation,
    side_view,
)


@pytest.fixture(scope="module")
def motions():
    return walker(duration=1.0, name="A"), walker(duration=1.2, freq=1.3, amp=0.7, name="B")


def test_side_view_looks_along_the_walk():
    m = walker(duration=1.0, yaw=1.0)
    v = side_view(m)
    travel = m.root_translation[-1] - m.root_translation[0]
    assert v.right @ travel > 0.99 * np.linalg.norm(travel)
    np.testing.assert_allclose(v.up, [0, 1, 0])
    xy = v.project(np.array([[0.0, 1.0, 0.0]]))
    np.testing.assert_allclose(xy, [[0.0, 1.0]], atol=1e-12)


def test_gif_animation(motions, tmp_path):
    a, b = motions
    out = render_animation([a, b], tmp_path / "ab.gif", labels=["A", "B"], fps=10, panel_size=(96, 80))
    img = Image.open(out)
    assert img.size == (192, 80)
    assert img.n_frames == 13  # the longer motion, 1.2 s at 10 fps
    img.seek(6)
    rgb = np.asarray(img.convert("RGB"))
    left, right = rgb[:, :96], rgb[:, 96:]
    assert (left.std() > 5) and (right.std() > 5)  # both panels draw something
    blue = (rgb[..., 2] > 150) & (rgb[..., 0] < 100)
    orange = (rgb[..., 0] > 200) & (rgb[..., 2] < 100)
    assert blue.sum() > 10 and orange.sum() > 10  # left limbs blue, right limbs orange
    assert not list(tmp_path.glob(".*"))  # no temporary files left


@pytest.mark.skipif(importlib.util.find_spec("imageio_ffmpeg") is None, reason="imageio-ffmpeg not installed")
def test_mp4_and_gif_from_the_same_frames(motions, tmp_path):
    a, _b = motions
    render_animation([a], tmp_path / "a.mp4", also=[tmp_path / "a.gif"], fps=10, panel_size=(64, 64))
    assert (tmp_path / "a.mp4").stat().st_size > 1000
    assert Image.open(tmp_path / "a.gif").n_frames == 11


def test_refuses_inputs_and_wrong_formats(motions, tmp_path):
    a, _ = motions
    src = tmp_path / "in.bvh"
    src.write_text("not really")
    with pytest.raises(ValueError, match="refusing to overwrite the input"):
        render_animation([a], src, protected=[src])
    with pytest.raises(ValueError, match="expected one of"):
        render_animation([a], tmp_path / "x.avi")
    with pytest.raises(ValueError, match="is a still"):
        render([a], tmp_path / "x.gif", kind="feet")
    with pytest.raises(ValueError, match="expected two motions"):
        render([a], tmp_path / "x.png", kind="warp")
    assert src.read_text() == "not really"


def test_still_pictures(motions, tmp_path):
    a, b = motions
    fig = plot_foot_trajectories([a, b], tmp_path / "feet.png", labels=["A", "B"])
    assert len([ax for ax in fig.axes if ax.lines]) == 2
    assert Image.open(tmp_path / "feet.png").size[0] > 300
    res = align_motions(a, b, landmarks=[(0.5, 0.6)])
    fig = plot_warp(res, tmp_path / "warp.png")
    x, y = fig.axes[0].lines[1].get_data()
    np.testing.assert_allclose(x[[0, -1]], [0.0, a.duration])
    np.testing.assert_allclose(y[[0, -1]], [0.0, b.duration])
    looped = loop_motion(a).motion
    fig = plot_seam(a, looped, tmp_path / "seam.png", repeat=2)
    assert len(fig.axes) == 4
    curves = [joint_rotation_curve(m, "LeftUpLeg") for m in (a, b)]
    fig = plot_so3_curves(curves, tmp_path / "sphere.png", labels=["A", "B"], vectors=((0, -1, 0),))
    line = next(ln for ln in fig.axes[0].lines if ln.get_label() == "A")
    xs, ys, zs = line.get_data_3d()
    np.testing.assert_allclose(np.sqrt(xs**2 + ys**2 + zs**2), 1.0, atol=1e-9)  # on the sphere
    for name in ("feet", "warp", "seam", "sphere"):
        assert (tmp_path / f"{name}.png").stat().st_size > 5000
    assert np.allclose(joint_rotation_curve(a, 0, frame="global"), a.rotations[:, 0])


def test_render_dispatch(motions, tmp_path):
    a, b = motions
    assert render([a, b], tmp_path / "auto.png").exists()
    assert render([a, b], tmp_path / "w.png", kind="warp").exists()
    assert render([a], tmp_path / "s.png", kind="sphere", joint="LeftUpLeg").exists()
    assert render([a], tmp_path / "seam.png", kind="seam", repeat=2).exists()


def test_video_sink_commits_atomically_and_abort_leaves_nothing(tmp_path):
    from elastic_motion.apps.render import _VideoSink

    frame = np.zeros((8, 8, 3), dtype=np.uint8)
    old = tmp_path / "clip.gif"
    old.write_bytes(b"previous")
    sink = _VideoSink(old, 10.0)
    sink.send(frame)
    sink.abort()
    assert old.read_bytes() == b"previous"  # an aborted render keeps the old file
    assert sorted(p.name for p in tmp_path.iterdir()) == ["clip.gif"]  # and no temporary
    sink = _VideoSink(old, 10.0)
    for k in range(3):
        sink.send(frame + 40 * k)
    sink.commit()
    assert old.read_bytes()[:6] == b"GIF89a"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["clip.gif"]
