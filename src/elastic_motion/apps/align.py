"""The time warp between two motions, and the curves the warp works on.

:func:`align_motions` prepares two motions (:mod:`elastic_motion.apps.prepare`), then
computes the optimal time warp of B onto A (paper 001, eq. 21; paper 000, sec. 3.5), with
or without landmarks, and the elastic distance. :func:`motion_curves` and
:func:`solve_warp` are the pieces blend and distance share.

Conventions
-----------
* **Curve joints**: the curves that the warp and the blend work on carry every joint
  except the finger, thumb and hand-index joints (:func:`elastic_motion.motion.finger_joints`):
  in the CMU data these flip by 180 degrees between frames, where ``log`` is ambiguous and
  a single flip would dominate the SRV norm of the whole frame. Blends carry them along
  separately (:mod:`elastic_motion.apps.blend`).
* **Representations** (the ``method`` argument): ``"lie"`` -- the curve in
  ``R^3 x SO(3)^J`` with the inner-product weights of
  :func:`elastic_motion.motion.group_weights` shared by all the motions (paper
  000); ``"euler-linear"`` and ``"euler-elastic"`` -- continuous Euler angles in
  ``R^(3 + 3 J)``, root position in metres, angles in radians, unweighted (the baseline
  of paper 001). Each later motion's Euler angles are shifted by whole turns (``2 pi k``,
  per coordinate) to start nearest the first motion's, so that a heading of 179 degrees
  in one clip and -179 in the other are not 358 degrees apart.
* **Parameters and times**: a curve of a motion with duration ``d`` has parameter
  ``t = time / d`` in ``[0, 1]``. The warp ``phi`` maps A's parameter to B's: frame time
  ``tA`` of A matches ``d_B phi(tA / d_A)`` of B. Landmarks are given in seconds
  ``(tA, tB)`` and become ``(tA / d_A, tB / d_B)``.
* **How the warp is found**: one :class:`elastic_motion.warp.WarpOptions` (a method name
  such as ``"dp"`` is short for ``WarpOptions(method="dp")``): the solver, the DP slopes,
  the frame rate the curves are resampled to (``sample_fps``, default 30: a warp is a
  function on ``[0, 1]``, independent of the sampling, and the DP cost grows with the
  square of the frame count), the Gaussian low-pass before that sampling
  (``sample_smoothing``, seconds) and the *relative* landmark weight
  ``landmark_weight`` (:mod:`elastic_motion.warp.options`).
* **Smoothing before sampling**: with ``fps`` given, :func:`motion_curves` low-passes each
  motion (:func:`elastic_motion.motion.edit.smooth_motion`, standard deviation ``smoothing``
  seconds, default 1/60 s) before it samples it, also when it is already at that rate: the
  SRV ``q = v / sqrt|v|`` of a curve is a derivative, and without the low-pass the
  capture's frame-to-frame noise, what lies above the Nyquist frequency of the sampled
  curve and the choice of the sampling instants all show in the distance, which then grows
  with the frame rate. The full-rate curves
  (``fps=None``, the ones a blend is made of) are never smoothed.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from elastic_motion.apps.landmark_files import LandmarkFile
from elastic_motion.apps.landmarks import DEFAULT_PAIR_KINDS, phase_landmarks
from elastic_motion.apps.prepare import PreparedMotions, PrepareOptions, Source, prepare_motions
from elastic_motion.curves import DiscreteCurve, SRVFunction, srv_transform
from elastic_motion.defaults import AUTO_LANDMARK_WEIGHT
from elastic_motion.errors import OptionError
from elastic_motion.groups import Euclidean
from elastic_motion.motion import (
    Motion,
    resample,
    select_frames,
    to_euler_curve,
    to_lie_curve,
)
from elastic_motion.motion.edit import check_interpolation, resampled_frames, smooth_motion
from elastic_motion.motion.representations import representation
from elastic_motion.notes import Note, note_texts
from elastic_motion.vocabulary import CURVE_METHODS, CurveMethod
from elastic_motion.warp import WARP_METHODS, WarpOptions, WarpResult, optimal_warp, warp_energy
from elastic_motion.warp.options import DEFAULT_SAMPLE_SMOOTHING

__all__ = [
    "AUTO_LANDMARK_WEIGHT",
    "METHODS",
    "AlignResult",
    "CurveMethod",
    "LandmarkPlan",
    "align_motions",
    "check_method",
    "landmark_parameters",
    "motion_curves",
    "plan_landmarks",
    "solve_warp",
    "warp_options",
]

#: Blend / alignment methods: the two representations (:data:`elastic_motion.motion.METHODS`)
#: and ``"euler-linear"``, Euler curves interpolated frame by frame (paper 001 Fig. 5 (a)):
#: the values of :data:`CurveMethod` (:mod:`elastic_motion.vocabulary`).
METHODS: tuple[str, ...] = CURVE_METHODS


def warp_options(warp: str | WarpOptions | None) -> WarpOptions:
    """``WarpOptions`` from a method name (``"dp"``...), an options object or None (defaults)."""
    if warp is None:
        return WarpOptions()
    if isinstance(warp, WarpOptions):
        return warp
    if isinstance(warp, str):
        if warp not in WARP_METHODS:
            raise OptionError("warp", f"expected one of {list(WARP_METHODS)} or WarpOptions; got {warp!r}")
        return WarpOptions(method=warp)  # type: ignore[arg-type]
    raise OptionError("warp", f"expected a method name or WarpOptions; got {type(warp).__name__}")


# ------------------------------------------------------------------------------------------
# Curves and warps
# ------------------------------------------------------------------------------------------


def motion_curves(
    prepared: PreparedMotions,
    method: str,
    *,
    fps: float | None = None,
    which: Sequence[int] | None = None,
    smoothing: float = DEFAULT_SAMPLE_SMOOTHING,
    interpolation: str = "geodesic",
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
    smoothing : float, default ``WarpOptions().sample_smoothing`` (1/60 s)
        With ``fps`` given: Gaussian low-pass of each motion before it is sampled, standard
        deviation in seconds (module docstring); 0: none. Ignored without ``fps``.
    interpolation : {"geodesic", "cubic"}, default "geodesic"
        With ``fps`` given: ``"geodesic"`` downsamples to at most ``fps`` (a motion at a lower
        rate stays as it is); ``"cubic"`` samples every motion at exactly ``fps``, above its
        own rate too, by cubic splines through its smoothed frames
        (:func:`elastic_motion.motion.edit.resample_at_times`). A piecewise-geodesic curve on a
        clip's own 30 fps grid cannot be matched to the same motion sampled between its
        frames (a sub-frame shift, which a DP on that grid cannot represent, and cut
        corners); on a finer grid of a smooth interpolant it can, so distances resolve
        changes much smaller than the sampling floor (``benchmarks/blend_quality.py``).

    Returns
    -------
    list of DiscreteCurve
        Over the curve joints; points ``(3 + 9 J,)`` (lie) or ``(3 + 3 J,)`` (euler).
    """
    method = check_method(method)
    check_interpolation(interpolation, OptionError)
    idx = range(len(prepared.motions)) if which is None else list(which)
    out = []
    ref_angles = None
    for k in idx:
        m = prepared.curve_motion(k)
        if fps is not None and smoothing > 0:
            m = smooth_motion(m, smoothing)
        if fps is not None and interpolation == "cubic" and not math.isclose(m.fps, fps):
            # (may sample above the clip's rate: bounded before it allocates, naming the option)
            _check_samples(m, fps, prepared.labels[k])
            m = resample(m, fps, interpolation="cubic")
        elif fps is not None and m.fps > fps * (1 + 1e-9):
            _check_samples(m, fps, prepared.labels[k])
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


def _check_samples(motion: Motion, fps: float, label: str) -> None:
    """A curve needs two samples: ``OptionError("sample_fps", ...)`` naming the clip when its
    resampling at ``fps`` would keep one (or more than the limits allow)."""
    n = resampled_frames(motion, fps, "sample_fps")
    if n < 2:
        raise OptionError(
            "sample_fps",
            f"{label}: expected a rate giving at least 2 samples of the clip ({motion.duration:.3g} s); "
            f"got {fps:g} fps (1 sample)",
        )


def check_method(method: str, argument: str = "method") -> str:
    """The canonical name of a curve method (:data:`CurveMethod`; ``"euler"`` is
    ``"euler-elastic"``), else an :class:`OptionError` naming ``argument``."""
    if method == "euler-linear":
        return method
    if method not in METHODS and method != "euler":
        raise OptionError(argument, f"expected one of {list(METHODS)}; got {method!r}")
    return representation(method, argument).name


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
    options: WarpOptions,
    *,
    landmarks: np.ndarray | None = None,
) -> WarpResult | None:
    """The optimal warp of B onto A (:func:`elastic_motion.warp.optimal_warp`).

    Parameters
    ----------
    srv_a, srv_b : SRVFunction
    options : WarpOptions
        ``method="none"`` returns None. The relative ``landmark_weight`` becomes the
        solver's absolute ``lam`` here (:meth:`WarpOptions.absolute_landmark_weight`).
    landmarks : ndarray, shape (M, 2), optional
        Curve parameters (:func:`landmark_parameters`).
    """
    if options.method == "none":
        if landmarks is not None and len(landmarks):
            raise OptionError("landmarks", "expected a time warp (warp 'dp' or 'dp+refine'); got warp 'none'")
        return None
    kw: dict[str, Any] = {}
    if landmarks is not None and len(landmarks):
        kw["landmarks"] = np.asarray(landmarks)
        kw["lam"] = options.absolute_landmark_weight(srv_a.norm() ** 2, srv_b.norm() ** 2)
    return optimal_warp(srv_a.q, srv_b.q, t0=srv_a.t, t1=srv_b.t, **options.solver_kwargs(), **kw)


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
    landmark_weight : float or None
        The relative weight the warp met ``landmarks`` with (``"auto"``: at least
        :data:`AUTO_LANDMARK_WEIGHT`); None without landmarks.
    landmark_pairing : PhasePairing or None
        ``landmarks="auto"``: the pairing by phase the pairs come from
        (:func:`elastic_motion.apps.landmarks.phase_landmarks`); None otherwise.
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
    landmark_weight: float | None = None
    landmark_pairing: Any = None

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
            "landmark_weight": self.landmark_weight,
            "duration_a_s": self.duration_a,
            "duration_b_s": self.duration_b,
            "warp_vertices_s": np.column_stack([ta, tb]).tolist(),
            "notes": note_texts(self.prepared.notes),
        }
        if self.landmark_pairing is not None:
            out["landmark_pairing"] = self.landmark_pairing.summary()
        if self.result is not None:
            d = self.result.diagnostics
            out["solver"] = {
                "grid": list(d.grid_shape),
                "slopes": d.n_steps,
                "time_s": d.time_total,
            }
        return out


#: Kind of the landmark plan's notes (``Note.kind``): where the pairs came from.
LANDMARK_PLAN = "landmarks.plan"
# AUTO_LANDMARK_WEIGHT (elastic_motion.defaults): the relative landmark weight at least used
# for automatic landmarks (pairs found by phase around the warp without landmarks are trusted).


@dataclass(frozen=True)
class LandmarkPlan:
    """The landmarks a warp between two prepared motions will meet (:func:`plan_landmarks`).

    Attributes
    ----------
    pairs : list of (float, float)
        Seconds ``(tA, tB)``; empty without landmarks.
    options : WarpOptions
        The warp options to solve with (``"auto"`` raises the landmark weight to at least
        :data:`AUTO_LANDMARK_WEIGHT`).
    notes : tuple of Note
        How the pairs were found (``"auto"``: paired by phase, how many left unpaired), kind
        :data:`LANDMARK_PLAN`.
    pairing : PhasePairing or None
        ``"auto"``: the phase pairing the pairs come from (pinned and dropped events, why:
        :func:`elastic_motion.apps.landmarks.phase_landmarks`); None otherwise.
    """

    pairs: list[tuple[float, float]]
    options: WarpOptions
    notes: tuple[Note, ...] = ()
    pairing: Any = None


def plan_landmarks(
    landmarks: Any,
    a: Motion,
    b: Motion,
    prior: np.ndarray | tuple[SRVFunction, SRVFunction],
    options: WarpOptions,
    *,
    kinds: Sequence[str] | None = None,
    max_pairs: int | None = None,
) -> LandmarkPlan:
    """Landmark pairs in seconds from ``None``, ``"auto"`` or pairs ``(tA, tB)``: the one
    place where blend and align decide what their warp meets.

    ``"auto"``: events of ``kinds`` (default
    :data:`elastic_motion.apps.landmarks.DEFAULT_PAIR_KINDS`: knee crossings, foot strikes and
    lift-offs) detected on the two prepared motions and paired by phase, with the warp
    without landmarks as the prior (:func:`elastic_motion.apps.landmarks.phase_landmarks`);
    the warp then meets them with a relative weight of at least
    :data:`AUTO_LANDMARK_WEIGHT`.

    Parameters
    ----------
    landmarks : None, "none", "auto", LandmarkFile or array_like of shape (M, 2)
        A :class:`~elastic_motion.apps.landmark_files.LandmarkFile` gives its pairs and its
        recorded landmark weight, which replaces ``options``'.
    a, b : Motion
        The prepared motions (times from their first frames).
    prior : ndarray of shape (V, 2), or (SRVFunction, SRVFunction)
        For ``"auto"``: the warp of B onto A without landmarks, its vertices when solved
        already (a blend's plain warp), or the SRV functions of A's and B's curves to solve it
        on (``solve_warp(srv_a, srv_b, options)``, only for ``"auto"``).
    options : WarpOptions
    kinds, max_pairs
        For ``"auto"``.
    """
    if landmarks is None or (isinstance(landmarks, str) and landmarks == "none"):
        return LandmarkPlan([], options)
    if isinstance(landmarks, LandmarkFile):
        # the file's pairs, met with the weight it records (the report of `landmarks`)
        weight = landmarks.landmark_weight
        options = landmarks.warp_options(options)
        note = f"landmarks from {Path(landmarks.path).name}: {len(landmarks.pairs)} pairs" + (
            "" if weight is None else f", met with the relative weight it records ({weight:g})"
        )
        return LandmarkPlan(list(landmarks.pairs), options, (Note(LANDMARK_PLAN, note),))
    if isinstance(landmarks, str):
        if landmarks != "auto":
            raise OptionError(
                "landmarks", f"expected None, 'auto' or pairs (tA, tB) in seconds; got {landmarks!r}"
            )
        if options.method == "none":
            raise OptionError("landmarks", "expected a time warp (warp 'dp' or 'dp+refine'); got warp 'none'")
        if isinstance(prior, tuple):
            prior = np.asarray(solve_warp(prior[0], prior[1], options).vertices)
        pairing = phase_landmarks(
            a,
            b,
            tuple(kinds) if kinds else DEFAULT_PAIR_KINDS,
            prior=np.asarray(prior),
            max_pairs=max_pairs,
        )
        pairs = list(pairing.times)
        if not pairs:
            return LandmarkPlan(
                [],
                options,
                (Note(LANDMARK_PLAN, "landmarks auto: no events to pair; warp without landmarks"),),
                pairing,
            )
        return LandmarkPlan(
            pairs,
            options.replace(landmark_weight=max(options.landmark_weight, AUTO_LANDMARK_WEIGHT)),
            (
                Note(
                    LANDMARK_PLAN,
                    f"landmarks auto: {len(pairs)} events paired by phase (prior: the warp without "
                    f"landmarks), {len(pairing.skipped)} left unpaired",
                    {"pairs": len(pairs), "unpaired": len(pairing.skipped)},
                ),
            ),
            pairing,
        )
    arr = np.asarray(landmarks, dtype=np.float64)
    if arr.size == 0:
        return LandmarkPlan([], options)
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise OptionError("landmarks", f"expected pairs (tA, tB) of shape (M, 2); got shape {arr.shape}")
    return LandmarkPlan([(float(x), float(y)) for x, y in arr], options)


def align_motions(
    a: Source | PreparedMotions,
    b: Source | None = None,
    *,
    method: str = "lie",
    warp: str | WarpOptions | None = None,
    landmarks: Any = None,
    prepare: PrepareOptions | None = None,
    landmark_kinds: Sequence[str] | None = None,
    max_pairs: int | None = None,
) -> AlignResult:
    """The optimal time warp of B onto A and their elastic distance.

    Parameters
    ----------
    a, b : path or Motion
        Prepared together by :func:`elastic_motion.apps.prepare.prepare_motions`; or ``a``
        that function's result for two motions and ``b`` None.
    method : {"lie", "euler-elastic", "euler-linear"}
        Representation of the curves (both Euler methods use the Euler SRV here).
    warp : str or WarpOptions, optional
        How the warp is found (default ``WarpOptions()``: dynamic programming).
    landmarks : None, "auto" or array_like of shape (M, 2)
        Pairs ``(time in A, time in B)`` in seconds, or automatic (:mod:`.landmarks`).
    prepare : PrepareOptions, optional
        Preparation (T-pose, units, up axis, trim, joints, placement).
    landmark_kinds, max_pairs
        For ``landmarks="auto"``: event kinds and pairs per kind.

    Returns
    -------
    AlignResult
    """
    method = check_method(method)
    opts = warp_options(warp)
    if isinstance(a, PreparedMotions):
        if b is not None or len(a.motions) != 2:
            raise OptionError("motions", "expected prepared motions of exactly two inputs and no b")
        prep = prepare_motions(a, prepare)
    else:
        if b is None:
            raise OptionError("motions", "expected two motions a and b; got b None")
        prep = prepare_motions([a, b], prepare)
    ma, mb = prep.motions
    ca, cb = motion_curves(prep, method, fps=opts.sample_fps, smoothing=opts.sample_smoothing)
    sa, sb = srv_transform(ca), srv_transform(cb)
    plan = plan_landmarks(landmarks, ma, mb, (sa, sb), opts, kinds=landmark_kinds, max_pairs=max_pairs)
    pairs, opts = plan.pairs, plan.options
    prep = prep.with_notes(*plan.notes)
    theta = landmark_parameters(pairs, ma.duration, mb.duration, prep.labels[:2]) if pairs else None
    res = solve_warp(sa, sb, opts, landmarks=theta)
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
        warp=opts.method,
        duration_a=ma.duration,
        duration_b=mb.duration,
        prepared=prep,
        result=res,
        landmark_weight=opts.landmark_weight if pairs else None,
        landmark_pairing=plan.pairing,
    )
