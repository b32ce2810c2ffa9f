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

Frame timing: ``fps`` is ``1 / dt`` of the frames (snapped to an integer when within
0.01 %). When the durations are not all equal (``humanoid3d_roll.txt`` has one frame of
0.0327 s among 0.0167 s ones), the clip is resampled onto a uniform grid at that rate by
geodesic interpolation, so that the Motion's times are right.
"""

from __future__ import annotations

import json
import math
import os
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

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


def _frame_line(text: str, k: int) -> int | None:
    """1-based line of the opening bracket of frame ``k`` in the ``Frames`` array."""
    start = text.find('"Frames"')
    if start < 0:
        return None
    depth = 0
    count = -1
    for pos in range(start, len(text)):
        ch = text[pos]
        if ch == "[":
            depth += 1
            if depth == 2:
                count += 1
                if count == k:
                    return text.count("\n", 0, pos) + 1
        elif ch == "]":
            depth -= 1
            if depth <= 0:
                return None
    return None


def _check_frames(p: str, text: str, frames: object) -> np.ndarray:
    if not isinstance(frames, list) or not frames:
        raise ParseError(p, _frame_line(text, 0) or 1, "expected 'Frames' to be a non-empty list of frames")
    out = np.empty((len(frames), _FRAME_SIZE))
    for k, fr in enumerate(frames):
        if not isinstance(fr, list) or len(fr) != _FRAME_SIZE:
            found = f"{len(fr)} values" if isinstance(fr, list) else type(fr).__name__
            raise ParseError(
                p,
                _frame_line(text, k),
                f"expected {_FRAME_SIZE} numbers in frame {k} (duration, root position, root "
                f"quaternion, 8 joint quaternions, 4 joint angles), found {found}",
            )
        for c, v in enumerate(fr):
            ok = isinstance(v, (int, float)) and not isinstance(v, bool)
            if ok:
                try:
                    out[k, c] = float(v)
                except OverflowError:  # an integer beyond the float range
                    ok = False
                ok = ok and math.isfinite(out[k, c])
            if not ok:
                shown = repr(v) if len(repr(v)) < 40 else repr(v)[:37] + "..."
                raise ParseError(
                    p,
                    _frame_line(text, k),
                    f"expected a finite number at position {c} of frame {k}, found {shown}",
                )
    return out


def _load_clip(p: str, text: str) -> dict[str, Any]:
    """The clip's JSON object, which must hold ``Frames``."""
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ParseError(p, exc.lineno, f"expected JSON ({exc.msg})") from exc
    except RecursionError as exc:
        raise ParseError(p, None, "expected JSON (nesting too deep)") from exc
    except ValueError as exc:  # e.g. an integer of more than 4300 digits
        raise ParseError(p, None, f"expected JSON numbers of usual size ({exc})") from exc
    if not isinstance(data, dict) or "Frames" not in data:
        raise ParseError(p, 1, "expected a JSON object with a 'Frames' list (a DeepMimic clip)")
    return data


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


def _frame_timing(p: str, text: str, values: np.ndarray, n_joints: int) -> tuple[np.ndarray, float, float]:
    """The frames' durations checked: ``(steps, dt, fps)`` with ``steps`` the durations
    between frames (s; the only one of a one-frame clip), ``dt`` their median (positive ones)
    and ``fps`` its rate (:func:`.bvh.snap_fps`); the clip checked against the limits."""
    durations = values[:, 0]
    if (durations < 0).any():
        k = int(np.argmax(durations < 0))
        raise ParseError(
            p,
            _frame_line(text, k),
            f"expected a non-negative frame duration in frame {k}, found {durations[k]}",
        )
    f = values.shape[0]
    steps = durations[:-1] if f > 1 else durations
    positive = steps[steps > 0]
    if positive.size == 0:
        positive = durations[durations > 0]
    if positive.size == 0:
        raise ParseError(
            p, _frame_line(text, 0), "expected a positive frame duration in some frame, found none"
        )
    if f > 1 and not (steps > 0).all():
        k = int(np.argmax(~(steps > 0)))
        raise ParseError(
            p,
            _frame_line(text, k),
            f"expected a positive duration in frame {k} (not the last), found {steps[k]}",
        )
    dt = float(np.median(positive))
    fps = snap_fps(dt)
    with np.errstate(over="ignore"):  # an overflowing sum is inf, refused by the duration limit
        duration = float(np.sum(steps)) if f > 1 else dt
    limits.check_clip(p, _frame_line(text, 0), frames=f, fps=fps, duration=duration, joints=n_joints)
    return steps, dt, fps


def _rotations(p: str, text: str, values: np.ndarray, skeleton: Skeleton, slot: list[int]) -> np.ndarray:
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
                p, _frame_line(text, k), f"expected a non-zero quaternion for {name!r} in frame {k}"
            )
        rotations[:, j] = quaternion_to_matrix(q)
        col += 4
    return rotations


def _resample_uniform(p: str, text: str, motion: Motion, steps: np.ndarray, fps: float) -> Motion:
    """``motion`` (frames ``steps`` seconds apart) on a uniform grid at ``fps``, its size
    checked against the limits before it is allocated."""
    f = motion.n_frames
    times = np.concatenate([[0.0], np.cumsum(steps)])
    if not (np.diff(times) > 0).all():  # a duration too small to advance the clock (1e-320 after 2 s)
        k = int(np.argmax(~(np.diff(times) > 0)))
        raise ParseError(
            p,
            _frame_line(text, k),
            f"expected a duration that advances the time in frame {k}, found {steps[k]}",
        )
    n_out = math.floor(times[-1] * fps + 1e-6) + 1  # finite: duration and fps within the limits
    lim = limits.current()
    grown = lim.max_resample_growth * f + 1000
    if n_out > grown:
        k = int(np.argmax(steps))
        raise ParseError(
            p,
            _frame_line(text, k),
            limits.limit_message(
                f"a uniform resampling at {fps:g} fps of {f} frames (frame {k} lasts {steps[k]:g} s) "
                "to give a number of frames",
                n_out,
                "max_resample_growth",
                f"{lim.max_resample_growth:g} x {f} + 1000 = {grown:g}",
            ),
        )
    limits.check_clip(p, _frame_line(text, 0), frames=n_out, joints=motion.n_joints)
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
    text = read_text(path)
    values = _check_frames(p, text, _load_clip(p, text)["Frames"])
    if skeleton is None:
        skeleton = read_urdf_skeleton(urdf) if urdf is not None else deepmimic_skeleton()
    slot = _frame_slots(skeleton)
    steps, dt, fps = _frame_timing(p, text, values, skeleton.n_joints)
    motion = Motion(
        skeleton=skeleton,
        fps=fps,
        root_translation=values[:, 1:4],
        rotations=_rotations(p, text, values, skeleton, slot),
        metres_per_unit=1.0,
        up_axis="y",
        source=(p,) if urdf is None else (p, os.fspath(urdf)),
        name=Path(p).stem,
    )
    if resample_uniform and values.shape[0] > 2 and np.abs(steps - dt).max() > 1e-3 * dt:
        motion = _resample_uniform(p, text, motion, steps, fps)
    return motion
