"""Quality metrics of a motion an animator judges: skating while in contact, feet below the
floor, foot sliding, bone lengths, a loop's seam and a blend's distances to its inputs.

The one home of the measures an app reports about its output: feet (:mod:`.feet`), bones
(:mod:`.bones`), a loop's seam (:mod:`.seam`) and a blend against its inputs (:mod:`.blend`,
with the elastic distances of :func:`elastic_motion.apps.distance.distance_table`).

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

from elastic_motion.apps.metrics.blend import BlendMetrics, blend_metrics
from elastic_motion.apps.metrics.bones import BoneLengthError, bone_length_error
from elastic_motion.apps.metrics.feet import (
    ContactSkating,
    FootSliding,
    contact_skating,
    foot_joints,
    foot_sliding,
)
from elastic_motion.apps.metrics.seam import SeamMetrics, seam_metrics

__all__ = [
    "BlendMetrics",
    "BoneLengthError",
    "ContactSkating",
    "FootSliding",
    "SeamMetrics",
    "blend_metrics",
    "bone_length_error",
    "contact_skating",
    "foot_joints",
    "foot_sliding",
    "seam_metrics",
]
