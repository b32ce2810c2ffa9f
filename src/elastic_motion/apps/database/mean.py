"""The Karcher mean of motion files, as a motion: :func:`mean_motion` (``elastic-motion mean``).

The files are prepared as for a database
(:func:`~elastic_motion.apps.database.preparation.prepare_same_skeleton`: ``n_samples + 1``
frames each, one skeleton, one rest pose), turned into curves of one representation
(:func:`~elastic_motion.apps.database.preparation.database_curves`: Lie curves with weights
shared by all, or Euler curves), averaged in SRV space by
:func:`elastic_motion.apps.statistics.karcher_mean` and converted back on the skeleton of the
first file, lasting the inputs' mean duration, resampled (geodesic interpolation) to the output
frame rate. :class:`MeanOptions` holds every knob; :mod:`elastic_motion.apps.pca` builds its
model around the same mean.
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from elastic_motion import motion as mm
from elastic_motion._options import options_from_json, with_overrides
from elastic_motion.apps.database.preparation import database_curves, prepare_same_skeleton
from elastic_motion.apps.database.settings import joint_selection
from elastic_motion.apps.limit_stage import LimitStage, check_limits_option, keep_within_limits
from elastic_motion.apps.prepare import PrepareOptions
from elastic_motion.apps.progress import Progress
from elastic_motion.apps.report import jsonable
from elastic_motion.apps.statistics import MEAN_WARP, KarcherMeanResult, as_warp_options, karcher_mean
from elastic_motion.errors import OptionError
from elastic_motion.motion import Motion, representations
from elastic_motion.motion.joint_limits import JointLimits
from elastic_motion.vocabulary import LimitPolicy
from elastic_motion.warp import WarpOptions

__all__ = ["MeanMotionResult", "MeanOptions", "mean_motion"]


@dataclass(frozen=True)
class MeanOptions:
    """How the Karcher mean of motion files is taken (:func:`mean_motion`; the alignment of
    :func:`elastic_motion.apps.pca.motion_pca`).

    Attributes
    ----------
    n_samples : int, default 64
        Cells of the common time grid: each motion is resampled to ``n_samples + 1`` frames
        uniformly over its duration (normalised to 1).
    method : {"lie", "euler-elastic"}, default "lie"
        The curve representation (``"euler"`` is accepted for ``"euler-elastic"``; held as the
        public name).
    joints : "all", "common", "map" or tuple of str, default "all"
        As :attr:`elastic_motion.apps.database.DatabaseSettings.joints`; ``"all"`` needs one
        skeleton.
    drop_fingers, align_heading : bool, default True
        As in :class:`~elastic_motion.apps.database.DatabaseSettings`.
    warp : WarpOptions, default :data:`~elastic_motion.apps.statistics.MEAN_WARP`
        How each motion is aligned to the mean (DP, neighbourhood 10: its energy is
        non-increasing; an internal step, not a distance reported for a pair); a method name is
        accepted for ``WarpOptions(method=name)``; ``"none"``: the plain SRV average. Its
        ``sample_smoothing`` is not used: the mean's inputs are not low-passed (the mean is an
        animation made of them), unlike a database's curves for its pair distances.
    max_iter : int, default 20
        Alignment iterations at most (0: the plain average, unaligned).
    tol : float, default 1e-4
        Stop when the relative energy decrease falls below it (dimensionless).
    fps : float, optional
        Frames per second of the mean (default: the first file's, after preparation).
    up, units : str or None, default None
        How every file is read, as :attr:`DatabaseSettings.up` and
        :attr:`DatabaseSettings.units` (None: detected, guessed).
    joint_limits : {"keep", "report", "off"}, JointLimits or path, default "keep"
        Limits of the joints' DOF angles, the loop's and the blend's option
        (:func:`elastic_motion.apps.limit_stage.check_limits_option`: those of the first
        file's ASF, the given ones or those of the given ASF file). ``"keep"``: the mean's
        DOF angles that every input respects are moved into their ranges, eased
        (:func:`elastic_motion.apps.limit_stage.keep_within_limits`); ``"report"``: measured.

    Raises
    ------
    OptionError
        A value out of range, naming the field.
    """

    n_samples: int = 64
    method: str = "lie"
    joints: str | tuple[str, ...] = "all"
    drop_fingers: bool = True
    align_heading: bool = True
    warp: WarpOptions = MEAN_WARP
    max_iter: int = 20
    tol: float = 1e-4
    fps: float | None = None
    up: str | None = None
    units: str | None = None
    joint_limits: LimitPolicy | JointLimits = "keep"

    def __post_init__(self) -> None:
        object.__setattr__(self, "joint_limits", check_limits_option(self.joint_limits))
        PrepareOptions(up=self.up, units=self.units)  # type: ignore[arg-type]  # checks them, naming the field
        if isinstance(self.n_samples, bool) or not isinstance(self.n_samples, int) or self.n_samples < 2:
            raise OptionError("n_samples", f"expected an integer >= 2; got {self.n_samples!r}")
        object.__setattr__(self, "method", representations.representation(self.method).name)
        object.__setattr__(self, "joints", joint_selection(self.joints))
        object.__setattr__(self, "warp", as_warp_options(self.warp, default=MEAN_WARP))
        if isinstance(self.max_iter, bool) or not isinstance(self.max_iter, int) or self.max_iter < 0:
            raise OptionError("max_iter", f"expected an integer >= 0; got {self.max_iter!r}")
        if isinstance(self.tol, bool) or not isinstance(self.tol, int | float) or not self.tol >= 0:
            raise OptionError("tol", f"expected a number >= 0; got {self.tol!r}")
        if self.fps is not None and not (
            isinstance(self.fps, int | float)
            and not isinstance(self.fps, bool)
            and math.isfinite(self.fps)
            and self.fps > 0
        ):
            raise OptionError("fps", f"expected a positive frame rate; got {self.fps!r}")

    def read_options(self) -> PrepareOptions:
        """How each file is read (:func:`elastic_motion.apps.prepare.load_motion`): the
        defaults with :attr:`up` and :attr:`units`."""
        return PrepareOptions(up=self.up, units=self.units)  # type: ignore[arg-type]

    def replace(self, **changes: Any) -> MeanOptions:
        """A copy with some fields changed (validated again)."""
        return dataclasses.replace(self, **changes)

    def to_json(self) -> dict[str, Any]:
        """The fields as a JSON-ready dict (the warp as :meth:`WarpOptions.to_json`, joints as a list)."""
        return {
            **{f.name: getattr(self, f.name) for f in dataclasses.fields(self)},
            "joints": self.joints if isinstance(self.joints, str) else list(self.joints),
            "warp": self.warp.to_json(),
            "joint_limits": _limits_json(self.joint_limits),
        }

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> MeanOptions:
        """Inverse of :meth:`to_json`; unknown keys are an error naming them."""
        d = dict(data)
        if isinstance(d.get("warp"), dict):
            d["warp"] = WarpOptions.from_json(d["warp"])
        if isinstance(d.get("joint_limits"), dict):
            d["joint_limits"] = JointLimits.from_json(d["joint_limits"])
        if isinstance(d.get("joints"), list):
            d["joints"] = tuple(d["joints"])
        return options_from_json(cls, d, argument="mean options")


def _matched_frames(
    motion: Motion, inputs: Sequence[Motion], warps: Sequence[np.ndarray]
) -> list[np.ndarray]:
    """Each input's fractional frame at each of the mean's frames ``(F,)``, through its warp onto
    the mean (the mean's normalised time ``u`` -> the input's ``phi_k(u)``)."""
    u = np.clip(motion.times / max(motion.duration, 1e-12), 0.0, 1.0)
    out = []
    for m, w in zip(inputs, warps, strict=True):
        w = np.asarray(w, dtype=np.float64)
        phi = np.interp(u * w[-1, 0], w[:, 0], w[:, 1]) / w[-1, 1]
        out.append(phi * (m.n_frames - 1))
    return out


def _limits_json(value: str | JointLimits) -> Any:
    return value.to_json() if isinstance(value, JointLimits) else value


@dataclass(frozen=True, eq=False)
class MeanMotionResult:
    """Karcher mean of motion files, as a motion (:func:`mean_motion`).

    Attributes
    ----------
    motion : Motion
        The mean, on the skeleton of the first file (after preparation: metres when the
        unit is known, Y-up, no finger joints by default), lasting ``duration`` seconds at
        the output frame rate.
    karcher : KarcherMeanResult
        The mean curve, its SRV function, the warps, energies and distances.
    inputs : tuple of str
        The files, in order (length ``K``).
    representation : {"lie", "euler"}
        The stored key of the curve representation.
    n_samples : int
        Cells of the common grid the mean was computed on (``n_samples + 1`` frames).
    duration : float
        Seconds: the mean of the inputs' durations.
    notes : dict of str -> tuple of str
        What the preparation did to each input file.
    joint_limits : LimitStage or None
        What the limits stage did (``joint_limits`` option); None without limits.
    """

    motion: Motion
    karcher: KarcherMeanResult
    inputs: tuple[str, ...]
    representation: str
    n_samples: int
    duration: float
    notes: dict[str, tuple[str, ...]] = field(default_factory=dict)
    joint_limits: LimitStage | None = None

    @property
    def energies(self) -> np.ndarray:
        """``(iterations,)``: Karcher energy ``sum_k w_k d(mu_i, c_k)^2`` per iteration."""
        return self.karcher.energies

    @property
    def converged(self) -> bool:
        """The relative energy decrease fell below ``tol``."""
        return self.karcher.converged

    @property
    def distances(self) -> np.ndarray:
        """``(K,)``: elastic distance of each input to the mean (SRV norm units)."""
        return self.karcher.distances

    def summary(self) -> dict[str, Any]:
        """JSON-ready fields of a report, through :func:`~elastic_motion.apps.report.jsonable`."""
        return jsonable(
            {
                "inputs": self.inputs,
                "representation": self.representation,
                "method": representations.representation(self.representation).name,
                "n_samples": self.n_samples,
                "energies": self.karcher.energies,
                "iterations": self.karcher.iterations,
                "converged": self.karcher.converged,
                "distances": dict(zip(self.inputs, self.karcher.distances, strict=True)),
                "duration": self.duration,
                "fps": self.motion.fps,
                "frames": self.motion.n_frames,
                "notes": self.notes,
                "joint_limits": None if self.joint_limits is None else self.joint_limits.summary(),
            }
        )


def mean_motion(
    files: Sequence[str | os.PathLike[str]],
    options: MeanOptions | None = None,
    *,
    representation: str | None = None,
    progress: Progress | None = None,
    **overrides: Any,
) -> MeanMotionResult:
    """Karcher mean of motion files, as a motion (module docstring).

    The Python face of ``elastic-motion mean``: the same options give the same numbers.

    Parameters
    ----------
    files : sequence of paths
        At least one motion file, of one skeleton (or ``joints="common"`` / ``"map"``).
    options : MeanOptions, optional
        Every knob; default ``MeanOptions()``.
    representation : str, optional
        The name of ``method`` in earlier releases (``"lie"`` / ``"euler"``); overrides it.
    progress : callable, optional
        ``progress("mean", iteration, max_iter)``.
    **overrides
        Fields of :class:`MeanOptions` (``n_samples=32``, ``method="euler-elastic"``, ``warp="none"``...).

    Returns
    -------
    MeanMotionResult

    Raises
    ------
    OptionError
        No file, different skeletons (use ``joints="common"``), an unknown representation or
        another bad option.
    ParseError
        A malformed file.
    """
    if representation is not None:
        overrides = {
            **overrides,
            "method": representations.representation(representation, "representation").name,
        }
    opts = with_overrides(MeanOptions, options, overrides)
    files = [os.fspath(f) for f in files]
    if not files:
        raise OptionError("files", "expected at least one motion file; got none")
    prepared = prepare_same_skeleton(
        files,
        opts.n_samples,
        joints=opts.joints,
        drop_fingers=opts.drop_fingers,
        align_heading=opts.align_heading,
        options=opts.read_options(),
    )
    rep = representations.representation(opts.method)
    curves = database_curves(prepared, rep)
    res = karcher_mean(
        curves,
        n_samples=opts.n_samples,
        warp=opts.warp,
        max_iter=opts.max_iter,
        tol=opts.tol,
        progress=progress,
    )
    duration = float(np.mean([p.duration for p in prepared]))
    like = prepared[0].motion
    motion = rep.from_curve(res.mean, like, fps=opts.n_samples / duration if duration > 0 else like.fps)
    p0 = prepared[0]
    out_fps = float(opts.fps) if opts.fps is not None else (p0.original_frames - 1) / p0.duration
    if duration > 0 and out_fps > 0:
        motion = mm.resample(motion, out_fps)
    motion = motion.replace(name="karcher mean")
    limits = None
    if opts.joint_limits != "off":
        inputs = [p.motion for p in prepared]
        matched = _matched_frames(motion, inputs, res.warps)
        motion, limits = keep_within_limits(motion, opts.joint_limits, inputs, matched)
    return MeanMotionResult(
        motion=motion,
        karcher=res,
        inputs=tuple(files),
        representation=rep.key,
        n_samples=opts.n_samples,
        duration=duration,
        notes={p.path: p.notes for p in prepared},
        joint_limits=limits,
    )
