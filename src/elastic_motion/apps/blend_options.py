"""The options of a blend: one frozen :class:`BlendOptions`, every knob once, validated when made.

:func:`elastic_motion.apps.blend.blend_motions` takes a ``BlendOptions`` (or keyword overrides
of its fields: ``blend_motions([a, b], 0.5, method="euler-elastic")``) and passes it down its
stages unchanged; the blend space (:mod:`elastic_motion.apps.blendspace`) takes the same object
for its blends. The weights are not options: they are data (an argument of the blend).

This module sits beside the blend package, not in it, so that the command line reads its
choices (:data:`SkeletonMode`, the methods, the contact policies) without loading the blend
app: the package imports the loop app for ``loop=True``, 1.1 s of the command line's start.
"""

from __future__ import annotations

import os
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from elastic_motion.apps.align import CurveMethod, check_method, warp_options
from elastic_motion.apps.landmark_files import LandmarkFile
from elastic_motion.apps.limit_stage import check_limits_option
from elastic_motion.apps.prepare import PrepareOptions
from elastic_motion.errors import OptionError
from elastic_motion.motion.contacts import ContactOptions, ContactPolicy, contact_policy
from elastic_motion.motion.joint_limits import JointLimits
from elastic_motion.motion.representations import EULER, Representation, representation
from elastic_motion.vocabulary import (
    CONTACT_WARP_MODES,
    SKELETON_MODES,
    ContactWarpMode,
    LimitPolicy,
    SkeletonMode,
)
from elastic_motion.warp import WarpOptions

__all__ = [
    "SKELETON_MODES",
    "BlendOptions",
    "SkeletonMode",
    "knot_weights",
    "parse_weight_curve",
    "read_weight_curve",
]

# Bone offsets of a blend: SkeletonMode ("blend": the weighted mean of the inputs', "first":
# the first input's) and SKELETON_MODES, from elastic_motion.vocabulary.

_FLAGS = ("extrapolate", "anchor", "trim_ends", "cycles", "loop", "metrics")


@dataclass(frozen=True)
class BlendOptions:
    """How to blend motions (:func:`elastic_motion.apps.blend.blend_motions`; the steps are
    those of its module docstring).

    Attributes
    ----------
    method : {"lie", "euler-elastic", "euler-linear"}, default "lie"
        The curves blended (:data:`elastic_motion.apps.align.CurveMethod`; ``"euler"`` is
        accepted for ``"euler-elastic"``): the SRV geodesic in ``R^3 x SO(3)^J`` (paper 000),
        in the Euler angles' ``R^d``, or the Euler angles interpolated frame by frame.
    warp : WarpOptions, default ``WarpOptions()``
        How the warp of B onto A (of each input onto the template) is found; a method name
        (``"dp"``, ``"dp+refine"``, ``"none"``) is taken as ``WarpOptions(method=name)``.
    landmarks : None, "auto", LandmarkFile or pairs ``(tA, tB)``, default None
        Two motions only: pairs of times in seconds (after preparation, from each motion's
        first frame) the warp meets, or ``"auto"`` (events paired by phase,
        :func:`elastic_motion.apps.landmarks.phase_landmarks`); ``"none"`` is None. Pairs are
        kept as a tuple of ``(float, float)``. Needs a warp; not with ``cycles``.
    landmark_kinds : tuple of str or None, default None
        ``landmarks="auto"``: the event kinds paired (None: the library's default kinds).
    max_pairs : int or None, default None
        ``landmarks="auto"``: at most this many pairs (None: all).
    prepare : PrepareOptions or None, default None
        The preparation step (:func:`elastic_motion.apps.prepare.prepare_motions`); None: its
        defaults. Must be None for motions already prepared (a ``PreparedMotions``).
    extrapolate : bool, default False
        Allow a weight outside ``[0, 1]`` (two motions only).
    skeleton : {"blend", "first"}, default "blend"
        Bone offsets of the result: the inputs' weighted mean, or A's.
    weight_curve : tuple of tuple of float, str, path or None, default None
        Instead of weights, time-varying weights ``w_k(u)``, piecewise linear in the result's
        normalised time ``u`` (the template's parameter), blended in SRV space (the package
        docstring). Knots ``(u, w_1, ..., w_K)``, one weight per motion, each row
        non-negative and summing to 1 (within 1e-6; rows are rescaled to sum to 1), ``u``
        from 0 to 1, increasing: a string ``"0:0.5/0.5/0,1:0/0/1"``, an array ``(M, K + 1)``,
        or a CSV file (a path, or a string ending in ``.csv``; :func:`read_weight_curve`).
        Two motions also take knots ``(u, s)`` of B's weight: ``"0:0,1:1"`` (a transition
        from A into B) or an array ``(M, 2)``. Kept as given (parsed by
        :func:`parse_weight_curve`): rows ``(u, s)`` or ``(u, w_1, ..., w_K)``.
    anchor : bool, default True
        Pose anchoring of the elastic methods with constant weights in ``[0, 1]``: the slow
        drift (Gaussian, 1 s) of the joint angles and of the root's height from the aligned
        inputs' mean is removed. False: the papers' plain SRV blend.
    contacts : {"keep", "report", "off"}, default "keep"
        The inputs' foot contacts (:data:`elastic_motion.motion.contacts.ContactPolicy`):
        ``"keep"`` carries them through the warps and plants them by leg IK (the foot-skate
        clean-up; ``"auto"`` is accepted for it), ``"report"`` carries them and measures the
        blend's skating against them without changing it, ``"off"`` (or None) does neither.
    contact_options : ContactOptions, default ``ContactOptions()``
        Thresholds of the contact detection (metres, m/s, seconds), for the clean-up and for
        the gait cycles.
    cycles : bool, default False
        Two motions: match their gait cycles (:mod:`elastic_motion.apps.cycles`), keep the
        matched spans and make the warp pass through every cycle boundary and step.
    loop : bool, default False
        Two motions: blend one matched cycle of each and close it into a seamless loop
        (:func:`elastic_motion.apps.loop.loop_motion`, root "travel", C1).
    trim_ends : bool, default True
        Trim the output's ends to the span where every input is in motion: where the warp holds
        one input still while another moves on (its clock rate below
        :data:`elastic_motion.apps.blend.timing.HELD_RATE` of the fastest input's, as at the
        ends of clips that start or stop out of phase), the blend of a step and a pause is a
        foot sliding at half a step's length. The trim is in the notes and the report; False
        keeps the whole clips.
    metrics : bool, default False
        Compute the quality metrics (:func:`elastic_motion.apps.metrics.blend_metrics`:
        ``K (K + 1) / 2`` extra DP solves, ``K`` when the blend's own warp of A and B is the
        metrics': a Lie blend of two, default warp options, no landmarks).
    contact_warp : {"auto", "on", "off"}, default "auto"
        The contact-guided warp (:mod:`elastic_motion.apps.blend.contact_warp`): the heel
        strikes and toe-offs of A and B as landmarks, paired by phase around the plain warp.
        ``"on"``: always (a warp between two motions, no landmarks given, no cycles);
        ``"auto"``: only when the plain warp's blend skids more than its inputs (measured like
        them) and the guided one skids less with ``d(A, B)`` under its warp at most
        :data:`~elastic_motion.apps.blend.contact_warp.DISTANCE_TOLERANCE` times the plain
        warp's; ``"off"``: never.
    joint_limits : {"keep", "report", "off"}, JointLimits or path, default "keep"
        Limits of the joints' DOF angles, the loop's option
        (:func:`elastic_motion.apps.limit_stage.check_limits_option`): those of the ASF file
        the first input was read from (nothing happens when there are none), the given ones
        or those of the given ASF file. ``"keep"``: the blend's last stage moves every DOF
        angle the inputs respect at the matched times into its range, eased
        (:func:`elastic_motion.apps.limit_stage.keep_within_limits`); ``"report"``: only
        measured; ``"off"``: skip.
    """

    method: CurveMethod = "lie"
    warp: WarpOptions = field(default_factory=WarpOptions)
    landmarks: Any = None
    landmark_kinds: tuple[str, ...] | None = None
    max_pairs: int | None = None
    prepare: PrepareOptions | None = None
    extrapolate: bool = False
    skeleton: SkeletonMode = "blend"
    weight_curve: tuple[tuple[float, ...], ...] | None = None
    anchor: bool = True
    trim_ends: bool = True
    contacts: ContactPolicy = "keep"
    contact_options: ContactOptions = field(default_factory=ContactOptions)
    cycles: bool = False
    loop: bool = False
    metrics: bool = False
    joint_limits: LimitPolicy | JointLimits = "keep"
    contact_warp: ContactWarpMode = "auto"

    def __post_init__(self) -> None:
        self._set("joint_limits", check_limits_option(self.joint_limits))
        self._set("method", check_method(self.method))
        self._set("warp", warp_options(self.warp))
        self._set("landmarks", _landmarks(self.landmarks))
        self._set("landmark_kinds", _kinds(self.landmark_kinds))
        mp = self.max_pairs
        if mp is not None and (isinstance(mp, bool) or not isinstance(mp, int | np.integer) or mp < 1):
            raise OptionError("max_pairs", f"expected None or an integer >= 1; got {mp!r}")
        if self.prepare is not None and not isinstance(self.prepare, PrepareOptions):
            raise OptionError(
                "prepare", f"expected PrepareOptions or None; got {type(self.prepare).__name__}"
            )
        if self.skeleton not in SKELETON_MODES:
            raise OptionError("skeleton", f"expected 'blend' or 'first'; got {self.skeleton!r}")
        if self.weight_curve is not None:
            self._set(
                "weight_curve",
                tuple(tuple(float(x) for x in row) for row in parse_weight_curve(self.weight_curve)),
            )
        if isinstance(self.contacts, ContactOptions):
            raise OptionError(
                "contacts",
                "expected one of ['keep', 'report', 'off']; got ContactOptions: give the thresholds as "
                "contact_options= (and contacts='keep')",
            )
        self._set("contacts", contact_policy(self.contacts))
        self._set(
            "contact_options", ContactOptions() if self.contact_options is None else self.contact_options
        )
        if not isinstance(self.contact_options, ContactOptions):
            raise OptionError(
                "contact_options", f"expected ContactOptions; got {type(self.contact_options).__name__}"
            )
        if self.contact_warp not in CONTACT_WARP_MODES:
            raise OptionError(
                "contact_warp", f"expected one of {list(CONTACT_WARP_MODES)}; got {self.contact_warp!r}"
            )
        for name in _FLAGS:
            value = getattr(self, name)
            if not isinstance(value, bool | np.bool_):
                raise OptionError(name, f"expected True or False; got {value!r}")
            self._set(name, bool(value))
        self._check_together()

    def _set(self, name: str, value: Any) -> None:
        object.__setattr__(self, name, value)

    def _check_together(self) -> None:
        """Cross-field checks, naming the option that cannot be given with the others."""
        if self.contact_warp == "on":
            if self.warp.method == "none":
                raise OptionError("contact_warp", "expected a time warp (warp 'dp' or 'dp+refine') with 'on'")
            if self.landmarks is not None:
                raise OptionError("contact_warp", "expected no landmarks with 'on' (it sets them)")
            if self.matches_cycles:
                raise OptionError(
                    "contact_warp", "expected no cycles with 'on' (the cycles give the landmarks)"
                )
        if self.landmarks is None:
            return
        if self.warp.method == "none":
            raise OptionError("landmarks", "expected a time warp (warp 'dp' or 'dp+refine'); got warp 'none'")
        if self.cycles or self.loop:
            raise OptionError("landmarks", "expected no landmarks with cycles (the cycles give them)")

    @property
    def representation(self) -> Representation:
        """The curves' representation (:data:`~elastic_motion.motion.representations.LIE` or
        ``EULER``; ``"euler-linear"`` interpolates Euler curves)."""
        return EULER if self.method == "euler-linear" else representation(self.method)

    @property
    def matches_cycles(self) -> bool:
        """Whether the gait cycles are matched first (``cycles``, or ``loop``, which needs them)."""
        return self.cycles or self.loop

    def replace(self, **changes: Any) -> BlendOptions:
        """A copy with some fields changed (validated again)."""
        return replace(self, **changes)

    def to_json(self) -> dict[str, Any]:
        """The fields as a JSON-ready dict (a landmarks file as its pairs)."""
        out = asdict(self)
        out["warp"] = self.warp.to_json()
        if isinstance(self.landmarks, LandmarkFile):
            out["landmarks"] = [list(p) for p in self.landmarks.pairs]
        if isinstance(self.joint_limits, JointLimits):
            out["joint_limits"] = self.joint_limits.to_json()
        return out


def _landmarks(value: Any) -> Any:
    """The ``landmarks`` option: None, ``"auto"``, a LandmarkFile, or a tuple of pairs (s)."""
    if value is None or isinstance(value, LandmarkFile) or (isinstance(value, str) and value == "auto"):
        return value
    if isinstance(value, str):
        if value == "none":
            return None
        raise OptionError("landmarks", f"expected None, 'auto' or pairs (tA, tB) in seconds; got {value!r}")
    arr = np.asarray(value, dtype=np.float64)
    if arr.size == 0:
        return ()
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise OptionError("landmarks", f"expected pairs (tA, tB) of shape (M, 2); got shape {arr.shape}")
    return tuple((float(a), float(b)) for a, b in arr)


def _kinds(value: Any) -> tuple[str, ...] | None:
    if value is None:
        return None
    if isinstance(value, str) or not all(isinstance(k, str) for k in value):
        raise OptionError("landmark_kinds", f"expected a sequence of event kinds; got {value!r}")
    return tuple(value)


def parse_weight_curve(value: Any) -> np.ndarray:
    """Knots of a weight curve (:class:`BlendOptions` ``weight_curve``): from ``"u:s,u:s,..."``
    (two motions, B's weight ``s``), ``"u:w1/w2/.../wK,..."`` (one weight per motion), an
    array ``(M, 2)`` or ``(M, K + 1)``, or a CSV file (a path, or a string ending in
    ``.csv``: :func:`read_weight_curve`).

    Returns
    -------
    ndarray, shape (M, 2) or (M, K + 1)
        Rows ``(u, s)`` or ``(u, w_1, ..., w_K)`` (each of the latter rescaled to sum to 1).

    Raises
    ------
    OptionError
        Not defined on [0, 1] (first ``u`` not 0, last not 1, not increasing), a weight ``s``
        outside [0, 1], weights ``w_k`` negative or not summing to 1 (within 1e-6), fewer
        than two knots, a malformed string (a file's errors name it and the line).
    """
    if isinstance(value, os.PathLike) or (isinstance(value, str) and value.strip().lower().endswith(".csv")):
        return read_weight_curve(value)
    if isinstance(value, str):
        arr = _parse_keys(value)
    else:
        arr = np.asarray(value, dtype=np.float64)
        if arr.ndim != 2 or arr.shape[1] < 2:
            raise OptionError(
                "weight_curve",
                f"expected knots (u, s) of shape (M, 2) or (u, w_1, ..., w_K) of shape (M, K + 1); "
                f"got shape {arr.shape}",
            )
    return _check_knots(arr)


def _parse_keys(value: str) -> np.ndarray:
    """``"u:s,..."`` or ``"u:w1/.../wK,..."`` as an array (rows of one width)."""
    try:
        rows = []
        for item in (x for x in value.split(",") if x.strip()):
            u, ws = item.split(":")
            rows.append([float(u)] + [float(x) for x in ws.split("/")])
        arr = np.array(rows, dtype=np.float64)
    except ValueError:
        arr = np.zeros((0, 1))
    if arr.ndim != 2 or arr.shape[1] < 2:
        raise OptionError(
            "weight_curve",
            f"expected knots 'u:s,u:s,...' like '0:0,1:1' or 'u:w1/w2/.../wK,...' like "
            f"'0:1/0/0,1:0/0.5/0.5' (the same number of weights in every knot); got {value!r}",
        )
    return arr


def _check_knots(arr: np.ndarray, where: str = "") -> np.ndarray:
    """The knots checked (``where``, e.g. ``"file.csv: "``, starts the errors' messages)."""
    if arr.shape[0] < 2 or not np.isfinite(arr).all():
        raise OptionError(
            "weight_curve", f"{where}expected at least two finite knots (u, s); got {arr.tolist()}"
        )
    u, w = arr[:, 0], arr[:, 1:]
    if abs(u[0]) > 1e-12 or abs(u[-1] - 1.0) > 1e-12 or not (np.diff(u) > 0).all():
        raise OptionError(
            "weight_curve",
            f"{where}expected a curve defined on [0, 1]: times u from 0 to 1, increasing; "
            f"got u = {u.tolist()}",
        )
    if w.shape[1] == 1:
        if (w < 0).any() or (w > 1).any():
            raise OptionError(
                "weight_curve", f"{where}expected weights s in [0, 1]; got s = {w[:, 0].tolist()}"
            )
        return arr
    sums = w.sum(axis=1)
    if (w < 0).any() or np.abs(sums - 1.0).max() > 1e-6:
        bad = int(np.argmax((w < 0).any(axis=1) | (np.abs(sums - 1.0) > 1e-6)))
        raise OptionError(
            "weight_curve",
            f"{where}expected weights w_k >= 0 summing to 1 at every knot; knot {bad} (u = {u[bad]:g}) has "
            f"{w[bad].tolist()} (sum {sums[bad]:.9g})",
        )
    return np.column_stack([u, w / sums[:, None]])


def read_weight_curve(path: str | os.PathLike) -> np.ndarray:
    """Knots ``(M, K + 1)`` of a weight curve from a CSV file: a header ``u,<name 1>,...,<name
    K>`` (the first column named ``u``), then one knot per line, ``u,w_1,...,w_K``; blank
    lines and lines starting with ``#`` are skipped. Checked as :func:`parse_weight_curve`.

    Raises
    ------
    OptionError
        Naming ``file:line``: a missing header, a row of another width or not numbers; the
        knots' errors (:func:`parse_weight_curve`) name the file.
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as exc:
        raise OptionError("weight_curve", f"{p}: cannot read the weight curve ({exc.strerror})") from exc
    rows: list[list[float]] = []
    width = 0
    for no, line in enumerate(text.splitlines(), start=1):
        cells = [c.strip() for c in line.split(",")]
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        if not width:
            if cells[0].lower() != "u" or len(cells) < 3:
                raise OptionError(
                    "weight_curve",
                    f"{p}:{no}: expected a header 'u,w1,...,wK' (u, then one column per motion, K >= 2); "
                    f"got {line.strip()!r}",
                )
            width = len(cells)
            continue
        try:
            row = [float(c) for c in cells]
        except ValueError:
            row = []
        if len(row) != width:
            raise OptionError(
                "weight_curve",
                f"{p}:{no}: expected {width} numbers (u and {width - 1} weights, as the header); "
                f"got {line.strip()!r}",
            )
        rows.append(row)
    if not width:
        raise OptionError("weight_curve", f"{p}:1: expected a header 'u,w1,...,wK'; the file is empty")
    return _check_knots(np.array(rows, dtype=np.float64).reshape(-1, width), f"{p}: ")


def knot_weights(knots: np.ndarray) -> np.ndarray:
    """Knots ``(M, K + 1)`` ``(u, w_1, ..., w_K)`` from :func:`parse_weight_curve`'s: two
    motions' ``(u, s)`` become ``(u, 1 - s, s)``; the others are returned as they are."""
    knots = np.asarray(knots, dtype=np.float64)
    if knots.shape[1] == 2:
        return np.column_stack([knots[:, 0], 1.0 - knots[:, 1], knots[:, 1]])
    return knots
