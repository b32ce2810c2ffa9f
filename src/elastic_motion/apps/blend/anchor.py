"""Stage 5 of a blend: pose anchoring, and the blended curve made a motion of the curve joints.

The SRV blend integrates blended velocities, so its joint angles drift slowly from the
aligned inputs' poses (on Bandai normal x tired, knees bent backwards by up to 16 degrees in
the Lie blend and 29 in the Euler one, where both inputs stand straight). With ``anchor``
(``"lie"`` and ``"euler-elastic"`` with weights in ``[0, 1]``, constant or a weight curve's
per frame) the slow part
(Gaussian, :data:`POSE_ANCHOR` s) of each joint's difference from the inputs' weighted mean
pose at the matched times is removed: the geodesic mean of the local rotations for
``"lie"`` (:func:`anchor_poses`), the mean of the Euler angles, the method's own space, for
``"euler-elastic"`` (:func:`anchor_euler`). The root's height is anchored likewise to the
inputs' weighted mean root height (the root sinks too: 8 cm over Bandai happy x sad); its
horizontal path is kept. An extrapolated mean pose is no anchor: beyond the inputs it bends
joints further than either (knees 48 degrees backwards at s = 1.5 on Bandai normal x tired),
so extrapolated blends are not anchored (a note says so).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from elastic_motion.apps.blend.curves import BlendedCurve, inputs_mean
from elastic_motion.apps.blend.inputs import BlendInputs
from elastic_motion.apps.blend.sampling import blend_rotations, frame_weight, sample_linear, sample_rotations
from elastic_motion.apps.blend.timing import Clock
from elastic_motion.apps.blend_options import BlendOptions
from elastic_motion.curves import DiscreteCurve
from elastic_motion.groups import SO3
from elastic_motion.motion import Motion
from elastic_motion.motion.edit import gaussian_frames, smooth_change
from elastic_motion.notes import Note

__all__ = ["NOTE_ANCHOR", "POSE_ANCHOR", "AnchoredBody", "anchor_blend", "anchor_euler", "anchor_poses"]

#: The SRV blend integrates blended velocities, so its joint angles drift from the aligned
#: inputs' poses: on Bandai normal x tired the knees of the Lie + warp blend bent backwards by
#: up to 16 degrees where both inputs stand straight, 16 degrees from their mean pose on
#: average (the Euler + warp blend: 29 degrees backwards). The drift is slow, so it is taken
#: out by a slow correction (Gaussian of this standard deviation, s) toward the inputs'
#: weighted mean pose: the knees' range is the inputs' again, while the velocities, which the
#: elastic distance measures, barely change (0.03 d(A, B) / 2 on that pair).
POSE_ANCHOR = 1.0
#: The pose anchoring: its largest corrections, or why the blend was not anchored.
NOTE_ANCHOR = "blend.anchor"

_SO3 = SO3()
_AXES = "xyz"


@dataclass(frozen=True, eq=False)
class AnchoredBody:
    """The blend's curve joints as a motion, anchored when asked.

    Attributes
    ----------
    body : Motion
        The curve joints, one frame per output frame.
    pose_deg : float or None
        The largest rotation (``"lie"``) or Euler angle (``"euler-elastic"``) correction in
        degrees; None when not anchored.
    height_m : float or None
        The largest root height correction (metres; length units when unknown); None when
        not anchored.
    notes : tuple of Note
    """

    body: Motion
    pose_deg: float | None
    height_m: float | None
    notes: tuple[Note, ...]


def anchor_poses(
    body: Motion, inputs: Sequence[Motion], times: Sequence[np.ndarray], w: np.ndarray
) -> tuple[Motion, float, float]:
    """``body`` (the blend's curve joints, one frame per output frame) with the slow part of its
    rotations' difference from the inputs' weighted mean pose removed (:data:`POSE_ANCHOR`),
    and likewise of its root height's difference from the inputs' weighted mean root height.

    ``inputs``: the prepared inputs' curve motions (same joints as ``body``); ``times``: each
    input's time (s) at every output frame; ``w``: the blend weights ``(K,)`` or per output
    frame ``(F, K)`` (a weight curve). Returns the
    anchored motion, the largest rotation correction in degrees and the largest height
    correction (``body``'s length units). The root's horizontal path is kept.
    """
    joints = np.arange(body.n_joints)
    rots = [sample_rotations(m, joints, t) for m, t in zip(inputs, times, strict=True)]
    up = _AXES.index(body.up_axis)
    target = body.root_translation.copy()  # the horizontal path kept, the mean height
    target[:, up] = sum(
        frame_weight(w, k, body.n_frames, 0) * sample_linear(m.root_translation[:, up], m.fps, t)
        for k, (m, t) in enumerate(zip(inputs, times, strict=True))
    )
    mean = body.replace(rotations=blend_rotations(rots, w), root_translation=target)
    out = smooth_change(body, mean, POSE_ANCHOR * body.fps)
    drift = _SO3.log(np.swapaxes(body.rotations, -1, -2) @ out.rotations)
    lift = float(np.abs(out.root_translation[:, up] - body.root_translation[:, up]).max(initial=0.0))
    return out, float(np.degrees(np.linalg.norm(drift, axis=-1).max())), lift


def anchor_euler(
    values: np.ndarray, mean: np.ndarray, fps: float, up: int
) -> tuple[np.ndarray, float, float]:
    """The Euler-angle blend ``values`` ``(F, 3 + 3 J)`` (root position, then angles in radians)
    with the slow part (:data:`POSE_ANCHOR`) of its angles' and its root height's (component
    ``up`` of the position) difference from ``mean``, the weighted mean of the aligned inputs'
    values, removed; the root's horizontal path is kept. Returns the anchored values, the
    largest correction of one angle in degrees and of the height (length units)."""
    out = values.copy()
    if values.shape[0] < 2:
        return out, 0.0, 0.0
    cols = np.r_[up, 3 : values.shape[1]]
    drift = gaussian_frames(values[:, cols] - mean[:, cols], POSE_ANCHOR * fps)
    out[:, cols] -= drift
    return out, float(np.degrees(np.abs(drift[:, 1:]).max())), float(np.abs(drift[:, 0]).max())


def anchor_blend(
    blended: BlendedCurve, inputs: BlendInputs, clock: Clock, options: BlendOptions
) -> AnchoredBody:
    """Stage 5 (module docstring): the curve anchored (Euler) or the motion anchored (Lie)."""
    prep, w = inputs.prepared, inputs.weights
    anchorable = options.anchor and options.method != "euler-linear"
    anchored = anchorable and bool(((w >= 0.0) & (w <= 1.0)).all())
    rep = options.representation
    like = prep.curve_motion(0)
    curve = blended.curve
    pose = height = None
    if anchored and not rep.is_lie:
        mean = inputs_mean(blended.inputs, clock.weights, clock.local_u)
        values, pose, height = anchor_euler(curve.values, mean, prep.fps, _AXES.index(like.up_axis))
        curve = DiscreteCurve(values, curve.group)
    body = rep.from_curve(curve, like, fps=prep.fps)
    if anchored and rep.is_lie:
        curve_inputs = [prep.curve_motion(k) for k in range(len(prep.motions))]
        body, pose, height = anchor_poses(body, curve_inputs, clock.times, clock.weights)
    if height is not None and like.metres_per_unit is not None:
        height *= like.metres_per_unit
    return AnchoredBody(body, pose, height, _anchor_notes(anchorable, pose, height, like, rep.is_lie))


def _anchor_notes(
    anchorable: bool, pose: float | None, height: float | None, like: Motion, lie: bool
) -> tuple[Note, ...]:
    if pose is not None and height is not None:
        mean_pose = "geodesic mean pose" if lie else "mean Euler angles"
        size = f"{100 * height:.3g} cm" if like.metres_per_unit is not None else f"{height:.3g} length units"
        text = (
            f"poses anchored: the SRV blend's slow drift from the aligned inputs' {mean_pose} and mean root "
            f"height (up to {pose:.3g} deg and {size}, Gaussian {POSE_ANCHOR:g} s) removed"
        )
        return (Note(NOTE_ANCHOR, text, {"pose_deg": pose, "height": height}),)
    if anchorable:
        return (Note(NOTE_ANCHOR, "poses not anchored: the weights extrapolate beyond the inputs"),)
    return ()
