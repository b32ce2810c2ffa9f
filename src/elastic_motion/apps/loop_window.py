"""The best cycle of a clip: which sub-clip closes with the least change (cheap part).

:func:`elastic_motion.apps.loop.loop_motion` with ``window="auto"`` loops a sub-clip
instead of the whole clip. This module does the cheap first pass: a pose and velocity
dissimilarity of every (start, end) frame pair, the clip's period (the default minimum
length) and the few best candidate windows; the loop then closes each candidate exactly
and keeps the one whose loop changes the motion least.

Conventions
-----------
* **A window** is the frame range ``[start, stop)``; the sub-clip's last frame ``stop - 1``
  is the one that must meet the first frame (the loop convention of
  :mod:`elastic_motion.apps.loop`). Its length is ``(stop - 1 - start) / fps`` seconds
  (the duration of one cycle when played in a loop).
* **Pose features** of a frame (what the loop convention closes): the local rotation of
  every closed joint but the root (rotation matrices), the root's tilt (the up axis seen
  from the root, ``R_root^T e_up``: blind to heading) and the root height (metres); with
  ``root="inplace"`` also the full root rotation and the floor-plane position. The
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
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from elastic_motion.errors import OptionError
from elastic_motion.motion import Motion

__all__ = ["CycleCandidates", "CycleWindow", "cycle_candidates", "estimate_period", "pose_dissimilarity"]

_AXES = "xyz"
_TAU = 0.1  # seconds: weight of the velocity term
_MIN_PERIOD = 0.3  # seconds


def _features(motion: Motion, root: str, closed: np.ndarray | None) -> np.ndarray:
    """Per-frame feature vectors (F, d) of the module docstring."""
    f, j = motion.n_frames, motion.n_joints
    up = _AXES.index(motion.up_axis)
    scale = motion.metres_per_unit if motion.metres_per_unit is not None else 1.0
    sel = np.ones(j, dtype=bool) if closed is None else np.asarray(closed, dtype=bool).copy()
    sel[0] = False
    parts = [motion.rotations[:, sel].reshape(f, -1)]
    r0 = motion.rotations[:, 0]
    if root == "inplace":
        parts.append(r0.reshape(f, 9))
        parts.append(motion.root_translation * scale)
    else:
        parts.append(r0[:, up, :])  # R^T e_up: the root's tilt
        parts.append(motion.root_translation[:, up : up + 1] * scale)
    return np.concatenate(parts, axis=1)


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
    x = _features(motion, root, closed)
    v = np.gradient(x, axis=0) * motion.fps
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
        Whether it was derived from the period (``min_length=None``).
    period : float or None
        The estimated period, seconds.
    """

    windows: list[tuple[int, int]]
    scores: np.ndarray
    min_length: float
    min_length_default: bool
    period: float | None


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
    dis = pose_dissimilarity(motion, root=root, closed=closed)
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
    return CycleCandidates(chosen, np.asarray(chosen_scores), float(min_length), default, period)


@dataclass(frozen=True, eq=False)
class CycleWindow:
    """The window a loop was made of (:func:`elastic_motion.apps.loop.loop_motion`).

    Attributes
    ----------
    start, stop : int
        Frames ``[start, stop)`` of the prepared clip.
    fps : float
    deviation_max_m, deviation_mean_m : float
        How much the loop changed the window: FK positions of the closed joints and their
        end sites against the window's own frames (m).
    change : float or None
        ``||q - q_orig||_L2`` of the window's closing (SRV units).
    whole : dict
        The same numbers for the whole clip closed (``deviation_max_m``,
        ``deviation_mean_m``, ``change_srv_l2``), or ``{"error": ...}``.
    candidates : tuple of dict
        Every window closed exactly, with its numbers (or its error).
    min_length : float or None
        Shortest window allowed, seconds (``None`` for a given window).
    min_length_default : bool
        Whether ``min_length`` came from the period.
    period : float or None
        The clip's estimated period, seconds.
    """

    start: int
    stop: int
    fps: float
    deviation_max_m: float
    deviation_mean_m: float
    change: float | None
    whole: dict
    candidates: tuple[dict, ...]
    min_length: float | None
    min_length_default: bool
    period: float | None

    @property
    def length(self) -> float:
        """Length of the cycle in seconds, ``(stop - 1 - start) / fps``."""
        return (self.stop - 1 - self.start) / self.fps

    def summary(self) -> dict[str, Any]:
        """JSON-ready fields (frames, seconds, metres)."""
        return {
            "start_frame": self.start,
            "stop_frame": self.stop,
            "start_s": self.start / self.fps,
            "stop_s": (self.stop - 1) / self.fps,
            "length_s": self.length,
            "deviation_max_m": self.deviation_max_m,
            "deviation_mean_m": self.deviation_mean_m,
            "change_srv_l2": self.change,
            "whole_clip": dict(self.whole),
            "candidates": [dict(c) for c in self.candidates],
            "min_length_s": self.min_length,
            "min_length_from_period": self.min_length_default,
            "period_s": self.period,
        }
