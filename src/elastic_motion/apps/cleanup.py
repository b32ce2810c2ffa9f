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
   the knee of a nearly straight leg by tens of degrees).
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
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from elastic_motion.apps.metrics import ContactSkating, contact_skating
from elastic_motion.groups import SO3
from elastic_motion.motion import Motion
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

__all__ = ["CleanupResult", "carry_contacts", "cleanup_footskate", "find_legs"]

_SO3 = SO3()
_AXES = "xyz"
#: Ankle corrections below this fraction of the leg's length (a micrometre) are not made.
_STILL = 1e-6
#: Metres: the vertical settle never puts a planted ankle or toe more than this under its
#: ground height (:func:`settle_offset`).
SETTLE_BELOW = 0.01


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
    from elastic_motion.apps.landmarks import find_leg_joints

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
    notes : tuple of str
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
    notes: tuple[str, ...] = field(default=())
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
            "notes": list(self.notes),
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


def cleanup_footskate(
    motion: Motion,
    contacts: Contacts,
    *,
    blend_time: float = 0.15,
    smooth: float = 0.05,
    strength: float = 1.0,
    legs: Sequence[LegChain] | None = None,
    plants: Mapping[str, np.ndarray] | None = None,
    fixed: Sequence[int] = (),
    knee_hinge: bool = True,
    settle: float | np.ndarray = 0.0,
) -> CleanupResult:
    """Enforce contacts on a motion by leg IK and a root correction (module docstring).

    Parameters
    ----------
    motion : Motion
        Lengths in metres (or consistent with ``contacts.floor``).
    contacts : Contacts
        On the motion's frames (e.g. :func:`carry_contacts`).
    blend_time : float, default 0.15
        Seconds over which a correction eases in before and out after a contact.
    smooth : float, default 0.05
        Standard deviation (seconds) of a Gaussian that smooths the change the clean-up
        makes (the root offset and each joint's rotation change ``log(R^T R')``) in time;
        0 keeps the exact plants. Smoothing trades a little skating for a smaller change of
        the motion's velocities (which the elastic distance measures).
    strength : float, default 1.0
        Fraction in [0, 1] of the way from the blend's feet to their plants (the ankle's
        correction and the foot's turn are scaled by it): less leaves part of the blend's
        skating and changes it less. The floor is enforced in full whatever the fraction.
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
    knee_hinge : bool, default True
        As ``hinge`` of :func:`elastic_motion.motion.ik.solve_legs`: False keeps each frame's
        own knee plane (small corrections of a motion whose knees are right, e.g. a loop's).
    settle : float or ndarray of shape (F,), default 0
        Seconds; when positive, first a slow vertical root offset puts the planted ankles and
        toes at their ground heights (:func:`settle_offset`, Gaussian of this standard
        deviation): a blend whose feet sink into the floor or float above it is moved as a
        whole, which its legs' angles and the elastic distance do not see, instead of bending
        every stance leg by IK. 0: none (the plants' heights are then reached by the IK). An
        array: that offset (motion's unit), e.g. :func:`settle_offset` computed once for
        several calls. Applied in full whatever ``strength`` (like the floor).

    Returns
    -------
    CleanupResult
        ``applied=False`` (and the motion unchanged) when no leg joint has a contact.
    """
    if contacts.n_frames != motion.n_frames:
        raise ValueError(
            f"contacts: expected {motion.n_frames} frames like the motion; got {contacts.n_frames}"
        )
    if not (0.0 <= strength <= 1.0):
        raise ValueError(f"strength: expected a fraction in [0, 1]; got {strength!r}")
    notes: list[str] = []
    if legs is None:
        found, leg_notes = find_legs(motion)
        notes += leg_notes
    else:
        found = list(legs)
    before = contact_skating(motion, contacts)
    sk = motion.skeleton
    up = _AXES.index(motion.up_axis)
    width = max(1, round(blend_time * motion.fps))
    parents = sk.parents
    base = motion
    if np.ndim(settle) > 0:
        settled = np.asarray(settle, dtype=np.float64)
        if settled.shape != (motion.n_frames,) or not np.isfinite(settled).all():
            raise ValueError(
                f"settle: expected {motion.n_frames} finite offsets (one a frame); got shape {settled.shape}"
            )
    elif (
        isinstance(settle, bool)  # True is not "1 s"
        or not isinstance(settle, (int, float, np.integer, np.floating))
        or not (np.isfinite(settle) and settle >= 0)
    ):
        raise ValueError(f"settle: expected seconds >= 0 or an offset per frame; got {settle!r}")
    else:
        settled = (
            settle_offset(motion, contacts, found, sigma=settle) if settle > 0 else np.zeros(motion.n_frames)
        )
    if settled.any():
        root = motion.root_translation.copy()
        root[:, up] += settled
        base = motion.replace(root_translation=root)
    pos, _ = joint_positions_and_rotations(parents, base.local_translations(), base.rotations)
    pos_all = forward_kinematics(base, end_sites=True)

    floor = contacts.floor_heights()  # (F,): a floor that is not level, frame by frame

    def col(j: int) -> tuple[np.ndarray, np.ndarray | None]:
        name = sk.names[j]
        if j < 0 or name not in contacts.joints:
            return np.zeros(motion.n_frames, dtype=bool), None
        k = contacts.joints.index(name)
        g = contacts.ground_height[k]
        return contacts.mask[:, k], (floor + g) if np.isfinite(g) else None

    used, targets, turns = [], [], []
    for leg in found:
        ma, ha = col(leg.ankle)
        mt, ht = col(leg.toe) if leg.toe >= 0 else (np.zeros(motion.n_frames, dtype=bool), None)
        if not (ma.any() or mt.any()):
            # no contact: only keep the foot out of the floor
            under = floor - _foot_low(pos_all, sk, leg.ankle, up)
            if (under > 0).any():
                tgt = np.full((motion.n_frames, 3), np.nan)
                tgt[under > 0] = pos[under > 0, leg.ankle]
                tgt[under > 0, up] += under[under > 0]
                targets.append(tgt)
                used.append(sk.names[leg.ankle])
            else:
                targets.append(None)
            turns.append(None)
            continue
        used.append(sk.names[leg.ankle])
        pa = pos[:, leg.ankle]
        plant_a = _given(plants, sk.names[leg.ankle], pa) if plants else None
        plant_a = _plants(pa, ma, ha, up) if plant_a is None else plant_a
        delta = np.zeros_like(pa)
        turn = None
        if mt.any():
            pt = pos[:, leg.toe]
            plant_t = _given(plants, sk.names[leg.toe], pt) if plants else None
            if plant_t is None:
                plant_t = _plants(pt, mt, ht, up)
                if not (plants and sk.names[leg.ankle] in plants):
                    _rigid_foot_plants(pa, plant_a, ma, pt, plant_t, mt, up)
            # the foot's turn about the ankle: where both are planted it takes toe - ankle to
            # plant_toe - plant_ankle; eased into the heel-off (toe only) and swing frames
            both = ma & mt
            vec = np.zeros_like(pa)
            if both.any():
                vec[both] = _SO3.log(rotation_between(pt[both] - pa[both], plant_t[both] - plant_a[both]))
            vec = strength * _ease(vec, both, width)
            turn = _SO3.exp(vec)
            # heel off: the ankle goes where the turned foot puts the toe on its plant
            only_toe = mt & ~ma
            foot = np.einsum("fij,fj->fi", turn[only_toe], pt[only_toe] - pa[only_toe])
            delta[only_toe] = plant_t[only_toe] - foot - pa[only_toe]
        delta[ma] = plant_a[ma] - pa[ma]  # (after the toe's plants: they may move the ankle's)
        known = ma | mt
        delta = strength * _ease(delta, known, width)
        # no point of the foot below the floor: raise the ankle where the foot would go under
        low = _foot_low(pos_all, sk, leg.ankle, up)
        # (eased in and out like the plants: a raise of one frame would jerk the knee)
        delta[:, up] += eased_envelope(np.maximum(floor - low - delta[:, up], 0.0), width)
        # a target within _STILL leg lengths of the ankle is where it is: IK there would only
        # bend a straight knee by its reach margin (cm at the knee for nothing)
        length = np.median(
            np.linalg.norm(pos[:, leg.knee] - pos[:, leg.hip], axis=1)
            + np.linalg.norm(pa - pos[:, leg.knee], axis=1)
        )
        moved = np.linalg.norm(delta, axis=1) > _STILL * length
        tgt = np.where(moved[:, None], pa + delta, np.nan)
        targets.append(tgt)
        turns.append(turn)
    other = [n for n in contacts.joints if contacts.mask[:, contacts.joints.index(n)].any()]
    other = [
        n for n in other if n not in {sk.names[j] for leg in found for j in (leg.ankle, leg.toe) if j >= 0}
    ]
    if other:
        notes.append(f"contacts of {other} are measured, not enforced (no IK for them)")
    if not used:
        notes.append("clean-up skipped: no contacts of the legs' ankle or toe joints")
        return CleanupResult(motion, contacts, before, before, 0.0, 0.0, 0.0, (), False, tuple(notes))

    # 1. root correction, 2. leg IK, 3. toe turns
    offset = root_correction(base, found, targets, sigma=blend_time / 2)
    out = base.replace(root_translation=base.root_translation + offset) if offset.any() else base
    out = solve_legs(out, found, targets, hinge=knee_hinge)
    for leg, turn in zip(found, turns, strict=True):
        if turn is not None:
            out = turn_joint(out, leg.ankle, turn)
    if smooth > 0:
        out = smooth_change(motion, out, smooth * motion.fps)
    # last, exactly: no point of a foot below the floor (the smoothing may have lowered one)
    p_out = forward_kinematics(out, end_sites=True)
    lift = []
    for leg in found:
        low = _foot_low(p_out, sk, leg.ankle, up)
        raise_ = eased_envelope(np.maximum(floor - low, 0.0), width)
        under = raise_ > 0
        if not under.any():
            lift.append(None)
            continue
        t = np.full((motion.n_frames, 3), np.nan)
        t[under] = p_out[under, leg.ankle]
        t[under, up] += raise_[under]
        lift.append(t)
    if any(t is not None for t in lift):
        out = solve_legs(out, found, lift, hinge=knee_hinge)
    if len(fixed):
        out = fade_change(motion, out, fixed_frames_weight(motion.n_frames, fixed, max(1, width // 3)))
    after = contact_skating(out, contacts)
    p0 = pos_all
    p1 = forward_kinematics(out, end_sites=True)
    dpos = float(np.linalg.norm(p1 - p0, axis=-1).max())
    rel = np.swapaxes(motion.rotations, -1, -2) @ out.rotations
    drot = float(np.degrees(np.linalg.norm(_SO3.log(rel), axis=-1).max()))
    return CleanupResult(
        motion=out,
        contacts=contacts,
        skating_before=before,
        skating_after=after,
        max_position_change=dpos,
        max_rotation_change_deg=drot,
        max_root_offset=float(np.linalg.norm(out.root_translation - motion.root_translation, axis=1).max()),
        legs=tuple(used),
        applied=True,
        notes=tuple(notes),
        smooth=float(smooth),
        strength=float(strength),
        settle_offset=float(settled[np.argmax(np.abs(settled))]),
    )
