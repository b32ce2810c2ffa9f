"""Foot-skate clean-up of a blend: the inputs' contacts carried through the warps, then
enforced by inverse kinematics.

In the spirit of Kovar, Schreiner and Gleicher (2002):

1. **Carried contacts** (:func:`carry_contacts`). Output frame ``f`` of a blend has curve
   parameter ``u_f`` (:attr:`BlendResult.timing`), i.e. time ``d_k phi_k(u_f)`` in input
   ``k``; the input's contact mask at its nearest frame *votes* with the input's weight.
   A joint is planted in ``f`` when the inputs planted there hold more than half of the
   weight (two inputs at 50 %: both must agree). Runs shorter than the contact options'
   ``min_duration`` are dropped. The floor and each joint's ground height are the weighted
   means of the inputs'.
2. **Plants** (:func:`cleanup_footskate`). Each contact run of an ankle (toe) joint gets one
   plant position: the mean of the joint's positions in the blend over the run; where ankle
   and toe are both planted, the two plants are a rigid foot's (the joint with the longer run
   keeps its mean, the other's plant sits at the blend's own mean floor vector of the foot from
   it: ``_rigid_foot_plants``). The ankle's
   correction ``delta(f)`` is ``plant - ankle`` where the ankle is planted, ``plant_toe -
   toe`` where only the toe is (the foot moves rigidly, heel off), and eases to 0 within
   ``blend_time`` (default 0.15 s) outside the contacts (smoothstep weights; two nearby
   contacts share the gap). A plant below the floor plus the joint's ground height is
   raised to it. Where a point of the foot would go below the floor the ankle is raised, the
   raise eased in and out over the same ``blend_time``
   (:func:`elastic_motion.motion.edit.eased_envelope`: a raise of a single frame would jerk
   the knee of a nearly straight leg by tens of degrees); so is, by default, the raise that
   keeps a swinging foot at its least height (``swing_heights``, a blend's contact plan;
   ``ease_swing``).
3. **IK** (:mod:`elastic_motion.motion.ik`): a smooth root offset brings every target
   within reach, two-bone leg IK moves the ankles to ``ankle + delta`` (the foot keeps its
   global orientation), and where ankle and toe are both planted the foot turns about the
   ankle to put the toe on its plant (the turn also eased in and out). Bone lengths are
   kept: only rotations of hip, knee and ankle joints and the root translation change.
   The knee bends one way: a blended knee bent slightly backwards is straightened through 0,
   not mirrored (:func:`elastic_motion.motion.ik.two_bone_ik` with the knee's hinge axis).
   The last lift (no point of a foot below the floor after the smoothing) is eased likewise.

Legs are found by name (:func:`elastic_motion.apps.landmarks.find_leg_joints`); contacts of
other joints (hands) are measured but not enforced (a note says so), unless their arms are
passed as ``legs`` (:func:`find_arms`: shoulder, elbow, hand; a loop's planted hands). Lengths are in the
motion's unit (metres after :mod:`elastic_motion.apps.prepare`).

:func:`cleanup_footskate` takes one :class:`CleanupOptions` (or keyword overrides of its
fields: ``cleanup_footskate(m, c, smooth=0.0)``) and runs its stages in order: the vertical
settle, each leg's target (:func:`plant_targets`), the IK (root correction, legs, toe
turns, smoothing of the change), the last lift out of the floor, the fixed frames, the
measures.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from elastic_motion._options import with_overrides
from elastic_motion.apps.landmarks import find_leg_joints
from elastic_motion.apps.metrics import ContactSkating, contact_skating
from elastic_motion.errors import OptionError
from elastic_motion.groups import SO3
from elastic_motion.motion import Motion, Skeleton
from elastic_motion.motion.contacts import ContactOptions, Contacts, close_gaps, mask_runs
from elastic_motion.motion.edit import (
    eased_envelope,
    fade_change,
    fixed_frames_weight,
    gaussian_frames,
    smooth_change,
    smoothstep,
)
from elastic_motion.motion.ik import (
    LegChain,
    leg_chain,
    root_correction,
    rotation_between,
    solve_legs,
    turn_joint,
)
from elastic_motion.motion.kinematics import forward_kinematics, joint_positions_and_rotations
from elastic_motion.notes import Note, note_texts

__all__ = [
    "NOTE_LEGS",
    "NOTE_SKIPPED",
    "NOTE_UNENFORCED",
    "SETTLE_BELOW",
    "CleanupOptions",
    "CleanupResult",
    "carry_contacts",
    "cleanup_footskate",
    "find_arms",
    "find_legs",
    "plant_targets",
    "settle_offset",
]

_SO3 = SO3()
_AXES = "xyz"
#: Ankle corrections below this fraction of the leg's length (a micrometre) are not made.
_STILL = 1e-6
#: Metres: the vertical settle never puts a planted ankle or toe more than this under its
#: ground height (:func:`settle_offset`).
SETTLE_BELOW = 0.01
#: A leg that could not be used (no hip, knee and ankle found by name; a bad chain).
NOTE_LEGS = "cleanup.legs"
#: Contacts of joints without IK (hands without ``legs=``): measured, not enforced.
NOTE_UNENFORCED = "cleanup.unenforced"
#: Nothing to enforce: no contact of the legs' ankle or toe joints.
NOTE_SKIPPED = "cleanup.skipped"


@dataclass(frozen=True)
class CleanupOptions:
    """How :func:`cleanup_footskate` enforces contacts.

    Attributes
    ----------
    blend_time : float, default 0.15
        Seconds over which a correction eases in before and out after a contact (and a raise
        out of the floor); the root correction is smoothed over half of it. Must be >= 0.
    smooth : float, default 0.05
        Standard deviation (seconds) of a Gaussian that smooths the change the clean-up
        makes (the root offset and each joint's rotation change ``log(R^T R')``) in time;
        0 keeps the exact plants. Smoothing trades a little skating for a smaller change of
        the motion's velocities (which the elastic distance measures). Must be >= 0.
    strength : float, default 1.0
        Fraction in [0, 1] of the way from the feet to their plants (the ankle's correction
        and the foot's turn are scaled by it): less leaves part of the skating and changes
        the motion less. The floor is enforced in full whatever the fraction.
    knee_hinge : bool, default True
        As ``hinge`` of :func:`elastic_motion.motion.ik.solve_legs`: False keeps each frame's
        own knee plane (small corrections of a motion whose knees are right, e.g. a loop's).
    settle : float or tuple of float, default 0
        Seconds; when positive, first a slow vertical root offset puts the planted ankles and
        toes at their ground heights (:func:`settle_offset`, Gaussian of this standard
        deviation): a motion whose feet sink into the floor or float above it is moved as a
        whole, which its legs' angles and the elastic distance do not see, instead of bending
        every stance leg by IK. 0: none (the plants' heights are then reached by the IK). An
        array (kept as a tuple): that offset per frame (motion's unit), e.g.
        :func:`settle_offset` computed once for several calls. Applied in full whatever
        ``strength`` (like the floor).
    ease_swing : bool, default True
        A swing's least height (``swing_heights`` of :func:`cleanup_footskate`) is reached by
        a raise eased in and out over ``blend_time``; False: raised only where the foot swings
        too low, not eased (it may jump where a plan releases the foot: the clean-up before
        issue 29's distance row).
    """

    blend_time: float = 0.15
    smooth: float = 0.05
    strength: float = 1.0
    knee_hinge: bool = True
    settle: float | tuple[float, ...] = 0.0
    ease_swing: bool = True

    def __post_init__(self) -> None:
        for name in ("blend_time", "smooth"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
                raise OptionError(name, f"expected seconds >= 0; got {value!r}")
            if not (math.isfinite(value) and value >= 0):
                raise OptionError(name, f"expected seconds >= 0; got {value!r}")
        if not (0.0 <= self.strength <= 1.0):
            raise OptionError("strength", f"expected a fraction in [0, 1]; got {self.strength!r}")
        for name in ("knee_hinge", "ease_swing"):
            if not isinstance(getattr(self, name), bool | np.bool_):
                raise OptionError(name, f"expected True or False; got {getattr(self, name)!r}")
        object.__setattr__(self, "settle", _settle_option(self.settle))

    def replace(self, **changes: Any) -> CleanupOptions:
        """A copy with some fields changed (validated again)."""
        return replace(self, **changes)


def _settle_option(settle: Any) -> float | tuple[float, ...]:
    """The ``settle`` option: seconds (a number >= 0) or finite offsets, one a frame (a tuple)."""
    if np.ndim(settle) > 0:
        offsets = np.asarray(settle, dtype=np.float64)
        if offsets.ndim != 1 or not np.isfinite(offsets).all():
            raise OptionError("settle", f"expected finite offsets, one a frame; got shape {offsets.shape}")
        return tuple(offsets.tolist())
    if (
        isinstance(settle, bool)  # True is not "1 s"
        or not isinstance(settle, int | float | np.integer | np.floating)
        or not (np.isfinite(settle) and settle >= 0)
    ):
        raise OptionError("settle", f"expected seconds >= 0 or an offset per frame; got {settle!r}")
    return settle


def carry_contacts(
    contacts: Sequence[Contacts],
    warps: Sequence[np.ndarray],
    timing: np.ndarray,
    durations: Sequence[float],
    weights: Sequence[float],
    *,
    fps: float,
    joints: Sequence[str] | None = None,
    options: ContactOptions | None = None,
) -> Contacts:
    """The inputs' contacts carried to a blend's frames (module docstring, step 1).

    Parameters
    ----------
    contacts : sequence of Contacts
        One per input (each on its input's frames).
    warps : sequence of ndarray, shape (V, 2)
        ``phi_k``: the result's parameter -> input ``k``'s (vertices).
    timing : ndarray, shape (F,)
        Curve parameter of each output frame.
    durations : sequence of float
        Inputs' durations (s).
    weights : array_like, shape (K,) or (F, K)
        Blend weights (sum 1), or per output frame (a weight curve).
    fps : float
        The output's frame rate.
    joints : sequence of str, optional
        Joints of the result (default: every joint in any input's contacts).
    options : ContactOptions, optional
        ``min_duration`` and ``min_gap`` of the carried runs (default the first input's).

    Returns
    -------
    Contacts
        On the output frames.
    """
    u = np.asarray(timing, dtype=np.float64)
    w = np.asarray(weights, dtype=np.float64)
    wf = np.broadcast_to(w, (u.shape[0], len(contacts))) if w.ndim == 1 else w
    names: list[str] = []
    for c in contacts:
        for n in c.joints:
            if n not in names and (joints is None or n in joints):
                names.append(n)
    f = u.shape[0]
    vote = np.zeros((f, len(names)))
    ground = np.zeros(len(names))
    gw = np.zeros(len(names))
    # a floor that is not level goes with the frames it is under (each input's at its warped frame)
    offset = np.zeros(f) if any(c.floor_offset is not None for c in contacts) else None
    for i, (c, v, d) in enumerate(zip(contacts, warps, durations, strict=True)):
        wk = wf[:, i]
        t = np.interp(u, v[:, 0], v[:, 1]) * d
        idx = np.clip(np.rint(t * c.fps).astype(int), 0, c.n_frames - 1)
        if offset is not None and c.floor_offset is not None:
            offset += wk * np.asarray(c.floor_offset)[idx]
        for j, n in enumerate(names):
            if n in c.joints:
                k = c.joints.index(n)
                vote[:, j] += wk * c.mask[idx, k]
                if np.isfinite(c.ground_height[k]):
                    ground[j] += wk.mean() * c.ground_height[k]
                    gw[j] += wk.mean()
    mask = vote > 0.5 + 1e-9
    opts = options or contacts[0].options
    min_len = max(1, math.ceil(opts.min_duration * fps - 1e-9))
    min_gap = max(1, math.ceil(opts.min_gap * fps - 1e-9))
    for j in range(mask.shape[1]):
        mask[:, j] = close_gaps(mask[:, j], min_len, min_gap)
    floor = float(np.dot(wf.mean(axis=0), [c.floor for c in contacts]))
    ground_out = np.where(gw > 0, ground / np.where(gw > 0, gw, 1.0), np.nan)
    return Contacts(
        tuple(names),
        np.zeros(len(names), dtype=np.int64) - 1,
        mask,
        floor,
        ground_out,
        float(fps),
        contacts[0].up_axis,
        opts,
        ("carried from the inputs through the warps (weighted vote > 1/2)",),
        offset,
    )


def find_legs(motion: Motion) -> tuple[list[LegChain], list[str]]:
    """The two legs of a skeleton by name (:func:`~elastic_motion.apps.landmarks.find_leg_joints`).

    Returns
    -------
    legs : list of LegChain
        Zero, one or two.
    notes : list of str
        Legs that could not be used, and why.
    """
    sk = motion.skeleton
    lj = find_leg_joints(sk)
    legs, notes = [], []
    for side in ("left", "right"):
        p = lj.side(side)
        if p["hip"] is None or p["knee"] is None or p["ankle"] is None:
            notes.append(f"{side} leg: no hip, knee and ankle joints found by name")
            continue
        toe = (
            p["toe"]
            if p["toe"] is not None and sk.parents[sk.index(p["toe"])] == sk.index(p["ankle"])
            else None
        )
        try:
            legs.append(leg_chain(sk, p["hip"], p["knee"], p["ankle"], toe))
        except ValueError as e:
            notes.append(f"{side} leg: {e}")
    return legs, notes


_ELBOW = re.compile(r"forearm|lowerarm|elbow|radius", re.IGNORECASE)


def find_arms(motion: Motion, hands: Sequence[str]) -> list[LegChain]:
    """Two-bone chains ``shoulder -> elbow -> hand`` ending at the given contact joints.

    A hand joint qualifies when its parent is named like an elbow (``forearm``, ``lowerarm``,
    ``elbow``, ``radius``: CMU ``LeftForeArm``, ASF ``lradius``); the chain's "hip" is the
    elbow's parent. The clean-up moves them like legs (:func:`cleanup_footskate` with
    ``legs=``), without a toe.

    Returns
    -------
    list of LegChain
        One per qualifying hand, in the order given.
    """
    sk = motion.skeleton
    out = []
    for name in hands:
        if name not in sk.names:
            continue
        hand = sk.index(name)
        elbow = sk.parents[hand]
        if elbow > 0 and _ELBOW.search(sk.names[elbow]) and sk.parents[elbow] >= 0:
            out.append(LegChain(int(sk.parents[elbow]), int(elbow), hand))
    return out


@dataclass(frozen=True, eq=False)
class CleanupResult:
    """The outcome of :func:`cleanup_footskate`.

    Attributes
    ----------
    motion : Motion
        The cleaned motion (the input unchanged when nothing was done).
    contacts : Contacts
        What was enforced.
    skating_before, skating_after : ContactSkating
        :func:`~elastic_motion.apps.metrics.contact_skating` of the motion before and after,
        against ``contacts``.
    max_position_change : float
        Largest displacement of a joint or end site over frames (metres, or the motion's unit).
    max_rotation_change_deg : float
        Largest change of a joint's local rotation (degrees).
    max_root_offset : float
        Largest root correction (metres, or the motion's unit).
    legs : tuple of str
        The ankle joints of the legs used.
    applied : bool
        False when there was nothing to enforce (no contacts, no legs).
    notes : tuple of Note
        Legs that could not be used (``NOTE_LEGS``), contacts measured but not enforced
        (``NOTE_UNENFORCED``), why nothing was done (``NOTE_SKIPPED``).
    smooth : float
        The smoothing of the change used (seconds, :func:`cleanup_footskate`).
    strength : float
        The fraction of the way to the plants (:func:`cleanup_footskate`).
    settle_offset : float
        Largest vertical root offset of the settling step (signed, metres; 0 when off:
        :func:`settle_offset`).
    """

    motion: Motion
    contacts: Contacts
    skating_before: ContactSkating
    skating_after: ContactSkating
    max_position_change: float
    max_rotation_change_deg: float
    max_root_offset: float
    legs: tuple[str, ...]
    applied: bool
    notes: tuple[Note, ...] = field(default=())
    smooth: float = 0.0
    strength: float = 1.0
    settle_offset: float = 0.0

    def summary(self) -> dict[str, Any]:
        """JSON-ready (speeds in m/s, lengths in m)."""
        return {
            "applied": self.applied,
            "legs": list(self.legs),
            "skating_before": self.skating_before.summary(),
            "skating_after": self.skating_after.summary(),
            "max_position_change_m": self.max_position_change,
            "max_rotation_change_deg": self.max_rotation_change_deg,
            "max_root_offset_m": self.max_root_offset,
            "smooth_s": self.smooth,
            "strength": self.strength,
            "settle_offset_m": self.settle_offset,
            "contacts": self.contacts.summary(),
            "notes": note_texts(self.notes),
        }


def _ease(values: np.ndarray, known: np.ndarray, width: int) -> np.ndarray:
    """``values`` where ``known``; elsewhere eased to 0 within ``width`` frames of the nearest
    known frames on either side (smoothstep weights, normalised when they sum above 1)."""
    f = known.shape[0]
    out = np.zeros_like(values)
    if not known.any():
        return out
    idx = np.arange(f)
    prev = np.maximum.accumulate(np.where(known, idx, -1))
    nxt = np.minimum.accumulate(np.where(known, idx, f)[::-1])[::-1]
    wl = np.where(prev >= 0, smoothstep(1.0 - (idx - prev) / (width + 1.0)), 0.0)
    wr = np.where(nxt < f, smoothstep(1.0 - (nxt - idx) / (width + 1.0)), 0.0)
    vl = values[np.clip(prev, 0, f - 1)]
    vr = values[np.clip(nxt, 0, f - 1)]
    s = wl + wr
    scale = np.where(s > 1.0, 1.0 / np.where(s > 0, s, 1.0), 1.0)
    shape = (-1,) + (1,) * (values.ndim - 1)
    eased = (wl.reshape(shape) * vl + wr.reshape(shape) * vr) * scale.reshape(shape)
    out = np.where(known.reshape(shape), values, eased)
    return out


def _foot_low(pos_all: np.ndarray, sk, ankle: int, up: int) -> np.ndarray:
    """Lowest height per frame of the ankle, the joints under it and their end sites ``(F,)``."""
    sub = sk.subtree(ankle)
    sites = [sk.n_joints + e for e, p in enumerate(sk.end_site_parents) if p in sub]
    return pos_all[:, sub + sites, up].min(axis=1)


def _plants(p: np.ndarray, mask: np.ndarray, min_height: np.ndarray | None, up: int) -> np.ndarray:
    """Per frame, the plant of the run it is in: the mean floor position over the run, the
    joint's own height (at least ``min_height``, per frame); NaN elsewhere."""
    out = np.full_like(p, np.nan)
    for a, b in mask_runs(mask):
        plant = p[a:b].mean(axis=0)
        out[a:b] = plant
        # the height is the joint's own (a heel rises before the toe lifts): only the floor
        # position is planted, and the height kept at least the joint's ground height
        h = p[a:b, up]
        out[a:b, up] = h if min_height is None else np.maximum(h, min_height[a:b])
    return out


def _rigid_foot_plants(
    pa: np.ndarray,
    plant_a: np.ndarray,
    ma: np.ndarray,
    pt: np.ndarray,
    plant_t: np.ndarray,
    mt: np.ndarray,
    up: int,
) -> None:
    """Make the ankle's and the toe's plants (``(F, 3)`` each, changed in place) agree with a
    rigid foot where both are planted.

    Each stretch of frames with both planted lies in one run of each joint; the joint with the
    longer run leads (its plant stays the mean over its run) and the other's plant, over its
    whole run, is put at the foot's own mean floor vector over the stretch from the leader's
    (a run that follows over several stretches: over the longest).
    Only floor coordinates move (plant heights are the joints' own). Without this, the two
    means of a foot that skated in a carried contact (the toe 46 cm while the ankle was planted
    for a third of it, in an Euler blend of CMU 131_01 x 131_02) disagree and the turn about
    the ankle that joins them twists the foot by tens of degrees (67 there).
    """
    floor_axes = [i for i in range(3) if i != up]
    runs_a, runs_t = mask_runs(ma), mask_runs(mt)
    # per following run, the stretch it shares most with its leader (a short toe contact
    # bridging two heel contacts follows the longer overlap, not whichever came last)
    follow: dict[tuple[str, tuple[int, int]], tuple[int, np.ndarray]] = {}
    for a, b in mask_runs(ma & mt):
        ra = next(r for r in runs_a if r[0] <= a < r[1])
        rt = next(r for r in runs_t if r[0] <= a < r[1])
        vec = (pt[a:b] - pa[a:b]).mean(axis=0)[floor_axes]
        if rt[1] - rt[0] >= ra[1] - ra[0]:
            key, target = ("ankle", ra), plant_t[a, floor_axes] - vec
        else:
            key, target = ("toe", rt), plant_a[a, floor_axes] + vec
        if key not in follow or b - a > follow[key][0]:
            follow[key] = (b - a, target)
    for (joint, (lo, hi)), (_, target) in follow.items():
        (plant_a if joint == "ankle" else plant_t)[lo:hi, floor_axes] = target


def settle_offset(
    motion: Motion,
    contacts: Contacts,
    legs: Sequence[LegChain],
    *,
    sigma: float,
    lower: np.ndarray | None = None,
    upper: np.ndarray | None = None,
) -> np.ndarray:
    """Vertical root offset ``(F,)`` (motion's unit) that puts the planted ankles and toes of
    ``legs`` at their ground heights (``contacts.floor_heights() + contacts.ground_height``), as slowly
    as ``sigma`` allows.

    On each frame with a planted joint of known ground height the offset is the mean of
    ``ground - height`` over those joints; between such frames it is interpolated linearly
    (held at the ends); then, kept within its bounds, smoothed by a Gaussian of standard
    deviation ``sigma`` seconds. A slow vertical translation of the whole body changes no
    joint angle and the root's velocity by little (its SRV distance to the motion is small),
    where lifting each stance foot by IK bends the knees.

    **Bounds** (per frame, the motion's unit): ``upper`` and ``lower`` when given, and never
    so low that a planted joint goes more than :data:`SETTLE_BELOW` (metres) under its ground
    height. The lower ones hold exactly on the result: where the smoothed offset crosses
    one, the difference is added back eased in and out over ``sigma``
    (:func:`~elastic_motion.motion.edit.eased_envelope`), so the offset stays slow; ``upper``
    likewise, except within that easing of frames where the floor bound lies above it (the
    floor wins). (Without
    the floor bound, a foot that a blend holds decimetres above the floor in a carried
    contact pulled the body down by half of that, and the other stance knee, planted on the
    floor, folded by 25-47 deg to stay out of it: Euler blends of CMU 131_01's crouch.) Zeros
    when no planted joint has a ground height.
    """
    if not (np.isfinite(sigma) and sigma >= 0):
        raise ValueError(f"sigma: expected seconds >= 0; got {sigma!r}")
    sk = motion.skeleton
    up = _AXES.index(motion.up_axis)
    pos, _ = joint_positions_and_rotations(sk.parents, motion.local_translations(), motion.rotations)
    total = np.zeros(motion.n_frames)
    count = np.zeros(motion.n_frames)
    highest = np.full(motion.n_frames, -np.inf)  # the least a planted joint allows down
    floor = contacts.floor_heights()
    for leg in legs:
        for j in (leg.ankle, leg.toe):
            if j < 0 or sk.names[j] not in contacts.joints:
                continue
            k = contacts.joints.index(sk.names[j])
            g = contacts.ground_height[k]
            m = contacts.mask[:, k]
            if not np.isfinite(g) or not m.any():
                continue
            gap = floor[m] + g - pos[m, j, up]
            total[m] += gap
            count[m] += 1
            highest[m] = np.maximum(highest[m], gap)
    known = count > 0
    if not known.any():
        return np.zeros(motion.n_frames)
    frames = np.arange(motion.n_frames)
    unit = motion.metres_per_unit if motion.metres_per_unit is not None else 1.0
    need = np.interp(frames, frames[known], total[known] / count[known])
    floor_bound = np.where(known, highest - SETTLE_BELOW / unit, -np.inf)
    lo = floor_bound if lower is None else np.maximum(floor_bound, np.asarray(lower, dtype=np.float64))
    hi = np.full(motion.n_frames, np.inf) if upper is None else np.asarray(upper, dtype=np.float64)
    hi = np.maximum(hi, floor_bound)  # the floor wins
    width = max(1, round(sigma * motion.fps))
    out = gaussian_frames(np.clip(need, lo, hi), sigma * motion.fps)
    out -= eased_envelope(np.maximum(out - hi, 0.0), width)
    return out + eased_envelope(np.maximum(lo - out, 0.0), width)


def _given(plants: Mapping[str, np.ndarray], name: str, p: np.ndarray) -> np.ndarray | None:
    """A joint's given plants ``(F, 3)``, its own position ``p`` where a coordinate is NaN."""
    if name not in plants:
        return None
    given = np.asarray(plants[name], dtype=np.float64)
    if given.shape != p.shape:
        raise ValueError(f"plants[{name!r}]: expected shape {p.shape}; got {given.shape}")
    return np.where(np.isnan(given), p, given)


@dataclass(frozen=True, eq=False)
class _Feet:
    """A motion's joints and end sites before the IK, and the contacts its feet are planted by.

    ``pos`` ``(F, J, 3)`` joint positions, ``points`` ``(F, J + E, 3)`` joints and end sites,
    ``up`` the up axis's coordinate, ``floor`` ``(F,)`` the floor under each frame, ``width``
    the frames a correction eases in and out over.
    """

    skeleton: Skeleton
    contacts: Contacts
    pos: np.ndarray
    points: np.ndarray
    up: int
    floor: np.ndarray
    width: int

    @classmethod
    def of(cls, motion: Motion, contacts: Contacts, blend_time: float) -> _Feet:
        pos, _ = joint_positions_and_rotations(
            motion.skeleton.parents, motion.local_translations(), motion.rotations
        )
        return cls(
            motion.skeleton,
            contacts,
            pos,
            forward_kinematics(motion, end_sites=True),
            _AXES.index(motion.up_axis),
            contacts.floor_heights(),  # (F,): a floor that is not level, frame by frame
            max(1, round(blend_time * motion.fps)),
        )

    def column(self, j: int) -> tuple[np.ndarray, np.ndarray | None]:
        """Joint ``j``'s contact mask ``(F,)`` and its ground height per frame (None unknown)."""
        c = self.contacts
        if j < 0 or self.skeleton.names[j] not in c.joints:
            return np.zeros(self.floor.shape[0], dtype=bool), None
        k = c.joints.index(self.skeleton.names[j])
        g = c.ground_height[k]
        return c.mask[:, k], (self.floor + g) if np.isfinite(g) else None

    def low(self, ankle: int) -> np.ndarray:
        """Lowest height per frame of the foot below ``ankle`` ``(F,)``."""
        return _foot_low(self.points, self.skeleton, ankle, self.up)

    def plant_positions(
        self, plants: Mapping[str, np.ndarray] | None, j: int, mask: np.ndarray, ground: np.ndarray | None
    ) -> np.ndarray:
        """Joint ``j``'s plants ``(F, 3)``: the given ones, else the mean over each run."""
        p = self.pos[:, j]
        given = _given(plants, self.skeleton.names[j], p) if plants else None
        return _plants(p, mask, ground, self.up) if given is None else given


def _out_of_floor_target(leg: LegChain, feet: _Feet) -> np.ndarray | None:
    """A leg without contacts: its ankle raised where the foot is under the floor (None: never)."""
    under = feet.floor - feet.low(leg.ankle)
    if not (under > 0).any():
        return None
    tgt = np.full((under.shape[0], 3), np.nan)
    tgt[under > 0] = feet.pos[under > 0, leg.ankle]
    tgt[under > 0, feet.up] += under[under > 0]
    return tgt


def _foot_turn(
    pa: np.ndarray, plant_a: np.ndarray, pt: np.ndarray, plant_t: np.ndarray, both: np.ndarray, ease: int
) -> np.ndarray:
    """The foot's turn about the ankle ``(F, 3)`` (rotation vectors): where ankle and toe are
    both planted it takes ``toe - ankle`` to ``plant_toe - plant_ankle``; eased over ``ease``
    frames into the heel-off (toe only) and swing frames."""
    vec = np.zeros_like(pa)
    if both.any():
        vec[both] = _SO3.log(rotation_between(pt[both] - pa[both], plant_t[both] - plant_a[both]))
    return _ease(vec, both, ease)


def _swing_raise(
    leg: LegChain, feet: _Feet, delta_up: np.ndarray, heights: Mapping[str, np.ndarray]
) -> np.ndarray:
    """How much to raise the ankle ``(F,)`` so that each point of the foot with a least height
    (``heights``: per ankle or toe joint or ``"<joint> end site"``, absolute, NaN where none;
    a contact plan's swings) is at least that high, after the raise ``delta_up`` planned."""
    sk = feet.skeleton
    points = [(sk.names[j], j) for j in (leg.ankle, leg.toe) if j >= 0]
    points += [
        (f"{sk.names[p]} end site", sk.n_joints + e)
        for e, p in enumerate(sk.end_site_parents)
        if p in (leg.ankle, leg.toe)
    ]
    need = np.zeros_like(delta_up)
    for name, i in points:
        if name not in heights:
            continue
        least = np.asarray(heights[name], dtype=np.float64)
        if least.shape != delta_up.shape:
            raise ValueError(f"swing_heights[{name!r}]: expected shape {delta_up.shape}; got {least.shape}")
        deficit = least - (feet.points[:, i, feet.up] + delta_up)
        need = np.maximum(need, np.where(np.isnan(deficit), 0.0, deficit))
    return need


def _planted_target(
    leg: LegChain,
    feet: _Feet,
    plants: Mapping[str, np.ndarray] | None,
    strength: float,
    swing_heights: Mapping[str, np.ndarray] | None = None,
    ease_swing: bool = True,
) -> tuple[np.ndarray, np.ndarray | None]:
    """A planted leg's ankle targets ``(F, 3)`` (NaN: stays) and its foot's turn ``(F, 3, 3)``
    (None without toe contacts): module docstring, step 2; with ``swing_heights``, the ankle
    raised where a joint of the foot swings lower than its least height."""
    sk, up, width = feet.skeleton, feet.up, feet.width
    ma, ha = feet.column(leg.ankle)
    mt, ht = feet.column(leg.toe)
    pa = feet.pos[:, leg.ankle]
    plant_a = feet.plant_positions(plants, leg.ankle, ma, ha)
    delta = np.zeros_like(pa)
    turn = None
    if mt.any():
        pt = feet.pos[:, leg.toe]
        plant_t = feet.plant_positions(plants, leg.toe, mt, ht)
        given_t = plants and sk.names[leg.toe] in plants
        if not given_t and not (plants and sk.names[leg.ankle] in plants):
            _rigid_foot_plants(pa, plant_a, ma, pt, plant_t, mt, up)
        turn = _SO3.exp(strength * _foot_turn(pa, plant_a, pt, plant_t, ma & mt, width))
        # heel off: the ankle goes where the turned foot puts the toe on its plant
        only_toe = mt & ~ma
        foot = np.einsum("fij,fj->fi", turn[only_toe], pt[only_toe] - pa[only_toe])
        delta[only_toe] = plant_t[only_toe] - foot - pa[only_toe]
    delta[ma] = plant_a[ma] - pa[ma]  # (after the toe's plants: they may move the ankle's)
    delta = strength * _ease(delta, ma | mt, width)
    # no point of the foot below the floor: raise the ankle where the foot would go under
    # (eased in and out like the plants: a raise of one frame would jerk the knee)
    delta[:, up] += eased_envelope(np.maximum(feet.floor - feet.low(leg.ankle) - delta[:, up], 0.0), width)
    if swing_heights and not ease_swing:
        delta[:, up] += _swing_raise(leg, feet, delta[:, up], swing_heights)
    elif swing_heights:
        # eased in and out too: the raise starts where the plan releases the foot, and a raise
        # that jumps there snaps the knee by tens of degrees in one frame, the velocity change
        # the elastic distance is made of (DeepMimic walk x run: the clean-up's own move
        # d(R, R0) 1.05 -> 0.46 of d(A, B) / 2; benchmarks/cleanup_distance.py)
        delta[:, up] += eased_envelope(_swing_raise(leg, feet, delta[:, up], swing_heights), width)
    # a target within _STILL leg lengths of the ankle is where it is: IK there would only
    # bend a straight knee by its reach margin (cm at the knee for nothing)
    length = np.median(
        np.linalg.norm(feet.pos[:, leg.knee] - feet.pos[:, leg.hip], axis=1)
        + np.linalg.norm(pa - feet.pos[:, leg.knee], axis=1)
    )
    moved = np.linalg.norm(delta, axis=1) > _STILL * length
    return np.where(moved[:, None], pa + delta, np.nan), turn


def plant_targets(
    motion: Motion,
    contacts: Contacts,
    legs: Sequence[LegChain],
    options: CleanupOptions,
    plants: Mapping[str, np.ndarray] | None = None,
    swing_heights: Mapping[str, np.ndarray] | None = None,
) -> tuple[list[np.ndarray | None], list[np.ndarray | None], list[str]]:
    """Each leg's ankle targets ``(F, 3)`` (NaN where it stays; None: the leg is not moved)
    and foot turn ``(F, 3, 3)`` (None: none), and the ankle names of the legs moved (module
    docstring, step 2). A leg without contacts is only raised out of the floor."""
    feet = _Feet.of(motion, contacts, options.blend_time)
    targets: list[np.ndarray | None] = []
    turns: list[np.ndarray | None] = []
    used = []
    for leg in legs:
        ma, _ = feet.column(leg.ankle)
        mt, _ = feet.column(leg.toe)
        if ma.any() or mt.any():
            target, turn = _planted_target(
                leg, feet, plants, options.strength, swing_heights, options.ease_swing
            )
        else:
            target, turn = _out_of_floor_target(leg, feet), None  # no contact: out of the floor only
        if target is not None:
            used.append(motion.skeleton.names[leg.ankle])
        targets.append(target)
        turns.append(turn)
    return targets, turns, used


def _settled(motion: Motion, contacts: Contacts, legs: Sequence[LegChain], settle: Any) -> np.ndarray:
    """The vertical settle ``(F,)`` of the motion (``CleanupOptions.settle``)."""
    if isinstance(settle, tuple):
        offsets = np.asarray(settle, dtype=np.float64)
        if offsets.shape != (motion.n_frames,):
            raise OptionError(
                "settle",
                f"expected {motion.n_frames} finite offsets (one a frame); got shape {offsets.shape}",
            )
        return offsets
    return settle_offset(motion, contacts, legs, sigma=settle) if settle > 0 else np.zeros(motion.n_frames)


def _unenforced(contacts: Contacts, skeleton: Skeleton, legs: Sequence[LegChain]) -> list[str]:
    """Joints in contact somewhere that no leg's ankle or toe is."""
    feet = {skeleton.names[j] for leg in legs for j in (leg.ankle, leg.toe) if j >= 0}
    return [n for n in contacts.joints if contacts.mask[:, contacts.joints.index(n)].any() and n not in feet]


def _enforce(
    base: Motion,
    motion: Motion,
    legs: Sequence[LegChain],
    targets: Sequence[np.ndarray | None],
    turns: Sequence[np.ndarray | None],
    options: CleanupOptions,
) -> Motion:
    """Module docstring, step 3: root correction, leg IK, toe turns; the change from
    ``motion`` smoothed (``options.smooth``)."""
    offset = root_correction(base, legs, targets, sigma=options.blend_time / 2)
    out = base.replace(root_translation=base.root_translation + offset) if offset.any() else base
    out = solve_legs(out, legs, targets, hinge=options.knee_hinge)
    for leg, turn in zip(legs, turns, strict=True):
        if turn is not None:
            out = turn_joint(out, leg.ankle, turn)
    if options.smooth > 0:
        out = smooth_change(motion, out, options.smooth * motion.fps)
    return out


def _lift_out_of_floor(
    out: Motion, legs: Sequence[LegChain], floor: np.ndarray, width: int, hinge: bool
) -> Motion:
    """Last, exactly: no point of a foot below ``floor`` ``(F,)`` (the smoothing may have
    lowered one); the raise eased in and out over ``width`` frames."""
    sk = out.skeleton
    up = _AXES.index(out.up_axis)
    p_out = forward_kinematics(out, end_sites=True)
    lift = []
    for leg in legs:
        raise_ = eased_envelope(np.maximum(floor - _foot_low(p_out, sk, leg.ankle, up), 0.0), width)
        under = raise_ > 0
        if not under.any():
            lift.append(None)
            continue
        t = np.full((out.n_frames, 3), np.nan)
        t[under] = p_out[under, leg.ankle]
        t[under, up] += raise_[under]
        lift.append(t)
    if any(t is not None for t in lift):
        out = solve_legs(out, legs, lift, hinge=hinge)
    return out


def cleanup_footskate(
    motion: Motion,
    contacts: Contacts,
    options: CleanupOptions | None = None,
    *,
    legs: Sequence[LegChain] | None = None,
    plants: Mapping[str, np.ndarray] | None = None,
    fixed: Sequence[int] = (),
    swing_heights: Mapping[str, np.ndarray] | None = None,
    **overrides: Any,
) -> CleanupResult:
    """Enforce contacts on a motion by leg IK and a root correction (module docstring).

    Parameters
    ----------
    motion : Motion
        Lengths in metres (or consistent with ``contacts.floor``).
    contacts : Contacts
        On the motion's frames (e.g. :func:`carry_contacts`).
    options : CleanupOptions, optional
        How (``blend_time``, ``smooth``, ``strength``, ``knee_hinge``, ``settle``); default
        ``CleanupOptions()``.
    legs : sequence of LegChain, optional
        Default :func:`find_legs`.
    plants : mapping of str to ndarray of shape (F, 3), optional
        Where given, a contact joint's plant on every frame of its contacts (motion's unit;
        NaN coordinates keep the joint's own), instead of the mean over each run: e.g. a
        loop's planted feet between the frames it was closed on
        (:mod:`elastic_motion.apps.loop_contacts`).
    fixed : sequence of int
        Frames that must not change (a loop's seam frames): the clean-up's change fades to 0
        there, within a third of ``blend_time`` (:func:`elastic_motion.motion.edit.fade_change`).
    swing_heights : mapping of str to ndarray of shape (F,), optional
        Per ankle or toe joint, the least height (absolute, motion's unit; NaN where none) it
        keeps while swinging: where it is lower, its leg's ankle is raised by IK, the raise
        eased in and out over ``blend_time`` unless ``ease_swing`` is False (a blend's contact
        plan, :mod:`elastic_motion.apps.blend.contact_plan`).
    **overrides
        Fields of :class:`CleanupOptions` changed from ``options`` (``smooth=0.0``, ...).

    Returns
    -------
    CleanupResult
        ``applied=False`` (and the motion unchanged) when no leg joint has a contact.
    """
    opts = with_overrides(CleanupOptions, options, overrides)
    if contacts.n_frames != motion.n_frames:
        raise ValueError(
            f"contacts: expected {motion.n_frames} frames like the motion; got {contacts.n_frames}"
        )
    notes: list[Note] = []
    if legs is None:
        found, leg_notes = find_legs(motion)
        notes += [Note(NOTE_LEGS, n) for n in leg_notes]
    else:
        found = list(legs)
    before = contact_skating(motion, contacts)
    settled = _settled(motion, contacts, found, opts.settle)
    base = motion
    if settled.any():
        root = motion.root_translation.copy()
        root[:, _AXES.index(motion.up_axis)] += settled
        base = motion.replace(root_translation=root)
    targets, turns, used = plant_targets(base, contacts, found, opts, plants, swing_heights)
    other = _unenforced(contacts, motion.skeleton, found)
    if other:
        notes.append(
            Note(NOTE_UNENFORCED, f"contacts of {other} are measured, not enforced (no IK for them)")
        )
    if not used:
        notes.append(Note(NOTE_SKIPPED, "clean-up skipped: no contacts of the legs' ankle or toe joints"))
        return CleanupResult(motion, contacts, before, before, 0.0, 0.0, 0.0, (), False, tuple(notes))
    width = max(1, round(opts.blend_time * motion.fps))
    out = _enforce(base, motion, found, targets, turns, opts)
    out = _lift_out_of_floor(out, found, contacts.floor_heights(), width, opts.knee_hinge)
    if len(fixed):
        out = fade_change(motion, out, fixed_frames_weight(motion.n_frames, fixed, max(1, width // 3)))
    p0 = forward_kinematics(base, end_sites=True)
    p1 = forward_kinematics(out, end_sites=True)
    rel = np.swapaxes(motion.rotations, -1, -2) @ out.rotations
    return CleanupResult(
        motion=out,
        contacts=contacts,
        skating_before=before,
        skating_after=contact_skating(out, contacts),
        max_position_change=float(np.linalg.norm(p1 - p0, axis=-1).max()),
        max_rotation_change_deg=float(np.degrees(np.linalg.norm(_SO3.log(rel), axis=-1).max())),
        max_root_offset=float(np.linalg.norm(out.root_translation - motion.root_translation, axis=1).max()),
        legs=tuple(used),
        applied=True,
        notes=tuple(notes),
        smooth=float(opts.smooth),
        strength=float(opts.strength),
        settle_offset=float(settled[np.argmax(np.abs(settled))]),
    )
