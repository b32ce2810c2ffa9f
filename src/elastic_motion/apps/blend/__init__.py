"""Blend motions: the four methods of paper 001 Fig. 5, the Lie group method of paper 000,
and weighted means of several motions.

Methods (``method``, ``warp``, ``landmarks``)
----------------------------------------------
=================  ============  ===========  ==============================================
method             warp          landmarks    what it is
=================  ============  ===========  ==============================================
``euler-linear``   ``none``      --           paper 001 Fig. 5 (a): frame-by-frame linear
                                              interpolation of Euler angles and root position
``euler-elastic``  ``none``      --           (b): SRV geodesic in ``R^d`` without warp
``euler-elastic``  ``dp``        --           (c): SRV geodesic in ``R^d`` with the optimal warp
``euler-elastic``  ``dp``        ``auto``     (d): with warp and feature points (the left
                                              knee passing the right knee, foot strikes and
                                              toe-offs), paired by phase (``apps.landmarks``)
``lie``            ``none``      --           paper 000 Fig. 4, bottom left: SRV geodesic in
                                              ``R^3 x SO(3)^J`` without warp
``lie``            ``dp``        optional     paper 000 Fig. 4, bottom right: with the warp
=================  ============  ===========  ==============================================

``warp="dp+refine"`` refines the DP warp off the grid by gradient descent. Any warp works
with any method (``euler-linear`` with a warp interpolates the time-aligned frames).

What happens, in order (two motions A, B and weight ``s``: the result is ``(1-s) A + s B``)
------------------------------------------------------------------------------------------
:func:`blend_motions` runs these stages, each a function in a module named for its job, all
taking the one :class:`~elastic_motion.apps.blend_options.BlendOptions`:

1. **Inputs** (:mod:`.inputs`): :func:`elastic_motion.apps.prepare.prepare_motions` (the one
   preparation step, options ``prepare``): T-pose frame, trim, static root, metres, Y-up,
   common joints, B resampled to A's frame rate, B placed like A (a rotation about the up
   axis and a floor translation fitted to A's root path: registration-curve style); the
   weights checked. With ``cycles`` (or ``loop``), the gait cycles of A and B are matched
   (:mod:`elastic_motion.apps.cycles`), both clips keep only the matched cycles (B moved on
   the floor to start where A does), and the warp passes through every cycle boundary and
   step (landmarks, relative weight at least 1000).
2. **Warps** (:mod:`.warps`): the warp ``phi`` of B onto A (``warp.method != "none"``), on
   the curves of the method at most ``warp.sample_fps`` frames per second, with the landmarks
   (seconds, or ``"auto"``: the warp without landmarks is solved first and is the prior that
   pairs the events of A and B by phase, :func:`elastic_motion.apps.landmarks.pair_by_phase`;
   a pair the prior already meets within the events' timing uncertainty is dropped, the
   others are met at the edge of that window nearest the prior, with a relative landmark
   weight of at least 1000; ``BlendResult.landmark_pairing`` says which and why); or the
   warps given (``template_warps``), or the Karcher template of three motions or more.
3. **Timing** (:mod:`.timing`): the result is a curve on ``[0, 1]``; its parameter ``u`` is
   played at time ``T(u) = (1 - s) d_A u + s d_B phi(u)``, the blended clock of the two
   inputs (``d``: durations), and sampled at A's frame rate. So ``s = 0`` gives A and
   ``s = 1`` gives B, each at its own timing, and the result's duration is
   ``(1 - s) d_A + s d_B``. (If extrapolation makes ``T`` decrease somewhere, its rate is
   held there at a tenth of the mean rate and the clock rescaled to the blended duration; a
   note says so.) A weight curve runs its own clock (:mod:`.transitions`).
4. **Curve blend** (:mod:`.curves`), on curves of all non-finger joints at the full frame
   rate: ``R^{-1}((1 - s) qA + s (qB * phi))`` started at the blended start point (paper 000,
   eq. 20; :func:`elastic_motion.curves.weighted_blend`), or for ``euler-linear``
   ``(1 - s) cA(u) + s cB(phi(u))``, or a weight curve's transition.
5. **Pose anchoring** (:mod:`.anchor`; ``anchor=True``, the default; ``"lie"`` and
   ``"euler-elastic"`` with constant weights in ``[0, 1]``): the SRV blend integrates blended
   velocities, so its joint angles drift slowly from the aligned inputs' poses (on Bandai
   normal x tired, knees bent backwards by up to 16 degrees in the Lie blend and 29 in the
   Euler one, where both inputs stand straight). The slow part (Gaussian, 1 s) of each
   joint's difference from the inputs' weighted mean pose at the matched times is removed:
   the geodesic mean of the local rotations for ``"lie"`` (:func:`.anchor.anchor_poses`), the
   mean of the Euler angles, the method's own space, for ``"euler-elastic"``
   (:func:`.anchor.anchor_euler`). The root's height is anchored likewise to the inputs'
   weighted mean root height: the root sinks too (8 cm over Bandai happy x sad), which the
   drifting poses had partly hidden; with the poses anchored alone the toes went 8.9 cm under
   the floor, with the height too 1.1 cm. The blend's velocities, which the elastic distance
   measures, barely change; the root's horizontal path is kept. A note,
   ``BlendResult.pose_anchor_deg`` and ``height_anchor_m`` give the largest corrections.
   ``anchor=False`` gives the papers' plain SRV blend (``examples/paper_figures.py``
   reproduces the papers with it, and with ``contact_warp="off"``, stage 10).
6. **Assembly** (:mod:`.assemble`): finger joints (not on the curves, see
   :mod:`elastic_motion.apps.align`) get the geodesic blend of A's and B's local rotations
   at the matched times; per-frame translations of non-root joints (position channels),
   linear blends. The skeleton:
   ``skeleton="blend"`` (default) gives each bone the weighted mean of the inputs' offsets,
   so that leg length and root height blend together; ``"first"`` keeps A's.
7. **Loop** (:mod:`.loop_closing`; ``loop=True``): one matched cycle of each is blended
   (stages 1-6) and closed into a seamless loop by :func:`elastic_motion.apps.loop.loop_motion`
   (root ``"travel"``, C1: the velocities match at the seam too, so a game playing it on
   repeat shows no hitch); then the contacts are planted on the loop (stage 8), and the
   small seam gap that leaves (it plants the cycle's first and last contacts separately) is
   closed once more; where that closing pushes a foot more than 5 mm into the floor, the feet
   are lifted out of it (the floor only, eased) and the loop closed again (at most 3 times).
   The notes give the seam and the skating after each step.
8. **Contacts** (:mod:`.contacts`; ``contacts="keep"``, the default: the foot-skate
   clean-up): the inputs' contacts (:func:`elastic_motion.motion.contacts.detect_contacts`)
   are carried through the warps to the blend's frames and enforced by leg IK and a smooth
   root correction (:mod:`elastic_motion.apps.cleanup`, :mod:`elastic_motion.motion.ik`; bone
   lengths kept). The change is smoothed in time by the largest of 0.4, 0.3, ..., 0.025, 0 s
   that leaves the blend skating at most 0.95 times the lesser input (its own contacts), and
   then only the least fraction of the way to the plants that still does so (bisection): the
   smallest change of the blend's velocities (what the elastic distance measures) that skates
   no more than the inputs; planting harder than the inputs themselves would only move the
   blend farther from them. The floor is enforced in full. Skipped, with a note, when the
   inputs have no contacts or a weight is 1. ``BlendResult.cleanup`` reports skating before
   and after and the largest pose change; ``before_cleanup`` keeps the blend before it.
   ``contacts="report"`` carries the contacts and measures the blend's skating against them
   without changing it; ``"off"`` does neither.
9. **Joint limits** (:mod:`.limits`; ``joint_limits="keep"``, the default, with limits from
   the first input's ASF file, a given :class:`~elastic_motion.motion.joint_limits.JointLimits`
   or an ``.asf`` limits file): every DOF angle the inputs respect at the matched times is
   moved into its range, the correction eased over 0.15 s
   (:func:`elastic_motion.apps.limit_stage.keep_within_limits`: exact within the range, the
   nearest point of the DOF-angle box per frame, not a constrained SRV solve); limits the
   inputs violate are reported, not enforced. ``BlendResult.joint_limits`` says which joints
   and frames changed and by how much. ``"report"`` only measures; ``"off"`` skips.
10. **Contact-guided warp** (:mod:`.contact_warp`; ``contact_warp="auto"``, the default; two
    motions, a warp the blend solves, no landmarks given, no cycles): the blend of stages 3-9
    on the plain warp has its skids counted exactly as its inputs' are
    (:func:`elastic_motion.apps.metrics.floor.foot_quality`; the clean-up's own measure when it
    is the final motion). No more than the inputs' larger count: nothing else is done. More:
    the contact-guided warp (heel strikes and toe-offs of A and B paired by phase around the
    plain warp, met as ``landmarks="auto"`` meets them) is solved, stages 3-9 run again on it,
    and its blend is kept when it has fewer skids and ``d(A, B)`` under its warp is at most
    1.02 times the plain warp's. A note and ``BlendResult.contact_warp`` give both skid
    counts, slid distances and distances and which was kept. ``"on"`` blends on the guided
    warp always (stage 2), ``"off"`` never.
11. **Metrics** (``metrics=True``, below) and the :class:`BlendResult`.

Time-varying weights (``weight_curve``; paper 000 sec. 5.3)
-----------------------------------------------------------
``w_k(u)`` piecewise linear in the result's normalised time ``u`` (knots ``u:w1/.../wK``, an
array ``(M, K + 1)``, a CSV file, or for two motions B's weight ``u:s``;
:func:`elastic_motion.apps.blend_options.parse_weight_curve`), for any ``K >= 2`` motions,
blended in SRV space on the warps of stage 2 (two motions: B's onto A; more: the weighted
Karcher template at the curve's mean weights): ``R^{-1}(sum_k w_k(u) (q_k * phi_k)(u))``
started at the start weighted at ``w(0)`` (:func:`elastic_motion.curves.weighted_blend` with
knots), anchored at the per-frame weighted mean pose, on the clock ``dT/du = sum_k w_k(u)
d_k phi_k'(u)`` (:mod:`.transitions`). Constant weights give the constant-weight blend (with
``trim_ends=False``: a weight curve's ends are not trimmed) and ``w = e_k`` input ``k`` on its
own clock. ``0:0,1:1`` is a transition from A into B: it starts on A's first pose and ends
near B's last, within the SRV blend's drift (until issue 33 the poses were frame-wise
geodesics at ``s(u)``, which end on B's exactly but are no SRV blend).

**Root translation.** The root position is a coordinate of the curve in both
representations (``R^3`` factor of ``R^3 x SO(3)^J``; the first three coordinates of the
Euler curve): after stage 1 the SRV blend mixes the root *velocities* of A and B (the time-
aligned ones, with a warp) and integrates them from the blended start position. The
blended path therefore goes in the direction both inputs go after placement and covers a
distance between theirs; it is not the average of the two paths point by point (that is
``euler-linear``).

Several motions (``len(motions) >= 3``, weights ``w_k`` summing to 1): the weighted mean in
SRV space after aligning all to a common template, the weighted Karcher mean
(:func:`elastic_motion.apps.statistics.karcher_mean`: align every motion to the current
mean, average, repeat). Its warps ``phi_k`` map the template's parameter to each motion's,
and the timing is ``T(u) = sum_k w_k d_k phi_k(u)``. Landmarks are for two motions only.

Metrics (``BlendResult.metrics``, a :class:`~elastic_motion.apps.metrics.BlendMetrics`, computed only with
``metrics=True``: they cost ``K (K + 1) / 2`` extra DP solves, or ``K`` (the result's onto
each input) when the warp stage solved the metrics' own warp of A and B: a Lie blend of two
with the default warp options and no landmarks; its curves and distance are reused): foot sliding of the
result and of each input (:func:`elastic_motion.apps.metrics.foot_sliding`), bone-length
error of the result against its own skeleton and each input's
(:func:`elastic_motion.apps.metrics.bone_length_error`), and Lie elastic distances
between the inputs and from the result to each input
(:func:`elastic_motion.apps.distance.distance_table`, the same metric whatever the blend
method; on the SRV geodesic with the warp, ``d(R, A) + d(R, B) = d(A, B)`` up to the
discretisation, a useful check).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from elastic_motion._options import with_overrides
from elastic_motion.apps.blend.anchor import NOTE_ANCHOR, AnchoredBody, anchor_blend
from elastic_motion.apps.blend.assemble import assemble_motion
from elastic_motion.apps.blend.contact_warp import (
    NOTE_CONTACT_WARP,
    ContactWarpChoice,
    contact_warp_applies,
    guided_or_plain,
)
from elastic_motion.apps.blend.contacts import NOTE_CLEANUP, BlendContacts, blend_contacts
from elastic_motion.apps.blend.curves import blend_curves
from elastic_motion.apps.blend.inputs import NOTE_CYCLES, BlendInputs, prepare_inputs
from elastic_motion.apps.blend.limits import limit_blend
from elastic_motion.apps.blend.loop_closing import NOTE_LOOP, BlendLoop, close_again, close_cycle
from elastic_motion.apps.blend.result import BlendResult
from elastic_motion.apps.blend.timing import NOTE_TIMING, Clock, output_clock
from elastic_motion.apps.blend.transitions import NOTE_WEIGHT_CURVE
from elastic_motion.apps.blend.warps import NOTE_LANDMARKS, NOTE_WARP, Warps, contact_guided_warp, find_warps
from elastic_motion.apps.blend_options import BlendOptions, parse_weight_curve
from elastic_motion.apps.distance import KnownDistances
from elastic_motion.apps.limit_stage import LimitStage
from elastic_motion.apps.metrics import BlendMetrics, blend_metrics
from elastic_motion.apps.metrics.floor import FootQuality, foot_quality
from elastic_motion.apps.prepare import PreparedMotions, Source
from elastic_motion.apps.progress import Progress, null_progress
from elastic_motion.errors import OptionError
from elastic_motion.motion import Motion
from elastic_motion.notes import Note
from elastic_motion.warp import WarpOptions

__all__ = [
    "NOTE_ANCHOR",
    "NOTE_CLEANUP",
    "NOTE_CONTACT_WARP",
    "NOTE_CYCLES",
    "NOTE_LANDMARKS",
    "NOTE_LOOP",
    "NOTE_TIMING",
    "NOTE_WARP",
    "NOTE_WEIGHT_CURVE",
    "BlendOptions",
    "BlendResult",
    "blend_motions",
    "parse_weight_curve",
]


def blend_motions(
    motions: Sequence[Source] | PreparedMotions,
    weights: float | Sequence[float] | None = None,
    options: BlendOptions | None = None,
    *,
    template_warps: Sequence[np.ndarray] | None = None,
    progress: Progress | None = None,
    **overrides: Any,
) -> BlendResult:
    """Blend two or more motions (the stages of the module docstring).

    Parameters
    ----------
    motions : sequence of path or Motion, or PreparedMotions
        ``K >= 2`` motions (the first, A, sets the frame rate, joint order and placement);
        or the result of :func:`~elastic_motion.apps.prepare.prepare_motions` (then the
        options' ``prepare`` must be None).
    weights : float or array_like of shape (K,), optional
        Two motions: ``s`` (the result is ``(1 - s) A + s B``) or ``(1 - s, s)``. More: one
        weight each, summing to 1. Default: equal weights (none with a weight curve).
    options : BlendOptions, optional
        Every knob of the blend (default ``BlendOptions()``: Lie curves, ``dp+refine`` warp,
        pose anchoring, contacts kept).
    template_warps : sequence of ndarray of shape (V, 2), optional
        Warps ``phi_k`` (a common template's parameter -> input ``k``'s) found before, e.g. by
        a blend space (:mod:`elastic_motion.apps.blendspace`); no warp is solved then.
    progress : callable, optional
        ``progress(stage, done, total)``.
    **overrides
        Fields of :class:`~elastic_motion.apps.blend_options.BlendOptions` changed from
        ``options`` (``method="euler-elastic"``, ``warp="dp"``, ``contacts="off"``, ...); an
        unknown name is an error.

    Returns
    -------
    BlendResult

    Raises
    ------
    ValueError
        Fewer than 2 motions, weights outside ``[0, 1]`` without ``extrapolate``, weights not
        summing to 1, different skeletons without ``joints="common"``, landmarks outside the
        clips or out of order, landmarks with more than two motions or without a warp, an
        unknown option (:class:`~elastic_motion.errors.OptionError` naming it).
    """
    opts = with_overrides(BlendOptions, options, overrides)
    report = progress or null_progress
    stages = 4 if opts.metrics else 3
    report("prepare", 0, stages)
    inputs = prepare_inputs(motions, weights, opts)
    report("warp", 1, stages)
    warps = plain = find_warps(inputs, opts, template_warps)
    report("blend", 2, stages)
    warps, built, choice, feet = _built_on_chosen_warp(inputs, plain, opts, template_warps is not None)
    notes = [*inputs.notes, *built.notes] + ([] if choice is None else [choice.note()])
    metrics = None
    if opts.metrics:
        report("metrics", 3, stages)
        metrics = _metrics(built, inputs, opts, plain, feet)
    report("done", stages, stages)
    looped, contacts = built.looped, built.contacts
    return BlendResult(
        motion=built.motion,
        method=opts.method,
        warp=warps.options.method,
        weights=inputs.weights,
        warps=warps.vertices,
        landmarks=warps.pairs,
        timing=built.clock.u,
        prepared=inputs.prepared,
        warp_options=warps.options,
        metrics=metrics,
        notes=tuple(notes),
        cleanup=contacts.cleanup,
        before_cleanup=built.before,
        cycles=inputs.cycles,
        loop=None if looped is None else looped.loop,
        landmark_pairing=None if warps.pairing is None else warps.pairing.summary(),
        pose_anchor_deg=built.anchored.pose_deg,
        height_anchor_m=built.anchored.height_m,
        weight_curve=None if opts.weight_curve is None else np.array(opts.weight_curve),
        options=opts,
        trimmed=built.clock.trimmed,
        joint_limits=built.limits,
        contact_warp=None if choice is None else choice.summary(),
    )


def _built_on_chosen_warp(
    inputs: BlendInputs, plain: Warps, opts: BlendOptions, given_warps: bool
) -> tuple[Warps, _Built, ContactWarpChoice | None, tuple[Sequence[FootQuality], FootQuality | None]]:
    """Stages 3 to 10: the blend built on the plain warp, or on the contact-guided warp
    (``contact_warp``: ``"on"``, or ``"auto"`` where the rule keeps it). Returns the warps
    kept, the blend, the rule's choice (None when it did not run) and the feet it measured
    (the inputs', the final blend's or None), for the metrics."""
    guided = contact_warp_applies(inputs, opts, given_warps)
    if opts.contact_warp == "on" and len(inputs.prepared.motions) != 2:
        raise OptionError(
            "contact_warp",
            f"expected two motions with 'on' (B warped onto A); got {len(inputs.prepared.motions)}",
        )
    warps = contact_guided_warp(inputs, plain) if guided and opts.contact_warp == "on" else plain
    built = _build(inputs, warps, opts)
    if not (guided and opts.contact_warp == "auto"):
        return warps, built, None, ((), None)
    measured = _Feet(inputs, opts)
    own = measured.inputs(built)
    warps, built, choice = guided_or_plain(
        inputs, warps, built, lambda w: _build(inputs, w, opts, own), measured.blend, own
    )
    return warps, built, choice, (measured.inputs(built), measured.known(built))


@dataclass(frozen=True, eq=False)
class _Built:
    """A blend built on one set of warps (stages 3 to 9) and what its stages did."""

    motion: Motion
    clock: Clock
    anchored: AnchoredBody
    contacts: BlendContacts
    looped: BlendLoop | None
    before: Motion | None
    limits: LimitStage | None
    notes: tuple[Note, ...]

    @property
    def planted_feet(self) -> FootQuality | None:
        """The final motion measured like its inputs, when the contacts stage measured it: the
        clean-up's motion, unchanged since (no loop closed, no joint limit moved)."""
        c = self.contacts
        if c.applied and self.motion is c.cleanup.motion:
            return c.result_feet
        return None


def _build(
    inputs: BlendInputs, warps: Warps, opts: BlendOptions, inputs_feet: Sequence[FootQuality] = ()
) -> _Built:
    """Stages 3 to 9 on the given warps (the contact-guided warp's rule may run them twice;
    the second time with the inputs' feet the first measured, ``inputs_feet``)."""
    clock = output_clock(inputs, warps, opts)
    anchored = anchor_blend(blend_curves(inputs, warps, clock, opts), inputs, clock, opts)
    blend = assemble_motion(anchored.body, inputs, clock, opts, warps.options.method)
    notes = [*warps.notes, *clock.notes, *anchored.notes]
    looped = close_cycle(blend, inputs.cycles) if opts.loop else None
    if looped is not None:
        blend = looped.motion
        notes += looped.notes
    contacts = blend_contacts(blend, inputs, warps, clock, opts, inputs_feet)
    notes += contacts.notes
    before = None
    if contacts.applied:
        before, blend = blend, contacts.cleanup.motion
        if looped is not None:
            looped = close_again(contacts.cleanup, looped)
            blend = looped.motion
            notes += looped.notes
    blend, limits = limit_blend(blend, inputs, clock, opts, notes)
    return _Built(blend, clock, anchored, contacts, looped, before, limits, tuple(notes))


class _Feet:
    """The feet of the inputs and of built blends, measured like the inputs
    (:func:`~elastic_motion.apps.metrics.floor.foot_quality`, the blend's contact options),
    each once: what a contacts stage measured is taken, not measured again."""

    def __init__(self, inputs: BlendInputs, opts: BlendOptions) -> None:
        self._inputs = inputs
        self._options = opts.contact_options
        self._own: tuple[FootQuality, ...] = ()
        self._seen: list[tuple[Motion, FootQuality]] = []  # the motions themselves: no reused id

    def inputs(self, built: _Built) -> tuple[FootQuality, ...]:
        if built.contacts.inputs_feet:
            return built.contacts.inputs_feet
        if not self._own:
            self._own = tuple(foot_quality(m, self._options) for m in self._inputs.prepared.motions)
        return self._own

    def blend(self, built: _Built) -> FootQuality:
        q = self.known(built)
        if q is None:
            q = foot_quality(built.motion, self._options)
            self._seen.append((built.motion, q))
        return q

    def known(self, built: _Built) -> FootQuality | None:
        """The final motion of ``built`` measured already (by its contacts stage or here)."""
        if built.planted_feet is not None:
            return built.planted_feet
        return next((q for m, q in self._seen if m is built.motion), None)


def _metrics(
    built: _Built,
    inputs: BlendInputs,
    opts: BlendOptions,
    plain: Warps,
    feet: tuple[Sequence[FootQuality], FootQuality | None],
) -> BlendMetrics:
    """Stage 11: the metrics, with the feet measured already (the inputs' and the final
    blend's, by the contacts stage or by the contact-guided warp's rule, ``feet``): no motion
    is measured twice. The warp stage's curves and distance of A and B too, when they are the
    metrics' own (the ``plain`` warp, solved without landmarks, whichever warp the blend
    kept)."""
    warps = plain
    reuse = _metric_warp(warps, opts)
    return blend_metrics(
        built.motion,
        inputs.prepared,
        inputs.weights,
        opts.contact_options,
        feet_inputs=feet[0] or built.contacts.inputs_feet,
        feet=feet[1] or built.planted_feet,
        inputs_known=KnownDistances(warps.srvs, np.array([[0.0, warps.distance], [warps.distance, 0.0]]))
        if reuse
        else None,
    )


def _metric_warp(warps: Warps, opts: BlendOptions) -> bool:
    """Whether the blend's warp of B onto A is the metrics' distance of A and B: solved on Lie
    curves with ``WarpOptions()`` (its sampling and solver) and no landmarks, as
    :func:`elastic_motion.apps.distance.distance_table` solves it."""
    if not warps.srvs or warps.distance is None or warps.pairs or opts.method != "lie":
        return False
    default = WarpOptions()
    return warps.options.replace(landmark_weight=default.landmark_weight) == default
