"""Which world axis is up: detection from the motion itself, and checks on a label.

BVH does not record its up axis. Most files are Y-up, but Blender is Z-up and its BVH
exporter writes armature space, so every BVH exported by Blender (3.4 tested) is Z-up,
even one it imported from a Y-up file; read as Y-up, the character lies on the floor.
:func:`detect_up_axis` tells the six signed axis directions apart from the posed motion
(forward kinematics in the world frame), scoring each direction ``d`` on three cues, each
in ``[0, 1]`` (the first in ``[-1, 1]``):

* **body axis** ``B(d)``: mean over frames of ``b_f . d``, ``b_f`` the unit vector from the
  feet (leaf points of the leg subtrees) to the centroid of the torso subtree (the largest
  subtree below the first branching joint). Humans are upright in most frames.
* **floor** ``F(d)``: fraction of frames whose lowest point along ``d`` (joints and end
  sites) lies within ``0.1 s`` of the clip's floor level along ``d`` (the 5th percentile of
  those lowest points), ``s`` the body size (median feet-to-torso distance). Along the up
  axis the lowest points are floor contacts at one level; along a horizontal axis they
  travel with the body.
* **balance** ``Bal(d)``: fraction of frames whose centre of mass (the skeleton as a wire
  of uniform density), projected along ``d``, lies within ``0.05 s`` of the convex hull of
  the support points (points within ``0.15 s`` of the lowest point along ``d`` that move
  less than ``0.4 s`` per second relative to the feet on that floor: contacts do not slide).
  A body stands over its support; a crawling body seen along its length would be
  cantilevered over its feet. The speeds are relative to the floor (the median velocity of
  the foot points on it, across it), not to the world: on an **in-place export** (the
  body's travel removed, its height kept, as animators export walk cycles) the planted
  feet slide back as on a treadmill, so no point would be still in the world frame, while
  the side of an upright body, seen along a horizontal axis, stays still and looks like a
  body lying on its side. Nothing here reads the root's path: the body axis is the pose,
  and the floor and balance cues hold whether the body travels or not.

The total is ``S(d) = B(d) + F(d) + Bal(d)`` (``-1 .. 3``); the best direction wins and the
**margin** to the second best is the confidence. Body axis alone decides upright clips
(walks, runs, dances: ``B ~ 0.9-1``); floor and balance decide clips whose body is mostly
horizontal (crawl: ``B(+y) = 0.16``, but ``F = 1``, ``Bal = 1`` along +y). On the 47 real clips
of the project's test data (CMU BVH and ASF/AMC, Bandai, DeepMimic, all Y-up), +y wins
with margins 0.31 to 2.15; the smallest are the DeepMimic get-up and crawl clips. Blender's
own exports of all 43 shared BVH and DeepMimic clips (Z-up: in full, with
``root_transform_only`` and in place) are all detected +z (129 of 129; 125 before the
speeds were relative to the feet and the rest pose confirmed narrow leads).

The **rest pose** (all rotations identity) is not scored: in the test data it points the
body along -y (the CMU files converted from FBX, whose root rotation turns the skeleton
over in every frame) or along +x (Bandai, bone-aligned local frames) in 18 of 47 clips.
It only **confirms**: a best direction whose margin is below ``min_margin`` is taken (not
ambiguous) when the rest pose's feet-to-torso vector lies within 30 degrees of it (the
DeepMimic crawl in place, the get-up face down as Blender exports it); a rest pose along
another axis changes nothing.

Conventions: a detected direction is a signed axis (``"+z"``); ``Motion.up_axis`` holds
positive axes only, so a reader labels a motion with :attr:`UpAxisEstimate.up_axis`, which
falls back to ``"y"`` when the estimate is ambiguous (margin below ``min_margin``), the
skeleton has no recognisable legs and torso, or the body's up points along a negative
axis (an upside-down file). Callers warn on :attr:`UpAxisEstimate.fallback`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from elastic_motion.motion.kinematics import joint_positions_and_rotations
from elastic_motion.motion.skeleton import Motion, Skeleton

__all__ = [
    "DIRECTIONS",
    "UpAxisEstimate",
    "body_axis",
    "detect_up_axis",
    "is_lying_down",
    "up_axis_warning",
]

#: The six candidate up directions (ties go to the earlier one).
DIRECTIONS = ("+x", "-x", "+y", "-y", "+z", "-z")
_AXES = "xyz"

#: Default minimum score margin for a confident estimate (the real clips of ../shared/mocap:
#: 0.31 and above, the least a DeepMimic get-up with its hands on the floor).
MIN_MARGIN = 0.3
_FLOOR_TOL = 0.1  # body sizes: lowest point within this of the floor level counts as on it
_SUPPORT_TOL = 0.15  # body sizes: points this close to the lowest one support the body
_BALANCE_TOL = 0.05  # body sizes: centre of mass this close to the support hull counts as balanced
_CONTACT_SPEED = 0.4  # body sizes per second: slower points can be floor contacts
_FLOOR_PERCENTILE = 5.0
_REST_CONFIRM_COS = math.cos(math.radians(30.0))  # rest pose this close to the best direction confirms it
_N_HULL_DIRECTIONS = 32  # a multiple of 4: the test is the same for every signed-axis permutation


@dataclass(frozen=True, eq=False)
class UpAxisEstimate:
    """Result of :func:`detect_up_axis`.

    Attributes
    ----------
    axis : {"x", "y", "z"}
        Axis of the best direction.
    sign : {1, -1}
        ``-1`` when the body's up points along the negative axis (an upside-down file).
    confidence : float
        Score margin of the best direction over the second best, ``0 .. 4``. Below the
        ``min_margin`` given to :func:`detect_up_axis` the estimate is ``ambiguous``.
    ambiguous : bool
        Margin below ``min_margin``, or no legs and torso found in the skeleton.
    scores : dict
        Total score ``S(d)`` of each direction of :data:`DIRECTIONS` (``"+x"`` ...).
    evidence : dict
        ``"body_axis"``, ``"floor"``, ``"balance"``: the per-direction cue values;
        ``"rest_pose"``: the feet-to-torso unit vector of the rest pose (not scored; see
        the module docstring); ``"root_travel"``: range of the root position along x, y,
        z in body sizes; ``"body_size"`` (file units), ``"frames_used"``, ``"min_margin"``,
        ``"runner_up"`` (second-best direction).
    reason : str
        One line for people: the winning direction and cues, or why it is not trusted.
    """

    axis: str
    sign: int
    confidence: float
    ambiguous: bool
    scores: dict[str, float] = field(default_factory=dict)
    evidence: dict[str, Any] = field(default_factory=dict)
    reason: str = ""

    @property
    def direction(self) -> str:
        """The best direction as a signed axis, ``"+y"``, ``"-z"`` ..."""
        return ("+" if self.sign > 0 else "-") + self.axis

    @property
    def fallback(self) -> bool:
        """True when a reader should not trust the estimate: ambiguous or a negative axis."""
        return self.ambiguous or self.sign < 0

    @property
    def up_axis(self) -> str:
        """The label for ``Motion.up_axis``: ``axis``, or ``"y"`` when :attr:`fallback`."""
        return "y" if self.fallback else self.axis


# ------------------------------------------------------------------------------------------
# Skeleton structure
# ------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class _Body:
    torso: np.ndarray  # joint indices of the torso subtree
    feet_joints: np.ndarray  # leaf joints of the leg subtrees (used when they have no end sites)
    feet_sites: np.ndarray  # end sites under the leg subtrees
    foot_joints: np.ndarray  # the legs' leaf joints, the parents of their end sites, and their parents


def _body_parts(skeleton: Skeleton) -> _Body | None:
    """Torso and feet of a skeleton, from its shape only (names are not used).

    From the root, go down while a joint has a single child joint and no end site (a
    reference root like Bandai's ``joint_Root`` above the hips). At the first branching
    joint, the child subtree with the most joints is the torso (spine, head, arms), the
    others are the legs; their end sites (or leaf joints) are the feet. ``None`` unless
    that joint has at least three children (torso and two legs) and the torso subtree
    has more joints than any leg: chains, stars and other non-human test skeletons get no
    estimate rather than a wrong one.
    """
    sk = skeleton
    h = 0
    while True:
        kids = sk.children(h)
        if len(kids) == 1 and not (sk.end_site_parents == h).any():
            h = kids[0]
            continue
        break
    kids = sk.children(h)
    if len(kids) < 3:
        return None
    subtrees = [sk.subtree(c) for c in kids]
    t = max(range(len(subtrees)), key=lambda i: len(subtrees[i]))
    if any(len(s) >= len(subtrees[t]) for i, s in enumerate(subtrees) if i != t):
        return None  # no subtree stands out as the torso
    legs = sorted(j for i, s in enumerate(subtrees) if i != t for j in s)
    leg_set = set(legs)
    sites = np.array([e for e, p in enumerate(sk.end_site_parents.tolist()) if p in leg_set], dtype=np.int64)
    leaf_joints = np.array([j for j in legs if not sk.children(j)], dtype=np.int64)
    if sites.size == 0 and leaf_joints.size == 0:
        return None
    ends = {int(sk.end_site_parents[e]) for e in sites} | set(leaf_joints.tolist())
    foot = sorted(ends | {int(sk.parents[j]) for j in ends if int(sk.parents[j]) in leg_set})
    return _Body(np.array(subtrees[t], dtype=np.int64), leaf_joints, sites, np.array(foot, dtype=np.int64))


def _frame_sample(n_frames: int, max_frames: int) -> np.ndarray:
    if n_frames <= max_frames:
        return np.arange(n_frames)
    return np.unique(np.linspace(0, n_frames - 1, max_frames).round().astype(np.int64))


def _posed_points(motion: Motion, frames: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World positions of joints ``(F, J, 3)`` and end sites ``(F, E, 3)`` at ``frames``."""
    sk = motion.skeleton
    pos, glob = joint_positions_and_rotations(
        sk.parents, motion.local_translations()[frames], motion.rotations[frames]
    )
    ep = sk.end_site_parents
    sites = pos[:, ep] + np.einsum("fejk,ek->fej", glob[:, ep], sk.end_site_offsets)
    return pos, sites


def _feet(body: _Body, pos: np.ndarray, sites: np.ndarray) -> np.ndarray:
    return sites[:, body.feet_sites] if body.feet_sites.size else pos[:, body.feet_joints]


def body_axis(motion: Motion, *, max_frames: int = 300) -> np.ndarray | None:
    """Unit vectors from the feet to the torso centroid, in the world frame.

    Parameters
    ----------
    motion : Motion
    max_frames : int, default 300
        At most this many frames, evenly spaced (first and last included).

    Returns
    -------
    ndarray, shape (N, 3), or None
        One unit vector per sampled frame; ``None`` when the skeleton has no recognisable
        legs and torso (see the module docstring) or the vector vanishes.
    """
    body = _body_parts(motion.skeleton)
    if body is None:
        return None
    pos, sites = _posed_points(motion, _frame_sample(motion.n_frames, max_frames))
    v = pos[:, body.torso].mean(axis=1) - _feet(body, pos, sites).mean(axis=1)
    n = np.linalg.norm(v, axis=1, keepdims=True)
    if not (n > 0).all():
        return None
    return v / n


# ------------------------------------------------------------------------------------------
# Cues
# ------------------------------------------------------------------------------------------
def _centre_of_mass(skeleton: Skeleton, pos: np.ndarray, sites: np.ndarray) -> np.ndarray:
    """Centroid ``(F, 3)`` of the skeleton as a wire of uniform density (bones and end sites)."""
    a = np.concatenate([pos[:, skeleton.parents[1:]], pos[:, skeleton.end_site_parents]], axis=1)
    b = np.concatenate([pos[:, 1:], sites], axis=1)
    w = np.linalg.norm(b - a, axis=-1)  # (F, S)
    total = w.sum(axis=1, keepdims=True)
    mid = 0.5 * (a + b)
    com = np.einsum("fs,fsk->fk", w, mid) / np.where(total > 0, total, 1.0)
    return np.where(total > 0, com, pos.mean(axis=1))


def _floor_velocity(vel: np.ndarray, feet_on_floor: np.ndarray, axis: int) -> np.ndarray:
    """Velocity ``(F, 3)`` of the floor under the body: the median velocity of the foot points
    on it (``feet_on_floor`` (F, N)), its component along the up ``axis`` removed; zero in
    frames with no foot on it.

    On a capture the planted feet are still and this is about zero; on an in-place export
    (the body's travel removed, its height kept) the planted feet slide back at the walking
    speed, as on a treadmill, and contacts are still relative to them.
    """
    out = np.zeros(vel.shape[::2])
    rows = feet_on_floor.any(axis=1)
    if rows.any():
        out[rows] = _masked_median(vel[rows], feet_on_floor[rows])
    out[:, axis] = 0.0
    return out


def _masked_median(values: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Median ``(R, C)`` over axis 1 of ``values`` (R, N, C) where ``mask`` (R, N) is True
    (at least one per row): ``np.nanmedian`` of the unmasked values, to the bit.

    The mean of the two middle values for an even count, ``(lo + hi) / 2`` as numpy's
    computes it (an odd count takes the middle one twice: ``(x + x) / 2 == x``). Direct
    sorting rather than ``np.nanmedian``, which on short rows goes through masked arrays:
    about 10 times slower, and it imports ``numpy.ma`` (the up-axis check of every input).
    """
    s = np.sort(np.where(mask[..., None], values, np.nan), axis=1)  # NaN sort last
    n = np.count_nonzero(mask, axis=1)[:, None, None]  # (R, 1, 1)
    hi = np.broadcast_to(n // 2, (s.shape[0], 1, s.shape[2]))
    lo = np.where(n % 2 == 1, hi, hi - 1)
    return ((np.take_along_axis(s, lo, axis=1) + np.take_along_axis(s, hi, axis=1)) / 2.0)[:, 0]


def _hull_distance(points: np.ndarray, mask: np.ndarray, q: np.ndarray, dirs: np.ndarray) -> np.ndarray:
    """Distance from ``q`` (F, 2) to the convex hull of the masked ``points`` (F, N, 2).

    ``max_k (min_p w_k.p - w_k.q)`` over unit directions ``w_k`` (K, 2), clipped at 0: exact
    for the hull's own edge normals, a slight underestimate otherwise.
    """
    proj = points @ dirs.T  # (F, N, K); on points[mask] alone matmul rounds differently
    # the least over the masked points (a few per frame of N) by np.minimum.reduceat over
    # each frame's run of them, not a masked copy of all; frames without any stay +inf
    frame, _ = np.nonzero(mask)  # row-major: the frames in order
    low = np.full(proj.shape[::2], np.inf)
    if frame.size:
        proj = proj[mask]  # (M, K)
        starts = np.flatnonzero(np.r_[True, frame[1:] != frame[:-1]])
        low[frame[starts]] = np.minimum.reduceat(proj, starts, axis=0)
    gap = low - q @ dirs.T  # (F, K)
    return np.maximum(gap.max(axis=1), 0.0)


#: Coordinates (file units) beyond which the sums and squares of the cues overflow (a file's
#: numbers may reach 1e308): such a body cannot be judged (the up axis is then ambiguous,
#: and preparing it for an application refuses it: ``apps.prepare.MAX_EXTENT_M``).
_MAX_COORD = 1e100


class _Degenerate(Exception):
    """The body has zero size (feet at the torso centroid)."""


def _cues(motion: Motion, body: _Body, frames: np.ndarray) -> dict[str, Any]:
    """The three scored cues per direction, root travel and body size (module docstring)."""
    sk = motion.skeleton
    pos, sites = _posed_points(motion, frames)
    pts = np.concatenate([pos, sites], axis=1)  # (F, N, 3)
    if not np.all(np.abs(pts) < _MAX_COORD):
        raise _Degenerate
    v = pos[:, body.torso].mean(axis=1) - _feet(body, pos, sites).mean(axis=1)
    length = np.linalg.norm(v, axis=1)
    size = float(np.median(length))
    if not (size > 0 and math.isfinite(size)):
        raise _Degenerate
    b = v / np.where(length > 0, length, 1.0)[:, None]
    # Speed of every point by central differences of the neighbouring frames, body sizes / s.
    last = motion.n_frames - 1
    after, before = np.minimum(frames + 1, last), np.maximum(frames - 1, 0)
    pa, sa = _posed_points(motion, after)
    pb, sb = _posed_points(motion, before)
    if not all(np.all(np.abs(a) < _MAX_COORD) for a in (pa, sa, pb, sb)):
        raise _Degenerate
    step = np.maximum(after - before, 1)[:, None] / motion.fps
    vel = np.concatenate([pa - pb, sa - sb], axis=1) / (step * size)[:, :, None]  # (F, N, 3)
    is_foot = np.zeros(pts.shape[1], dtype=bool)
    is_foot[body.foot_joints] = True
    is_foot[pos.shape[1] + body.feet_sites] = True
    com = _centre_of_mass(sk, pos, sites)
    angles = np.arange(_N_HULL_DIRECTIONS) * (2 * math.pi / _N_HULL_DIRECTIONS)
    dirs = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    body_cue, floor, balance = {}, {}, {}
    for name in DIRECTIONS:
        s = 1.0 if name[0] == "+" else -1.0
        a = _AXES.index(name[1])
        rest = [k for k in range(3) if k != a]
        height = s * pts[..., a]  # (F, N)
        low = height.min(axis=1)
        level = np.percentile(low, _FLOOR_PERCENTILE)
        near = height <= (low + _SUPPORT_TOL * size)[:, None]
        slide = vel - _floor_velocity(vel, near & is_foot, a)[:, None]
        support = near & (np.linalg.norm(slide, axis=-1) < _CONTACT_SPEED)
        dist = _hull_distance(pts[..., rest], support, com[:, rest], dirs)
        body_cue[name] = float(np.mean(s * b[:, a]))
        floor[name] = float(np.mean(low - level <= _FLOOR_TOL * size))
        balance[name] = float(np.mean(support.any(axis=1) & (dist <= _BALANCE_TOL * size)))
    root = pos[:, 0]
    return {
        "body_axis": body_cue,
        "floor": floor,
        "balance": balance,
        "root_travel": {ax: float(np.ptp(root[:, k]) / size) for k, ax in enumerate(_AXES)},
        "body_size": size,
    }


def _rest_pose_axis(skeleton: Skeleton, body: _Body) -> dict[str, float] | None:
    """Feet-to-torso unit vector of the rest pose (identity rotations), or None."""
    n = skeleton.n_joints
    if not (
        np.all(np.abs(skeleton.offsets) < _MAX_COORD)
        and np.all(np.abs(skeleton.end_site_offsets) < _MAX_COORD)
    ):
        return None
    pos = np.zeros((n, 3))
    for j in range(1, n):
        pos[j] = pos[skeleton.parents[j]] + skeleton.offsets[j]
    sites = pos[skeleton.end_site_parents] + skeleton.end_site_offsets
    feet = sites[body.feet_sites] if body.feet_sites.size else pos[body.feet_joints]
    v = pos[body.torso].mean(axis=0) - feet.mean(axis=0)
    norm = float(np.linalg.norm(v))
    if not norm > 0:
        return None
    return {ax: float(v[k] / norm) for k, ax in enumerate(_AXES)}


def _rest_pose_confirms(rest: dict[str, float] | None, direction: str) -> bool:
    """True if the rest pose's feet-to-torso vector is within 30 degrees of ``direction``."""
    if rest is None:
        return False
    sign = 1.0 if direction[0] == "+" else -1.0
    return sign * rest[direction[1]] >= _REST_CONFIRM_COS


# ------------------------------------------------------------------------------------------
# Public API
# ------------------------------------------------------------------------------------------
def detect_up_axis(
    motion: Motion, *, min_margin: float = MIN_MARGIN, max_frames: int = 300
) -> UpAxisEstimate:
    """Estimate which signed world axis is up, from the posed motion.

    The motion's own ``up_axis`` label is ignored: positions are taken as they are in the
    file. Scores and cues are described in the module docstring.

    Parameters
    ----------
    motion : Motion
        Any length unit (the cues are relative to the body size).
    min_margin : float, default 0.3
        Score margin (best minus second-best direction, ``0 .. 4``) below which the
        estimate is ``ambiguous``, unless the rest pose stands along the best direction
        (module docstring). On the project's 47 real clips the margin is at least 0.31.
    max_frames : int, default 300
        At most this many frames, evenly spaced, are used (a few milliseconds).

    Returns
    -------
    UpAxisEstimate
        ``axis``, ``sign``, ``confidence`` (the margin), ``ambiguous``, ``scores``,
        ``evidence`` and ``reason``; ``up_axis`` is the label a reader should use.

    Raises
    ------
    ValueError
        If ``min_margin`` is negative or ``max_frames`` below 1.
    """
    if not (isinstance(min_margin, int | float) and math.isfinite(min_margin) and min_margin >= 0):
        raise ValueError(f"min_margin: expected a non-negative number; got {min_margin!r}")
    if not (isinstance(max_frames, int) and max_frames >= 1):
        raise ValueError(f"max_frames: expected an integer >= 1; got {max_frames!r}")
    body = _body_parts(motion.skeleton)
    frames = _frame_sample(motion.n_frames, max_frames)
    evidence: dict[str, Any] = {"frames_used": int(frames.size), "min_margin": float(min_margin)}
    cues = None
    if body is not None:
        evidence["rest_pose"] = _rest_pose_axis(motion.skeleton, body)
        try:
            cues = _cues(motion, body, frames)
        except _Degenerate:
            cues = None
    if cues is None:
        return UpAxisEstimate(
            axis="y",
            sign=1,
            confidence=0.0,
            ambiguous=True,
            scores=dict.fromkeys(DIRECTIONS, 0.0),
            evidence=evidence,
            reason="no torso and two legs below a branching joint of the skeleton (or a body of "
            "zero size); cannot tell the up axis",
        )
    evidence.update(cues)
    scores = {d: cues["body_axis"][d] + cues["floor"][d] + cues["balance"][d] for d in DIRECTIONS}
    ranked = sorted(DIRECTIONS, key=lambda d: (-scores[d], DIRECTIONS.index(d)))
    best, second = ranked[0], ranked[1]
    margin = scores[best] - scores[second]
    evidence["runner_up"] = second
    confirmed = margin > 0 and _rest_pose_confirms(evidence.get("rest_pose"), best)
    evidence["rest_pose_confirms"] = confirmed
    ambiguous = margin < min_margin and not confirmed
    cue_text = (
        f"body axis {cues['body_axis'][best]:+.2f}, floor {cues['floor'][best]:.2f}, "
        f"balance {cues['balance'][best]:.2f} along {best}"
    )
    if ambiguous:
        reason = f"ambiguous: {best} leads {second} by {margin:.2f} (< {min_margin:g}); {cue_text}"
    elif margin < min_margin:
        reason = (
            f"up is {best} by {margin:.2f} over {second} (< {min_margin:g}), as the rest pose stands; "
            f"{cue_text}"
        )
    elif best[0] == "-":
        reason = f"up is {best} (an upside-down file) by {margin:.2f} over {second}; {cue_text}"
    else:
        reason = f"up is {best} by {margin:.2f} over {second}; {cue_text}"
    return UpAxisEstimate(
        axis=best[1],
        sign=1 if best[0] == "+" else -1,
        confidence=float(margin),
        ambiguous=bool(ambiguous),
        scores=scores,
        evidence=evidence,
        reason=reason,
    )


def is_lying_down(motion: Motion, *, max_tilt_deg: float = 60.0, max_frames: int = 300) -> bool:
    """True if, with its ``up_axis`` label, the body is mostly far from upright.

    The body axis (feet to torso centroid, :func:`body_axis`) makes on average more than
    ``max_tilt_deg`` with the labelled up axis: ``mean(b . up) < cos(max_tilt_deg)``. That is
    the symptom of a Z-up file labelled Y-up (the character lies on the floor), but also of
    clips that really are lying, crawling or turning over: among the 47 real clips of the
    test data, DeepMimic ``crawl`` (mean 0.16), the two ``getup`` clips (0.16, 0.46), the
    cartwheels CMU ``49_08`` (0.37) and DeepMimic ``cartwheel`` (0.499, its hands on the
    floor for a third of the clip). So warn, and refuse only when :func:`detect_up_axis` also
    disagrees with the label (:func:`up_axis_warning`). ``False`` when the skeleton has no
    recognisable legs and torso.

    Parameters
    ----------
    motion : Motion
    max_tilt_deg : float, default 60
        In ``(0, 180)``.
    max_frames : int, default 300
    """
    if not (0 < max_tilt_deg < 180):
        raise ValueError(f"max_tilt_deg: expected an angle in (0, 180) degrees; got {max_tilt_deg!r}")
    b = body_axis(motion, max_frames=max_frames)
    if b is None:
        return False
    up = _AXES.index(motion.up_axis)
    return bool(b[:, up].mean() < math.cos(math.radians(max_tilt_deg)))


def up_axis_warning(motion: Motion, *, estimate: UpAxisEstimate | None = None) -> str | None:
    """A one-line warning when the motion's ``up_axis`` label looks wrong, else ``None``.

    Warns when :func:`detect_up_axis` confidently finds another direction than the label
    (``+`` the labelled axis), when the estimate is ambiguous, or when the body is lying
    down under the label (:func:`is_lying_down`).

    Parameters
    ----------
    motion : Motion
    estimate : UpAxisEstimate, optional
        A result of ``detect_up_axis(motion)`` to reuse.
    """
    est = detect_up_axis(motion) if estimate is None else estimate
    label = "+" + motion.up_axis
    name = motion.name or "motion"
    if not est.ambiguous and est.direction != label:
        return (
            f"{name}: labelled {motion.up_axis}-up but the motion looks {est.direction}-up "
            f"({est.reason}); pass the up axis explicitly if the label is right"
        )
    if est.ambiguous and est.evidence.get("body_size") is not None:
        return f"{name}: cannot tell the up axis reliably ({est.reason}); assuming {motion.up_axis}-up"
    if is_lying_down(motion):
        return (
            f"{name}: the body is mostly horizontal with {motion.up_axis} up (lying or crawling?); "
            "check the up axis"
        )
    return None
