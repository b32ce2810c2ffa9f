"""Bring motions to common ground and find the time warp between two of them.

:func:`prepare_motions` is the first step of every multi-motion command (blend, align,
distance): it makes the motions comparable. :func:`align_motions` then computes the
optimal time warp of B onto A (paper 001, eq. 21; paper 000, sec. 3.5), with or without
landmarks, and the elastic distance.

Conventions
-----------
* **Preparation** (:func:`prepare_motions`), in this order, each step recorded in
  ``PreparedMotions.notes``:

  1. lengths to metres when the unit is known (all or none must be known);
  2. the up axis of the first motion for all;
  3. a root that is a static reference frame (its only child has position channels, as
     in the Bandai files) is folded into that child;
  4. joints: identical joint sets are reordered to the first motion's order; different
     sets are an error naming the joints that differ, unless ``joints="common"`` (keep the
     joints all motions share, whole chains from the root) or an explicit list;
  5. frame rates: every motion is resampled (geodesic interpolation) to the first one's;
  6. placement (registration-curve style): each later motion is moved rigidly -- a
     rotation about the up axis and a floor-plane translation, heights untouched -- so
     that its root starts on the floor spot where the first motion's root starts, turned
     to best match the first one's root path: the rotation is the least-squares fit (2D
     Procrustes about the start) of the floor-plane root displacements from frame 0,
     sampled at equal fractions of each clip's duration. When either root path spans less
     than 10 cm (motion on the spot) the fit is ill-posed and the root's facing
     directions at frame 0 are matched instead.

* **Curve joints**: the curves that the warp and the blend work on carry every joint
  except the finger, thumb and hand-index joints (:func:`elastic_motion.motion.finger_joints`):
  in the CMU data these flip by 180 degrees between frames, where ``log`` is ambiguous and
  a single flip would dominate the SRV norm of the whole frame. Blends carry them along
  separately (:mod:`elastic_motion.apps.blend`).
* **Representations** (the ``method`` argument): ``"lie"`` -- the curve in
  ``R^3 x SO(3)^J`` with the inner-product weights of
  :func:`elastic_motion.apps.database.group_weights` shared by all the motions (paper
  000); ``"euler-linear"`` and ``"euler-elastic"`` -- continuous Euler angles in
  ``R^(3 + 3 J)``, root position in metres, angles in radians, unweighted (the baseline
  of paper 001). Each later motion's Euler angles are shifted by whole turns (``2 pi k``,
  per coordinate) to start nearest the first motion's, so that a heading of 179 degrees
  in one clip and -179 in the other are not 358 degrees apart.
* **Parameters and times**: a curve of a motion with duration ``d`` has parameter
  ``t = time / d`` in ``[0, 1]``. The warp ``phi`` maps A's parameter to B's: frame time
  ``tA`` of A matches ``d_B phi(tA / d_A)`` of B. Landmarks are given in seconds
  ``(tA, tB)`` and become ``(tA / d_A, tB / d_B)``.
* **Landmark weight** ``lam`` is relative: the feature term of the warp energy is
  ``lam * (||qA||^2 + ||qB||^2) * sum_m (phi(thetaA_m) - thetaB_m)^2`` (paper 001, eq. 21,
  squared penalty), so one value works for every representation and clip length. With the
  default 100, missing a landmark by 5 % of the clip costs a quarter of the two curves'
  squared SRV norms: enough to pull the warp onto the landmarks.
* The warp is computed on curves resampled to at most ``warp_fps`` frames per second
  (default 30): a warp is a function on ``[0, 1]``, independent of the sampling, and the DP
  cost grows with the square of the frame count.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from elastic_motion.curves import DiscreteCurve, SRVFunction, srv_transform
from elastic_motion.groups import Euclidean
from elastic_motion.motion import (
    Motion,
    finger_joints,
    has_reference_root,
    heading_angle,
    merge_root,
    resample,
    select_frames,
    select_joints,
    set_up_axis,
    to_euler_curve,
    to_lie_curve,
    to_metres,
)
from elastic_motion.motion.rotations import axis_rotation
from elastic_motion.warp import DEFAULT_MAX_STEP, WarpResult, optimal_warp, warp_energy

__all__ = [
    "DEFAULT_LAMBDA",
    "METHODS",
    "WARPS",
    "AlignResult",
    "PreparedMotions",
    "align_motions",
    "landmark_parameters",
    "motion_curves",
    "place_like",
    "prepare_motions",
    "resolve_landmarks",
    "solve_warp",
]

Method = Literal["euler-linear", "euler-elastic", "lie"]
WarpMode = Literal["none", "dp", "dp+refine"]

#: Blend / alignment methods: the two baselines of paper 001 Fig. 5 and paper 000's.
METHODS = ("euler-linear", "euler-elastic", "lie")
#: Warp modes: no warp, dynamic programming, DP then gradient refinement.
WARPS = ("none", "dp", "dp+refine")
#: Default relative landmark weight (see the module docstring).
DEFAULT_LAMBDA = 100.0
#: Default frame rate of the curves the warp is computed on.
DEFAULT_WARP_FPS = 30.0

_AXES = "xyz"
_MIN_PATH = 0.10  # metres: root paths shorter than this are "on the spot"


# ------------------------------------------------------------------------------------------
# Preparation
# ------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class PreparedMotions:
    """Motions brought to common ground (:func:`prepare_motions`).

    Attributes
    ----------
    motions : tuple of Motion
        Same joints in the same order, same frame rate, same up axis, metres when known;
        each later motion placed like the first.
    labels : tuple of str
        Names of the motions (``Motion.name`` or ``"motion k"``).
    curve_joints : tuple of str
        Joints carried by the curves (all but finger joints).
    joint_weights : ndarray, shape (len(curve_joints),)
        Lie inner-product weights of the curve joints, shared by all motions.
    translation_weight : float
        Lie inner-product weight of the root translation (1 / m^2).
    notes : tuple of str
        What was done, in words.
    """

    motions: tuple[Motion, ...]
    labels: tuple[str, ...]
    curve_joints: tuple[str, ...]
    joint_weights: np.ndarray
    translation_weight: float
    notes: tuple[str, ...] = field(default=())

    @property
    def fps(self) -> float:
        """The common frame rate."""
        return self.motions[0].fps

    @property
    def extra_joints(self) -> tuple[str, ...]:
        """Joints not carried by the curves (finger joints)."""
        keep = set(self.curve_joints)
        return tuple(n for n in self.motions[0].skeleton.names if n not in keep)

    def curve_motion(self, k: int) -> Motion:
        """Motion ``k`` restricted to the curve joints."""
        m = self.motions[k]
        if len(self.curve_joints) == m.n_joints:
            return m
        return select_joints(m, self.curve_joints)


def _check_motion(m: object, name: str) -> Motion:
    if not isinstance(m, Motion):
        raise ValueError(f"{name}: expected a Motion; got {type(m).__name__}")
    if m.n_frames < 3:
        raise ValueError(f"{name}: expected at least 3 frames; got {m.n_frames} ({m.name or 'unnamed'})")
    if not (np.isfinite(m.rotations).all() and np.isfinite(m.root_translation).all()):
        raise ValueError(f"{name}: expected finite rotations and root positions ({m.name or 'unnamed'})")
    return m


def _parent_names(m: Motion) -> dict[str, str | None]:
    sk = m.skeleton
    return {n: (sk.names[p] if p >= 0 else None) for n, p in zip(sk.names, sk.parents, strict=True)}


def _closed_set(m: Motion, names: set[str]) -> list[str]:
    """Names of ``m`` in ``names`` whose whole chain to the root is in ``names`` too."""
    sk = m.skeleton
    keep = np.zeros(sk.n_joints, dtype=bool)
    for j, n in enumerate(sk.names):
        keep[j] = n in names and (j == 0 or keep[sk.parents[j]])
    return [n for j, n in enumerate(sk.names) if keep[j]]


def _reorder(m: Motion, order: Sequence[str]) -> Motion:
    """Same joints in ``order`` (which must list parents before children)."""
    sk = m.skeleton
    if tuple(order) == sk.names:
        return m
    from elastic_motion.motion import Skeleton

    idx = np.array([sk.index(n) for n in order])
    pos = {n: i for i, n in enumerate(order)}
    parents = [-1] + [pos[sk.names[sk.parents[j]]] for j in idx[1:]]
    es_par = [pos[sk.names[p]] for p in sk.end_site_parents]
    new_sk = Skeleton(
        names=list(order),
        parents=parents,
        offsets=sk.offsets[idx],
        channels=[sk.channels[j] for j in idx],
        end_site_parents=es_par,
        end_site_offsets=sk.end_site_offsets,
    )
    jt = m.joint_translations
    return m.replace(
        skeleton=new_sk, rotations=m.rotations[:, idx], joint_translations=None if jt is None else jt[:, idx]
    )


def _describe_difference(a: Motion, b: Motion, la: str, lb: str) -> str:
    na, nb = set(a.skeleton.names), set(b.skeleton.names)
    only_a = [n for n in a.skeleton.names if n not in nb]
    only_b = [n for n in b.skeleton.names if n not in na]
    parts = []
    if only_a:
        parts.append(f"only in {la}: {only_a}")
    if only_b:
        parts.append(f"only in {lb}: {only_b}")
    if not parts:
        pa, pb = _parent_names(a), _parent_names(b)
        moved = [n for n in a.skeleton.names if pa[n] != pb[n]]
        parts.append(f"joints with different parents: {moved}")
    return "; ".join(parts)


def _floor_axes(up: int) -> tuple[int, int]:
    return (up + 1) % 3, (up + 2) % 3


def _root_path(m: Motion, up: int, n: int = 64) -> np.ndarray:
    """Floor-plane root positions ``(n, 2)`` at equal fractions of the clip."""
    p, q = _floor_axes(up)
    u = np.linspace(0.0, 1.0, n) * (m.n_frames - 1)
    src = np.arange(m.n_frames)
    r = m.root_translation
    return np.column_stack([np.interp(u, src, r[:, p]), np.interp(u, src, r[:, q])])


def _rigid(m: Motion, angle: float, shift: np.ndarray) -> Motion:
    """Rotate the world by ``angle`` about the up axis, then translate by ``shift`` (3,)."""
    up = _AXES.index(m.up_axis)
    rot = axis_rotation(np.array(angle), "XYZ"[up])
    rotations = m.rotations.copy()
    rotations[:, 0] = rot @ m.rotations[:, 0]
    root = m.root_translation @ rot.T + shift
    return m.replace(rotations=rotations, root_translation=root)


def place_like(reference: Motion, motion: Motion) -> tuple[Motion, str]:
    """Move ``motion`` rigidly (yaw + floor translation) to match ``reference`` (step 6 of
    the module docstring). Returns the moved motion and a note saying how."""
    up = _AXES.index(reference.up_axis)
    p, q = _floor_axes(up)
    scale = reference.metres_per_unit or 1.0
    pa, pb = _root_path(reference, up), _root_path(motion, up)
    a, b = pa - pa[0], pb - pb[0]
    span = min(np.ptp(pa, axis=0).max(), np.ptp(pb, axis=0).max()) * scale
    if span >= _MIN_PATH:
        cross = float(np.sum(b[:, 0] * a[:, 1] - b[:, 1] * a[:, 0]))
        dot = float(np.sum(b * a))
        angle = math.atan2(cross, dot)
        how = "start matched, root paths fitted"
    else:
        angle = float(
            heading_angle(reference.rotations[0, 0], up) - heading_angle(motion.rotations[0, 0], up)
        )
        how = "start and frame-0 facing matched (motion on the spot)"
    c, s = math.cos(angle), math.sin(angle)
    moved0 = np.array([c * pb[0, 0] - s * pb[0, 1], s * pb[0, 0] + c * pb[0, 1]])
    target = pa[0] - moved0
    shift = np.zeros(3)
    shift[p], shift[q] = target
    angle = (angle + math.pi) % (2 * math.pi) - math.pi
    return _rigid(motion, angle, shift), f"{how}: turned {math.degrees(angle):+.1f} deg about the up axis"


def prepare_motions(
    motions: Sequence[Motion],
    *,
    joints: str | Sequence[str] = "all",
    align: bool = True,
    labels: Sequence[str] | None = None,
) -> PreparedMotions:
    """Make motions comparable: units, up axis, joints, frame rate, placement.

    Parameters
    ----------
    motions : sequence of Motion
        At least one, each with at least 3 finite frames.
    joints : "all", "common" or sequence of str
        ``"all"``: the motions must have the same joints (in any order); ``"common"``: keep
        the joints they share; a sequence: keep these (and their ancestors must be listed).
    align : bool, default True
        Place each later motion like the first (module docstring, step 6).
    labels : sequence of str, optional
        Names used in messages (default ``Motion.name`` or ``"motion k"``).

    Returns
    -------
    PreparedMotions

    Raises
    ------
    ValueError
        Joint sets that differ (naming the joints), unknown units for some motions only,
        bad arguments.
    """
    motions = list(motions)
    if not motions:
        raise ValueError("motions: expected at least one motion")
    if labels is None:
        labels = [
            m.name if isinstance(m, Motion) and m.name else f"motion {k}" for k, m in enumerate(motions)
        ]
    labels = [str(x) for x in labels]
    if len(labels) != len(motions):
        raise ValueError(f"labels: expected {len(motions)} labels; got {len(labels)}")
    ms = [_check_motion(m, lab) for m, lab in zip(motions, labels, strict=True)]
    notes: list[str] = []
    known = [m.metres_per_unit is not None for m in ms]
    if all(known):
        ms = [to_metres(m) for m in ms]
    elif any(known):
        unknown = [lab for lab, k in zip(labels, known, strict=True) if not k]
        raise ValueError(
            f"motions: the length unit of {unknown} is unknown while others are known; "
            "read the files with units=... (CLI: --units)"
        )
    else:
        notes.append("length units unknown: lengths compared as they are in the files")
    up = ms[0].up_axis
    for k in range(1, len(ms)):
        if ms[k].up_axis != up:
            notes.append(f"{labels[k]}: rotated from {ms[k].up_axis}-up to {up}-up")
            ms[k] = set_up_axis(ms[k], up)
    for k, m in enumerate(ms):
        if has_reference_root(m):
            ms[k] = merge_root(m)
            notes.append(f"{labels[k]}: folded the static root {m.skeleton.names[0]!r} into its child")

    # joints
    if isinstance(joints, str) and joints not in ("all", "common"):
        raise ValueError(f"joints: expected 'all', 'common' or a list of joint names; got {joints!r}")
    if isinstance(joints, str) and joints == "all":
        names0 = set(ms[0].skeleton.names)
        pa = _parent_names(ms[0])
        for k in range(1, len(ms)):
            if set(ms[k].skeleton.names) != names0 or _parent_names(ms[k]) != pa:
                raise ValueError(
                    f"motions: {labels[0]} and {labels[k]} have different skeletons "
                    f"({_describe_difference(ms[0], ms[k], labels[0], labels[k])}); "
                    "use joints='common' (CLI: --joints common) to keep the shared joints"
                )
    else:
        if isinstance(joints, str):  # common
            wanted = set(ms[0].skeleton.names)
            for m in ms[1:]:
                wanted &= set(m.skeleton.names)
        else:
            wanted = {str(n) for n in joints}
            for m, lab in zip(ms, labels, strict=True):
                missing = sorted(wanted - set(m.skeleton.names))
                if missing:
                    raise ValueError(f"joints: {lab} has no joint named {missing}")
        keep = _closed_set(ms[0], wanted)
        if not keep:
            raise ValueError(
                f"joints: the motions share no joints starting from the root "
                f"(roots: {[m.skeleton.names[0] for m in ms]})"
            )
        for k, m in enumerate(ms):
            dropped = [n for n in m.skeleton.names if n not in keep]
            if dropped:
                notes.append(f"{labels[k]}: dropped joints not shared by all motions: {dropped}")
                ms[k] = select_joints(m, [n for n in m.skeleton.names if n in keep])
        pa = _parent_names(ms[0])
        for k in range(1, len(ms)):
            if set(ms[k].skeleton.names) != set(keep) or _parent_names(ms[k]) != pa:
                raise ValueError(
                    f"motions: {labels[0]} and {labels[k]} still differ after keeping the common joints "
                    f"({_describe_difference(ms[0], ms[k], labels[0], labels[k])})"
                )
    order = ms[0].skeleton.names
    for k in range(1, len(ms)):
        if ms[k].skeleton.names != order:
            ms[k] = _reorder(ms[k], order)
            notes.append(f"{labels[k]}: joints reordered like {labels[0]}")

    # frame rate
    fps = ms[0].fps
    for k in range(1, len(ms)):
        if not math.isclose(ms[k].fps, fps, rel_tol=1e-9):
            notes.append(
                f"{labels[k]}: resampled from {ms[k].fps:g} to {fps:g} fps (the frame rate of {labels[0]})"
            )
            ms[k] = resample(ms[k], fps)
            if ms[k].n_frames < 3:
                raise ValueError(f"{labels[k]}: fewer than 3 frames at {fps:g} fps")

    # placement
    if align:
        for k in range(1, len(ms)):
            ms[k], how = place_like(ms[0], ms[k])
            notes.append(f"{labels[k]}: placed like {labels[0]} ({how})")

    fingers = set(finger_joints(ms[0].skeleton))
    curve_joints = tuple(n for n in order if n not in fingers)
    from elastic_motion.apps.database import group_weights

    body = [select_joints(m, curve_joints) if fingers else m for m in ms]
    jw, tw = group_weights(body)
    if fingers:
        notes.append(f"finger joints blended frame by frame, not part of the curves: {sorted(fingers)}")
    return PreparedMotions(tuple(ms), tuple(labels), curve_joints, np.asarray(jw), float(tw), tuple(notes))


# ------------------------------------------------------------------------------------------
# Curves and warps
# ------------------------------------------------------------------------------------------


def motion_curves(
    prepared: PreparedMotions,
    method: str,
    *,
    fps: float | None = None,
    which: Sequence[int] | None = None,
) -> list[DiscreteCurve]:
    """The curves of prepared motions in the representation of ``method``.

    Parameters
    ----------
    prepared : PreparedMotions
    method : {"lie", "euler-linear", "euler-elastic"}
        ``"lie"``: ``R^3 x SO(3)^J`` with the shared weights; ``"euler-*"``: continuous
        Euler angles, each later motion shifted by whole turns to start nearest the first.
    fps : float, optional
        Downsample (geodesic interpolation) to at most this frame rate; default: as they are.
    which : sequence of int, optional
        Indices of the motions (default all).

    Returns
    -------
    list of DiscreteCurve
        Over the curve joints; points ``(3 + 9 J,)`` (lie) or ``(3 + 3 J,)`` (euler).
    """
    _check_method(method)
    idx = range(len(prepared.motions)) if which is None else list(which)
    out = []
    ref_angles = None
    for k in idx:
        m = prepared.curve_motion(k)
        if fps is not None and m.fps > fps * (1 + 1e-9):
            m = resample(m, fps)
        if method == "lie":
            out.append(
                to_lie_curve(m, prepared.joint_weights, translation_weight=prepared.translation_weight)
            )
            continue
        c = to_euler_curve(m)
        if ref_angles is None:
            first = select_frames(prepared.curve_motion(0), slice(0, 2))
            ref_angles = to_euler_curve(first).values[0, 3:]
        vals = np.array(c.values)
        turns = np.round((ref_angles - vals[0, 3:]) / (2 * math.pi))
        vals[:, 3:] += 2 * math.pi * turns
        out.append(DiscreteCurve(vals, Euclidean(vals.shape[1]), c.t))
    return out


def _check_method(method: str) -> str:
    if method not in METHODS:
        raise ValueError(f"method: expected one of {list(METHODS)}; got {method!r}")
    return method


def _check_warp(warp: str) -> str:
    if warp not in WARPS:
        raise ValueError(f"warp: expected one of {list(WARPS)}; got {warp!r}")
    return warp


def landmark_parameters(
    pairs: Sequence[tuple[float, float]],
    duration_a: float,
    duration_b: float,
    labels: tuple[str, str] = ("A", "B"),
) -> np.ndarray:
    """Landmark pairs in seconds -> curve parameters ``(M, 2)`` in ``[0, 1]``.

    Raises
    ------
    ValueError
        A time outside a clip (naming the pair, the time and the duration) or pairs out of
        order (no increasing warp meets them).
    """
    arr = np.asarray(pairs, dtype=np.float64).reshape(-1, 2)
    for m, (ta, tb) in enumerate(arr):
        for t, d, lab in ((ta, duration_a, labels[0]), (tb, duration_b, labels[1])):
            if not (np.isfinite(t) and -1e-9 <= t <= d + 1e-9):
                raise ValueError(
                    f"landmarks: pair {m} has time {t:g} s in {lab}, outside its duration [0, {d:g}] s"
                )
    theta = np.column_stack([arr[:, 0] / duration_a, arr[:, 1] / duration_b]) if arr.size else arr
    theta = np.clip(theta, 0.0, 1.0)
    for m in range(1, theta.shape[0]):
        if not (theta[m, 0] > theta[m - 1, 0] and theta[m, 1] > theta[m - 1, 1]):
            raise ValueError(
                f"landmarks: pairs {m - 1} and {m} are not in increasing order in both motions "
                f"({arr[m - 1].tolist()} then {arr[m].tolist()} s); no time warp can meet both"
            )
    return theta


def solve_warp(
    srv_a: SRVFunction,
    srv_b: SRVFunction,
    warp: str = "dp",
    *,
    landmarks: np.ndarray | None = None,
    lam: float = DEFAULT_LAMBDA,
    neighbourhood: int = DEFAULT_MAX_STEP,
) -> WarpResult | None:
    """The optimal warp of B onto A (:func:`elastic_motion.warp.optimal_warp`).

    Parameters
    ----------
    srv_a, srv_b : SRVFunction
    warp : {"none", "dp", "dp+refine"}
        ``"none"`` returns None.
    landmarks : ndarray, shape (M, 2), optional
        Curve parameters (:func:`landmark_parameters`).
    lam : float
        Relative landmark weight (module docstring).
    neighbourhood : int
        DP slopes.
    """
    _check_warp(warp)
    if not (np.isfinite(lam) and lam >= 0):
        raise ValueError(f"lam: expected a non-negative landmark weight; got {lam!r}")
    if warp == "none":
        if landmarks is not None and len(landmarks):
            raise ValueError("landmarks: need a time warp (warp='dp' or 'dp+refine'), not warp='none'")
        return None
    kw: dict[str, Any] = {}
    if landmarks is not None and len(landmarks):
        kw["landmarks"] = np.asarray(landmarks)
        kw["lam"] = float(lam) * (srv_a.norm() ** 2 + srv_b.norm() ** 2)
    return optimal_warp(
        srv_a.q, srv_b.q, t0=srv_a.t, t1=srv_b.t, method=warp, neighbourhood=neighbourhood, **kw
    )


# ------------------------------------------------------------------------------------------
# Alignment of two motions
# ------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class AlignResult:
    """The time warp between two motions (:func:`align_motions`).

    Attributes
    ----------
    vertices : ndarray, shape (K, 2)
        The warp ``phi`` (A's parameter -> B's), piecewise linear; identity for ``warp="none"``.
    distance : float
        ``||qA - qB * phi||`` (elastic distance of the curves when there are no landmarks).
    distance_unwarped : float
        ``||qA - qB||`` (no warp; the distance of parametrised curves, paper 000 eq. 4).
    landmark_cost : float
        The landmark term of the energy at the optimum (absolute; 0 without landmarks).
    landmarks : tuple of (float, float)
        Landmark pairs used, seconds ``(tA, tB)``.
    method, warp : str
    duration_a, duration_b : float
        Seconds.
    prepared : PreparedMotions
    result : WarpResult or None
        The solver's full result (None for ``warp="none"``).
    """

    vertices: np.ndarray
    distance: float
    distance_unwarped: float
    landmark_cost: float
    landmarks: tuple[tuple[float, float], ...]
    method: str
    warp: str
    duration_a: float
    duration_b: float
    prepared: PreparedMotions
    result: WarpResult | None = None

    def time_in_b(self, time_a: np.ndarray | float) -> np.ndarray:
        """Time in B (seconds) matched to time ``time_a`` in A (seconds), any shape."""
        ta = np.asarray(time_a, dtype=np.float64)
        u = np.clip(ta / self.duration_a, 0.0, 1.0)
        return np.interp(u, self.vertices[:, 0], self.vertices[:, 1]) * self.duration_b

    def warp_times(self) -> tuple[np.ndarray, np.ndarray]:
        """The warp's vertices in seconds: ``(times in A, times in B)``, each ``(K,)``."""
        return self.vertices[:, 0] * self.duration_a, self.vertices[:, 1] * self.duration_b

    def summary(self) -> dict[str, Any]:
        """The fields of a JSON report (``warp_vertices_s``: the warp in seconds)."""
        ta, tb = self.warp_times()
        out: dict[str, Any] = {
            "method": self.method,
            "warp": self.warp,
            "distance": self.distance,
            "distance_unwarped": self.distance_unwarped,
            "landmark_cost": self.landmark_cost,
            "landmarks_s": [list(p) for p in self.landmarks],
            "landmarks_matched_s": [[ta_, float(self.time_in_b(ta_))] for ta_, _ in self.landmarks],
            "duration_a_s": self.duration_a,
            "duration_b_s": self.duration_b,
            "warp_vertices_s": np.column_stack([ta, tb]).tolist(),
            "notes": list(self.prepared.notes),
        }
        if self.result is not None:
            d = self.result.diagnostics
            out["solver"] = {
                "grid": list(d.grid_shape),
                "slopes": d.n_steps,
                "time_s": d.time_total,
            }
        return out


def resolve_landmarks(
    landmarks: Any,
    a: Motion,
    b: Motion,
    *,
    kinds: Sequence[str] | None = None,
    max_pairs: int | None = None,
) -> list[tuple[float, float]]:
    """Landmark pairs in seconds from ``None``, ``"auto"`` or pairs ``(tA, tB)``.

    ``"auto"`` pairs the detected events of the two (prepared) motions in order
    (:func:`elastic_motion.apps.landmarks.auto_landmarks`, default kind: the left knee passing
    the right knee).
    """
    if landmarks is None or (isinstance(landmarks, str) and landmarks == "none"):
        return []
    if isinstance(landmarks, str):
        if landmarks != "auto":
            raise ValueError(
                f"landmarks: expected None, 'auto' or pairs (tA, tB) in seconds; got {landmarks!r}"
            )
        from elastic_motion.apps.landmarks import DEFAULT_PAIR_KINDS, auto_landmarks

        return auto_landmarks(a, b, tuple(kinds) if kinds else DEFAULT_PAIR_KINDS, max_pairs=max_pairs)
    arr = np.asarray(landmarks, dtype=np.float64)
    if arr.size == 0:
        return []
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise ValueError(f"landmarks: expected pairs (tA, tB) of shape (M, 2); got shape {arr.shape}")
    return [(float(x), float(y)) for x, y in arr]


def align_motions(
    a: Motion,
    b: Motion,
    *,
    method: str = "lie",
    warp: str = "dp",
    landmarks: Any = None,
    lam: float = DEFAULT_LAMBDA,
    joints: str | Sequence[str] = "all",
    align: bool = True,
    warp_fps: float = DEFAULT_WARP_FPS,
    neighbourhood: int = DEFAULT_MAX_STEP,
    landmark_kinds: Sequence[str] | None = None,
    max_pairs: int | None = None,
) -> AlignResult:
    """The optimal time warp of B onto A and their elastic distance.

    Parameters
    ----------
    a, b : Motion
    method : {"lie", "euler-elastic", "euler-linear"}
        Representation of the curves (both Euler methods use the Euler SRV here).
    warp : {"dp", "dp+refine", "none"}
    landmarks : None, "auto" or array_like of shape (M, 2)
        Pairs ``(time in A, time in B)`` in seconds, or automatic (:mod:`.landmarks`).
    lam : float
        Relative landmark weight (module docstring).
    joints : "all", "common" or sequence of str
        See :func:`prepare_motions`.
    align : bool
        Place B like A first (heading and floor position).
    warp_fps : float
        Frame rate of the curves the DP runs on (at most).
    neighbourhood : int
        DP slopes (coprime steps up to this).
    landmark_kinds, max_pairs
        For ``landmarks="auto"``: event kinds and pairs per kind.

    Returns
    -------
    AlignResult
    """
    _check_method(method)
    _check_warp(warp)
    prep = prepare_motions([a, b], joints=joints, align=align)
    ma, mb = prep.motions
    pairs = resolve_landmarks(landmarks, ma, mb, kinds=landmark_kinds, max_pairs=max_pairs)
    theta = landmark_parameters(pairs, ma.duration, mb.duration, prep.labels[:2]) if pairs else None
    if isinstance(landmarks, str) and landmarks == "auto" and not pairs and warp != "none":
        prep = PreparedMotions(
            prep.motions,
            prep.labels,
            prep.curve_joints,
            prep.joint_weights,
            prep.translation_weight,
            (*prep.notes, "landmarks auto: no events to pair; warp without landmarks"),
        )
    ca, cb = motion_curves(prep, method, fps=warp_fps)
    sa, sb = srv_transform(ca), srv_transform(cb)
    res = solve_warp(sa, sb, warp, landmarks=theta, lam=lam, neighbourhood=neighbourhood)
    identity = np.array([[0.0, 0.0], [1.0, 1.0]])
    unwarped = math.sqrt(max(warp_energy(sa.q, sb.q, identity, sa.t, sb.t), 0.0))
    if res is None:
        verts, dist, lcost = identity, unwarped, 0.0
    else:
        verts, dist, lcost = np.asarray(res.vertices), float(res.distance), float(res.landmark_cost)
    return AlignResult(
        vertices=verts,
        distance=dist,
        distance_unwarped=unwarped,
        landmark_cost=lcost,
        landmarks=tuple(pairs),
        method=method,
        warp=warp,
        duration_a=ma.duration,
        duration_b=mb.duration,
        prepared=prep,
        result=res,
    )
