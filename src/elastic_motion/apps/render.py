"""Pictures and videos of motions: skeleton animations side by side, foot trajectories (the
papers' figures), the time warp, the loop seam, and curves in SO(3) on the sphere.

Everything draws with matplotlib's object API on an Agg canvas (no pyplot state, no
window); files are written atomically (temporary file + ``os.replace``).

Conventions
-----------
* **Camera** (:class:`View`): orthographic, looking at the motions from the side. The
  screen's horizontal axis is the main floor direction of travel of the first motion (the
  principal direction of its floor-plane root path, oriented from start to end; the root's
  facing direction when it stays on the spot), turned by ``azimuth`` degrees about the up
  axis; the screen's vertical axis is the up axis, tilted by ``elevation`` degrees (points
  farther from the camera appear higher). One view is shared by all panels of a figure so
  that directions compare.
* **Colours** (:mod:`elastic_motion.apps.palette`, shared with the viewer and the demo's
  legend): left limbs blue, right limbs orange (as in paper 001 Fig. 5-6: blue and orange
  foot trajectories), the rest grey. The side of a joint comes from its name
  (:func:`~elastic_motion.apps.palette.joint_side`).
* **Feet**: the ankle joints of :func:`elastic_motion.apps.landmarks.find_leg_joints`
  (the joint located at the ankle: CMU ``LeftFoot``, DeepMimic ``left_ankle``); where
  none is found, the lowest joint of each side.
* **Floor**: the horizontal plane through the lowest point of a clip, drawn with the same
  projection as the joints (:meth:`View.project`): with a tilted camera it is a band, not
  a line, and a foot on the floor is drawn on it, wherever the foot is in depth.
* **Framing**: an animation panel's view holds every pose of its motion (limits from the
  projected points of all frames, with a margin); titles sit outside the drawing.
* **Time**: a video plays in real time: frame ``k`` is the pose at ``k / fps`` seconds and
  stays on screen ``1 / fps``; a GIF's delays, whole centiseconds, are chosen so that the
  cumulative time stays exact (:func:`gif_frame_delays`).
* **Units**: metres when the motion's unit is known; axes say their unit.
* **Video formats**: ``.gif`` through Pillow (a matplotlib dependency), ``.mp4`` (H.264)
  through the optional ``imageio-ffmpeg`` package (``pip install "elastic-motion[video]"``),
  ``.png`` a still (see :func:`render`).
* **Options**: each picture takes one frozen options object (:class:`AnimationOptions`,
  :class:`FeetPlotOptions`, :class:`WarpPlotOptions`, :class:`SeamPlotOptions`) or its fields
  as keywords (``plot_seam(a, b, repeat=2)``: :func:`elastic_motion._options.with_overrides`).

Imports of matplotlib, Pillow and imageio-ffmpeg are inside the functions that draw: they
are heavy, and the last one optional.
"""

from __future__ import annotations

import contextlib
import math
import os
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from elastic_motion._io import atomic_path, check_not_input
from elastic_motion._options import with_overrides
from elastic_motion.apps.align import align_motions
from elastic_motion.apps.landmarks import find_leg_joints
from elastic_motion.apps.palette import (
    CURVES,
    FLOOR,
    GHOST,
    LEFT,
    RIGHT,
    TRACE,
    UNIFORM,
    WARP,
    bone_colours,
    joint_side,
)
from elastic_motion.apps.prepare import PrepareOptions
from elastic_motion.apps.progress import Progress, null_progress
from elastic_motion.errors import OptionError
from elastic_motion.motion import Motion, forward_kinematics, global_rotations, select_frames
from elastic_motion.motion.looping import RootMode, check_root, cycle_transform, repeat_motion
from elastic_motion.vocabulary import RENDER_KINDS, ROTATION_FRAMES, RenderKind, RotationFrame

__all__ = [
    "FRAMES",
    "KINDS",
    "RENDER_KEYWORDS",
    "VIDEO_FORMATS",
    "AnimationOptions",
    "FeetPlotOptions",
    "RenderKind",
    "RotationFrame",
    "SeamPlotOptions",
    "View",
    "WarpPlotOptions",
    "gif_frame_delays",
    "joint_rotation_curve",
    "plot_foot_trajectories",
    "plot_seam",
    "plot_so3_curves",
    "plot_warp",
    "render",
    "render_animation",
    "render_kind",
    "save_figure",
    "side_view",
]

#: File extensions :func:`render_animation` writes.
VIDEO_FORMATS = (".gif", ".mp4")

_AXES = "xyz"

#: What :func:`render` draws: the values of :data:`RenderKind` (:mod:`elastic_motion.vocabulary`):
#: ``"auto"`` (an animation for a video file, the foot trajectories for a still), or one picture.
KINDS: tuple[str, ...] = RENDER_KINDS
#: The frame of a joint's rotation curve (:func:`joint_rotation_curve`): the values of
#: :data:`RotationFrame`, relative to its parent or to the world.
FRAMES: tuple[str, ...] = ROTATION_FRAMES


# ------------------------------------------------------------------------------------------
# Figures and files
# ------------------------------------------------------------------------------------------


def _figure(width: float, height: float, dpi: float = 100):
    """A matplotlib Figure on an Agg canvas (inches)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), dpi=dpi)
    FigureCanvasAgg(fig)
    return fig


def _check_output(path: str | os.PathLike[str], protected: Sequence[str | os.PathLike[str]]) -> Path:
    try:
        return check_not_input(path, protected)
    except ValueError as exc:
        raise ValueError(f"output: {exc}".replace("path: ", "", 1)) from None


def save_figure(
    fig: Any, path: str | os.PathLike[str], *, dpi: float | None = None, protected: Sequence[str] = ()
) -> Path:
    """Save a figure atomically (format from the extension: png, svg, pdf)."""
    out = _check_output(path, protected)
    out.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(out) as tmp:
        fig.savefig(tmp, dpi=dpi or fig.dpi)
    return out


# ------------------------------------------------------------------------------------------
# Camera, sides, feet
# ------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class View:
    """An orthographic side camera (module docstring).

    Attributes
    ----------
    right : ndarray, shape (3,)
        World direction shown to the right (horizontal).
    up : ndarray, shape (3,)
        The up axis.
    depth : ndarray, shape (3,)
        Horizontal direction away from the camera.
    elevation : float
        Radians.
    """

    right: np.ndarray
    up: np.ndarray
    depth: np.ndarray
    elevation: float = 0.0

    def project(self, p: np.ndarray) -> np.ndarray:
        """Screen coordinates ``(..., 2)`` of world points ``(..., 3)``."""
        x = p @ self.right
        y = (p @ self.up) * math.cos(self.elevation) + (p @ self.depth) * math.sin(self.elevation)
        return np.stack([x, y], axis=-1)


def _unit(v: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(v)
    return v / n if n > 0 else v


def side_view(motion: Motion, *, azimuth: float = 0.0, elevation: float = 0.0) -> View:
    """The side camera for ``motion`` (module docstring); angles in degrees."""
    up_i = _AXES.index(motion.up_axis)
    up = np.zeros(3)
    up[up_i] = 1.0
    r = motion.root_translation * (motion.metres_per_unit or 1.0)
    flat = r - np.outer(r @ up, up)
    centred = flat - flat.mean(axis=0)
    direction = np.zeros(3)
    if np.abs(centred).max() > 0.05:
        direction = np.linalg.svd(centred, full_matrices=False)[2][0]
        if direction @ (flat[-1] - flat[0]) < 0:
            direction = -direction
    if np.linalg.norm(direction) < 1e-9:
        p = (up_i + 1) % 3
        fwd = motion.rotations[0, 0][:, p]
        direction = fwd - (fwd @ up) * up
        if np.linalg.norm(direction) < 1e-9:
            direction = np.roll(up, 1)
    direction = _unit(direction)
    a = math.radians(azimuth)
    side = np.cross(up, direction)
    right = _unit(math.cos(a) * direction + math.sin(a) * side)
    depth = np.cross(up, right)
    return View(right, up, depth, math.radians(elevation))


def _feet(motion: Motion) -> tuple[int | None, int | None]:
    """Indices of the left and right ankle joints (or the lowest joint of each side)."""
    sk = motion.skeleton
    legs = find_leg_joints(sk)
    out: list[int | None] = []
    for side, name in (("L", legs.left_ankle), ("R", legs.right_ankle)):
        if name is not None:
            out.append(sk.index(name))
            continue
        cand = [j for j, n in enumerate(sk.names) if joint_side(n) == side]
        if not cand:
            out.append(None)
            continue
        rest = forward_kinematics(select_frames(motion, slice(0, 1)))[0]
        up = _AXES.index(motion.up_axis)
        out.append(int(min(cand, key=lambda j: rest[j, up])))
    return out[0], out[1]


def _points(motion: Motion) -> np.ndarray:
    """FK positions of joints and end sites, metres, ``(F, J + E, 3)``."""
    return forward_kinematics(motion, end_sites=True) * (motion.metres_per_unit or 1.0)


# ------------------------------------------------------------------------------------------
# Animation
# ------------------------------------------------------------------------------------------

#: A GIF stores each frame's delay in whole centiseconds; browsers show delays under 2 cs as
#: 10 cs, so a GIF plays at most 50 frames per second.
_GIF_MIN_DELAY_CS = 2


def _centiseconds(t: float) -> int:
    """Seconds rounded to whole centiseconds (half up)."""
    return math.floor(100.0 * t + 0.5)


def gif_frame_delays(times: Sequence[float], end: float) -> tuple[np.ndarray, np.ndarray]:
    """The frames a GIF shows, and their delays, so that it plays in real time.

    A GIF delay is a whole number of centiseconds, at least 2 (:data:`_GIF_MIN_DELAY_CS`).
    Frame ``k`` is shown from its time rounded to the centisecond to the next shown frame's,
    the last one until ``end``: the cumulative delays track the true time to within half a
    centisecond, and the total is ``end`` rounded to the centisecond. Frames closer than
    2 cs to the previous shown frame (above 50 fps) are left out.

    Parameters
    ----------
    times : sequence of float, shape (N,)
        Increasing display times of the frames, seconds; the first is normally 0.
    end : float
        Seconds at which the clip ends (after the last frame's display time).

    Returns
    -------
    shown : ndarray of int, shape (K,)
        Indices into ``times`` of the frames to write, ``K >= 1`` when ``N >= 1``.
    delays_cs : ndarray of int, shape (K,)
        Centiseconds each shown frame stays on screen; they sum to ``end`` in centiseconds
        minus the first frame's time (at least 2 cs per frame).
    """
    cs = [_centiseconds(t) for t in times]
    if not cs:
        return np.zeros(0, dtype=int), np.zeros(0, dtype=int)
    shown = [0]
    for k in range(1, len(cs)):
        if cs[k] - cs[shown[-1]] >= _GIF_MIN_DELAY_CS:
            shown.append(k)
    stop = _centiseconds(end)
    while len(shown) > 1 and stop - cs[shown[-1]] < _GIF_MIN_DELAY_CS:
        shown.pop()  # too close to the end: the previous frame stays on instead
    marks = [cs[k] for k in shown] + [max(stop, cs[shown[-1]] + _GIF_MIN_DELAY_CS)]
    return np.asarray(shown, dtype=int), np.diff(np.asarray(marks, dtype=int))


class _VideoSink:
    """Frames in, one video file out (atomically): ``send(rgb, t)``, then ``commit()`` or ``abort()``.

    A GIF keeps the frames :func:`gif_frame_delays` shows (:meth:`wants` says which, before
    they are drawn) and stores each with its delay, so that it plays in real time; an MP4
    plays at ``fps``.
    """

    def __init__(self, path: Path, fps: float) -> None:
        self.path = path
        self.fps = float(fps)
        self.ext = path.suffix.lower()
        if self.ext not in VIDEO_FORMATS:
            raise ValueError(f"output: expected a .gif or .mp4 file for an animation; got {path.name!r}")
        if not self.fps > 0:
            raise ValueError(f"fps: expected a positive frame rate; got {fps!r}")
        self._ffmpeg = None
        if self.ext == ".mp4":
            try:
                import imageio_ffmpeg
            except ImportError as exc:
                raise ValueError(
                    f"output: writing {path.name!r} (MP4) needs the optional package imageio-ffmpeg: "
                    'pip install "elastic-motion[video]"; or write a .gif'
                ) from exc
            self._ffmpeg = imageio_ffmpeg
        self._frames: list[Any] = []
        self._cs: list[int] = []  # display time of each kept GIF frame, centiseconds
        self._sent = 0
        self._last_t = 0.0
        self._writer = None
        # the shared atomic writer: frames go to a temporary file beside ``path``, renamed
        # onto it by commit(), removed by abort()
        path.parent.mkdir(parents=True, exist_ok=True)
        self._stack = contextlib.ExitStack()
        self.tmp = self._stack.enter_context(atomic_path(path))

    def wants(self, t: float) -> bool:
        """Whether a frame at ``t`` seconds would be written (a GIF skips frames < 2 cs apart)."""
        if self.ext != ".gif" or not self._cs:
            return True
        return _centiseconds(t) - self._cs[-1] >= _GIF_MIN_DELAY_CS

    def send(self, rgb: np.ndarray | None, t: float | None = None) -> None:
        """One frame, ``(H, W, 3)`` uint8, shown at ``t`` seconds (default: ``frames sent / fps``).

        ``rgb`` may be None for a frame :meth:`wants` declined (only its time is recorded).
        """
        t = self._sent / self.fps if t is None else float(t)
        if self._sent and t <= self._last_t:
            raise ValueError(f"t: frame times must increase; got {t} after {self._last_t}")
        self._sent += 1
        self._last_t = t
        if self.ext == ".gif":
            if not self.wants(t):
                return
            if rgb is None:
                raise ValueError(f"rgb: the GIF shows the frame at {t:.3f} s; got no picture")
            from PIL import Image

            img = Image.fromarray(rgb)
            if not self._frames:  # one palette for the whole clip: stable colours, fast
                self._frames.append(img.quantize(colors=96, method=Image.Quantize.MEDIANCUT))
            else:
                self._frames.append(img.quantize(palette=self._frames[0], dither=Image.Dither.NONE))
            self._cs.append(_centiseconds(t))
            return
        if rgb is None:
            raise ValueError("rgb: an MP4 needs every frame")
        if self._writer is None:
            self._writer = self._ffmpeg.write_frames(
                str(self.tmp),
                (rgb.shape[1], rgb.shape[0]),
                fps=self.fps,
                codec="libx264",
                pix_fmt_out="yuv420p",
                quality=6,
                macro_block_size=2,
                ffmpeg_log_level="error",
            )
            self._writer.send(None)
        self._writer.send(np.ascontiguousarray(rgb))

    def commit(self) -> None:
        """Write the file (a GIF lasts until one frame period after the last frame sent)."""
        if self.ext == ".gif":
            if not self._frames:
                raise ValueError(f"rendering {self.path.name}: no frames to write")
            shown, delays = gif_frame_delays([c / 100.0 for c in self._cs], self._last_t + 1.0 / self.fps)
            frames = [self._frames[k] for k in shown]
            frames[0].save(
                self.tmp,
                format="GIF",
                save_all=True,
                append_images=frames[1:],
                duration=[int(d) * 10 for d in delays],  # milliseconds, whole centiseconds
                loop=0,
                disposal=1,
            )
            self._frames = []
        elif self._writer is not None:
            self._writer.close()
        self._stack.close()

    def abort(self) -> None:
        if self._writer is not None:
            try:
                self._writer.close()
            except Exception:
                pass
        aborted = RuntimeError(f"rendering {self.path.name} was aborted")
        self._stack.__exit__(type(aborted), aborted, None)  # removes the temporary file


def _smooth(x: np.ndarray, window: int) -> np.ndarray:
    """Moving average over ``window`` frames along axis 0, edges held (``x``: ``(F, ...)``)."""
    if window <= 1 or len(x) < 2:
        return np.array(x, dtype=np.float64)
    pad = np.concatenate([np.repeat(x[:1], window, axis=0), x, np.repeat(x[-1:], window, axis=0)])
    c = np.cumsum(pad, axis=0)
    c = np.concatenate([np.zeros_like(c[:1]), c])
    lo = np.arange(len(x)) + window - window // 2
    return (c[lo + window] - c[lo]) / window


class _AnimationPanel:
    """One panel of :func:`render_animation`: a skeleton, its feet's trails, the floor, a clock.

    The camera follows the root's floor position, smoothed over half a second (the point
    followed at frame ``f`` has screen abscissa ``cx[f]`` and depth ``cd[f]``). The floor is
    the horizontal plane through the lowest point of the clip, drawn with the same
    projection (:meth:`View.project`) as the joints: a band from depth ``cd + d_near`` (its
    front edge, a line) to ``cd + d_far`` that holds every point within 10 cm of the floor in
    every frame, with cross ticks every 0.5 m. The axis limits hold every projected point of
    every frame with a margin; the title sits above the drawing area, the clock below it.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        Positioned by the caller, ``aspect`` = its width / height in pixels.
    motion : Motion
    view : View
    label : str
    aspect : float
    trail : float
        Seconds of foot trail.
    clock : matplotlib.text.Text, optional
        Where to write the time.
    """

    TICK = 0.5  # metres between floor ticks
    CONTACT = 0.10  # metres above the floor that count as touching it

    def __init__(
        self, ax: Any, motion: Motion, view: View, *, label: str, aspect: float, trail: float, clock=None
    ) -> None:
        from matplotlib.collections import LineCollection
        from matplotlib.patches import Polygon

        self.ax, self.m, self.view, self.aspect, self.trail = ax, motion, view, float(aspect), float(trail)
        pts = _points(motion)  # (F, P, 3) metres
        self.scr = view.project(pts)  # (F, P, 2)
        height = pts @ view.up  # (F, P)
        depth = pts @ view.depth
        self.floor_h = float(height.min())
        followed = _smooth(pts[:, 0], max(1, round(0.5 * motion.fps)))  # (F, 3)
        self.cx = followed @ view.right
        self.cd = followed @ view.depth
        touching = height <= self.floor_h + self.CONTACT
        rel = (depth - self.cd[:, None])[touching]
        self.d_near = float(min(rel.min(), 0.0)) - 0.15
        self.d_far = float(max(rel.max(), 0.0)) + 0.15
        # extents of the drawing relative to the followed floor point, over all frames
        ref = self.floor_ref()  # (F, 2)
        dx = self.scr[..., 0] - ref[:, None, 0]
        dy = self.scr[..., 1] - ref[:, None, 1]
        s = math.sin(view.elevation)
        lo_y = min(float(dy.min()), self.d_near * s, self.d_far * s)
        hi_y = max(float(dy.max()), self.d_near * s, self.d_far * s)
        span = max(hi_y - lo_y, 2.0 * float(np.abs(dx).max()), 0.5)
        self.tick_len = 0.03 * span
        margin = 0.06 * span
        lo_y -= margin + self.tick_len
        hi_y += margin
        half_w = float(np.abs(dx).max()) + margin
        half_h = 0.5 * (hi_y - lo_y)
        if 2 * half_w < self.aspect * 2 * half_h:
            half_w = self.aspect * half_h
        else:
            half_h = half_w / self.aspect
        self.half_w = half_w
        self.y_range = (0.5 * (lo_y + hi_y) - half_h, 0.5 * (lo_y + hi_y) + half_h)

        ax.set_axis_off()
        ax.set_aspect("equal", adjustable="box")
        self.band = Polygon(np.zeros((4, 2)), closed=True, fc=FLOOR, ec="none", zorder=0)
        ax.add_patch(self.band)
        self.ticks = LineCollection([], colors="#b8b8b8", linewidths=0.8, zorder=0.5)
        ax.add_collection(self.ticks)
        (self.front,) = ax.plot([], [], "-", color="#888888", lw=1.0, zorder=0.6)
        self.a, self.b, colours = bone_colours(motion)
        self.bones = LineCollection([], colors=colours, linewidths=2.2, capstyle="round", zorder=2)
        ax.add_collection(self.bones)
        self.feet = _feet(motion)
        self.trails = [
            ax.plot([], [], "-", color=c, lw=1.0, alpha=0.8, zorder=1.5)[0] if j is not None else None
            for j, c in zip(self.feet, (LEFT, RIGHT), strict=True)
        ]
        self.title = ax.set_title(label, fontsize=8, pad=2)
        self.clock = clock

    def floor_ref(self, frames: Any = slice(None)) -> np.ndarray:
        """Screen position ``(..., 2)`` of the floor point below the followed root."""
        return self.floor_points(self.cx[frames], self.cd[frames])

    def floor_points(self, x: Any, d: Any) -> np.ndarray:
        """Screen position ``(..., 2)`` of floor points at screen abscissa ``x`` and depth ``d`` (m)."""
        x, d = np.broadcast_arrays(np.asarray(x, dtype=np.float64), np.asarray(d, dtype=np.float64))
        v = self.view
        world = x[..., None] * v.right + d[..., None] * v.depth + self.floor_h * v.up
        return v.project(world)

    def frame_index(self, t: float) -> int:
        """The motion frame shown at ``t`` seconds (the last one after the end)."""
        return int(min(round(t * self.m.fps), self.m.n_frames - 1))

    def update(self, t: float) -> None:
        """Draw the pose at ``t`` seconds."""
        fi = self.frame_index(t)
        s = self.scr[fi]
        self.bones.set_segments(np.stack([s[self.a], s[self.b]], axis=1))
        lo = int(max(0, fi - round(self.trail * self.m.fps)))
        for j, line in zip(self.feet, self.trails, strict=True):
            if line is not None:
                tr = self.scr[lo : fi + 1, j]
                line.set_data(tr[:, 0], tr[:, 1])
        cx, cd = float(self.cx[fi]), float(self.cd[fi])
        ref_y = float(self.floor_points(cx, cd)[1])
        x0, x1 = cx - self.half_w, cx + self.half_w
        self.ax.set_xlim(x0, x1)
        self.ax.set_ylim(ref_y + self.y_range[0], ref_y + self.y_range[1])
        near, far = cd + self.d_near, cd + self.d_far
        corners = self.floor_points([x0, x1, x1, x0], [near, near, far, far])
        self.band.set_xy(corners)
        self.front.set_data(corners[:2, 0], corners[:2, 1])
        tick_x = np.arange(math.ceil(x0 / self.TICK), math.floor(x1 / self.TICK) + 1) * self.TICK
        front = self.floor_points(tick_x, near)
        back = self.floor_points(tick_x, far)
        front[:, 1] -= self.tick_len
        self.ticks.set_segments(np.stack([front, back], axis=1))
        if self.clock is not None:
            self.clock.set_text(f"{min(t, self.m.duration):.2f} s")


def _animation_figure(
    motions: Sequence[Motion], view: View, labels: Sequence[str], panel_size: tuple[int, int], trail: float
) -> tuple[Any, list[_AnimationPanel]]:
    """The figure of :func:`render_animation`: one panel per motion, side by side.

    Each panel is ``panel_size`` pixels (rounded down to even numbers): a strip at the top
    for the title, the drawing, a strip at the bottom for the clock.
    """
    w_px, h_px = max(2, int(panel_size[0]) // 2 * 2), max(2, int(panel_size[1]) // 2 * 2)
    k = len(motions)
    dpi = 100.0
    strip = min(16.0, 0.15 * h_px)  # pixels above (title) and below (clock) the drawing
    font = max(4.0, min(8.0, 0.75 * strip * 72.0 / dpi))
    fig = _figure(k * w_px / dpi, h_px / dpi, dpi)
    panels = []
    for i, m in enumerate(motions):
        ax = fig.add_axes((i / k, strip / h_px, 1.0 / k, 1.0 - 2.0 * strip / h_px))
        clock = fig.text(
            (i + 0.03) / k, 0.5 * strip / h_px, "", ha="left", va="center", fontsize=font - 1, color="#666666"
        )
        panel = _AnimationPanel(
            ax, m, view, label=labels[i], aspect=w_px / (h_px - 2.0 * strip), trail=trail, clock=clock
        )
        panel.title.set_fontsize(font)
        panels.append(panel)
    return fig, panels


@dataclass(frozen=True)
class AnimationOptions:
    """How :func:`render_animation` draws a video.

    Attributes
    ----------
    fps : float or None, default None
        Video frame rate, frames per second; None (or 0): the highest of the motions', at
        most 30.
    panel_size : (int, int), default (320, 320)
        Pixels per panel (width, height), rounded down to even numbers.
    seconds : float or None, default None
        Length of the video in seconds; None: the longest motion.
    trail : float, default 1.0
        Seconds of foot trail.
    azimuth : float, default 25.0
        Camera angle about the up axis, degrees (:func:`side_view`).
    elevation : float, default 12.0
        Camera tilt, degrees (:func:`side_view`).
    """

    fps: float | None = None
    panel_size: tuple[int, int] = (320, 320)
    seconds: float | None = None
    trail: float = 1.0
    azimuth: float = 25.0
    elevation: float = 12.0

    def __post_init__(self) -> None:
        if self.fps and not float(self.fps) > 0:
            raise OptionError("fps", f"expected a positive frame rate; got {float(self.fps)!r}")
        if self.seconds is not None and not float(self.seconds) >= 0:
            raise OptionError("seconds", f"expected a length >= 0; got {self.seconds!r}")

    def video_fps(self, motions: Sequence[Motion]) -> float:
        """The frame rate of the video of ``motions`` (frames per second)."""
        return float(self.fps) if self.fps else min(30.0, max(m.fps for m in motions))


def render_animation(
    motions: Sequence[Motion],
    path: str | os.PathLike[str],
    options: AnimationOptions | None = None,
    *,
    labels: Sequence[str] | None = None,
    also: Sequence[str | os.PathLike[str]] = (),
    protected: Sequence[str] = (),
    progress: Progress | None = None,
    **overrides: Any,
) -> Path:
    """Skeleton animations side by side, written as a GIF or an MP4.

    Each panel follows its motion's root along the floor (the camera moves with it; the
    floor is drawn in the same tilted projection as the skeleton, with a tick every 0.5 m
    to show the travel) and draws the trails of both feet over the last ``trail`` seconds.
    All motions play at the same clock; a shorter one holds its last frame. The panel's
    view holds every pose of its motion; its title is above the drawing, the clock below.

    Frames are drawn at ``0, 1/fps, 2/fps, ...`` up to ``seconds``, and each is shown for
    ``1/fps``: the video plays in real time. A GIF stores delays in whole centiseconds, so
    its delays vary (3 and 4 cs at 30 fps) to keep the cumulative time exact
    (:func:`gif_frame_delays`); above 50 fps a GIF leaves frames out.

    Parameters
    ----------
    motions : sequence of Motion
    path : str or os.PathLike
        ``.gif`` or ``.mp4`` (module docstring).
    options : AnimationOptions, optional
        Frame rate, panel size, length, trail, camera; or give its fields as keywords
        (``fps=10``).
    labels : sequence of str, optional
        Panel titles (default the motions' names).
    also : sequence of paths
        More files (``.gif``/``.mp4``) to write the same frames to, e.g. an MP4 beside the
        GIF (the frames are drawn once).
    protected : sequence of paths
        Input files that must not be overwritten.
    progress : callable, optional
        ``progress("render", frame, frames)``.

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    opts = with_overrides(AnimationOptions, options, overrides)
    motions = list(motions)
    if not motions:
        raise ValueError("motions: expected at least one motion to render")
    out = _check_output(path, protected)
    extra = [_check_output(p, protected) for p in also]
    for target in [out, *extra]:
        if target.suffix.lower() not in VIDEO_FORMATS:
            raise ValueError(
                f"output: expected one of {list(VIDEO_FORMATS)} for an animation; got {target.name!r}"
            )
    labels = [m.name for m in motions] if labels is None else list(labels)
    if len(labels) != len(motions):
        raise ValueError(f"labels: expected {len(motions)} labels; got {len(labels)}")
    fps = opts.video_fps(motions)
    duration = max(m.duration for m in motions) if opts.seconds is None else float(opts.seconds)
    report = progress or null_progress
    n_frames = max(1, math.floor(duration * fps + 1e-6) + 1)
    view = side_view(motions[0], azimuth=opts.azimuth, elevation=opts.elevation)

    fig, panels = _animation_figure(motions, view, labels, opts.panel_size, opts.trail)
    sinks: list[_VideoSink] = []
    try:
        for target in [out, *extra]:
            sinks.append(_VideoSink(target, fps))
        for f in range(n_frames):
            t = f / fps
            wanted = [sink for sink in sinks if sink.wants(t)]
            if wanted:
                for p in panels:
                    p.update(t)
                fig.canvas.draw()
                rgb = np.asarray(fig.canvas.buffer_rgba())[..., :3]
            for sink in sinks:
                sink.send(rgb if sink in wanted else None, t)
            report("render", f + 1, n_frames)
        for sink in sinks:
            sink.commit()
    except BaseException:
        for sink in sinks:
            sink.abort()
        raise
    return out


# ------------------------------------------------------------------------------------------
# Foot trajectories (paper 000 Fig. 4, paper 001 Fig. 5-6)
# ------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class FeetPlotOptions:
    """How :func:`plot_foot_trajectories` draws.

    Attributes
    ----------
    ncols : int or None, default None
        Panels per row; None: all in one row up to 4 motions, else two rows.
    ghosts : int, default 5
        Number of grey whole-body poses per panel.
    azimuth : float, default 0.0
        Camera angle about the up axis, degrees (:func:`side_view`).
    elevation : float, default 10.0
        Camera tilt, degrees.
    title : str or None, default None
        Title above the panels.
    panel_size : (float, float), default (3.4, 1.9)
        Inches per panel: the width, and a height the data's aspect ratio may stretch up to
        three times.
    dpi : float, default 100
        Dots per inch of the written picture.
    """

    ncols: int | None = None
    ghosts: int = 5
    azimuth: float = 0.0
    elevation: float = 10.0
    title: str | None = None
    panel_size: tuple[float, float] = (3.4, 1.9)
    dpi: float = 100

    def __post_init__(self) -> None:
        if self.ncols is not None and not (isinstance(self.ncols, int) and self.ncols >= 1):
            raise OptionError("ncols", f"expected a number of panels per row >= 1; got {self.ncols!r}")
        if not (isinstance(self.ghosts, int) and self.ghosts >= 0):
            raise OptionError("ghosts", f"expected a number of poses >= 0; got {self.ghosts!r}")
        _check_dpi(self.dpi)


def _check_dpi(dpi: Any) -> None:
    if not (isinstance(dpi, int | float) and math.isfinite(dpi) and dpi > 0):
        raise OptionError("dpi", f"expected dots per inch > 0; got {dpi!r}")


def plot_foot_trajectories(
    motions: Sequence[Motion],
    path: str | os.PathLike[str] | None = None,
    options: FeetPlotOptions | None = None,
    *,
    labels: Sequence[str] | None = None,
    protected: Sequence[str] = (),
    **overrides: Any,
) -> Any:
    """Trajectories of both feet, one panel per motion, as in the papers' figures.

    Left foot blue, right foot orange, a few poses in light grey, all seen by one side
    camera (:func:`side_view` of the first motion) with shared axes.

    Parameters
    ----------
    motions : sequence of Motion
    path : str or os.PathLike, optional
        Write the figure there (PNG); otherwise only return it.
    options : FeetPlotOptions, optional
        Layout, camera, title, size; or give its fields as keywords (``ncols=4``).
    labels : sequence of str, optional
        Panel titles (default the motions' names).
    protected : sequence of paths

    Returns
    -------
    matplotlib.figure.Figure
    """
    opts = with_overrides(FeetPlotOptions, options, overrides)
    motions = list(motions)
    if not motions:
        raise ValueError("motions: expected at least one motion")
    labels = [m.name for m in motions] if labels is None else list(labels)
    k = len(motions)
    ncols = opts.ncols or (k if k <= 4 else math.ceil(k / 2))
    nrows = math.ceil(k / ncols)
    view = side_view(motions[0], azimuth=opts.azimuth, elevation=opts.elevation)
    screens = [view.project(_points(m)) for m in motions]
    lo = np.min([sc.reshape(-1, 2).min(axis=0) for sc in screens], axis=0)
    hi = np.max([sc.reshape(-1, 2).max(axis=0) for sc in screens], axis=0)
    pad = 0.04 * (hi - lo).max()
    lo, hi = lo - pad, hi + pad
    ratio = float((hi[1] - lo[1]) / max(hi[0] - lo[0], 1e-9))
    width = opts.panel_size[0]
    height = min(max(width * ratio, 0.6), 3.0 * opts.panel_size[1]) + 0.55
    fig = _figure(width * ncols, height * nrows + (0.35 if opts.title else 0.0), opts.dpi)
    axes = fig.subplots(nrows, ncols, squeeze=False)
    from matplotlib.collections import LineCollection

    for i, m in enumerate(motions):
        ax = axes[i // ncols][i % ncols]
        scr = screens[i]
        a_idx, b_idx, _ = bone_colours(m)
        if opts.ghosts > 0:
            frames = np.linspace(0, m.n_frames - 1, opts.ghosts).round().astype(int)
            segs = np.concatenate([np.stack([scr[f, a_idx], scr[f, b_idx]], axis=1) for f in frames])
            ax.add_collection(LineCollection(segs, colors=GHOST, linewidths=0.8, zorder=1))
        lf, rf = _feet(m)
        for j, c, name in ((lf, LEFT, "left foot"), (rf, RIGHT, "right foot")):
            if j is not None:
                ax.plot(scr[:, j, 0], scr[:, j, 1], "-", color=c, lw=1.3, label=name, zorder=2)
        ax.set_title(labels[i], fontsize=8)
        ax.tick_params(labelsize=6)
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        ax.set_aspect("equal", adjustable="box")
        ax.grid(True, lw=0.3, alpha=0.5)
    for i in range(k, nrows * ncols):
        axes[i // ncols][i % ncols].set_axis_off()
    axes[0][0].legend(fontsize=6, loc="upper left", frameon=False)
    ylabel = "height (m)" if opts.elevation == 0 else f"height (m), seen {opts.elevation:g} deg from above"
    xlabel = "along the walk (m)" if opts.azimuth == 0 else f"along the walk, turned {opts.azimuth:g} deg (m)"
    for r in range(nrows):
        axes[r][0].set_ylabel(ylabel, fontsize=7)
    for c in range(min(ncols, k)):
        axes[(k - 1 - c) // ncols][c].set_xlabel(xlabel, fontsize=7)  # the lowest panel drawn
    if opts.title:
        fig.suptitle(opts.title, fontsize=9)
    fig.tight_layout()
    if path is not None:
        save_figure(fig, path, protected=protected)
    return fig


# ------------------------------------------------------------------------------------------
# Warp
# ------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class WarpPlotOptions:
    """How :func:`plot_warp` draws.

    Attributes
    ----------
    labels : (str, str), default ("A", "B")
        Names of the two motions on the axes (an ``AlignResult`` gives its own).
    title : str or None, default None
        Title; None: for an ``AlignResult``, its method, warp and distances.
    dpi : float, default 100
        Dots per inch of the written picture.
    """

    labels: tuple[str, str] = ("A", "B")
    title: str | None = None
    dpi: float = 100

    def __post_init__(self) -> None:
        _check_dpi(self.dpi)


def plot_warp(
    result: Any = None,
    path: str | os.PathLike[str] | None = None,
    options: WarpPlotOptions | None = None,
    *,
    vertices: np.ndarray | None = None,
    durations: tuple[float, float] | None = None,
    landmarks: Sequence[tuple[float, float]] = (),
    protected: Sequence[str] = (),
    **overrides: Any,
) -> Any:
    """The time warp as a curve: time in A (horizontal) against the matched time in B.

    Parameters
    ----------
    result : AlignResult, optional
        From :func:`elastic_motion.apps.align.align_motions`; or give ``vertices`` and
        ``durations``.
    path : str or os.PathLike, optional
    options : WarpPlotOptions, optional
        Labels, title, resolution; or give its fields as keywords (``title="..."``).
    vertices : ndarray, shape (K, 2), optional
        Warp in curve parameters.
    durations : (float, float), optional
        Seconds of A and B.
    landmarks : sequence of (float, float)
        Landmark pairs in seconds; drawn as crosses (where they ask the warp to go).
    protected : sequence of paths

    Returns
    -------
    matplotlib.figure.Figure
    """
    opts = with_overrides(WarpPlotOptions, options, overrides)
    labels, title, dpi = opts.labels, opts.title, opts.dpi
    if result is not None:
        vertices = result.vertices
        durations = (result.duration_a, result.duration_b)
        landmarks = result.landmarks
        labels = result.prepared.labels[:2]
        if title is None:
            title = (
                f"{result.method}, warp {result.warp}: distance {result.distance:.3g} "
                f"(no warp {result.distance_unwarped:.3g})"
            )
    if vertices is None or durations is None:
        raise ValueError("plot_warp: give an AlignResult or vertices and durations")
    v = np.asarray(vertices, dtype=np.float64)
    da, db = durations
    fig = _figure(4.2, 4.0, dpi)
    ax = fig.add_subplot(1, 1, 1)
    ax.plot([0, da], [0, db], "--", color=UNIFORM, lw=1, label="uniform (no warp)")
    ax.plot(v[:, 0] * da, v[:, 1] * db, "-", color=WARP, lw=1.6, label="optimal warp")
    if len(landmarks):
        lm = np.asarray(landmarks, dtype=np.float64)
        ax.plot(lm[:, 0], lm[:, 1], "x", color="k", ms=7, mew=1.5, label="landmarks")
        for ta, tb in lm:
            ax.axvline(ta, color="#cccccc", lw=0.6, zorder=0)
            ax.axhline(tb, color="#cccccc", lw=0.6, zorder=0)
    ax.set_xlim(0, da)
    ax.set_ylim(0, db)
    ax.set_xlabel(f"time in {labels[0]} (s)", fontsize=8)
    ax.set_ylabel(f"time in {labels[1]} (s)", fontsize=8)
    ax.tick_params(labelsize=7)
    ax.legend(fontsize=7, loc="upper left", frameon=False)
    if title:
        ax.set_title(title, fontsize=8)
    ax.grid(True, lw=0.3, alpha=0.5)
    fig.tight_layout()
    if path is not None:
        save_figure(fig, path, protected=protected)
    return fig


# ------------------------------------------------------------------------------------------
# Loop seam (paper 000 Fig. 5-7)
# ------------------------------------------------------------------------------------------


def _trace_joints(motion: Motion, joints: Sequence[str] | None) -> list[tuple[str, int]]:
    """``(name, index)`` of the joints :func:`plot_seam` traces (``KeyError`` for an unknown name)."""
    sk = motion.skeleton
    if isinstance(joints, str):
        joints = [joints]
    if joints:
        return [(n, sk.index(n)) for n in joints]
    _lf, rf = _feet(motion)
    out = []
    if rf is not None:
        out.append((sk.names[rf], rf))
    hands = [
        j
        for j, n in enumerate(sk.names)
        if joint_side(n) == "L" and re.search(r"hand|wrist|elbow|radius", n, re.I)
    ]
    if hands:
        out.append((sk.names[hands[0]], hands[0]))
    return out or [(sk.names[0], 0)]


@dataclass(frozen=True)
class SeamPlotOptions:
    """How :func:`plot_seam` draws.

    Attributes
    ----------
    repeat : int, default 3
        Cycles to play (at least 2).
    root : {"travel", "inplace"}, default "travel"
        Loop convention (:func:`elastic_motion.motion.looping.repeat_motion`).
    joints : str, sequence of str or None, default None
        Joints whose paths are drawn; None: the right ankle and the left hand or wrist.
    labels : (str, str), default ("original", "looped")
        Row titles.
    title : str or None, default None
        Title above the rows.
    dpi : float, default 100
        Dots per inch of the written picture.
    """

    repeat: int = 3
    root: RootMode = "travel"
    joints: str | Sequence[str] | None = None
    labels: tuple[str, str] = ("original", "looped")
    title: str | None = None
    dpi: float = 100

    def __post_init__(self) -> None:
        if int(self.repeat) < 2:
            raise OptionError("repeat", f"expected at least 2 cycles to show a seam; got {self.repeat!r}")
        object.__setattr__(self, "repeat", int(self.repeat))
        check_root(self.root)
        _check_dpi(self.dpi)


def plot_seam(
    original: Motion,
    looped: Motion | None = None,
    path: str | os.PathLike[str] | None = None,
    options: SeamPlotOptions | None = None,
    *,
    protected: Sequence[str] = (),
    **overrides: Any,
) -> Any:
    """The jump at the loop seam, before and after closing (paper 000 Fig. 5-6).

    One row per motion (``original``, then ``looped`` if given). Left: the side-view path
    of a few joints (default: the right ankle and the left hand or wrist) while the clip
    plays ``repeat`` times, each cycle moved by the cycle transform ``T``
    (:func:`elastic_motion.motion.looping.repeat_motion`: a cycle's last frame is replaced by
    the next cycle's first). At each seam a circle marks where the cycle's own last frame
    puts the joint and a cross where the next cycle starts: they coincide for a seamless
    loop; the distance between them is the jump. Right: the skeleton in the last three
    frames of the clip (blue) and the first three of the next cycle, ``T`` applied (orange).
    Both panels are side views without tilt: horizontal, metres along the direction the
    repeated clip travels most; vertical, height in metres.

    Parameters
    ----------
    original : Motion
    looped : Motion, optional
        The same clip made seamless (:func:`elastic_motion.apps.loop.loop_motion`).
    path : str or os.PathLike, optional
        Write the figure there; otherwise only return it.
    options : SeamPlotOptions, optional
        Cycles, loop convention, traced joints, labels, title; or give its fields as
        keywords (``repeat=2``).
    protected : sequence of paths

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.collections import LineCollection

    opts = with_overrides(SeamPlotOptions, options, overrides)
    repeat, root, joints, labels, title, dpi = (
        opts.repeat, opts.root, opts.joints, opts.labels, opts.title, opts.dpi
    )  # fmt: skip
    rows = [(labels[0], original)] + ([(labels[1], looped)] if looped is not None else [])
    view = side_view(repeat_motion(original, repeat, root))
    trace = _trace_joints(original, joints)
    fig = _figure(9.0, 2.3 * len(rows) + (0.3 if title else 0.0), dpi)
    axes = fig.subplots(len(rows), 2, squeeze=False, gridspec_kw={"width_ratios": [3.2, 1.0]})
    colours = TRACE
    for r, (lab, m) in enumerate(rows):
        scale = m.metres_per_unit or 1.0
        rot, shift = cycle_transform(m, root)
        shift = shift * scale
        one = _points(m)  # (F, P, 3) metres
        rep = repeat_motion(m, repeat, root)
        scr = view.project(_points(rep))
        f = m.n_frames
        ax = axes[r][0]
        for c, (name, j) in enumerate(trace):
            ax.plot(scr[:, j, 0], scr[:, j, 1], "-", color=colours[c % 4], lw=1.1, label=name)
            last = one[-1, j]
            for k in range(1, repeat):
                last_k = last  # T^(k-1) applied to the clip's last frame
                for _ in range(k - 1):
                    last_k = rot @ last_k + shift
                ax.plot(*view.project(last_k), "o", mfc="none", mec="k", ms=5)
                ax.plot(*scr[k * (f - 1), j], "x", color="r", ms=5)
        ax.set_title(f"{lab}: {repeat} cycles", fontsize=8)
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel("along the travel (m)", fontsize=7)
        ax.set_ylabel("height (m)", fontsize=7)
        ax.tick_params(labelsize=6)
        ax.grid(True, lw=0.3, alpha=0.5)
        if r == 0:
            ax.legend(fontsize=6, loc="upper left", frameon=False)
        # close-up of the seam: the clip's last frames, the next cycle's first frames
        axc = axes[r][1]
        a_idx, b_idx, _ = bone_colours(m)
        nxt = one[:3] @ rot.T + shift
        poses = [(one[fr], LEFT) for fr in range(max(0, f - 3), f)] + [(p, RIGHT) for p in nxt]
        for pose, col in poses:
            sp = view.project(pose)
            axc.add_collection(
                LineCollection(
                    np.stack([sp[a_idx], sp[b_idx]], axis=1), colors=col, linewidths=0.9, alpha=0.8
                )
            )
        axc.autoscale()
        axc.set_aspect("equal", adjustable="datalim")
        axc.set_title("seam: end (blue), next start (orange)", fontsize=7)
        axc.set_xlabel("along the travel (m)", fontsize=7)
        axc.set_ylabel("height (m)", fontsize=7)
        axc.tick_params(labelsize=6)
    if title:
        fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    if path is not None:
        save_figure(fig, path, protected=protected)
    return fig


# ------------------------------------------------------------------------------------------
# SO(3) curves on the sphere (paper 000 Fig. 2-3)
# ------------------------------------------------------------------------------------------


def joint_rotation_curve(motion: Motion, joint: str | int, *, frame: RotationFrame = "local") -> np.ndarray:
    """Rotations of one joint over the clip, ``(F, 3, 3)``: its local rotation (relative to
    its parent, ``frame="local"``) or its global orientation (``"global"``)."""
    j = motion.skeleton.index(joint) if isinstance(joint, str) else int(joint)
    if frame == "local":
        return np.asarray(motion.rotations[:, j])
    if frame == "global":
        return global_rotations(motion)[:, j]
    raise ValueError(f"frame: expected 'local' or 'global'; got {frame!r}")


def plot_so3_curves(
    curves: Sequence[np.ndarray],
    path: str | os.PathLike[str] | None = None,
    *,
    labels: Sequence[str] | None = None,
    vectors: Sequence[Sequence[float]] = ((1.0, 0.0, 0.0),),
    title: str | None = None,
    elev: float | None = None,
    azim: float | None = None,
    protected: Sequence[str] = (),
) -> Any:
    """Curves in SO(3) drawn on the unit sphere, as in paper 000 Fig. 2-3: for each rotation
    curve ``R(t)`` and vector ``v``, the path ``R(t) v`` (a start marker at ``t = 0``).

    Parameters
    ----------
    curves : sequence of ndarray, shape (N_k, 3, 3)
    labels : sequence of str, optional
    vectors : sequence of 3-vectors
        Unit vectors to transport (normalised here); each gets a line style.
    elev, azim : float, optional
        Camera angles in degrees (matplotlib's); default: looking at the mean point of the
        curves, so that they face the viewer.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig = _figure(4.6, 4.4)
    ax = fig.add_subplot(1, 1, 1, projection="3d")
    u = np.linspace(0, 2 * np.pi, 37)
    w = np.linspace(0, np.pi, 19)
    xs = np.outer(np.cos(u), np.sin(w))
    ys = np.outer(np.sin(u), np.sin(w))
    zs = np.outer(np.ones_like(u), np.cos(w))
    ax.plot_wireframe(xs, ys, zs, color="#dddddd", lw=0.4)
    palette = CURVES
    styles = ["-", "--", ":", "-."]
    labels = [f"curve {k}" for k in range(len(curves))] if labels is None else list(labels)
    if elev is None or azim is None:
        pts = np.concatenate(
            [
                np.asarray(r, dtype=np.float64) @ _unit(np.asarray(v, dtype=np.float64))
                for r in curves
                for v in vectors
            ]
        )
        c = pts.mean(axis=0)
        if np.linalg.norm(c) > 1e-6:
            c = c / np.linalg.norm(c)
            elev = math.degrees(math.asin(float(np.clip(c[2], -1, 1)))) if elev is None else elev
            azim = math.degrees(math.atan2(c[1], c[0])) if azim is None else azim
        elev = 20.0 if elev is None else elev
        azim = 35.0 if azim is None else azim
    for k, rot in enumerate(curves):
        rot = np.asarray(rot, dtype=np.float64)
        for i, v in enumerate(vectors):
            v = _unit(np.asarray(v, dtype=np.float64))
            p = rot @ v
            ax.plot(
                p[:, 0],
                p[:, 1],
                p[:, 2],
                styles[i % 4],
                color=palette[k % 6],
                lw=max(2.4 - 0.6 * k, 0.8),
                label=labels[k] if i == 0 else None,
            )
            ax.scatter([p[0, 0]], [p[0, 1]], [p[0, 2]], color=palette[k % 6], s=12)
    ax.set_box_aspect((1, 1, 1))
    ax.set_xlim(-1, 1)
    ax.set_ylim(-1, 1)
    ax.set_zlim(-1, 1)
    ax.view_init(elev=elev, azim=azim)
    ax.set_axis_off()
    ax.legend(fontsize=7, loc="upper left", frameon=False)
    if title:
        ax.set_title(title, fontsize=8)
    fig.tight_layout()
    if path is not None:
        save_figure(fig, path, protected=protected)
    return fig


# ------------------------------------------------------------------------------------------
# One entry point for the CLI
# ------------------------------------------------------------------------------------------

#: The keywords :func:`render` accepts for each kind (besides ``labels``, ``protected``,
#: ``progress``).
RENDER_KEYWORDS: dict[str, tuple[str, ...]] = {
    "animation": ("fps", "panel_size", "seconds", "trail", "azimuth", "elevation", "also"),
    "feet": ("ncols", "ghosts", "azimuth", "elevation", "title"),
    "warp": ("method", "warp", "landmarks", "joints", "prepare", "max_pairs", "title"),
    "seam": ("repeat", "root", "joints", "title"),
    "sphere": ("joint", "frame", "vectors", "title"),
}


def render_kind(kind: str, path: str | os.PathLike[str]) -> str:
    """The picture :func:`render` draws into ``path`` for ``kind`` (resolves ``"auto"``)."""
    if kind not in KINDS:
        raise ValueError(f"kind: expected one of {list(KINDS)}; got {kind!r}")
    if kind == "auto":
        return "animation" if Path(path).suffix.lower() in VIDEO_FORMATS else "feet"
    return kind


def render(
    motions: Sequence[Motion],
    path: str | os.PathLike[str],
    *,
    kind: str = "auto",
    labels: Sequence[str] | None = None,
    protected: Sequence[str] = (),
    progress: Progress | None = None,
    **kw: Any,
) -> Path:
    """Draw motions into a file; ``kind`` chooses the picture.

    Parameters
    ----------
    motions : sequence of Motion
    path : str or os.PathLike
        ``.gif``/``.mp4`` (animation) or ``.png``/``.svg``/``.pdf`` (a still).
    kind : {"auto", "animation", "feet", "warp", "seam", "sphere"}
        ``"auto"``: an animation for ``.gif``/``.mp4``, the foot trajectories for a still.
    labels : sequence of str, optional
        Panel titles, one per motion (default: the motions' names; ``"warp"`` and ``"seam"``
        use their own).
    protected : sequence of paths
        Input files (never overwritten).
    progress : callable, optional
        ``progress("render", frame, frames)`` (animations).
    **kw
        The keywords of the function that draws ``kind`` (:data:`RENDER_KEYWORDS`):

        * ``"animation"`` (:func:`render_animation`): ``fps`` (frames per second),
          ``panel_size`` (pixels, ``(width, height)``), ``seconds``, ``trail`` (seconds),
          ``azimuth``, ``elevation`` (degrees), ``also`` (more video files).
        * ``"feet"`` (:func:`plot_foot_trajectories`): ``ncols``, ``ghosts``, ``azimuth``,
          ``elevation`` (degrees), ``title``.
        * ``"warp"``: two motions, aligned by :func:`elastic_motion.apps.align.align_motions`
          (``method``, ``warp``, ``landmarks`` (seconds), ``prepare``, ``max_pairs``;
          ``joints``, the joints compared: ``"all"``, ``"common"`` or names, sets
          ``prepare.joints``) and drawn by :func:`plot_warp` (``title``).
        * ``"seam"`` (:func:`plot_seam`): each motion as a loop, repeated: ``repeat``
          (cycles), ``root``, ``joints`` (the joints whose paths are drawn), ``title``; two
          motions: the original and the looped one.
        * ``"sphere"``: the rotation curve of one joint per motion on the sphere
          (:func:`joint_rotation_curve`: ``joint``, default the root; ``frame``;
          :func:`plot_so3_curves`: ``vectors``, ``title``).

    Returns
    -------
    pathlib.Path

    Raises
    ------
    TypeError
        A keyword that ``kind`` does not use (the message names it and lists the accepted
        ones).
    ValueError
        A bad value: an unknown kind, a still written as a video, the wrong number of motions.
    """
    kind = render_kind(kind, path)
    accepted = RENDER_KEYWORDS[kind]
    unknown = sorted(set(kw) - set(accepted))
    if unknown:
        raise TypeError(
            f"render(kind={kind!r}): unexpected keyword{'s' if len(unknown) > 1 else ''} "
            f"{', '.join(map(repr, unknown))}; accepted: {', '.join(accepted)}"
        )
    out = Path(path)
    ext = out.suffix.lower()
    motions = list(motions)
    if not motions:
        raise ValueError("motions: expected at least one motion")
    if kind == "animation":
        return render_animation(motions, out, labels=labels, protected=protected, progress=progress, **kw)
    if ext in VIDEO_FORMATS:
        raise ValueError(
            f"output: a {kind!r} picture is a still; write a .png, .svg or .pdf (got {out.name!r})"
        )
    draw = {"feet": _render_feet, "warp": _render_warp, "seam": _render_seam, "sphere": _render_sphere}[kind]
    draw(motions, out, labels, protected, kw)
    return out


def _render_feet(
    motions: list[Motion], out: Path, labels: Sequence[str] | None, protected: Sequence[str], kw: dict
) -> None:
    plot_foot_trajectories(motions, out, labels=labels, protected=protected, **kw)


def _render_warp(
    motions: list[Motion], out: Path, labels: Sequence[str] | None, protected: Sequence[str], kw: dict
) -> None:
    """Two motions aligned (``joints`` sets ``prepare.joints``) and their warp drawn (labels:
    the alignment's own)."""
    if len(motions) != 2:
        raise ValueError(f"kind 'warp': expected two motions; got {len(motions)}")
    title = kw.pop("title", None)
    joints = kw.pop("joints", None)
    if joints is not None:
        prepare = kw.get("prepare") or PrepareOptions()
        kw["prepare"] = prepare.replace(joints=joints if isinstance(joints, str) else tuple(joints))
    res = align_motions(motions[0], motions[1], **kw)
    plot_warp(res, out, title=title, protected=protected)


def _render_seam(
    motions: list[Motion], out: Path, labels: Sequence[str] | None, protected: Sequence[str], kw: dict
) -> None:
    """One motion as a loop, or the original and its loop; ``labels`` name the rows."""
    if len(motions) > 2:
        raise ValueError(
            f"kind 'seam': expected one motion (or the original and its loop); got {len(motions)}"
        )
    looped = motions[1] if len(motions) == 2 else None
    seam_labels = ("original", "looped")
    if labels:
        seam_labels = (labels[0], labels[1] if len(labels) > 1 else "looped")
    plot_seam(motions[0], looped, out, labels=seam_labels, protected=protected, **kw)


def _render_sphere(
    motions: list[Motion], out: Path, labels: Sequence[str] | None, protected: Sequence[str], kw: dict
) -> None:
    """The rotation curve of one joint (default: the root) per motion on the sphere."""
    joint = kw.pop("joint", None)
    frame = kw.pop("frame", "local")
    curves = [joint_rotation_curve(m, joint if joint is not None else 0, frame=frame) for m in motions]
    name = joint if joint is not None else motions[0].skeleton.names[0]
    kw.setdefault("title", f"{name} ({frame} rotation)")
    plot_so3_curves(curves, out, labels=labels or [m.name for m in motions], protected=protected, **kw)
