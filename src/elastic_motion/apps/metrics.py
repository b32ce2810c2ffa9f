"""Quality metrics of a motion an animator judges: skating while in contact, feet below the
floor, foot sliding and bone lengths.

The one home of these two concepts (the loop seam metrics of
:func:`elastic_motion.apps.loop.seam_metrics` and the blend report use them). Distances of
a result to its inputs are :func:`elastic_motion.apps.distance.motion_distance`.

Conventions
-----------
* **Units**: positions in metres when the motion's ``metres_per_unit`` is known, otherwise
  in its own length unit (the result then says ``units="unknown"``); speeds per second.
* **Foot joints** (:func:`foot_joints`): joints whose name contains ``foot``, ``toe`` or
  ``ankle`` (case-insensitive): CMU ``LeftFoot``/``LeftToeBase``, ASF ``lfoot``/``ltoes``,
  DeepMimic ``left_ankle``, Bandai ``Foot_L``/``Toes_L``.
* **Foot sliding** (:func:`foot_sliding`): a foot joint *touches* the floor in a frame when
  its height is less than ``contact_height`` (default 5 cm) above its own lowest height in
  the clip. Over every frame step where a joint touches in both frames, its horizontal
  speed (up coordinate dropped) is averaged: ``mean_speed`` in m/s. A planted foot scores
  0; a foot that skates while down scores its skating speed. Contact is decided by height
  alone (not by speed), so a sliding foot is not excused for moving.
* **Skating** (:func:`contact_skating`): the mean horizontal speed (m/s) of the contact
  joints over the frame steps where a given :class:`~elastic_motion.motion.contacts.Contacts`
  says they are planted (both frames of the step), measured on a motion by forward
  kinematics. Pass the *input's* contacts to measure an output against what should stay
  planted (a loop: the same frames; a blend: the inputs' contacts carried through the
  warp). With it, the **lowest point below the floor** (m, >= 0): how far the motion's
  lowest joint or end site goes below a given floor height (the input's floor).
* **Bone-length error** (:func:`bone_length_error`): the largest relative difference, over
  frames and bones, between a bone's length in the motion (from forward kinematics:
  distance of a joint to its parent) and the rest length of the same bone in a reference
  skeleton (matched by joint name). Against the motion's own skeleton it checks that the
  motion is a rigid-bone animation (0 up to rounding for rotation-only joints); against an
  input of a blend it says how far the result's proportions are from that input's.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from elastic_motion.motion import Motion, Skeleton, forward_kinematics
from elastic_motion.motion.contacts import Contacts

__all__ = [
    "BoneLengthError",
    "ContactSkating",
    "FootSliding",
    "bone_length_error",
    "contact_skating",
    "foot_joints",
    "foot_sliding",
]

_AXES = "xyz"
_FOOT_WORDS = ("foot", "toe", "ankle")


def _metres(motion: Motion) -> tuple[float, str]:
    if motion.metres_per_unit is None:
        return 1.0, "unknown"
    return motion.metres_per_unit, "m"


def foot_joints(motion: Motion | Skeleton) -> list[int]:
    """Indices of the joints whose name says foot, toe or ankle (case-insensitive).

    Parameters
    ----------
    motion : Motion or Skeleton

    Returns
    -------
    list of int
        In skeleton order; empty when no name matches.
    """
    sk = motion.skeleton if isinstance(motion, Motion) else motion
    return [j for j, nm in enumerate(sk.names) if any(k in nm.lower() for k in _FOOT_WORDS)]


@dataclass(frozen=True, eq=False)
class FootSliding:
    """Foot sliding of a motion (:func:`foot_sliding`).

    Attributes
    ----------
    mean_speed : float
        Mean horizontal speed of the foot joints over the frame steps where they touch the
        floor (m/s, or length units per second); 0 when no foot ever touches.
    max_speed : float
        Largest such speed.
    distance : float
        Summed horizontal travel of the foot joints while touching, divided by the number
        of foot joints (m): "how far did a foot skate in the clip".
    contact_fraction : float
        Fraction of (frame step, foot joint) pairs that touch.
    joints : tuple of str
        The foot joints measured.
    speed : ndarray, shape (F-1, K)
        Horizontal speed of each foot joint over each frame step.
    contact : ndarray of bool, shape (F-1, K)
        Whether the joint touches in both frames of the step.
    units : str
        ``"m"`` or ``"unknown"`` (the motion's own length unit).
    lowest : ndarray, shape (K,)
        The height each joint's ``contact_height`` was measured from (its lowest in the clip,
        or the ``lowest`` given to :func:`foot_sliding`); empty without foot joints.
    """

    mean_speed: float
    max_speed: float
    distance: float
    contact_fraction: float
    joints: tuple[str, ...]
    speed: np.ndarray
    contact: np.ndarray
    units: str
    lowest: np.ndarray

    def summary(self) -> dict[str, float | str | list[str]]:
        """The scalars, for a JSON report (``*_m_s`` in m/s, ``distance_m`` in m)."""
        return {
            "mean_speed_m_s": self.mean_speed,
            "max_speed_m_s": self.max_speed,
            "distance_m": self.distance,
            "contact_fraction": self.contact_fraction,
            "joints": list(self.joints),
            "units": self.units,
        }


def foot_sliding(
    motion: Motion,
    *,
    contact_height: float = 0.05,
    joints: list[int] | None = None,
    lowest: np.ndarray | None = None,
) -> FootSliding:
    """Foot sliding: mean horizontal speed of the foot joints while they touch the floor.

    Parameters
    ----------
    motion : Motion
        At least 2 frames.
    contact_height : float, default 0.05
        A joint touches when it is less than this (metres; length units if unknown) above
        its lowest height in the clip.
    joints : list of int, optional
        Joints to measure (default :func:`foot_joints`).
    lowest : ndarray, shape (K,), optional
        The heights (same units as ``contact_height``) to measure ``contact_height`` from,
        one per measured joint, instead of each joint's lowest height in this clip: e.g. a
        motion's own lowest heights (``FootSliding.lowest``) to measure an edit of it by the
        same threshold (an edit that lifts a joint's lowest frame would otherwise raise the
        threshold and count more of its swing as touching).

    Returns
    -------
    FootSliding
        All zeros (and empty arrays) when the skeleton has no foot joints.
    """
    if not isinstance(motion, Motion):
        raise ValueError(f"motion: expected a Motion; got {type(motion).__name__}")
    if not (np.isfinite(contact_height) and contact_height > 0):
        raise ValueError(f"contact_height: expected a positive height; got {contact_height!r}")
    scale, units = _metres(motion)
    feet = foot_joints(motion) if joints is None else [int(j) for j in joints]
    names = tuple(motion.skeleton.names[j] for j in feet)
    n_steps = max(motion.n_frames - 1, 0)
    if lowest is not None:
        floor = np.array(lowest, dtype=np.float64)  # a copy: the result's own
        if floor.shape != (len(feet),) or not np.isfinite(floor).all():
            raise ValueError(
                f"lowest: expected {len(feet)} finite heights, one per joint; got {floor.tolist()!r}"
            )
    if not feet:
        empty = np.zeros((n_steps, 0))
        return FootSliding(0.0, 0.0, 0.0, 0.0, names, empty, empty.astype(bool), units, np.zeros(0))
    up = _AXES.index(motion.up_axis)
    p = forward_kinematics(motion)[:, feet] * scale  # (F, K, 3)
    height = p[..., up]
    if lowest is None:
        floor = height.min(axis=0)
    if n_steps == 0:
        empty = np.zeros((0, len(feet)))
        return FootSliding(0.0, 0.0, 0.0, 0.0, names, empty, empty.astype(bool), units, floor)
    touch = height < floor + contact_height
    contact = touch[:-1] & touch[1:]
    step = np.diff(p, axis=0)
    step[..., up] = 0.0
    travel = np.linalg.norm(step, axis=-1)
    speed = travel * motion.fps
    return FootSliding(
        mean_speed=float(speed[contact].mean()) if contact.any() else 0.0,
        max_speed=float(speed[contact].max()) if contact.any() else 0.0,
        distance=float(travel[contact].sum() / len(feet)),
        contact_fraction=float(contact.mean()),
        joints=names,
        speed=speed,
        contact=contact,
        units=units,
        lowest=floor,
    )


@dataclass(frozen=True, eq=False)
class BoneLengthError:
    """Bone lengths of a motion against a reference skeleton (:func:`bone_length_error`).

    Attributes
    ----------
    max_relative : float
        Largest ``| |p_j - p_parent| - L_j | / L_j`` over frames and compared bones.
    max_absolute : float
        Largest ``| |p_j - p_parent| - L_j |`` (m, or length units when unknown).
    worst_joint : str
        Joint (child end of the bone) where ``max_relative`` occurs; ``""`` if none compared.
    n_bones : int
        Bones compared (joints present in both skeletons, with a parent, a rest length
        above 1 % of the reference's median bone and no position channels in either
        skeleton: a file with position channels on every joint, as Bandai's, compares none).
    """

    max_relative: float
    max_absolute: float
    worst_joint: str
    n_bones: int

    def summary(self) -> dict[str, float | str | int]:
        """The fields, for a JSON report."""
        return {
            "max_relative": self.max_relative,
            "max_absolute_m": self.max_absolute,
            "worst_joint": self.worst_joint,
            "bones": self.n_bones,
        }


def bone_length_error(motion: Motion, reference: Motion | Skeleton | None = None) -> BoneLengthError:
    """Relative bone-length error of ``motion`` against a reference skeleton.

    Parameters
    ----------
    motion : Motion
    reference : Motion or Skeleton, optional
        Default: the motion's own skeleton. Bones are matched by the child joint's name;
        the reference's rest lengths are converted to the motion's unit when both units
        are known.

    Returns
    -------
    BoneLengthError
    """
    if not isinstance(motion, Motion):
        raise ValueError(f"motion: expected a Motion; got {type(motion).__name__}")
    ref_sk = motion.skeleton
    ref_scale = 1.0
    if isinstance(reference, Motion):
        ref_sk = reference.skeleton
        if reference.metres_per_unit is not None and motion.metres_per_unit is not None:
            ref_scale = reference.metres_per_unit / motion.metres_per_unit
    elif isinstance(reference, Skeleton):
        ref_sk = reference
    elif reference is not None:
        raise ValueError(f"reference: expected a Motion, a Skeleton or None; got {type(reference).__name__}")
    sk = motion.skeleton
    scale, _ = _metres(motion)
    pos_ch = sk.has_position_channels
    ref_pos_ch = ref_sk.has_position_channels
    ref_len = ref_sk.bone_lengths * ref_scale
    # a bone of a few micrometres (CMU's LHipJoint in some files) has no meaningful relative
    # error: bones under 1 % of the median bone are left out
    positive = ref_len[ref_len > 1e-9]
    tiny = 0.01 * float(np.median(positive)) if positive.size else 0.0
    pairs = []
    for j in range(1, sk.n_joints):
        name = sk.names[j]
        if name not in ref_sk.names:
            continue
        k = ref_sk.index(name)
        if pos_ch[j] or ref_pos_ch[k] or ref_len[k] <= max(1e-9, tiny):
            continue
        pairs.append((j, k))
    if not pairs:
        return BoneLengthError(0.0, 0.0, "", 0)
    idx = np.array([j for j, _ in pairs])
    rest = np.array([ref_len[k] for _, k in pairs])
    p = forward_kinematics(motion)
    lengths = np.linalg.norm(p[:, idx] - p[:, sk.parents[idx]], axis=-1)  # (F, B)
    err = np.abs(lengths - rest)
    rel = err / rest
    worst = np.unravel_index(int(np.argmax(rel)), rel.shape)
    return BoneLengthError(
        max_relative=float(rel.max()),
        max_absolute=float(err.max() * scale),
        worst_joint=sk.names[int(idx[worst[1]])],
        n_bones=len(pairs),
    )


@dataclass(frozen=True, eq=False)
class ContactSkating:
    """Skating during contacts and depth below the floor (:func:`contact_skating`).

    Attributes
    ----------
    mean_speed : float
        Mean horizontal speed (m/s) of the planted joints over the frame steps where they
        are planted; 0 when no contact.
    max_speed : float
    per_joint : dict of str to float
        Mean speed per contact joint that has contacts.
    steps : int
        Number of (frame step, joint) pairs measured.
    below_floor : float
        How far (m, >= 0) the lowest joint or end site goes below ``floor``.
    floor : float
        The floor height used (m).
    """

    mean_speed: float
    max_speed: float
    per_joint: dict[str, float]
    steps: int
    below_floor: float
    floor: float

    def summary(self) -> dict[str, float | int | dict[str, float]]:
        """JSON-ready (``*_m_s`` in m/s, ``*_m`` in m)."""
        return {
            "skating_mean_m_s": self.mean_speed,
            "skating_max_m_s": self.max_speed,
            "skating_per_joint_m_s": dict(self.per_joint),
            "contact_steps": self.steps,
            "below_floor_m": self.below_floor,
            "floor_m": self.floor,
        }


def contact_skating(motion: Motion, contacts: Contacts) -> ContactSkating:
    """Skating of ``motion``'s joints during ``contacts`` and its depth below their floor.

    Parameters
    ----------
    motion : Motion
        Measured by forward kinematics (metres when its unit is known).
    contacts : Contacts
        Which joints should be planted in which frames (same frame count as ``motion``),
        and the floor (:func:`elastic_motion.motion.contacts.detect_contacts`, usually of an
        input).

    Returns
    -------
    ContactSkating

    Raises
    ------
    ValueError
        Frame counts that differ, a contact joint missing from the motion.
    """
    if contacts.n_frames != motion.n_frames:
        raise ValueError(
            f"contacts: expected {motion.n_frames} frames like the motion; got {contacts.n_frames}"
        )
    missing = [n for n in contacts.joints if n not in motion.skeleton.names]
    if missing:
        raise ValueError(f"contacts: joints {missing} are not in the motion's skeleton")
    scale, _ = _metres(motion)
    up = _AXES.index(motion.up_axis)
    pos = forward_kinematics(motion, end_sites=True) * scale
    below = float(max(0.0, (contacts.floor_heights() - pos[..., up].min(axis=1)).max()))
    idx = [motion.skeleton.index(n) for n in contacts.joints]
    if not idx or motion.n_frames < 2:
        return ContactSkating(0.0, 0.0, {}, 0, below, contacts.floor)
    p = pos[:, idx]
    step = np.diff(p, axis=0)
    step[..., up] = 0.0
    speed = np.linalg.norm(step, axis=-1) * motion.fps  # (F-1, K)
    planted = contacts.mask[:-1] & contacts.mask[1:]
    per_joint = {
        n: float(speed[planted[:, k], k].mean()) for k, n in enumerate(contacts.joints) if planted[:, k].any()
    }
    return ContactSkating(
        mean_speed=float(speed[planted].mean()) if planted.any() else 0.0,
        max_speed=float(speed[planted].max()) if planted.any() else 0.0,
        per_joint=per_joint,
        steps=int(planted.sum()),
        below_floor=below,
        floor=contacts.floor,
    )
