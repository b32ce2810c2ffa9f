"""Stage 8 of a blend: the inputs' foot contacts (``contacts``: keep, report or off).

The inputs' contacts (:func:`elastic_motion.motion.contacts.detect_contacts`) are carried
through the warps to the blend's frames (:func:`elastic_motion.apps.cleanup.carry_contacts`).
``"report"`` measures the blend's skating against them and changes nothing. ``"keep"``
enforces them by leg IK and a smooth root correction (the foot-skate clean-up,
:func:`elastic_motion.apps.cleanup.cleanup_footskate`; bone lengths kept): the whole body
first settles vertically (slowly, within the inputs' root heights), then the change is
smoothed in time by the largest of :data:`SMOOTHING` that leaves the blend skating at most
:data:`SKATE_GOAL` times the lesser input (its own contacts), and then only the least
fraction of the way to the plants that still does so (bisection): the smallest change of the
blend's velocities (what the elastic distance measures) that skates no more than the inputs.
The floor is enforced in full. Skipped, with a note, when the inputs have no contacts or a
weight is 1.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from elastic_motion.apps.blend.inputs import BlendInputs
from elastic_motion.apps.blend.sampling import frame_weight, sample_linear
from elastic_motion.apps.blend.timing import Clock
from elastic_motion.apps.blend.warps import Warps
from elastic_motion.apps.blend_options import BlendOptions
from elastic_motion.apps.cleanup import (
    CleanupOptions,
    CleanupResult,
    carry_contacts,
    cleanup_footskate,
    find_legs,
    settle_offset,
)
from elastic_motion.apps.metrics import contact_skating
from elastic_motion.apps.prepare import PreparedMotions
from elastic_motion.motion import Motion
from elastic_motion.motion.contacts import MISSED_STANCES, Contacts, detect_contacts
from elastic_motion.motion.edit import gaussian_frames
from elastic_motion.notes import Note

__all__ = [
    "NOTE_CLEANUP",
    "SETTLE",
    "SETTLE_MARGIN",
    "SKATE_GOAL",
    "SMOOTHING",
    "STRENGTH_STEPS",
    "BlendContacts",
    "blend_contacts",
    "settle_bounds",
]

#: The clean-up's smoothing of its change (s), tried in this order: the first whose skating is
#: at most SKATE_GOAL times the lesser input's is kept (0: the exact plants); then the least
#: fraction of the way to the plants (``strength``) that still meets the goal. The goal is the
#: inputs' own skating (less 5 %, a margin for the written file and for the skating of the
#: spans that ``cycles`` keeps): the clean-up removes what the blend adds, no more. The old goal
#: of 0.9 with smoothings of at most 0.1 s moved the blends up to 33 % farther from their inputs
#: (benchmarks/blend_quality.py, Bandai normal x tired); now at most 13 %.
SMOOTHING = (0.4, 0.3, 0.2, 0.15, 0.1, 0.07, 0.05, 0.035, 0.025, 0.0)
SKATE_GOAL = 0.95
#: Bisection steps for the fraction of the way to the plants (1/64 resolution).
STRENGTH_STEPS = 6
#: The clean-up first moves the whole blend vertically, as slowly as this (s, Gaussian), so
#: its planted feet stand at their ground heights (``cleanup_footskate(settle=...)``).
SETTLE = 1.0
#: Metres: how far the settle may take the root beyond the inputs' root heights at the
#: matched times (the six pairs of ``benchmarks/blend_quality.py`` settle at most 2 cm
#: beyond them: blended leg angles on a blended skeleton; :func:`settle_bounds`).
SETTLE_MARGIN = 0.03
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
    """

    cleanup: CleanupResult | None
    notes: tuple[Note, ...]

    @property
    def applied(self) -> bool:
        """Whether the blend was changed (its contacts planted)."""
        return self.cleanup is not None and self.cleanup.applied


def settle_bounds(
    result: Motion, prep: PreparedMotions, local_u: Sequence[np.ndarray], wf: np.ndarray
) -> tuple[np.ndarray | None, np.ndarray | None]:
    """Per-frame bounds ``(lower, upper)`` of the clean-up's vertical settle
    (:func:`~elastic_motion.apps.cleanup.settle_offset`): it may take the blend's root no
    lower than the lowest and no higher than the highest root of the inputs that weigh in
    on the frame, at the matched times (``local_u``: each input's curve parameter per output
    frame), give or take :data:`SETTLE_MARGIN`, the inputs' heights smoothed like the settle
    (their step-by-step bob would make it fast); where the root is already outside that
    range, no further out. ``(None, None)`` for weights outside ``[0, 1]`` (extrapolation).

    A planted foot that the blend holds decimetres above the floor while its root is at the
    inputs' height is a leg posed wrong (an Euler blend's hip), not a body floating: settled
    down to it, the body sank 16-30 cm and the other stance knee folded 30-47 deg more than
    in either input (CMU 131_01's crouch blended with 131_02 or 02_01); leg IK plants it.
    """
    if not bool(np.all((wf >= 0.0) & (wf <= 1.0))):
        return None, None
    up = _AXES.index(result.up_axis)
    n = result.n_frames
    heights = np.stack(
        [
            gaussian_frames(
                sample_linear(m.root_translation[:, up], m.fps, lu * m.duration), SETTLE * result.fps
            )
            for m, lu in zip(prep.motions, local_u, strict=True)
        ]
    )  # (K, F)
    weighs = np.stack([np.broadcast_to(frame_weight(wf, k, n, 0), (n,)) > 0 for k in range(len(local_u))])
    root = result.root_translation[:, up]
    lo = np.where(weighs, heights, np.inf).min(axis=0) - SETTLE_MARGIN - root
    hi = np.where(weighs, heights, -np.inf).max(axis=0) + SETTLE_MARGIN - root
    return np.minimum(lo, 0.0), np.maximum(hi, 0.0)


def blend_contacts(
    result: Motion, inputs: BlendInputs, warps: Warps, clock: Clock, options: BlendOptions
) -> BlendContacts:
    """Stage 8 (module docstring): carry the inputs' contacts to the blend and plant them
    (``"keep"``) or measure the blend's skating against them (``"report"``)."""
    if options.contacts == "off":
        return BlendContacts(None, ())
    w, prep = clock.weights, inputs.prepared
    if w.ndim == 1 and np.isclose(w, 1.0).any():
        return _skipped("clean-up: skipped, the result is one of the inputs (a weight of 1)")
    found = [detect_contacts(m, options.contact_options) for m in prep.motions]
    notes = [
        Note(NOTE_CLEANUP, f"clean-up: contacts of {label}: {n}")
        for label, c in zip(prep.labels, found, strict=True)
        for n in c.notes
        if n.kind == MISSED_STANCES
    ]
    if not any(c.any for c in found):
        return _skipped("clean-up: skipped, no contacts found in the inputs", notes)
    carried = carry_contacts(
        found,
        warps.vertices,
        clock.u,
        [m.duration for m in prep.motions],
        w,
        fps=result.fps,
        joints=result.skeleton.names,
        options=options.contact_options,
    )
    own = [contact_skating(m, c).mean_speed for m, c in zip(prep.motions, found, strict=True) if c.any]
    if options.contacts == "report":
        return _measured(result, carried, own, notes)
    lower, upper = settle_bounds(result, prep, clock.local_u, w)
    res, leg_notes = plant_least(result, carried, SKATE_GOAL * min(own), lower, upper)
    if res.applied:
        notes.append(_planted_note(res, own))
    else:
        notes += [Note(NOTE_CLEANUP, f"clean-up: {n}") for n in (*leg_notes, *res.notes)]
    return BlendContacts(res, tuple(notes))


def plant_least(
    result: Motion, carried: Contacts, goal: float, lower: np.ndarray | None, upper: np.ndarray | None
) -> tuple[CleanupResult, list[str]]:
    """The smoothest change (least change of velocities) that skates at most ``goal`` (m/s)
    against ``carried``: the largest smoothing of :data:`SMOOTHING` that meets it, then the
    least fraction of the way to the plants (bisection, :data:`STRENGTH_STEPS`); the body
    settled vertically first within ``lower`` and ``upper`` (:func:`settle_bounds`). Returns
    the clean-up and the notes on legs that could not be used."""
    legs, leg_notes = find_legs(result)  # once, for every trial below
    lift = settle_offset(result, carried, legs, sigma=SETTLE, lower=lower, upper=upper)  # for every trial
    base = CleanupOptions(settle=lift)
    for smooth in SMOOTHING:
        res = cleanup_footskate(result, carried, base, legs=legs, smooth=smooth)
        if not res.applied or res.skating_after.mean_speed <= goal:
            break
    if res.applied and res.skating_after.mean_speed < goal:
        # then the least fraction of that change that still meets the goal (bisection)
        lo, hi = 0.0, 1.0
        for _ in range(STRENGTH_STEPS):
            mid = 0.5 * (lo + hi)
            trial = cleanup_footskate(result, carried, base, legs=legs, smooth=res.smooth, strength=mid)
            if trial.skating_after.mean_speed <= goal:
                hi, res = mid, trial
            else:
                lo = mid
    return res, leg_notes


def _planted_note(res: CleanupResult, own: Sequence[float]) -> Note:
    text = (
        "clean-up: contacts carried through the warps and enforced by leg IK; skating "
        f"{res.skating_before.mean_speed:.3g} -> {res.skating_after.mean_speed:.3g} m/s (inputs "
        + ", ".join(f"{x:.3g}" for x in own)
        + f"), body settled vertically by up to {res.settle_offset:+.3g} m, "
        f"change smoothed over {res.smooth:g} s, {100 * res.strength:.0f} % of it kept; "
        f"largest change {res.max_position_change:.3g} m, {res.max_rotation_change_deg:.3g} deg"
    )
    data = {
        "skating_before_m_s": res.skating_before.mean_speed,
        "skating_after_m_s": res.skating_after.mean_speed,
        "inputs_skating_m_s": list(own),
    }
    return Note(NOTE_CLEANUP, text, data)


def _measured(result: Motion, carried: Contacts, own: Sequence[float], notes: list[Note]) -> BlendContacts:
    """``contacts="report"``: the blend's skating against the carried contacts, nothing changed."""
    skating = contact_skating(result, carried)
    text = (
        "clean-up: not applied (contacts 'report'): contacts carried through the warps; skating "
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
    return BlendContacts(measured, (*notes, Note(NOTE_CLEANUP, text, data)))


def _skipped(text: str, notes: Sequence[Note] = ()) -> BlendContacts:
    return BlendContacts(None, (*notes, Note(NOTE_CLEANUP, text)))
