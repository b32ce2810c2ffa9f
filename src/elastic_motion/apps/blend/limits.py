"""Stage 9 of a blend: the joint limits (:mod:`elastic_motion.apps.limit_stage`).

Last of the stages that change the motion (after the contacts' clean-up, whose leg IK bends
knees, and the loop's closing): each DOF angle the inputs respect at the matched times
(each input's frame at every output frame, :class:`.timing.Clock`)
is moved into its range, eased over :data:`~elastic_motion.apps.limit_stage.LIMIT_EASE` s.
"""

from __future__ import annotations

from elastic_motion.apps.blend.inputs import BlendInputs
from elastic_motion.apps.blend.timing import Clock
from elastic_motion.apps.blend_options import BlendOptions
from elastic_motion.apps.limit_stage import LimitStage, keep_within_limits
from elastic_motion.motion import Motion
from elastic_motion.notes import Note

__all__ = ["limit_blend"]


def limit_blend(
    blend: Motion, inputs: BlendInputs, clock: Clock, options: BlendOptions, notes: list[Note]
) -> tuple[Motion, LimitStage | None]:
    """The blend within its joint limits (``options.joint_limits``) and what was done; the
    stage's notes are appended to ``notes`` (the blend's list).

    The inputs at the blend's frames are their frames at ``clock.times``; when the frames
    differ (a closed loop's cycle), the inputs' limits are taken over all their frames instead.
    """
    if options.joint_limits == "off":
        return blend, None
    motions = inputs.prepared.motions
    matched = None
    if all(len(t) == blend.n_frames for t in clock.times):
        matched = [t * m.fps for m, t in zip(motions, clock.times, strict=True)]
    out, stage = keep_within_limits(blend, options.joint_limits, motions, matched)
    if stage is not None:
        notes += stage.notes()
    return out, stage
