"""Feet on the floor: foot sliding of a motion, and skating and depth below the floor while
in contact (conventions: :mod:`elastic_motion.apps.metrics`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from elastic_motion.motion import Motion, Skeleton, forward_kinematics
from elastic_motion.motion.contacts import Contacts

__all__ = ["ContactSkating", "FootSliding", "contact_skating", "foot_joints", "foot_sliding", "metres"]

_AXES = "xyz"
_FOOT_WORDS = ("foot", "toe", "ankle")


def metres(motion: Motion) -> tuple[float, str]:
    """Metres per length unit of ``motion`` and the unit's name (``"m"``, or 1 and ``"unknown"``)."""
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
    scale, units = metres(motion)
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
    scale, _ = metres(motion)
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
