"""Blend motions: the four methods of paper 001 Fig. 5, the Lie group method of paper 000,
and weighted means of several motions.

Methods (``method``, ``warp``, ``landmarks``)
----------------------------------------------
=================  ============  ===========  ==============================================
method             warp          landmarks    what it is
=================  ============  ===========  ==============================================
``euler-linear``   ``none``      --           paper 001 Fig. 5 (a): frame-by-frame linear
                                              interpolation of Euler angles and root position
``euler-elastic``  ``none``      --           (b): SRV geodesic in ``R^d`` without warp
``euler-elastic``  ``dp``        --           (c): SRV geodesic in ``R^d`` with the optimal warp
``euler-elastic``  ``dp``        ``auto``     (d): with warp and feature points (the left
                                              knee passing the right knee, foot strikes and
                                              toe-offs), paired by phase (:mod:`.landmarks`)
``lie``            ``none``      --           paper 000 Fig. 4, bottom left: SRV geodesic in
                                              ``R^3 x SO(3)^J`` without warp
``lie``            ``dp``        optional     paper 000 Fig. 4, bottom right: with the warp
=================  ============  ===========  ==============================================

``warp="dp+refine"`` refines the DP warp off the grid by gradient descent. Any warp works
with any method (``euler-linear`` with a warp interpolates the time-aligned frames).

What happens, in order (two motions A, B and weight ``s``: the result is ``(1-s) A + s B``)
------------------------------------------------------------------------------------------
1. :func:`elastic_motion.apps.prepare.prepare_motions` (the one preparation step, options
   ``prepare``): T-pose frame, trim, static root, metres, Y-up, common joints, B resampled
   to A's frame rate, B placed like A (a rotation about the up axis and a floor
   translation fitted to A's root path: registration-curve style). Recorded in
   ``BlendResult.notes``.
2. The warp ``phi`` of B onto A (``warp.method != "none"``), on the curves of the method
   at most ``warp.sample_fps`` frames per second, with the landmarks (seconds, or ``"auto"``:
   the warp without landmarks is solved first and is the prior that pairs the events of A
   and B by phase, :func:`elastic_motion.apps.landmarks.pair_by_phase`; a pair the prior
   already meets within the events' timing uncertainty is dropped, the others are met at
   the edge of that window nearest the prior, with a relative landmark weight of at least
   1000; ``BlendResult.landmark_pairing`` says which and why). With ``cycles``,
   the gait cycles of A and B are matched first (:mod:`.cycles`), both clips keep only the
   matched cycles (B moved on the floor to start where A does), and the warp passes through
   every cycle boundary and step (landmarks, relative weight at least 1000).
3. The blend, on curves of all non-finger joints at the full frame rate:
   ``R^{-1}((1 - s) qA + s (qB * phi))`` started at the blended start point (paper 000,
   eq. 20; :func:`elastic_motion.curves.weighted_blend`), or for ``euler-linear``
   ``(1 - s) cA(u) + s cB(phi(u))``.
4. **Timing.** The result is a curve on ``[0, 1]``; its parameter ``u`` is played at time
   ``T(u) = (1 - s) d_A u + s d_B phi(u)``, the blended clock of the two inputs (``d``:
   durations), and sampled at A's frame rate. So ``s = 0`` gives A and ``s = 1`` gives B,
   each at its own timing, and the result's duration is ``(1 - s) d_A + s d_B``. (If
   extrapolation makes ``T`` decrease somewhere, its rate is held there at a tenth of the
   mean rate and the clock rescaled to the blended duration; a note says so.)
   **Pose anchoring** (``anchor=True``, the default; ``"lie"`` and ``"euler-elastic"`` with
   constant weights in ``[0, 1]``): the SRV blend integrates blended velocities, so its joint
   angles drift slowly from the aligned inputs' poses (on Bandai normal x tired, knees bent
   backwards by up to 16 degrees in the Lie blend and 29 in the Euler one, where both inputs
   stand straight). The slow part (Gaussian, 1 s) of each joint's difference from the inputs'
   weighted mean pose at the matched times is removed: the geodesic mean of the local
   rotations for ``"lie"`` (``_anchor_poses``), the mean of the Euler angles, the method's
   own space, for ``"euler-elastic"`` (``_anchor_euler``). The root's height is anchored
   likewise to the inputs' weighted mean root height: the root sinks too (8 cm over Bandai
   happy x sad), which the drifting poses had partly hidden; with the poses anchored alone the
   toes went 8.9 cm under the floor, with the height too 1.1 cm. The blend's velocities,
   which the elastic distance measures, barely change; the root's horizontal path is kept. A
   note, ``BlendResult.pose_anchor_deg`` and ``height_anchor_m`` give the largest
   corrections. ``anchor=False`` gives the
   papers' plain SRV blend (``examples/paper_figures.py`` reproduces the papers with it).
5. Finger joints (not on the curves, see :mod:`.align`) get the geodesic blend of A's and
   B's local rotations at the matched times; per-frame translations of non-root joints
   (position channels), linear blends.
6. The skeleton: ``skeleton="blend"`` (default) gives each bone the weighted mean of the
   inputs' offsets, so that leg length and root height blend together; ``"first"`` keeps A's.
7. **Foot-skate clean-up** (``contacts="auto"``, the default): the inputs' contacts
   (:func:`elastic_motion.motion.contacts.detect_contacts`) are carried through the warps to
   the blend's frames and enforced by leg IK and a smooth root correction
   (:mod:`.cleanup`, :mod:`elastic_motion.motion.ik`; bone lengths kept). The change is
   smoothed in time by the largest of 0.4, 0.3, ..., 0.025, 0 s that leaves the blend skating
   at most 0.95 times the lesser input (its own contacts), and then only the least fraction of
   the way to the plants that still does so (bisection): the smallest change of the blend's
   velocities (what the elastic distance measures) that skates no more than the inputs;
   planting harder than the inputs themselves would only move the blend farther from them.
   The floor is enforced in full. Skipped, with a note, when the inputs have no contacts
   or a weight is 1. ``BlendResult.cleanup`` reports skating before and after and the
   largest pose change; ``before_cleanup`` keeps the blend before it.
8. ``loop=True``: one matched cycle of each is blended (steps 1-6) and closed into a seamless
   loop by :func:`elastic_motion.apps.loop.loop_motion` (root ``"travel"``, C1: the
   velocities match at the seam too, so a game playing it on repeat shows no hitch); then the
   clean-up (step 7) runs on the loop, and the small seam gap it leaves (it plants the
   cycle's first and last contacts separately) is closed once more; where that closing pushes
   a foot more than 5 mm into the floor, the feet are lifted out of it (the floor only, eased)
   and the loop closed again (at most 3 times). The notes give the seam and the skating after
   each step.

Time-varying weights (``weight_curve``, two motions; paper 000 sec. 5.3)
----------------------------------------------------------------------
``s(u)`` piecewise linear in the result's normalised time ``u``: the poses are the frame-wise
geodesics between ``cA(u)`` and ``cB(phi(u))`` at ``s(u)`` (a constant-weight SRV blend
integrates blended velocities from a blended start, which would not end on B's pose), the
root integrates the blended root velocities ``(1 - s) cA' + s (cB o phi)'`` from the
blended start, and the clock runs at ``dT/du = (1 - s(u)) d_A + s(u) d_B phi'(u)``. So
``0:0,1:1`` starts on A's first pose and ends on B's last, a transition.

**Root translation.** The root position is a coordinate of the curve in both
representations (``R^3`` factor of ``R^3 x SO(3)^J``; the first three coordinates of the
Euler curve): after step 1 the SRV blend mixes the root *velocities* of A and B (the time-
aligned ones, with a warp) and integrates them from the blended start position. The
blended path therefore goes in the direction both inputs go after placement and covers a
distance between theirs; it is not the average of the two paths point by point (that is
``euler-linear``).

Several motions (``len(motions) >= 3``, weights ``w_k`` summing to 1): the weighted mean in
SRV space after aligning all to a common template, the weighted Karcher mean
(:func:`elastic_motion.apps.statistics.karcher_mean`: align every motion to the current
mean, average, repeat). Its warps ``phi_k`` map the template's parameter to each motion's,
and the timing is ``T(u) = sum_k w_k d_k phi_k(u)``. Landmarks are for two motions only.

Metrics (``BlendResult.metrics``, a :class:`BlendMetrics`, computed only with
``metrics=True``: they cost ``K (K + 1) / 2`` extra DP solves): foot sliding of the
result and of each input (:func:`elastic_motion.apps.metrics.foot_sliding`), bone-length
error of the result against its own skeleton and each input's
(:func:`elastic_motion.apps.metrics.bone_length_error`), and Lie elastic distances
between the inputs and from the result to each input
(:func:`elastic_motion.apps.distance.distance_table`, the same metric whatever the blend
method; on the SRV geodesic with the warp, ``d(R, A) + d(R, B) = d(A, B)`` up to the
discretisation, a useful check).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from elastic_motion.apps.align import (
    AUTO_LANDMARK_WEIGHT,
    check_method,
    landmark_parameters,
    motion_curves,
    plan_landmarks,
    solve_warp,
    warp_options,
)
from elastic_motion.apps.cleanup import CleanupResult
from elastic_motion.apps.metrics import BlendMetrics, blend_metrics, seam_metrics
from elastic_motion.apps.prepare import PreparedMotions, PrepareOptions, Source, prepare_motions
from elastic_motion.apps.progress import Progress, null_progress
from elastic_motion.curves import DiscreteCurve, srv_transform, weighted_blend
from elastic_motion.errors import OptionError
from elastic_motion.groups import SO3, PowerGroup
from elastic_motion.motion import Motion, Skeleton, from_euler_curve, from_lie_curve
from elastic_motion.motion.contacts import ContactOptions
from elastic_motion.motion.edit import gaussian_frames, smooth_change
from elastic_motion.warp import WarpOptions

__all__ = ["BlendMetrics", "BlendResult", "blend_metrics", "blend_motions"]

_SO3 = SO3()
_IDENTITY = np.array([[0.0, 0.0], [1.0, 1.0]])


@dataclass(frozen=True, eq=False)
class BlendResult:
    """The outcome of :func:`blend_motions`.

    Attributes
    ----------
    motion : Motion
        The blend: A's joints (or the common ones), A's frame rate, metres when known.
    method, warp : str
    weights : ndarray, shape (K,)
        Weight of each input (sum 1); with a weight curve, its mean over the normalised time.
    warps : tuple of ndarray
        Vertices ``(V, 2)`` of ``phi_k``: the result's curve parameter -> input ``k``'s
        (identity for A in a two-motion blend, and for every input without warp).
    landmarks : tuple of (float, float)
        Landmark pairs used, seconds in A and B.
    timing : ndarray, shape (F_out,)
        Curve parameter ``u`` of each output frame (see step 4 of the module docstring).
    prepared : PreparedMotions
        The inputs after preparation (units, joints, frame rate, placement).
    warp_options : WarpOptions
        How the warp was found.
    metrics : BlendMetrics or None
        Quality metrics (module docstring); None unless asked for.
    notes : tuple of str
        What was done, in words (preparation, warps, timing).
    cleanup : CleanupResult or None
        The foot-skate clean-up (step 7): carried contacts, skating before and after, the
        largest pose change; None when skipped (``contacts="off"``, a weight of 1).
    before_cleanup : Motion or None
        The blend before the clean-up (None when no clean-up was applied).
    cycles : CycleMatch or None
        How the gait cycles were matched (``cycles=True``); ``n == 0`` when they could not be.
    loop : LoopResult or None
        The closing of the blended cycle (``loop=True``): seam before and after.
    landmark_pairing : dict or None
        ``landmarks="auto"``: how the events were paired
        (:meth:`elastic_motion.apps.landmarks.PhasePairing.summary`): each pinned pair with
        its offset from the warp without landmarks, its timing window and why; each dropped
        pair and skipped event with the reason. None otherwise.
    pose_anchor_deg : float or None
        The largest correction of the pose anchoring (step 4, degrees: of a joint's rotation
        for ``"lie"``, of one Euler angle for ``"euler-elastic"``); None when not anchored.
    height_anchor_m : float or None
        The largest correction of the root height by the same anchoring (metres; length
        units when the motion's are unknown); None when not anchored.
    weight_curve : ndarray, shape (M, 2), or None
        The knots ``(u, s)`` of a weight curve (``weight_curve=``); None for constant weights.
    """

    motion: Motion
    method: str
    warp: str
    weights: np.ndarray
    warps: tuple[np.ndarray, ...]
    landmarks: tuple[tuple[float, float], ...]
    timing: np.ndarray
    prepared: PreparedMotions
    warp_options: WarpOptions = field(default_factory=WarpOptions)
    metrics: BlendMetrics | None = None
    notes: tuple[str, ...] = ()
    cleanup: CleanupResult | None = None
    before_cleanup: Motion | None = None
    cycles: Any = None
    loop: Any = None
    landmark_pairing: dict | None = None
    pose_anchor_deg: float | None = None
    height_anchor_m: float | None = None
    weight_curve: np.ndarray | None = None

    def summary(self) -> dict[str, Any]:
        """JSON-ready fields of a report (``docs/cli.md``)."""
        m = self.motion
        return {
            "method": self.method,
            "warp": self.warp,
            "weights": self.weights.tolist(),
            "weight_curve": None if self.weight_curve is None else self.weight_curve.tolist(),
            "landmarks_s": [list(p) for p in self.landmarks],
            "landmark_pairing": self.landmark_pairing,
            "frames": m.n_frames,
            "fps": m.fps,
            "duration_s": m.duration,
            "joints": m.n_joints,
            "warp_options": self.warp_options.to_json(),
            "warp_vertices": [w.tolist() for w in self.warps],
            "preparation": [dataclasses.asdict(r) for r in self.prepared.inputs],
            "metrics": None if self.metrics is None else self.metrics.summary(),
            "notes": list(self.notes),
            "cleanup": None if self.cleanup is None else self.cleanup.summary(),
            "cycles": None if self.cycles is None else self.cycles.summary(),
            "loop": None if self.loop is None else self.loop.summary(),
            "pose_anchor_deg": self.pose_anchor_deg,
            "height_anchor_m": self.height_anchor_m,
        }


def _check_weights(weights: Any, k: int, extrapolate: bool) -> np.ndarray:
    if weights is None:
        w = np.full(k, 1.0 / k)
    elif np.ndim(weights) == 0:
        if k != 2:
            raise OptionError(
                "weights",
                f"a single weight s means (1 - s, s) for two motions; got {k} motions, give {k} weights",
            )
        s = float(weights)
        w = np.array([1.0 - s, s])
    else:
        w = np.asarray(weights, dtype=np.float64).reshape(-1)
        if w.shape != (k,):
            raise OptionError("weights", f"expected {k} weights (one per motion); got {w.shape[0]}")
    if not np.isfinite(w).all():
        raise OptionError("weights", f"expected finite weights; got {w.tolist()}")
    if abs(w.sum() - 1.0) > 1e-9:
        raise OptionError("weights", f"expected weights summing to 1; got {w.tolist()} (sum {w.sum():g})")
    if (w < 0).any() or (w > 1).any():
        if k != 2:
            raise OptionError("weights", f"expected weights in [0, 1] for {k} motions; got {w.tolist()}")
        if not extrapolate:
            raise OptionError(
                "weights",
                f"s = {w[1]:g} is outside [0, 1]: that extrapolates beyond the inputs; "
                "pass extrapolate=True (CLI: --extrapolate) to allow it",
            )
    return w


def _sample_rotations(m: Motion, joints: np.ndarray, times: np.ndarray) -> np.ndarray:
    """Local rotations of ``joints`` at ``times`` (s) by geodesic interpolation, ``(N, k, 3, 3)``."""
    f = np.clip(times * m.fps, 0.0, m.n_frames - 1)
    i = np.clip(np.floor(f).astype(int), 0, m.n_frames - 2)
    u = f - i
    r0 = m.rotations[i][:, joints]
    r1 = m.rotations[i + 1][:, joints]
    return r0 @ _SO3.exp(u[:, None, None] * _SO3.log(np.swapaxes(r0, -1, -2) @ r1))


def _sample_linear(arr: np.ndarray, fps: float, times: np.ndarray) -> np.ndarray:
    """Linear interpolation of per-frame data ``(F, ...)`` at ``times`` (s)."""
    n = arr.shape[0]
    f = np.clip(times * fps, 0.0, n - 1)
    i = np.clip(np.floor(f).astype(int), 0, max(n - 2, 0))
    u = (f - i).reshape((-1,) + (1,) * (arr.ndim - 1))
    j = np.minimum(i + 1, n - 1)
    return (1.0 - u) * arr[i] + u * arr[j]


def _blend_rotations(rots: list[np.ndarray], w: np.ndarray) -> np.ndarray:
    """Weighted geodesic blend of rotation stacks ``(N, k, 3, 3)`` (two: geodesic point,
    extrapolation allowed; more: weighted Karcher mean, batched)."""
    if len(rots) == 2:
        return rots[0] @ _SO3.exp(w[1] * _SO3.log(np.swapaxes(rots[0], -1, -2) @ rots[1]))
    shape = rots[0].shape
    n = int(np.prod(shape[:-2]))
    g = PowerGroup(SO3(), n)
    pts = np.stack([r.reshape(n, 3, 3) for r in rots])
    return g.weighted_mean(pts, w).reshape(shape)


def parse_weight_curve(value: Any) -> np.ndarray:
    """Knots ``(u, s)`` of a weight curve from ``"u:s,u:s,..."`` or an array ``(M, 2)``.

    Raises
    ------
    OptionError
        Not defined on [0, 1] (first ``u`` not 0, last not 1, not increasing), a weight
        outside [0, 1], fewer than two knots, a malformed string.
    """
    if isinstance(value, str):
        try:
            arr = np.array([[float(x) for x in item.split(":")] for item in value.split(",") if item.strip()])
        except ValueError:
            arr = np.zeros((0, 1))
        if arr.ndim != 2 or arr.shape[1:] != (2,):
            raise OptionError("weight_curve", f"expected knots 'u:s,u:s,...' like '0:0,1:1'; got {value!r}")
    else:
        arr = np.asarray(value, dtype=np.float64)
        if arr.ndim != 2 or arr.shape[1] != 2:
            raise OptionError("weight_curve", f"expected knots (u, s) of shape (M, 2); got shape {arr.shape}")
    if arr.shape[0] < 2 or not np.isfinite(arr).all():
        raise OptionError("weight_curve", f"expected at least two finite knots (u, s); got {arr.tolist()}")
    u, s = arr[:, 0], arr[:, 1]
    if abs(u[0]) > 1e-12 or abs(u[-1] - 1.0) > 1e-12 or not (np.diff(u) > 0).all():
        raise OptionError(
            "weight_curve",
            f"expected a curve defined on [0, 1]: times u from 0 to 1, increasing; got u = {u.tolist()}",
        )
    if (s < 0).any() or (s > 1).any():
        raise OptionError("weight_curve", f"expected weights s in [0, 1]; got s = {s.tolist()}")
    return arr


def _per_frame(wf: np.ndarray, k: int, n: int, ndim_extra: int) -> np.ndarray | float:
    if wf.ndim == 1:
        return float(wf[k])
    return wf[:, k].reshape((n,) + (1,) * ndim_extra)


#: The SRV blend integrates blended velocities, so its joint angles drift from the aligned
#: inputs' poses: on Bandai normal x tired the knees of the Lie + warp blend bent backwards by
#: up to 16 degrees where both inputs stand straight, 16 degrees from their mean pose on
#: average (the Euler + warp blend: 29 degrees backwards). The drift is slow, so it is taken
#: out by a slow correction (Gaussian of this standard deviation, s) toward the inputs'
#: weighted mean pose: the knees' range is the inputs' again, while the velocities, which the
#: elastic distance measures, barely change (0.03 d(A, B) / 2 on that pair).
_POSE_ANCHOR = 1.0
#: Axis letters: ``_AXES.index(motion.up_axis)`` is the up axis's coordinate.
_AXES = "xyz"


def _anchor_poses(
    body: Motion, inputs: Sequence[Motion], times: Sequence[np.ndarray], w: np.ndarray
) -> tuple[Motion, float, float]:
    """``body`` (the blend's curve joints, one frame per output frame) with the slow part of its
    rotations' difference from the inputs' weighted mean pose removed (:data:`_POSE_ANCHOR`),
    and likewise of its root height's difference from the inputs' weighted mean root height.

    ``inputs``: the prepared inputs' curve motions (same joints as ``body``); ``times``: each
    input's time (s) at every output frame; ``w``: the blend weights ``(K,)``. Returns the
    anchored motion, the largest rotation correction in degrees and the largest height
    correction (``body``'s length units). The root's horizontal path is kept.
    """
    joints = np.arange(body.n_joints)
    rots = [_sample_rotations(m, joints, t) for m, t in zip(inputs, times, strict=True)]
    up = _AXES.index(body.up_axis)
    target = body.root_translation.copy()  # the horizontal path kept, the mean height
    target[:, up] = sum(
        wk * _sample_linear(m.root_translation[:, up], m.fps, t)
        for wk, m, t in zip(w, inputs, times, strict=True)
    )
    mean = body.replace(rotations=_blend_rotations(rots, w), root_translation=target)
    out = smooth_change(body, mean, _POSE_ANCHOR * body.fps)
    drift = _SO3.log(np.swapaxes(body.rotations, -1, -2) @ out.rotations)
    lift = float(np.abs(out.root_translation[:, up] - body.root_translation[:, up]).max(initial=0.0))
    return out, float(np.degrees(np.linalg.norm(drift, axis=-1).max())), lift


def _anchor_euler(
    values: np.ndarray, mean: np.ndarray, fps: float, up: int
) -> tuple[np.ndarray, float, float]:
    """The Euler-angle blend ``values`` ``(F, 3 + 3 J)`` (root position, then angles in radians)
    with the slow part (:data:`_POSE_ANCHOR`) of its angles' and its root height's (component
    ``up`` of the position) difference from ``mean``, the weighted mean of the aligned inputs'
    values, removed; the root's horizontal path is kept. Returns the anchored values, the
    largest correction of one angle in degrees and of the height (length units)."""
    out = values.copy()
    if values.shape[0] < 2:
        return out, 0.0, 0.0
    cols = np.r_[up, 3 : values.shape[1]]
    drift = gaussian_frames(values[:, cols] - mean[:, cols], _POSE_ANCHOR * fps)
    out[:, cols] -= drift
    return out, float(np.degrees(np.abs(drift[:, 1:]).max())), float(np.abs(drift[:, 0]).max())


def _blend_rotations_varying(rots: list[np.ndarray], s: np.ndarray) -> np.ndarray:
    """Geodesic blend of two rotation stacks ``(N, k, 3, 3)`` at per-frame weights ``s (N,)``."""
    rel = _SO3.log(np.swapaxes(rots[0], -1, -2) @ rots[1])
    return rots[0] @ _SO3.exp(s[:, None, None] * rel)


def _timing_varying(
    warps: Sequence[np.ndarray], knots: np.ndarray, durations: np.ndarray, fps: float
) -> np.ndarray:
    """Curve parameters of the output frames with a weight curve: the clock runs at
    ``dT/du = (1 - s(u)) d_A + s(u) d_B phi'(u)``."""
    v = warps[1]
    x = np.unique(np.concatenate([v[:, 0], knots[:, 0], np.linspace(0.0, 1.0, 1025)]))
    mid = 0.5 * (x[1:] + x[:-1])
    dphi = np.diff(np.interp(x, v[:, 0], v[:, 1])) / np.diff(x)
    s = np.interp(mid, knots[:, 0], knots[:, 1])
    rate = (1.0 - s) * durations[0] + s * durations[1] * dphi
    total = np.concatenate([[0.0], np.cumsum(rate * np.diff(x))])
    n = math.floor(total[-1] * fps + 1e-6) + 1
    times = np.arange(n) / fps
    u = np.interp(times, total, x)
    u[0] = 0.0
    if abs(times[-1] - total[-1]) < 1e-6:
        u[-1] = 1.0
    return u


def _varying_blend(
    curves: Sequence[DiscreteCurve], phi: np.ndarray, knots: np.ndarray, u: np.ndarray
) -> DiscreteCurve:
    """A transition at weights ``s(u)``: poses by frame-wise geodesics between ``cA(u)`` and
    ``cB(phi(u))``, the root (the first three coordinates) by integrating the blended root
    velocities ``(1 - s) cA' + s (cB o phi)'`` from the blended start."""
    ca, cb = curves
    g = ca.group
    uu = np.clip(u, 0.0, 1.0)
    s = np.interp(uu, knots[:, 0], knots[:, 1])
    pa = ca.evaluate(uu)
    pb = cb.evaluate(np.clip(np.interp(uu, phi[:, 0], phi[:, 1]), 0.0, 1.0))
    values = g.interpolate(pa, pb, s)
    # root: integrate the blended velocities on a fine grid
    x = np.unique(np.concatenate([uu, np.linspace(0.0, 1.0, 2049), phi[:, 0]]))
    ra = ca.evaluate(x)[:, :3]
    rb = cb.evaluate(np.clip(np.interp(x, phi[:, 0], phi[:, 1]), 0.0, 1.0))[:, :3]
    sm = np.interp(0.5 * (x[1:] + x[:-1]), knots[:, 0], knots[:, 1])[:, None]
    steps = (1.0 - sm) * np.diff(ra, axis=0) + sm * np.diff(rb, axis=0)
    root = (1.0 - s[0]) * ra[0] + s[0] * rb[0] + np.concatenate([np.zeros((1, 3)), np.cumsum(steps, axis=0)])
    values = np.array(values)
    values[:, :3] = np.column_stack([np.interp(uu, x, root[:, i]) for i in range(3)])
    return DiscreteCurve(values, g)


#: Where an extrapolated blend's clock would run backwards, its rate is held at this fraction
#: of the mean rate (``_timing``).
_CLOCK_FLOOR = 0.1


def _timing(
    warps: Sequence[np.ndarray], w: np.ndarray, durations: np.ndarray, fps: float
) -> tuple[np.ndarray, str]:
    """Curve parameters of the output frames (step 4) and a note (empty if regular)."""
    x = np.unique(np.concatenate([v[:, 0] for v in warps] + [np.linspace(0.0, 1.0, 257)]))
    total = np.zeros_like(x)
    for v, wk, dk in zip(warps, w, durations, strict=True):
        total += wk * dk * np.interp(x, v[:, 0], v[:, 1])
    duration = float(np.dot(w, durations))
    note = ""
    if not (np.diff(total) > 0).all() or total[-1] <= 0:
        if duration <= 0:
            raise OptionError(
                "weights",
                f"the blended duration sum_k w_k d_k = {duration:g} s is not positive; extrapolate less",
            )
        # hold the clock's rate (s per unit of u) at a tenth of its mean where it falls below,
        # keep its shape elsewhere: where the warp is steep the extrapolated curve moves far
        # in little u, and played uniformly it jumped (1 m in 5 frames at s = 1.5, 35 m/s)
        dx = np.diff(x)
        rate = np.maximum(np.diff(total) / dx, _CLOCK_FLOOR * duration)
        held = float(dx[np.diff(total) <= 0].sum())  # where it runs backwards (the note's share)
        total = np.concatenate([[0.0], np.cumsum(rate * dx)])
        total *= duration / total[-1]
        note = (
            f"timing: the blended clock does not increase on {100 * held:.0f} % of the curve "
            f"(extrapolation); its rate is held at {_CLOCK_FLOOR:g} of the mean there, the result lasts "
            f"the blended {duration:.3g} s"
        )
    duration = float(total[-1])
    n = math.floor(duration * fps + 1e-6) + 1
    times = np.arange(n) / fps
    u = np.interp(times, total, x)
    u[0] = 0.0
    if abs(times[-1] - duration) < 1e-6:
        u[-1] = 1.0
    return u, note


def _blend_skeleton(ms: Sequence[Motion], w: np.ndarray, mode: str) -> Skeleton:
    sk = ms[0].skeleton
    if mode == "first" or len(ms) == 1:
        return sk
    offsets = np.einsum("k,kjd->jd", w, np.stack([m.skeleton.offsets for m in ms]))
    es = sk.end_site_offsets
    same_es = all(
        m.skeleton.end_site_offsets.shape == es.shape
        and np.array_equal(m.skeleton.end_site_parents, sk.end_site_parents)
        for m in ms
    )
    if same_es and es.size:
        es = np.einsum("k,kjd->jd", w, np.stack([m.skeleton.end_site_offsets for m in ms]))
    return Skeleton(sk.names, sk.parents, offsets, sk.channels, sk.end_site_parents, es)


def _pairing_notes(pairing) -> list[str]:
    """One note for the pinned pairs and one for the dropped ones, seconds ``A:B``."""
    out = []
    if pairing.details:
        out.append(
            "landmarks auto: pinned (offset from the warp without landmarks beyond the events' "
            "timing uncertainty; met at the window's edge): "
            + ", ".join(
                f"{d['kind']} {d['time_a_s']:.3f}:{d['time_b_s']:.3f} "
                f"({d['offset_s']:+.3f} +- {d['window_s']:.4f} s -> {d['target_b_s']:.3f})"
                for d in pairing.details
            )
        )
    if pairing.dropped:
        out.append(
            "landmarks auto: dropped (the warp without landmarks meets them within the events' "
            "timing uncertainty, or out of order once pinned): "
            + ", ".join(
                f"{d['kind']} {d['time_s']:.3f}:{d['time_b_s']:.3f} "
                f"({d['offset_s']:+.3f} +- {d['window_s']:.4f} s)"
                for d in pairing.dropped
            )
        )
    return out


def blend_motions(
    motions: Sequence[Source] | PreparedMotions,
    weights: float | Sequence[float] | None = None,
    *,
    method: str = "lie",
    warp: str | WarpOptions | None = None,
    landmarks: Any = None,
    prepare: PrepareOptions | None = None,
    extrapolate: bool = False,
    skeleton: str = "blend",
    landmark_kinds: Sequence[str] | None = None,
    max_pairs: int | None = None,
    metrics: bool = False,
    progress: Progress | None = None,
    contacts: str | ContactOptions | None = "auto",
    weight_curve: Any = None,
    cycles: bool = False,
    loop: bool = False,
    template_warps: Sequence[np.ndarray] | None = None,
    anchor: bool = True,
) -> BlendResult:
    """Blend two or more motions.

    Parameters
    ----------
    motions : sequence of path or Motion, or PreparedMotions
        ``K >= 2`` motions (the first, A, sets the frame rate, joint order and placement);
        or the result of :func:`~elastic_motion.apps.prepare.prepare_motions` (then
        ``prepare`` must be None).
    weights : float or array_like of shape (K,), optional
        Two motions: ``s`` (the result is ``(1 - s) A + s B``) or ``(1 - s, s)``. More: one
        weight each, summing to 1. Default: equal weights.
    method : {"lie", "euler-elastic", "euler-linear"}
    warp : str or WarpOptions, optional
        How the warp is found (default ``WarpOptions()``); a method name (``"dp"``,
        ``"dp+refine"``, ``"none"``) is short for ``WarpOptions(method=name)``.
    landmarks : None, "auto" or array_like of shape (M, 2)
        Two motions only: pairs ``(time in A, time in B)`` in seconds (after preparation,
        i.e. from each motion's first frame), or ``"auto"``
        (:func:`elastic_motion.apps.landmarks.auto_landmarks`).
    prepare : PrepareOptions, optional
        The preparation step (:mod:`elastic_motion.apps.prepare`): T-pose, trim, units, up
        axis, joints (``"common"``...), placement.
    extrapolate : bool
        Allow ``s`` outside ``[0, 1]`` (two motions only).
    skeleton : {"blend", "first"}
        Bone offsets of the result: weighted mean of the inputs', or A's.
    landmark_kinds, max_pairs
        For ``landmarks="auto"`` (default kind ``"left_knee_passes"``, all pairs).
    metrics : bool, default False
        Compute :attr:`BlendResult.metrics` (:func:`blend_metrics`: three or more extra DP
        solves).
    progress : callable, optional
        ``progress(stage, done, total)``.
    contacts : "auto", "off" or ContactOptions, default "auto"
        The foot-skate clean-up (step 7): ``"auto"`` detects the inputs' contacts with the
        default :class:`~elastic_motion.motion.contacts.ContactOptions` (or the ones given),
        carries them through the warps and enforces them by leg IK; ``"off"`` (or None)
        skips it. Skipped (with a note) when the inputs have no contacts or a weight is 1.
    weight_curve : str or array_like of shape (M, 2), optional
        Two motions only, instead of ``weights``: the weight ``s`` of B as a piecewise linear
        function of the result's normalised time ``u`` (knots ``(u, s)``, ``u`` from 0 to 1
        increasing, ``s`` in [0, 1]; the string ``"0:0,1:1"`` is a transition from A into
        B). See "Time-varying weights" in the module docstring.
    cycles : bool, default False
        Two motions: segment gait cycles from the contacts, match consecutive cycles of A and
        B (:mod:`elastic_motion.apps.cycles`), keep only the matched spans and make the warp
        pass through every cycle boundary and step (landmarks). When the cycles cannot be
        matched, the global warp is used and a note says so.
    loop : bool, default False
        Blend one matched cycle of each (implies ``cycles``) and close the result into a
        seamless loop with :func:`elastic_motion.apps.loop.loop_motion` (root "travel", C1).
    template_warps : sequence of ndarray of shape (V, 2), optional
        Warps ``phi_k`` (a common template's parameter -> input ``k``'s) found before, e.g. by
        a blend space (:mod:`elastic_motion.apps.blendspace`); no warp is solved then.
    anchor : bool, default True
        Pose anchoring (step 4 of the module docstring) for the elastic methods with constant
        weights in ``[0, 1]``: the slow drift of the joint angles and of the root's height
        from the aligned inputs' mean is removed. False gives the papers' plain SRV blend
        (its joint angles may drift from the inputs': knees bent backwards; its root sinks).

    Returns
    -------
    BlendResult

    Raises
    ------
    ValueError
        Fewer than 2 motions, weights outside ``[0, 1]`` without ``extrapolate``, weights not
        summing to 1, different skeletons without ``joints="common"``, landmarks outside the
        clips or out of order, landmarks with more than two motions or without a warp.
    """
    report = progress or null_progress
    knots = None
    if weight_curve is not None:
        knots = parse_weight_curve(weight_curve)
        if weights is not None:
            raise OptionError("weight_curve", "expected weights or a weight curve, not both")
    if not isinstance(motions, PreparedMotions):
        motions = list(motions)
    k = len(motions.motions) if isinstance(motions, PreparedMotions) else len(motions)
    if k < 2:
        raise ValueError(f"motions: expected at least 2 motions to blend; got {k}")
    method = check_method(method)
    opts = warp_options(warp)
    if skeleton not in ("blend", "first"):
        raise OptionError("skeleton", f"expected 'blend' or 'first'; got {skeleton!r}")
    if knots is not None:
        if k != 2:
            raise OptionError("weight_curve", f"expected two motions (a transition from A into B); got {k}")
        mean_s = float(np.trapezoid(knots[:, 1], knots[:, 0]))
        weights = np.array([1.0 - mean_s, mean_s])
    w = _check_weights(weights, k, extrapolate)
    has_landmarks = landmarks is not None and not (isinstance(landmarks, str) and landmarks == "none")
    if has_landmarks and k != 2:
        raise OptionError("landmarks", f"expected two motions (landmarks pair A with B); got {k} motions")
    if has_landmarks and opts.method == "none":
        raise OptionError("landmarks", "expected a time warp (warp 'dp' or 'dp+refine'); got warp 'none'")

    stages = 4 if metrics else 3
    report("prepare", 0, stages)
    prep = prepare_motions(motions, prepare)
    notes = list(prep.notes)
    match = None
    if cycles or loop:
        if k != 2:
            raise OptionError("cycles", f"expected two motions (cycles of A against cycles of B); got {k}")
        if has_landmarks:
            raise OptionError("landmarks", "expected no landmarks with cycles (the cycles give them)")
        prep, match = _cycle_span(prep, contacts, 1 if loop else None)
        notes.append("cycles: " + match.why)
        if match.n:
            landmarks = list(match.landmarks)
            has_landmarks = bool(landmarks)
            if opts.method == "none":
                opts = opts.replace(method="dp")
            opts = opts.replace(landmark_weight=max(opts.landmark_weight, AUTO_LANDMARK_WEIGHT))
    ms = prep.motions
    durations = np.array([m.duration for m in ms])
    report("warp", 1, stages)

    # 2. warps, on curves of the method at warp_fps
    pairs: list[tuple[float, float]] = []
    landmark_pairing = None
    warps: list[np.ndarray] = [_IDENTITY] * k
    if template_warps is not None:
        if len(template_warps) != k:
            raise OptionError(
                "template_warps", f"expected {k} warps (one per motion); got {len(template_warps)}"
            )
        warps = [np.asarray(v, dtype=np.float64) for v in template_warps]
        notes.append("warps: given (a common template computed once)")
    elif opts.method != "none":
        coarse = motion_curves(prep, method, fps=opts.sample_fps, smoothing=opts.sample_smoothing)
        if k == 2:
            sa, sb = srv_transform(coarse[0]), srv_transform(coarse[1])
            plan = plan_landmarks(
                landmarks, ms[0], ms[1], sa, sb, opts, kinds=landmark_kinds, max_pairs=max_pairs
            )
            landmark_pairing = plan.pairing
            pairs, opts = plan.pairs, plan.options
            notes.extend(plan.notes)
            if landmark_pairing is not None:
                notes.extend(_pairing_notes(landmark_pairing))
            theta = landmark_parameters(pairs, durations[0], durations[1], prep.labels[:2]) if pairs else None
            res = solve_warp(sa, sb, opts, landmarks=theta)
            warps = [_IDENTITY, np.asarray(res.vertices)]
            notes.append(
                f"warp ({opts.method}) of {prep.labels[1]} onto {prep.labels[0]}: distance {res.distance:.4g}"
                + (f", {len(pairs)} landmark pairs" if pairs else "")
            )
        else:
            from elastic_motion.apps.statistics import karcher_mean

            n = max(c.n_points for c in coarse) - 1
            # the Karcher mean aligns by DP (its template moves between iterations)
            km = karcher_mean(coarse, weights=w, n_samples=n, warp=opts.replace(method="dp"))
            warps = [np.asarray(v) for v in km.warps]
            notes.append(
                f"weighted Karcher mean template: {km.iterations} iterations, "
                f"{'converged' if km.converged else 'not converged'}"
            )
    report("blend", 2, stages)

    # 3-4. blend on the full-rate curves, sample on the blended clock
    full = motion_curves(prep, method)
    if knots is not None:
        u = _timing_varying(warps, knots, durations, prep.fps)
        notes.append(
            "weight curve: s(u) = " + ", ".join(f"{a:g}:{b:g}" for a, b in knots) + " (u: normalised time); "
            "poses interpolated frame by frame at s(u), root velocities blended at s(u)"
        )
    else:
        u, tnote = _timing(warps, w, durations, prep.fps)
        if tnote:
            notes.append(tnote)
    local_u = [np.clip(np.interp(u, v[:, 0], v[:, 1]), 0.0, 1.0) for v in warps]
    s_u = None if knots is None else np.interp(u, knots[:, 0], knots[:, 1])
    # the inputs' weighted mean at the matched times, in R^d: the "euler-linear" blend, and the
    # pose the Euler elastic blend is anchored to
    # (a weight curve interpolates the poses frame by frame, _varying_blend: nothing drifts)
    anchorable = anchor and knots is None and method != "euler-linear"
    in_range = bool(((w >= 0.0) & (w <= 1.0)).all())
    euler_anchor = method == "euler-elastic" and anchorable and in_range
    linear_mean = (
        sum(wk * c.evaluate(lu) for wk, c, lu in zip(w, full, local_u, strict=True))
        if euler_anchor or (method == "euler-linear" and knots is None)
        else None
    )
    if knots is not None:
        curve = _varying_blend(full, warps[1], knots, u)
    elif method == "euler-linear":
        curve = DiscreteCurve(linear_mean, full[0].group)
    else:
        blended = weighted_blend(full, w, [None if v is _IDENTITY else v for v in warps])
        curve = DiscreteCurve(blended.evaluate(u), blended.group)
    anchored = None  # the largest pose-anchoring correction (deg), when anchored
    lifted = None  # and of the root height (length units of the prepared motions)
    like = prep.curve_motion(0)
    if euler_anchor:
        values, anchored, lifted = _anchor_euler(
            curve.values, linear_mean, prep.fps, _AXES.index(like.up_axis)
        )
        curve = DiscreteCurve(values, curve.group)
    conv = from_lie_curve if method == "lie" else from_euler_curve
    body = conv(curve, like, fps=prep.fps)
    times = [lu * d for lu, d in zip(local_u, durations, strict=True)]
    if anchorable and in_range and method == "lie":
        body, anchored, lifted = _anchor_poses(body, [prep.curve_motion(k) for k in range(len(ms))], times, w)
    if lifted is not None and like.metres_per_unit is not None:
        lifted *= like.metres_per_unit
    if anchored is not None:
        mean_pose = "geodesic mean pose" if method == "lie" else "mean Euler angles"
        height = (
            f"{100 * lifted:.3g} cm" if like.metres_per_unit is not None else f"{lifted:.3g} length units"
        )
        notes.append(
            f"poses anchored: the SRV blend's slow drift from the aligned inputs' {mean_pose} and mean root "
            f"height (up to {anchored:.3g} deg and {height}, Gaussian {_POSE_ANCHOR:g} s) removed"
        )
    elif anchorable:
        # an extrapolated mean pose is no anchor: beyond the inputs it bends joints further
        # than either (knees 48 degrees backwards at s = 1.5 on Bandai normal x tired)
        notes.append("poses not anchored: the weights extrapolate beyond the inputs")

    # 5. assemble the full skeleton: curve joints from the curve, the others blended per frame
    out_sk = _blend_skeleton(ms, w, skeleton)
    names = out_sk.names
    f_out = u.shape[0]
    rotations = np.empty((f_out, len(names), 3, 3))
    cj = [names.index(n) for n in prep.curve_joints]
    rotations[:, cj] = body.rotations
    extra = np.array([names.index(n) for n in prep.extra_joints], dtype=int)
    wf = w if s_u is None else np.column_stack([1.0 - s_u, s_u])  # (K,) or per frame (F, K)
    if extra.size:
        rots = [_sample_rotations(m, extra, t) for m, t in zip(ms, times, strict=True)]
        rotations[:, extra] = (
            _blend_rotations(rots, w) if s_u is None else _blend_rotations_varying(rots, s_u)
        )
    jt = None
    if all(m.joint_translations is not None for m in ms):
        jt = sum(
            _per_frame(wf, i, u.shape[0], 2) * _sample_linear(m.joint_translations, m.fps, t)
            for i, (m, t) in enumerate(zip(ms, times, strict=True))
        )
    elif ms[0].joint_translations is not None:
        jt = _sample_linear(ms[0].joint_translations, ms[0].fps, times[0])
    label = " + ".join(f"{wk:.3g} {lab}" for wk, lab in zip(w, prep.labels, strict=True))
    result = ms[0].replace(
        skeleton=out_sk,
        fps=prep.fps,
        root_translation=body.root_translation,
        rotations=rotations,
        joint_translations=jt,
        source=(),
        name=f"blend ({method}, warp {opts.method}): {label}",
    )

    loop_res = None
    if loop:
        # close the blended cycle first, then plant the feet on the loop: the closing spreads
        # the seam's gap over the cycle (and would bring the skating back after a clean-up)
        loop_res = _close_loop(result)
        result = loop_res.motion
        what = "one matched cycle of each" if match is not None and match.n else "the whole clips (no cycles)"
        notes.append(
            f"loop: {what} blended and closed (seam {loop_res.seam_before.seam_position_max_m:.3g} m -> "
            f"{loop_res.seam_after.seam_position_max_m:.3g} m, {_hitch(loop_res)})"
        )
    cleaned, before = _cleanup(result, prep, warps, u, local_u, wf, contacts, notes)
    if cleaned is not None and cleaned.applied:
        before, result = result, cleaned.motion
        if loop_res is not None:
            # the clean-up plants the first and the last contact of the cycle separately: close
            # the small gap it leaves at the seam once more
            seam = seam_metrics(result, joints=loop_res.closed_joints)
            loop_res = _close_loop(result)
            result = loop_res.motion
            from elastic_motion.apps.cleanup import cleanup_footskate
            from elastic_motion.apps.metrics import contact_skating

            again = contact_skating(result, cleaned.contacts)
            floor_note = ""
            below = again.below_floor
            rounds = 0
            while again.below_floor > _LOOP_FLOOR_TOL and rounds < _LOOP_FLOOR_ROUNDS:
                # the closing spreads the seam over the cycle and may push a foot into the
                # floor: lift it out (the floor only, eased) and close again
                rounds += 1
                result = cleanup_footskate(result, cleaned.contacts, smooth=0.0, strength=0.0).motion
                loop_res = _close_loop(result)
                result = loop_res.motion
                again = contact_skating(result, cleaned.contacts)
            if rounds:
                floor_note = (
                    f" (a foot went {below:.3g} m below the floor in the closing: lifted out and "
                    f"closed again {rounds} times)"
                )
            notes.append(
                f"loop: the clean-up left a seam of {seam.seam_position_max_m:.3g} m, "
                f"{seam.seam_angle_max_deg:.3g} deg; closed again: seam "
                f"{loop_res.seam_after.seam_position_max_m:.3g} m, skating while in contact "
                f"{again.mean_speed:.3g} m/s, below the floor {again.below_floor:.3g} m, {_hitch(loop_res)}"
                + floor_note
            )
    out_metrics = None
    if metrics:
        report("metrics", 3, stages)
        out_metrics = blend_metrics(result, prep, w)
    report("done", stages, stages)
    return BlendResult(
        motion=result,
        method=method,
        warp=opts.method,
        weights=w,
        warps=tuple(warps),
        landmarks=tuple(pairs),
        timing=u,
        prepared=prep,
        warp_options=opts,
        metrics=out_metrics,
        notes=tuple(notes),
        cleanup=cleaned,
        before_cleanup=before,
        landmark_pairing=None if landmark_pairing is None else landmark_pairing.summary(),
        cycles=match,
        loop=loop_res,
        pose_anchor_deg=anchored,
        height_anchor_m=lifted,
        weight_curve=knots,
    )


def _cycle_span(prep: PreparedMotions, contacts: Any, max_cycles: int | None) -> tuple[PreparedMotions, Any]:
    """Match the gait cycles of the two prepared motions and keep the matched spans; B is
    moved on the floor so that its span starts where A's does."""
    from elastic_motion.apps.cycles import gait_cycles, match_cycles
    from elastic_motion.motion import trim

    opts = _contact_options(contacts) or ContactOptions()
    ma, mb = prep.motions
    ca = gait_cycles(ma, opts)
    cb = gait_cycles(mb, opts, foot=ca.foot or None)
    if ca.n_cycles and not cb.n_cycles:
        other = "right" if ca.foot == "left" else "left"
        ca2, cb2 = gait_cycles(ma, opts, foot=other), gait_cycles(mb, opts, foot=other)
        if ca2.n_cycles and cb2.n_cycles:
            ca, cb = ca2, cb2
    match = match_cycles(ca, cb, max_cycles=max_cycles)
    if not match.n and (ca.n_cycles or cb.n_cycles):
        # say per foot what each has: the cycles must be of one foot in both
        count = {
            f: (gait_cycles(ma, opts, foot=f).n_cycles, gait_cycles(mb, opts, foot=f).n_cycles)
            for f in ("left", "right")
        }
        have = "; ".join(f"{f} foot: A {n[0]}, B {n[1]}" for f, n in count.items())
        match = dataclasses.replace(
            match,
            why=f"no foot has a gait cycle (two strikes) in both A and B ({have}): fall back to the "
            "global warp",
        )
    if not match.n:
        return prep, match
    ta = trim(ma, *match.span_a)
    tb = trim(mb, *match.span_b)
    up = "xyz".index(tb.up_axis)
    shift = ta.root_translation[0] - tb.root_translation[0]
    shift[up] = 0.0
    tb = tb.replace(root_translation=tb.root_translation + shift)
    return dataclasses.replace(prep, motions=(ta, tb)), match


#: The clean-up's smoothing of its change (s), tried in this order: the first whose skating is
#: at most _SKATE_GOAL times the lesser input's is kept (0: the exact plants); then the least
#: fraction of the way to the plants (``strength``) that still meets the goal. The goal is the
#: inputs' own skating (less 5 %, a margin for the written file and for the skating of the
#: spans that ``cycles`` keeps): the clean-up removes what the blend adds, no more. The old goal
#: of 0.9 with smoothings of at most 0.1 s moved the blends up to 33 % farther from their inputs
#: (benchmarks/blend_quality.py, Bandai normal x tired); now at most 13 %.
_SMOOTHING = (0.4, 0.3, 0.2, 0.15, 0.1, 0.07, 0.05, 0.035, 0.025, 0.0)
_SKATE_GOAL = 0.95
#: Bisection steps for the fraction of the way to the plants (1/64 resolution).
_STRENGTH_STEPS = 6
#: The clean-up first moves the whole blend vertically, as slowly as this (s, Gaussian), so
#: its planted feet stand at their ground heights (``cleanup_footskate(settle=...)``).
_SETTLE = 1.0
#: Metres: how far the settle may take the root beyond the inputs' root heights at the
#: matched times (the six pairs of ``benchmarks/blend_quality.py`` settle at most 2 cm
#: beyond them: blended leg angles on a blended skeleton; :func:`_settle_bounds`).
_SETTLE_MARGIN = 0.03


#: A loop's floor after the last closing: lift and close again while a foot is deeper (m).
_LOOP_FLOOR_TOL = 0.005
_LOOP_FLOOR_ROUNDS = 3


def _close_loop(cycle: Motion):
    """The blended cycle closed into a loop (``blend_motions(loop=True)``): root "travel" and
    C1, the velocities matched at the seam too. C0 left a hitch there, the velocity jump 1.3-2.8
    times the blend's own quickest changes inside the cycle (DeepMimic walk x run 2.3, CMU
    07_01 x 09_11 2.8, Bandai normal x tired 1.7), C1 0.8-2.1 (what is left is the root's
    floor velocity, which travel keeps), at the same skating and change."""
    from elastic_motion.apps.loop import loop_motion

    return loop_motion(cycle, prepare=PrepareOptions(drop_tpose=False, fold_static_root=False), c1=True)


def _hitch(loop_res: Any) -> str:
    """The closed loop's hitch at the seam, for the notes (``SeamMetrics.seam_velocity_jump_ratio``:
    the seam's velocity jump over the cycle's own quick changes; the joints' velocities match
    in a C1 loop, what is left is the root's floor velocity, which a travelling loop keeps)."""
    s = loop_res.seam_after
    ratio, point = s.seam_velocity_jump_ratio, s.seam_velocity_jump_point
    return f"hitch {ratio:.2f}x the cycle's quickest changes, at {point}"


def _contact_options(contacts: Any) -> ContactOptions | None:
    if contacts is None or (isinstance(contacts, str) and contacts == "off"):
        return None
    if isinstance(contacts, ContactOptions):
        return contacts
    if isinstance(contacts, str) and contacts == "auto":
        return ContactOptions()
    raise OptionError("contacts", f"expected 'auto', 'off' or ContactOptions; got {contacts!r}")


def _settle_bounds(
    result: Motion, prep: PreparedMotions, local_u: Sequence[np.ndarray], wf: np.ndarray
) -> tuple[np.ndarray | None, np.ndarray | None]:
    """Per-frame bounds ``(lower, upper)`` of the clean-up's vertical settle
    (:func:`~elastic_motion.apps.cleanup.settle_offset`): it may take the blend's root no
    lower than the lowest and no higher than the highest root of the inputs that weigh in
    on the frame, at the matched times (``local_u``: each input's curve parameter per output
    frame), give or take :data:`_SETTLE_MARGIN`, the inputs' heights smoothed like the settle
    (their step-by-step bob would make it fast); where the root is already outside that
    range, no further out. ``(None, None)`` for weights outside ``[0, 1]`` (extrapolation).

    A planted foot that the blend holds decimetres above the floor while its root is at the
    inputs' height is a leg posed wrong (an Euler blend's hip), not a body floating: settled
    down to it, the body sank 16-30 cm and the other stance knee folded 30-47 deg more than
    in either input (CMU 131_01's crouch blended with 131_02 or 02_01); leg IK plants it.
    """
    if not bool(np.all((wf >= 0.0) & (wf <= 1.0))):
        return None, None
    up = _AXES.index(result.up_axis)
    n = result.n_frames
    heights = np.stack(
        [
            gaussian_frames(
                _sample_linear(m.root_translation[:, up], m.fps, lu * m.duration), _SETTLE * result.fps
            )
            for m, lu in zip(prep.motions, local_u, strict=True)
        ]
    )  # (K, F)
    weighs = np.stack([np.broadcast_to(_per_frame(wf, k, n, 0), (n,)) > 0 for k in range(len(local_u))])
    root = result.root_translation[:, up]
    lo = np.where(weighs, heights, np.inf).min(axis=0) - _SETTLE_MARGIN - root
    hi = np.where(weighs, heights, -np.inf).max(axis=0) + _SETTLE_MARGIN - root
    return np.minimum(lo, 0.0), np.maximum(hi, 0.0)


def _cleanup(
    result: Motion,
    prep: PreparedMotions,
    warps: Sequence[np.ndarray],
    u: np.ndarray,
    local_u: Sequence[np.ndarray],
    w: np.ndarray,
    contacts: Any,
    notes: list[str],
) -> tuple[CleanupResult | None, Motion | None]:
    """Step 7: carry the inputs' contacts to the blend and enforce them (:mod:`.cleanup`)."""
    from elastic_motion.apps.cleanup import carry_contacts, cleanup_footskate, find_legs, settle_offset
    from elastic_motion.motion.contacts import MISSED_STANCES_NOTE, detect_contacts

    opts = _contact_options(contacts)
    if opts is None:
        return None, None
    if w.ndim == 1 and np.isclose(w, 1.0).any():
        notes.append("clean-up: skipped, the result is one of the inputs (a weight of 1)")
        return None, None
    found = [detect_contacts(m, opts) for m in prep.motions]
    for label, c in zip(prep.labels, found, strict=True):
        notes += [f"clean-up: contacts of {label}: {n}" for n in c.notes if n.startswith(MISSED_STANCES_NOTE)]
    if not any(c.any for c in found):
        notes.append("clean-up: skipped, no contacts found in the inputs")
        return None, None
    carried = carry_contacts(
        found,
        warps,
        u,
        [m.duration for m in prep.motions],
        w,
        fps=result.fps,
        joints=result.skeleton.names,
        options=opts,
    )
    # the smoothest change (least change of velocities) that skates no more than the inputs
    from elastic_motion.apps.metrics import contact_skating

    own = [contact_skating(m, c).mean_speed for m, c in zip(prep.motions, found, strict=True) if c.any]
    goal = _SKATE_GOAL * min(own)
    legs, leg_notes = find_legs(result)  # once, for every trial below
    lower, upper = _settle_bounds(result, prep, local_u, w)
    lift = settle_offset(result, carried, legs, sigma=_SETTLE, lower=lower, upper=upper)  # for every trial
    for smooth in _SMOOTHING:
        res = cleanup_footskate(result, carried, smooth=smooth, settle=lift, legs=legs)
        if not res.applied or res.skating_after.mean_speed <= goal:
            break
    if res.applied and res.skating_after.mean_speed < goal:
        # then the least fraction of that change that still meets the goal (bisection)
        lo, hi = 0.0, 1.0
        for _ in range(_STRENGTH_STEPS):
            mid = 0.5 * (lo + hi)
            trial = cleanup_footskate(
                result, carried, smooth=res.smooth, strength=mid, settle=lift, legs=legs
            )
            if trial.skating_after.mean_speed <= goal:
                hi, res = mid, trial
            else:
                lo = mid
    if res.applied:
        notes.append(
            "clean-up: contacts carried through the warps and enforced by leg IK; skating "
            f"{res.skating_before.mean_speed:.3g} -> {res.skating_after.mean_speed:.3g} m/s (inputs "
            + ", ".join(f"{x:.3g}" for x in own)
            + f"), body settled vertically by up to {res.settle_offset:+.3g} m, "
            f"change smoothed over {res.smooth:g} s, {100 * res.strength:.0f} % of it kept; "
            f"largest change {res.max_position_change:.3g} m, {res.max_rotation_change_deg:.3g} deg"
        )
    else:
        notes += [f"clean-up: {n}" for n in (*leg_notes, *res.notes)]
    return res, None
