"""Contacts with the floor: when a foot, a toe or a hand is planted, per joint and frame.

The one home of contacts: loops keep them, blends carry them through the warp and plant
them again, landmarks pair their strikes and lift-offs, metrics measure skating during
them, pictures draw them.

Conventions
-----------
* **Candidate joints** (:func:`contact_joints`): joints whose name says foot, toe, ankle,
  hand or wrist (case-insensitive; finger, thumb and hand-index joints excluded): CMU
  ``LeftFoot``/``LeftToeBase``/``LeftHand``, ASF ``lfoot``/``ltoes``/``lhand``, DeepMimic
  ``left_ankle``/``left_wrist``, Bandai ``Foot_L``/``Toes_L``/``Hand_L``.
* **The floor** of a clip is the height (along the motion's up axis, metres) below which
  the clip's lowest point stays only 2 % of the frames: the 2nd percentile over frames of
  the lowest joint or end site. Robust to a few frames of noise.
* **A floor that is not level** (:func:`floor_profile`): in a clip of at least
  ``1.5 * FLOOR_WINDOW`` seconds, the lowest point's 10th percentile over a moving window of
  :data:`FLOOR_WINDOW` seconds, smoothed, tells how the floor moves; when it moves by
  ``height_enter`` or more over the clip, one way (its total variation at most 1.2 times
  its range) and never faster than :data:`FLOOR_MAX_RATE` (a floor that slopes under a
  walk, a capture that drifts: CMU 07_01 and 08_02 rise 4.9 and 6.6 cm in 2.6 s), the floor
  is a straight line in time with its slope, placed like the level floor (2 % of frames
  under it), and heights are measured from it (:attr:`Contacts.floor_offset`); else from
  the one floor. (Up and down, it is the body, not the floor: a toe that dips in a turn.)
* **A joint's ground height** is its own height when planted: the 5th percentile of its
  height over the clip, above the floor (the floor of its frame). A joint whose ground
  height exceeds ``max_ground_offset`` (default 0.2 m) never touches in this clip (a hand in
  a walk) and gets no contact.
* **In contact** (hysteresis, per joint): a joint *enters* contact when it is within
  ``height_enter`` (3 cm) of its ground height and its horizontal speed is below
  ``speed_enter`` (0.4 m/s); it *leaves* when it rises above ``height_exit`` (6 cm) or
  moves faster than ``speed_exit`` (0.8 m/s). Contacts shorter than ``min_duration``
  (0.1 s) are dropped, gaps shorter than ``min_gap`` (0.05 s) between two contacts are
  filled. Speeds are central differences (one-sided at the ends), in m/s.
* **Not counted, but said**: a stretch that looks planted (slower than ``speed_enter`` for
  ``min_duration``, within ``max_ground_offset / 2`` of the joint's ground height) but stands
  above ``height_enter`` is no contact; the notes list them per joint (a floor that is not
  level, or a capture that drifts: in CMU 07_01 and 08_02 the floor rises 4-6 cm over
  2.6 s and later stances stand 3-6 cm above the first; one floor height misses them). A
  heel raised while the toe below it is planted (walking on the ball of the foot) is
  neither a contact of the heel nor said.
* **Intervals** are half-open frame ranges ``[start, stop)``.
* Units: a motion whose ``metres_per_unit`` is unknown is measured in its own length unit
  (thresholds then in that unit: pass suitable ones).
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from elastic_motion.defaults import CONTACT_HEIGHT_ENTER, CONTACT_SPEED_ENTER
from elastic_motion.errors import OptionError
from elastic_motion.motion.filters import gaussian_frames, percentile_frames
from elastic_motion.motion.kinematics import forward_kinematics
from elastic_motion.motion.skeleton import Motion, Skeleton
from elastic_motion.notes import Note, note_texts
from elastic_motion.vocabulary import CONTACT_POLICIES, CONTACT_POLICY_ALIASES, ContactPolicy

__all__ = [
    "CONTACT_POLICIES",
    "FLOOR_NOT_LEVEL",
    "MISSED_STANCES",
    "MISSED_STANCES_NOTE",
    "NEVER_NEAR_FLOOR",
    "NO_CONTACT_JOINTS",
    "ContactOptions",
    "ContactPolicy",
    "Contacts",
    "close_gaps",
    "contact_joints",
    "contact_policy",
    "detect_contacts",
    "floor_height",
    "floor_profile",
    "mask_runs",
]

_AXES = "xyz"
_CANDIDATE = re.compile(r"foot|toe|ankle|hand|wrist", re.IGNORECASE)
_NOT_CANDIDATE = re.compile(r"finger|thumb|index|handtip|hand_end", re.IGNORECASE)
_FLOOR_PERCENTILE = 2.0
#: Seconds of the moving window of :func:`floor_profile` (a stance of each foot in a walk).
FLOOR_WINDOW = 1.5
#: Fastest a floor that is not level may move under the clip (m/s; :func:`floor_profile`).
FLOOR_MAX_RATE = 0.07
#: Largest total variation of a floor that is not level, in multiples of its range (one way).
_FLOOR_MONOTONE = 1.2
#: How the note on stretches that look planted but are not contacts starts (:func:`detect_contacts`).
#: Kept for one release for callers that test the text: test ``note.kind == MISSED_STANCES``.
MISSED_STANCES_NOTE = "slow stretches above the contact height, not counted as contacts"

# Kinds of :attr:`Contacts.notes` (:mod:`elastic_motion.notes`), data in the contacts' unit
# (metres, or the motion's unit when unknown) and seconds.
#: No candidate joint in the skeleton (no data).
NO_CONTACT_JOINTS = "contacts.no_candidates"
#: The floor is not level (module docstring); data ``rise``, ``start``, ``end`` (its height
#: above ``floor`` at the first and last frames) and ``floor``.
FLOOR_NOT_LEVEL = "contacts.floor_not_level"
#: Candidates that never touch in this clip; data ``joints`` (names).
NEVER_NEAR_FLOOR = "contacts.never_near_floor"
#: Stretches that look planted above the contact height (module docstring); data ``joints``:
#: per joint ``count``, ``first_s`` (start of the first), ``lowest`` and ``highest`` (their
#: lowest heights above the joint's ground height, the least and the most).
MISSED_STANCES = "contacts.missed_stances"
_GROUND_PERCENTILE = 5.0

# What an app does with the contacts of its inputs, one vocabulary for blend, loop, blend
# spaces and the viewer: ContactPolicy ("keep", "report", "off") and its values
# CONTACT_POLICIES, from elastic_motion.vocabulary; "auto" (the blend's name before) is accepted
# for "keep", "none" for "off" (CONTACT_POLICY_ALIASES).


def contact_policy(value: str | None, argument: str = "contacts") -> str:
    """The :data:`ContactPolicy` named ``value`` (``None`` is ``"off"``; ``"auto"`` is ``"keep"``).

    Raises
    ------
    OptionError
        Any other value, naming ``argument``.
    """
    if value is None:
        return "off"
    if isinstance(value, str):
        value = CONTACT_POLICY_ALIASES.get(value, value)
        if value in CONTACT_POLICIES:
            return value
    raise OptionError(argument, f"expected one of {list(CONTACT_POLICIES)}; got {value!r}")


def contact_joints(skeleton: Skeleton | Motion) -> list[int]:
    """Indices of the joints that can touch the floor (module docstring), skeleton order."""
    sk = skeleton.skeleton if isinstance(skeleton, Motion) else skeleton
    return [
        j for j, n in enumerate(sk.names) if j != 0 and _CANDIDATE.search(n) and not _NOT_CANDIDATE.search(n)
    ]


@dataclass(frozen=True)
class ContactOptions:
    """Thresholds of contact detection (module docstring); lengths in metres, speeds in m/s,
    durations in seconds. ``follow_floor``: measure heights from a floor that is not level
    (:func:`floor_profile`); False: from one floor height (a loop: periodic, its floor level)."""

    height_enter: float = CONTACT_HEIGHT_ENTER
    height_exit: float = 0.06
    speed_enter: float = CONTACT_SPEED_ENTER
    speed_exit: float = 0.8
    min_duration: float = 0.1
    min_gap: float = 0.05
    max_ground_offset: float = 0.2
    follow_floor: bool = True

    def __post_init__(self) -> None:
        if not isinstance(self.follow_floor, bool):
            raise ValueError(f"follow_floor: expected True or False; got {self.follow_floor!r}")
        for name in self.__dataclass_fields__:
            if name == "follow_floor":
                continue
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v >= 0):
                raise ValueError(f"{name}: expected a finite number >= 0; got {v!r}")
        if self.height_exit < self.height_enter or self.speed_exit < self.speed_enter:
            raise ValueError(
                "contact thresholds: expected exit thresholds >= enter thresholds (hysteresis); got "
                f"height {self.height_enter}/{self.height_exit}, speed {self.speed_enter}/{self.speed_exit}"
            )


@dataclass(frozen=True, eq=False)
class Contacts:
    """Contacts of a motion's joints with the floor (:func:`detect_contacts`).

    Attributes
    ----------
    joints : tuple of str
        The candidate joints (``K``), including those that never touch.
    joint_indices : ndarray of int, shape (K,)
        Their indices in the skeleton.
    mask : ndarray of bool, shape (F, K)
        ``mask[f, k]``: joint ``k`` is planted in frame ``f``.
    floor : float
        Floor height along the up axis (metres, or the motion's unit when unknown).
    ground_height : ndarray, shape (K,)
        Each joint's height above the floor when planted (NaN for joints that never touch).
    fps : float
    up_axis : str
    options : ContactOptions
    notes : tuple of Note
        What was found or skipped, kinds :data:`NO_CONTACT_JOINTS`, :data:`FLOOR_NOT_LEVEL`,
        :data:`NEVER_NEAR_FLOOR`, :data:`MISSED_STANCES`.
    floor_offset : ndarray, shape (F,), or None
        A floor that is not level (module docstring): its height above ``floor`` frame by
        frame (same unit); None for a level floor. :meth:`floor_heights` gives both.
    """

    joints: tuple[str, ...]
    joint_indices: np.ndarray
    mask: np.ndarray
    floor: float
    ground_height: np.ndarray
    fps: float
    up_axis: str
    options: ContactOptions = field(default_factory=ContactOptions)
    notes: tuple[Note, ...] = ()
    floor_offset: np.ndarray | None = None

    @property
    def n_frames(self) -> int:
        return int(self.mask.shape[0])

    def floor_heights(self) -> np.ndarray:
        """The floor's height ``(F,)`` frame by frame: ``floor + floor_offset`` (level: ``floor``)."""
        if self.floor_offset is None:
            return np.full(self.n_frames, self.floor)
        return self.floor + np.asarray(self.floor_offset, dtype=np.float64)

    def select_frames(self, frames: np.ndarray) -> Contacts:
        """The contacts on ``frames`` (indices into these frames; fps unchanged)."""
        off = None if self.floor_offset is None else np.asarray(self.floor_offset)[frames]
        return dataclasses.replace(self, mask=self.mask[frames], floor_offset=off)

    @property
    def any(self) -> bool:
        """True when some joint is ever in contact."""
        return bool(self.mask.any())

    def intervals(self, joint: str | int) -> list[tuple[int, int]]:
        """Contact intervals ``[start, stop)`` (frames) of a joint (name or position in ``joints``)."""
        k = self.joints.index(joint) if isinstance(joint, str) else int(joint)
        return mask_runs(self.mask[:, k])

    def all_intervals(self) -> dict[str, list[tuple[int, int]]]:
        """Every joint's intervals, joints that never touch left out."""
        out = {}
        for k, name in enumerate(self.joints):
            runs = mask_runs(self.mask[:, k])
            if runs:
                out[name] = runs
        return out

    def events(self) -> list[tuple[float, str, str]]:
        """Strikes and lift-offs in time order: ``(time s, joint, "strike" | "lift")``.

        A contact that starts at frame 0 has no strike and one that ends at the last frame
        no lift-off (the clip cut them, they did not happen).
        """
        out = []
        for name, runs in self.all_intervals().items():
            for a, b in runs:
                if a > 0:
                    out.append((a / self.fps, name, "strike"))
                if b < self.n_frames:
                    out.append((b / self.fps, name, "lift"))
        out.sort()
        return out

    def summary(self) -> dict[str, Any]:
        """JSON-ready: floor, per-joint intervals in frames and seconds, notes."""
        return {
            "floor_m": self.floor,
            "floor_rise_m": 0.0 if self.floor_offset is None else float(np.ptp(self.floor_offset)),
            "fps": self.fps,
            "joints": {
                name: {
                    "frames": [list(r) for r in runs],
                    "seconds": [[a / self.fps, b / self.fps] for a, b in runs],
                }
                for name, runs in self.all_intervals().items()
            },
            "candidates": list(self.joints),
            "notes": note_texts(self.notes),
        }


def mask_runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """The runs of True in a 1-D boolean mask, as half-open frame ranges ``(start, stop)``."""
    m = np.concatenate([[False], np.asarray(mask, dtype=bool), [False]])
    d = np.diff(m.astype(np.int8))
    starts, stops = np.flatnonzero(d == 1), np.flatnonzero(d == -1)
    return [(int(a), int(b)) for a, b in zip(starts, stops, strict=True)]


def _scale(motion: Motion) -> float:
    return motion.metres_per_unit if motion.metres_per_unit is not None else 1.0


def floor_height(motion: Motion, positions: np.ndarray | None = None) -> float:
    """The clip's floor (module docstring), metres (the motion's unit when unknown).

    Parameters
    ----------
    motion : Motion
    positions : ndarray, shape (F, P, 3), optional
        FK positions of joints and end sites in metres (computed when not given).
    """
    if positions is None:
        positions = forward_kinematics(motion, end_sites=True) * _scale(motion)
    up = _AXES.index(motion.up_axis)
    lowest = positions[..., up].min(axis=1)
    return float(np.percentile(lowest, _FLOOR_PERCENTILE))


def floor_profile(motion: Motion, positions: np.ndarray, floor: float, rise: float) -> np.ndarray | None:
    """The floor's height above ``floor`` frame by frame, or None for a level floor (module
    docstring).

    A straight line in time: ``floor(t) = a + b t`` with the slope ``b`` of the lowest
    point's moving low percentile (least squares) and ``a`` the 2nd percentile of
    ``lowest - b t``, as the level floor is of ``lowest`` (so at most 2 % of frames go under it,
    and ``b = 0`` is the level floor).

    Parameters
    ----------
    motion : Motion
    positions : ndarray, shape (F, P, 3)
        FK positions of joints and end sites (metres, or the motion's unit).
    floor : float
        The clip's level floor (:func:`floor_height`).
    rise : float
        The least change over the clip that makes the floor not level (same unit).

    Returns
    -------
    ndarray, shape (F,), or None
        None for a clip shorter than ``1.5 * FLOOR_WINDOW``, a floor that moves less than
        ``rise``, faster than :data:`FLOOR_MAX_RATE`, or up and down.
    """
    f = motion.n_frames
    width = round(FLOOR_WINDOW * motion.fps)
    if 2 * f < 3 * width or width < 3:
        return None
    lowest = positions[..., _AXES.index(motion.up_axis)].min(axis=1)
    # a window holds a stance of each foot in a walk: its low percentile is the floor there,
    # whatever the feet do in between (flight, a raised foot); smoothed over a third of it
    low = gaussian_frames(percentile_frames(lowest, 10.0, width | 1), width / 3.0)
    # a floor that slopes under a walk, or a capture that drifts, moves slowly and one way
    # (CMU 07_01, 08_02: 2.5-3 cm/s, all the way up); faster, or up and down, it is the body
    # (a foot held up, a toe that dips in a turn: CMU 131_01 went 5 cm down and up again in
    # 2 s and lost two stances), and the floor is taken as level
    if np.ptp(low) < rise or np.abs(np.gradient(low)).max() * motion.fps > FLOOR_MAX_RATE:
        return None
    if np.abs(np.diff(low)).sum() > _FLOOR_MONOTONE * np.ptp(low):
        return None
    t = np.arange(f) / motion.fps
    slope = float(np.polyfit(t, low, 1)[0])
    if abs(slope) * t[-1] < rise:
        return None
    line = slope * t
    return float(np.percentile(lowest - line, _FLOOR_PERCENTILE)) + line - floor


def _horizontal_speed(p: np.ndarray, up: int, fps: float) -> np.ndarray:
    """Horizontal speed (F, K) by central differences (one-sided at the ends)."""
    q = p.copy()
    q[..., up] = 0.0
    if q.shape[0] < 2:
        return np.zeros(q.shape[:2])
    v = np.gradient(q, axis=0) * fps
    return np.linalg.norm(v, axis=-1)


def _hysteresis(near_enter: np.ndarray, near_exit: np.ndarray) -> np.ndarray:
    """Per column: on when ``near_enter``, stays on while ``near_exit``."""
    f, k = near_enter.shape
    out = np.zeros((f, k), dtype=bool)
    state = near_enter[0].copy()
    out[0] = state
    for i in range(1, f):
        state = np.where(state, near_exit[i], near_enter[i])
        out[i] = state
    # the state machine runs forward; a contact is also on where it would have started had
    # the clip begun later: run it backward and take the union (symmetric in time)
    back = np.zeros((f, k), dtype=bool)
    state = near_enter[-1].copy()
    back[-1] = state
    for i in range(f - 2, -1, -1):
        state = np.where(state, near_exit[i], near_enter[i])
        back[i] = state
    return out | back


def close_gaps(col: np.ndarray, min_len: int, min_gap: int) -> np.ndarray:
    """A copy of the 1-D boolean mask ``col`` with gaps shorter than ``min_gap`` frames filled,
    then runs shorter than ``min_len`` frames removed (the hysteresis of contact detection)."""
    col = col.copy()
    runs = mask_runs(col)
    for (_, b), (c, _) in itertools.pairwise(runs):
        if c - b < min_gap:
            col[b:c] = True
    for a, b in mask_runs(col):
        if b - a < min_len:
            col[a:b] = False
    return col


def _below(skeleton: Skeleton, idx: Sequence[int]) -> list[list[int]]:
    """For each candidate ``idx[k]``, the positions in ``idx`` of the candidates below it in
    the skeleton (an ankle's toe)."""
    return [[i for i, j in enumerate(idx) if j != jk and j in skeleton.subtree(jk)] for jk in idx]


def _frames_of(seconds: float, fps: float) -> int:
    """The least whole number of frames (at least 1) that lasts ``seconds``."""
    return max(1, math.ceil(seconds * fps - 1e-9))


def _missed_stances(
    names: Sequence[str],
    mask: np.ndarray,
    rel: np.ndarray,
    speed: np.ndarray,
    touches: np.ndarray,
    below: Sequence[Sequence[int]],
    opts: ContactOptions,
    fps: float,
) -> dict[str, dict[str, Any]]:
    """Per joint, the stretches that look planted but are not contacts: slower than
    ``speed_enter`` for at least ``min_duration``, never in contact, within
    ``max_ground_offset / 2`` of the joint's ground height but above ``height_enter``
    (CMU 07_01 and 08_02: the floor rises 4-6 cm over 2.6 s and the later stances stand
    3-6 cm above the first). A stretch during most of which a joint below it (``below[k]``:
    its toe) is planted is a heel raised on the toe, not a missed stance, and is left out
    (CMU 131_02 walks slowly on its toes: 10 such stretches of its ankles, 5-9 cm up).

    Returns, for each joint that has some: ``count``, ``first_s`` (start of the first, s),
    ``lowest`` and ``highest`` (the least and the most of their lowest heights above the
    joint's ground height, in the contacts' unit).
    """
    min_len = _frames_of(opts.min_duration, fps)
    out = {}
    for k in np.flatnonzero(touches):
        found = []
        for a, b in mask_runs(speed[:, k] <= opts.speed_enter):
            if b - a < min_len or mask[a:b, k].any():
                continue
            if below[k] and 2 * mask[a:b, list(below[k])].any(axis=1).sum() > b - a:
                continue
            low = float(rel[a:b, k].min())
            if opts.height_enter < low <= opts.max_ground_offset / 2:
                found.append((a, low))
        if found:
            lows = [x for _, x in found]
            out[names[k]] = {
                "count": len(found),
                "first_s": found[0][0] / fps,
                "lowest": min(lows),
                "highest": max(lows),
            }
    return out


def _contact_notes(
    names: Sequence[str], touches: np.ndarray, floor: float, offset: np.ndarray | None, missed: dict[str, Any]
) -> tuple[Note, ...]:
    """The notes of :func:`detect_contacts`: a floor that is not level (``offset``), joints
    that never touch, missed stances (:func:`_missed_stances`)."""
    notes = []
    if offset is not None:
        notes.append(
            Note(
                FLOOR_NOT_LEVEL,
                f"the floor is not level: it moves by {np.ptp(offset):.3g} over the clip (from "
                f"{offset[0]:+.3g} to {offset[-1]:+.3g} about the floor {floor:.3g}); heights are "
                "measured from it frame by frame",
                {
                    "rise": float(np.ptp(offset)),
                    "start": float(offset[0]),
                    "end": float(offset[-1]),
                    "floor": float(floor),
                },
            )
        )
    never = [n for n, t in zip(names, touches, strict=True) if not t]
    if never:
        notes.append(
            Note(NEVER_NEAR_FLOOR, f"never near the floor in this clip: {never}", {"joints": list(never)})
        )
    if missed:
        per_joint = [
            f"{name} {m['count']} (the first at {m['first_s']:.2f} s), "
            f"{m['lowest']:.3f}-{m['highest']:.3f} m above its lowest height"
            for name, m in missed.items()
        ]
        notes.append(
            Note(
                MISSED_STANCES,
                MISSED_STANCES_NOTE + " (a floor that is not "
                "level, or a capture that drifts? ContactOptions(height_enter=) counts them): "
                + "; ".join(per_joint),
                {"joints": missed},
            )
        )
    return tuple(notes)


def detect_contacts(
    motion: Motion,
    options: ContactOptions | None = None,
    *,
    joints: Sequence[str] | None = None,
) -> Contacts:
    """Detect when each foot, toe and hand is planted on the clip's floor.

    Parameters
    ----------
    motion : Motion
        At least 2 frames.
    options : ContactOptions, optional
        Thresholds (module docstring).
    joints : sequence of str, optional
        Candidate joints (default :func:`contact_joints`).

    Returns
    -------
    Contacts
        With an empty candidate list (and a note) when no joint can touch the floor.

    Raises
    ------
    ValueError
        Unknown joint names, fewer than 2 frames.
    """
    opts = options or ContactOptions()
    if not isinstance(motion, Motion):
        raise ValueError(f"motion: expected a Motion; got {type(motion).__name__}")
    if motion.n_frames < 2:
        raise ValueError(f"motion: expected at least 2 frames to detect contacts; got {motion.n_frames}")
    sk = motion.skeleton
    if joints is None:
        idx = contact_joints(sk)
    else:
        unknown = [n for n in joints if n not in sk.names]
        if unknown:
            raise ValueError(f"joints: expected joint names of the skeleton; got unknown {unknown}")
        idx = [sk.index(n) for n in joints]
    up = _AXES.index(motion.up_axis)
    pos = forward_kinematics(motion, end_sites=True) * _scale(motion)
    floor = floor_height(motion, pos)
    names = tuple(sk.names[j] for j in idx)
    f = motion.n_frames
    if not idx:
        return Contacts(
            names, np.zeros(0, dtype=np.int64), np.zeros((f, 0), dtype=bool), floor, np.zeros(0),
            motion.fps, motion.up_axis, opts,
            (Note(NO_CONTACT_JOINTS, "no joint that can touch the floor (feet, toes, hands)"),),
        )  # fmt: skip
    p = pos[:, idx]
    offset = floor_profile(motion, pos, floor, opts.height_enter) if opts.follow_floor else None
    height = p[..., up] - floor - (0.0 if offset is None else offset[:, None])
    ground = np.percentile(height, _GROUND_PERCENTILE, axis=0)
    speed = _horizontal_speed(p, up, motion.fps)
    touches = ground <= opts.max_ground_offset
    rel = height - ground
    near_enter = (rel <= opts.height_enter) & (speed <= opts.speed_enter) & touches
    near_exit = (rel <= opts.height_exit) & (speed <= opts.speed_exit) & touches
    mask = _hysteresis(near_enter, near_exit)
    min_len = _frames_of(opts.min_duration, motion.fps)
    min_gap = _frames_of(opts.min_gap, motion.fps)
    for k in range(mask.shape[1]):
        mask[:, k] = close_gaps(mask[:, k], min_len, min_gap)
    missed = _missed_stances(names, mask, rel, speed, touches, _below(sk, idx), opts, motion.fps)
    notes = _contact_notes(names, touches, floor, offset, missed)
    ground_out = np.where(touches, ground, np.nan)
    return Contacts(
        names, np.asarray(idx, dtype=np.int64), mask, floor, ground_out, motion.fps, motion.up_axis,
        opts, notes, offset,
    )  # fmt: skip
