"""One database across skeletons: joint-name maps onto a common body model (``joints="map"``).

The common body has the 13 joints every convention in the data holds (DeepMimic's set)::

    pelvis -> spine -> head;  spine -> {l,r}_shoulder -> {l,r}_elbow
    pelvis -> {l,r}_hip -> {l,r}_knee -> {l,r}_ankle

============ =========== ============ ========= ============ ============
common       CMU FBX     CMU cgspeed  CMU ASF   Bandai       DeepMimic
============ =========== ============ ========= ============ ============
pelvis       Hips        Hips         root      Hips         root
spine        Spine1      Chest2       thorax    Chest        chest
head         Head        Head         head      Head         neck
l_hip        LeftUpLeg   LeftHip      lfemur    UpperLeg_L   left_hip
l_knee       LeftLeg     LeftKnee     ltibia    LowerLeg_L   left_knee
l_ankle      LeftFoot    LeftAnkle    lfoot     Foot_L       left_ankle
r_hip        RightUpLeg  RightHip     rfemur    UpperLeg_R   right_hip
r_knee       RightLeg    RightKnee    rtibia    LowerLeg_R   right_knee
r_ankle      RightFoot   RightAnkle   rfoot     Foot_R       right_ankle
l_shoulder   LeftArm     LeftShoulder lhumerus  UpperArm_L   left_shoulder
l_elbow      LeftForeArm LeftElbow    lradius   LowerArm_L   left_elbow
r_shoulder   RightArm    RightShoulder rhumerus UpperArm_R   right_shoulder
r_elbow      RightForeArm RightElbow  rradius   LowerArm_R   right_elbow
============ =========== ============ ========= ============ ============

(CMU FBX: the IsaacGymEnvs / una-dinosauria conversions, e.g. ``07_01``; CMU cgspeed: the
bvh11 conversions ``131_*``; CMU ASF: Acclaim ``.asf``/``.amc``.) A motion's convention is
the one whose 13 names it holds (:func:`detect_convention`).

Rotations: each common joint gets the rotation of its source joint *relative to the source
joint mapped to its common parent*, from the world orientations of forward kinematics,
``R_j = G_parent^T G_j``: the intermediate joints of a convention (CMU's ``LHipJoint``,
``LowerBack``, ``Spine``, ``Neck``, the clavicles) are folded in, and the identity is each
skeleton's own rest pose (all local rotations identity), so rotations are expressed relative
to each skeleton's rest pose. What stays different between rest poses (a T-pose against an
A-pose, other bone axes) is a constant rotation ``C`` per joint: ``R C`` or ``C R``; the Lie
SRV sees rotations through ``R_{f+1} R_f^T``, unchanged by ``R C`` and only re-expressed in
other axes (same length) by ``C R``, so the elastic distance depends little on it. Offsets of
the common skeleton: each source joint's position in the frame of the joint mapped to its
common parent, averaged over the frames (exact when the folded joints keep a fixed rotation).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from elastic_motion.errors import OptionError
from elastic_motion.motion import Motion, Skeleton
from elastic_motion.motion.kinematics import joint_positions_and_rotations

__all__ = [
    "COMMON_JOINTS",
    "COMMON_PARENTS",
    "CONVENTIONS",
    "detect_convention",
    "map_to_common_body",
    "missing_for_map",
]

#: Joints of the common body model, in skeleton order.
COMMON_JOINTS = (
    "pelvis",
    "spine",
    "head",
    "l_hip",
    "l_knee",
    "l_ankle",
    "r_hip",
    "r_knee",
    "r_ankle",
    "l_shoulder",
    "l_elbow",
    "r_shoulder",
    "r_elbow",
)
#: Parent of each common joint (index into :data:`COMMON_JOINTS`; -1 for the pelvis).
COMMON_PARENTS = (-1, 0, 1, 0, 3, 4, 0, 6, 7, 1, 9, 1, 11)

#: Source joint name of each common joint, per convention (module docstring's table).
CONVENTIONS: dict[str, tuple[str, ...]] = {
    "cmu-fbx": (
        "Hips",
        "Spine1",
        "Head",
        "LeftUpLeg",
        "LeftLeg",
        "LeftFoot",
        "RightUpLeg",
        "RightLeg",
        "RightFoot",
        "LeftArm",
        "LeftForeArm",
        "RightArm",
        "RightForeArm",
    ),
    "cmu-cgspeed": (
        "Hips",
        "Chest2",
        "Head",
        "LeftHip",
        "LeftKnee",
        "LeftAnkle",
        "RightHip",
        "RightKnee",
        "RightAnkle",
        "LeftShoulder",
        "LeftElbow",
        "RightShoulder",
        "RightElbow",
    ),
    "cmu-asf": (
        "root",
        "thorax",
        "head",
        "lfemur",
        "ltibia",
        "lfoot",
        "rfemur",
        "rtibia",
        "rfoot",
        "lhumerus",
        "lradius",
        "rhumerus",
        "rradius",
    ),
    "bandai": (
        "Hips",
        "Chest",
        "Head",
        "UpperLeg_L",
        "LowerLeg_L",
        "Foot_L",
        "UpperLeg_R",
        "LowerLeg_R",
        "Foot_R",
        "UpperArm_L",
        "LowerArm_L",
        "UpperArm_R",
        "LowerArm_R",
    ),
    "deepmimic": (
        "root",
        "chest",
        "neck",
        "left_hip",
        "left_knee",
        "left_ankle",
        "right_hip",
        "right_knee",
        "right_ankle",
        "left_shoulder",
        "left_elbow",
        "right_shoulder",
        "right_elbow",
    ),
}


def detect_convention(names: Sequence[str]) -> str | None:
    """The convention whose 13 source names are all in ``names`` (None if none)."""
    have = set(names)
    for conv, src in CONVENTIONS.items():
        if set(src) <= have:
            return conv
    return None


def missing_for_map(names: Sequence[str]) -> str:
    """A sentence naming, for the closest convention, the joints ``names`` lacks."""
    have = set(names)
    best = min(CONVENTIONS, key=lambda c: len(set(CONVENTIONS[c]) - have))
    return (
        f"no joint-name map fits this skeleton ({len(have)} joints); closest convention {best!r} "
        f"lacks {sorted(set(CONVENTIONS[best]) - have)}"
    )


def map_to_common_body(motion: Motion) -> Motion:
    """The motion on the common body model (module docstring).

    Parameters
    ----------
    motion : Motion
        A motion of one of :data:`CONVENTIONS` (any unit and up axis; the apps pass metres,
        Y-up).

    Returns
    -------
    Motion
        13 joints named :data:`COMMON_JOINTS`; root translation = the source pelvis's world
        position; same frames, rate, unit and up axis.

    Raises
    ------
    OptionError
        ``joints``: the skeleton fits no convention (naming the joints it lacks).
    """
    sk = motion.skeleton
    conv = detect_convention(sk.names)
    if conv is None:
        raise OptionError("joints", f"{motion.name or 'motion'}: {missing_for_map(sk.names)}")
    idx = np.array([sk.names.index(n) for n in CONVENTIONS[conv]], dtype=np.int64)
    pos, glob = joint_positions_and_rotations(sk.parents, motion.local_translations(), motion.rotations)
    parents = np.array(COMMON_PARENTS, dtype=np.int64)
    g = glob[:, idx]  # (F, 13, 3, 3)
    rot = np.empty_like(g)
    rot[:, 0] = g[:, 0]
    for j in range(1, len(COMMON_JOINTS)):
        rot[:, j] = np.einsum("fki,fkj->fij", g[:, parents[j]], g[:, j])
    # offsets: where each joint sits in its common parent's frame, averaged over the frames (exact
    # when the folded intermediate joints keep a fixed rotation, as CMU's LHipJoint does)
    p = pos[:, idx]
    offsets = np.zeros((len(COMMON_JOINTS), 3))
    for j in range(1, len(COMMON_JOINTS)):
        k = parents[j]
        offsets[j] = np.einsum("fki,fk->fi", g[:, k], p[:, j] - p[:, k]).mean(axis=0)
    channels = [("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation")] + [
        ("Zrotation", "Yrotation", "Xrotation")
    ] * (len(COMMON_JOINTS) - 1)
    common = Skeleton(COMMON_JOINTS, parents, offsets, channels)
    return Motion(
        common,
        motion.fps,
        np.ascontiguousarray(p[:, 0]),
        np.ascontiguousarray(rot),
        metres_per_unit=motion.metres_per_unit,
        up_axis=motion.up_axis,
        name=motion.name,
    )
