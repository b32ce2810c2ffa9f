"""The contact plan of a blend: when each foot is planted or swinging, in output time.

A blend's feet must do what an animator expects of a walk: on every output frame each foot
joint is either **planted** (held where it stands, as its inputs hold theirs) or **swinging**
(up in the air at least as its inputs swing); there is no third state, a foot that drifts
along the floor at half a step's speed. The inputs' contact intervals
(:func:`elastic_motion.motion.contacts.detect_contacts`) are carried through the warps and
matched, and each output interval starts and ends at the weighted mean of its matched input
intervals' boundaries (the constraints of registration curves, Kovar & Gleicher 2003).

Conventions
-----------
* **Carried intervals.** Input ``k``'s interval ``[a, b)`` (its frames) covers the output
  frames whose time in input ``k`` (the clock, :class:`~elastic_motion.apps.blend.timing.Clock`)
  rounds to a frame of ``[a, b)``.
* **Matching** (per joint; the reference is the input of largest weight): an interval of one
  input that overlaps two of the other's is split at the middle of their gap (the other
  input steps where this one stands: the split is a swing of length zero), then intervals are
  paired by their overlap, most first. An interval left alone is matched by a zero-length
  interval of the other input at its centre: at weight ``w`` it lasts ``w`` of its length
  (blended with a step, a stance of the input that carries the blend becomes a shorter
  stance, not a slide).
* **Output interval** of a matched group: ``[sum_k w_k s_k, sum_k w_k e_k)``, rounded to frames;
  kept when at least ``min_duration`` long and when the inputs planted in it, or at its
  centre, weigh more than :data:`MAJORITY` (a half) there; overlapping ones merge. A stance
  of inputs that weigh half or less, where the others swing, is a swing of the blend, at the
  blended heights of their swings and its stance ("Swing heights"). Planted at half its
  length, a lone stance left the foot of a 50 % blend no time to reach its next plant (CMU
  131_01 x 131_02: 131_02's right toe alone, planted over output frames 663-695; the heel's
  plant of both inputs from 696, 10 cm further on). At 131_02's own heights (1.4-5.2 cm over
  its ground height, held only by the detector's hysteresis) the toe never came within the
  3 cm that starts a contact: the blend's own contacts saw a swing of frames 625-697 passing
  5.2 cm over the floor, 0.62 of the lesser input's clearance; brought down to the floor (tried),
  it dragged 1.5 cm over it at 1 m/s into the heel's plant (0.64). Swung: 0.86.
* **Plant targets** of a planted joint: the blend's own mean position over the interval plus
  the weighted motion of the inputs' joints about their own means there (what they did while
  planted: a heel rolling, a few millimetres of capture jitter; zero for a perfectly planted
  input), heights the inputs' own above their floors (weighted over the inputs planted there),
  on the blended floor; a foot the blend holds more than :data:`MAX_PULL` higher over most of
  the interval keeps its own heights (a leg posed wrong above it stays up, locked in the floor
  plane: pulled down, the knee would fold). A blend of identical inputs is its own plan: its
  targets are where its feet already are.
* **Swing heights** of a swinging joint between two planted intervals: the weighted mean of
  the matched inputs' own heights over their swings at the same phase (0 at lift-off, 1 at the
  strike; inputs that do not swing there left out), on the blended floor: the least height the
  clean-up keeps the joint at (the feet of a blend swing as high as their inputs' at the same
  phase; lifted only to 0.9 of the inputs' clearance, feet hung low and slow over the floor,
  and the blend's own contacts then skated 1.21x the better input on CMU 107_02 x 108_01
  against 1.04x). Before the first plant and after the last, the inputs' heights at the
  same times.

Units: metres (the prepared motions'), frames of the output, seconds.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from elastic_motion.apps.blend.timing import Clock
from elastic_motion.apps.cleanup import find_legs
from elastic_motion.motion import Motion, Skeleton, forward_kinematics
from elastic_motion.motion.contacts import ContactOptions, Contacts
from elastic_motion.motion.ik import LegChain

__all__ = [
    "ContactPlan",
    "PlannedInterval",
    "at_ends",
    "carried_interval",
    "match_intervals",
    "on_own_floor",
    "plan_contacts",
    "plan_mask",
    "steadier",
]

_AXES = "xyz"

Interval = tuple[int, int]

#: Degrees: a foot whose ankle and toe targets turn it more than this from the blend's own
#: orientation is planted as one rigid piece (:func:`_rigid_feet`).
RIGID_TURN = 20.0
#: Metres: a planted foot the blend holds higher than its inputs' heights by more than this over
#: most of its interval is a leg posed wrong above it, and is not pulled down (module docstring,
#: "Plant targets"); a foot hovering lower is.
MAX_PULL = 0.05
#: A matched group is planted only when the inputs planted in it weigh more than this at its
#: centre (module docstring, "Output interval"): at 50 % a stance of one input alone swings,
#: at 60 % it is planted for 60 % of its length. A group of every input always is.
MAJORITY = 0.5


@dataclass(frozen=True)
class PlannedInterval:
    """One planted interval of the output.

    Attributes
    ----------
    start, stop : int
        Output frames ``[start, stop)``.
    members : tuple of (int, int, int)
        ``(input k, start, stop)``: the carried intervals (output frames) it blends; an input
        that does not plant there is absent.
    """

    start: int
    stop: int
    members: tuple[tuple[int, int, int], ...]


@dataclass(frozen=True, eq=False)
class ContactPlan:
    """When each foot joint of a blend is planted, where, and how high it swings.

    Attributes
    ----------
    contacts : Contacts
        The planted frames on the output's frames, the joints' blended ground heights, and as
        its floor (``floor_heights()``) the height the blend may not go under: the blended
        floor, or the inputs' own lowest points there if lower.
    intervals : dict of str to tuple of PlannedInterval
    plants : dict of str to ndarray, shape (F, 3)
        Per planted joint, its target on planted frames (NaN elsewhere), metres.
    swing_heights : dict of str to ndarray, shape (F,)
        Per joint (and ``"<joint> end site"``, the end sites hanging from a planted joint),
        the least height (absolute, metres) on its swinging frames (NaN elsewhere).
    floor : ndarray, shape (F,), or None
        The blended floor (metres) the plants' and swings' heights stand on; None: the
        contacts' mean floor.
    """

    contacts: Contacts
    intervals: dict[str, tuple[PlannedInterval, ...]]
    plants: dict[str, np.ndarray] = field(default_factory=dict)
    swing_heights: dict[str, np.ndarray] = field(default_factory=dict)
    floor: np.ndarray | None = None

    def floor_heights(self) -> np.ndarray:
        """The blended floor ``(F,)`` (metres)."""
        if self.floor is not None:
            return self.floor
        return np.full(self.contacts.n_frames, self.contacts.floor)


def carried_interval(run: Interval, frames: np.ndarray) -> Interval:
    """An input interval ``[a, b)`` (its frames) on the output frames: those whose input frame
    ``frames`` (fractional, non-decreasing) rounds into it."""
    a, b = run
    return int(np.searchsorted(frames, a - 0.5, "left")), int(np.searchsorted(frames, b - 0.5, "left"))


def _split(runs: list[Interval], other: list[Interval]) -> list[Interval]:
    """``runs`` with each interval that overlaps two or more of ``other`` split at the middle
    of the gaps between them (module docstring, "Matching")."""
    out = []
    for a, b in runs:
        inside = [(c, d) for c, d in other if min(b, d) > max(a, c)]
        cuts = [(d + c2) // 2 for (_, d), (c2, _) in itertools.pairwise(inside)]
        edges = [a, *[x for x in cuts if a < x < b], b]
        out += [(s, e) for s, e in itertools.pairwise(edges) if e > s]
    return out


def match_intervals(
    ref: list[Interval], other: list[Interval], *, split_ref: bool = True
) -> list[tuple[Interval | None, Interval | None]]:
    """Pairs of intervals of two inputs (output frames, module docstring "Matching"); an
    interval left alone is paired with None. In time order. ``split_ref=False`` leaves the
    reference's intervals whole (several inputs matched to one reference)."""
    if split_ref:
        ref = _split(ref, other)
    other = _split(other, ref)
    pairs = sorted(
        ((min(b, d) - max(a, c), i, j) for i, (a, b) in enumerate(ref) for j, (c, d) in enumerate(other)),
        reverse=True,
    )
    used_r: dict[int, int] = {}
    used_o: set[int] = set()
    for overlap, i, j in pairs:
        if overlap <= 0:
            break
        if i not in used_r and j not in used_o:
            used_r[i] = j
            used_o.add(j)
    out: list[tuple[Interval | None, Interval | None]] = [
        (r, other[used_r[i]] if i in used_r else None) for i, r in enumerate(ref)
    ]
    out += [(None, o) for j, o in enumerate(other) if j not in used_o]
    return sorted(out, key=lambda p: min(x[0] for x in p if x is not None))


def _group_interval(members: Sequence[Interval | None], weights: np.ndarray) -> tuple[float, float]:
    """``[sum w s, sum w e)`` of a matched group; an absent member is a zero-length interval at
    the present ones' weighted centre."""
    present = [(w, m) for w, m in zip(weights, members, strict=True) if m is not None]
    total = sum(w for w, _ in present)
    centre = sum(w * 0.5 * (m[0] + m[1]) for w, m in present) / total if total > 0 else 0.0
    s = sum(w * (m[0] if m is not None else centre) for w, m in zip(weights, members, strict=True))
    e = sum(w * (m[1] if m is not None else centre) for w, m in zip(weights, members, strict=True))
    return s, e


def _joint_groups(runs: Sequence[list[Interval]], weights: np.ndarray) -> list[tuple[Interval | None, ...]]:
    """Matched groups of one joint's carried intervals, one member per input (None: absent).

    Two inputs are matched both ways (either may be split); more are each matched to the
    reference (the input of largest weight) whose intervals stay whole."""
    k = len(runs)
    ref = int(np.argmax(weights))
    if k == 2:
        other = 1 - ref
        out = []
        for r, o in match_intervals(runs[ref], runs[other]):
            g: list[Interval | None] = [None, None]
            g[ref], g[other] = r, o
            out.append(tuple(g))
        return out
    groups: dict[int, list[Interval | None]] = {}
    loose: list[list[Interval | None]] = []
    for i, r in enumerate(runs[ref]):
        groups[i] = [None] * k
        groups[i][ref] = r
    for i in range(k):
        if i == ref:
            continue
        for r, o in match_intervals(runs[ref], runs[i], split_ref=False):
            if r is None:
                g = [None] * k
                g[i] = o
                loose.append(g)
            else:
                groups[runs[ref].index(r)][i] = o
    return [tuple(g) for g in [*groups.values(), *loose]]


@dataclass(frozen=True)
class _InputFeet:
    """One input's joint positions (metres) and floor at the output frames' times."""

    frames: np.ndarray  # (F,) fractional input frame of each output frame
    positions: np.ndarray  # (F, J + E, 3) joints and end sites at those times (linear)
    floor: np.ndarray  # (F,) the input's floor at those times


def _input_feet(m: Motion, c: Contacts, times: np.ndarray) -> _InputFeet:
    scale = m.metres_per_unit if m.metres_per_unit is not None else 1.0
    x = np.clip(times * m.fps, 0.0, m.n_frames - 1)
    i = np.clip(np.floor(x).astype(int), 0, max(m.n_frames - 2, 0))
    frac = (x - i)[:, None, None]
    p = forward_kinematics(m, end_sites=True) * scale  # joints, then end sites
    j = np.minimum(i + 1, m.n_frames - 1)
    pos = (1.0 - frac) * p[i] + frac * p[j]
    fl = c.floor_heights()
    return _InputFeet(x, pos, (1.0 - frac[:, 0, 0]) * fl[i] + frac[:, 0, 0] * fl[j])


def _allowed_floor(feet: Sequence[_InputFeet], wf: np.ndarray, floor: np.ndarray, up: int) -> np.ndarray:
    """The height ``(F,)`` the blend's points may not go under: the blended floor, or the
    inputs' own lowest points there (blended) if lower (the floor is a robust estimate: an
    input's own feet go under it on a few frames, by 0.1-1.5 cm, and its blend with itself must
    stay itself). A blend goes no deeper than its inputs do at the same times."""
    lowest = sum(wf[:, k] * f.positions[..., up].min(axis=1) for k, f in enumerate(feet))
    return np.minimum(floor, lowest)


def _frame_weights(clock: Clock, n: int) -> np.ndarray:
    w = np.asarray(clock.weights, dtype=np.float64)
    return np.broadcast_to(w, (n, w.shape[-1])) if w.ndim == 1 else w


def plan_contacts(
    result: Motion,
    motions: Sequence[Motion],
    found: Sequence[Contacts],
    clock: Clock,
    options: ContactOptions,
    max_skating: float | None = None,
) -> ContactPlan:
    """The contact plan of a blend (module docstring).

    Parameters
    ----------
    result : Motion
        The blend before its contacts are planted (metres, the prepared inputs' joints).
    motions : sequence of Motion
        The prepared inputs.
    found : sequence of Contacts
        Their contacts, each on its own frames.
    clock : Clock
        The output clock (each input's time at every output frame, the weights).
    options : ContactOptions
        ``min_duration`` and ``min_gap`` of the planned intervals.
    max_skating : float, optional
        m/s: the plants' floor-plane motion (the inputs' planted feet's, blended) scaled down
        so that they move at most this fast on average (e.g. the lesser input's skating).
    """
    n = result.n_frames
    up = _AXES.index(result.up_axis)
    wf = _frame_weights(clock, n)
    feet = [_input_feet(m, c, t) for m, c, t in zip(motions, found, clock.times, strict=True)]
    floor = sum(wf[:, k] * f.floor for k, f in enumerate(feet))
    scale = result.metres_per_unit if result.metres_per_unit is not None else 1.0
    out_pos = forward_kinematics(result) * scale
    names = [nm for nm in dict.fromkeys(j for c in found for j in c.joints) if nm in result.skeleton.names]
    min_len = max(1, math.ceil(options.min_duration * result.fps - 1e-9))
    min_gap = max(1, math.ceil(options.min_gap * result.fps - 1e-9))
    mask = np.zeros((n, len(names)), dtype=bool)
    intervals: dict[str, tuple[PlannedInterval, ...]] = {}
    plants: dict[str, np.ndarray] = {}
    swings: dict[str, np.ndarray] = {}
    for col, name in enumerate(names):
        runs = [
            [carried_interval(r, f.frames) for r in c.intervals(name)] if name in c.joints else []
            for c, f in zip(found, feet, strict=True)
        ]
        runs = [[(max(0, s), min(n, e)) for s, e in rr if min(n, e) > max(0, s)] for rr in runs]
        planned = _planned(runs, wf, min_len, min_gap, n)
        if not planned:
            continue
        intervals[name] = planned
        for p in planned:
            mask[p.start : p.stop, col] = True
        j = result.skeleton.index(name)
        plants[name] = _plant_targets(planned, j, out_pos, feet, wf, floor, up)
        swings[name] = _swing_heights(planned, j, feet, wf, floor, up, n)
        sk = result.skeleton
        for e, parent in enumerate(sk.end_site_parents):
            if parent == j:  # the tip of a toe swings lowest
                swings[f"{name} end site"] = _swing_heights(planned, sk.n_joints + e, feet, wf, floor, up, n)
    speed = _planted_speed(plants, result.fps, up)
    if max_skating is not None and speed > max_skating * (1.0 + 1e-9):
        # the inputs' planted feet move more, blended, than the better input's own: scale their
        # motion about the plants' means down to it (a blend skates no more than its inputs)
        for name, planned in intervals.items():
            j = result.skeleton.index(name)
            plants[name] = _plant_targets(planned, j, out_pos, feet, wf, floor, up, max_skating / speed)
    for leg in find_legs(result)[0]:
        _rigid_feet(result.skeleton, leg, intervals, plants, out_pos, up)
        _foot_swings_only(result.skeleton, leg, mask, names, swings)
    ground = np.array([_ground(name, found, wf) for name in names])
    contacts = Contacts(
        tuple(names),
        np.array([result.skeleton.index(nm) for nm in names], dtype=np.int64),
        mask,
        float(np.mean(floor)),
        ground,
        float(result.fps),
        result.up_axis,
        options,
        (),
        _allowed_floor(feet, wf, floor, up) - float(np.mean(floor)),
    )
    return ContactPlan(contacts, intervals, plants, swings, floor)


def _planned(
    runs: Sequence[list[Interval]], wf: np.ndarray, min_len: int, min_gap: int, n: int
) -> tuple[PlannedInterval, ...]:
    """The output intervals of one joint's carried runs (module docstring)."""
    if not any(runs):
        return ()
    w_mean = wf.mean(axis=0)
    active = [k for k in range(len(runs)) if w_mean[k] > 0]
    groups = _joint_groups([runs[k] for k in active], w_mean[active])
    out: list[PlannedInterval] = []
    for g in groups:
        centre = int(np.clip(np.mean([0.5 * (m[0] + m[1]) for m in g if m is not None]), 0, n - 1))
        w = wf[centre, active]
        w = w / w.sum() if w.sum() > 0 else w
        # the inputs planted in the group, or at its centre (with more than two inputs the
        # stances of two that the reference lacks are groups of their own)
        members_w = sum(wi for wi, m in zip(w, g, strict=True) if m is not None)
        centre_w = sum(
            wi for wi, k in zip(w, active, strict=True) if any(a <= centre < b for a, b in runs[k])
        )
        if max(members_w, centre_w) <= MAJORITY:
            continue  # a stance of inputs that do not carry the blend: it swings (module docstring)
        s, e = _group_interval(g, w)
        start, stop = max(0, round(s)), min(n, round(e))
        if stop - start < min_len:
            continue
        members = tuple((active[i], m[0], m[1]) for i, m in enumerate(g) if m is not None)
        out.append(PlannedInterval(start, stop, members))
    out.sort(key=lambda p: p.start)
    merged: list[PlannedInterval] = []
    for p in out:
        if merged and p.start - merged[-1].stop < min_gap:
            last = merged[-1]
            merged[-1] = PlannedInterval(last.start, max(last.stop, p.stop), last.members + p.members)
        else:
            merged.append(p)
    return tuple(merged)


def _rigid_feet(
    sk: Skeleton,
    leg: LegChain,
    intervals: dict[str, tuple[PlannedInterval, ...]],
    plants: dict[str, np.ndarray],
    out_pos: np.ndarray,
    up: int,
) -> None:
    """Where a leg's ankle and toe are both planted and their targets turn the foot more than
    :data:`RIGID_TURN` from the blend's own (floor plane), the one of the shorter interval
    follows the other at the blend's own mean foot vector there (``plants`` changed in place):
    planned apart, the two targets of a foot disagreed with it by tens of degrees and the
    clean-up turned the ankle by 105 deg to join them (CMU 131_01 x 131_02, Euler + warp).
    Targets that agree with the foot are left (followed frame by frame, a toe slid with every
    roll of the blend's foot: its own contacts skated 1.37x the better input's, CMU 107_02 x
    108_01).

    The follower's correction is carried over the rest of its own planted interval (held
    beyond the overlaps, linear between two of them): made on the overlap only, it jumped
    where the overlap began, inside a plant (3.4 cm in one frame on CMU 107_02 x 108_01 whole,
    a planted heel sliding at 1 m/s)."""
    if leg.toe < 0:
        return
    ankle, toe = sk.names[leg.ankle], sk.names[leg.toe]
    if ankle not in intervals or toe not in intervals:
        return
    floor_axes = [a for a in range(3) if a != up]
    own = {ankle: out_pos[:, leg.ankle][:, floor_axes], toe: out_pos[:, leg.toe][:, floor_axes]}
    # (follower, its interval) -> the overlaps' corrections, from the targets as planned
    fixes: dict[tuple[str, int], list[tuple[int, int, np.ndarray]]] = {}
    for ia, pa in enumerate(intervals[ankle]):
        for it, pt in enumerate(intervals[toe]):
            a, b = max(pa.start, pt.start), min(pa.stop, pt.stop)
            if b <= a:
                continue
            lead, follow = (ankle, toe) if pa.stop - pa.start >= pt.stop - pt.start else (toe, ankle)
            vec = own[follow][a:b] - own[lead][a:b]
            planned = plants[follow][a:b, floor_axes] - plants[lead][a:b, floor_axes]
            cos = np.einsum("fi,fi->f", vec, planned) / np.maximum(
                np.linalg.norm(vec, axis=1) * np.linalg.norm(planned, axis=1), 1e-12
            )
            if np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))).max() <= RIGID_TURN:
                continue
            rigid = plants[lead][a:b, floor_axes] + vec.mean(axis=0)
            key = (follow, it if follow == toe else ia)
            fixes.setdefault(key, []).append((a, b, rigid - plants[follow][a:b, floor_axes]))
    for (follow, i), found in fixes.items():
        p = intervals[follow][i]
        frames = np.concatenate([np.arange(a, b) for a, b, _ in found])
        change = np.concatenate([c for _, _, c in found])
        order = np.argsort(frames, kind="stable")
        span = np.arange(p.start, p.stop)
        for axis, col in enumerate(floor_axes):
            plants[follow][p.start : p.stop, col] += np.interp(span, frames[order], change[order, axis])


def _foot_swings_only(
    sk: Skeleton, leg: LegChain, mask: np.ndarray, names: list[str], swings: dict[str, np.ndarray]
) -> None:
    """A joint of a foot has a least swing height only where the whole foot swings: not where
    the other joint of the foot is planted (a heel raised on a planted toe, a toe up on a
    planted heel: the plants and the foot's turn decide there). Asked there too, the ankle of
    a heel-off was lifted to the inputs' heel height on a leg the blend poses otherwise, and the
    knee bent 9 deg more than either input's (CMU 131_01 x 131_02, Euler + warp)."""
    joints = [j for j in (leg.ankle, leg.toe) if j >= 0 and sk.names[j] in names]
    for j in joints:
        others = [k for k in joints if k != j]
        if not others:
            continue
        other_planted = mask[:, names.index(sk.names[others[0]])]
        points = [sk.names[j]] + [
            f"{sk.names[j]} end site" for e, p in enumerate(sk.end_site_parents) if p == j
        ]
        for name in points:
            if name in swings:
                swings[name] = np.where(other_planted, np.nan, swings[name])


def _planted_speed(plants: dict[str, np.ndarray], fps: float, up: int) -> float:
    """Mean floor-plane speed (m/s) of the plant targets over their planted frame steps (as
    :func:`~elastic_motion.apps.metrics.contact_skating` measures a motion)."""
    speeds = []
    for p in plants.values():
        step = np.diff(p, axis=0)
        step[:, up] = 0.0
        v = np.linalg.norm(step, axis=1) * fps
        speeds.append(v[np.isfinite(v)])
    all_ = np.concatenate(speeds) if speeds else np.zeros(0)
    return float(all_.mean()) if all_.size else 0.0


def _ground(name: str, found: Sequence[Contacts], wf: np.ndarray) -> float:
    """The joint's ground height above the floor: the inputs' weighted (NaN: none touches)."""
    w = wf.mean(axis=0)
    vals = [(w[k], c.ground_height[c.joints.index(name)]) for k, c in enumerate(found) if name in c.joints]
    vals = [(wk, g) for wk, g in vals if np.isfinite(g) and wk > 0]
    total = sum(wk for wk, _ in vals)
    return float(sum(wk * g for wk, g in vals) / total) if total > 0 else float("nan")


def _plant_targets(
    planned: Sequence[PlannedInterval],
    joint: int,
    out_pos: np.ndarray,
    feet: Sequence[_InputFeet],
    wf: np.ndarray,
    floor: np.ndarray,
    up: int,
    motion: float = 1.0,
) -> np.ndarray:
    """A planted joint's targets ``(F, 3)`` (module docstring, "Plant targets"); NaN off plants.
    ``motion`` scales the inputs' floor-plane motion about their means (1: all of it)."""
    n = out_pos.shape[0]
    targets = np.full((n, 3), np.nan)
    horizontal = [a for a in range(3) if a != up]
    for p in planned:
        span = slice(p.start, p.stop)
        jitter = np.zeros((p.stop - p.start, 3))
        height = np.zeros(p.stop - p.start)
        weight = np.zeros(p.stop - p.start)
        frames = np.arange(p.start, p.stop)
        for k, a, b in p.members:
            # the input's joint while it is planted: held at its own interval's ends beyond them
            at = np.clip(frames, a, b - 1)
            pk = feet[k].positions[at, joint]
            jitter += wf[span, k, None] * (pk - pk.mean(axis=0))
            height += wf[span, k] * (pk[:, up] - feet[k].floor[at])
            weight += wf[span, k]
        own = out_pos[span, joint]
        targets[span, horizontal] = own[:, horizontal].mean(axis=0) + motion * jitter[:, horizontal]
        ground = floor[span] + height / np.where(weight > 0, weight, 1.0)
        # a planted foot goes to its inputs' heights, unless the blend holds it more than
        # MAX_PULL above them over most of the interval (a leg posed wrong higher up: an Euler
        # blend's hip, a foot still up where the plan plants it): then it keeps its own heights,
        # locked in the floor plane; pulled down, knees folded 60-90 deg and the root sank 6 cm
        # (CMU 131_01 x 131_02, Euler + warp). A hovering foot is pulled down: left a few
        # centimetres up, the blends' own contacts skated up to 1.37x the better input's
        floating = float(np.median(own[:, up] - ground)) > MAX_PULL
        targets[span, up] = np.maximum(ground, own[:, up]) if floating else ground
    return targets


def _swing_heights(
    planned: Sequence[PlannedInterval],
    joint: int,
    feet: Sequence[_InputFeet],
    wf: np.ndarray,
    floor: np.ndarray,
    up: int,
    n: int,
) -> np.ndarray:
    """The least heights ``(F,)`` of a joint swinging between two plants (module docstring,
    "Swing heights"); NaN elsewhere."""
    out = np.full(n, np.nan)
    # before the first plant and after the last: the inputs' heights at the same times
    for a, b in ((0, planned[0].start), (planned[-1].stop, n)):
        if b > a:
            heights = sum(
                wf[a:b, k] * (f.positions[a:b, joint, up] - f.floor[a:b]) for k, f in enumerate(feet)
            )
            out[a:b] = floor[a:b] + heights / wf[a:b].sum(axis=1)
    for before, after in itertools.pairwise(planned):
        a, b = before.stop, after.start
        if b <= a:
            continue
        phase = (np.arange(a, b) - a + 0.5) / (b - a)
        total = np.zeros(b - a)
        weight = np.zeros(b - a)
        for k in sorted({m[0] for m in before.members} & {m[0] for m in after.members}):
            lift = max(m[2] for m in before.members if m[0] == k)
            strike = min(m[1] for m in after.members if m[0] == k)
            if strike <= lift:
                continue  # this input does not swing here (a split stance)
            at = lift + phase * (strike - lift)  # the input's own swing at the same phase
            i = np.clip(np.floor(at).astype(int), 0, n - 1)
            heights = feet[k].positions[i, joint, up] - feet[k].floor[i]
            total += wf[a:b, k] * heights
            weight += wf[a:b, k]
        has = weight > 0
        out[a:b] = np.where(has, floor[a:b] + total / np.where(has, weight, 1.0), np.nan)
    return out


def plan_mask(plan: ContactPlan, name: str) -> np.ndarray:
    """The planted frames of joint ``name`` ``(F,)`` (all False when it never plants)."""
    c = plan.contacts
    if name not in c.joints:
        return np.zeros(c.n_frames, dtype=bool)
    return c.mask[:, c.joints.index(name)]


def steadier(plan: ContactPlan, factor: float) -> ContactPlan:
    """The plan with its plants' floor-plane motion about each planted interval's mean scaled
    by ``factor`` in [0, 1] (0: each foot locked at one point for the interval; heights kept).

    The plants carry what the inputs' planted feet do, capped on average at the better input's
    skating (:func:`plan_contacts`); the blend measured on itself sees more (its own contacts
    begin and end where its feet arrive and leave, not where the plan's do) and skated 1.35x
    the better input on DeepMimic walk x run. A steadier plan is what is left to plant then
    (:func:`~elastic_motion.apps.blend.contacts.plant_plan`)."""
    if not 0.0 <= factor <= 1.0:
        raise ValueError(f"factor: expected a fraction in [0, 1]; got {factor!r}")
    if factor == 1.0:
        return plan
    up = _AXES.index(plan.contacts.up_axis)
    horizontal = [a for a in range(3) if a != up]
    plants = {}
    for name, target in plan.plants.items():
        t = target.copy()
        for p in plan.intervals.get(name, ()):
            span = t[p.start : p.stop][:, horizontal]
            mean = np.nanmean(span, axis=0) if np.isfinite(span).any() else np.zeros(len(horizontal))
            t[p.start : p.stop, horizontal] = mean + factor * (span - mean)
        plants[name] = t
    return ContactPlan(plan.contacts, plan.intervals, plants, plan.swing_heights, plan.floor)


def at_ends(plan: ContactPlan, result: Motion, legs: Sequence[LegChain] | None = None) -> ContactPlan:
    """The plan with each planted interval's floor position moved from the blend's own mean
    over the interval (module docstring, "Plant targets") to the middle of where the blend puts
    the joint on the interval's first and last frames (``result``: the blend the plan was made
    for; heights and the plants' motion about their position kept).

    Inside a plant the clean-up's correction is ``plant - own``; where the blend's foot still
    moves at a plant's start or end (it arrives late or leaves early), the mean stands far
    from it there and the correction eases in or out of that jump within the clean-up's
    ``blend_time``: a change of the blend's velocities, what the elastic distance measures.
    The middle of the two ends halves the larger jump. Tried by
    :func:`~elastic_motion.apps.blend.contacts.plant_plan` next to the plan itself, which keeps
    the one that changes the blend less (CMU 131_01 x 131_02: the planted blend's fine distance
    to 131_02 1.11 -> 1.096 of ``d(A, B) / 2``; Bandai normal x old is nearer with the means).
    ``legs``: ``result``'s (default :func:`~elastic_motion.apps.cleanup.find_legs`)."""
    up = _AXES.index(plan.contacts.up_axis)
    horizontal = [a for a in range(3) if a != up]
    scale = result.metres_per_unit if result.metres_per_unit is not None else 1.0
    pos = forward_kinematics(result) * scale
    plants = {}
    for name, target in plan.plants.items():
        t = target.copy()
        own = pos[:, result.skeleton.index(name)][:, horizontal]
        for p in plan.intervals.get(name, ()):
            span = own[p.start : p.stop]
            t[p.start : p.stop, horizontal] += 0.5 * (span[0] + span[-1]) - span.mean(axis=0)
        plants[name] = t
    # moved apart, the ankle's and toe's plants of one foot can turn it (70 deg at an ankle of an
    # Euler blend of CMU 131_01 x 131_02): a foot is made rigid again as the plan makes it
    for leg in find_legs(result)[0] if legs is None else legs:
        _rigid_feet(result.skeleton, leg, dict(plan.intervals), plants, pos, up)
    return ContactPlan(plan.contacts, plan.intervals, plants, plan.swing_heights, plan.floor)


def on_own_floor(plan: ContactPlan, own_floor: np.ndarray, below: float) -> ContactPlan:
    """The plan with no point allowed more than ``below`` (metres) under the floor its planted
    blend stands on, where that floor is above the plan's.

    The floor of a motion is where its lowest point stays only 2 % of the frames
    (:func:`~elastic_motion.motion.contacts.floor_height`): an input's can be set by one
    stance where a toe dips lower than in the others (CMU 131_01 and 131_02: one stance each,
    4-5 cm under the lowest point of the rest). Their blend meets each dip at half its depth,
    at another time, and its own floor, found the same way (``own_floor`` ``(F,)``, metres:
    the planted blend's, :func:`~elastic_motion.apps.metrics.floor.foot_quality`), stands
    higher than the blended floor (3.6 cm on 131_01 x 131_02): a half dip went 1.45 cm under
    it. Unchanged where the two floors agree (a blend of a motion with itself). (The swings'
    least heights stay on the plan's floor: raised by the difference too, they did not clear
    the swings measured low on 131_01 x 131_02, which the plan then planted (a stance of one
    input alone, now swung: module docstring, "Output interval"), and the Euler blend's
    clean-up turned a joint 45 deg instead of 32.)"""
    floor = plan.floor_heights()
    lift = np.maximum(np.asarray(own_floor, dtype=np.float64) - floor, 0.0)
    c = plan.contacts
    allowed = np.maximum(c.floor_heights(), floor + lift - below)
    contacts = replace(c, floor_offset=allowed - c.floor)
    return ContactPlan(contacts, plan.intervals, plan.plants, plan.swing_heights, plan.floor)
