"""Seamless loops of motions (paper 000, sec. 5.4) with the loop convention of game engines.

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
* **What closes** (:func:`loop_motion`), on the Lie curve ``R^3 x SO(3)^J``
  (:func:`elastic_motion.motion.to_lie_curve`, with its default weights):

  - ``"travel"``: every joint's local rotation (excluded joints stay free: by default the
    finger and thumb joints, whose CMU data flips by 180 degrees between frames); the root
    orientation *relative to heading*, i.e. up to a rotation about the up axis (the swing
    residual of :mod:`elastic_motion.closing`); the root height. The floor-plane root
    trajectory keeps its samples, so the displacement of one cycle is kept.
  - ``"inplace"``: all of it, floor position and heading too (paper 000's closing).

  The first frame never changes.
* **Euler baseline** (``representation="euler"``): the same motion as continuous Euler
  angles in ``R^(3+3J)`` (:func:`elastic_motion.motion.to_euler_curve`, with the Lie
  curve's weights on the coordinates), closed by the Newton projection of paper 001,
  Thm. 2 (:func:`elastic_motion.closing.project_closed_rd`; C1 by
  :func:`elastic_motion.closing.close_curve`). In ``"travel"`` it closes the root height,
  every joint's three angles and the root's three angles -- except the root's outermost
  angle when that is about the up axis (then it *is* the heading and stays free). Euler
  angles have no heading coordinate otherwise, so a turning clip is turned back.
* **Units** of the metrics: angles in degrees, positions in metres when the motion's
  ``metres_per_unit`` is known (else in its length unit), times in seconds.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from elastic_motion._validation import check_finite
from elastic_motion.apps.metrics import foot_sliding
from elastic_motion.closing import ClosingResult, close_curve, project_closed_rd
from elastic_motion.curves import DiscreteCurve
from elastic_motion.groups import SO3, Euclidean
from elastic_motion.motion import (
    Motion,
    finger_joints,
    forward_kinematics,
    from_euler_curve,
    from_lie_curve,
    to_euler_curve,
    to_lie_curve,
)
from elastic_motion.motion.rotations import axis_rotation

__all__ = [
    "LoopResult",
    "cycle_transform",
    "loop_motion",
    "repeat_motion",
    "seam_metrics",
]

_SO3 = SO3()
_AXES = "xyz"
_ROOT_MODES = ("travel", "inplace")
_REPRESENTATIONS = ("lie", "euler")


@dataclass(frozen=True, eq=False)
class LoopResult:
    """A looped motion (:func:`loop_motion`).

    Attributes
    ----------
    motion : Motion
        The closed cycle: same frames, skeleton and first frame as the input.
    original : Motion
        The input.
    closing : ClosingResult
        The curve-level result (gap history, iterations, timing; see
        :mod:`elastic_motion.closing`).
    representation : {"lie", "euler"}
    root : {"travel", "inplace"}
    c1 : bool
    closed_joints, free_joints : tuple of str
        Joints whose rotations were closed / left free.
    heading_change : float
        ``delta`` of the result's cycle transform, radians (0 for ``"inplace"``).
    displacement : ndarray, shape (3,)
        Floor-plane root displacement per cycle, motion length units (0 for ``"inplace"``).
    """

    motion: Motion
    original: Motion
    closing: ClosingResult
    representation: str
    root: str
    c1: bool
    closed_joints: tuple[str, ...]
    free_joints: tuple[str, ...]
    heading_change: float
    displacement: np.ndarray


# ------------------------------------------------------------------------------------------
# Helpers
# ------------------------------------------------------------------------------------------


def _twist_angle(r: np.ndarray, axis: int) -> float:
    """Angle of the twist of rotation ``r`` about coordinate ``axis`` (swing-twist
    decomposition ``r = swing twist``, from the quaternion ``(w, v)``: ``2 atan2(v_a, w)``)."""
    ell = _SO3.log(r)
    a = float(np.linalg.norm(ell))
    w = math.cos(0.5 * a)
    va = math.sin(0.5 * a) * (ell[axis] / a) if a > 0 else 0.0
    delta = 2.0 * math.atan2(va, w)
    return (delta + math.pi) % (2.0 * math.pi) - math.pi


def _check_root(root: str) -> str:
    if root not in _ROOT_MODES:
        raise ValueError(f"root: expected 'travel' or 'inplace'; got {root!r}")
    return root


def _check_motion(motion: object, name: str = "motion", min_frames: int = 3) -> Motion:
    if not isinstance(motion, Motion):
        raise ValueError(f"{name}: expected a Motion; got {type(motion).__name__}")
    if motion.n_frames < min_frames:
        raise ValueError(
            f"{name}: expected at least {min_frames} frames to make a loop; got {motion.n_frames}"
        )
    check_finite(motion.rotations, f"{name}.rotations")
    check_finite(motion.root_translation, f"{name}.root_translation")
    return motion


def _metres(motion: Motion) -> float:
    return motion.metres_per_unit if motion.metres_per_unit is not None else 1.0


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
    _check_root(root)
    if root == "inplace":
        return np.eye(3), np.zeros(3)
    up = _AXES.index(motion.up_axis)
    r_root = motion.rotations[-1, 0] @ motion.rotations[0, 0].T
    rot = axis_rotation(_twist_angle(r_root, up), "XYZ"[up])
    p0 = motion.root_translation[0].copy()
    p1 = motion.root_translation[-1].copy()
    p0[up] = 0.0
    p1[up] = 0.0
    return rot, p1 - rot @ p0


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
    _check_motion(motion, min_frames=2)
    if int(cycles) != cycles or cycles < 1:
        raise ValueError(f"cycles: expected a positive integer; got {cycles!r}")
    rot, shift = cycle_transform(motion, root)
    f = motion.n_frames
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


def _excluded(motion: Motion, exclude: str | Sequence[str] | None) -> list[str]:
    if exclude is None:
        return []
    if isinstance(exclude, str):
        if exclude != "fingers":
            raise ValueError(
                f"exclude_joints: expected 'fingers', None or a list of joint names; got {exclude!r}"
            )
        return list(finger_joints(motion.skeleton))
    names = list(exclude)
    unknown = [n for n in names if n not in motion.skeleton.names]
    if unknown:
        raise ValueError(
            f"exclude_joints: unknown joint names {unknown}; the skeleton has {list(motion.skeleton.names)}"
        )
    return names


# ------------------------------------------------------------------------------------------
# Looping
# ------------------------------------------------------------------------------------------


def loop_motion(
    motion: Motion,
    *,
    root: str = "travel",
    c1: bool = False,
    representation: str = "lie",
    method: str = "gauss-newton",
    tol: float = 1e-6,
    max_iter: int = 100,
    exclude_joints: str | Sequence[str] | None = "fingers",
    joint_weights: np.ndarray | None = None,
    translation_weight: float | None = None,
) -> LoopResult:
    """Make a motion loop seamlessly by closing its curve (paper 000, sec. 4 and 5.4).

    Parameters
    ----------
    motion : Motion
        At least 3 frames, finite. Preprocess first if needed (e.g.
        :func:`elastic_motion.motion.drop_tpose`).
    root : {"travel", "inplace"}
        Loop convention (module docstring): keep the floor-plane displacement and heading
        change of one cycle, or close them too.
    c1 : bool
        Also match the velocities at the seam (:func:`elastic_motion.closing.close_curve`).
    representation : {"lie", "euler"}
        Close the Lie curve (the method) or the Euler-angle curve (the baseline).
    method, tol, max_iter
        Passed to :func:`~elastic_motion.closing.close_curve` (Lie, and Euler with C1);
        the Euler C0 projection uses Newton with ``tol`` and ``max_iter``.
    exclude_joints : "fingers", None or sequence of str
        Joints left free (their rotations keep their samples).
    joint_weights, translation_weight
        Inner-product weights (default: those of :func:`elastic_motion.motion.to_lie_curve`).

    Returns
    -------
    LoopResult

    Raises
    ------
    ValueError
        Fewer than 3 frames; NaN/inf in the motion; a closed joint whose seam rotation is
        at log's cut locus (angle pi: the error names the joint; leave it free with
        ``exclude_joints`` to loop anyway); bad option values.
    """
    motion = _check_motion(motion)
    _check_root(root)
    if representation not in _REPRESENTATIONS:
        raise ValueError(f"representation: expected 'lie' or 'euler'; got {representation!r}")
    names = motion.skeleton.names
    j = motion.n_joints
    up = _AXES.index(motion.up_axis)
    free = set(_excluded(motion, exclude_joints))
    closed_joint = np.array([n not in free for n in names])
    lie = to_lie_curve(motion, joint_weights, translation_weight=translation_weight)
    # per-joint closing mask (3 coordinates each), root first
    rot_mask = np.repeat(closed_joint, 3).reshape(j, 3)
    pos_mask = np.ones(3, dtype=bool)
    if root == "travel":
        pos_mask[:] = False
        pos_mask[up] = True
    if representation == "lie":
        if root == "travel" and closed_joint[0]:
            rot_mask[0, up] = False  # root: swing about the up axis (heading free)
        mask = np.concatenate([pos_mask, rot_mask.ravel()])
        res = close_curve(
            lie,
            method=method,
            tol=tol,
            max_iter=max_iter,
            factors=mask,
            c1=c1,
            rotation_names=list(names),
        )
        out = from_lie_curve(res.curve, motion)
    else:
        euler = to_euler_curve(motion)
        weights = lie.group.weights  # same layout: root position, then 3 per joint
        curve = DiscreteCurve(euler.values, Euclidean(3 + 3 * j, weight=weights), euler.t)
        if (
            root == "travel"
            and closed_joint[0]
            and motion.skeleton.euler_orders[0][0].lower() == motion.up_axis
        ):
            rot_mask[0, 0] = False  # outermost root angle is the heading
        mask = np.concatenate([pos_mask, rot_mask.ravel()])
        if c1:
            res = close_curve(curve, method=method, tol=tol, max_iter=max_iter, factors=mask, c1=True)
        else:
            res = project_closed_rd(curve, factors=mask, tol=tol, max_iter=max_iter)
        out = from_euler_curve(res.curve, motion)
    out = out.replace(name=motion.name, source=())
    rot, _ = cycle_transform(out, root)
    heading = _twist_angle(rot, up) if root == "travel" else 0.0
    return LoopResult(
        motion=out,
        original=motion,
        closing=res,
        representation=representation,
        root=root,
        c1=bool(c1),
        closed_joints=tuple(n for n, c in zip(names, closed_joint, strict=True) if c),
        free_joints=tuple(n for n, c in zip(names, closed_joint, strict=True) if not c),
        heading_change=float(heading),
        displacement=out.root_translation[-1] - out.root_translation[0] if root == "travel" else np.zeros(3),
    )


# ------------------------------------------------------------------------------------------
# Metrics
# ------------------------------------------------------------------------------------------


def seam_metrics(
    motion: Motion,
    *,
    original: Motion | None = None,
    root: str = "travel",
    joints: Sequence[str] | None = None,
    contact_height: float = 0.05,
) -> dict:
    """What an animator sees at the seam of a looping clip, and how far it is from the original.

    Parameters
    ----------
    motion : Motion
        The cycle (at least 3 frames).
    original : Motion, optional
        The clip before looping (same skeleton and frame count), for the deviation.
    root : {"travel", "inplace"}
        Loop convention (cycle transform ``T``, module docstring).
    joints : sequence of str, optional
        Joints that count (default: all): their rotations in the angle metrics, their
        positions and the end sites hanging from them in the position metrics (pass
        :attr:`LoopResult.closed_joints` to leave out joints a loop left free).
    contact_height : float
        A foot joint touches the floor when it is less than this (metres) above its lowest
        height in the clip.

    Returns
    -------
    dict
        Scalars (float):

        - ``seam_angle_max_deg``, ``seam_angle_mean_deg``: per-joint angle between the last
          frame and ``T`` applied to the first (local rotations; root with ``T``).
        - ``seam_angular_velocity_max_deg_s``, ``seam_angular_velocity_mean_deg_s``: per joint
          ``|omega_last - Ad_T omega_first|``, ``omega`` the right-trivialised angular
          velocity of the last / first frame step.
        - ``seam_position_max_m``, ``seam_position_mean_m``: FK positions of the joints and
          their end sites, last frame vs ``T``(first frame).
        - ``seam_velocity_max_m_s``: largest jump of an FK point's velocity at the seam.
        - ``foot_sliding_m_s``: mean horizontal speed of foot joints
          (:func:`elastic_motion.apps.metrics.foot_joints`)
          over frame steps where they touch the floor, measured over two cycles played
          in a row (so the seam counts); ``foot_sliding_seam_m_s``: the largest such speed at
          the seam step (0 if no foot touches).
        - with ``original``: ``deviation_max_m``, ``deviation_mean_m`` (FK positions of the
          same points, over all frames).

        Arrays: ``seam_angle_deg`` (J,), ``seam_angular_velocity_deg_s`` (J,), and with
        ``original``: ``deviation_per_frame_max_m``, ``deviation_per_frame_mean_m`` (F,).
    """
    motion = _check_motion(motion)
    _check_root(root)
    sel = np.arange(motion.n_joints)
    if joints is not None:
        unknown = [n for n in joints if n not in motion.skeleton.names]
        if unknown:
            raise ValueError(f"joints: unknown joint names {unknown}")
        sel = np.array([motion.skeleton.index(n) for n in joints], dtype=np.int64)
    scale = _metres(motion)
    fps = motion.fps
    rot_t, shift_t = cycle_transform(motion, root)
    r = motion.rotations
    first = r[0].copy()
    first[0] = rot_t @ first[0]
    second = r[1].copy()
    second[0] = rot_t @ second[0]
    seam = np.degrees(np.linalg.norm(_SO3.difference(first, r[-1]), axis=-1))
    w_last = _SO3.difference(r[-2], r[-1]) * fps
    w_first = _SO3.difference(first, second) * fps
    dw = np.degrees(np.linalg.norm(w_last - w_first, axis=-1))
    sk = motion.skeleton
    points = np.concatenate([sel, sk.n_joints + np.flatnonzero(np.isin(sk.end_site_parents, sel))])
    pos = forward_kinematics(motion, end_sites=True)[:, points]
    p_first = pos[0] @ rot_t.T + shift_t
    p_second = pos[1] @ rot_t.T + shift_t
    seam_pos = np.linalg.norm(pos[-1] - p_first, axis=-1) * scale
    dv = np.linalg.norm((pos[-1] - pos[-2]) - (p_second - p_first), axis=-1) * fps * scale
    out: dict = {
        "seam_angle_max_deg": float(seam[sel].max()),
        "seam_angle_mean_deg": float(seam[sel].mean()),
        "seam_angular_velocity_max_deg_s": float(dw[sel].max()),
        "seam_angular_velocity_mean_deg_s": float(dw[sel].mean()),
        "seam_position_max_m": float(seam_pos.max()),
        "seam_position_mean_m": float(seam_pos.mean()),
        "seam_velocity_max_m_s": float(dv.max()),
        "seam_angle_deg": seam,
        "seam_angular_velocity_deg_s": dw,
    }
    out.update(_foot_sliding(motion, root, contact_height))
    if original is not None:
        original = _check_motion(original, "original")
        if original.n_frames != motion.n_frames or original.n_joints != motion.n_joints:
            raise ValueError(
                f"original: expected {motion.n_frames} frames of {motion.n_joints} joints like motion; "
                f"got {original.n_frames} frames of {original.n_joints}"
            )
        dev = np.linalg.norm(forward_kinematics(original, end_sites=True)[:, points] - pos, axis=-1) * scale
        out["deviation_max_m"] = float(dev.max())
        out["deviation_mean_m"] = float(dev.mean())
        out["deviation_per_frame_max_m"] = dev.max(axis=1)
        out["deviation_per_frame_mean_m"] = dev.mean(axis=1)
    return out


def _foot_sliding(motion: Motion, root: str, contact_height: float) -> dict:
    # measured on two cycles so that the step across the seam counts too
    fs = foot_sliding(repeat_motion(motion, 2, root), contact_height=contact_height)
    seam_step = motion.n_frames - 2  # frames F-2 -> F-1 (= T(frame 0))
    seam = fs.speed[seam_step][fs.contact[seam_step]] if fs.joints else np.zeros(0)
    return {
        "foot_sliding_m_s": fs.mean_speed,
        "foot_sliding_seam_m_s": float(seam.max(initial=0.0)),
    }
