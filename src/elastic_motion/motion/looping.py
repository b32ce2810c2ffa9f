"""The loop convention of game engines on a motion: the cycle transform, a clip played on
repeat, the treadmill of an in-place clip.

Conventions
-----------
* **Cycle and cycle transform.** A looping clip (a *cycle*) of ``F`` frames is played with
  its last frame dropped: the next cycle starts where the last frame was. The next cycle is
  the clip moved by the *cycle transform* ``T``, a rigid map of the world applied to the
  root (position and orientation; joint-local rotations are unchanged):

  - ``root="travel"``: ``T`` rotates about the up axis by the clip's heading change
    ``delta`` (the twist about the up axis of ``R_root[F-1] R_root[0]^T``, in radians) and
    moves the floor-plane root position of frame 0 to that of frame ``F-1``:
    ``T(x) = Y(delta) (x - floor(p_0)) + floor(p_{F-1})`` (``floor`` zeroes the up
    coordinate). The character travels on (and turns) from cycle to cycle.
  - ``root="inplace"``: ``T`` is the identity; the clip must come back to its start.

  A clip is a seamless (C0) loop when its last frame equals ``T`` applied to its first.
* **Treadmill** (:func:`treadmill`): an in-place clip whose feet stay planted cannot come
  back to its start; its travel is removed at a constant rate instead, so planted feet move
  back with a belt (:func:`on_belt` puts the belt's motion back).
* **Units**: positions in the motion's length unit; angles in radians.
"""

from __future__ import annotations

import math

import numpy as np

from elastic_motion import limits
from elastic_motion._validation import check_finite
from elastic_motion.errors import OptionError
from elastic_motion.groups import SO3
from elastic_motion.motion.rotations import axis_rotation
from elastic_motion.motion.skeleton import Motion
from elastic_motion.vocabulary import ROOT_MODES, RootMode

__all__ = [
    "ROOT_MODES",
    "RootMode",
    "check_loop_motion",
    "check_root",
    "cycle_transform",
    "on_belt",
    "repeat_motion",
    "treadmill",
    "twist_angle",
]

# The loop conventions (module docstring), RootMode ("travel": the character travels on from
# cycle to cycle, "inplace": it comes back to where it started) and ROOT_MODES, live in
# elastic_motion.vocabulary.

_SO3 = SO3()
_AXES = "xyz"


def twist_angle(r: np.ndarray, axis: int) -> float:
    """Angle of the twist of rotation ``r`` about coordinate ``axis`` (swing-twist
    decomposition ``r = swing twist``, from the quaternion ``(w, v)``: ``2 atan2(v_a, w)``)."""
    ell = _SO3.log(r)
    a = float(np.linalg.norm(ell))
    w = math.cos(0.5 * a)
    va = math.sin(0.5 * a) * (ell[axis] / a) if a > 0 else 0.0
    delta = 2.0 * math.atan2(va, w)
    return (delta + math.pi) % (2.0 * math.pi) - math.pi


def check_root(root: str) -> str:
    """``root`` if it is a loop convention (:data:`RootMode`), else an :class:`OptionError`."""
    if root not in ROOT_MODES:
        raise OptionError("root", f"expected 'travel' or 'inplace'; got {root!r}")
    return root


def check_loop_motion(motion: object, name: str = "motion", min_frames: int = 3) -> Motion:
    """``motion`` if it is a :class:`Motion` of at least ``min_frames`` finite frames, else an error
    naming ``name``."""
    if not isinstance(motion, Motion):
        raise ValueError(f"{name}: expected a Motion; got {type(motion).__name__}")
    if motion.n_frames < min_frames:
        raise ValueError(
            f"{name}: expected at least {min_frames} frames to make a loop; got {motion.n_frames}"
        )
    check_finite(motion.rotations, f"{name}.rotations")
    check_finite(motion.root_translation, f"{name}.root_translation")
    return motion


def cycle_transform(motion: Motion, root: str = "travel") -> tuple[np.ndarray, np.ndarray]:
    """The rigid map ``x -> rot @ x + shift`` taking a cycle to the next one.

    Parameters
    ----------
    motion : Motion
        At least 2 frames.
    root : {"travel", "inplace"}

    Returns
    -------
    rot : ndarray, shape (3, 3)
        Rotation about the up axis by the heading change (identity for ``"inplace"``).
    shift : ndarray, shape (3,)
        Translation in the floor plane (motion length units).
    """
    check_root(root)
    if root == "inplace":
        return np.eye(3), np.zeros(3)
    up = _AXES.index(motion.up_axis)
    r_root = motion.rotations[-1, 0] @ motion.rotations[0, 0].T
    rot = axis_rotation(twist_angle(r_root, up), "XYZ"[up])
    p0 = motion.root_translation[0].copy()
    p1 = motion.root_translation[-1].copy()
    p0[up] = 0.0
    p1[up] = 0.0
    return rot, p1 - rot @ p0


def treadmill(motion: Motion) -> tuple[Motion, float, float]:
    """The clip with its travel removed at a constant rate: frame ``f`` (``s = f / (F - 1)``)
    is moved by ``x -> Y(-s delta) (x - L_s) + floor(p_0)``, where ``delta`` is the heading
    change of the clip and ``L_s`` runs straight from the root's floor-plane position on the
    first frame to that on the last (:func:`cycle_transform` with ``"travel"``, undone a
    fraction at a time). The first frame is unchanged, the last is back on the first's floor
    position and heading; heights and joint-local rotations are kept, so a planted foot
    moves back at the clip's mean speed (the treadmill of an in-place game clip).

    Returns
    -------
    Motion
    travel : float
        The floor-plane distance removed (motion length units).
    turn : float
        The heading change removed (radians).
    """
    turn, p0, line, delta = _belt(motion)
    r = turn.swapaxes(-1, -2)  # (F, 3, 3): each frame turned back
    root = np.einsum("fij,fj->fi", r, motion.root_translation - line) + p0
    rots = motion.rotations.copy()
    rots[:, 0] = r @ rots[:, 0]
    return motion.replace(root_translation=root, rotations=rots), float(np.linalg.norm(line[-1] - p0)), delta


def _belt(motion: Motion) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """The treadmill of a clip (:func:`treadmill`): per frame the turn ``Y(delta s)`` it has
    made by then ``(F, 3, 3)``, the first floor position ``p0``, the straight line ``L_s``
    from it to the last ``(F, 3)`` and the heading change ``delta`` (radians)."""
    up = _AXES.index(motion.up_axis)
    s = np.arange(motion.n_frames) / max(motion.n_frames - 1, 1)
    delta = twist_angle(motion.rotations[-1, 0] @ motion.rotations[0, 0].T, up)
    p0, p1 = motion.root_translation[0].copy(), motion.root_translation[-1].copy()
    p0[up] = p1[up] = 0.0
    return axis_rotation(delta * s, "XYZ"[up]), p0, p0 + s[:, None] * (p1 - p0), float(delta)


def on_belt(motion: Motion, original: Motion) -> Motion:
    """``motion`` (on ``original``'s frames) with :func:`treadmill` of ``original`` undone: the
    travel and turn that the treadmill removes at a constant rate put back, so a foot that
    rides the belt stands still. The inverse of ``treadmill(original)`` (exact on it)."""
    f = original.n_frames
    if motion.n_frames != f:
        raise ValueError(f"motion: expected {f} frames like the original; got {motion.n_frames}")
    r, p0, line, _ = _belt(original)
    root = np.einsum("fij,fj->fi", r, motion.root_translation - p0) + line
    rots = motion.rotations.copy()
    rots[:, 0] = r @ rots[:, 0]
    return motion.replace(root_translation=root, rotations=rots)


def repeat_motion(motion: Motion, cycles: int = 3, root: str = "travel") -> Motion:
    """Play a clip ``cycles`` times, each cycle moved by the cycle transform.

    Cycle ``k`` is frames ``0 .. F-2`` moved by ``T^k``; the last frame of the last cycle is
    kept, so the result has ``cycles (F - 1) + 1`` frames. For a closed clip frame
    ``k (F - 1)`` is the seam.

    Parameters
    ----------
    motion : Motion
    cycles : int
    root : {"travel", "inplace"}

    Returns
    -------
    Motion
    """
    check_loop_motion(motion, min_frames=2)
    if int(cycles) != cycles or cycles < 1:
        raise ValueError(f"cycles: expected a positive integer; got {cycles!r}")
    f = motion.n_frames
    # bounded before allocation: the frames and frames x joints of the result
    total = int(cycles) * (f - 1) + 1
    limits.check_option("cycles", "a repeated clip of frames", total, "max_frames")
    limits.check_option(
        "cycles",
        "a repeated clip of frames x joints",
        total * motion.n_joints,
        "max_samples",
    )
    rot, shift = cycle_transform(motion, root)
    roots, rots, jts = [], [], []
    r_k, s_k = np.eye(3), np.zeros(3)
    for k in range(int(cycles)):
        take = slice(0, f - 1) if k < cycles - 1 else slice(0, f)
        rr = motion.rotations[take].copy()
        rr[:, 0] = r_k @ rr[:, 0]
        rots.append(rr)
        roots.append(motion.root_translation[take] @ r_k.T + s_k)
        if motion.joint_translations is not None:
            jts.append(motion.joint_translations[take])
        r_k, s_k = rot @ r_k, rot @ s_k + shift
    return motion.replace(
        root_translation=np.concatenate(roots),
        rotations=np.concatenate(rots),
        joint_translations=np.concatenate(jts) if jts else None,
        source=(),
    )
