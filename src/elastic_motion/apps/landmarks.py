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
``"left_foot_contact"`` / ``"right_foot_contact"``
    A foot touches down: the ankle or toe joint of that side comes within ``contact_height``
    (default 5 cm) of its lowest height in the clip while moving horizontally slower than
    ``contact_speed`` (default 0.5 m/s). The event is the first frame of a contact that
    lasts at least 0.06 s after at least 0.06 s off the floor (a contact already under way
    at frame 0 is not an event: its onset is not seen).

Joints are found by name (:func:`find_leg_joints`): the side from a ``left``/``right``/``l``/
``r`` prefix or an ``_l``/``_r`` suffix, the part from the rest (``UpLeg``/``femur``/``hip``/
``thigh``; ``Leg``/``knee``/``tibia``/``LowerLeg``/``shin``; ``Foot``/``ankle``; ``Toe``/
``toes``/``ToeBase``). This covers the CMU BVH and ASF files, DeepMimic, Bandai and Mixamo
names. Times are seconds from the motion's first frame; lengths in metres when the motion's
unit is known.
"""

from __future__ import annotations

import itertools
import math
import re
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from elastic_motion.motion import Motion, Skeleton, forward_kinematics

__all__ = [
    "EVENT_KINDS",
    "Event",
    "LegJoints",
    "auto_landmarks",
    "detect_events",
    "find_leg_joints",
    "pair_events",
]

#: The event kinds :func:`detect_events` knows.
EVENT_KINDS = ("left_knee_passes", "right_knee_passes", "left_foot_contact", "right_foot_contact")

#: The paper's choice (paper 001, sec. 4.2), the default of ``--landmarks auto``.
DEFAULT_PAIR_KINDS = ("left_knee_passes",)

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
_KNEE_EPS = 0.02  # hysteresis, fraction of the leg length


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
    """

    kind: str
    time: float
    frame: int


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


def _need(legs: LegJoints, fields: Sequence[str], skeleton: Skeleton, what: str) -> None:
    missing = [f for f in fields if getattr(legs, f) is None]
    if missing:
        raise ValueError(
            f"motion: cannot detect {what}: no joint found for {', '.join(missing)} among "
            f"{list(skeleton.names)}; pass legs=LegJoints(...) naming them"
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


def _crossings(d: np.ndarray, eps: float, upward: bool) -> list[float]:
    """Fractional frame indices where ``d`` crosses 0 (up or down) with hysteresis ``eps``."""
    s = d if upward else -d
    out: list[float] = []
    armed = False
    last_neg = -1  # last frame with s < 0
    for f in range(s.shape[0]):
        if s[f] < -eps:
            armed = True
        if s[f] < 0:
            last_neg = f
        elif armed and s[f] > eps and last_neg >= 0:
            k = last_neg  # s[k] < 0 <= s[k+1]: interpolate the zero
            a, b = s[k], s[k + 1]
            out.append(k + (0.0 - a) / (b - a) if b != a else float(k))
            armed = False
    return out


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """``[start, stop)`` of the runs of True in a boolean array."""
    m = np.concatenate([[False], mask, [False]]).astype(np.int8)
    d = np.diff(m)
    return list(zip(np.flatnonzero(d == 1).tolist(), np.flatnonzero(d == -1).tolist(), strict=True))


def _fill_gaps(mask: np.ndarray, n: int) -> np.ndarray:
    """Close gaps of fewer than ``n`` frames between True runs."""
    out = mask.copy()
    runs = _runs(mask)
    for (_, e0), (s1, _) in itertools.pairwise(runs):
        if s1 - e0 < n:
            out[e0:s1] = True
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
    if not isinstance(motion, Motion):
        raise ValueError(f"motion: expected a Motion; got {type(motion).__name__}")
    kinds = tuple(kinds)
    bad = [k for k in kinds if k not in EVENT_KINDS]
    if bad:
        raise ValueError(f"kinds: unknown event kind {bad[0]!r}; expected some of {list(EVENT_KINDS)}")
    if motion.n_frames < 3:
        raise ValueError(f"motion: expected at least 3 frames to detect events; got {motion.n_frames}")
    sk = motion.skeleton
    legs = find_leg_joints(sk) if legs is None else legs
    up = _AXES.index(motion.up_axis)
    scale = _scale(motion)
    pos = forward_kinematics(motion) * scale
    fps = motion.fps
    events: list[Event] = []

    def add(kind: str, frame_f: float) -> None:
        t = frame_f / fps
        events.append(Event(kind, float(t), int(min(max(round(frame_f), 0), motion.n_frames - 1))))

    if any(k.endswith("knee_passes") for k in kinds):
        _need(legs, ("left_hip", "right_hip", "left_knee", "right_knee"), sk, "knee crossings")
        lh, rh = sk.index(legs.left_hip), sk.index(legs.right_hip)
        lk, rk = sk.index(legs.left_knee), sk.index(legs.right_knee)
        leg = float(np.linalg.norm(pos[0, lk] - pos[0, lh]))
        ank = legs.left_ankle
        if ank is not None:
            leg += float(np.linalg.norm(pos[0, sk.index(ank)] - pos[0, lk]))
        eps = _KNEE_EPS * max(leg, 1e-9)
        fwd = _forward(pos, lh, rh, up)
        d = np.einsum("fi,fi->f", pos[:, lk] - pos[:, rk], fwd)
        if "left_knee_passes" in kinds:
            for f in _crossings(d, eps, upward=True):
                add("left_knee_passes", f)
        if "right_knee_passes" in kinds:
            for f in _crossings(d, eps, upward=False):
                add("right_knee_passes", f)

    n_run = max(1, math.ceil(_MIN_RUN * fps))
    for side in ("left", "right"):
        kind = f"{side}_foot_contact"
        if kind not in kinds:
            continue
        parts = legs.side(side)
        joints = [sk.index(parts[p]) for p in ("ankle", "toe") if parts[p] is not None]
        if not joints:
            _need(legs, (f"{side}_ankle",), sk, "foot contacts")
        p = pos[:, joints]  # (F, k, 3)
        h = p[..., up]
        low = h < h.min(axis=0) + contact_height
        v = np.diff(p, axis=0)
        v[..., up] = 0.0
        speed = np.linalg.norm(v, axis=-1) * fps
        speed = np.concatenate([speed[:1], speed], axis=0)  # (F, k): speed arriving at each frame
        touch = (low & (speed < contact_speed)).any(axis=1)
        touch = _fill_gaps(touch, n_run)
        for start, stop in _runs(touch):
            if start == 0 or stop - start < n_run:
                continue
            if touch[max(0, start - n_run) : start].any():
                continue
            add(kind, float(start))
    events.sort(key=lambda e: (e.time, e.kind))
    return events


def pair_events(
    events_a: Sequence[Event],
    events_b: Sequence[Event],
    kinds: Sequence[str] = DEFAULT_PAIR_KINDS,
    *,
    max_pairs: int | None = None,
) -> list[tuple[Event, Event]]:
    """Pair the events of two motions in order, kind by kind.

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


def auto_landmarks(
    a: Motion,
    b: Motion,
    kinds: Sequence[str] = DEFAULT_PAIR_KINDS,
    *,
    max_pairs: int | None = None,
) -> list[tuple[float, float]]:
    """Landmark pairs ``(time in a, time in b)`` in seconds from paired events.

    Detects ``kinds`` on both motions (:func:`detect_events`) and pairs them in order
    (:func:`pair_events`). Pairs at the very first or last frame are dropped (the warp
    fixes its ends anyway).

    Returns
    -------
    list of (float, float)
        Possibly empty (e.g. a motion without knee crossings).
    """
    ev_a = detect_events(a, kinds)
    ev_b = detect_events(b, kinds)
    out = []
    for pa, pb in pair_events(ev_a, ev_b, kinds, max_pairs=max_pairs):
        if 0.0 < pa.time < a.duration and 0.0 < pb.time < b.duration:
            out.append((pa.time, pb.time))
    return out
