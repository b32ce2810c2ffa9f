"""The contact-guided warp of a blend of two (``contact_warp``: auto, on or off).

The plain warp of B onto A (no landmarks) aligns the curves as a whole; nothing makes A's heel
strike meet B's, and where exactly one input foot is planted at the matched time the blend of
a planted foot and a swinging one slides along the floor. The contact-guided warp meets the
heel strikes and toe-offs of both feet (:data:`~elastic_motion.vocabulary.GAIT_KINDS`, from the
one contact detector, :func:`elastic_motion.apps.landmarks.contact_events`) paired by phase
around the plain warp (:func:`.warps.contact_guided_warp`), at the price of a larger distance
``||qA - qB * phi||``.

``"on"`` always blends on the guided warp. ``"auto"`` (the default) decides after the plain
warp's blend is built (stages 3 to 9): the blend's skids are counted on the blend exactly as the
inputs' are (:func:`elastic_motion.apps.metrics.floor.foot_quality`, the blend's contact
options); when it has no more than the inputs' larger count nothing else happens (the cost is
that count, which the clean-up and the metrics reuse). Otherwise the blend is built again on the
guided warp and kept when it has **fewer skids** and ``d(A, B)`` under its warp is at most
:data:`DISTANCE_TOLERANCE` times the plain warp's; else the plain blend is kept. A note
(:data:`NOTE_CONTACT_WARP`) gives both skid counts, both slid distances, both distances and
which was kept; ``BlendResult.contact_warp`` the same fields.

The rule applies to a blend of two motions with a time warp solved by the blend (not given,
not a Karcher template), no landmarks given, no matched cycles (which set the landmarks) and
no weight of 1 (the blend is that input).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Any, TypeVar

import numpy as np

from elastic_motion.apps.blend.inputs import BlendInputs
from elastic_motion.apps.blend.warps import Warps, contact_guided_warp
from elastic_motion.apps.blend_options import BlendOptions
from elastic_motion.apps.metrics.floor import FootQuality
from elastic_motion.notes import Note

__all__ = [
    "DISTANCE_TOLERANCE",
    "NOTE_CONTACT_WARP",
    "ContactWarpChoice",
    "contact_warp_applies",
    "guided_or_plain",
]

#: The guided warp is kept only when ``d(A, B)`` under it is at most this times the plain
#: warp's (issue 29: "without raising the distance by more than 2 %").
DISTANCE_TOLERANCE = 1.02
#: The contact-guided warp's decision: skid counts, slid distances, distances, which was kept.
NOTE_CONTACT_WARP = "blend.contact_warp"

Built = TypeVar("Built")


@dataclass(frozen=True)
class ContactWarpChoice:
    """What ``contact_warp="auto"`` decided (module docstring).

    Attributes
    ----------
    kept : {"plain", "guided"}
    inputs_skids : int
        The inputs' larger skid count.
    plain_skids, guided_skids : int or None
        The skids of the blend on each warp (None: not built).
    plain_slid_m, guided_slid_m : float or None
        Their slid distances (m).
    plain_distance, guided_distance : float or None
        ``||qA - qB * phi||`` under each warp (the guided one: with its landmarks met).
    landmark_pairs : int
        Heel strikes and toe-offs the guided warp met (0: none paired, not built).
    reason : str
    """

    kept: str
    inputs_skids: int
    plain_skids: int
    plain_slid_m: float
    plain_distance: float | None
    reason: str
    guided_skids: int | None = None
    guided_slid_m: float | None = None
    guided_distance: float | None = None
    landmark_pairs: int = 0

    def summary(self) -> dict[str, Any]:
        """JSON-ready fields."""
        return {
            "kept": self.kept,
            "inputs_skids": self.inputs_skids,
            "plain": {
                "skids": self.plain_skids,
                "slid_m": self.plain_slid_m,
                "distance": self.plain_distance,
            },
            "guided": None
            if self.guided_skids is None
            else {
                "skids": self.guided_skids,
                "slid_m": self.guided_slid_m,
                "distance": self.guided_distance,
                "landmark_pairs": self.landmark_pairs,
            },
            "reason": self.reason,
        }

    def note(self) -> Note:
        """The decision in words, its fields as data."""
        text = (
            f"contact-guided warp: {self.kept} warp kept ({self.reason}); skids plain {self.plain_skids} "
            f"({self.plain_slid_m:.3g} m slid)"
        )
        if self.guided_skids is not None:
            text += f", guided {self.guided_skids} ({self.guided_slid_m:.3g} m slid)"
        text += f", inputs at most {self.inputs_skids}"
        if self.plain_distance is not None:
            text += f"; distance plain {self.plain_distance:.4g}"
            if self.guided_distance is not None:
                text += (
                    f", guided {self.guided_distance:.4g} "
                    f"({self.guided_distance / self.plain_distance:.3f}x, at most {DISTANCE_TOLERANCE:g}x)"
                )
        return Note(NOTE_CONTACT_WARP, text, self.summary())


def contact_warp_applies(inputs: BlendInputs, options: BlendOptions, given_warps: bool) -> bool:
    """Whether a blend can take the contact-guided warp (module docstring): two motions, a warp
    the blend solves, no landmarks given, no matched cycles, no weight of 1 (the blend is that
    input: no warp changes it), whatever ``contact_warp`` says."""
    return (
        len(inputs.prepared.motions) == 2
        and not np.isclose(inputs.weights, 1.0).any()
        and not given_warps
        and inputs.warp.method != "none"
        and inputs.landmarks is None
        and not options.matches_cycles
    )


def guided_or_plain(
    inputs: BlendInputs,
    plain: Warps,
    built: Built,
    build: Callable[[Warps], Built],
    feet: Callable[[Built], FootQuality],
    inputs_feet: Sequence[FootQuality],
) -> tuple[Warps, Built, ContactWarpChoice]:
    """``contact_warp="auto"`` (module docstring): the plain warp and its blend ``built``, or
    the guided warp and its blend (``build(warps)``), whichever the rule keeps.

    Parameters
    ----------
    inputs : BlendInputs
    plain : Warps
        The warp without landmarks (:func:`.warps.find_warps`).
    built
        The blend built on ``plain`` (stages 3 to 9).
    build : callable
        Builds the blend on other warps.
    feet : callable
        A built blend's feet measured like the inputs'
        (:func:`~elastic_motion.apps.metrics.floor.foot_quality`, or what a stage measured).
    inputs_feet : sequence of FootQuality
        The prepared inputs measured likewise.
    """
    limit = max(q.skid_count for q in inputs_feet)
    mine = feet(built)
    choice = ContactWarpChoice(
        "plain", limit, mine.skid_count, mine.slid_m, plain.distance, "no more skids than the inputs"
    )
    if mine.skid_count <= limit:
        return plain, built, choice
    guided = contact_guided_warp(inputs, plain)
    if not guided.pairs:
        return plain, built, replace(choice, reason="no heel strikes or toe-offs to pair")
    other = build(guided)
    theirs = feet(other)
    choice = replace(
        choice,
        guided_skids=theirs.skid_count,
        guided_slid_m=theirs.slid_m,
        guided_distance=guided.distance,
        landmark_pairs=len(guided.pairs),
    )
    fewer = theirs.skid_count < mine.skid_count
    within = (
        guided.distance is not None
        and plain.distance is not None
        and guided.distance <= DISTANCE_TOLERANCE * plain.distance
    )
    if fewer and within:
        return guided, other, replace(choice, kept="guided", reason="fewer skids, distance within tolerance")
    why = (
        f"the guided warp raises the distance by more than {100 * (DISTANCE_TOLERANCE - 1):g} %"
        if fewer
        else "the guided warp does not lower the skid count"
    )
    return plain, built, replace(choice, reason=why)
