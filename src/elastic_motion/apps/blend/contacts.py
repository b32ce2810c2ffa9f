"""Stage 8 of a blend: the inputs' foot contacts (``contacts``: keep, report or off).

The inputs are measured on themselves (:func:`elastic_motion.apps.metrics.floor.foot_quality`:
their own contacts, skating, skids, swing clearance) and their contacts become the blend's
**contact plan** (:mod:`elastic_motion.apps.blend.contact_plan`): when each foot is planted,
where, and how low it may swing. ``"report"`` measures the blend against the plan and changes
nothing. ``"keep"`` plants the plan by leg IK and a smooth root correction (the foot-skate
clean-up, :func:`elastic_motion.apps.cleanup.cleanup_footskate`; bone lengths kept): feet
locked where the plan plants them (moving as the inputs' planted feet do, no faster than the
better input's), lifted where they swing lower than the inputs' clearance. Several ways of
planting it are tried (the change smoothed in time by each of :data:`SMOOTHING`, steadier
plants, :data:`STEADIER`, plants where the blend's feet are at their ends, the swing raise
eased or not); of those whose blend, **measured like its inputs**, skids no more than they
do, skates at most :data:`SKATE_GOAL` times the lesser input, swings at least
:data:`CLEARANCE_GOAL` as high and puts no point more than
:data:`~elastic_motion.apps.cleanup.SETTLE_BELOW` under its own floor, the one that changes
the blend least (its SRV distance to the blend on the blend's clock: the elastic distance is
made of velocities) is kept: the least change that plants its feet as well as the inputs
plant theirs. The search ends early at a trial that meets the goal with a change of at most
:data:`ENOUGH` of the blend's distance to the nearer input. Where the planted blend's own floor
stands above the plan's, it is planted again with nothing deeper under that floor than the
inputs go under theirs (:func:`plant_plan`). Skipped, with a note, when the inputs have no
contacts or a weight is 1.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from elastic_motion.apps.blend.contact_plan import ContactPlan, at_ends, on_own_floor, plan_contacts, steadier
from elastic_motion.apps.blend.inputs import BlendInputs
from elastic_motion.apps.blend.timing import Clock
from elastic_motion.apps.blend.warps import Warps
from elastic_motion.apps.blend_options import BlendOptions
from elastic_motion.apps.cleanup import (
    SETTLE_BELOW,
    CleanupOptions,
    CleanupResult,
    cleanup_footskate,
    find_legs,
)
from elastic_motion.apps.metrics import contact_skating
from elastic_motion.apps.metrics.floor import FootQuality, foot_quality
from elastic_motion.curves import srv_distance, srv_transform
from elastic_motion.motion import Motion, resample_at_times
from elastic_motion.motion.contacts import MISSED_STANCES, ContactOptions, Contacts
from elastic_motion.motion.ik import LegChain
from elastic_motion.motion.representations import group_weights, to_lie_curve
from elastic_motion.notes import Note

__all__ = [
    "CLEARANCE_GOAL",
    "ENOUGH",
    "NOTE_CLEANUP",
    "PLANT",
    "SKATE_GOAL",
    "SMOOTHING",
    "STEADIER",
    "BlendContacts",
    "blend_contacts",
    "plant_plan",
]

#: The clean-up's smoothings of its change (Gaussian, s), tried from the largest, for each way of
#: planting (:func:`plant_plan`) until one meets the goal (0: the exact plants). A smoother
#: change moves the blend less from the SRV geodesic in the elastic distance (fine measure,
#: Bandai normal x old: 0.75 of d(A, B) / 2 exact, 0.34 at 0.1 s) but lets the feet slide
#: again (6 skids at 0.1 s, none exact): the feet come first.
SMOOTHING = (0.4, 0.3, 0.2, 0.15, 0.1, 0.07, 0.05, 0.035, 0.025, 0.0)
SKATE_GOAL = 1.05
#: The least swing clearance of a planted blend's foot point, as a fraction of the lesser
#: input's on the same point (issue 29's target).
CLEARANCE_GOAL = 0.8
#: A planting that meets the goal and changes the blend by at most this fraction of its
#: distance to the nearer input (both on the blend's clock, :func:`_change_from`) ends the search
#: (:func:`plant_plan`): even along the inputs' difference it would move the blend's distances
#: by at most this, across it by ~2 %; searching on for a smaller change cost 4x the clean-up's
#: time (CMU 07_01 x 08_02: the command line's blend 1.09 -> 1.51 s) and changed nothing there.
ENOUGH = 0.2
#: The fractions of the plants' own floor-plane motion tried
#: (:func:`~elastic_motion.apps.blend.contact_plan.steadier`, :func:`plant_plan`): the inputs' planted feet
#: move, and carried into a blend whose own contacts begin and end elsewhere that motion read
#: as skating (DeepMimic walk x run: 1.35x the better input with all of it).
STEADIER = (1.0, 0.5, 0.0)
#: How a blend's contact plan is planted: all the way (its targets already carry what the
#: inputs' planted feet do), without a vertical settle (the targets' heights are the inputs'
#: own), eased in and out over the default 0.15 s; the smoothing is :func:`plant_plan`'s.
PLANT = CleanupOptions(smooth=0.0, strength=1.0, settle=0.0)
#: The contacts carried to the blend: enforced (with the skating before and after), measured
#: (``"report"``), missed stances of the inputs, or why nothing was done.
NOTE_CLEANUP = "blend.cleanup"

_AXES = "xyz"


@dataclass(frozen=True, eq=False)
class BlendContacts:
    """What the contacts stage did.

    Attributes
    ----------
    cleanup : CleanupResult or None
        The clean-up (``applied``), or the skating measured (``"report"``: ``applied``
        False, the motion unchanged); None when skipped.
    notes : tuple of Note
    inputs_feet : tuple of FootQuality
        The prepared inputs measured on themselves (:func:`~elastic_motion.apps.metrics.floor.foot_quality`
        with the blend's contact options); empty when the stage measured nothing. The blend's
        metrics take them instead of measuring again.
    result_feet : FootQuality or None
        The clean-up's motion (``cleanup.motion``, when ``applied``) measured likewise.
    """

    cleanup: CleanupResult | None
    notes: tuple[Note, ...]
    inputs_feet: tuple[FootQuality, ...] = ()
    result_feet: FootQuality | None = None

    @property
    def applied(self) -> bool:
        """Whether the blend was changed (its contacts planted)."""
        return self.cleanup is not None and self.cleanup.applied


def blend_contacts(
    result: Motion,
    inputs: BlendInputs,
    warps: Warps,
    clock: Clock,
    options: BlendOptions,
    inputs_feet: Sequence[FootQuality] = (),
) -> BlendContacts:
    """Stage 8 (module docstring): the contact plan of the blend, planted (``"keep"``) or
    measured against (``"report"``). ``inputs_feet``: the prepared inputs measured already
    (:func:`~elastic_motion.apps.metrics.floor.foot_quality`, ``options.contact_options``: a
    second build of the blend on another warp), not measured again."""
    if options.contacts == "off":
        return BlendContacts(None, ())
    w, prep = clock.weights, inputs.prepared
    if w.ndim == 1 and np.isclose(w, 1.0).any():
        return _skipped("clean-up: skipped, the result is one of the inputs (a weight of 1)")
    measured = list(inputs_feet) or [foot_quality(m, options.contact_options) for m in prep.motions]
    found = [q.contacts for q in measured]
    notes = [
        Note(NOTE_CLEANUP, f"clean-up: contacts of {label}: {n}", n.data)
        for label, c in zip(prep.labels, found, strict=True)
        for n in c.notes
        if n.kind == MISSED_STANCES
    ]
    if not any(c.any for c in found):
        return _skipped("clean-up: skipped, no contacts found in the inputs", notes, measured)
    own = [q.skating.mean_speed for q in measured if q.contacts.any]
    plan = plan_contacts(result, prep.motions, found, clock, options.contact_options, min(own))
    if options.contacts == "report":
        return _measured(result, plan.contacts, own, notes, measured)
    on_clock = [
        resample_at_times(m, m.times, np.clip(t, m.times[0], m.times[-1]), fps=result.fps)
        for m, t in zip(prep.motions, clock.times, strict=True)
    ]
    change = _change_from(result)
    enough = ENOUGH * min(change(m) for m in on_clock)
    res, feet = plant_plan(result, plan, measured, options.contact_options, enough)
    if res.applied:
        notes.append(_planted_note(res, own))
    else:
        notes += [Note(NOTE_CLEANUP, f"clean-up: {n}") for n in res.notes]
    return BlendContacts(res, tuple(notes), tuple(measured), feet if res.applied else None)


def plant_plan(
    result: Motion,
    plan: ContactPlan,
    inputs: Sequence[FootQuality],
    contact_options: ContactOptions,
    enough: float = 0.0,
) -> tuple[CleanupResult, FootQuality | None]:
    """The plan planted with the least change of the blend among the trials whose blend,
    measured like its inputs, skids no more than they do, skates at most :data:`SKATE_GOAL`
    times the lesser, swings at least :data:`CLEARANCE_GOAL` as high as the lesser on every
    foot point and puts no point more than :data:`~elastic_motion.apps.cleanup.SETTLE_BELOW`
    under its own floor (module docstring); when no trial does, the one that comes nearest
    (fewest skids, then least slid, then least skating, depth, lost clearance).

    The trials: each smoothing of :data:`SMOOTHING`, with the plants' own motion scaled by each
    of :data:`STEADIER` (:func:`~elastic_motion.apps.blend.contact_plan.steadier`), with the
    swing raise eased in and out (``ease_swing``: a raise that jumps where the plan releases a
    foot snaps the knee; the plain raise only when no eased trial meets the goal: tried always,
    it cost twice the time for at most 0.03 of ``d(A, B) / 2`` on the rows of
    ``benchmarks/blend_quality.py``), with the plants where the plan puts them and at the
    middle of where the blend's feet are at their ends
    (:func:`~elastic_motion.apps.blend.contact_plan.at_ends`); for each but the smoothing, the
    smoothest that meets the goal (less smoothing changes the blend faster). The **change** is
    the SRV distance of the planted blend to the blend on the blend's own clock
    (:func:`_change_from`, the elastic distance's L2 norm without a warp: an upper bound of
    ``d(R, R0)``). Kept before as the first trial to meet the goal, from the smoothest down,
    it moved the blend 0.06-0.81 of ``d(A, B) / 2``: a smoothed change of steadier plants can
    cost far less than an exact plant (Bandai normal x tired: 0.73 with the exact plants, 0.11
    steadier and smoothed over 0.2 s, both meeting the goal; fine measure,
    ``benchmarks/cleanup_distance.py``).
    ``enough``: a trial that meets the goal with a change of at most this ends the search
    (:data:`ENOUGH`; 0: every trial). Where the planted blend's own floor stands above the
    plan's, no point may go deeper under it than the shallower input goes under its own, at most
    :data:`~elastic_motion.apps.cleanup.SETTLE_BELOW`
    (:func:`~elastic_motion.apps.blend.contact_plan.on_own_floor`): planted again, kept when it
    comes as near. With it, the planted blend measured like its inputs
    (:func:`~elastic_motion.apps.metrics.floor.foot_quality`; None when the plan planted
    nothing)."""
    legs, _ = find_legs(result)  # once, for every trial below
    search = _Search(_change_from(result), enough)
    placements = [plan]  # and at_ends(plan), made when first tried
    best = None
    for ease_swing in (True, False):
        if not ease_swing and best is not None and not any(best[2][:-1]):
            break  # an eased trial met the goal
        for k in range(2):
            met = best is not None and not any(best[2][:-1])
            if met and best[2][-1] <= enough:
                return best[0], best[1]  # little enough
            if k == len(placements):
                placements.append(at_ends(plan, result, legs))
            # a trial that changes the blend more than one that met the goal ends its search
            most = best[2][-1] if met else math.inf
            got = _plant_on_floor(
                result, placements[k], inputs, contact_options, legs, ease_swing,
                dataclasses.replace(search, most=most),
            )  # fmt: skip
            if got[1] is None:
                return got[0], None
            if best is None or got[2] < best[2]:
                best = got
    assert best is not None
    return best[0], best[1]


@dataclass(frozen=True)
class _Search:
    """How far :func:`plant_plan`'s search goes.

    Attributes
    ----------
    change : callable
        ``change(planted)``: the change of a planted blend from the blend (:func:`_change_from`).
    enough : float
        A trial that meets the goal with a change of at most this ends the search.
    most : float
        A trial that misses the goal with a change above this ends its smoothings (a change
        that met the goal already).
    """

    change: Callable[[Motion], float]
    enough: float = 0.0
    most: float = math.inf


def _plant_on_floor(
    result: Motion,
    plan: ContactPlan,
    inputs: Sequence[FootQuality],
    contact_options: ContactOptions,
    legs: Sequence[LegChain],
    ease_swing: bool,
    search: _Search,
) -> tuple[CleanupResult, FootQuality | None, tuple[float, ...]]:
    """:func:`plant_plan` with the swing raise eased or not: the trials, then on the planted
    blend's own floor where it stands above the plan's; with the key of what it keeps (how far
    it misses the goal, then its change)."""
    res, q, key = _plant_trials(result, plan, inputs, contact_options, legs, ease_swing, search)
    if q is None:
        return res, None, key
    lift = q.contacts.floor_heights() - plan.floor_heights()
    if lift.max() <= _SAME_FLOOR:
        return res, q, key
    below = min(SETTLE_BELOW, *(i.below_floor_m for i in inputs))
    own = on_own_floor(plan, q.contacts.floor_heights(), below)
    again = _plant_trials(result, own, inputs, contact_options, legs, ease_swing, search)
    # kept when it misses the goal by no more (its own floor asks more of it than the plan's)
    return again if again[1] is not None and again[2][:-1] <= key[:-1] else (res, q, key)


#: Metres: floors that agree to this are one floor (:func:`plant_plan`; a blend of a motion
#: with itself is planted once).
_SAME_FLOOR = 1e-6


def _change_from(before: Motion) -> Callable[[Motion], float]:
    """``change(after)``: the SRV distance of ``after`` to ``before`` on their common clock
    (same frames; ``before``'s SRV function made once, the trials measure against it): the norm
    of the elastic distance without a warp, so an upper bound of it; each motion a curve in
    ``R^3 x SO(3)^J`` with ``before``'s skeleton's default weights
    (:func:`~elastic_motion.motion.representations.to_lie_curve`). The SRV is made of
    velocities: a change costs more the faster it varies."""
    w, tw = group_weights([before])
    reference = srv_transform(to_lie_curve(before, w, translation_weight=tw))

    def change(after: Motion) -> float:
        return srv_distance(reference, srv_transform(to_lie_curve(after, w, translation_weight=tw)))

    return change


def _change(before: Motion, after: Motion) -> float:
    """:func:`_change_from` of ``before`` for one ``after``."""
    return _change_from(before)(after)


def _clearance_lost(q: FootQuality, inputs: Sequence[FootQuality]) -> float:
    """How far the least swing clearance of ``q`` over its foot points falls short of
    :data:`CLEARANCE_GOAL` times the lesser input's on the same point (a fraction of it; 0:
    none short). Points that an input or ``q`` does not swing are left out."""
    short = 0.0
    for name, v in q.swing_clearance_m.items():
        own = [x for x in (i.swing_clearance_m.get(name, np.nan) for i in inputs) if np.isfinite(x)]
        if own and np.isfinite(v) and min(own) > 0:
            short = max(short, CLEARANCE_GOAL - v / min(own))
    return short


def _plant_trials(
    result: Motion,
    plan: ContactPlan,
    inputs: Sequence[FootQuality],
    contact_options: ContactOptions,
    legs: Sequence[LegChain],
    ease_swing: bool = True,
    search: _Search | None = None,
) -> tuple[CleanupResult, FootQuality | None, tuple[float, ...]]:
    """:func:`plant_plan`'s search over :data:`STEADIER` and :data:`SMOOTHING`: of the trials
    that meet the goal the one of least change (:func:`_change_from`), else the nearest; with its
    key: how far it misses the skids, the slid distance, the skating, the depth under its own
    floor (at most :data:`~elastic_motion.apps.cleanup.SETTLE_BELOW`) and the swing clearance
    (all 0 when it meets them), then its change. For each steadier plan the smoothings are tried
    from the largest until one meets the goal, or until one that does not changes the blend
    more than ``search.most`` (a change that met the goal already): less smoothing only changes
    the blend more (faster); and it ends at a trial that meets the goal with a change of at most
    ``search.enough`` (:data:`ENOUGH`). Default: every trial, measured from ``result``."""
    search = search if search is not None else _Search(_change_from(result))
    most, enough = search.most, search.enough
    goal = SKATE_GOAL * min(q.skating.mean_speed for q in inputs if q.contacts.any)
    skids = max(q.skid_count for q in inputs)
    slid = max(q.slid_m for q in inputs)
    best: tuple[tuple[float, ...], CleanupResult, FootQuality] | None = None
    for factor in STEADIER:
        trial = steadier(plan, factor)
        for smooth in SMOOTHING:
            res = cleanup_footskate(
                result, trial.contacts, PLANT, legs=legs, plants=trial.plants,
                swing_heights=trial.swing_heights, smooth=smooth, ease_swing=ease_swing,
            )  # fmt: skip
            if not res.applied:
                return res, None, ()
            q = foot_quality(res.motion, contact_options)
            key = (
                max(q.skid_count - skids, 0),
                max(q.slid_m - slid, 0.0),
                max(q.skating.mean_speed - goal, 0.0),
                # and no point deeper than SETTLE_BELOW under its own floor (issue 29): a smoothed
                # change may take a foot down where the unsmoothed one kept it out
                max(q.below_floor_m - SETTLE_BELOW, 0.0),
                _clearance_lost(q, inputs),
                search.change(res.motion),
            )
            if best is None or key < best[0]:
                best = (key, res, q)
            if not any(key[:-1]) and key[-1] <= enough:
                return res, q, key  # little enough
            if not any(key[:-1]) or key[-1] > most:
                break  # met, or beaten already: a smoothing less than this changes the blend more
    assert best is not None
    return best[1], best[2], best[0]


def _planted_note(res: CleanupResult, own: Sequence[float]) -> Note:
    text = (
        "clean-up: the contact plan planted by leg IK (feet planted and swinging as the inputs' at "
        f"matched times); skating {res.skating_before.mean_speed:.3g} -> {res.skating_after.mean_speed:.3g} "
        "m/s against the plan (inputs " + ", ".join(f"{x:.3g}" for x in own) + " on their own), "
        f"change smoothed over {res.smooth:g} s; largest change {res.max_position_change:.3g} m, "
        f"{res.max_rotation_change_deg:.3g} deg"
    )
    data = {
        "skating_before_m_s": res.skating_before.mean_speed,
        "skating_after_m_s": res.skating_after.mean_speed,
        "inputs_skating_m_s": list(own),
        "smooth_s": res.smooth,
    }
    return Note(NOTE_CLEANUP, text, data)


def _measured(
    result: Motion, carried: Contacts, own: Sequence[float], notes: list[Note], inputs: Sequence[FootQuality]
) -> BlendContacts:
    """``contacts="report"``: the blend's skating against the carried contacts, nothing changed."""
    skating = contact_skating(result, carried)
    text = (
        "clean-up: not applied (contacts 'report'): the contact plan measured; skating "
        f"{skating.mean_speed:.3g} m/s (inputs " + ", ".join(f"{x:.3g}" for x in own) + "), below the "
        f"floor {skating.below_floor:.3g} m"
    )
    data = {
        "skating_m_s": skating.mean_speed,
        "inputs_skating_m_s": list(own),
        "below_floor_m": skating.below_floor,
    }
    measured = CleanupResult(
        result, carried, skating, skating, 0.0, 0.0, 0.0, (), False, (), smooth=0.0, strength=0.0
    )
    return BlendContacts(measured, (*notes, Note(NOTE_CLEANUP, text, data)), tuple(inputs))


def _skipped(text: str, notes: Sequence[Note] = (), inputs: Sequence[FootQuality] = ()) -> BlendContacts:
    return BlendContacts(None, (*notes, Note(NOTE_CLEANUP, text)), tuple(inputs))
