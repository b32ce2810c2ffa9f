"""Resource limits: one home for the bounds that keep a small hostile file from taking a machine.

Every limit is checked *before* the memory it guards is allocated, and a value beyond it is
an error naming the file (or option), the value and the limit, e.g.::

    walk.bvh:186: expected a frame count of at most 1000000 (limit max_frames; change it with
    ELASTIC_MOTION_LIMITS); got 1000000000000000

The limits (field of :class:`Limits`, default, what it bounds):

==========================  ============  ===============================================
``max_file_bytes``          4 GB          size of one motion file read
``max_frames``              1,000,000     frames of one clip, as declared by a file or
                                          produced by resampling (2.3 h at 120 fps)
``max_joints``              2,000         joints of one skeleton (some steps are quadratic in it)
``max_duration``            86,400 s      duration of one clip (a day)
``min_fps``, ``max_fps``    0.1, 10,000   frame rate of a clip (from ``Frame Time``, frame
                                          durations, ``--fps``)
``max_resample_growth``     100           a clip resampled onto a uniform grid (DeepMimic
                                          frames of unequal duration) has at most this many
                                          times its file's frames (+ 1000)
``max_samples``             50,000,000    frames x joints of one clip or result (rotation
                                          matrices: 72 bytes each, 3.6 GB)
``max_repeat``              100           repeats of a loop preview (``--repeat``)
``max_render_size``         8,192 px      width and height of a picture or video
``min_render_fps``,         0.1, 1,000    frame rate of a rendered video
``max_render_fps``
``max_render_frames``       100,000       frames of a rendered video
``max_dp_nodes``            50,000,000    nodes of one dynamic-programming table of a time
                                          warp (about 20 bytes each: 1 GB; two clips of
                                          7,000 samples each, 4 min at 30 fps)
``max_constraint_rows``     8,000         contact rows a loop keeps in one projection (their
                                          Gram matrix: 8 bytes per pair of rows, 0.5 GB)
==========================  ============  ===============================================

Overriding: a user who needs more (a day-long capture, a 16k render) sets the environment
variable ``ELASTIC_MOTION_LIMITS`` (``"max_frames=5e6,max_duration=172800"``; read when this
module is first imported, so it also reaches the command line and Dask workers started from
that environment), or, in Python, ``with elastic_motion.limits.override(max_frames=5_000_000):``.
Readers never open anything but regular files (:func:`elastic_motion._io.read_bytes`): a FIFO
named ``x.bvh`` is refused instead of blocking forever.
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
import os
from collections.abc import Iterator
from dataclasses import dataclass

from elastic_motion.errors import OptionError, ParseError

__all__ = [
    "ENV_VAR",
    "Limits",
    "check_clip",
    "check_option",
    "current",
    "limit_message",
    "override",
    "set_limits",
]

#: Environment variable with limit overrides, ``name=value`` separated by commas.
ENV_VAR = "ELASTIC_MOTION_LIMITS"


@dataclass(frozen=True)
class Limits:
    """The resource limits (see the module docstring for what each bounds)."""

    max_file_bytes: int = 4_000_000_000
    max_frames: int = 1_000_000
    max_joints: int = 2_000
    max_duration: float = 86_400.0
    min_fps: float = 0.1
    max_fps: float = 10_000.0
    max_resample_growth: float = 100.0
    max_samples: int = 50_000_000
    max_repeat: int = 100
    max_render_size: int = 8_192
    min_render_fps: float = 0.1
    max_render_fps: float = 1_000.0
    max_render_frames: int = 100_000
    max_dp_nodes: int = 50_000_000
    max_constraint_rows: int = 8_000

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if isinstance(v, bool) or not isinstance(v, int | float) or not (math.isfinite(v) and v > 0):
                raise ValueError(f"limits: expected {f.name} to be a positive finite number; got {v!r}")
        if self.min_fps > self.max_fps or self.min_render_fps > self.max_render_fps:
            raise ValueError("limits: expected min_fps <= max_fps and min_render_fps <= max_render_fps")


def _from_env(text: str | None) -> Limits:
    if not text or not text.strip():
        return Limits()
    kw: dict[str, float | int] = {}
    names = {f.name: f.type for f in dataclasses.fields(Limits)}
    for item in text.split(","):
        if not item.strip():
            continue
        name, sep, value = item.partition("=")
        name = name.strip()
        if not sep or name not in names:
            raise ValueError(
                f"{ENV_VAR}: expected name=value pairs with names from {sorted(names)}; got {item.strip()!r}"
            )
        try:
            x = float(value)
        except ValueError:
            raise ValueError(f"{ENV_VAR}: expected a number for {name}; got {value.strip()!r}") from None
        kw[name] = int(x) if names[name] in ("int", int) and x.is_integer() else x
    return Limits(**kw)


_current: Limits = _from_env(os.environ.get(ENV_VAR))


def current() -> Limits:
    """The limits in force."""
    return _current


def set_limits(limits: Limits | None = None, **changes: float) -> Limits:
    """Replace the limits in force (``None``: the defaults, then ``changes``); return the old ones."""
    global _current
    old = _current
    base = Limits() if limits is None else limits
    _current = dataclasses.replace(base, **changes) if changes else base
    return old


@contextlib.contextmanager
def override(**changes: float) -> Iterator[Limits]:
    """Within the block, the current limits with ``changes`` (e.g. ``max_frames=5_000_000``)."""
    old = set_limits(_current, **changes)
    try:
        yield _current
    finally:
        set_limits(old)


def _show(x: object) -> str:
    if isinstance(x, float) and x.is_integer() and abs(x) < 1e16:
        return str(int(x))
    return f"{x:g}" if isinstance(x, float) else str(x)


def limit_message(what: str, value: object, name: str, bound: object, *, at_least: bool = False) -> str:
    """``expected WHAT at most BOUND (limit NAME; raise it with ELASTIC_MOTION_LIMITS); got VALUE``."""
    side = "at least" if at_least else "at most"
    return (
        f"expected {what} {side} {_show(bound)} (limit {name}; change it with {ENV_VAR}); got {_show(value)}"
    )


def check_clip(
    path: str | os.PathLike[str],
    line: int | None,
    *,
    frames: float | None = None,
    fps: float | None = None,
    duration: float | None = None,
    joints: int | None = None,
) -> None:
    """Check a clip's declared size against the limits; ``ParseError`` naming file, line, value, limit.

    Parameters
    ----------
    path : path
        The file (named in the error).
    line : int or None
        1-based line of the offending declaration.
    frames, fps, duration : float, optional
        Frame count, frames per second, seconds (each checked when given).
    joints : int, optional
        With ``frames``: ``frames * joints`` is checked against ``max_samples``.
    """
    lim = _current
    if joints is not None and joints > lim.max_joints:
        raise ParseError(path, line, limit_message("a joint count of", joints, "max_joints", lim.max_joints))
    if fps is not None:
        if not (fps >= lim.min_fps):  # also NaN
            raise ParseError(
                path, line, limit_message("a frame rate (fps) of", fps, "min_fps", lim.min_fps, at_least=True)
            )
        if fps > lim.max_fps:
            raise ParseError(path, line, limit_message("a frame rate (fps) of", fps, "max_fps", lim.max_fps))
    if frames is not None and not (frames <= lim.max_frames):
        raise ParseError(path, line, limit_message("a frame count of", frames, "max_frames", lim.max_frames))
    if duration is not None and not (duration <= lim.max_duration):
        raise ParseError(
            path, line, limit_message("a duration (seconds) of", duration, "max_duration", lim.max_duration)
        )
    if frames is not None and joints is not None and not (frames * joints <= lim.max_samples):
        raise ParseError(
            path, line, limit_message("frames x joints of", frames * joints, "max_samples", lim.max_samples)
        )


def check_option(option: str, what: str, value: float, name: str, *, at_least: bool = False) -> None:
    """``OptionError(option, ...)`` when ``value`` is beyond the limit ``name`` (or not a number)."""
    bound = getattr(_current, name)
    ok = value >= bound if at_least else value <= bound
    if not ok:  # NaN fails both
        raise OptionError(option, limit_message(what, value, name, bound, at_least=at_least))
