"""The seam-metrics stage of a loop: what an animator sees at the seam, before and after, the
cycle transform, and the skating during the input's contacts (:func:`measure_loop`).

Units: positions in metres when the motion's unit is known (else its length unit), speeds
in m/s, angles in degrees, ``heading_change`` in radians.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from elastic_motion.apps.loop.close import ClosedClip, ClosedJoints
from elastic_motion.apps.loop.options import LoopOptions
from elastic_motion.apps.loop.window import relative_change
from elastic_motion.apps.metrics import ContactSkating, SeamMetrics, contact_skating, seam_metrics
from elastic_motion.apps.metrics.floor import FootQuality, foot_quality
from elastic_motion.motion import Motion
from elastic_motion.motion.contacts import Contacts, detect_contacts
from elastic_motion.motion.looping import cycle_transform, on_belt, twist_angle

__all__ = ["LoopMeasures", "measure_loop"]

_AXES = "xyz"


@dataclass(frozen=True, eq=False)
class LoopMeasures:
    """The numbers of one loop (:func:`measure_loop`).

    Attributes
    ----------
    seam_before, seam_after : SeamMetrics
        :func:`~elastic_motion.apps.metrics.seam_metrics` of the input and of the loop (the
        closed joints; ``seam_after`` with the deviation from the input).
    heading_change : float
        ``delta`` of the loop's cycle transform, radians (0 in place).
    displacement : ndarray, shape (3,)
        Floor-plane root displacement per cycle, motion length units (0 in place).
    contacts : Contacts or None
        The input's contacts (None with ``contacts="off"``).
    skating_before, skating_after : ContactSkating or None
        Skating and depth below the floor during the input's contacts, input and loop (None
        without a joint that can touch the floor).
    skating_on_treadmill : ContactSkating or None
        Contacts kept on a treadmill: the loop's skating with the belt's motion taken out.
    change_m : float
        The most the loop moves a closed joint or end site relative to the root, against the
        clip (in place: the clip on its own treadmill), metres (what ``change_bound`` bounds).
    feet_before, feet_after : FootQuality or None
        The clip and the loop each measured on itself the same way
        (:func:`~elastic_motion.apps.metrics.floor.foot_quality`: own contacts, skating, skids),
        the loop in place with the belt's motion put back (:func:`on_belt`); None with
        ``contacts="off"``.
    """

    seam_before: SeamMetrics
    seam_after: SeamMetrics
    heading_change: float
    displacement: np.ndarray
    contacts: Contacts | None = None
    skating_before: ContactSkating | None = None
    skating_after: ContactSkating | None = None
    skating_on_treadmill: ContactSkating | None = None
    change_m: float = 0.0
    feet_before: FootQuality | None = None
    feet_after: FootQuality | None = None


def measure_loop(
    clip: Motion, closed: ClosedClip, options: LoopOptions, joints: ClosedJoints
) -> LoopMeasures:
    """The seam metrics, cycle transform and contact skating of ``closed``, the loop of ``clip``."""
    out, root = closed.motion, options.root
    rot, _ = cycle_transform(out, root)
    travel = root == "travel"
    found = detect_contacts(clip, options.detection) if options.contact_mode != "off" else None
    sk_before = sk_after = sk_belt = None
    if found is not None and found.joints:
        sk_before = contact_skating(clip, found)
        sk_after = contact_skating(out, found)
        if closed.kept is not None and closed.kept.treadmill:
            # in place the feet ride the belt: how much they slip on it
            sk_belt = contact_skating(on_belt(out, clip), found)
    feet_before = feet_after = None
    if options.contact_mode != "off":
        feet_before = foot_quality(clip, options.detection)
        feet_after = foot_quality(out if travel else on_belt(out, clip), options.detection)
    return LoopMeasures(
        change_m=relative_change(out, clip, root, joints.closed),
        feet_before=feet_before,
        feet_after=feet_after,
        seam_before=seam_metrics(clip, root=root, joints=joints.closed),
        seam_after=seam_metrics(out, original=clip, root=root, joints=joints.closed),
        heading_change=float(twist_angle(rot, _AXES.index(clip.up_axis)) if travel else 0.0),
        displacement=out.root_translation[-1] - out.root_translation[0] if travel else np.zeros(3),
        contacts=found,
        skating_before=sk_before,
        skating_after=sk_after,
        skating_on_treadmill=sk_belt,
    )
