"""Editing a motion: frames, joints, time, units and placement. Every function returns a
new :class:`~.skeleton.Motion` and leaves its input untouched.

* Frames and time: :func:`drop_tpose` (the CMU conversions start with a T-pose frame),
  :func:`trim` (by time in seconds), :func:`resample` (to a frame rate, geodesic
  interpolation of rotations), :func:`resample_at_times`, :func:`smooth_motion` (a Gaussian
  low-pass in time, the anti-aliasing step before sampling a curve at a lower rate).
* Joints: :func:`select_joints`, :func:`drop_joints`, :func:`finger_joints` (CMU hand
  joints flip by 180 degrees between frames: drop them before comparing motions),
  :func:`merge_root` (fold a static reference root, like the Bandai files' ``joint_Root``,
  into its only child, so that the moving hips become the root).
* Placement: :func:`align_heading` (remove the yaw and the floor-plane translation at a
  reference frame, as registration curves do), :func:`place_on_floor`,
  :func:`set_up_axis`, :func:`to_metres`.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Sequence

import numpy as np

from elastic_motion import limits
from elastic_motion.errors import OptionError
from elastic_motion.groups import SO3
from elastic_motion.motion.filters import gaussian_frames
from elastic_motion.motion.kinematics import forward_kinematics
from elastic_motion.motion.rotations import axis_rotation
from elastic_motion.motion.skeleton import Motion, Skeleton
from elastic_motion.vocabulary import INTERPOLATIONS

__all__ = [
    "align_heading",
    "drop_joints",
    "drop_tpose",
    "eased_envelope",
    "finger_joints",
    "frames_read_at_times",
    "gaussian_frames",
    "has_reference_root",
    "has_tpose_first_frame",
    "heading_angle",
    "lift_out_of_floor",
    "merge_root",
    "place_like",
    "place_on_floor",
    "resample",
    "resample_at_times",
    "select_frames",
    "select_joints",
    "set_up_axis",
    "smooth_change",
    "smooth_motion",
    "smoothstep",
    "to_metres",
    "trim",
]

_SO3 = SO3()
_AXES = "xyz"
_FINGER = re.compile(r"finger|thumb|index", re.IGNORECASE)


# ------------------------------------------------------------------------------------------
# Frames and time
# ------------------------------------------------------------------------------------------
def select_frames(motion: Motion, frames: slice | Sequence[int] | np.ndarray) -> Motion:
    """Keep the given frames (a slice, indices or a boolean mask); fps unchanged.

    Raises
    ------
    ValueError
        If no frame is left.
    """
    idx = np.arange(motion.n_frames)[frames]
    if idx.size == 0:
        raise ValueError(
            f"frames: expected a selection of at least one of {motion.n_frames} frames; got none"
        )
    jt = motion.joint_translations
    return motion.replace(
        rotations=motion.rotations[idx],
        root_translation=motion.root_translation[idx],
        joint_translations=None if jt is None else jt[idx],
    )


def _frame_jumps(motion: Motion, joints: Sequence[int]) -> np.ndarray:
    """Largest rotation (degrees) between consecutive frames over ``joints``, ``(F-1,)``."""
    r = motion.rotations[:, joints]
    rel = np.swapaxes(r[:-1], -1, -2) @ r[1:]
    ang = np.linalg.norm(_SO3.log(rel), axis=-1)
    return np.degrees(ang.max(axis=1))


def has_tpose_first_frame(motion: Motion, *, min_jump_deg: float = 45.0) -> bool:
    """True if frame 0 does not belong to the motion that follows (a T-pose/rest frame).

    Frame 0 is judged foreign when the largest joint rotation between frames 0 and 1
    (finger and thumb joints excluded, they flip anyway) exceeds both ``min_jump_deg``
    and 1.5 times the largest such jump anywhere else in the clip. On the CMU files the
    T-pose jump is 79-176 degrees against at most 54 elsewhere; clips without a T-pose
    frame start with a 1-8 degree step.

    Parameters
    ----------
    motion : Motion
        At least 3 frames (fewer: ``False``).
    min_jump_deg : float, default 45
    """
    if motion.n_frames < 3:
        return False
    fingers = set(finger_joints(motion.skeleton))
    body = [k for k, n in enumerate(motion.skeleton.names) if n not in fingers]
    jumps = _frame_jumps(motion, body)
    return bool(jumps[0] > min_jump_deg and jumps[0] > 1.5 * jumps[1:].max())


def drop_tpose(motion: Motion, *, force: bool = False) -> Motion:
    """Drop frame 0 when it is a T-pose (:func:`has_tpose_first_frame`), or always with
    ``force=True``. Returns the motion unchanged otherwise."""
    if force or has_tpose_first_frame(motion):
        if motion.n_frames < 2:
            raise ValueError("motion: cannot drop the first frame of a one-frame motion")
        return select_frames(motion, slice(1, None))
    return motion


def trim(motion: Motion, start: float | None = None, stop: float | None = None) -> Motion:
    """Keep the frames with time ``start <= t <= stop`` (seconds from frame 0).

    Parameters
    ----------
    motion : Motion
    start, stop : float, optional
        Bounds in seconds (default: the clip's ends). A frame within 1e-9 s of a bound
        counts as inside.

    Raises
    ------
    ValueError
        If no frame lies in the interval.
    """
    t = motion.times
    lo = -math.inf if start is None else float(start) - 1e-9
    hi = math.inf if stop is None else float(stop) + 1e-9
    keep = (t >= lo) & (t <= hi)
    if not keep.any():
        raise ValueError(
            f"start, stop: expected an interval holding at least one frame of [0, {motion.duration:g}] s; "
            f"got [{start}, {stop}]"
        )
    return select_frames(motion, keep)


# How a motion is sampled between its frames (:func:`resample_at_times`): INTERPOLATIONS,
# the values of Interpolation (elastic_motion.vocabulary).


def check_interpolation(interpolation: str, error: type = ValueError) -> str:
    """``interpolation`` if it is one of :data:`INTERPOLATIONS`; else ``error("interpolation", ...)``
    (an :class:`~elastic_motion.errors.OptionError`) or ``ValueError("interpolation: ...")``."""
    if interpolation not in INTERPOLATIONS:
        msg = f"expected one of {list(INTERPOLATIONS)}; got {interpolation!r}"
        if error is ValueError:
            raise ValueError(f"interpolation: {msg}")
        raise error("interpolation", msg)
    return interpolation


def _check_target_times(src: np.ndarray, dst: np.ndarray) -> None:
    """Raise unless ``dst`` is a non-empty 1-D array of times within ``[src[0], src[-1]]``."""
    if dst.ndim != 1 or dst.size == 0:
        raise ValueError(f"target_times: expected a non-empty 1-D array; got shape {dst.shape}")
    tol = 1e-9 * max(1.0, abs(src[-1]))
    if dst.min() < src[0] - tol or dst.max() > src[-1] + tol:
        raise ValueError(
            f"target_times: expected times within [{src[0]:g}, {src[-1]:g}] s; "
            f"got [{dst.min():g}, {dst.max():g}]"
        )


def resample_at_times(
    motion: Motion,
    source_times: np.ndarray,
    target_times: np.ndarray,
    *,
    fps: float,
    interpolation: str = "geodesic",
) -> Motion:
    """Sample a motion whose frames sit at ``source_times`` at ``target_times``.

    ``interpolation="geodesic"``: rotations along the geodesic of SO(3) between the two
    neighbouring frames, ``R = R_k exp(s log(R_k^T R_k+1))``, ``s`` the fraction of the
    interval (slerp; the shorter arc); translations linearly.

    ``interpolation="cubic"``: each rotation matrix's entries and the translations by a
    not-a-knot cubic spline through the frames (:class:`scipy.interpolate.CubicSpline`), the
    matrices then projected to the nearest rotation (polar factor by SVD, determinant +1).
    Exact at the frames and twice continuously differentiable between them, so a motion
    sampled between its frames keeps its velocity peaks where the geodesic cuts their
    corners. Motions of fewer than 4 frames are sampled geodesically.

    Parameters
    ----------
    motion : Motion
    source_times : array_like, shape (F,)
        Strictly increasing times of the motion's frames, seconds.
    target_times : array_like, shape (N,)
        Times to sample, within ``[source_times[0], source_times[-1]]``.
    fps : float
        Frame rate recorded on the result.
    interpolation : {"geodesic", "cubic"}, default "geodesic"

    Returns
    -------
    Motion
        ``N`` frames.
    """
    check_interpolation(interpolation, ValueError)
    src = np.asarray(source_times, dtype=np.float64)
    dst = np.asarray(target_times, dtype=np.float64)
    if src.shape != (motion.n_frames,):
        raise ValueError(f"source_times: expected shape ({motion.n_frames},); got {src.shape}")
    if motion.n_frames > 1 and not (np.diff(src) > 0).all():
        raise ValueError("source_times: expected strictly increasing times")
    _check_target_times(src, dst)
    if interpolation == "cubic" and motion.n_frames >= 4:
        return _cubic_at_times(motion, src, np.clip(dst, src[0], src[-1]), fps)
    k, k1, s = _bracket_times(src, dst)
    r0 = motion.rotations[k]
    r1 = motion.rotations[k1]
    step = _SO3.log(np.swapaxes(r0, -1, -2) @ r1)  # (N, J, 3)
    rot = r0 @ _SO3.exp(s[:, None, None] * step)
    # Exact copies at the nodes (s = 0 or 1) keep a resample at the same rate lossless.
    at0 = s == 0.0
    at1 = s == 1.0
    rot[at0] = r0[at0]
    rot[at1] = r1[at1]

    def lerp(a: np.ndarray) -> np.ndarray:
        w = s.reshape((-1,) + (1,) * (a.ndim - 1))
        return (1.0 - w) * a[k] + w * a[k1]

    jt = motion.joint_translations
    return motion.replace(
        fps=fps,
        rotations=rot,
        root_translation=lerp(motion.root_translation),
        joint_translations=None if jt is None else lerp(jt),
    )


def _bracket_times(src: np.ndarray, dst: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per target time: the frames before and after it and the fraction between them."""
    if src.size == 1:
        k = np.zeros(dst.size, dtype=int)
        return k, k, np.zeros(dst.size)
    k = np.clip(np.searchsorted(src, dst, side="right") - 1, 0, src.size - 2)
    s = np.clip((dst - src[k]) / (src[k + 1] - src[k]), 0.0, 1.0)
    return k, k + 1, s


def frames_read_at_times(source_times: np.ndarray, target_times: np.ndarray) -> np.ndarray:
    """The frames a geodesic :func:`resample_at_times` reads: the two around each target
    time, sorted and unique (the ``frames`` of :func:`smooth_motion` before such a resample).

    Parameters
    ----------
    source_times : array_like, shape (F,)
        Strictly increasing frame times, seconds.
    target_times : array_like, shape (N,)

    Returns
    -------
    ndarray of int, shape (<= 2 N,)
    """
    src = np.asarray(source_times, dtype=np.float64)
    k, k1, _ = _bracket_times(src, np.asarray(target_times, dtype=np.float64))
    return np.union1d(k, k1)


def resample(motion: Motion, fps: float, *, interpolation: str = "geodesic") -> Motion:
    """Resample to a new frame rate over the same time span.

    Parameters
    ----------
    motion : Motion
    fps : float
        New frame rate (> 0).
    interpolation : {"geodesic", "cubic"}, default "geodesic"
        ``"geodesic"``: rotations along the geodesic between neighbouring frames, translations
        linearly; ``"cubic"``: cubic splines, which keep what lies between frames (no corner
        of a piecewise-geodesic curve): for sampling a motion *above* its own rate
        (:func:`resample_at_times`).

    Returns
    -------
    Motion
        ``floor(duration * fps) + 1`` frames at times ``i / fps`` (the last source frame is
        kept when the duration is a multiple of the new frame time).
    """
    fps = float(fps)
    n = resampled_frames(motion, fps, "fps")
    return resample_at_times(motion, motion.times, np.arange(n) / fps, fps=fps, interpolation=interpolation)


def resampled_frames(motion: Motion, fps: float, option: str) -> int:
    """The frame count of :func:`resample` at ``fps``, checked before anything is allocated:
    ``OptionError(option, ...)`` beyond the limit ``max_frames``, or ``max_samples`` for its
    frames x joints (:mod:`elastic_motion.limits`); ``OptionError(option, ...)`` too for a rate
    that is not a positive finite number."""
    if not (math.isfinite(fps) and fps > 0):
        raise OptionError(option, f"expected a positive frame rate; got {fps!r}")
    n = math.floor(motion.duration * fps + 1e-6) + 1
    limits.check_option(option, "a resampled frame count of", n, "max_frames")
    limits.check_option(option, "frames x joints of a resampled clip of", n * motion.n_joints, "max_samples")
    return n


def _cubic_at_times(motion: Motion, src: np.ndarray, dst: np.ndarray, fps: float) -> Motion:
    """:func:`resample_at_times` with ``interpolation="cubic"`` (checked times, >= 4 frames)."""
    from scipy.interpolate import CubicSpline  # local: 0.3 s to import, not on `import elastic_motion.motion`

    f, j = motion.n_frames, motion.n_joints
    mats = CubicSpline(src, motion.rotations.reshape(f, -1), axis=0)(dst)
    rot = _SO3.project(mats.reshape(dst.size, j, 3, 3))  # the nearest rotations
    root = CubicSpline(src, motion.root_translation, axis=0)(dst)
    jt = motion.joint_translations
    if jt is not None:
        jt = CubicSpline(src, jt.reshape(f, -1), axis=0)(dst).reshape((dst.size, *jt.shape[1:]))
    return motion.replace(rotations=rot, root_translation=root, joint_translations=jt, fps=float(fps))


def _point_reflected(x: np.ndarray, k: int) -> np.ndarray:
    """``x`` ``(F, ...)`` extended by ``k`` frames at each end by point reflection about its end
    values (``x[-m] = 2 x[0] - x[m]``), so a linear-in-time sequence stays linear: ``(F + 2k, ...)``."""
    head = 2.0 * x[:1] - x[k:0:-1]
    tail = 2.0 * x[-1:] - x[-2 : -k - 2 : -1]
    return np.concatenate([head, x, tail])


def smooth_motion(
    motion: Motion, sigma: float, *, truncate: float = 4.0, frames: np.ndarray | None = None
) -> Motion:
    """Gaussian low-pass of a motion in time, e.g. before sampling it at a lower frame rate.

    With the sampled Gaussian kernel ``g_k ~ exp(-k^2 / (2 s^2))``, ``s = sigma * fps``
    frames, ``|k| <= ceil(truncate * s)``, normalised to sum 1:

    * root translation and joint translations (if any): ``p'_f = sum_k g_k p_{f+k}``;
    * each joint's rotation, in the Lie algebra around the frame itself:
      ``R'_f = R_f exp(sum_k g_k log(R_f^T R_{f+k}))``, one Gauss-Newton step of the weighted
      Karcher mean of the neighbouring rotations started at ``R_f`` (not the converged mean;
      the two differ by terms of third order in the angles within the window).

    Beyond the ends the motion is extended by point reflection about the end frame
    (``p_{-m} = 2 p_0 - p_m``, ``R_{-m} = R_0 R_m^T R_0``, likewise after the last frame), so
    a motion that is linear in time (translations) and a constant-speed geodesic
    (``R_f = R_0 exp(f w)``) are returned unchanged, up to rounding, ends included. The
    rotation step is bi-invariant: multiplying every ``R_f`` by a constant rotation on the
    left or on the right commutes with it (a change of world frame or of rest pose does not
    change what is smoothed). It assumes that a joint turns by well under pi within
    ``truncate * sigma`` seconds (``log`` is ambiguous at pi: drop the CMU finger joints
    first, :func:`finger_joints`).

    The gain at frequency ``nu`` (Hz) is about ``exp(-2 pi^2 sigma^2 nu^2)``: for half a
    frame of a lower rate, ``sigma = 0.5 / fps_out`` (the default of
    :func:`elastic_motion.apps.align.motion_curves`, 1/60 s at 30 fps), 0.29 at the
    Nyquist frequency ``fps_out / 2`` of that rate, 0.73 at half of it, -3 dB at
    ``0.27 fps_out`` (8 Hz at 30 fps).

    Parameters
    ----------
    motion : Motion
        ``F`` frames at ``motion.fps``.
    sigma : float
        Standard deviation of the kernel, seconds (>= 0); 0, or less than a thousandth
        of a frame, returns ``motion`` itself.
    truncate : float, default 4
        Kernel half-width in standard deviations (as ``scipy.ndimage.gaussian_filter``);
        at most ``F - 1`` frames (the kernel is cut there and renormalised: still symmetric).
    frames : array_like of int, optional
        Smooth only these frames (indices in ``[0, F)``); the others are returned as they
        are. For a caller that then reads the motion only at them: a geodesic resample
        (:func:`resample_at_times`) reads the two frames around each time, so a database
        sampling a 1,000-frame clip on 64 cells smooths 128 frames, not 1,000. The smoothed
        frames equal the whole motion's smoothing bit for bit.

    Returns
    -------
    Motion
        Same frames, frame rate, skeleton; rotations ``(F, J, 3, 3)``, root translation
        ``(F, 3)`` and joint translations ``(F, J, 3)`` smoothed (at ``frames`` only, if given).

    Raises
    ------
    ValueError
        If ``sigma`` or ``truncate`` is negative or not finite, or ``frames`` not indices of
        the motion's frames.
    """
    sigma = float(sigma)
    truncate = float(truncate)
    if not (math.isfinite(sigma) and sigma >= 0):
        raise ValueError(f"sigma: expected a standard deviation >= 0 in seconds; got {sigma!r}")
    if not (math.isfinite(truncate) and truncate > 0):
        raise ValueError(f"truncate: expected a positive number of standard deviations; got {truncate!r}")
    f = motion.n_frames
    at = np.arange(f) if frames is None else _frame_indices(frames, f)
    s = sigma * motion.fps
    if s < 1e-3 or f < 3:
        return motion
    half = min(max(1, math.ceil(truncate * s)), f - 1)
    offsets = np.arange(-half, half + 1)
    g = np.exp(-0.5 * (offsets / s) ** 2)
    g /= g.sum()

    def linear(x: np.ndarray) -> np.ndarray:
        ext = _point_reflected(x, half)
        out = x.copy()
        out[at] = sum(w * ext[half + k + at] for k, w in zip(offsets, g, strict=True))
        return out

    r = motion.rotations  # (F, J, 3, 3)
    rt = np.swapaxes(r, -1, -2)
    m = np.arange(1, half + 1)
    head = r[:1] @ rt[m] @ r[:1]  # R_{-m} = R_0 R_m^T R_0, m = 1..half (frames -1..-half)
    tail = r[-1:] @ rt[f - 1 - m] @ r[-1:]  # R_{F-1+m}
    ext = np.concatenate([head[::-1], r, tail])  # (F + 2 half, J, 3, 3)
    step = np.zeros((at.size, *r.shape[1:-1]))  # (frames, J, 3): sum_k g_k log(R_f^T R_{f+k})
    for k, w in zip(offsets, g, strict=True):
        if k:
            step += w * _SO3.log(rt[at] @ ext[half + k + at])
    rotations = r.copy()
    rotations[at] = r[at] @ _SO3.exp(step)
    jt = motion.joint_translations
    return motion.replace(
        rotations=rotations,
        root_translation=linear(motion.root_translation),
        joint_translations=None if jt is None else linear(jt),
    )


def _frame_indices(frames: np.ndarray, n_frames: int) -> np.ndarray:
    """``frames`` as sorted unique int indices, checked against ``n_frames``."""
    idx = np.asarray(frames)
    if idx.ndim != 1 or (idx.size and not np.issubdtype(idx.dtype, np.integer)):
        raise ValueError(
            f"frames: expected a 1-D array of frame indices; got {idx.dtype} of shape {idx.shape}"
        )
    if idx.size and (idx.min() < 0 or idx.max() >= n_frames):
        raise ValueError(f"frames: expected indices in [0, {n_frames}); got {idx.min()}..{idx.max()}")
    return np.unique(idx.astype(np.int64))


# ------------------------------------------------------------------------------------------
# Joints
# ------------------------------------------------------------------------------------------
def finger_joints(skeleton: Skeleton) -> list[str]:
    """Names of finger, thumb and hand-index joints (``/finger|thumb|index/i``) and their
    descendants: CMU's ``LFingers``, ``LThumb``, ``LeftFingerBase``, ``LeftHandIndex1``,
    ``lfingers``, ``lthumb``... These flip by 180 degrees between frames in the CMU data.
    """
    out: set[int] = set()
    for k, name in enumerate(skeleton.names):
        if _FINGER.search(name) and k != 0:
            out.update(skeleton.subtree(k))
    return [skeleton.names[k] for k in sorted(out)]


def select_joints(motion: Motion, names: Iterable[str]) -> Motion:
    """Keep only the named joints (the root must be among them, and every kept joint's
    parent too).

    A dropped joint whose parent is kept becomes an End Site of that parent (at the
    dropped joint's offset), so the kept bones keep their geometry.

    Raises
    ------
    KeyError
        For an unknown joint name.
    ValueError
        If the root is not kept, or a kept joint's parent is not.
    """
    sk = motion.skeleton
    keep = np.zeros(sk.n_joints, dtype=bool)
    for n in names:
        keep[sk.index(n)] = True
    if not keep[0]:
        raise ValueError(f"names: expected the root {sk.names[0]!r} among the joints to keep")
    orphan = [sk.names[k] for k in range(1, sk.n_joints) if keep[k] and not keep[sk.parents[k]]]
    if orphan:
        raise ValueError(
            f"names: joint {orphan[0]!r} is kept but its parent "
            f"{sk.names[sk.parents[sk.index(orphan[0])]]!r} is not; keep whole chains from the root"
        )
    idx = np.flatnonzero(keep)
    new_index = -np.ones(sk.n_joints, dtype=int)
    new_index[idx] = np.arange(idx.size)
    parents = [-1] + [int(new_index[sk.parents[k]]) for k in idx[1:]]
    es_parents = [int(new_index[p]) for p in sk.end_site_parents if keep[p]]
    es_offsets = [o for p, o in zip(sk.end_site_parents, sk.end_site_offsets, strict=True) if keep[p]]
    for k in range(1, sk.n_joints):  # dropped children of kept joints become end sites
        if not keep[k] and keep[sk.parents[k]]:
            es_parents.append(int(new_index[sk.parents[k]]))
            es_offsets.append(sk.offsets[k])
    new_sk = Skeleton(
        names=[sk.names[k] for k in idx],
        parents=parents,
        offsets=sk.offsets[idx],
        channels=[sk.channels[k] for k in idx],
        end_site_parents=es_parents,
        end_site_offsets=np.array(es_offsets).reshape(-1, 3),
    )
    jt = motion.joint_translations
    if jt is not None and not new_sk.has_position_channels[1:].any():
        jt = None
    return motion.replace(
        skeleton=new_sk,
        rotations=motion.rotations[:, idx],
        joint_translations=None if jt is None else jt[:, idx],
    )


def drop_joints(motion: Motion, names: Iterable[str]) -> Motion:
    """Remove the named joints together with their descendants (see :func:`select_joints`).

    ``drop_joints(m, finger_joints(m.skeleton))`` removes CMU's flipping hand joints.
    """
    sk = motion.skeleton
    gone: set[int] = set()
    for n in names:
        k = sk.index(n)
        if k == 0:
            raise ValueError(f"names: cannot drop the root joint {n!r}")
        gone.update(sk.subtree(k))
    return select_joints(motion, [n for k, n in enumerate(sk.names) if k not in gone])


def has_reference_root(motion: Motion) -> bool:
    """True if the root only carries a single child that has position channels of its own.

    That is the shape of the Bandai files' ``joint_Root`` (a fixed reference frame while the
    hips move through position channels); :func:`merge_root` folds such a root into its child
    so that the curve representations, which carry only the root's translation, keep the walk.
    """
    sk = motion.skeleton
    if sk.n_joints < 2 or (sk.end_site_parents == 0).any():
        return False
    kids = sk.children(0)
    return len(kids) == 1 and bool(sk.has_position_channels[kids[0]])


def merge_root(motion: Motion) -> Motion:
    """Fold the root into its only child, which becomes the new root.

    The new root's translation is the child's world position ``t_root + R_root t_child``
    and its rotation ``R_root R_child``; all other joints keep their local data, so
    forward kinematics is unchanged. Use it on skeletons whose root is a fixed reference
    frame (the Bandai files' ``joint_Root``, always zero) while the hips move through
    position channels: the Lie and Euler curves carry only the root's translation.

    Raises
    ------
    ValueError
        If the root does not have exactly one child joint, or has end sites.
    """
    sk = motion.skeleton
    kids = sk.children(0)
    if len(kids) != 1 or sk.n_joints < 2:
        raise ValueError(
            f"motion: expected a root with exactly one child joint; {sk.names[0]!r} has {len(kids)}"
        )
    if (sk.end_site_parents == 0).any():
        raise ValueError(f"motion: the root {sk.names[0]!r} has end sites; cannot merge it into its child")
    c = kids[0]  # == 1 in topological order
    local_t = motion.local_translations()
    r_root = motion.rotations[:, 0]
    new_root_t = motion.root_translation + np.einsum("fij,fj->fi", r_root, local_t[:, c])
    rotations = motion.rotations[:, 1:].copy()
    rotations[:, 0] = r_root @ motion.rotations[:, c]
    chans = sk.channels[c]
    if not any(ch.endswith("position") for ch in chans):
        chans = ("Xposition", "Yposition", "Zposition", *chans)
    new_sk = Skeleton(
        names=sk.names[1:],
        parents=[-1] + [int(p) - 1 for p in sk.parents[2:]],
        offsets=sk.offsets[1:],
        channels=(chans, *sk.channels[2:]),
        end_site_parents=sk.end_site_parents - 1,
        end_site_offsets=sk.end_site_offsets,
    )
    jt = motion.joint_translations
    if jt is not None:
        jt = jt[:, 1:] if new_sk.has_position_channels[1:].any() else None
    return motion.replace(
        skeleton=new_sk,
        root_translation=new_root_t,
        rotations=rotations,
        joint_translations=jt,
    )


# ------------------------------------------------------------------------------------------
# Units and placement
# ------------------------------------------------------------------------------------------
def to_metres(motion: Motion) -> Motion:
    """Scale all lengths (offsets, end sites, translations) to metres.

    Raises
    ------
    ValueError
        If ``motion.metres_per_unit`` is unknown (``None``).
    """
    s = motion.metres_per_unit
    if s is None:
        raise ValueError(
            "motion: metres_per_unit is unknown; read the file with units=... or set it with "
            "motion.replace(metres_per_unit=...)"
        )
    sk = motion.skeleton
    new_sk = Skeleton(
        sk.names, sk.parents, sk.offsets * s, sk.channels, sk.end_site_parents, sk.end_site_offsets * s
    )
    jt = motion.joint_translations
    return motion.replace(
        skeleton=new_sk,
        root_translation=motion.root_translation * s,
        joint_translations=None if jt is None else jt * s,
        metres_per_unit=1.0,
    )


def _apply_world_transform(motion: Motion, rot: np.ndarray, shift: np.ndarray) -> Motion:
    """Left-multiply the whole motion by the rigid map ``x -> rot @ x + shift``.

    ``rot`` (3, 3) or (F, 3, 3); ``shift`` (3,) or (F, 3).
    """
    rotations = motion.rotations.copy()
    rotations[:, 0] = rot @ motion.rotations[:, 0]
    root = np.einsum("...ij,...j->...i", rot, motion.root_translation) + shift
    return motion.replace(rotations=rotations, root_translation=root)


def set_up_axis(motion: Motion, up_axis: str) -> Motion:
    """Rotate the whole motion so that its up axis becomes ``up_axis``.

    The rotation is the proper quarter turn (determinant +1: handedness kept) taking the
    current up axis to the new one (``y -> z``: +90 degrees about x, ``(x, y, z) -> (x, -z,
    y)``, what Blender's BVH import does; ``z -> y``: -90 degrees about x, ``(x, y, z) ->
    (x, z, -y)``, its exact inverse, so Blender's forward -y becomes +z; ``x <-> y``: about
    z; ``x <-> z``: about y). Joint-local data is unchanged; only the root moves. Positions
    are rotated, not relabelled: use ``motion.replace(up_axis=...)`` to fix a wrong label.
    """
    if up_axis not in _AXES:
        raise ValueError(f"up_axis: expected 'x', 'y' or 'z'; got {up_axis!r}")
    a, b = _AXES.index(motion.up_axis), _AXES.index(up_axis)
    if a == b:
        return motion
    # Rotation about the third axis c taking e_a to e_b: +90 degrees if (a, b, c) is cyclic.
    c = 3 - a - b
    angle = math.pi / 2 if (b - a) % 3 == 1 else -math.pi / 2
    rot = np.round(axis_rotation(angle, "XYZ"[c]))
    moved = _apply_world_transform(motion, rot, np.zeros(3))
    return moved.replace(up_axis=up_axis)


def heading_angle(rotation: np.ndarray, up: int) -> np.ndarray:
    """Yaw (heading, radians) about axis ``up`` (0, 1, 2 for x, y, z) of rotations ``(..., 3, 3)``.

    The forward axis is ``e_p`` with ``p`` the cyclic successor of ``up`` (+z for y-up,
    +x for z-up, +y for x-up); the yaw is the angle of ``R e_p`` in the floor plane,
    measured from ``e_p`` towards ``e_q`` (``q`` the next axis), i.e. in the sense of a
    right-handed rotation about ``up``.
    """
    p, q = (up + 1) % 3, (up + 2) % 3
    fwd = rotation[..., :, p]
    return np.arctan2(fwd[..., q], fwd[..., p])


def align_heading(motion: Motion, *, frame: int = 0) -> Motion:
    """Remove the yaw and the floor-plane translation of the root at ``frame``.

    After alignment the root at ``frame`` stands above the origin (its height is kept)
    and faces forward: for Y-up, the root's rotated ``+z`` axis projected on the floor
    points along ``+z`` (z-up: ``+x``; see :func:`heading_angle`). The whole clip moves rigidly (a rotation
    about the up axis and a floor translation), as registration curves align motions
    before comparing them.

    Parameters
    ----------
    motion : Motion
    frame : int, default 0
        Reference frame (negative counts from the end).
    """
    if not -motion.n_frames <= frame < motion.n_frames:
        raise ValueError(f"frame: expected an index in [-{motion.n_frames}, {motion.n_frames}); got {frame}")
    up = _AXES.index(motion.up_axis)
    yaw = float(heading_angle(motion.rotations[frame, 0], up))
    rot = axis_rotation(-yaw, "XYZ"[up])
    origin = rot @ motion.root_translation[frame]
    shift = -origin
    shift[up] = 0.0
    return _apply_world_transform(motion, rot, shift)


def place_on_floor(motion: Motion, *, floor: float = 0.0) -> Motion:
    """Translate along the up axis so that the lowest point of the clip (joints and end
    sites over all frames, by forward kinematics) is at height ``floor``."""
    up = _AXES.index(motion.up_axis)
    lowest = float(forward_kinematics(motion, end_sites=True)[..., up].min())
    shift = np.zeros(3)
    shift[up] = floor - lowest
    return _apply_world_transform(motion, np.eye(3), shift)


def smoothstep(x: np.ndarray) -> np.ndarray:
    """``3 x^2 - 2 x^3`` of ``x`` clipped to ``[0, 1]``: 0 to 1 with zero slope at both ends."""
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def eased_envelope(x: np.ndarray, width: int) -> np.ndarray:
    """The smallest smooth upper envelope of ``x >= 0`` ``(F,)`` by bumps: each value eased in
    and out over ``width`` frames on either side (:func:`smoothstep`), the maximum over the
    frames (a change needed on one frame, spread so that it does not jump)."""
    f = x.shape[0]
    out = np.array(x, dtype=np.float64)
    for k in range(1, min(width, f - 1) + 1):  # (no frame is farther than f - 1 away)
        w = float(smoothstep(np.array(1.0 - k / (width + 1.0))))
        out[k:] = np.maximum(out[k:], w * x[: f - k])
        out[: f - k] = np.maximum(out[: f - k], w * x[k:])
    return out


def fixed_frames_weight(n_frames: int, fixed: Sequence[int], width: int) -> np.ndarray:
    """Per frame, how much of a change may apply next to frames that must not change.

    Returns an ``(n_frames,)`` array: 0 on the ``fixed`` frames (negative indices count from
    the end), rising by :func:`smoothstep` to 1 at ``width + 1`` frames from the nearest one.
    """
    idx = np.arange(n_frames)
    if not len(fixed):
        return np.ones(n_frames)
    frames = np.asarray(fixed, dtype=np.int64)
    if (frames >= n_frames).any() or (frames < -n_frames).any():
        raise ValueError(f"fixed: expected frames in [-{n_frames}, {n_frames}); got {list(fixed)}")
    dist = np.min(np.abs(idx[:, None] - (frames % n_frames)[None, :]), axis=1)
    return smoothstep(dist / (width + 1.0))


def smooth_change(before: Motion, after: Motion, sigma_frames: float) -> Motion:
    """``after`` with its change from ``before`` smoothed in time: each joint's rotation change
    ``log(R_before^T R_after)`` and the root offset ``after - before`` through a Gaussian of
    ``sigma_frames`` standard deviation (:func:`gaussian_frames`), then applied to ``before``
    again. Same skeleton and frames (else ``ValueError``)."""
    if (before.n_frames, before.n_joints) != (after.n_frames, after.n_joints):
        raise ValueError(
            f"after: expected {before.n_frames} frames of {before.n_joints} joints like before; got "
            f"{after.n_frames} of {after.n_joints}"
        )
    if before.n_frames < 2 or sigma_frames <= 0:
        gaussian_frames(before.root_translation, sigma_frames)  # checks sigma_frames
        return after
    rel = gaussian_frames(_SO3.log(np.swapaxes(before.rotations, -1, -2) @ after.rotations), sigma_frames)
    off = gaussian_frames(after.root_translation - before.root_translation, sigma_frames)
    return after.replace(
        rotations=before.rotations @ _SO3.exp(rel), root_translation=before.root_translation + off
    )


def fade_change(before: Motion, after: Motion, weight: np.ndarray) -> Motion:
    """``after``'s change from ``before`` scaled per frame by ``weight`` (0: ``before``'s frame).

    The change is each joint's ``log(R_before^T R_after)`` and the root offset, scaled
    linearly; frames of weight 1 are ``after``'s exactly, of weight 0 ``before``'s exactly.
    """
    if after.n_frames != before.n_frames or after.n_joints != before.n_joints:
        raise ValueError(
            f"after: expected {before.n_frames} frames of {before.n_joints} joints like before; "
            f"got {after.n_frames} of {after.n_joints}"
        )
    w = np.asarray(weight, dtype=np.float64)
    if w.shape != (before.n_frames,):
        raise ValueError(f"weight: expected shape ({before.n_frames},); got {w.shape}")
    part = (w > 0) & (w < 1)
    rot = np.where((w >= 1)[:, None, None, None], after.rotations, before.rotations)
    if part.any():
        rel = _SO3.log(np.swapaxes(before.rotations[part], -1, -2) @ after.rotations[part])
        rot[part] = before.rotations[part] @ _SO3.exp(w[part, None, None] * rel)
    root = before.root_translation + w[:, None] * (after.root_translation - before.root_translation)
    return after.replace(rotations=rot, root_translation=root)


def lift_out_of_floor(
    motion: Motion, floor: float | np.ndarray, *, ease: float = 0.15, fixed: Sequence[int] = ()
) -> tuple[Motion, np.ndarray]:
    """Raise the root, smoothly in time, where a point of the body is below ``floor``.

    Parameters
    ----------
    motion : Motion
    floor : float or ndarray, shape (F,)
        Floor height along the up axis, in the motion's length unit (per frame: e.g. the
        floor or an original's own lowest point there, whichever is lower).
    ease : float, default 0.15
        Seconds over which a lift eases in before and out after the frames that need it
        (smoothstep), so the body does not jump.
    fixed : sequence of int
        Frames that must not move (e.g. a loop's seam frames); the lift eases to 0 there,
        within a third of ``ease``.

    Returns
    -------
    motion : Motion
        The lifted motion (``motion`` itself when nothing is below the floor).
    lift : ndarray, shape (F,)
        The root's rise per frame (motion unit), at least the depth of the lowest joint or
        end site below ``floor`` on every frame not within ``ease`` of a fixed frame.
    """
    up = _AXES.index(motion.up_axis)
    f = motion.n_frames
    depth = np.maximum(floor - forward_kinematics(motion, end_sites=True)[..., up].min(axis=1), 0.0)
    if not depth.any():
        return motion, np.zeros(f)
    lift = eased_envelope(depth, max(1, round(ease * motion.fps)))
    if len(fixed):
        # a third of the ease: a lift next to a fixed frame is needed close to it
        lift *= fixed_frames_weight(f, fixed, max(1, round(ease * motion.fps / 3)))
    root = motion.root_translation.copy()
    root[:, up] += lift
    return motion.replace(root_translation=root), lift


# ------------------------------------------------------------------------------------------
# Placing one motion like another
# ------------------------------------------------------------------------------------------
_MIN_PATH = 0.10  # metres: root paths shorter than this are "on the spot"


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
    rot = axis_rotation(np.array(angle), "XYZ"[_AXES.index(m.up_axis)])
    return _apply_world_transform(m, rot, shift)


def place_like(reference: Motion, motion: Motion) -> tuple[Motion, str]:
    """Move ``motion`` rigidly (a turn about the up axis and a floor translation, heights
    untouched) so that its root starts where ``reference``'s does, turned to best match the
    reference's root path.

    The turn is the least-squares fit (2D Procrustes about the start) of the floor-plane
    root displacements from frame 0, sampled at equal fractions of each clip's duration.
    When either root path spans less than 10 cm (motion on the spot) the fit is ill-posed
    and the root's facing directions at frame 0 are matched instead.

    Returns
    -------
    motion : Motion
    note : str
        How it was placed.
    """
    up = _AXES.index(reference.up_axis)
    p, q = _floor_axes(up)
    scale = reference.metres_per_unit or 1.0
    pa, pb = _root_path(reference, up), _root_path(motion, up)
    a, b = pa - pa[0], pb - pb[0]
    span = min(np.ptp(pa, axis=0).max(), np.ptp(pb, axis=0).max()) * scale
    if span >= _MIN_PATH:
        angle = math.atan2(float(np.sum(b[:, 0] * a[:, 1] - b[:, 1] * a[:, 0])), float(np.sum(b * a)))
        how = "start matched, root paths fitted"
    else:
        angle = float(
            heading_angle(reference.rotations[0, 0], up) - heading_angle(motion.rotations[0, 0], up)
        )
        how = "start and frame-0 facing matched (motion on the spot)"
    c, s = math.cos(angle), math.sin(angle)
    moved0 = np.array([c * pb[0, 0] - s * pb[0, 1], s * pb[0, 0] + c * pb[0, 1]])
    shift = np.zeros(3)
    shift[p], shift[q] = pa[0] - moved0
    angle = (angle + math.pi) % (2 * math.pi) - math.pi
    return _rigid(motion, angle, shift), f"{how}: turned {math.degrees(angle):+.1f} deg about the up axis"
