"""A motion as a curve: in the Lie group ``R^3 x SO(3)^J`` or as Euler angles in ``R^d``.

Both representations sample the motion's frames at uniform parameters ``t = i / (F-1)``
(frame ``i`` at time ``i / fps``, so ``t`` is time divided by the duration).

Lie curve (paper 000)
---------------------
``to_lie_curve`` gives a :class:`~elastic_motion.curves.DiscreteCurve` in
``animation_group(J, joint_weights, translation_weight)``: a point is the flat vector
``(root position (3), local rotation matrices of joints 0..J-1 (9 J, row-major))``. The
inner product on the Lie algebra is ``w_T |v|^2 + sum_j w_j |omega_j|^2`` (``v`` root
velocity in length units, ``omega_j`` angular velocity in radians; see
:mod:`elastic_motion.groups`). Default weights (:func:`default_joint_weights`,
:func:`default_translation_weight`):

* ``w_j`` proportional to the total length of the bones that joint ``j`` moves (the
  bones and end-site segments of its subtree), normalised to mean 1, floored at 0.01.
  Rotating a joint by ``theta`` moves each of those bones by up to ``theta`` times its
  distance from the joint, so the weight follows how much of the body a joint's rotation
  moves: the root (everything) weighs most, hips and shoulders more than knees and
  elbows, fingers almost nothing -- which also keeps the 180-degree finger flips of the
  CMU data from dominating a distance.
* ``w_T = J / L^2`` with ``L`` half the skeleton's diameter along its bones (about a leg
  length for a human; the diameter is hand-to-hand or hand-to-foot, about the body
  height). ``1 / L^2`` makes a root displacement of one leg length count like one radian
  of a joint of weight 1 -- the pendulum relation of walking, where the root advances by
  about the leg length per radian of leg swing. The factor ``J`` (the sum of the joint
  weights) puts the root translation on the scale of the whole body's rotation rather
  than of a single joint; on the walks of the test data the translational part of the
  mean squared speed is then 0.39-0.45 times the rotational part (0.83 for a run), so
  neither dominates nor vanishes (``tests/motion/test_motion_representations.py``).

Euler curve (the baseline of paper 001)
---------------------------------------
``to_euler_curve`` gives a curve in ``Euclidean(3 + 3 J)``: the root position, then for
each joint its three Euler angles in **radians**, in that joint's channel order
(:attr:`Skeleton.euler_orders`, intrinsic). The angles are made continuous over time:
each frame takes, of the two Euler solutions of its rotation (``(a, b, c)`` and
``(a + pi, pi - b, c + pi)``), shifted by multiples of ``2 pi``, the one nearest the
previous frame -- ``np.unwrap`` plus a choice of branch, so a middle angle that passes
90 degrees does not flip the other two by 180. The coordinate singularity itself (gimbal
lock) remains: that is the baseline's known weakness.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numba import njit

from elastic_motion.curves import DiscreteCurve
from elastic_motion.errors import OptionError
from elastic_motion.groups import Euclidean, ProductGroup, animation_group
from elastic_motion.motion.rotations import euler_to_matrix, matrix_to_euler
from elastic_motion.motion.skeleton import Motion, Skeleton
from elastic_motion.vocabulary import METHOD_ALIASES, METHODS, Method

__all__ = [
    "EULER",
    "LIE",
    "METHODS",
    "Method",
    "Representation",
    "default_joint_weights",
    "default_translation_weight",
    "from_euler_curve",
    "from_lie_curve",
    "group_weights",
    "lie_group_for",
    "representation",
    "skeleton_diameter",
    "to_euler_curve",
    "to_lie_curve",
    "unwrap_euler",
]

_MIN_WEIGHT = 0.01


# ------------------------------------------------------------------------------------------
# Weights
# ------------------------------------------------------------------------------------------
def _subtree_bone_length(skeleton: Skeleton) -> np.ndarray:
    """``(J,)`` summed length of the bones (offsets of descendants, end sites) below each joint."""
    n = skeleton.n_joints
    own = np.zeros(n)  # bones hanging directly from each joint
    lengths = skeleton.bone_lengths
    for k in range(1, n):
        own[skeleton.parents[k]] += lengths[k]
    if skeleton.end_site_parents.size:
        np.add.at(own, skeleton.end_site_parents, np.linalg.norm(skeleton.end_site_offsets, axis=1))
    total = own.copy()
    for k in range(n - 1, 0, -1):  # children come after parents: accumulate bottom-up
        total[skeleton.parents[k]] += total[k]
    return total


def default_joint_weights(skeleton: Skeleton) -> np.ndarray:
    """Default per-joint weights of the Lie-curve inner product.

    ``w_j`` is proportional to the summed length of the bones joint ``j`` moves (every
    bone and end-site segment in its subtree), normalised to mean 1, and floored at
    0.01 so that joints moving nothing (e.g. an end joint with a zero-length end site)
    keep a positive weight. See the module docstring for the reasoning.

    Parameters
    ----------
    skeleton : Skeleton

    Returns
    -------
    ndarray, shape (J,)
        Positive weights with mean 1 before flooring (unitless: the lengths cancel).
    """
    total = _subtree_bone_length(skeleton)
    if not total.max() > 0:
        return np.ones(skeleton.n_joints)
    w = total / total.mean()
    return np.maximum(w, _MIN_WEIGHT)


def skeleton_diameter(skeleton: Skeleton) -> float:
    """Longest path between two points of the skeleton along its bones (length units).

    The points are joints and end sites; the path length sums bone lengths (offset
    norms). For a human skeleton this is hand-to-hand or hand-to-foot, about the body
    height. Computed by two farthest-point searches on the tree.
    """
    n = skeleton.n_joints
    e = skeleton.end_site_parents.size
    nodes = n + e
    adj: list[list[tuple[int, float]]] = [[] for _ in range(nodes)]
    lengths = skeleton.bone_lengths
    for k in range(1, n):
        p = int(skeleton.parents[k])
        adj[p].append((k, float(lengths[k])))
        adj[k].append((p, float(lengths[k])))
    for i, (p, off) in enumerate(zip(skeleton.end_site_parents, skeleton.end_site_offsets, strict=True)):
        d = float(np.linalg.norm(off))
        adj[int(p)].append((n + i, d))
        adj[n + i].append((int(p), d))

    def farthest(start: int) -> tuple[int, float]:
        dist = np.full(nodes, -1.0)
        dist[start] = 0.0
        stack = [start]
        while stack:
            u = stack.pop()
            for v, w in adj[u]:
                if dist[v] < 0:
                    dist[v] = dist[u] + w
                    stack.append(v)
        far = int(np.argmax(dist))
        return far, float(dist[far])

    a, _ = farthest(0)
    _, d = farthest(a)
    return d


def default_translation_weight(skeleton: Skeleton) -> float:
    """Default weight ``w_T = J / L^2`` of the root translation, ``L`` = half the
    :func:`skeleton_diameter` (about a leg length). Units: 1 / length^2.

    Returns 1.0 for a skeleton of zero size.
    """
    half = 0.5 * skeleton_diameter(skeleton)
    if not half > 0:
        return 1.0
    return skeleton.n_joints / half**2


def group_weights(motions: Sequence[Motion]) -> tuple[np.ndarray, float]:
    """Inner-product weights shared by motions of one skeleton: the means of the per-motion
    defaults (:func:`default_joint_weights`, :func:`default_translation_weight`).

    Parameters
    ----------
    motions : sequence of Motion
        At least one; all with the same joints in the same order.

    Returns
    -------
    joint_weights : ndarray, shape (J,)
    translation_weight : float
        In 1 / (length unit)^2 of the motions.
    """
    motions = list(motions)
    if not motions:
        raise ValueError("motions: expected at least one motion to take weights from; got none")
    for m in motions:
        _check_weighable(m)
    return mean_weights(
        [default_joint_weights(m.skeleton) for m in motions],
        [default_translation_weight(m.skeleton) for m in motions],
    )


def _motion_label(motion: Motion) -> str:
    """How a message names a motion: its name (the file's stem), else its file, else "a motion"."""
    return motion.name or (motion.source[0] if motion.source else "a motion")


def _check_weighable(motion: Motion) -> None:
    """Refuse, naming the motion, a skeleton whose size squared over- or underflows (bones
    of 1e160 length units): its weights (:func:`default_translation_weight` is ``J / L^2``)
    would be 0, infinite or NaN."""
    with np.errstate(over="ignore", invalid="ignore"):
        d = skeleton_diameter(motion.skeleton)
        tw = default_translation_weight(motion.skeleton)
    if math.isfinite(d) and 0 < tw < math.inf:
        return
    sk = motion.skeleton
    reach = max(np.abs(sk.offsets).max(), np.abs(sk.end_site_offsets).max(initial=0.0))
    size = (
        f"{reach:.3g} length units"
        if motion.metres_per_unit is None
        else f"{reach * motion.metres_per_unit:.3g} m"
    )
    how = "large" if tw < math.inf else "small"
    raise ValueError(
        f"{_motion_label(motion)}: expected a skeleton of usual size; its offsets reach {size}, too "
        f"{how} for the weights of its curve (the size squared must be a normal floating-point "
        "number: check the file's offsets)"
    )


def mean_weights(
    joint_weights: Sequence[np.ndarray], translation_weights: Sequence[float]
) -> tuple[np.ndarray, float]:
    """:func:`group_weights` from the motions' defaults already computed (e.g. on the workers
    that read the files): their means, ``(J,)`` and a float, in this order of motions."""
    return np.mean(joint_weights, axis=0), float(np.mean(translation_weights))


def lie_group_for(
    skeleton: Skeleton,
    joint_weights: np.ndarray | None = None,
    translation_weight: float | None = None,
) -> ProductGroup:
    """``animation_group`` for ``skeleton`` with the default weights where not given."""
    jw = (
        default_joint_weights(skeleton)
        if joint_weights is None
        else np.asarray(joint_weights, dtype=np.float64)
    )
    if jw.shape != (skeleton.n_joints,):
        raise ValueError(
            f"joint_weights: expected one weight per joint, shape ({skeleton.n_joints},); got {jw.shape}"
        )
    tw = default_translation_weight(skeleton) if translation_weight is None else float(translation_weight)
    return animation_group(skeleton.n_joints, jw, tw)


def _check_joint_translations(motion: Motion) -> None:
    """Refuse motions whose non-root joints travel through position channels: a curve
    carries only the root's translation, so that motion would be silently lost."""
    jt = motion.joint_translations
    if jt is None:
        return
    sk = motion.skeleton
    mask = sk.has_position_channels.copy()
    mask[0] = False
    dev = np.linalg.norm(jt[:, mask] - sk.offsets[mask], axis=-1).max(axis=0)
    tol = 1e-3 * max(skeleton_diameter(sk), 1e-12)
    if (dev > tol).any():
        k = np.flatnonzero(mask)[int(np.argmax(dev))]
        raise ValueError(
            f"{_motion_label(motion)}: joint {sk.names[k]!r} moves through its position channels "
            f"(up to {dev.max():.4g} units from its offset), but a curve carries only the root's "
            "translation, so this motion cannot be made a curve (compared, blended, looped); in "
            "Python, if its root is a fixed reference joint (as in the Bandai files), "
            "elastic_motion.motion.merge_root(motion) first (the command line does that itself)"
        )


# ------------------------------------------------------------------------------------------
# Lie curve
# ------------------------------------------------------------------------------------------
def to_lie_curve(
    motion: Motion,
    weights: np.ndarray | None = None,
    *,
    translation_weight: float | None = None,
) -> DiscreteCurve:
    """The motion as a curve in ``R^3 x SO(3)^J``.

    Parameters
    ----------
    motion : Motion
        At least 2 frames.
    weights : array_like, shape (J,), optional
        Per-joint weights of the inner product; default :func:`default_joint_weights`.
    translation_weight : float, optional
        Weight of the root translation (1 / length^2); default
        :func:`default_translation_weight`.

    Returns
    -------
    DiscreteCurve
        ``values`` of shape ``(F, 3 + 9 J)`` (root position, then the row-major local
        rotation matrices), uniform parameters ``t = i / (F - 1)``; ``curve.group`` is
        the weighted ``animation_group``. Per-frame translations of non-root joints
        (position channels) are not part of the curve; :func:`from_lie_curve` takes them
        from its ``like`` motion.

    Raises
    ------
    ValueError
        If a non-root joint moves through position channels by more than 0.1 % of the
        skeleton's size (the Bandai hips): apply :func:`~.edit.merge_root` first.
    """
    _check_joint_translations(motion)
    group = lie_group_for(motion.skeleton, weights, translation_weight)
    values = group.join_points([motion.root_translation, motion.rotations])
    return DiscreteCurve(values, group=group)


def _uniform_samples(curve: DiscreteCurve) -> np.ndarray:
    n = curve.n_points
    grid = np.linspace(0.0, 1.0, n)
    if np.array_equal(curve.t, grid):
        return np.asarray(curve.values)
    return curve.evaluate(grid)


def _frame_rate(like: Motion, n: int, fps: float | None) -> float:
    if fps is not None:
        fps = float(fps)
        if not (math.isfinite(fps) and fps > 0):
            raise ValueError(f"fps: expected a positive frame rate; got {fps!r}")
        return fps
    if n == like.n_frames or like.n_frames < 2:
        return like.fps
    return (n - 1) / like.duration  # same duration as `like`


def _joint_translations_like(like: Motion, n: int) -> np.ndarray | None:
    jt = like.joint_translations
    if jt is None or n == like.n_frames:
        return jt
    src = np.linspace(0.0, 1.0, like.n_frames)
    dst = np.linspace(0.0, 1.0, n)
    flat = jt.reshape(like.n_frames, -1)
    out = np.stack([np.interp(dst, src, flat[:, c]) for c in range(flat.shape[1])], axis=1)
    return out.reshape(n, *jt.shape[1:])


def from_lie_curve(curve: DiscreteCurve, like: Motion, *, fps: float | None = None) -> Motion:
    """A motion from a curve in ``R^3 x SO(3)^J`` (inverse of :func:`to_lie_curve`).

    Parameters
    ----------
    curve : DiscreteCurve
        In a group with point shape ``(3 + 9 J,)`` (any weights). Samples at non-uniform
        parameters are first evaluated on a uniform grid of the same size (the curve is
        piecewise geodesic, so this is exact for it).
    like : Motion
        Supplies the skeleton, units, up axis and name; and per-frame translations of
        non-root joints, if any (linearly resampled to the curve's sample count).
    fps : float, optional
        Frame rate of the result. Default: ``like.fps`` when the sample counts match,
        otherwise the rate that keeps ``like``'s duration.

    Returns
    -------
    Motion
        One frame per curve sample; ``source = ()``.
    """
    j = like.n_joints
    expected = 3 + 9 * j
    if tuple(curve.group.point_shape) != (expected,):
        raise ValueError(
            f"curve: expected a curve in R^3 x SO(3)^{j} (points of shape ({expected},)) for a "
            f"{j}-joint skeleton; got point shape {tuple(curve.group.point_shape)}"
        )
    values = _uniform_samples(curve)
    n = values.shape[0]
    root = values[:, :3]
    rotations = values[:, 3:].reshape(n, j, 3, 3)
    return like.replace(
        fps=_frame_rate(like, n, fps),
        root_translation=root,
        rotations=rotations,
        joint_translations=_joint_translations_like(like, n),
        source=(),
    )


# ------------------------------------------------------------------------------------------
# Euler curve
# ------------------------------------------------------------------------------------------
@njit(cache=True)
def _unwrap_euler_kernel(a: np.ndarray) -> None:  # pragma: no cover - numba
    # a: (F, J, 3) Euler angles of one Tait-Bryan order per joint, modified in place.
    # For each frame pick, of (a, b, c) and (a + pi, pi - b, c + pi) (the same rotation),
    # each angle shifted by the multiple of 2 pi nearest the previous frame, the candidate
    # closest to the previous frame in the sum of squared differences.
    two_pi = 2.0 * np.pi
    f, n = a.shape[0], a.shape[1]
    best = np.empty(3)
    cand = np.empty(3)
    for i in range(1, f):
        for j in range(n):
            best_d = np.inf
            for branch in range(2):
                if branch == 0:
                    cand[0] = a[i, j, 0]
                    cand[1] = a[i, j, 1]
                    cand[2] = a[i, j, 2]
                else:
                    cand[0] = a[i, j, 0] + np.pi
                    cand[1] = np.pi - a[i, j, 1]
                    cand[2] = a[i, j, 2] + np.pi
                d = 0.0
                for k in range(3):
                    prev = a[i - 1, j, k]
                    # rint: np.round (ties to even) without numba's array-math registry at load
                    cand[k] += two_pi * np.rint((prev - cand[k]) / two_pi)
                    d += (cand[k] - prev) ** 2
                if d < best_d:
                    best_d = d
                    best[0] = cand[0]
                    best[1] = cand[1]
                    best[2] = cand[2]
            a[i, j, 0] = best[0]
            a[i, j, 1] = best[1]
            a[i, j, 2] = best[2]


def unwrap_euler(angles: np.ndarray) -> np.ndarray:
    """Make Tait-Bryan Euler angles continuous over time (branch choice + 2 pi shifts).

    Parameters
    ----------
    angles : array_like, shape (F, J, 3)
        Radians, any Tait-Bryan order per joint (the alternative solution
        ``(a + pi, pi - b, c + pi)`` is the same rotation for all of them).

    Returns
    -------
    ndarray, shape (F, J, 3)
        Same rotations; frame 0 unchanged; each later frame the solution nearest the
        previous one.
    """
    a = np.array(angles, dtype=np.float64, copy=True)
    if a.ndim != 3 or a.shape[2] != 3:
        raise ValueError(f"angles: expected shape (F, J, 3); got {a.shape}")
    _unwrap_euler_kernel(a)
    return a


def to_euler_curve(motion: Motion) -> DiscreteCurve:
    """The motion as a curve of continuous Euler angles in ``R^d``, ``d = 3 + 3 J``.

    Parameters
    ----------
    motion : Motion
        At least 2 frames.

    Returns
    -------
    DiscreteCurve
        In ``Euclidean(3 + 3 J)``: values ``(F, 3 + 3 J)`` = root position (length
        units), then per joint its Euler angles in radians in the joint's order
        (``motion.skeleton.euler_orders``), made continuous by :func:`unwrap_euler`;
        uniform parameters.

    Raises
    ------
    ValueError
        As :func:`to_lie_curve`, for non-root joints moving through position channels.
    """
    _check_joint_translations(motion)
    f, j = motion.n_frames, motion.n_joints
    orders = motion.skeleton.euler_orders
    angles = np.empty((f, j, 3))
    for order in sorted(set(orders)):
        idx = [k for k in range(j) if orders[k] == order]
        angles[:, idx] = matrix_to_euler(motion.rotations[:, idx], order)
    angles = unwrap_euler(angles)
    values = np.concatenate([motion.root_translation, angles.reshape(f, 3 * j)], axis=1)
    return DiscreteCurve(values, group=Euclidean(3 + 3 * j))


def from_euler_curve(curve: DiscreteCurve, like: Motion, *, fps: float | None = None) -> Motion:
    """A motion from an Euler-angle curve (inverse of :func:`to_euler_curve`).

    Parameters
    ----------
    curve : DiscreteCurve
        Values ``(n, 3 + 3 J)`` laid out as in :func:`to_euler_curve` for ``like``'s
        skeleton; non-uniform parameters are resampled linearly onto a uniform grid.
    like : Motion
        Supplies skeleton (and its Euler orders), units, up axis, name and non-root joint
        translations.
    fps : float, optional
        As in :func:`from_lie_curve`.

    Returns
    -------
    Motion
    """
    j = like.n_joints
    d = 3 + 3 * j
    if tuple(curve.group.point_shape) != (d,):
        raise ValueError(
            f"curve: expected an Euler curve in R^{d} (3 + 3 x {j} joints); got point shape "
            f"{tuple(curve.group.point_shape)}"
        )
    values = _uniform_samples(curve)
    n = values.shape[0]
    angles = values[:, 3:].reshape(n, j, 3)
    orders = like.skeleton.euler_orders
    rotations = np.empty((n, j, 3, 3))
    for order in sorted(set(orders)):
        idx = [k for k in range(j) if orders[k] == order]
        rotations[:, idx] = euler_to_matrix(angles[:, idx], order)
    return like.replace(
        fps=_frame_rate(like, n, fps),
        root_translation=values[:, :3],
        rotations=rotations,
        joint_translations=_joint_translations_like(like, n),
        source=(),
    )


# ------------------------------------------------------------------------------------------
# The representation, one home
# ------------------------------------------------------------------------------------------
# The curve a motion becomes: :data:`Method` (the Lie group curve, paper 000, or continuous
# Euler angles, the baseline of paper 001) and its values :data:`METHODS`, from
# :mod:`elastic_motion.vocabulary`. ``"euler"`` is accepted for ``"euler-elastic"``
# everywhere (:func:`representation`).


@dataclass(frozen=True)
class Representation:
    """A curve representation of motions (module docstring).

    Attributes
    ----------
    name : {"lie", "euler-elastic"}
        The public name (the ``method`` of the apps and the CLI's ``--method``).
    key : {"lie", "euler"}
        The short key of stored files (database caches and matrices).
    title : str
        What it is, for people.
    """

    name: str
    key: str
    title: str

    @property
    def is_lie(self) -> bool:
        """True for the Lie group curve."""
        return self.name == "lie"

    def to_curve(
        self, motion: Motion, joint_weights: np.ndarray | None = None, translation_weight: float | None = None
    ) -> DiscreteCurve:
        """The motion as a curve of this representation (:func:`to_lie_curve` with the weights,
        or :func:`to_euler_curve`, unweighted)."""
        if self.is_lie:
            return to_lie_curve(motion, joint_weights, translation_weight=translation_weight)
        return to_euler_curve(motion)

    def from_curve(self, curve: DiscreteCurve, like: Motion, *, fps: float | None = None) -> Motion:
        """A motion from a curve of this representation (:func:`from_lie_curve` or
        :func:`from_euler_curve`)."""
        if self.is_lie:
            return from_lie_curve(curve, like, fps=fps)
        return from_euler_curve(curve, like, fps=fps)

    def __str__(self) -> str:
        return self.name


#: The Lie group curve in ``R^3 x SO(3)^J`` (paper 000).
LIE = Representation("lie", "lie", "Lie group curve in R^3 x SO(3)^J")
#: Continuous Euler angles in ``R^(3 + 3 J)`` (the baseline of paper 001).
EULER = Representation("euler-elastic", "euler", "Euler angles in R^(3+3J)")

_BY_NAME = {"lie": LIE, "euler-elastic": EULER}
_BY_NAME.update({alias: _BY_NAME[name] for alias, name in METHOD_ALIASES.items()})


def representation(value: str | Representation, argument: str = "method") -> Representation:
    """The representation named ``value`` (``"lie"``, ``"euler-elastic"`` or ``"euler"``).

    Raises
    ------
    OptionError
        Any other value, naming ``argument``.
    """
    if isinstance(value, Representation):
        return value
    rep = _BY_NAME.get(value) if isinstance(value, str) else None
    if rep is None:
        raise OptionError(
            argument, f"expected one of {list(METHODS)} ('euler' for 'euler-elastic'); got {value!r}"
        )
    return rep
