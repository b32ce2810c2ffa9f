"""DeepMimic motion clips (JSON) and the DeepMimic humanoid skeleton.

File format (``humanoid3d_*.txt`` shipped with pybullet, DeepMimic)::

    {"Loop": "wrap" | "none", "Frames": [[dt, px, py, pz, qw, qx, qy, qz, ...], ...]}

A frame is: the duration ``dt`` (seconds until the next frame; often 0 on the last), the
root position (3, metres, **Y up**), the root orientation as a quaternion **(w, x, y, z)**,
then the 12 joints in this order -- chest, neck, right hip, right knee, right ankle,
right shoulder, right elbow, left hip, left knee, left ankle, left shoulder, left elbow --
as quaternions **(w, x, y, z)** for the spherical joints and one angle (radians, about
the joint's axis, ``z``) for knees and elbows: 44 numbers. Quaternions are local rotations
relative to the parent link; they are normalised on reading (some files store them far
from unit length).

The skeleton is the one of ``humanoid.urdf`` at pybullet's ``globalScaling = 0.25``
(the scale DeepMimic's humanoid runs at, in metres); it is built in
(:func:`deepmimic_skeleton`) and can be read from the URDF instead. The wrists (fixed
joints of the URDF, not in the frames) are joints of the skeleton with the identity
rotation, so that a hand on the floor is a contact like a foot; end sites: the centres of
the head and foot collision shapes.

Reading: the JSON text is read left to right and its structure checked as it comes (no
``json.loads`` of the whole): the ``Frames`` list frame by frame, each a list of 44 plain
JSON numbers kept as float64, so a malformed file fails at its first bad frame with memory
of the order of its text (30 MB of empty frames: 0.1 s, where a Python object per frame took
870 MB and 10 s). The other entries (``"Loop"``, ``"RightJoints"``, ...) are settings: checked
as JSON (at most 100,000 values, nested at most 1,000 deep) and dropped. Every error names
the file and a line, what was expected and what came.

Frame timing: ``fps`` is ``1 / dt`` of the frames (snapped to an integer when within
0.01 %). When the durations are not all equal (``humanoid3d_roll.txt`` has one frame of
0.0327 s among 0.0167 s ones), the clip is resampled onto a uniform grid at that rate by
geodesic interpolation, so that the Motion's times are right.
"""

from __future__ import annotations

import json
import math
import os
import re
from array import array
from pathlib import Path

import numpy as np

from elastic_motion import limits
from elastic_motion._io import read_text
from elastic_motion.errors import ParseError
from elastic_motion.motion.bvh import snap_fps
from elastic_motion.motion.edit import resample_at_times
from elastic_motion.motion.rotations import axis_rotation, quaternion_to_matrix
from elastic_motion.motion.skeleton import Motion, Skeleton

__all__ = [
    "DEEPMIMIC_FIXED_JOINTS",
    "DEEPMIMIC_JOINTS",
    "SKELETON_ORDER",
    "deepmimic_skeleton",
    "read_deepmimic",
    "read_urdf_skeleton",
]

#: Joints of the humanoid in frame order (root first): (name, parent, revolute).
DEEPMIMIC_JOINTS: tuple[tuple[str, str, bool], ...] = (
    ("root", "", False),
    ("chest", "root", False),
    ("neck", "chest", False),
    ("right_hip", "root", False),
    ("right_knee", "right_hip", True),
    ("right_ankle", "right_knee", False),
    ("right_shoulder", "chest", False),
    ("right_elbow", "right_shoulder", True),
    ("left_hip", "root", False),
    ("left_knee", "left_hip", True),
    ("left_ankle", "left_knee", False),
    ("left_shoulder", "chest", False),
    ("left_elbow", "left_shoulder", True),
)

#: The humanoid's fixed joints (name, parent): the wrists. Not in the frames (their rotation
#: is the identity in every frame); joints of the Skeleton so that the hands are points a
#: contact can plant (cartwheels, handsprings).
DEEPMIMIC_FIXED_JOINTS: tuple[tuple[str, str], ...] = (
    ("right_wrist", "right_elbow"),
    ("left_wrist", "left_elbow"),
)

#: Joint order of the Skeleton: depth-first (as a BVH file lists them), children in
#: frame order. Frame order and skeleton order differ; readers map by name.
SKELETON_ORDER: tuple[str, ...] = (
    "root",
    "chest",
    "neck",
    "right_shoulder",
    "right_elbow",
    "right_wrist",
    "left_shoulder",
    "left_elbow",
    "left_wrist",
    "right_hip",
    "right_knee",
    "right_ankle",
    "left_hip",
    "left_knee",
    "left_ankle",
)

#: pybullet loads humanoid.urdf with ``globalScaling=0.25``; that is the clips' scale.
URDF_SCALE = 0.25

# humanoid.urdf joint origins (unscaled), and the end sites (joint, unscaled offset).
_URDF_OFFSETS = {
    "root": (0.0, 0.0, 0.0),
    "chest": (0.0, 0.944604, 0.0),
    "neck": (0.0, 0.895576, 0.0),
    "right_hip": (0.0, 0.0, 0.339548),
    "right_knee": (0.0, -1.686184, 0.0),
    "right_ankle": (0.0, -1.639480, 0.0),
    "right_shoulder": (-0.096200, 0.974000, 0.732440),
    "right_elbow": (0.0, -1.099152, 0.0),
    "left_hip": (0.0, 0.0, -0.339548),
    "left_knee": (0.0, -1.686184, 0.0),
    "left_ankle": (0.0, -1.639480, 0.0),
    "left_shoulder": (-0.096200, 0.974000, -0.732440),
    "left_elbow": (0.0, -1.099152, 0.0),
    "right_wrist": (0.0, -1.035788, 0.0),  # fixed joints: the centres of the hand spheres
    "left_wrist": (0.0, -1.035788, 0.0),
}
_URDF_END_SITES = (  # depth-first order, as a BVH file lists them
    ("neck", (0.0, 0.7, 0.0)),  # centre of the head sphere
    ("right_ankle", (0.18, -0.09, 0.0)),  # centre of the foot box
    ("left_ankle", (0.18, -0.09, 0.0)),
)
_ROOT_CHANNELS = ("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation")
_JOINT_CHANNELS = ("Zrotation", "Yrotation", "Xrotation")
_FRAME_SIZE = 1 + 3 + 4 + sum(1 if rev else 4 for _, _, rev in DEEPMIMIC_JOINTS[1:])


def _build_skeleton(offsets: dict, end_sites: list, scale: float) -> Skeleton:
    names = list(SKELETON_ORDER)
    parent_of = {n: p for n, p, _ in DEEPMIMIC_JOINTS} | dict(DEEPMIMIC_FIXED_JOINTS)
    parents = [names.index(parent_of[n]) if parent_of[n] else -1 for n in names]
    return Skeleton(
        names=names,
        parents=parents,
        offsets=np.array([offsets[n] for n in names]) * scale,
        channels=[_ROOT_CHANNELS] + [_JOINT_CHANNELS] * (len(names) - 1),
        end_site_parents=[names.index(j) for j, _ in end_sites],
        end_site_offsets=np.array([o for _, o in end_sites]).reshape(-1, 3) * scale,
    )


def deepmimic_skeleton() -> Skeleton:
    """The DeepMimic humanoid (15 joints, metres, Y up), as in ``humanoid.urdf`` x 0.25.

    The 13 joints of the clips' frames and the two fixed wrists (identity rotation).

    Joints in depth-first order (:data:`SKELETON_ORDER`).

    Every joint has BVH channels ``Zrotation Yrotation Xrotation`` (root: positions
    first), so a converted clip writes as an ordinary BVH file; knees and elbows rotate
    about ``z`` only, which ``ZYX`` Euler angles express as ``(angle, 0, 0)``.
    """
    return _build_skeleton(_URDF_OFFSETS, list(_URDF_END_SITES), URDF_SCALE)


def read_urdf_skeleton(path: str | os.PathLike[str], *, scale: float = URDF_SCALE) -> Skeleton:
    """Read the DeepMimic humanoid's joint offsets from ``humanoid.urdf``.

    Parameters
    ----------
    path : str or os.PathLike
    scale : float, default 0.25
        Length scale applied to the URDF (pybullet's ``globalScaling`` for DeepMimic).

    Returns
    -------
    Skeleton
        Same joints, order and channels as :func:`deepmimic_skeleton`; offsets from the
        joints' ``<origin xyz>`` (the fixed wrists' too), end sites from the head and foot
        links' collision origins.

    Raises
    ------
    ParseError
        Malformed XML, or a DeepMimic joint missing from the file.
    """
    import xml.etree.ElementTree as ET  # local: only a URDF needs it (CLI start-up)

    p = os.fspath(path)
    # pybullet's humanoid.urdf ends with a NUL byte after </robot>: trim trailing NULs.
    text = read_text(path).rstrip("\x00 \t\r\n")
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise ParseError(p, exc.position[0], f"expected well-formed URDF XML ({exc})") from exc

    def xyz(elem, what: str) -> tuple[float, float, float]:
        origin = elem.find("origin")
        raw = origin.get("xyz", "0 0 0") if origin is not None else "0 0 0"
        try:
            vals = tuple(float(v) for v in raw.split())
        except ValueError:
            vals = ()
        if len(vals) != 3 or not all(math.isfinite(v) for v in vals):
            raise ParseError(p, None, f"expected 'x y z' numbers in the origin of {what}, found {raw!r}")
        return vals

    joints = {j.get("name"): j for j in root.iter("joint")}
    links = {lk.get("name"): lk for lk in root.iter("link")}
    offsets = {"root": (0.0, 0.0, 0.0)}
    for name in [n for n, _, _ in DEEPMIMIC_JOINTS[1:]] + [n for n, _ in DEEPMIMIC_FIXED_JOINTS]:
        if name not in joints:
            raise ParseError(p, None, f"expected a joint named {name!r} in the URDF, found none")
        offsets[name] = xyz(joints[name], f"joint {name!r}")
    end_sites = []
    for joint, _ in _URDF_END_SITES:
        link = links.get(joint)
        coll = link.find("collision") if link is not None else None
        if coll is None:
            raise ParseError(p, None, f"expected a link {joint!r} with a <collision> in the URDF")
        end_sites.append((joint, xyz(coll, f"the collision of link {joint!r}")))
    return _build_skeleton(offsets, end_sites, scale)


# ------------------------------------------------------------------------------------------
# The clip's text, read left to right: structure checked while streaming
# ------------------------------------------------------------------------------------------
_JSON_NUMBER = r"-?(?:0|[1-9][0-9]*)(?:\.[0-9]+)?(?:[eE][+-]?[0-9]+)?"
_BLANK = "[ \t\n\r]*"
_WS = re.compile(_BLANK)
_NUMBER = re.compile(_JSON_NUMBER)
_LITERAL = re.compile(r"true|false|null|NaN|-?Infinity")
#: A frame of plain values: no nested list, object or string between its brackets.
_FLAT_FRAME = re.compile(r"\[([^\[\]{}\"]*)\]")
_NUMBER_LIST = re.compile(f"{_BLANK}{_JSON_NUMBER}{_BLANK}(?:,{_BLANK}{_JSON_NUMBER}{_BLANK})*")
_FRAME_WHAT = "duration, root position, root quaternion, 8 joint quaternions, 4 joint angles"
#: Frames converted to numbers at a time (bounded temporary text).
_BATCH = 4096
#: The other entries of a clip are settings (``"Loop": "wrap"``, ``"RightJoints": [3, 4, 5, 6, 7, 8]``):
#: at most this many values and this deep, checked as JSON without being kept.
_MAX_SETTING_VALUES = 100_000
_MAX_SETTING_DEPTH = 1_000


class _ClipText:
    """A DeepMimic file's text with the positions of its frames, for errors that name lines."""

    def __init__(self, path: str, text: str) -> None:
        self.path = path
        self.text = text
        self.frame_starts = array("q")  # offset of each frame's '['

    def line_at(self, pos: int) -> int:
        """1-based line of the character at offset ``pos``."""
        return self.text.count("\n", 0, pos) + 1

    def frame_line(self, k: int) -> int:
        """1-based line of the opening bracket of frame ``k``."""
        return self.line_at(self.frame_starts[k])

    def error(self, pos: int, message: str) -> ParseError:
        return ParseError(self.path, self.line_at(pos), message)

    def ws(self, pos: int) -> int:
        """The offset of the first non-blank character from ``pos``."""
        return _WS.match(self.text, pos).end()

    def found(self, pos: int) -> str:
        """What is at ``pos``, for a message: a few characters, or the end of the file."""
        if pos >= len(self.text):
            return "the end of the file"
        shown = self.text[pos : pos + 20]
        return repr(shown if len(self.text) <= pos + 20 else shown + "...")

    def string(self, pos: int, what: str) -> tuple[str, int]:
        """The JSON string at ``pos`` (``what`` names it in an error) and the offset after it."""
        if not self.text.startswith('"', pos):
            raise self.error(pos, f"expected JSON ({what} in double quotes), found {self.found(pos)}")
        try:
            return json.decoder.scanstring(self.text, pos + 1)
        except json.JSONDecodeError as exc:
            raise self.error(exc.pos, f"expected JSON ({exc.msg})") from None

    def expect(self, pos: int, char: str, what: str) -> int:
        """The offset after ``char`` at ``pos`` (blanks skipped before and after)."""
        pos = self.ws(pos)
        if not self.text.startswith(char, pos):
            raise self.error(pos, f"expected JSON ({char!r} {what}), found {self.found(pos)}")
        return self.ws(pos + 1)


def _parse_clip(clip: _ClipText) -> np.ndarray:
    """The frames ``(F, 44)`` of the clip's JSON object, read in one pass.

    The ``Frames`` list is read frame by frame and checked as it comes, so a malformed file
    fails at its first bad frame, with its line, before anything is built for the others
    (``json.loads`` first made a Python object of every frame: 870 MB for 30 MB of empty
    frames). The other entries are checked as JSON and dropped.
    """
    text = clip.text
    pos = clip.ws(1 if text.startswith("\ufeff") else 0)
    if not text.startswith("{", pos):
        raise clip.error(
            pos, f"expected a JSON object with a 'Frames' list (a DeepMimic clip), found {clip.found(pos)}"
        )
    values = None
    pos = clip.ws(pos + 1)
    closed = text.startswith("}", pos)
    while not closed:
        key, pos = clip.string(pos, "a key")
        pos = clip.expect(pos, ":", f"after the key {key!r}")
        if key == "Frames":
            values, pos = _parse_frames(clip, pos)
        else:
            pos = _skip_value(clip, pos, f"the value of {key!r}")
        pos = clip.ws(pos)
        closed = text.startswith("}", pos)
        if not closed:
            pos = clip.expect(pos, ",", f"or '}}' after the value of {key!r}")
    pos = clip.ws(pos + 1)
    if pos < len(text):
        raise clip.error(pos, f"expected JSON (nothing after the clip's last '}}'), found {clip.found(pos)}")
    if values is None:
        raise clip.error(0, "expected a JSON object with a 'Frames' list (a DeepMimic clip), found none")
    return values


def _parse_frames(clip: _ClipText, pos: int) -> tuple[np.ndarray, int]:
    """The ``Frames`` list at ``pos``: its values ``(F, 44)`` and the offset after it."""
    text = clip.text
    if not text.startswith("[", pos) or text.startswith("]", clip.ws(pos + 1)):
        found = "[]" if text.startswith("[", pos) else clip.found(pos)
        raise clip.error(pos, f"expected 'Frames' to be a non-empty list of frames, found {found}")
    clip.frame_starts = starts = array("q")
    max_frames = limits.current().max_frames
    chunks: list[np.ndarray] = []
    batch: list[str] = []
    pos = clip.ws(pos + 1)
    while True:
        k = len(starts)
        if k >= max_frames:  # before a frame more is kept
            limits.check_clip(clip.path, clip.line_at(pos), frames=k + 1)
        starts.append(pos)
        m = _FLAT_FRAME.match(text, pos)
        if m is None or not _NUMBER_LIST.fullmatch(m.group(1)):
            raise _frame_error(clip, k, pos)
        content = m.group(1)
        if content.count(",") + 1 != _FRAME_SIZE:
            raise _count_error(clip, k, content.count(",") + 1)
        batch.append(content)
        if len(batch) == _BATCH:
            chunks.append(_frame_numbers(clip, batch, k + 1 - len(batch)))
            batch = []
        pos = clip.ws(m.end())
        if text.startswith("]", pos):
            break
        pos = clip.expect(pos, ",", f"or ']' after frame {k}")
    if batch:
        chunks.append(_frame_numbers(clip, batch, len(starts) - len(batch)))
    values = chunks[0] if len(chunks) == 1 else np.concatenate(chunks)
    return values, pos + 1


def _frame_numbers(clip: _ClipText, contents: list[str], first: int) -> np.ndarray:
    """The values ``(len(contents), 44)`` of frames ``first, first + 1, ...``, whose text between
    the brackets (``contents``) holds 44 JSON numbers each; finite, else an error naming the frame."""
    joined = ",".join(contents)
    try:
        flat = np.fromstring(joined, sep=",")
    except ValueError:  # not expected for JSON numbers; Python's float() reads them too
        flat = np.array([float(v) for v in joined.split(",")])
    out = flat.reshape(len(contents), _FRAME_SIZE)
    bad = ~np.isfinite(out)
    if bad.any():
        r, c = (int(v) for v in np.argwhere(bad)[0])
        token = contents[r].split(",")[c].strip()
        raise _value_error(clip, first + r, c, token)
    return out


def _count_error(clip: _ClipText, k: int, n: int) -> ParseError:
    return ParseError(
        clip.path,
        clip.frame_line(k),
        f"expected {_FRAME_SIZE} numbers in frame {k} ({_FRAME_WHAT}), found {n} value{'s' * (n != 1)}",
    )


def _value_error(clip: _ClipText, k: int, c: int, shown: str) -> ParseError:
    shown = shown if len(shown) < 40 else shown[:37] + "..."
    return ParseError(
        clip.path, clip.frame_line(k), f"expected a finite number at position {c} of frame {k}, found {shown}"
    )


def _json_kind(clip: _ClipText, pos: int) -> str:
    """What kind of JSON value starts at ``pos``, for a message ("a string", "an object")."""
    c = clip.text[pos : pos + 1]
    kinds = {"[": "a list", "{": "an object", '"': "a string", "t": "true", "f": "false", "n": "null"}
    if c in kinds:
        return kinds[c]
    return "a number" if _NUMBER.match(clip.text, pos) else clip.found(pos)


def _frame_error(clip: _ClipText, k: int, pos: int) -> ParseError:
    """The error for frame ``k`` at ``pos``, which is not a list of plain JSON numbers: the
    wrong count of values if so, else the first value that is not a finite number."""
    text = clip.text
    if not text.startswith("[", pos):
        return clip.error(
            pos, f"expected {_FRAME_SIZE} numbers in frame {k} ({_FRAME_WHAT}), found {_json_kind(clip, pos)}"
        )
    n, first_bad = 0, None
    pos = clip.ws(pos + 1)
    if not text.startswith("]", pos):
        while True:
            m = _NUMBER.match(text, pos)
            if m is None and first_bad is None:
                lit = _LITERAL.match(text, pos)
                shown = lit.group() if lit is not None else _json_kind(clip, pos)
                first_bad = (n, shown)
            pos = m.end() if m is not None else _skip_value(clip, pos, f"frame {k}")
            n += 1
            pos = clip.ws(pos)
            if text.startswith("]", pos):
                break
            pos = clip.expect(pos, ",", f"or ']' after value {n - 1} of frame {k}")
    if n != _FRAME_SIZE:
        return _count_error(clip, k, n)
    if first_bad is not None:
        return _value_error(clip, k, *first_bad)
    return clip.error(pos, f"expected {_FRAME_SIZE} JSON numbers in frame {k}")  # pragma: no cover


def _skip_value(clip: _ClipText, pos: int, where: str) -> int:
    """The offset after the JSON value at ``pos`` (``where`` names its place in errors),
    checked as JSON without building it: at most ``_MAX_SETTING_VALUES`` values nested
    at most ``_MAX_SETTING_DEPTH`` deep (an explicit stack: no recursion)."""
    text = clip.text
    stack = bytearray()  # the open containers: ord("[") or ord("{")
    for _ in range(_MAX_SETTING_VALUES):
        pos = clip.ws(pos)
        if text.startswith(("[", "{"), pos):
            if len(stack) >= _MAX_SETTING_DEPTH:
                raise clip.error(pos, f"expected JSON nested at most {_MAX_SETTING_DEPTH} deep in {where}")
            stack.append(ord(text[pos]))
            pos = clip.ws(pos + 1)
            if text.startswith("]" if stack[-1] == ord("[") else "}", pos):
                stack.pop()
                pos += 1
            elif stack[-1] == ord("{"):
                pos = clip.expect(clip.string(pos, "a key")[1], ":", "after a key")
                continue
            else:
                continue
        elif text.startswith('"', pos):
            pos = clip.string(pos, "a string")[1]
        else:
            m = _NUMBER.match(text, pos) or _LITERAL.match(text, pos)
            if m is None:
                raise clip.error(pos, f"expected JSON (a value in {where}), found {clip.found(pos)}")
            pos = m.end()
        pos, more = _close_containers(clip, pos, stack, where)
        if not more:
            return pos
    raise clip.error(pos, f"expected at most {_MAX_SETTING_VALUES} values in {where} (a clip setting)")


def _close_containers(clip: _ClipText, pos: int, stack: bytearray, where: str) -> tuple[int, bool]:
    """After a value: close the containers it ends; ``(offset, True)`` when another value of an
    open container follows (its key read, for an object), ``(offset, False)`` when none is open."""
    text = clip.text
    while stack:
        closer = "]" if stack[-1] == ord("[") else "}"
        pos = clip.ws(pos)
        if text.startswith(closer, pos):
            stack.pop()
            pos += 1
            continue
        pos = clip.expect(pos, ",", f"or {closer!r} in {where}")
        if stack[-1] == ord("{"):
            pos = clip.expect(clip.string(pos, "a key")[1], ":", "after a key")
        return pos, True
    return pos, False


def _frame_slots(skeleton: Skeleton) -> list[int]:
    """The skeleton index of each joint of the frames (:data:`DEEPMIMIC_JOINTS` order)."""
    try:
        slot = [skeleton.index(name) for name, _, _ in DEEPMIMIC_JOINTS]
    except KeyError as exc:
        raise ValueError(f"skeleton: expected the DeepMimic humanoid's joints; {exc.args[0]}") from None
    n_expected = len(DEEPMIMIC_JOINTS) + len(DEEPMIMIC_FIXED_JOINTS)
    if skeleton.n_joints != n_expected or not all(n in skeleton.names for n, _ in DEEPMIMIC_FIXED_JOINTS):
        raise ValueError(
            f"skeleton: expected the {n_expected}-joint DeepMimic humanoid (with the fixed wrists); "
            f"got {skeleton.n_joints} joints"
        )
    return slot


def _frame_timing(clip: _ClipText, values: np.ndarray, n_joints: int) -> tuple[np.ndarray, float, float]:
    """The frames' durations checked: ``(steps, dt, fps)`` with ``steps`` the durations
    between frames (s; the only one of a one-frame clip), ``dt`` their median (positive ones)
    and ``fps`` its rate (:func:`.bvh.snap_fps`); the clip checked against the limits."""
    durations = values[:, 0]
    if (durations < 0).any():
        k = int(np.argmax(durations < 0))
        raise ParseError(
            clip.path,
            clip.frame_line(k),
            f"expected a non-negative frame duration in frame {k}, found {durations[k]}",
        )
    f = values.shape[0]
    steps = durations[:-1] if f > 1 else durations
    positive = steps[steps > 0]
    if positive.size == 0:
        positive = durations[durations > 0]
    if positive.size == 0:
        raise ParseError(
            clip.path, clip.frame_line(0), "expected a positive frame duration in some frame, found none"
        )
    if f > 1 and not (steps > 0).all():
        k = int(np.argmax(~(steps > 0)))
        raise ParseError(
            clip.path,
            clip.frame_line(k),
            f"expected a positive duration in frame {k} (not the last), found {steps[k]}",
        )
    dt = float(np.median(positive))
    fps = snap_fps(dt)
    with np.errstate(over="ignore"):  # an overflowing sum is inf, refused by the duration limit
        duration = float(np.sum(steps)) if f > 1 else dt
    limits.check_clip(clip.path, clip.frame_line(0), frames=f, fps=fps, duration=duration, joints=n_joints)
    return steps, dt, fps


def _rotations(clip: _ClipText, values: np.ndarray, skeleton: Skeleton, slot: list[int]) -> np.ndarray:
    """Local rotations ``(F, J, 3, 3)``: the frames' quaternions (normalised) and revolute
    angles (about ``z``) at ``slot``, the identity at the fixed wrists."""
    rotations = np.empty((values.shape[0], skeleton.n_joints, 3, 3))
    for name, _ in DEEPMIMIC_FIXED_JOINTS:
        rotations[:, skeleton.index(name)] = np.eye(3)
    col = 4
    for j, (name, _, revolute) in zip(slot, DEEPMIMIC_JOINTS, strict=True):
        if revolute:
            rotations[:, j] = axis_rotation(values[:, col], "Z")
            col += 1
            continue
        q = values[:, col : col + 4]
        scale = np.abs(q).max(axis=1, keepdims=True)  # rescaled first: |q| of 1e308 values overflows
        q = q / np.where(scale > 0, scale, 1.0)
        norms = np.linalg.norm(q, axis=1)
        if not (norms > 1e-12).all():
            k = int(np.argmax(~(norms > 1e-12)))
            raise ParseError(
                clip.path, clip.frame_line(k), f"expected a non-zero quaternion for {name!r} in frame {k}"
            )
        rotations[:, j] = quaternion_to_matrix(q)
        col += 4
    return rotations


def _resample_uniform(clip: _ClipText, motion: Motion, steps: np.ndarray, fps: float) -> Motion:
    """``motion`` (frames ``steps`` seconds apart) on a uniform grid at ``fps``, its size
    checked against the limits before it is allocated."""
    f = motion.n_frames
    times = np.concatenate([[0.0], np.cumsum(steps)])
    if not (np.diff(times) > 0).all():  # a duration too small to advance the clock (1e-320 after 2 s)
        k = int(np.argmax(~(np.diff(times) > 0)))
        raise ParseError(
            clip.path,
            clip.frame_line(k),
            f"expected a duration that advances the time in frame {k}, found {steps[k]}",
        )
    n_out = math.floor(times[-1] * fps + 1e-6) + 1  # finite: duration and fps within the limits
    lim = limits.current()
    grown = lim.max_resample_growth * f + 1000
    if n_out > grown:
        k = int(np.argmax(steps))
        raise ParseError(
            clip.path,
            clip.frame_line(k),
            limits.limit_message(
                f"a uniform resampling at {fps:g} fps of {f} frames (frame {k} lasts {steps[k]:g} s) "
                "to give a number of frames",
                n_out,
                "max_resample_growth",
                f"{lim.max_resample_growth:g} x {f} + 1000 = {grown:g}",
            ),
        )
    limits.check_clip(clip.path, clip.frame_line(0), frames=n_out, joints=motion.n_joints)
    return resample_at_times(motion, times, np.arange(n_out) / fps, fps=fps)


def read_deepmimic(
    path: str | os.PathLike[str],
    *,
    skeleton: Skeleton | None = None,
    urdf: str | os.PathLike[str] | None = None,
    resample_uniform: bool = True,
) -> Motion:
    """Read a DeepMimic motion clip.

    Parameters
    ----------
    path : str or os.PathLike
        A ``humanoid3d_*.txt`` (JSON) file.
    skeleton : Skeleton, optional
        The humanoid; default the built-in :func:`deepmimic_skeleton`.
    urdf : str or os.PathLike, optional
        Read the skeleton from this ``humanoid.urdf`` instead (:func:`read_urdf_skeleton`).
    resample_uniform : bool, default True
        When frame durations differ, resample onto a uniform grid (geodesic interpolation);
        with ``False`` the frames are kept as they are and ``fps`` is their median rate.

    Returns
    -------
    Motion
        15 joints (the frames' 13 and the fixed wrists), metres, Y up.

    Raises
    ------
    ParseError
        Invalid JSON, missing ``Frames``, a frame with the wrong count of values or a
        non-numeric value, a negative duration, an all-zero quaternion; a frame rate, duration
        or resampled size beyond the resource limits (:mod:`elastic_motion.limits`), checked
        before the resampled clip is allocated.
    """
    p = os.fspath(path)
    clip = _ClipText(p, read_text(path))
    values = _parse_clip(clip)
    if skeleton is None:
        skeleton = read_urdf_skeleton(urdf) if urdf is not None else deepmimic_skeleton()
    slot = _frame_slots(skeleton)
    steps, dt, fps = _frame_timing(clip, values, skeleton.n_joints)
    motion = Motion(
        skeleton=skeleton,
        fps=fps,
        root_translation=values[:, 1:4],
        rotations=_rotations(clip, values, skeleton, slot),
        metres_per_unit=1.0,
        up_axis="y",
        source=(p,) if urdf is None else (p, os.fspath(urdf)),
        name=Path(p).stem,
    )
    if resample_uniform and values.shape[0] > 2 and np.abs(steps - dt).max() > 1e-3 * dt:
        motion = _resample_uniform(clip, motion, steps, fps)
    return motion
