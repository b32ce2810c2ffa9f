"""Inverse kinematics: analytic two-bone leg IK and a smooth root correction.

The one home of inverse kinematics (the foot-skate clean-up of
:mod:`elastic_motion.apps.cleanup` uses it), in the spirit of Kovar, Schreiner and Gleicher,
"Footskate cleanup for motion capture editing" (SCA 2002): the ankle of a leg is moved to a
target by rotating the hip and the knee joints only, so every bone keeps its length; when a
target is out of reach the root is moved first, by a correction smooth in time.

Conventions
-----------
* A **leg** is a :class:`LegChain` of three joints ``hip -> knee -> ankle`` (the joints
  *located* there, e.g. CMU ``LeftUpLeg``, ``LeftLeg``, ``LeftFoot``), each the parent of the
  next, and optionally a ``toe`` joint under the ankle.
* **Two-bone IK** (:func:`two_bone_ik`, per frame, vectorised): with hip ``a``, knee ``b``,
  ankle ``c``, target ``t``, thigh ``l1 = |b - a|``, shin ``l2 = |c - b|`` and the reachable
  distance ``d = clip(|t - a|, |l1 - l2|, l1 + l2)`` (shrunk by ``1e-4 (l1 + l2)``),

  1. the hip turns by ``alpha1 - alpha0`` and the knee by ``beta1 - beta0`` about
     ``n = (c - a) x (b - a)`` (the leg's plane), where ``alpha`` is the angle at the hip
     between ``c - a`` and ``b - a``, ``beta`` the interior angle at the knee, ``0`` the
     current and ``1`` the law-of-cosines values for ``|c - a| = d``; this keeps the
     direction of ``c - a``;
  2. the whole leg turns about the hip by the smallest rotation taking ``c - a`` to ``t - a``.

  The knee's hinge axis ``h`` is learnt from the frames where the leg is bent (the main axis
  of the normals ``n`` in the knee's frame, oriented the way the knee bends most). The knee
  bends one way only: where ``n`` points against ``h`` (a knee bent backwards, which blends
  produce) the angles are signed (``alpha -> -alpha``, ``beta -> 2 pi - beta``, about ``-n``),
  so such a knee is straightened through 0 and bent forwards, never mirrored (mirroring jumps
  by twice the bend where the leg passes straight); where the leg is nearly straight
  (``sin`` of the bend below 0.05) it bends about ``h`` projected off the leg. Rotations are
  global (world) rotations applied on the left: ``G_hip' = R2 R0 G_hip``,
  ``G_knee' = R2 R0 R1 G_knee``; the ankle keeps its global orientation (the foot does not
  tilt), so its local rotation is ``G_knee'^T G_ankle``.
* **Root correction** (:func:`root_correction`): where a target is farther from its hip than
  ``reach`` (default 0.999) times the leg length, the hip must move towards it by the excess;
  the root's translation moves by the sum over legs, smoothed in time by a Gaussian of
  ``sigma`` seconds, repeated a few times so that the smoothing does not lose the peaks.
* Positions are in the motion's length unit and world frame; the functions do not care
  about units.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from elastic_motion.groups import SO3
from elastic_motion.motion.filters import gaussian_frames, max_frames, min_frames
from elastic_motion.motion.kinematics import joint_positions_and_rotations
from elastic_motion.motion.skeleton import Motion, Skeleton

__all__ = [
    "LegChain",
    "leg_chain",
    "root_correction",
    "rotation_between",
    "solve_legs",
    "turn_joint",
    "two_bone_ik",
]

_SO3 = SO3()
_SHRINK = 1e-4
#: Below this sine of the knee's bend the leg's plane is taken from the knee's hinge axis.
_WEAK_BEND = 0.05


@dataclass(frozen=True)
class LegChain:
    """Joint indices of one leg: ``hip -> knee -> ankle`` (each the parent of the next) and
    an optional ``toe`` (a child of the ankle, or -1)."""

    hip: int
    knee: int
    ankle: int
    toe: int = -1


def leg_chain(skeleton: Skeleton, hip: str, knee: str, ankle: str, toe: str | None = None) -> LegChain:
    """A :class:`LegChain` from joint names.

    Raises
    ------
    ValueError
        A name not in the skeleton, or joints that are not parent and child in this order.
    """
    names = [hip, knee, ankle] + ([toe] if toe else [])
    unknown = [n for n in names if n not in skeleton.names]
    if unknown:
        raise ValueError(f"leg: joints {unknown} are not in the skeleton")
    h, k, a = (skeleton.index(n) for n in (hip, knee, ankle))
    t = skeleton.index(toe) if toe else -1
    p = skeleton.parents
    if p[k] != h or p[a] != k or (t >= 0 and p[t] != a):
        raise ValueError(
            f"leg: expected {hip} -> {knee} -> {ankle}"
            + (f" -> {toe}" if toe else "")
            + " to be parent and child"
        )
    return LegChain(h, k, a, t)


def _unit(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.where(n > 0, n, 1.0), n[..., 0]


def _angle(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    uu, _ = _unit(u)
    vv, _ = _unit(v)
    return np.arccos(np.clip(np.einsum("...i,...i->...", uu, vv), -1.0, 1.0))


def rotation_between(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The smallest rotations taking the directions ``u`` to ``v``, ``(..., 3)`` -> ``(..., 3, 3)``.

    Antiparallel vectors turn by pi about an axis orthogonal to ``u``.
    """
    uu, nu = _unit(np.asarray(u, dtype=np.float64))
    vv, nv = _unit(np.asarray(v, dtype=np.float64))
    axis = np.cross(uu, vv)
    s = np.linalg.norm(axis, axis=-1)
    c = np.einsum("...i,...i->...", uu, vv)
    ang = np.arctan2(s, c)
    ax, _ = _unit(axis)
    flip = (s < 1e-9) & (c < 0)
    if flip.any():
        # any axis orthogonal to u
        e = np.where(np.abs(uu[..., :1]) < 0.9, np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]))
        alt, _ = _unit(np.cross(uu, e))
        ax = np.where(flip[..., None], alt, ax)
    ang = np.where((nu == 0) | (nv == 0), 0.0, ang)
    return _SO3.exp(ax * ang[..., None])


def two_bone_ik(
    hip: np.ndarray,
    knee: np.ndarray,
    ankle: np.ndarray,
    target: np.ndarray,
    bend_axis: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """World rotations that bring an ankle to a target (module docstring).

    Parameters
    ----------
    hip, knee, ankle, target : ndarray, shape (F, 3)
        Positions of the hip, knee and ankle joints and the ankle's target.
    bend_axis : ndarray, shape (F, 3), optional
        The knee's hinge axis in the world frame, oriented like ``(c - a) x (b - a)`` of a
        knee bent forwards (module docstring): a backward bend is straightened through 0, a
        nearly straight leg bends about it. Default: the plane of each frame as it is, and
        any axis orthogonal to a straight leg.

    Returns
    -------
    r_hip : ndarray, shape (F, 3, 3)
        ``R2 R0``: the new global rotation of the hip joint is ``r_hip @ G_hip``.
    r_knee : ndarray, shape (F, 3, 3)
        ``R2 R0 R1``: the new global rotation of the knee joint is ``r_knee @ G_knee``.
    """
    a, b, c, t = (np.asarray(x, dtype=np.float64) for x in (hip, knee, ankle, target))
    l1 = np.linalg.norm(b - a, axis=-1)
    l2 = np.linalg.norm(c - b, axis=-1)
    total = l1 + l2
    lo = np.abs(l1 - l2) + _SHRINK * total
    hi = total * (1.0 - _SHRINK)
    d = np.clip(np.linalg.norm(t - a, axis=-1), lo, hi)
    alpha0 = _angle(c - a, b - a)
    beta0 = _angle(a - b, c - b)
    safe = np.maximum(l1 * d, 1e-300)
    alpha1 = np.arccos(np.clip((l1**2 + d**2 - l2**2) / (2.0 * safe), -1.0, 1.0))
    beta1 = np.arccos(np.clip((l1**2 + l2**2 - d**2) / np.maximum(2.0 * l1 * l2, 1e-300), -1.0, 1.0))
    n, nn = _unit(np.cross(c - a, b - a))
    straight = nn < 1e-6 * np.maximum(total, 1e-300) ** 2
    if bend_axis is not None:
        # the knee bends one way only: orient the leg's plane by the hinge, so that a knee
        # bent backwards (hyperextended, common in blends) is straightened through 0 instead
        # of its bend being mirrored (a jump of twice the bend where the leg passes straight)
        h = np.asarray(bend_axis, dtype=np.float64)
        leg_dir, _ = _unit(c - a)
        h = h - np.einsum("...i,...i->...", h, leg_dir)[..., None] * leg_dir
        h, hn = _unit(h)
        sin_bend = nn / np.maximum(l1 * np.linalg.norm(c - a, axis=-1), 1e-300)
        weak = (sin_bend < _WEAK_BEND) & (hn > 0)
        back = ~weak & ~straight & (np.einsum("...i,...i->...", n, h) < 0)
        # signed angles about the oriented normal: a backward bend is beyond straight
        n = np.where(back[..., None], -n, n)
        alpha0 = np.where(back, -alpha0, alpha0)
        beta0 = np.where(back, 2.0 * np.pi - beta0, beta0)
        # nearly straight: the plane is ill-defined, bend about the hinge (signed likewise)
        sgn = np.sign(np.einsum("...i,...i->...", np.cross(c - a, b - a), h))
        w_back = weak & (sgn < 0)
        n = np.where(weak[..., None], h, n)
        alpha0 = np.where(w_back, -alpha0, alpha0)
        beta0 = np.where(w_back, 2.0 * np.pi - beta0, beta0)
        straight = straight & ~weak & (hn <= 0)
    if straight.any():
        if bend_axis is None:
            leg = c - a
            e = np.where(np.abs(leg[..., :1]) < 0.9 * np.linalg.norm(leg, axis=-1, keepdims=True), 1.0, 0.0)
            alt = np.cross(leg, np.concatenate([e, 1.0 - e, np.zeros_like(e)], axis=-1))
        else:
            alt = np.asarray(bend_axis, dtype=np.float64)
        alt, _ = _unit(alt)
        n = np.where(straight[..., None], alt, n)
    r0 = _SO3.exp(n * (alpha1 - alpha0)[..., None])
    r1 = _SO3.exp(n * (beta1 - beta0)[..., None])
    # after R0 (hip) and R1 (knee) the ankle is at distance d along the old direction c - a
    # (up to the knee's offset from the hinge's plane on a nearly straight leg: measured)
    c1 = np.einsum("...ij,...j->...i", r0, (b - a) + np.einsum("...ij,...j->...i", r1, c - b))
    r2 = rotation_between(c1, t - a)
    return r2 @ r0, r2 @ r0 @ r1


def _bend_axis_local(g_knee: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray | None:
    """The knee's bending axis in its own frame, from the frames where the leg is bent."""
    n, nn = _unit(np.cross(c - a, b - a))
    scale = np.linalg.norm(c - a, axis=-1) * np.linalg.norm(b - a, axis=-1)
    good = nn > 0.02 * np.maximum(scale, 1e-300)
    if not good.any():
        return None
    local = np.einsum("fji,fj->fi", g_knee[good], n[good])  # G^T n
    # the hinge's line: the main axis of the normals; its sign: the way the knee bends most
    # (weighted by the bend, so a few slightly hyperextended frames do not decide it)
    wgt = nn[good] / np.maximum(scale[good], 1e-300)
    _, vecs = np.linalg.eigh(np.einsum("f,fi,fj->ij", wgt, local, local))
    m = vecs[:, -1]
    if np.dot(wgt, local @ m) < 0:
        m = -m
    return m


def solve_legs(
    motion: Motion, legs: list[LegChain], targets: list[np.ndarray | None], *, hinge: bool = True
) -> Motion:
    """Move each leg's ankle to its target by two-bone IK (module docstring).

    Parameters
    ----------
    motion : Motion
    legs : list of LegChain
    targets : list of (ndarray of shape (F, 3) or None)
        World positions of each leg's ankle (the motion's unit); NaN rows or None: leave
        that frame (leg) alone.
    hinge : bool, default True
        Bend each knee about its hinge axis (estimated from the clip's bent frames): a knee
        bent backwards is straightened through 0 (blends). False keeps each frame's own bend
        plane: the least change for a small correction of a motion whose knees are its own
        (a loop's planted feet), even where the hinge estimate is poor.

    Returns
    -------
    Motion
        Same skeleton and root; only the rotations of the hip, knee and ankle joints change
        (the ankle keeps its global orientation), so bone lengths are kept exactly.
    """
    if len(targets) != len(legs):
        raise ValueError(f"targets: expected {len(legs)} arrays (one per leg); got {len(targets)}")
    rot = np.array(motion.rotations)
    parents = motion.skeleton.parents
    trans = motion.local_translations()
    for leg, tgt in zip(legs, targets, strict=True):
        if tgt is None:
            continue
        tgt = np.asarray(tgt, dtype=np.float64)
        sel = np.isfinite(tgt).all(axis=1)
        if not sel.any():
            continue
        pos, glob = joint_positions_and_rotations(parents, trans, rot)
        a, b, c = pos[:, leg.hip], pos[:, leg.knee], pos[:, leg.ankle]
        g_hip, g_knee, g_ankle = glob[:, leg.hip], glob[:, leg.knee], glob[:, leg.ankle]
        g_par = glob[:, parents[leg.hip]]
        axis_l = _bend_axis_local(g_knee, a, b, c) if hinge else None
        bend = None if axis_l is None else g_knee[sel] @ axis_l
        r_hip, r_knee = two_bone_ik(a[sel], b[sel], c[sel], tgt[sel], bend)
        new_hip = r_hip @ g_hip[sel]
        new_knee = r_knee @ g_knee[sel]
        rot[sel, leg.hip] = np.swapaxes(g_par[sel], -1, -2) @ new_hip
        rot[sel, leg.knee] = np.swapaxes(new_hip, -1, -2) @ new_knee
        rot[sel, leg.ankle] = np.swapaxes(new_knee, -1, -2) @ g_ankle[sel]
    return motion.replace(rotations=rot)


def turn_joint(motion: Motion, joint: int, turns: np.ndarray) -> Motion:
    """Turn a joint (and its subtree) in the world frame: ``G_joint' = turns @ G_joint``.

    Parameters
    ----------
    motion : Motion
    joint : int
        Not the root.
    turns : ndarray, shape (F, 3, 3)
        World rotations, one per frame (identity: no change).

    Returns
    -------
    Motion
        Only ``rotations[:, joint]`` changes: ``G_parent^T turns G_joint``.
    """
    parents = motion.skeleton.parents
    if joint <= 0:
        raise ValueError(f"joint: expected a joint other than the root; got {joint}")
    _, glob = joint_positions_and_rotations(parents, motion.local_translations(), motion.rotations)
    rot = np.array(motion.rotations)
    rot[:, joint] = np.swapaxes(glob[:, parents[joint]], -1, -2) @ turns @ glob[:, joint]
    return motion.replace(rotations=rot)


def _dilate(x: np.ndarray, half_width: float) -> np.ndarray:
    size = 2 * int(np.ceil(half_width)) + 1
    if size <= 1:
        return x
    return max_frames(np.maximum(x, 0.0), size) + min_frames(np.minimum(x, 0.0), size)


def root_correction(
    motion: Motion,
    legs: list[LegChain],
    targets: list[np.ndarray | None],
    *,
    reach: float = 0.999,
    sigma: float = 0.1,
    iterations: int = 6,
) -> np.ndarray:
    """A smooth offset of the root translation that brings every target within reach.

    Parameters
    ----------
    motion : Motion
    legs, targets
        As :func:`solve_legs` (NaN rows: no target in that frame).
    reach : float, default 0.999
        Fraction of the leg length ``l1 + l2`` a target may be from its hip.
    sigma : float, default 0.1
        Gaussian smoothing of the offset, seconds.
    iterations : int
        Rounds of (measure the excess, add it, smooth).

    Returns
    -------
    ndarray, shape (F, 3)
        Offset to add to ``motion.root_translation`` (world frame, the motion's unit); zero
        where every target is within reach.
    """
    f = motion.n_frames
    total = np.zeros((f, 3))
    pos = None
    parents = motion.skeleton.parents
    rot = motion.rotations
    trans0 = motion.local_translations()
    for _ in range(max(1, iterations)):
        trans = trans0.copy()
        trans[:, 0] += total
        pos, _ = joint_positions_and_rotations(parents, trans, rot)
        need = np.zeros((f, 3))
        for leg, tgt in zip(legs, targets, strict=True):
            if tgt is None:
                continue
            tgt = np.asarray(tgt, dtype=np.float64)
            a = pos[:, leg.hip]
            length = np.linalg.norm(pos[:, leg.knee] - a, axis=-1) + np.linalg.norm(
                pos[:, leg.ankle] - pos[:, leg.knee], axis=-1
            )
            v = tgt - a
            dist = np.linalg.norm(v, axis=-1)
            excess = dist - reach * length
            ok = np.isfinite(excess) & (excess > 0)
            if ok.any():
                need[ok] += v[ok] / dist[ok, None] * excess[ok, None]
        if not need.any():
            break
        # widen each need by 2 sigma (per component and sign) so that the smoothing keeps
        # its peak; the next round measures what is still missing
        total = total + gaussian_frames(_dilate(need, 2.0 * sigma * motion.fps), sigma * motion.fps)
    return total
