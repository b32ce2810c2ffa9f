"""Pictures and videos: files are written (atomically), say what they should, refuse inputs."""

from __future__ import annotations

import importlib.util
import re

import numpy as np
import pytest
from blend_testlib import walker
from PIL import Image

from elastic_motion.apps.align import align_motions
from elastic_motion.apps.loop import loop_motion
from elastic_motion.apps.render import (
    gif_frame_delays,
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


# ------------------------------------------------------------------------------------------
# Pictures that do not lie
# ------------------------------------------------------------------------------------------


def _gif_delays_ms(path) -> list[int]:
    img = Image.open(path)
    out = []
    for k in range(img.n_frames):
        img.seek(k)
        out.append(img.info["duration"])
    return out


@pytest.mark.parametrize("motion_fps", [30.0, 120.0, 24.0])
def test_gif_plays_in_real_time(motion_fps, tmp_path):
    m = walker(duration=2.0, fps=motion_fps)
    out = render_animation([m], tmp_path / "m.gif", panel_size=(32, 32))
    fps = min(30.0, motion_fps)  # the default video frame rate
    delays = _gif_delays_ms(out)
    n = round(m.duration * fps) + 1  # frames drawn at 0, 1/fps, ..., duration
    assert len(delays) == n
    total = sum(delays)
    # the clip plays for its duration plus the last frame's display time
    assert abs(total - 1000.0 * m.duration) <= 1000.0 / fps + 10
    assert abs(total - 1000.0 * n / fps) <= 5
    # and every frame appears at its own time (GIF delays are whole centiseconds)
    starts = np.concatenate([[0], np.cumsum(delays)[:-1]])
    np.testing.assert_allclose(starts, 1000.0 * np.arange(n) / fps, atol=5.0 + 1e-9)


def test_gif_above_50_fps_leaves_frames_out_but_keeps_time(tmp_path):
    m = walker(duration=0.5, fps=120.0)
    delays = _gif_delays_ms(render_animation([m], tmp_path / "m.gif", fps=120, panel_size=(32, 32)))
    assert min(delays) >= 20  # browsers slow down shorter delays
    assert abs(sum(delays) - 1000.0 * (m.n_frames / 120.0)) <= 5


def test_gif_frame_delays():
    shown, delays = gif_frame_delays(np.arange(31) / 30.0, 31 / 30.0)
    assert shown.tolist() == list(range(31))
    assert set(delays.tolist()) == {3, 4} and delays.sum() == 103
    shown, delays = gif_frame_delays(np.arange(13) / 120.0, 13 / 120.0)
    assert delays.min() >= 2 and delays.sum() == 11 and shown[0] == 0
    shown, delays = gif_frame_delays([0.0], 0.001)
    assert shown.tolist() == [0] and delays.tolist() == [2]


def _tilted_panel(motion, size=(120, 120), azimuth=25.0, elevation=12.0):
    from elastic_motion.apps.render import _animation_figure

    view = side_view(motion, azimuth=azimuth, elevation=elevation)
    fig, panels = _animation_figure([motion], view, ["a long title for a small panel"], size, 1.0)
    return fig, panels[0], view


def _sideways(m, offset):
    """The same walk, moved ``offset`` metres sideways (along x): far from the world origin."""
    return m.replace(root_translation=m.root_translation + np.array([offset, 0.0, 0.0]))


@pytest.mark.parametrize("offset", [-3.0, 3.0])
def test_feet_on_the_floor_are_drawn_on_the_floor(offset):
    from elastic_motion.apps.render import _feet, _points

    m = _sideways(walker(duration=1.0), offset)
    _fig, panel, view = _tilted_panel(m)
    pts = _points(m)
    lf, rf = _feet(m)
    foot_points = [lf, rf] + [m.skeleton.n_joints + e for e in range(2)]  # ankles, toes (end sites)
    floor_h = pts[..., 1].min()
    for f in range(m.n_frames):
        panel.update(f / m.fps)
        front_y = panel.front.get_ydata()
        assert np.ptp(front_y) < 1e-12  # the front edge is level on screen
        band = panel.band.get_xy()
        back_y = band[2:4, 1].max()
        low = foot_points[int(np.argmin(pts[f, foot_points, 1]))]
        foot = view.project(pts[f, low])
        under = pts[f, low].copy()
        under[1] = floor_h  # the floor at the same place
        floor_here = view.project(under)
        assert front_y[0] - 1e-9 <= floor_here[1] <= back_y + 1e-9  # the floor band holds that place
        assert foot[1] >= front_y[0] - 1e-9  # the foot is not below the floor
        if pts[f, low, 1] - floor_h < 0.02:  # touching: drawn on the floor, not floating above it
            assert foot[1] <= back_y + 0.02


def test_panel_holds_every_pose_and_the_title_sits_above_it():
    m = walker(duration=1.0)
    hop = 0.6 * np.abs(np.sin(np.pi * m.times))  # hops up to 0.6 m
    m = _sideways(m.replace(root_translation=m.root_translation + np.outer(hop, [0.0, 1.0, 0.0])), -2.0)
    fig, panel, _view = _tilted_panel(m, size=(100, 140))
    renderer = fig.canvas.get_renderer()
    for f in range(m.n_frames):
        panel.update(f / m.fps)
        (x0, x1), (y0, y1) = panel.ax.get_xlim(), panel.ax.get_ylim()
        s = panel.scr[f]
        assert (s[:, 0] > x0).all() and (s[:, 0] < x1).all(), f
        assert (s[:, 1] > y0).all() and (s[:, 1] < y1).all(), f
    fig.canvas.draw()
    box = panel.ax.get_window_extent(renderer)
    title = panel.title.get_window_extent(renderer)
    clock = panel.clock.get_window_extent(renderer)
    assert title.y0 >= box.y1 - 0.5 and title.y1 <= fig.bbox.height + 0.5  # above the drawing, visible
    assert clock.y1 <= box.y0 + 0.5  # the clock below it


def test_seam_figure_axes_have_units(motions):
    a, _ = motions
    fig = plot_seam(a, loop_motion(a).motion, repeat=2)
    for ax in fig.axes:
        assert re.search(r"\((m|s|deg)\)", ax.get_xlabel()), ax.get_xlabel()
        assert re.search(r"\((m|s|deg)\)", ax.get_ylabel()), ax.get_ylabel()


def test_render_uses_the_documented_joints_keyword(motions, tmp_path):
    a, _ = motions
    default = render([a], tmp_path / "default.png", kind="seam", repeat=2)
    head = render([a], tmp_path / "head.png", kind="seam", repeat=2, joints=["Head"])
    px = [np.asarray(Image.open(p).convert("RGB"), dtype=int) for p in (default, head)]
    assert px[0].shape == px[1].shape and np.abs(px[0] - px[1]).sum() > 0
    with pytest.raises(KeyError, match="NoSuchJoint"):
        render([a], tmp_path / "x.png", kind="seam", repeat=2, joints=["NoSuchJoint"])


def test_render_rejects_unknown_keywords(motions, tmp_path):
    a, _ = motions
    with pytest.raises(TypeError, match=r"'colour'.*accepted: ncols, ghosts, azimuth, elevation, title"):
        render([a], tmp_path / "x.png", colour="red")
    with pytest.raises(TypeError, match=r"'joint'.*accepted: fps, panel_size"):
        render([a], tmp_path / "x.gif", joint="Head")  # a sphere keyword, not an animation one
    with pytest.raises(TypeError, match="'trace_joints'"):
        render([a], tmp_path / "x.png", kind="seam", trace_joints=["Head"])
    assert not list(tmp_path.iterdir())


# ------------------------------------------------------------------------------------------
# Options objects and the shared palette
# ------------------------------------------------------------------------------------------


def test_picture_options_are_validated_and_keywords_override_them(motions, tmp_path):
    from elastic_motion.apps.render import AnimationOptions, FeetPlotOptions, SeamPlotOptions, WarpPlotOptions
    from elastic_motion.errors import OptionError

    a, b = motions
    with pytest.raises(OptionError, match="repeat: expected at least 2 cycles"):
        SeamPlotOptions(repeat=1)
    with pytest.raises(OptionError, match="root: expected 'travel' or 'inplace'"):
        SeamPlotOptions(root="sideways")
    with pytest.raises(OptionError, match=r"fps: expected a positive frame rate; got -1\.0"):
        AnimationOptions(fps=-1)
    with pytest.raises(OptionError, match="seconds: expected a length >= 0"):
        AnimationOptions(seconds=-0.5)
    with pytest.raises(OptionError, match="ghosts"):
        FeetPlotOptions(ghosts=-1)
    with pytest.raises(OptionError, match="dpi"):
        WarpPlotOptions(dpi=0)
    assert AnimationOptions(fps=0).video_fps([a, b]) == 30.0  # 0: the motions' rate, at most 30
    # an options object and the same fields as keywords draw the same picture
    opts = SeamPlotOptions(repeat=2, title="seam", joints=["Head"])
    plot_seam(a, None, tmp_path / "opts.png", opts)
    plot_seam(a, None, tmp_path / "kw.png", repeat=2, title="seam", joints=["Head"])
    assert (tmp_path / "opts.png").read_bytes() == (tmp_path / "kw.png").read_bytes()
    plot_seam(a, None, tmp_path / "over.png", opts, title="other")  # keywords override the object
    assert (tmp_path / "over.png").read_bytes() != (tmp_path / "opts.png").read_bytes()
    with pytest.raises(OptionError, match=r"unknown option \['colour'\] of FeetPlotOptions"):
        plot_foot_trajectories([a], tmp_path / "x.png", colour="red")
    with pytest.raises(OptionError, match="SeamPlotOptions"):
        plot_seam(a, None, tmp_path / "x.png", FeetPlotOptions())
    fig = plot_foot_trajectories([a, b], None, FeetPlotOptions(ncols=1, ghosts=0))
    assert len(fig.axes) == 2 and not any(ax.collections for ax in fig.axes)  # one column, no ghosts


def test_the_palette_gives_sides_and_bone_colours():
    from elastic_motion.apps.palette import CENTRE, LEFT, RIGHT, bone_colours, joint_side

    assert [joint_side(n) for n in ("LeftUpLeg", "lfemur", "RHipJoint", "hand_r", "mixamorig:LeftArm")] == [
        "L",
        "L",
        "R",
        "R",
        "L",
    ]
    assert joint_side("Hips") == joint_side("lowerback") == ""
    m = walker(duration=0.5)
    start, end, colours = bone_colours(m)
    sk = m.skeleton
    assert len(start) == len(end) == len(colours) == sk.n_joints - 1 + len(sk.end_site_parents)
    assert {LEFT, RIGHT, CENTRE} == set(colours)
