"""Bringing one motion to the common form of a database: :func:`prepare_motion`.

The per-file steps every door of the library shares (read, drop a T-pose frame 0, fold a
static root, metres, Y-up) are :func:`elastic_motion.apps.prepare.load_motion`'s; this
module adds the database's own steps, in this order:

1. drop finger joints (``drop_fingers``; CMU's 180-degree flips);
2. remove the heading and the floor position of the root at frame 0 (``align_heading``;
   :func:`elastic_motion.motion.align_heading`);
3. keep the joints asked for (a list; ``"common"`` is applied to a whole set by
   :func:`restrict_to_common_joints`), closed towards the root
   (:func:`elastic_motion.apps.prepare.closed_joint_set`);
4. low-pass every joint (``smoothing``: a Gaussian of that standard deviation in seconds,
   :func:`elastic_motion.motion.edit.smooth_motion`, the low-pass ``distance`` applies before
   it samples its curves, :func:`elastic_motion.apps.align.motion_curves`; a database passes
   its ``warp.sample_smoothing``, :data:`~elastic_motion.defaults.DEFAULT_SAMPLE_SMOOTHING` by
   default);
5. resample to ``n_samples + 1`` frames uniformly over the clip's duration (geodesic
   interpolation of rotations), the grid of the SRV arrays.
"""

from __future__ import annotations

import os
from collections.abc import Sequence, Set
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from elastic_motion import motion as mm
from elastic_motion.apps.database.jointmap import map_to_common_body
from elastic_motion.apps.prepare import (
    MotionPreparation,
    PrepareOptions,
    closed_joint_set,
    load_motion,
    rest_pose_like,
)
from elastic_motion.curves import DiscreteCurve
from elastic_motion.errors import OptionError
from elastic_motion.motion import Motion
from elastic_motion.motion.edit import heading_angle
from elastic_motion.motion.representations import Representation, representation
from elastic_motion.motion.rotations import axis_rotation
from elastic_motion.notes import note_texts

__all__ = [
    "PreparedMotion",
    "balanced_pose_weight",
    "common_joint_names",
    "database_curves",
    "heading_relative_root",
    "pose_arrays",
    "prepare_motion",
    "prepare_same_skeleton",
    "restrict_prepared",
    "restrict_to_common_joints",
    "same_rest_pose",
    "with_pose_term",
]


@dataclass(frozen=True, eq=False)
class PreparedMotion:
    """A motion read, cleaned and resampled, ready for its curves.

    Attributes
    ----------
    path : str
    motion : Motion
        Metres when the unit is known, Y-up, resampled to ``n_samples + 1`` frames
        uniformly over the clip's duration.
    original_frames : int
        Frames after cleaning, before resampling.
    duration : float
        Seconds.
    notes : tuple of str
        What the preparation did, one sentence per step that changed something.
    preparation : MotionPreparation or None
        The report of the shared per-file steps (:func:`~elastic_motion.apps.prepare.load_motion`).
    """

    path: str
    motion: Motion
    original_frames: int
    duration: float
    notes: tuple[str, ...] = ()
    preparation: MotionPreparation | None = None

    @property
    def joint_names(self) -> tuple[str, ...]:
        """Joint names of the prepared motion, in skeleton order."""
        return tuple(self.motion.skeleton.names)


def prepare_motion(
    path: str | os.PathLike[str],
    n_samples: int,
    *,
    joints: str | Sequence[str] = "all",
    drop_fingers: bool = True,
    align_heading: bool = True,
    motion: Motion | None = None,
    options: PrepareOptions | None = None,
    smoothing: float = 0.0,
) -> PreparedMotion:
    """Read a motion file and bring it to the common form of a database (module docstring).

    Parameters
    ----------
    path : path
        The motion file (``.bvh``, ``.amc``, DeepMimic ``.txt`` / ``.json``).
    n_samples : int
        Cells of the common grid: the result has ``n_samples + 1`` frames.
    joints : "all", "common", "map" or sequence of str, default "all"
        ``"all"`` and ``"common"`` keep every joint here (``"common"`` is applied to a set by
        :func:`restrict_to_common_joints`); ``"map"`` maps the motion onto the common body
        model (:func:`~elastic_motion.apps.database.jointmap.map_to_common_body`); a sequence
        keeps those joints and their chains to the root.
    drop_fingers, align_heading : bool, default True
    motion : Motion, optional
        Use this motion instead of reading ``path`` (``path`` then only names it).
    options : PrepareOptions, optional
        The shared per-file steps (default ``PrepareOptions()``: drop a T-pose frame 0,
        fold a static root, unit guessed from the skeleton, up axis as read). Its set-level
        fields (``joints``, ``align``, ``trim``) are not used here.
    smoothing : float, default 0
        Standard deviation (seconds) of the Gaussian low-pass before the grid is sampled
        (step 4; 0: none). A database's curves pass ``settings.warp.sample_smoothing``; a mean
        and :func:`~elastic_motion.apps.database.find_within` resample the motions unfiltered.

    Returns
    -------
    PreparedMotion

    Raises
    ------
    ParseError
        Malformed file.
    OptionError
        Missing file, fewer than 3 frames, joints missing from the skeleton (all
        ``ValueError``).
    """
    label = Path(path).stem
    m, report = load_motion(path if motion is None else motion, options, label=label)
    notes = note_texts(report.notes)  # the cache stores texts
    if drop_fingers:
        fingers = mm.finger_joints(m.skeleton)
        if fingers:
            m = mm.drop_joints(m, fingers)
            notes.append(f"{label}: dropped {len(fingers)} finger joints")
    if joints == "map":
        m = map_to_common_body(m.replace(name=m.name or label))
        notes.append(f"{label}: mapped onto the 13-joint common body model")
    if align_heading:
        m = mm.align_heading(m)
    if not isinstance(joints, str):
        missing = [n for n in joints if n not in m.skeleton.names]
        if missing:
            raise OptionError(
                "joints",
                f"{label}: expected joints named {missing} in the skeleton; got a skeleton without them",
            )
        m = mm.select_joints(m, closed_joint_set(m.skeleton, joints))
    original = m.n_frames
    duration = m.duration
    target = np.linspace(0.0, duration, n_samples + 1)
    if smoothing > 0:  # the low-pass of distance's curves (apps.align.motion_curves), same function
        # only where the geodesic resample below reads (2 frames a cell, not every frame)
        m = mm.smooth_motion(m, smoothing, frames=mm.frames_read_at_times(m.times, target))
    m = mm.resample_at_times(m, m.times, target, fps=n_samples / duration)
    return PreparedMotion(os.fspath(path), m, original, duration, tuple(notes), report)


def common_joint_names(joint_names: Sequence[Sequence[str]]) -> frozenset[str]:
    """The joint names all motions have, for ``joints='common'``.

    Parameters
    ----------
    joint_names : sequence of sequence of str
        Joint names of each motion (:attr:`PreparedMotion.joint_names`), root first; at least one.

    Returns
    -------
    frozenset of str

    Raises
    ------
    OptionError
        When the motions share no root joint (``joints='common'`` cannot compare them).
    """
    common = set(joint_names[0])
    for names in joint_names[1:]:
        common &= set(names)
    roots = sorted({names[0] for names in joint_names})
    if len(roots) != 1 or not common:
        raise OptionError(
            "joints",
            "expected motions sharing a root joint for joints='common'; got roots "
            f"{roots} (compare them in separate runs or with joints='all')",
        )
    return frozenset(common)


def restrict_prepared(prepared: PreparedMotion, common: Set[str]) -> PreparedMotion:
    """``prepared`` on the joints of ``common`` whose chain to the root is in it too
    (:func:`~elastic_motion.apps.prepare.closed_joint_set`), with a note when that drops any;
    ``prepared`` itself when it keeps them all."""
    keep = closed_joint_set(prepared.motion.skeleton, common)
    if len(keep) == len(prepared.joint_names):
        return prepared
    note = f"{Path(prepared.path).stem}: kept the {len(keep)} joints shared by all motions"
    return replace(prepared, motion=mm.select_joints(prepared.motion, keep), notes=(*prepared.notes, note))


def restrict_to_common_joints(prepared: Sequence[PreparedMotion]) -> list[PreparedMotion]:
    """The prepared motions restricted to the joints all of them have (closed towards the root).

    :func:`common_joint_names` of the set, then :func:`restrict_prepared` of each motion (the
    two steps a distributed preparation runs apart: names on the driver, motions on workers).

    Parameters
    ----------
    prepared : sequence of PreparedMotion

    Returns
    -------
    list of PreparedMotion
        Same order; each on the same joints in its own skeleton order.

    Raises
    ------
    OptionError
        When the motions share no root joint (``joints='common'`` cannot compare them).
    """
    prepared = list(prepared)
    if not prepared:
        return []
    common = common_joint_names([p.joint_names for p in prepared])
    return [restrict_prepared(p, common) for p in prepared]


def heading_relative_root(motion: Motion) -> Motion:
    """The motion with its root moving in its own heading frame: a heading-invariant curve.

    The Lie curve's SRV sees the root through its world-frame velocity and its right-trivialised
    angular velocity ``log(R_{f+1} R_f^T)``; both turn with the heading. Here each frame's
    increments are expressed in the heading frame ``Y_f`` of that frame (the yaw of the root,
    :func:`elastic_motion.motion.edit.heading_angle`) and integrated again::

        p~_0 = Y_0^T p_0 (floor part 0),   p~_{f+1} = p~_f + Y_f^T (p_{f+1} - p_f)
        R~_0 = Y_0^T R_0,                  R~_{f+1} = Y_f^T (R_{f+1} R_f^T) Y_f R~_f

    so that rotating the whole motion about the up axis (or a turn happening later in a take)
    leaves the SRV unchanged, while speed, height, turning rate and the other joints stay.
    The result is a curve for comparisons, not a pose to show (its root path is straightened).

    Parameters
    ----------
    motion : Motion
        Any up axis.

    Returns
    -------
    Motion
        Same skeleton, frames and joint rotations; new root translation and root rotation.
    """
    up = "xyz".index(motion.up_axis.lower())
    rot = np.array(motion.rotations, dtype=np.float64)
    root = rot[:, 0]
    y = axis_rotation(heading_angle(root, up), "XYZ"[up])  # (F, 3, 3)
    yt = np.swapaxes(y, -1, -2)
    p = np.asarray(motion.root_translation, dtype=np.float64)
    dp = np.einsum("fij,fj->fi", yt[:-1], np.diff(p, axis=0))
    p0 = yt[0] @ p[0]
    p0[[a for a in range(3) if a != up]] = 0.0
    pn = np.concatenate([p0[None], p0 + np.cumsum(dp, axis=0)])
    inc = np.einsum("fij,fjk,flk->fil", yt[:-1], root[1:], root[:-1])  # Y^T R_{f+1} R_f^T
    inc = np.einsum("fij,fjk->fik", inc, y[:-1])
    rn = np.empty_like(root)
    rn[0] = yt[0] @ root[0]
    for f in range(len(inc)):
        rn[f + 1] = inc[f] @ rn[f]
    rot[:, 0] = rn
    return replace(motion, root_translation=pn, rotations=rot)


def prepare_same_skeleton(
    files: Sequence[str | os.PathLike[str]],
    n_samples: int,
    *,
    joints: str | Sequence[str] = "all",
    drop_fingers: bool = True,
    align_heading: bool = True,
    options: PrepareOptions | None = None,
) -> list[PreparedMotion]:
    """Prepare files that must share one skeleton (a mean, a statistical model).

    :func:`prepare_motion` for each file; ``joints="common"`` then keeps the joints all
    share (:func:`restrict_to_common_joints`), ``"map"`` maps every skeleton onto the common
    body model, a list keeps those joints. A file whose rest pose is another conversion's is
    re-expressed in the first file's rest frames
    (:func:`~elastic_motion.apps.prepare.rest_pose_like`, with a note). ``options``: how
    each file is read (:func:`prepare_motion`; ``up``, ``units``).

    Raises
    ------
    OptionError
        A file whose skeleton differs from the first's (naming the joints it lacks and has
        extra; ``joints='common'`` or ``'map'`` compare such files).
    """
    files = [os.fspath(f) for f in files]
    prepared = [
        prepare_motion(
            f,
            n_samples,
            joints=joints if joints == "map" or not isinstance(joints, str) else "all",
            drop_fingers=drop_fingers,
            align_heading=align_heading,
            options=options,
        )
        for f in files
    ]
    if joints == "common":
        prepared = restrict_to_common_joints(prepared)
    names0 = prepared[0].joint_names
    for f, p in zip(files, prepared, strict=True):
        if p.joint_names != names0:
            a, b = set(names0), set(p.joint_names)
            raise OptionError(
                "joints",
                f"{f}: expected the skeleton of {files[0]} ({len(a)} joints); got {len(b)} joints (lacks "
                f"{sorted(a - b) or 'nothing'}, extra {sorted(b - a) or 'nothing'}): pass joints='common' "
                "or joints='map'",
            )
    # one rest pose: a file from another conversion of the skeleton is re-expressed in the
    # first's rest frames (a mean of CMU 07_01 and 107_02_30hz had its feet 0.86 m up otherwise)
    return same_rest_pose(prepared)


def same_rest_pose(prepared: Sequence[PreparedMotion]) -> list[PreparedMotion]:
    """Each skeleton group's motions (same joint names) in the rest frames of its first:
    :func:`~elastic_motion.apps.prepare.rest_pose_like` of every later one (re-expressed, with
    a note, only when its rest pose is another conversion's). ``build_srv_cache`` does the
    same as a stage of its engine."""
    first: dict[tuple[str, ...], PreparedMotion] = {}
    out = []
    for p in prepared:
        ref = first.setdefault(p.joint_names, p)
        if ref is not p:
            moved, notes = rest_pose_like(
                ref.motion.skeleton, p.motion, Path(ref.path).stem, Path(p.path).stem
            )
            p = replace(p, motion=moved, notes=(*p.notes, *notes)) if notes else p
        out.append(p)
    return out


def database_curves(prepared: Sequence[PreparedMotion], method: str | Representation) -> list[DiscreteCurve]:
    """The curves of prepared motions of one skeleton in the representation ``method``
    (:func:`~elastic_motion.motion.representations.representation`): Lie curves with weights
    shared by all (:func:`elastic_motion.motion.group_weights`), or the Euler-angle curves."""
    rep = representation(method)
    weights = mm.group_weights([p.motion for p in prepared]) if rep.is_lie else (None, None)
    return [rep.to_curve(p.motion, *weights) for p in prepared]


def pose_arrays(motion: Motion, joint_weights: Sequence[float] | np.ndarray) -> np.ndarray:
    """The pose term of a motion on its cells: what the SRV forgets (it sees velocities).

    Per cell ``[f, f+1]`` and non-root joint ``j``: ``sqrt(w_j) (R_j - I) / sqrt(2)`` of its
    local rotation, the mean of the cell's two frames, flattened (9 numbers a joint). The map
    ``R -> (R - I) / sqrt(2)`` is continuous (a rotation vector flips sign at 180 degrees,
    where e.g. Bandai's upper legs sit relative to their rest), and its distance between two
    rotations about one axis is ``2 sin(angle / 2)``: the angle between them for small angles.
    Appended to an SRV array (:func:`with_pose_term`), the DP warps it with the SRV.

    Parameters
    ----------
    motion : Motion
        ``F`` frames (a prepared motion: ``n_samples + 1``).
    joint_weights : array_like, shape (J,)
        The Lie inner-product weights of the joints (``group_weights``); the root's is unused.

    Returns
    -------
    ndarray, shape (F - 1, 9 (J - 1))
    """
    w = np.asarray(joint_weights, dtype=np.float64)
    r = np.asarray(motion.rotations, dtype=np.float64)[:, 1:]
    if w.shape != (r.shape[1] + 1,):
        raise OptionError(
            "joint_weights", f"expected one weight per joint, shape ({r.shape[1] + 1},); got {w.shape}"
        )
    f = (r - np.eye(3)).reshape(len(r), -1, 9) / np.sqrt(2.0) * np.sqrt(w[1:])[None, :, None]
    return 0.5 * (f[1:] + f[:-1]).reshape(len(r) - 1, -1)


def balanced_pose_weight(srvs: Sequence[np.ndarray], poses: Sequence[np.ndarray]) -> float:
    """Label-free weight ``lam`` of the pose term for a set of motions.

    ``lam = sum_k |S_k - mean S|^2 / sum_k |P_k - mean P|^2`` over the set's SRV arrays
    ``S_k`` and pose arrays ``P_k`` (:func:`pose_arrays`; each of one shape): with it, the mean
    squared distance of the weighted pose terms over all pairs of the set (unwarped) equals
    that of the SRV terms (``sum_{k<l} |x_k - x_l|^2 = M sum_k |x_k - mean x|^2``). It uses
    no labels: only the motions of the set.

    Parameters
    ----------
    srvs, poses : sequences of ndarray
        One SRV array and one pose array per motion, at least two motions.

    Returns
    -------
    float
        ``> 0``; 0 when every pose array is the same (no pose to weigh).
    """
    if len(srvs) != len(poses) or len(srvs) < 2:
        raise OptionError(
            "poses", f"expected one pose array per SRV array, at least two; got {len(poses)} and {len(srvs)}"
        )
    den = _spread(poses, "poses")
    return _spread(srvs, "srvs") / den if den > 0 else 0.0


def _spread(arrays: Sequence[np.ndarray], name: str) -> float:
    """``sum_k |x_k - mean x|^2`` of arrays of one shape, in two passes over them: memory of
    one array, not of the whole set (a database's group can hold thousands)."""
    shape = np.shape(arrays[0])
    total = np.zeros(shape)
    for k, x in enumerate(arrays):
        if np.shape(x) != shape:
            raise OptionError(name, f"expected arrays of one shape {shape}; item {k} has {np.shape(x)}")
        total += x
    mean = total / len(arrays)
    return float(sum(np.sum((np.asarray(x, dtype=np.float64) - mean) ** 2) for x in arrays))


def with_pose_term(srv: np.ndarray, pose: np.ndarray, weight: float) -> np.ndarray:
    """The SRV array with the pose term appended: ``[q | sqrt(weight) * pose]``, C-contiguous.

    The squared ``L^2`` distance of two such arrays is the SRV term's plus ``weight`` times the
    pose term's, and the DP warps both (``docs/database.md``, "Retrieval quality")."""
    if weight < 0:
        raise OptionError("weight", f"expected a pose weight >= 0; got {weight!r}")
    return np.ascontiguousarray(np.concatenate([srv, np.sqrt(weight) * np.asarray(pose)], axis=1))
