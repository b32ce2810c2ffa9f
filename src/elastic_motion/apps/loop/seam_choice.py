"""The seam stage of ``seam="auto"``: the C0 loop, or the same window closed C1 when the C0
seam hitches and C1 is better by every measure an animator judges.

:func:`elastic_motion.apps.loop.loop_motion` closes C0 first; when its seam has a hitch
(:func:`hitches`: the velocity jump more than
:data:`~elastic_motion.apps.loop.notes.HITCH_RATIO` times the clip's own quick changes) it
closes the same window C1 too (:func:`c1_options`) and :func:`choose_seam` takes the C1 loop
when it converged, is smoother, skates at most 1.1 times as fast, changes the clip at most
1.5 times as much (mean, + 5 mm) and whips no limb the C0 loop did not (read off the notes'
kinds). A note says which seam was taken and why. DeepMimic cartwheel, auto window: hitch
3.55 -> 0.73; whole CMU 09_11 stays C0 (C1 whips a toe at 91 m/s).
"""

from __future__ import annotations

import dataclasses

from elastic_motion.apps.loop.notes import HITCH, HITCH_RATIO, WHIP, hitch_note
from elastic_motion.apps.loop.options import LoopOptions
from elastic_motion.apps.loop.result import LoopResult
from elastic_motion.notes import Note, first_of_kind

__all__ = ["SEAM_C0_KEPT", "SEAM_C1_TAKEN", "c1_options", "choose_seam", "hitches"]

#: Kinds of the seam stage's notes: C1 closed too and taken; C1 closed too and not taken (the
#: text starts with the C0 seam's hitch, and says why).
SEAM_C1_TAKEN = "loop.seam_c1"
SEAM_C0_KEPT = "loop.seam_c0_kept"


def hitches(result: LoopResult) -> bool:
    """Whether a loop's seam has a hitch (its velocity jump above ``HITCH_RATIO`` times the
    clip's own quick changes)."""
    return result.seam_after.seam_velocity_jump_ratio > HITCH_RATIO


def c1_options(c0: LoopResult, options: LoopOptions) -> LoopOptions:
    """The options of the C1 closing compared with the C0 loop ``c0``: the same window."""
    window = None if c0.window is None else (c0.window.start, c0.window.stop)
    return options.replace(seam="c1", window=window, min_length=None)


def choose_seam(c0: LoopResult, c1: LoopResult) -> LoopResult:
    """The C1 loop when it is better than the hitching C0 loop by every measure (module
    docstring), else the C0 loop; with a note saying which and why."""
    s0, s1 = c0.seam_after, c1.seam_after
    why = _worse(c0, c1)
    hitch = hitch_note(s0)
    d0, d1 = s0.deviation_mean_m or 0.0, s1.deviation_mean_m or 0.0
    if why:
        notes = tuple(n for n in c0.notes if n.kind != HITCH)
        text = f"{hitch}; closed C1 too (c1='auto') and not taken: " + "; ".join(why)
        note = Note(SEAM_C0_KEPT, text, {**hitch.data, "c1_refused": why})
        return dataclasses.replace(c0, notes=(*notes, note))
    text = (
        f"seam C1 (c1='auto'): closed C0, {hitch}; closed C1, the joints' velocities match at the "
        f"seam too (hitch {s1.seam_velocity_jump_ratio:.2f}x; mean change {d1:.3g} m against {d0:.3g})"
    )
    note = Note(SEAM_C1_TAKEN, text, {"c0": hitch.data, "c1_ratio": s1.seam_velocity_jump_ratio})
    window = c1.window
    if c0.window is not None:  # how the window was chosen, with the C1 loop's numbers
        window = dataclasses.replace(
            c0.window, deviation_max_m=s1.deviation_max_m, deviation_mean_m=s1.deviation_mean_m,
            change=c1.closing.change,
        )  # fmt: skip
    return dataclasses.replace(c1, notes=(*c1.notes, note), window=window)


def _worse(c0: LoopResult, c1: LoopResult) -> list[str]:
    """Why the C1 loop is not taken (empty: it is better by every measure)."""
    s0, s1 = c0.seam_after, c1.seam_after
    why = []
    if not c1.closing.converged:
        why.append(f"it did not converge ({c1.closing.message})")
    if s1.seam_velocity_jump_ratio >= s0.seam_velocity_jump_ratio:
        why.append(f"its seam is no smoother ({s1.seam_velocity_jump_ratio:.2f}x)")
    if c0.skating_after is not None and c1.skating_after is not None:
        k0, k1 = c0.skating_after.mean_speed, c1.skating_after.mean_speed
        if k1 > 1.1 * k0 + 1e-9:
            faster = f"{k1 / k0:.2f}x as fast" if k0 > 0 else "where the C0 loop does not"
            why.append(f"it skates {faster} ({k1:.3g} against {k0:.3g} m/s)")
    d0, d1 = s0.deviation_mean_m or 0.0, s1.deviation_mean_m or 0.0
    if d1 > 1.5 * d0 + 0.005:
        why.append(f"it changes the clip more (mean {d1:.3g} against {d0:.3g} m)")
    whip0, whip1 = first_of_kind(c0.notes, WHIP), first_of_kind(c1.notes, WHIP)
    if whip1 is not None and whip0 is None:
        why.append(f"it whips a limb ({whip1})")
    return why
