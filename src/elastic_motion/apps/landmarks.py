"""Automatic events of a motion and their pairing into landmarks for the warp.

Paper 001 (sec. 4.2) guides the time warp between two walks with feature points: "the
first three times when the left knee moves forward and past the right knee". This module
finds such events on a :class:`~elastic_motion.motion.Motion` and pairs the events of two
motions in order, giving the landmark pairs ``(time in A, time in B)`` that
:func:`elastic_motion.apps.blend.blend_motions` and
:func:`elastic_motion.apps.align.align_motions` turn into the warp's feature term.

Event kinds
-----------
``"left_knee_passes"`` / ``"right_knee_passes"``
    The left (right) knee moves forward past the other knee: the signed distance
    ``d(t) = <p_left_knee - p_right_knee, forward(t)>`` crosses 0 upwards (downwards).
    ``forward(t)`` is the horizontal direction the pelvis faces, ``lateral x up`` with
    ``lateral`` the vector from the right hip joint to the left one projected on the floor
    (a character facing +z in a Y-up right-handed frame has its left at +x). A crossing
    counts once ``d`` has gone from below ``-eps`` to above ``+eps`` (hysteresis,
    ``eps = 2 %`` of the leg length), so jitter around 0 makes one event, not many; the
    event time is the zero crossing, linearly interpolated between frames.
``"left_heel_strike"`` / ``"right_heel_strike"`` / ``"left_toe_off"`` / ``"right_toe_off"``
    From the contacts of :func:`elastic_motion.motion.contacts.detect_contacts` (the one
    home of contacts): a heel strike is the start of a contact of the ankle joint, a toe-off
    the end of a contact of the toe joint (of the ankle when the skeleton has no toe joint).
    Contacts cut by the clip's ends are no events.
``"left_foot_contact"`` / ``"right_foot_contact"``
    A foot touches down: the ankle or toe joint of that side comes within ``contact_height``
    (default 5 cm) of its lowest height in the clip while moving horizontally slower than
    ``contact_speed`` (default 0.5 m/s). The event is the first frame of a contact that
    lasts at least 0.06 s after at least 0.06 s off the floor (a contact already under way
    at frame 0 is not an event: its onset is not seen).

Pairing by phase (:func:`pair_by_phase`, what ``landmarks="auto"`` does)
------------------------------------------------------------------------
Events are never paired blindly in order (A's first left step would meet B's second when the
clips start in different phases). Instead, a **prior warp** (the optimal warp without
landmarks) predicts, for each event of A at ``tA``, the time ``d_B phi(tA / d_A)`` where B
should have the same event. For each kind separately, a dynamic programme over the two
event sequences picks the increasing matching that maximises
``sum (1 - (offset / tol)^2)`` over the pairs (offset: the B event's time minus the
prediction; ``tol`` = 0.15 of the kind's median period, a sixth of a gait cycle, 0.4 s
when unknown: landmarks refine a warp that is about right, they do not overrule it),
skipping events freely and never pairing events more than ``tol`` apart. The pairs of all
kinds are then merged best first, keeping those that stay increasing in both clips.

Timing uncertainty: landmarks as windows
----------------------------------------
An event time is only known to within its detector's resolution, its ``uncertainty`` (the
half-width of the interval it lies in, seconds): a contact starts or ends between two
frames, so heel strikes, toe-offs and foot contacts are known to half a frame
(``0.5 / fps``; the event is the frame where the contact flag flips, a lag common to both
clips that cancels in the offset when they share a frame rate); a knee crossing is the
zero of ``d`` interpolated linearly between two frames, known to the interpolation error
``max|d''| / (8 |d'|)`` frames (at most one frame). A pair ``(tA, tB)`` therefore only asks
the warp to pass within the window ``|phi(tA) - tB| <= w`` with
``w = (P(tA + uA) - P(tA - uA)) / 2 + uB`` (``P`` the prior in seconds: A's uncertainty
carried into B by the prior's local slope). Pinning the detected times exactly (the old
rule) enforced the detectors' frame quantisation as if it were the motion: on the CMU
obstacle walks (30 fps) moving one pinned strike by half a frame changed the blend's foot
sliding by up to 13 %, and jittering all events within their half frame spread it by
+-5 % (``docs/applications.md``). So, with the same prior:

* a pair whose prior prediction already lies in the window (``|offset| <= w``, ``w > 0``)
  is **dropped**: the warp without landmarks meets it as well as the events can tell, and
  a hard landmark there would only add the events' jitter (events without an uncertainty,
  ``w = 0``, are pinned where they are, as before);
* a pair outside its window is **kept and moved to the window's edge nearest the prior**:
  its B time becomes ``tB - sign(offset) * w``. This is where the least-energy warp that
  respects the window touches it (the constraint binds, and the warp moves no further
  than the evidence requires); a kept pair that would then no longer increase in both
  clips is dropped too.

Each kept pair records why (its offset from the prior, its window, where it is pinned),
each dropped pair why (its offset is within the window) and each event left out why (no
B event near the prediction, or a conflict with a better pair).

Joints are found by name (:func:`find_leg_joints`): the side from a ``left``/``right``/``l``/
``r`` prefix or an ``_l``/``_r`` suffix, the part from the rest (``UpLeg``/``femur``/``hip``/
``thigh``; ``Leg``/``knee``/``tibia``/``LowerLeg``/``shin``; ``Foot``/``ankle``; ``Toe``/
``toes``/``ToeBase``). This covers the CMU BVH and ASF files, DeepMimic, Bandai and Mixamo
names. Times are seconds from the motion's first frame; lengths in metres when the motion's
unit is known.
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from elastic_motion.motion import Motion, Skeleton, forward_kinematics
from elastic_motion.motion.contacts import ContactOptions, close_gaps, detect_contacts, mask_runs
from elastic_motion.vocabulary import DEFAULT_PAIR_KINDS, EVENT_KINDS, GAIT_KINDS

__all__ = [
    "DEFAULT_PAIR_KINDS",
    "EVENT_KINDS",
    "GAIT_KINDS",
    "Event",
    "LegJoints",
    "PhasePairing",
    "contact_events",
    "detect_events",
    "find_leg_joints",
    "pair_by_phase",
    "pair_events",
    "phase_landmarks",
]

# The event kinds: EVENT_KINDS (those detect_events knows), GAIT_KINDS (those from the
# contacts, contact_events) and DEFAULT_PAIR_KINDS (the default of landmarks="auto": foot
# strikes and toe-offs of both feet and the paper's knee crossings, paper 001, sec. 4.2), from
# elastic_motion.vocabulary.

_AXES = "xyz"
_PARTS = {
    "hip": ("upleg", "upperleg", "uleg", "hip", "femur", "thigh"),
    "knee": ("leg", "knee", "tibia", "lowerleg", "lowleg", "loleg", "shin", "calf"),
    "ankle": ("foot", "ankle"),
    "toe": ("toe", "toes", "toebase", "ball", "toeend"),
}
_PART_OF = {base: part for part, bases in _PARTS.items() for base in bases}
_PREFIXES = (("left", "left"), ("right", "right"), ("l", "left"), ("r", "right"))
_SUFFIXES = (("left", "left"), ("right", "right"), ("l", "left"), ("r", "right"))

_MIN_RUN = 0.06  # seconds: shortest contact / shortest gap that counts
_TOL_FRACTION = 0.15  # pairing by phase: largest offset from the prior, fraction of the period
_KNEE_EPS = 0.02  # hysteresis, fraction of the leg length
#: Timing uncertainty of an event from a per-frame contact flag, frames: the flag flips
#: between two frames (module docstring, "Timing uncertainty").
_CONTACT_UNCERTAINTY = 0.5


@dataclass(frozen=True)
class Event:
    """One detected event.

    Attributes
    ----------
    kind : str
        One of :data:`EVENT_KINDS`.
    time : float
        Seconds from the first frame (interpolated between frames for knee crossings).
    frame : int
        The frame nearest ``time``.
    uncertainty : float
        Seconds, half-width of the interval the event lies in as far as its detector can
        tell (module docstring, "Timing uncertainty"): half a frame for contact events,
        the linear-interpolation error for knee crossings; 0 when unknown (given times).
    """

    kind: str
    time: float
    frame: int
    uncertainty: float = 0.0


@dataclass(frozen=True)
class LegJoints:
    """Joint names of the legs (``None`` where the skeleton has no such joint).

    Attributes
    ----------
    left_hip, left_knee, left_ankle, left_toe, right_hip, right_knee, right_ankle, right_toe
        Names of the joints *located* at the hip, knee, ankle and toe (in BVH terms: the
        joint whose offset ends there, e.g. CMU ``LeftUpLeg``, ``LeftLeg``, ``LeftFoot``,
        ``LeftToeBase``).
    """

    left_hip: str | None
    left_knee: str | None
    left_ankle: str | None
    left_toe: str | None
    right_hip: str | None
    right_knee: str | None
    right_ankle: str | None
    right_toe: str | None

    def side(self, side: str) -> dict[str, str | None]:
        """``{"hip": ..., "knee": ..., "ankle": ..., "toe": ...}`` of ``"left"`` or ``"right"``."""
        return {part: getattr(self, f"{side}_{part}") for part in ("hip", "knee", "ankle", "toe")}


def _classify(name: str) -> tuple[str, str] | None:
    """``(side, part)`` of a joint name, or None."""
    raw = name.rsplit(":", 1)[-1]  # drop a namespace like "mixamorig:"
    low = raw.lower()
    for pre, side in _PREFIXES:
        if low.startswith(pre):
            base = re.sub(r"[^a-z]", "", low[len(pre) :])
            if base in _PART_OF:
                return side, _PART_OF[base]
    for suf, side in _SUFFIXES:
        if low.endswith(suf):
            base = re.sub(r"[^a-z]", "", low[: len(low) - len(suf)])
            if base in _PART_OF and (len(suf) > 1 or not low[: len(low) - len(suf)][-1:].isalpha()):
                return side, _PART_OF[base]
    return None


def find_leg_joints(skeleton: Skeleton) -> LegJoints:
    """Find the hip, knee, ankle and toe joints of both legs by name.

    Parameters
    ----------
    skeleton : Skeleton

    Returns
    -------
    LegJoints
        The first joint (in skeleton order) of each side and part; ``None`` where no name
        matches.
    """
    found: dict[str, str] = {}
    for name in skeleton.names:
        sp = _classify(name)
        if sp is not None:
            found.setdefault(f"{sp[0]}_{sp[1]}", name)
    return LegJoints(**{f"{s}_{p}": found.get(f"{s}_{p}") for s in ("left", "right") for p in _PARTS})


def _need(legs: LegJoints, fields: Sequence[str], motion: Motion, what: str) -> None:
    missing = [f for f in fields if getattr(legs, f) is None]
    if missing:
        raise ValueError(
            f"{motion.name or 'the motion'}: cannot detect {what}: no joint found for {', '.join(missing)} "
            f"among {list(motion.skeleton.names)} (joints are found by their names, e.g. LeftUpLeg, "
            "LeftLeg, LeftFoot; in Python, legs=LegJoints(...) names them)"
        )


def _scale(motion: Motion) -> float:
    return motion.metres_per_unit if motion.metres_per_unit is not None else 1.0


def _forward(pos: np.ndarray, left_hip: int, right_hip: int, up: int) -> np.ndarray:
    """Unit horizontal facing direction per frame ``(F, 3)`` from the hip joints."""
    lateral = pos[:, left_hip] - pos[:, right_hip]
    lateral[:, up] = 0.0
    e_up = np.zeros(3)
    e_up[up] = 1.0
    fwd = np.cross(lateral, e_up)
    norm = np.linalg.norm(fwd, axis=1, keepdims=True)
    return fwd / np.where(norm > 0, norm, 1.0)


def _crossings(d: np.ndarray, eps: float, upward: bool) -> list[tuple[float, float]]:
    """Zero crossings of ``d`` (up or down) with hysteresis ``eps``: ``(fractional frame,
    uncertainty in frames)``.

    The zero is interpolated linearly between the frames ``k, k + 1`` that bracket it. The
    interpolation misses the value by at most ``max|d''| / 8`` (one frame step, ``d''`` the
    second differences around the bracket), i.e. the time by ``max|d''| / (8 |d'|)``
    frames with ``d' = d[k+1] - d[k]``; capped at one frame (the bracket itself).
    """
    s = d if upward else -d
    n = s.shape[0]
    out: list[tuple[float, float]] = []
    armed = False
    last_neg = -1  # last frame with s < 0
    for f in range(n):
        if s[f] < -eps:
            armed = True
        if s[f] < 0:
            last_neg = f
        elif armed and s[f] > eps and last_neg >= 0:
            k = last_neg  # s[k] < 0 <= s[k+1]: interpolate the zero
            a, b = s[k], s[k + 1]
            second = [abs(s[i + 1] - 2 * s[i] + s[i - 1]) for i in (k, k + 1) if 0 < i < n - 1]
            slope = abs(b - a)
            err = min(1.0, max(second, default=0.0) / (8.0 * slope)) if slope > 0 else 1.0
            out.append((k + (0.0 - a) / (b - a) if b != a else float(k), float(err)))
            armed = False
    return out


def detect_events(
    motion: Motion,
    kinds: Sequence[str] = EVENT_KINDS,
    *,
    legs: LegJoints | None = None,
    contact_height: float = 0.05,
    contact_speed: float = 0.5,
) -> list[Event]:
    """Detect knee crossings and foot contacts.

    Parameters
    ----------
    motion : Motion
        At least 3 frames.
    kinds : sequence of str
        Subset of :data:`EVENT_KINDS`.
    legs : LegJoints, optional
        Default :func:`find_leg_joints`.
    contact_height : float
        Metres (length units if unknown) above the joint's lowest height.
    contact_speed : float
        Metres per second (horizontal).

    Returns
    -------
    list of Event
        Sorted by time.

    Raises
    ------
    ValueError
        Unknown kind; the joints a kind needs are not found (the message lists the names).
    """
    kinds = _checked_kinds(motion, kinds)
    legs = find_leg_joints(motion.skeleton) if legs is None else legs
    up = _AXES.index(motion.up_axis)
    pos = forward_kinematics(motion) * _scale(motion)
    events: list[Event] = []
    if any(k.endswith("knee_passes") for k in kinds):
        events += _knee_events(motion, pos, legs, kinds, up)
    gait = [k for k in kinds if k in GAIT_KINDS]
    if gait:
        events += [e for e in contact_events(motion, legs=legs) if e.kind in gait]
    for side in ("left", "right"):
        if f"{side}_foot_contact" in kinds:
            touch = _touching(motion, pos, legs, side, up, (contact_height, contact_speed))
            events += _foot_contact_events(motion, touch, f"{side}_foot_contact")
    events.sort(key=lambda e: (e.time, e.kind))
    return events


def _checked_kinds(motion: Motion, kinds: Sequence[str]) -> tuple[str, ...]:
    """``kinds`` as a tuple, after checking the motion and the kinds (:func:`detect_events`)."""
    if not isinstance(motion, Motion):
        raise ValueError(f"motion: expected a Motion; got {type(motion).__name__}")
    kinds = tuple(kinds)
    bad = [k for k in kinds if k not in EVENT_KINDS]
    if bad:
        raise ValueError(f"kinds: unknown event kind {bad[0]!r}; expected some of {list(EVENT_KINDS)}")
    if motion.n_frames < 3:
        raise ValueError(f"motion: expected at least 3 frames to detect events; got {motion.n_frames}")
    return kinds


def _event_at(kind: str, frame: float, uncertainty: float, motion: Motion) -> Event:
    """The event of ``kind`` at the fractional ``frame``, ``uncertainty`` in frames."""
    f = int(min(max(round(frame), 0), motion.n_frames - 1))
    return Event(kind, float(frame / motion.fps), f, float(uncertainty) / motion.fps)


def _knee_events(
    motion: Motion, pos: np.ndarray, legs: LegJoints, kinds: tuple[str, ...], up: int
) -> list[Event]:
    """The knee crossings of ``kinds`` (module docstring), from the joint positions ``pos``
    ``(F, J, 3)`` in metres and the index ``up`` of the up axis."""
    sk = motion.skeleton
    _need(legs, ("left_hip", "right_hip", "left_knee", "right_knee"), motion, "knee crossings")
    lh, rh = sk.index(legs.left_hip), sk.index(legs.right_hip)
    lk, rk = sk.index(legs.left_knee), sk.index(legs.right_knee)
    leg = float(np.linalg.norm(pos[0, lk] - pos[0, lh]))
    ank = legs.left_ankle
    if ank is not None:
        leg += float(np.linalg.norm(pos[0, sk.index(ank)] - pos[0, lk]))
    eps = _KNEE_EPS * max(leg, 1e-9)
    fwd = _forward(pos, lh, rh, up)
    d = np.einsum("fi,fi->f", pos[:, lk] - pos[:, rk], fwd)
    events = []
    for kind, upward in (("left_knee_passes", True), ("right_knee_passes", False)):
        if kind in kinds:
            events += [_event_at(kind, f, err, motion) for f, err in _crossings(d, eps, upward=upward)]
    return events


def _touching(
    motion: Motion, pos: np.ndarray, legs: LegJoints, side: str, up: int, thresholds: tuple[float, float]
) -> np.ndarray:
    """Frames ``(F,)`` where the ankle or toe of ``side`` is within ``thresholds[0]`` (metres)
    of its lowest height and slower than ``thresholds[1]`` (metres per second,
    horizontally), gaps shorter than 0.06 s closed."""
    sk = motion.skeleton
    height, speed_max = thresholds
    parts = legs.side(side)
    joints = [sk.index(parts[p]) for p in ("ankle", "toe") if parts[p] is not None]
    if not joints:
        _need(legs, (f"{side}_ankle",), motion, "foot contacts")
    p = pos[:, joints]  # (F, k, 3)
    h = p[..., up]
    low = h < h.min(axis=0) + height
    v = np.diff(p, axis=0)
    v[..., up] = 0.0
    speed = np.linalg.norm(v, axis=-1) * motion.fps
    speed = np.concatenate([speed[:1], speed], axis=0)  # (F, k): speed arriving at each frame
    touch = (low & (speed < speed_max)).any(axis=1)
    return close_gaps(touch, 0, _min_run_frames(motion))


def _min_run_frames(motion: Motion) -> int:
    """The shortest contact or gap that counts (0.06 s), in frames."""
    return max(1, math.ceil(_MIN_RUN * motion.fps))


def _foot_contact_events(motion: Motion, touch: np.ndarray, kind: str) -> list[Event]:
    """The touch-downs of ``kind`` in the contact flags ``touch`` (module docstring): contacts
    of at least 0.06 s after at least 0.06 s off the floor, not already under way at frame 0."""
    n_run = _min_run_frames(motion)
    events = []
    for start, stop in mask_runs(touch):
        if start == 0 or stop - start < n_run:
            continue
        if touch[max(0, start - n_run) : start].any():
            continue
        events.append(_event_at(kind, float(start), _CONTACT_UNCERTAINTY, motion))
    return events


def pair_events(
    events_a: Sequence[Event],
    events_b: Sequence[Event],
    kinds: Sequence[str] = DEFAULT_PAIR_KINDS,
    *,
    max_pairs: int | None = None,
) -> list[tuple[Event, Event]]:
    """Pair the events of two motions in order, kind by kind (the old rule; wrong when the
    clips start in different phases: use :func:`pair_by_phase`).

    The ``k``-th event of a kind in A is paired with the ``k``-th of that kind in B, for
    ``k`` up to the smaller count (and ``max_pairs``). Pairs of different kinds are merged
    by their time in A; a pair that would make the warp decrease (its time in B not after
    the previous pair's, or the same time in A) is dropped, so the result is always a valid
    set of landmarks.

    Parameters
    ----------
    events_a, events_b : sequence of Event
    kinds : sequence of str
        Kinds to pair (default: the paper's ``"left_knee_passes"``).
    max_pairs : int, optional
        At most this many pairs per kind (the paper uses 3).

    Returns
    -------
    list of (Event, Event)
        Increasing in both times.
    """
    pairs: list[tuple[Event, Event]] = []
    for kind in kinds:
        ea = sorted((e for e in events_a if e.kind == kind), key=lambda e: e.time)
        eb = sorted((e for e in events_b if e.kind == kind), key=lambda e: e.time)
        n = min(len(ea), len(eb))
        if max_pairs is not None:
            n = min(n, int(max_pairs))
        pairs.extend(zip(ea[:n], eb[:n], strict=True))
    pairs.sort(key=lambda p: (p[0].time, p[1].time))
    kept: list[tuple[Event, Event]] = []
    for pa, pb in pairs:
        if kept and (pa.time <= kept[-1][0].time or pb.time <= kept[-1][1].time):
            continue
        kept.append((pa, pb))
    return kept


def contact_events(
    motion: Motion, *, legs: LegJoints | None = None, options: ContactOptions | None = None
) -> list[Event]:
    """Heel strikes and toe-offs of both feet from the contacts (module docstring).

    Parameters
    ----------
    motion : Motion
    legs : LegJoints, optional
        Default :func:`find_leg_joints`.
    options : ContactOptions, optional
        Thresholds of :func:`elastic_motion.motion.contacts.detect_contacts`.

    Returns
    -------
    list of Event
        Kinds in :data:`GAIT_KINDS`, sorted by time; empty without contacts.
    """
    legs = find_leg_joints(motion.skeleton) if legs is None else legs
    contacts = detect_contacts(motion, options)
    runs = contacts.all_intervals()
    f = motion.n_frames
    out: list[Event] = []
    for side in ("left", "right"):
        parts = legs.side(side)
        ankle, toe = parts["ankle"], parts["toe"]
        unc = _CONTACT_UNCERTAINTY / motion.fps
        if ankle in runs:
            out += [Event(f"{side}_heel_strike", a / motion.fps, a, unc) for a, _ in runs[ankle] if a > 0]
        lift = toe if toe in runs else ankle if ankle in runs else None
        if lift is not None:
            out += [Event(f"{side}_toe_off", b / motion.fps, b, unc) for _, b in runs[lift] if b < f]
    out.sort(key=lambda e: (e.time, e.kind))
    return out


@dataclass(frozen=True)
class PhasePairing:
    """Events of two motions paired by phase (:func:`pair_by_phase`).

    Attributes
    ----------
    pairs : tuple of (Event, Event)
        The landmarks the warp meets, increasing in both times. The B event of a pair is
        at the time the warp is pinned to: the edge of the pair's window nearest the prior
        (module docstring, "Timing uncertainty"); its detected time is in ``details``.
    details : tuple of dict
        One per pair: ``kind``, ``time_a_s``, ``time_b_s`` (detected), ``predicted_b_s`` (by
        the prior warp), ``offset_s`` (detected minus predicted), ``window_s`` (the
        half-width ``w``), ``target_b_s`` (where the warp is pinned) and ``why``.
    skipped : tuple of dict
        Events left unpaired and pairs dropped, each with ``motion`` ("A" or "B"),
        ``kind``, ``time_s`` and ``why``; a dropped pair (see :attr:`dropped`) also has
        ``dropped: True``, ``time_b_s``, ``predicted_b_s``, ``offset_s`` and ``window_s``.
    tolerance_s : dict of str to float
        Largest offset accepted, per kind.
    """

    pairs: tuple[tuple[Event, Event], ...]
    details: tuple[dict, ...]
    skipped: tuple[dict, ...]
    tolerance_s: dict

    @property
    def times(self) -> list[tuple[float, float]]:
        """The pairs as landmarks ``(tA, tB)`` in seconds (``tB`` the pinned time)."""
        return [(a.time, b.time) for a, b in self.pairs]

    @property
    def dropped(self) -> tuple[dict, ...]:
        """The pairs found but not pinned (within their window, or out of order once
        pinned), with the reason."""
        return tuple(d for d in self.skipped if d.get("dropped"))

    def summary(self) -> dict:
        """JSON-ready: pairs with their reasons, dropped pairs and skipped events, tolerances."""
        return {
            "rule": "paired by phase: the warp without landmarks predicts each event of A in B; "
            "a DP per kind keeps the increasing matching closest to the prediction; a pair "
            "the prediction meets within the events' timing uncertainty is dropped, the "
            "others are pinned at the edge of that window nearest the prediction",
            "pairs": [dict(d) for d in self.details],
            "dropped": [dict(d) for d in self.dropped],
            "skipped": [dict(d) for d in self.skipped if not d.get("dropped")],
            "tolerance_s": dict(self.tolerance_s),
        }


def _kind_tolerance(ta: np.ndarray, tb: np.ndarray) -> float:
    gaps = [np.diff(t) for t in (ta, tb) if t.size >= 2]
    if not gaps:
        return 0.4
    return float(_TOL_FRACTION * np.median(np.concatenate(gaps)))


def _dp_match(pred: np.ndarray, tb: np.ndarray, tol: float) -> list[tuple[int, int]]:
    """Increasing matching of predictions to B times maximising sum(1 - (off/tol)^2)."""
    n, m = pred.shape[0], tb.shape[0]
    score = np.zeros((n + 1, m + 1))
    move = np.zeros((n + 1, m + 1), dtype=np.int8)  # 0: skip A, 1: skip B, 2: match
    for i in range(1, n + 1):
        for j in range(1, m + 1):
            best, how = score[i - 1, j], 0
            if score[i, j - 1] > best:
                best, how = score[i, j - 1], 1
            off = abs(tb[j - 1] - pred[i - 1])
            if off < tol:
                gain = score[i - 1, j - 1] + 1.0 - (off / tol) ** 2
                if gain > best:
                    best, how = gain, 2
            score[i, j], move[i, j] = best, how
    out = []
    i, j = n, m
    while i > 0 and j > 0:
        if move[i, j] == 2:
            out.append((i - 1, j - 1))
            i, j = i - 1, j - 1
        elif move[i, j] == 1:
            j -= 1
        else:
            i -= 1
    return out[::-1]


def pair_by_phase(
    events_a: Sequence[Event],
    events_b: Sequence[Event],
    prior: np.ndarray,
    duration_a: float,
    duration_b: float,
    kinds: Sequence[str] = DEFAULT_PAIR_KINDS,
    *,
    max_pairs: int | None = None,
) -> PhasePairing:
    """Pair the events of two motions by phase (module docstring): match each kind by a DP
    around the prior's predictions, merge the kinds, then drop the pairs the prior meets
    within their timing window and pin the others at the window's edge nearest the prior
    (module docstring, "Timing uncertainty": the events' ``uncertainty`` sets the window).

    Parameters
    ----------
    events_a, events_b : sequence of Event
    prior : ndarray, shape (V, 2)
        Vertices of the warp without landmarks (A's curve parameter -> B's).
    duration_a, duration_b : float
        Seconds.
    kinds : sequence of str
    max_pairs : int, optional
        At most this many pairs per kind (the earliest in A).

    Returns
    -------
    PhasePairing
    """
    prior = np.asarray(prior, dtype=np.float64)

    def predict(t: float) -> float:
        return float(np.interp(t / duration_a, prior[:, 0], prior[:, 1]) * duration_b)

    cands: list[_Candidate] = []
    skipped: list[dict] = []
    tols = {}
    for kind in kinds:
        ea = sorted((e for e in events_a if e.kind == kind and 0 < e.time < duration_a), key=lambda e: e.time)
        eb = sorted((e for e in events_b if e.kind == kind and 0 < e.time < duration_b), key=lambda e: e.time)
        if not ea and not eb:
            continue
        tols[kind] = _match_kind(kind, ea, eb, predict, max_pairs, cands, skipped)
    kept = _merge_kinds(cands, skipped)
    pairs, details = _pin_to_windows(kept, predict, duration_b, skipped)
    return PhasePairing(tuple(pairs), tuple(details), tuple(skipped), tols)


#: A pair found for one kind: (score, event of A, event of B, B time the prior predicts,
#: offset of the B event from the prediction), seconds.
_Candidate = tuple[float, Event, Event, float, float]


def _match_kind(
    kind: str,
    ea: list[Event],
    eb: list[Event],
    predict: Callable[[float], float],
    max_pairs: int | None,
    cands: list[_Candidate],
    skipped: list[dict],
) -> float:
    """Match the events ``ea`` of A to ``eb`` of B (one kind, sorted by time) by the DP around
    the prior's predictions; append the pairs to ``cands`` and the events left out to
    ``skipped``; return the kind's tolerance (seconds)."""
    ta = np.array([e.time for e in ea])
    tb = np.array([e.time for e in eb])
    tol = _kind_tolerance(ta, tb)
    pred = np.array([predict(t) for t in ta])
    match = _dp_match(pred, tb, tol) if ea and eb else []
    if max_pairs is not None:
        match = match[: max(0, int(max_pairs))]
    used_a = {i for i, _ in match}
    used_b = {j for _, j in match}
    for i, j in match:
        off = float(tb[j] - pred[i])
        cands.append((1.0 - (off / tol) ** 2, ea[i], eb[j], float(pred[i]), off))
    for i, e in enumerate(ea):
        if i not in used_a:
            why = (
                f"no {kind} of B within {tol:.2f} s of the prior's {pred[i]:.2f} s"
                if max_pairs is None
                else f"not paired (no B event within {tol:.2f} s of {pred[i]:.2f} s, or beyond max_pairs)"
            )
            skipped.append({"motion": "A", "kind": kind, "time_s": e.time, "why": why})
    for j, e in enumerate(eb):
        if j not in used_b:
            skipped.append(
                {"motion": "B", "kind": kind, "time_s": e.time, "why": f"no {kind} of A predicted near it"}
            )
    return tol


def _merge_kinds(cands: list[_Candidate], skipped: list[dict]) -> list[_Candidate]:
    """The pairs of all kinds merged best first, keeping those that stay increasing in both
    clips (the others go to ``skipped``), sorted by their time in A."""
    cands = sorted(cands, key=lambda c: -c[0])
    kept: list[_Candidate] = []
    for c in cands:
        _, a, b, _pred, _off = c
        if all((a.time - k[1].time) * (b.time - k[2].time) > 0 for k in kept):
            kept.append(c)
        else:
            skipped.append(
                {
                    "motion": "A",
                    "kind": a.kind,
                    "time_s": a.time,
                    "why": f"pair {a.time:.2f}:{b.time:.2f} s crosses a closer pair of another kind",
                }
            )
    kept.sort(key=lambda c: c[1].time)
    return kept


def _pin_to_windows(
    kept: list[_Candidate], predict: Callable[[float], float], duration_b: float, skipped: list[dict]
) -> tuple[list[tuple[Event, Event]], list[dict]]:
    """Drop the pairs the prior meets within their timing window, pin the others at the
    window's edge nearest the prior (module docstring, "Timing uncertainty"); the dropped
    ones go to ``skipped``. Returns the pinned pairs and their details."""
    pairs: list[tuple[Event, Event]] = []
    details: list[dict] = []
    for _, a, b, pred, off in kept:
        # the window: A's uncertainty carried into B by the prior, plus B's own
        w = 0.5 * (predict(a.time + a.uncertainty) - predict(a.time - a.uncertainty)) + b.uncertainty
        info = {"time_b_s": b.time, "predicted_b_s": pred, "offset_s": off, "window_s": w}
        if w > 0.0 and abs(off) <= w:  # (times given without uncertainty are pinned as they are)
            skipped.append(
                {
                    "motion": "A",
                    "kind": a.kind,
                    "time_s": a.time,
                    "dropped": True,
                    **info,
                    "why": f"the warp without landmarks already meets it: offset {off:+.3f} s is "
                    f"within the events' timing uncertainty +-{w:.3f} s (a hard landmark would "
                    "only add the detectors' jitter)",
                }
            )
            continue
        target = b.time - math.copysign(w, off)
        if not (0.0 < target < duration_b) or (pairs and not target > pairs[-1][1].time):
            skipped.append(
                {
                    "motion": "A",
                    "kind": a.kind,
                    "time_s": a.time,
                    "dropped": True,
                    **info,
                    "why": f"pinned at the edge of its window ({target:.3f} s in B) it would leave "
                    "the clip or not follow the previous pair in B",
                }
            )
            continue
        pairs.append((a, dataclasses.replace(b, time=float(target))))
        details.append(
            {
                "kind": a.kind,
                "time_a_s": a.time,
                **info,
                "target_b_s": float(target),
                "why": f"the nearest {a.kind} of B to the prior's prediction ({off:+.3f} s), "
                f"more than its timing uncertainty +-{w:.3f} s: the warp is pinned at "
                f"{target:.3f} s, the edge of that window",
            }
        )
    return pairs, details


def phase_landmarks(
    a: Motion,
    b: Motion,
    kinds: Sequence[str] = DEFAULT_PAIR_KINDS,
    *,
    prior: np.ndarray,
    max_pairs: int | None = None,
) -> PhasePairing:
    """Detect ``kinds`` on both motions and pair them by phase (:func:`pair_by_phase`).

    Parameters
    ----------
    a, b : Motion
        Prepared (metres, Y-up; times from the first frame).
    kinds : sequence of str
    prior : ndarray, shape (V, 2)
        The warp without landmarks (A's curve parameter -> B's): the one ``blend`` and
        ``align`` find (:func:`elastic_motion.apps.landmark_detection.prior_warp` computes it
        for two motions).
    max_pairs : int, optional

    Returns
    -------
    PhasePairing
    """
    kinds = tuple(kinds)
    ev_a = _safe_events(a, kinds)
    ev_b = _safe_events(b, kinds)
    return pair_by_phase(ev_a, ev_b, prior, a.duration, b.duration, kinds, max_pairs=max_pairs)


def _safe_events(m: Motion, kinds: tuple[str, ...]) -> list[Event]:
    """Events of the kinds whose joints exist (a skeleton without knees gives no knee events)."""
    legs = find_leg_joints(m.skeleton)
    usable = []
    for k in kinds:
        if k.endswith("knee_passes"):
            if None in (legs.left_hip, legs.right_hip, legs.left_knee, legs.right_knee):
                continue
        elif k.endswith("foot_contact"):
            side = k.split("_")[0]
            if legs.side(side)["ankle"] is None and legs.side(side)["toe"] is None:
                continue
        usable.append(k)
    return detect_events(m, usable) if usable else []
