"""What an animator sees at the seam of a looping clip, and how far a loop moved from its
input (:func:`seam_metrics`). The cycle transform and the loop convention are those of
:mod:`elastic_motion.motion.looping`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from elastic_motion.apps.metrics.feet import foot_sliding, metres
from elastic_motion.errors import OptionError
from elastic_motion.groups import SO3
from elastic_motion.motion import Motion, forward_kinematics
from elastic_motion.motion.looping import check_loop_motion, check_root, cycle_transform, repeat_motion

__all__ = ["SEAM_WINDOW", "SeamMetrics", "seam_metrics"]

_SO3 = SO3()
#: Seconds before and after the seam over which its whips are looked for
#: (:attr:`SeamMetrics.seam_acceleration_ratio`): a closing spreads its change over the frames
#: next to the seam, a limb's whip there lasts a few frames.
SEAM_WINDOW = 0.3
#: Below these a point counts as still (m/s for speeds and velocity jumps, m/s^2 for
#: accelerations; the motion's length unit when unknown), far above the rounding noise of
#: forward kinematics (about 1e-15 m a frame): a seam ratio divides by at least this, and is 0
#: where the seam's own value is below it. Dividing by the smallest float instead made a clip
#: that does not move report its noise as a whip of 3.6e+295x its own.
_STILL_SPEED = 1e-6
_STILL_ACCELERATION = 1e-4


@dataclass(frozen=True, eq=False)
class SeamMetrics:
    """What an animator sees at the seam of a looping clip (:func:`seam_metrics`).

    Angles in degrees, positions in metres (the motion's length unit when unknown), times
    in seconds.

    Attributes
    ----------
    seam_angle_max_deg, seam_angle_mean_deg : float
        Per-joint angle between the last frame and ``T`` applied to the first (local
        rotations; root with the cycle transform ``T``).
    seam_angular_velocity_max_deg_s, seam_angular_velocity_mean_deg_s : float
        Per joint ``|omega_last - Ad_T omega_first|``, ``omega`` the right-trivialised
        angular velocity of the last / first frame step.
    seam_position_max_m, seam_position_mean_m : float
        FK positions of the joints and their end sites, last frame vs ``T`` (first frame).
    seam_velocity_max_m_s : float
        Largest jump of an FK point's velocity at the seam.
    seam_velocity_jump_ratio : float
        The hitch an animator sees at a C0 seam: per FK point its velocity jump at the seam
        over the largest change of its velocity between two frame steps inside the clip (99th
        percentile over the steps of ``original`` when given, else of the cycle itself; at
        least a tenth of the largest such value over the points, so a point that barely moves
        does not count a millimetre as a hitch); the largest over the points. At most about 1:
        no worse than the clip's own quick moves (C1 loops of CMU and DeepMimic clips:
        0.1-1.2); well above: a visible hitch (C0 loops of the same clips up to 5.5). 0 when
        no point's velocity jumps by more than 1e-6 m/s at the seam (a clip that does not
        move); the clip's own changes count as at least that much.
    seam_velocity_jump_point : str
        The point where that ratio is largest (a joint name, or ``"<joint> end site"``).
    seam_acceleration_ratio : float
        The whip an animator sees *around* the seam: per FK point its largest acceleration over
        the last and the first :data:`SEAM_WINDOW` seconds of two cycles played in a row (the
        seam in the middle) over its own 99th percentile of acceleration inside the clip
        (``original``'s when given; floored like the velocity jump's), the largest over the
        points. A closing that puts its change into the frames next to the seam whips a limb
        there that the jump at the seam frame does not show (DeepMimic long walk closed whole:
        an ankle at 25.7x its own). At most about 2: no quicker than the clip itself. 0 when
        no point accelerates by more than 1e-4 m/s^2 around the seam.
    seam_acceleration_point : str
        The point where that ratio is largest.
    seam_speed_ratio : float
        Likewise for speed: the largest speed over that window over the point's own largest
        speed inside the clip (floored at a tenth of the largest over the points).
    seam_speed_max_m_s : float
        The largest speed of a point over that window (m/s).
    foot_sliding_m_s : float
        Mean horizontal speed of foot joints over frame steps where they touch the floor,
        over two cycles played in a row (so the seam counts).
    foot_sliding_seam_m_s : float
        The largest such speed at the seam step (0 if no foot touches).
    seam_angle_deg, seam_angular_velocity_deg_s : ndarray, shape (J,)
        Per joint (all joints, also those not selected).
    deviation_max_m, deviation_mean_m : float or None
        With ``original``: FK positions of the same points against the original, all frames.
    deviation_relative_max_m : float or None
        With ``original``: the same, each point relative to the root joint (the body's own
        change, whatever the root's path: what a loop's ``change_bound`` bounds).
    deviation_per_frame_max_m, deviation_per_frame_mean_m : ndarray, shape (F,), or None
    """

    seam_angle_max_deg: float
    seam_angle_mean_deg: float
    seam_angular_velocity_max_deg_s: float
    seam_angular_velocity_mean_deg_s: float
    seam_position_max_m: float
    seam_position_mean_m: float
    seam_velocity_max_m_s: float
    seam_velocity_jump_ratio: float
    seam_velocity_jump_point: str
    seam_acceleration_ratio: float
    seam_acceleration_point: str
    seam_speed_ratio: float
    seam_speed_max_m_s: float
    foot_sliding_m_s: float
    foot_sliding_seam_m_s: float
    seam_angle_deg: np.ndarray
    seam_angular_velocity_deg_s: np.ndarray
    deviation_max_m: float | None = None
    deviation_mean_m: float | None = None
    deviation_relative_max_m: float | None = None
    deviation_per_frame_max_m: np.ndarray | None = None
    deviation_per_frame_mean_m: np.ndarray | None = None

    def summary(self) -> dict[str, float]:
        """The scalars, for a JSON report (deviation only when measured)."""
        out = {
            f.name: getattr(self, f.name)
            for f in dataclasses.fields(self)
            if not isinstance(getattr(self, f.name), np.ndarray) and getattr(self, f.name) is not None
        }
        return out


def seam_metrics(
    motion: Motion,
    *,
    original: Motion | None = None,
    root: str = "travel",
    joints: Sequence[str] | None = None,
    contact_height: float = 0.05,
) -> SeamMetrics:
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
    SeamMetrics
    """
    motion = check_loop_motion(motion)
    check_root(root)
    sel = np.arange(motion.n_joints)
    if joints is not None:
        unknown = [n for n in joints if n not in motion.skeleton.names]
        if unknown:
            raise OptionError("joints", f"expected joint names of the motion; got unknown {unknown}")
        sel = np.array([motion.skeleton.index(n) for n in joints], dtype=np.int64)
    scale = metres(motion)[0]
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
    pos_original = None
    if original is not None:
        original = check_loop_motion(original, "original")
        if original.n_frames != motion.n_frames or original.n_joints != motion.n_joints:
            raise ValueError(
                f"original: expected {motion.n_frames} frames of {motion.n_joints} joints like motion; "
                f"got {original.n_frames} frames of {original.n_joints}"
            )
        pos_original = forward_kinematics(original, end_sites=True)[:, points]
    # each point's quick changes of velocity inside the clip (the seam excluded): 99th percentile
    ref = pos if pos_original is None else pos_original
    inner = np.percentile(np.linalg.norm(np.diff(ref, 2, axis=0), axis=-1), 99, axis=0) * fps * scale
    inner = np.maximum(inner, 0.1 * inner.max(initial=0.0))
    ratio = _ratio(dv, inner, _STILL_SPEED)
    names = [*sk.names, *(f"{sk.names[p]} end site" for p in sk.end_site_parents)]
    out: dict = {
        "seam_angle_max_deg": float(seam[sel].max()),
        "seam_angle_mean_deg": float(seam[sel].mean()),
        "seam_angular_velocity_max_deg_s": float(dw[sel].max()),
        "seam_angular_velocity_mean_deg_s": float(dw[sel].mean()),
        "seam_position_max_m": float(seam_pos.max()),
        "seam_position_mean_m": float(seam_pos.mean()),
        "seam_velocity_max_m_s": float(dv.max()),
        "seam_velocity_jump_ratio": float(ratio.max()),
        "seam_velocity_jump_point": names[int(points[int(ratio.argmax())])],
        "seam_angle_deg": seam,
        "seam_angular_velocity_deg_s": dw,
    }
    out.update(_foot_sliding(motion, root, contact_height))
    out.update(_around_the_seam(motion, root, points, ref, names, scale))
    if pos_original is not None:
        dev = np.linalg.norm(pos_original - pos, axis=-1) * scale
        out["deviation_max_m"] = float(dev.max())
        out["deviation_mean_m"] = float(dev.mean())
        root_now = forward_kinematics(motion)[:, 0]
        root_then = forward_kinematics(original)[:, 0]
        rel = (pos - root_now[:, None]) - (pos_original - root_then[:, None])
        out["deviation_relative_max_m"] = float(np.linalg.norm(rel, axis=-1).max() * scale)
        out["deviation_per_frame_max_m"] = dev.max(axis=1)
        out["deviation_per_frame_mean_m"] = dev.mean(axis=1)
    return SeamMetrics(**out)


def _around_the_seam(
    motion: Motion, root: str, points: np.ndarray, ref: np.ndarray, names: list[str], scale: float
) -> dict:
    """The seam's acceleration and speed ratios (:class:`SeamMetrics`) of the FK ``points``
    (indices into joints and end sites), ``ref`` ``(F, P, 3)`` the clip they are measured
    against (its own or the original's positions)."""
    fps = motion.fps
    f = motion.n_frames
    two = forward_kinematics(repeat_motion(motion, 2, root), end_sites=True)[:, points]
    w = max(2, round(SEAM_WINDOW * fps))
    seam = f - 1  # the first cycle's last frame is the second's first
    lo, hi = max(1, seam - w), min(two.shape[0] - 1, seam + w + 1)
    acc = np.linalg.norm(
        two[lo - 1 : hi + 1][2:] - 2 * two[lo - 1 : hi + 1][1:-1] + two[lo - 1 : hi + 1][:-2], axis=-1
    )
    acc *= fps * fps * scale  # (frames around the seam, P), m/s^2
    vel = np.linalg.norm(np.diff(two[lo - 1 : hi + 1], axis=0), axis=-1) * fps * scale
    own_acc = np.percentile(np.linalg.norm(np.diff(ref, 2, axis=0), axis=-1), 99, axis=0) * fps * fps * scale
    own_acc = np.maximum(own_acc, 0.1 * own_acc.max(initial=0.0))
    own_vel = np.linalg.norm(np.diff(ref, axis=0), axis=-1).max(axis=0) * fps * scale
    own_vel = np.maximum(own_vel, 0.1 * own_vel.max(initial=0.0))
    acc_ratio = _ratio(acc.max(axis=0), own_acc, _STILL_ACCELERATION)
    vel_ratio = _ratio(vel.max(axis=0), own_vel, _STILL_SPEED)
    return {
        "seam_acceleration_ratio": float(acc_ratio.max()),
        "seam_acceleration_point": names[int(points[int(acc_ratio.argmax())])],
        "seam_speed_ratio": float(vel_ratio.max()),
        "seam_speed_max_m_s": float(vel.max()),
    }


def _ratio(at_seam: np.ndarray, own: np.ndarray, still: float) -> np.ndarray:
    """Per point, ``at_seam / own`` with ``own`` at least ``still``; 0 where ``at_seam`` is
    below ``still`` (nothing to see there, and a clip that does not move has no own value)."""
    return np.where(at_seam > still, at_seam / np.maximum(own, still), 0.0)


def _foot_sliding(motion: Motion, root: str, contact_height: float) -> dict:
    # measured on two cycles so that the step across the seam counts too
    fs = foot_sliding(repeat_motion(motion, 2, root), contact_height=contact_height)
    seam_step = motion.n_frames - 2  # frames F-2 -> F-1 (= T(frame 0))
    seam = fs.speed[seam_step][fs.contact[seam_step]] if fs.joints else np.zeros(0)
    return {
        "foot_sliding_m_s": fs.mean_speed,
        "foot_sliding_seam_m_s": float(seam.max(initial=0.0)),
    }
