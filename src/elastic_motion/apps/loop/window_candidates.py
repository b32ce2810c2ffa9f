"""The best cycle of a clip, the cheap pass: which sub-clips may close with little change.

:func:`elastic_motion.apps.loop.loop_motion` with ``window="auto"`` loops a sub-clip
instead of the whole clip. This module does the cheap first pass: a pose and velocity
dissimilarity of every (start, end) frame pair, the clip's period (the default minimum
length) and the few best candidate windows; the loop then closes each candidate exactly
and keeps the one whose loop changes the motion least
(:func:`elastic_motion.apps.loop.window.loop_window`).

Conventions
-----------
* **A window** is the frame range ``[start, stop)``; the sub-clip's last frame ``stop - 1``
  is the one that must meet the first frame (the loop convention of
  :mod:`elastic_motion.motion.looping`). Its length is ``(stop - 1 - start) / fps`` seconds
  (the duration of one cycle when played in a loop).
* **Pose features** of a frame (what the loop convention closes): the local rotation of
  every closed joint but the root (rotation matrices), the root's tilt (the up axis seen
  from the root, ``R_root^T e_up``: blind to heading) and the root height (metres); with
  ``root="inplace"`` also the floor-plane velocity and the turning rate among the
  velocities (not the floor position or the heading: the treadmill closes them; with the
  position, a walk's travel made every lag beyond a step look dissimilar, and CMU 107_02 in
  place got a period of 0.4 s instead of 3.5 s and a 12-frame window). The
  **dissimilarity** of frames ``a`` and ``b`` is
  ``D(a, b) = |x_a - x_b|^2 + tau^2 |v_a - v_b|^2``, ``x`` the feature vector (chordal
  distance of rotation matrices, metres), ``v`` its velocity per second (central
  differences), ``tau = 0.1`` s: so a window ends in the pose *and* the motion it starts
  with.
* **The period** (:func:`estimate_period`): the lag ``L`` (at least 0.3 s) where the mean
  ``D(a, a + L)`` over the clip has its first deep local minimum (below 60 % of the mean
  over all lags and within 25 % of the smallest minimum). ``None`` when the clip has no
  such repetition (a single cartwheel, a walk that starts and stops).
* **Default minimum length** (``min_length=None``): 90 % of the period when there is one
  (a window holds one cycle), else half the clip.
* **Walking clips**: in a clip whose root moves at :data:`WALKING` or faster (median over its
  frames), a window whose root moves slower than a quarter of that on average is not a
  candidate either: the near-standing lead-in of a long walk closes with millimetres of change
  and used to win.
* **Quiet windows**: a window whose mean feature speed ``|v|`` is below 30 % of the mean
  over the clip's busier half of frames is not a candidate (unless every window is): a
  pause closes with no change at all, and without this the auto window of CMU 131_01 (a
  walk that stops) with a 1 s minimum was its last second of standing (root 0.05 m/s
  against 0.62 elsewhere), and of CMU 107_02 in place a 12-frame stretch of a pause.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from elastic_motion.errors import OptionError
from elastic_motion.groups import SO3
from elastic_motion.motion import Motion

__all__ = ["CycleCandidates", "cycle_candidates", "estimate_period", "pose_dissimilarity"]

_AXES = "xyz"
_TAU = 0.1  # seconds: weight of the velocity term
_MIN_PERIOD = 0.3  # seconds
#: A candidate window moves on average at least this fraction of the clip's busier half
#: (module docstring, "Quiet windows").
_QUIET = 0.3
#: m/s: a clip whose root's median floor-plane speed is at least this walks (a slow walk is
#: 0.5-1 m/s; a dance or a cartwheel in place turns about 0.1-0.3)...
WALKING = 0.3
#: ...and a window of it carries the walk when its root moves at least this fraction of the
#: clip's median speed on average.
_TRAVEL = 0.25


def _features(motion: Motion, root: str, closed: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """Per-frame feature vectors ``x`` ``(F, d)`` and velocities ``v`` (per second) of the
    module docstring (``"inplace"``: ``v`` also holds the root's floor-plane velocity)."""
    f, j = motion.n_frames, motion.n_joints
    up = _AXES.index(motion.up_axis)
    scale = motion.metres_per_unit if motion.metres_per_unit is not None else 1.0
    sel = np.ones(j, dtype=bool) if closed is None else np.asarray(closed, dtype=bool).copy()
    sel[0] = False
    parts = [motion.rotations[:, sel].reshape(f, -1)]
    r0 = motion.rotations[:, 0]
    parts.append(r0[:, up, :])  # the tilt R^T e_up: blind to heading
    parts.append(motion.root_translation[:, up : up + 1] * scale)
    x = np.concatenate(parts, axis=1)
    v = np.gradient(x, axis=0) * motion.fps
    if root == "inplace":
        # the treadmill takes out each window's travel and turn at a constant rate, which
        # closes the floor-plane position and the heading whatever they were: only their
        # rates must match at the seam
        floor = [i for i in range(3) if i != up]
        travel = np.gradient(motion.root_translation[:, floor] * scale, axis=0) * motion.fps
        v = np.concatenate([v, travel, _yaw_rate(r0, up, motion.fps)[:, None]], axis=1)
    return x, v


def _yaw_rate(r0: np.ndarray, up: int, fps: float) -> np.ndarray:
    """The root's turning rate about the up axis ``(F,)`` (rad/s; central differences)."""
    f = r0.shape[0]
    nxt = np.minimum(np.arange(f) + 1, f - 1)
    prv = np.maximum(np.arange(f) - 1, 0)
    span = np.maximum(nxt - prv, 1)
    return SO3().log(r0[nxt] @ np.swapaxes(r0[prv], -1, -2))[:, up] * fps / span


def pose_dissimilarity(
    motion: Motion, *, root: str = "travel", closed: np.ndarray | None = None
) -> np.ndarray:
    """``D(a, b)`` of every frame pair (module docstring).

    Parameters
    ----------
    motion : Motion
        At least 2 frames (metres when its unit is known).
    root : {"travel", "inplace"}
    closed : ndarray of bool, shape (J,), optional
        Joints that count (default: all); the root is handled by ``root``.

    Returns
    -------
    ndarray, shape (F, F)
        Symmetric, zero on the diagonal, >= 0.
    """
    return _dissimilarity(*_features(motion, root, closed))


def _dissimilarity(x: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``D(a, b)`` from the features ``x`` and their velocities ``v`` ``(F, d)``."""
    z = np.concatenate([x, _TAU * v], axis=1)
    sq = np.einsum("ij,ij->i", z, z)
    d = sq[:, None] + sq[None, :] - 2.0 * (z @ z.T)
    np.maximum(d, 0.0, out=d)
    np.fill_diagonal(d, 0.0)
    return d


def estimate_period(dis: np.ndarray, fps: float) -> float | None:
    """The clip's period in seconds from a dissimilarity matrix (module docstring), or ``None``."""
    f = dis.shape[0]
    lmin = max(2, int(np.ceil(_MIN_PERIOD * fps)))
    if f - 1 <= lmin + 2:
        return None
    lags = np.arange(1, f)
    mean = np.array([np.diagonal(dis, k).mean() for k in lags])
    # only lags with at least a third of the clip to average over
    usable = lags <= (2 * (f - 1)) // 3
    cand = [
        k
        for k in range(lmin, int(lags[usable].max(initial=0)))
        if mean[k - 1] <= mean[k - 2] and mean[k - 1] <= mean[k]
    ]
    if not cand:
        return None
    overall = float(mean[usable].mean())
    best = min(mean[k - 1] for k in cand)
    for k in cand:
        if mean[k - 1] <= 0.6 * overall and mean[k - 1] <= 1.25 * best + 1e-12:
            return k / fps
    return None


@dataclass(frozen=True, eq=False)
class CycleCandidates:
    """The cheap pass of the best-cycle search (:func:`cycle_candidates`).

    Attributes
    ----------
    windows : list of (int, int)
        Candidate windows ``[start, stop)``, best dissimilarity first.
    scores : ndarray, shape (k,)
        Their ``D(start, stop - 1)``.
    min_length : float
        The minimum window length used, seconds.
    min_length_default : bool
        Whether it was not given (``min_length=None``: 90 % of the period, or half the clip
        without one).
    period : float or None
        The estimated period, seconds.
    quiet_excluded : bool
        Whether windows that barely move were left out (module docstring, "Quiet windows").
    """

    windows: list[tuple[int, int]]
    scores: np.ndarray
    min_length: float
    min_length_default: bool
    period: float | None
    quiet_excluded: bool = False


def cycle_candidates(
    motion: Motion,
    *,
    root: str = "travel",
    closed: np.ndarray | None = None,
    min_length: float | None = None,
    count: int = 5,
    separation: float = 0.1,
) -> CycleCandidates:
    """The ``count`` windows whose end frame best matches their start frame.

    Parameters
    ----------
    motion : Motion
        The prepared clip.
    root : {"travel", "inplace"}
    closed : ndarray of bool, shape (J,), optional
        Joints that count in the pose features.
    min_length : float, optional
        Shortest window, seconds (default: module docstring).
    count : int
        How many candidates to keep.
    separation : float
        Two candidates differ by more than this (seconds) in their start or in their end.

    Returns
    -------
    CycleCandidates

    Raises
    ------
    OptionError
        ``min_length`` not positive, or longer than the clip (the message gives both lengths).
    """
    fps = motion.fps
    dur = (motion.n_frames - 1) / fps
    x, v = _features(motion, root, closed)
    dis = _dissimilarity(x, v)
    period = estimate_period(dis, fps)
    default = min_length is None
    if default:
        min_length = 0.9 * period if period is not None else 0.5 * dur
    elif not (np.isfinite(min_length) and min_length > 0):
        raise OptionError("min_length", f"expected a positive number of seconds; got {min_length!r}")
    lmin = max(2, int(np.ceil(min_length * fps - 1e-9)))  # frames between first and last frame
    if lmin > motion.n_frames - 1:
        raise OptionError(
            "min_length",
            f"expected a minimum window no longer than the clip ({dur:.3f} s, {motion.n_frames} frames); "
            f"got {min_length:.3f} s ({lmin + 1} frames)",
        )
    f = motion.n_frames
    a, b = np.triu_indices(f, k=lmin)
    # a pause or a frozen lead-in closes with no change at all: only windows that move, and in
    # a clip that walks, only windows that walk
    active = _active_windows(np.linalg.norm(v, axis=1), a, b) & _travelling_windows(motion, a, b)
    quiet = bool(active.any() and not active.all())
    if quiet:
        a, b = a[active], b[active]
    scores = dis[a, b]
    order = np.argsort(scores, kind="stable")
    sep = max(1, round(separation * fps))
    chosen: list[tuple[int, int]] = []
    chosen_scores: list[float] = []
    for o in order:
        s, e = int(a[o]), int(b[o])
        if all(abs(s - cs) > sep or abs(e + 1 - ce) > sep for cs, ce in chosen):
            chosen.append((s, e + 1))
            chosen_scores.append(float(scores[o]))
            if len(chosen) >= count:
                break
    return CycleCandidates(chosen, np.asarray(chosen_scores), float(min_length), default, period, quiet)


def _travelling_windows(motion: Motion, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """In a clip that walks (its root's median floor-plane speed at least :data:`WALKING`),
    which windows ``[a, b]`` carry its travel: their root's mean floor speed at least
    :data:`_TRAVEL` times the clip's median (an idle lead-in is never chosen over the walk).
    All of them in a clip that does not walk."""
    up = _AXES.index(motion.up_axis)
    scale = motion.metres_per_unit if motion.metres_per_unit is not None else 1.0
    floor = np.delete(motion.root_translation, up, axis=1) * scale
    speed = np.linalg.norm(np.gradient(floor, axis=0), axis=1) * motion.fps
    median = float(np.median(speed))
    if median < WALKING:
        return np.ones(a.shape, dtype=bool)
    total = np.concatenate([[0.0], np.cumsum(speed)])
    mean = (total[b + 1] - total[a]) / (b - a + 1)
    return mean >= _TRAVEL * median


def _active_windows(speed: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Which windows ``[a, b]`` (last frame ``b``) move: their mean feature speed at least
    :data:`_QUIET` times the mean over the clip's busier half of frames."""
    busy = speed[speed >= np.median(speed)]
    reference = float(busy.mean()) if busy.size else 0.0
    if reference <= 0.0:
        return np.ones(a.shape, dtype=bool)
    total = np.concatenate([[0.0], np.cumsum(speed)])
    mean = (total[b + 1] - total[a]) / (b - a + 1)
    return mean >= _QUIET * reference
