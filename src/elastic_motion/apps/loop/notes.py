"""The policy notes of a loop: what it did and what a user should know, as :class:`Note`.

Each note has a kind (constants below) for code and a text for people
(:mod:`elastic_motion.notes`); :func:`policy_notes` lists them in the order a report gives
them: the contacts found, the joint limits, what became of the kept contacts, a whipping
limb, a skating warning, a hitch at the seam. The preparation's notes come first
(:func:`prepare_notes`); the seam stage adds its own (:mod:`elastic_motion.apps.loop.seam_choice`).

Units: speeds in m/s (metres when the motion's unit is known), angles in degrees.
"""

from __future__ import annotations

import numpy as np

from elastic_motion.apps.loop.close import ClosedClip
from elastic_motion.apps.loop.kept_contacts import KeptContacts
from elastic_motion.apps.loop.measure import LoopMeasures
from elastic_motion.apps.loop.options import LoopOptions
from elastic_motion.apps.metrics import ContactSkating, SeamMetrics
from elastic_motion.apps.prepare import PreparedMotions
from elastic_motion.motion import Motion, forward_kinematics
from elastic_motion.motion.contacts import MISSED_STANCES, Contacts
from elastic_motion.notes import Note

__all__ = [
    "HITCH_RATIO",
    "SKATING_WARN_RATIO",
    "WHIP_RATIO",
    "hitch_note",
    "policy_notes",
    "prepare_notes",
]

#: A loop that skates more than this many times as fast as its input while in contact gets a
#: ``warning:`` note saying why (:func:`skating_warning`).
SKATING_WARN_RATIO = 1.5
#: A C0 loop whose seam's velocity jump is more than this many times a point's quickest
#: changes inside the clip (:attr:`SeamMetrics.seam_velocity_jump_ratio`) has a hitch.
HITCH_RATIO = 1.5
#: A loop whose fastest point moves more than this many times as fast as anything in the
#: input says where (a closing that put its change into a few frames whips a limb there).
WHIP_RATIO = 1.5

#: Kinds of the notes (``Note.kind``).
CONTACTS_SKIPPED = "loop.contacts_skipped"  # no joint that can touch the floor
NO_CONTACTS = "loop.no_contacts"  # no joint planted in the clip
TREADMILL = "loop.contacts_treadmill"  # in place, contacts kept on a treadmill
POLISHED = "loop.contacts_polished"  # the stalled solve closed exactly from where it stopped
DROPPED = "loop.contacts_dropped"  # contacts and closure did not fit: closed without them
RELEASED = "loop.contact_released"  # one contact released to close the loop
LIFTED_EARLY = "loop.contact_lifted_early"  # planted on the last frame, in the air on the first
GAVE_WAY = "loop.contact_gave_way"  # a kept contact the loop misses by more than 1 mm
WHIP = "loop.whip"  # the loop's fastest point much faster than the input's
SKATING_WARNING = "loop.skating_warning"  # the loop skates much more than the input
HITCH = "loop.hitch"  # the seam's velocity jump above HITCH_RATIO

#: How the note on a seam's hitch starts.
_HITCH_TEXT = "a hitch at the seam"


def prepare_notes(prepared: PreparedMotions) -> tuple[Note, ...]:
    """The preparation step's notes (their kinds are :mod:`elastic_motion.apps.prepare`'s)."""
    return tuple(prepared.notes)


def policy_notes(
    clip: Motion,
    closed: ClosedClip,
    measures: LoopMeasures,
    limits: list[Note],
    options: LoopOptions,
    *,
    whole: bool,
) -> list[Note]:
    """The notes of one loop (module docstring), in order.

    Parameters
    ----------
    clip : Motion
        The looped frames of the prepared input.
    closed : ClosedClip
        Their loop.
    measures : LoopMeasures
    limits : list of Note
        The notes on joint limits (:mod:`elastic_motion.apps.loop.limits`).
    options : LoopOptions
    whole : bool
        The whole clip was looped (no window): the notes suggest the auto window.
    """
    notes = contact_notes(measures.contacts) + limits
    if closed.kept is not None:
        notes += kept_notes(closed.kept, clip.duration, c1=options.is_c1)
    whip = whip_note(clip, closed.motion, whole=whole, seam=measures.seam_before)
    if whip is not None:
        notes.append(whip)
    if measures.skating_before is not None:
        after = measures.skating_on_treadmill or measures.skating_after
        warn = skating_warning(
            measures.skating_before, after, closed.kept, options, measures.seam_before, whole=whole
        )
        if warn is not None:
            notes.append(warn)
    if not options.is_c1 and measures.seam_after.seam_velocity_jump_ratio > HITCH_RATIO:
        hitch = hitch_note(measures.seam_after)
        notes.append(hitch.with_text(f"{hitch}; c1=True / --seam c1 matches the velocities at the seam too"))
    return notes


def contact_notes(found: Contacts | None) -> list[Note]:
    """What contact detection found worth saying (None: not detected, ``contacts="off"``): no
    candidate joint, no contact, and the stances it did not count
    (:data:`~elastic_motion.motion.contacts.MISSED_STANCES`)."""
    if found is None:
        return []
    notes = []
    if not found.joints:
        notes.append(
            Note(CONTACTS_SKIPPED, "contacts skipped: no joint that can touch the floor (feet, toes, hands)")
        )
    elif not found.any:
        notes.append(Note(NO_CONTACTS, "contacts: no joint is planted in this clip"))
    notes += [Note(MISSED_STANCES, f"contacts: {n}", n.data) for n in found.notes if n.kind == MISSED_STANCES]
    return notes


def kept_notes(kept: KeptContacts, duration: float, *, c1: bool) -> list[Note]:
    """What became of the kept contacts: a treadmill, a polish, dropped, released, lifted
    early, gave way (``duration``: the clip's, seconds)."""
    notes = []
    if kept.treadmill and kept.dropped is None:
        t = kept.treadmill
        notes.append(
            Note(
                TREADMILL,
                f"contacts kept on a treadmill: in place, the clip's travel ({t['travel_m']:.3g} m, "
                f"turn {t['turn_deg']:.3g} deg) is removed at a constant rate before closing, so planted "
                f"feet move back with it at {t['travel_m'] / duration:.3g} m/s (the skating in the "
                "world; 'on the treadmill' takes the belt out; "
                "'changed the clip' counts the travel removed) instead of the body jumping back between "
                "two frames",
                t,
            )
        )
    if kept.polished:
        notes.append(Note(POLISHED, f"contacts: {kept.polished}"))
    if kept.dropped is not None:
        notes.append(Note(DROPPED, kept.dropped))
    for g in kept.released:
        miss = f", missed by {g['largest_miss_m']:.4f} m" if g["largest_miss_m"] is not None else ""
        text = (
            f"contact released (it conflicts with closing the loop): {g['joint']} frames "
            f"{g['frames'][0]}..{g['frames'][1] - 1} ({g['why']}{miss})"
        )
        notes.append(Note(RELEASED, text, g))
    held = "free" if c1 else "kept in the floor plane only"
    for g in kept.lifted_early:
        text = (
            f"contact lifted early (planted on the last frame, in the air on the first): {g['joint']} "
            f"{held} from frame {g['frames'][0]}, rising to the first frame's pose"
        )
        notes.append(Note(LIFTED_EARLY, text, g))
    for g in kept.gave_way:
        text = (
            f"contact gave way: {g['joint']} frames {g['frames'][0]}..{g['frames'][1] - 1} missed by "
            f"{g['largest_miss_m']:.4f} m"
        )
        notes.append(Note(GAVE_WAY, text, g))
    return notes


def hitch_note(seam: SeamMetrics) -> Note:
    """What a seam's hitch is (:attr:`SeamMetrics.seam_velocity_jump_ratio`), kind :data:`HITCH`."""
    text = (
        f"{_HITCH_TEXT}: velocities jump by up to {seam.seam_velocity_max_m_s:.3g} m/s; at "
        f"{seam.seam_velocity_jump_point} {seam.seam_velocity_jump_ratio:.1f}x its quickest changes inside "
        "the clip (99th percentile)"
    )
    data = {
        "ratio": seam.seam_velocity_jump_ratio,
        "point": seam.seam_velocity_jump_point,
        "velocity_max_m_s": seam.seam_velocity_max_m_s,
    }
    return Note(HITCH, text, data)


def skating_warning(
    before: ContactSkating,
    after: ContactSkating,
    kept: KeptContacts | None,
    options: LoopOptions,
    seam: SeamMetrics,
    *,
    whole: bool,
) -> Note | None:
    """A ``warning:`` note when the loop skates more than :data:`SKATING_WARN_RATIO` times
    the input while in contact (both measured on the input's contacts), with why: contacts
    released or dropped to close it, or not kept at all.

    A clip that does not repeat gets its change where the contacts give way: a DeepMimic
    get-up from the floor, auto window, released its final stance to close on the lying
    pose and its ankles skated 1.0-1.2 m/s against the input's 0.05-0.08; the numbers and
    the notes said so, nothing said it was wrong."""
    if before.mean_speed <= 0 or after.mean_speed <= SKATING_WARN_RATIO * before.mean_speed:
        return None
    worst = max(after.per_joint, key=lambda n: after.per_joint[n] - before.per_joint.get(n, 0.0))
    why = ""
    contacts = options.contact_mode
    if kept is not None and kept.dropped is not None:
        why = "; the contacts could not be kept (see the note on them)"
    elif kept is not None and kept.released:
        names = sorted({g["joint"] for g in kept.released})
        why = f"; contacts released to close it: {names}"
    elif contacts != "keep":
        why = (
            f"; contacts not kept (contacts={contacts!r}; contacts='keep' / --contacts keep, with the "
            "Lie method and the KKT solver, plants them)"
        )
    text = (
        f"warning: the loop skates {after.mean_speed / before.mean_speed:.1f}x as fast as the input while "
        f"in contact ({after.mean_speed:.3g} against {before.mean_speed:.3g} m/s; most added: {worst}, "
        f"{after.per_joint[worst]:.3g} against {before.per_joint.get(worst, 0.0):.3g}){why}"
        f"{_far_from_repeating(seam, whole)}"
    )
    return Note(SKATING_WARNING, text, {"ratio": after.mean_speed / before.mean_speed, "joint": worst})


def _far_from_repeating(seam: SeamMetrics, whole: bool) -> str:
    """The end of the skating warning when the clip ends far from the pose it starts in."""
    if not (seam.seam_angle_max_deg > 20.0 or seam.seam_position_max_m > 0.2):
        return ""
    where = (
        f"; the clip ends {seam.seam_angle_max_deg:.0f} deg and {seam.seam_position_max_m:.2f} m from "
        "the pose it starts in"
    )
    if whole:
        where += ": window='auto' / --window auto loops the sub-clip that closes with the least change"
    return where


def whip_note(motion: Motion, out: Motion, *, whole: bool, seam: SeamMetrics) -> Note | None:
    """A note when the loop ``out``'s fastest point (joint or end site, FK) moves more than
    :data:`WHIP_RATIO` times as fast as the input ``motion``'s fastest: where and how fast.

    A clip that does not end in the pose it starts in, closed whole, gets its change where
    the contacts leave room: the Bandai tired walk's right toe, lifting off in the last
    frames, went 9.3 m/s (the input's fastest point 3.8), which only a sub-clip fixes.
    """
    if out.n_frames < 2:
        return None
    fast, base = _point_speeds(out), _point_speeds(motion)
    top = float(base.max(initial=0.0))
    if top <= 0 or fast.max() <= WHIP_RATIO * top:
        return None
    f, j = np.unravel_index(int(fast.argmax()), fast.shape)
    sk = out.skeleton
    names = [*sk.names, *(f"{sk.names[p]} end site" for p in sk.end_site_parents)]
    text = (
        f"fast point: {names[j]} moves {fast.max():.3g} m/s at frames {f}-{f + 1} of the loop, "
        f"{fast.max() / top:.1f}x the input's fastest point ({top:.3g} m/s): the closing put its change there"
    )
    if whole:
        text += (
            f" (the clip ends {seam.seam_angle_max_deg:.0f} deg and {seam.seam_position_max_m:.2f} m from "
            "the pose it starts in; window='auto' / --window auto loops the sub-clip that closes with the "
            "least change)"
        )
    data = {
        "point": names[j],
        "speed_m_s": float(fast.max()),
        "frame": int(f),
        "ratio": float(fast.max() / top),
    }
    return Note(WHIP, text, data)


def _point_speeds(m: Motion) -> np.ndarray:
    """Speeds ``(F - 1, J + E)`` of the joints and end sites between frames, m/s."""
    p = forward_kinematics(m, end_sites=True)
    unit = m.metres_per_unit if m.metres_per_unit is not None else 1.0
    return np.linalg.norm(np.diff(p, axis=0), axis=-1) * m.fps * unit
