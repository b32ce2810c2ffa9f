"""Stage 7 of a blend (``loop=True``): the blended cycle closed into a seamless loop.

One matched cycle of each input is blended (stages 1-6) and closed by the loop app
(:func:`elastic_motion.apps.loop.loop_motion`, root ``"travel"``, C1: the velocities match at
the seam too, so a game playing it on repeat shows no hitch); then the contacts are planted
on the loop (stage 8), and the small seam gap that leaves (it plants the cycle's first and
last contacts separately) is closed once more (:func:`close_again`); where that closing
pushes a foot more than :data:`LOOP_FLOOR_TOL` into the floor, the feet are lifted out of it
(the floor only, eased) and the loop closed again (at most :data:`LOOP_FLOOR_ROUNDS` times).
The notes give the seam and the skating after each step.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from elastic_motion.apps.cleanup import CleanupResult, cleanup_footskate
from elastic_motion.apps.metrics import contact_skating, seam_metrics
from elastic_motion.apps.prepare import PrepareOptions
from elastic_motion.motion import Motion
from elastic_motion.notes import Note

if TYPE_CHECKING:  # the loop app (scipy.sparse, the closing solvers) is imported by close_loop
    from elastic_motion.apps.cycles import CycleMatch
    from elastic_motion.apps.loop import LoopResult

__all__ = [
    "LOOP_FLOOR_ROUNDS",
    "LOOP_FLOOR_TOL",
    "NOTE_LOOP",
    "BlendLoop",
    "close_again",
    "close_cycle",
    "close_loop",
]

#: A loop's floor after the last closing: lift and close again while a foot is deeper (m).
LOOP_FLOOR_TOL = 0.005
LOOP_FLOOR_ROUNDS = 3
#: The closing of the blended cycle: seam before and after, the hitch left; and the closing
#: again after the clean-up.
NOTE_LOOP = "blend.loop"


@dataclass(frozen=True, eq=False)
class BlendLoop:
    """A closing of the blend into a loop.

    Attributes
    ----------
    loop : LoopResult
        The loop app's result (its ``motion`` is the loop).
    notes : tuple of Note
    """

    loop: LoopResult
    notes: tuple[Note, ...]

    @property
    def motion(self) -> Motion:
        """The closed loop."""
        return self.loop.motion


def close_loop(cycle: Motion) -> LoopResult:
    """The blended cycle closed into a loop: root "travel" and C1, the velocities matched at
    the seam too. C0 left a hitch there, the velocity jump 1.3-2.8 times the blend's own
    quickest changes inside the cycle (DeepMimic walk x run 2.3, CMU 07_01 x 09_11 2.8, Bandai
    normal x tired 1.7), C1 0.8-2.1 (what is left is the root's floor velocity, which travel
    keeps), at the same skating and change."""
    # local: a blend imports the loop app only when it closes a loop (CLI start-up)
    from elastic_motion.apps.loop import LoopOptions, loop_motion

    return loop_motion(
        cycle,
        # the blended cycle is the loop, whatever it changes: its own whole clip, never refused
        LoopOptions(
            prepare=PrepareOptions(drop_tpose=False, fold_static_root=False),
            seam="c1",
            window=None,
            force=True,
        ),
    )


def hitch(loop: LoopResult) -> str:
    """The closed loop's hitch at the seam, for the notes (``SeamMetrics.seam_velocity_jump_ratio``:
    the seam's velocity jump over the cycle's own quick changes; the joints' velocities match
    in a C1 loop, what is left is the root's floor velocity, which a travelling loop keeps)."""
    s = loop.seam_after
    ratio, point = s.seam_velocity_jump_ratio, s.seam_velocity_jump_point
    return f"hitch {ratio:.2f}x the cycle's quickest changes, at {point}"


def close_cycle(blend: Motion, match: CycleMatch | None) -> BlendLoop:
    """Stage 7 (module docstring): close the blended cycle first, then the contacts are
    planted on the loop (the closing spreads the seam's gap over the cycle, and would bring
    the skating back after a clean-up)."""
    loop = close_loop(blend)
    what = "one matched cycle of each" if match is not None and match.n else "the whole clips (no cycles)"
    before, after = loop.seam_before.seam_position_max_m, loop.seam_after.seam_position_max_m
    text = f"loop: {what} blended and closed (seam {before:.3g} m -> {after:.3g} m, {hitch(loop)})"
    return BlendLoop(loop, (Note(NOTE_LOOP, text, {"seam_before_m": before, "seam_after_m": after}),))


def close_again(cleaned: CleanupResult, closed: BlendLoop) -> BlendLoop:
    """The cleaned loop closed once more (the clean-up plants the first and the last contact
    of the cycle separately: close the small gap it leaves at the seam); feet pushed into the
    floor by the closing lifted out and the loop closed again (module docstring)."""
    seam = seam_metrics(cleaned.motion, joints=closed.loop.closed_joints)
    loop = close_loop(cleaned.motion)
    again = contact_skating(loop.motion, cleaned.contacts)
    below = again.below_floor
    rounds = 0
    while again.below_floor > LOOP_FLOOR_TOL and rounds < LOOP_FLOOR_ROUNDS:
        # the closing spreads the seam over the cycle and may push a foot into the floor: lift
        # it out (the floor only, eased) and close again
        rounds += 1
        loop = close_loop(cleanup_footskate(loop.motion, cleaned.contacts, smooth=0.0, strength=0.0).motion)
        again = contact_skating(loop.motion, cleaned.contacts)
    floor_note = ""
    if rounds:
        floor_note = (
            f" (a foot went {below:.3g} m below the floor in the closing: lifted out and "
            f"closed again {rounds} times)"
        )
    text = (
        f"loop: the clean-up left a seam of {seam.seam_position_max_m:.3g} m, "
        f"{seam.seam_angle_max_deg:.3g} deg; closed again: seam "
        f"{loop.seam_after.seam_position_max_m:.3g} m, skating while in contact "
        f"{again.mean_speed:.3g} m/s, below the floor {again.below_floor:.3g} m, {hitch(loop)}" + floor_note
    )
    data = {"rounds": rounds, "seam_after_m": loop.seam_after.seam_position_max_m}
    return BlendLoop(loop, (Note(NOTE_LOOP, text, data),))
