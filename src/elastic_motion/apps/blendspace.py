"""Blend spaces: N >= 3 motions placed by a parameter (e.g. walk, jog, run by speed), all
aligned to a common template once, so that any parameter gives a consistent motion.

Paper 000, sec. 5.3 (future work). What happens:

1. :func:`elastic_motion.apps.prepare.prepare_motions` prepares the motions together (the
   first one sets the frame rate and placement). They must share one skeleton (the same
   joint names in the same order): a blend space of different skeletons is refused.
2. **Parameters**: given (one number per motion), or ``"speed"``: the mean horizontal speed
   of the root (m/s) of each prepared motion. They must differ.
3. **One alignment**: the Karcher mean of the motions' curves
   (:func:`elastic_motion.apps.statistics.karcher_mean`, equal weights, DP) is the common
   template; its warps ``phi_k`` (template parameter -> motion ``k``'s) are kept.
4. **Any parameter** ``p`` (:meth:`BlendSpace.at`): the motions sorted by parameter, ``p``
   between neighbours ``p_i <= p <= p_{i+1}`` gets weights ``(1 - t, t)`` on them
   (``t = (p - p_i) / (p_{i+1} - p_i)``, 0 elsewhere; for ``"speed"``, ``t`` is then found by
   bisection so that the blend's root speed is ``p``); the blend is
   :func:`elastic_motion.apps.blend.blend_motions` with these weights and the template's
   warps. Every parameter uses the same warps, so neighbouring parameters give neighbouring
   motions (the template's timing), and a motion's own parameter gives that motion at the
   template's timing. ``p`` outside the range is refused.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from elastic_motion._options import with_overrides
from elastic_motion.apps.align import motion_curves
from elastic_motion.apps.blend import BlendResult, blend_motions
from elastic_motion.apps.blend_options import BlendOptions
from elastic_motion.apps.cycles import gait_cycles
from elastic_motion.apps.metrics import blend_metrics
from elastic_motion.apps.prepare import PreparedMotions, Source, prepare_motions
from elastic_motion.apps.statistics import karcher_mean
from elastic_motion.errors import OptionError
from elastic_motion.motion import Motion, trim
from elastic_motion.motion.edit import heading_angle
from elastic_motion.notes import Note
from elastic_motion.warp import WarpOptions

__all__ = [
    "NOTE_ONE_CYCLE",
    "NOTE_TEMPLATE",
    "BlendSpace",
    "blendspace",
    "common_template",
    "motion_speed",
    "motion_turning_rate",
    "prepare_space",
]

#: The gait cycle kept of a motion (``one_cycle=True``), or why it was kept whole.
NOTE_ONE_CYCLE = "blendspace.one_cycle"
#: The common template: the Karcher mean's iterations and convergence.
NOTE_TEMPLATE = "blendspace.template"
#: Options of the blends that a blend space sets itself: its warps are the template's, its
#: weights come from the parameter.
_NOT_IN_A_SPACE = ("landmarks", "weight_curve")


def motion_speed(motion: Motion) -> float:
    """Mean horizontal speed of the root, m/s (the motion's unit per second if unknown)."""
    up = "xyz".index(motion.up_axis)
    p = np.array(motion.root_translation, dtype=np.float64)
    p[:, up] = 0.0
    scale = motion.metres_per_unit or 1.0
    if motion.n_frames < 2:
        return 0.0
    return float(np.linalg.norm(p[-1] - p[0]) * scale / motion.duration)


def motion_turning_rate(motion: Motion) -> float:
    """Mean turning rate of the root about the up axis, degrees per second: the change of its
    heading (:func:`elastic_motion.motion.edit.heading_angle`, unwrapped frame to frame) from
    the first frame to the last over the duration. Positive: counter-clockwise seen from
    above (a right-handed turn about the up axis: a left turn)."""
    if motion.n_frames < 2:
        return 0.0
    heading = np.unwrap(heading_angle(motion.rotations[:, 0], "xyz".index(motion.up_axis)))
    return float(np.degrees(heading[-1] - heading[0]) / motion.duration)


@dataclass(frozen=True, eq=False)
class BlendSpace:
    """Motions placed by a parameter and aligned to a common template (:func:`blendspace`).

    Attributes
    ----------
    prepared : PreparedMotions
        The motions, sorted by parameter.
    params : ndarray, shape (N,)
        Increasing.
    param_name : str
    warps : tuple of ndarray
        ``phi_k``: template parameter -> motion ``k``'s (vertices).
    options : BlendOptions
        The options of every blend of the space (``prepare`` None: the motions are prepared).
    notes : tuple of Note
    """

    prepared: PreparedMotions
    params: np.ndarray
    param_name: str
    warps: tuple[np.ndarray, ...]
    options: BlendOptions = field(default_factory=BlendOptions)
    notes: tuple[Note, ...] = field(default=())

    @property
    def method(self) -> str:
        """The blends' curve method."""
        return self.options.method

    @property
    def anchor(self) -> bool:
        """Whether the blends are pose-anchored."""
        return self.options.anchor

    def weights(self, p: float) -> np.ndarray:
        """Weights ``(N,)`` of parameter ``p`` (module docstring, step 4)."""
        x = self.params
        p = float(p)
        if not np.isfinite(p) or p < x[0] - 1e-12 or p > x[-1] + 1e-12:
            raise OptionError(
                "at", f"expected a parameter in [{x[0]:g}, {x[-1]:g}] ({self.param_name}); got {p:g}"
            )
        i = int(np.clip(np.searchsorted(x, p, side="right") - 1, 0, len(x) - 2))
        t = (p - x[i]) / (x[i + 1] - x[i])
        w = np.zeros(len(x))
        w[i], w[i + 1] = 1.0 - t, t
        return w

    def at(self, p: float, *, metrics: bool = False) -> BlendResult:
        """The motion at parameter ``p`` (:func:`~elastic_motion.apps.blend.blend_motions`
        with the template's warps). For ``params="speed"`` the weight between the two
        neighbours is found by bisection so that the blend's root speed is ``p`` (the speed of
        a blend is not linear in its weight, its clock is blended too; the frame count and
        the clean-up make it jump by a few per cent, so ``p`` is met to about 3 %)."""
        w = self.weights(p)
        if self.param_name == "speed_m_s" and 0 < w.max() < 1:
            w, met = self._speed_weights(float(p), w)
            if met is not None:  # the bisection's last blend is the answer: not blended again
                if metrics:
                    met = replace(met, metrics=blend_metrics(met.motion, met.prepared, met.weights))
                return met
        return self._blend(w, metrics=metrics)

    def _blend(self, w: np.ndarray, *, metrics: bool = False) -> BlendResult:
        """The blend of weights ``w`` ``(N,)`` on the template's warps, with this space's options."""
        return blend_motions(
            self.prepared, w, options=self.options, template_warps=self.warps, metrics=metrics
        )

    def _speed_weights(self, p: float, w: np.ndarray) -> tuple[np.ndarray, BlendResult | None]:
        """The weights between the two neighbours in ``w`` whose blend moves at ``p`` m/s, and
        that blend when the bisection met ``p`` (None when it ran out of steps)."""
        i = int(np.flatnonzero(w > 0)[0])
        lo, hi = 0.0, 1.0
        t = w[i + 1] if i + 1 < len(w) else 0.0
        for _ in range(12):
            trial = np.zeros_like(w)
            trial[i], trial[i + 1] = 1.0 - t, t
            res = self._blend(trial)
            v = motion_speed(res.motion)
            if abs(v - p) <= 0.005 * p:
                return trial, res
            lo, hi = (t, hi) if v < p else (lo, t)
            t = 0.5 * (lo + hi)
        out = np.zeros_like(w)
        out[i], out[i + 1] = 1.0 - t, t
        return out, None

    def summary(self) -> dict[str, Any]:
        """JSON-ready."""
        return {
            "param": self.param_name,
            "motions": list(self.prepared.labels),
            "params": self.params.tolist(),
            "method": self.method,
            "anchor": self.anchor,
            "template_warps": [v.tolist() for v in self.warps],
            "notes": [str(n) for n in self.notes],
        }


def blendspace(
    motions: Sequence[Source],
    params: str | Sequence[float] = "speed",
    options: BlendOptions | None = None,
    *,
    one_cycle: bool = False,
    **overrides: Any,
) -> BlendSpace:
    """Build a blend space (module docstring).

    Parameters
    ----------
    motions : sequence of path or Motion
        ``N >= 3`` motions of one skeleton.
    params : "speed" or sequence of float
        One parameter per motion, all different, or ``"speed"`` (m/s of the root).
    options : BlendOptions, optional
        The options of every blend of the space (:func:`~elastic_motion.apps.blend.blend_motions`:
        ``method``, ``contacts``, ``anchor``, ...); its ``prepare`` prepares the motions
        together, once. No ``landmarks``, ``weight_curve``, ``cycles`` or ``loop``: the space's
        warps are the template's.
    one_cycle : bool, default False
        Keep one gait cycle of each motion (:func:`elastic_motion.apps.cycles.gait_cycles`:
        the cycle whose duration is the clip's median, from heel strike to heel strike of the
        same foot); a motion without a full cycle is kept whole (a note says so).
    **overrides
        Fields of :class:`~elastic_motion.apps.blend_options.BlendOptions` changed from
        ``options`` (``method="euler-elastic"``, ``contacts="off"``, ``anchor=False``, ...).

    Returns
    -------
    BlendSpace

    Raises
    ------
    OptionError
        Fewer than 3 motions, different skeletons, parameters not one per motion or not all
        different, options a blend space sets itself.
    """
    prep, opts, notes = prepare_space(motions, options, one_cycle, overrides)
    x, name = _parameters(params, prep, len(prep.motions))
    order = np.argsort(x, kind="stable")
    if (np.diff(x[order]) <= 1e-9 * max(1.0, np.abs(x).max())).any():
        raise OptionError("params", f"expected different parameters for the motions; got {x.tolist()}")
    sorted_prep = dataclasses.replace(
        prep,
        motions=tuple(prep.motions[i] for i in order),
        labels=tuple(prep.labels[i] for i in order),
        inputs=tuple(prep.inputs[i] for i in order) if prep.inputs else prep.inputs,
    )
    warps, template = common_template(sorted_prep, opts.method)
    return BlendSpace(
        prepared=sorted_prep,
        params=x[order],
        param_name=name,
        warps=warps,
        options=opts.replace(prepare=None),
        notes=(*notes, template),
    )


def common_template(prep: PreparedMotions, method: str) -> tuple[tuple[np.ndarray, ...], Note]:
    """The warps ``phi_k`` (template parameter -> motion ``k``'s) of the prepared motions onto
    their Karcher mean (equal weights, DP; module docstring, step 3), and a note."""
    warp = WarpOptions(method="dp")
    coarse = motion_curves(prep, method, fps=warp.sample_fps, smoothing=warp.sample_smoothing)
    n = max(c.n_points for c in coarse) - 1
    km = karcher_mean(coarse, n_samples=n, warp=warp)
    template = Note(
        NOTE_TEMPLATE,
        f"one alignment: Karcher mean template of {len(prep.motions)} motions, {km.iterations} "
        f"iterations, {'converged' if km.converged else 'not converged'}",
    )
    return tuple(np.asarray(v) for v in km.warps), template


def prepare_space(
    motions: Sequence[Source], options: BlendOptions | None, one_cycle: bool, overrides: dict[str, Any]
) -> tuple[PreparedMotions, BlendOptions, tuple[Note, ...]]:
    """The motions of a blend space prepared together (one skeleton; one gait cycle each when
    asked), the space's options checked, and the notes (module docstring, step 1)."""
    opts = _space_options(with_overrides(BlendOptions, options, overrides))
    motions = list(motions)
    if len(motions) < 3:
        raise OptionError("motions", f"expected at least 3 motions for a blend space; got {len(motions)}")
    prep = prepare_motions(motions, opts.prepare)
    _check_one_skeleton(prep)
    extra_notes: tuple[Note, ...] = ()
    if one_cycle:
        prep, extra_notes = _one_cycle_each(prep)
    return prep, opts, (*tuple(prep.notes), *extra_notes)


def _space_options(opts: BlendOptions) -> BlendOptions:
    """``opts``, refused when it sets what a blend space sets itself."""
    for name in _NOT_IN_A_SPACE:
        if getattr(opts, name) is not None:
            raise OptionError(
                name,
                f"expected none in a blend space (its warps are the template's); got {getattr(opts, name)!r}",
            )
    if opts.matches_cycles:
        raise OptionError("cycles", "expected no cycles or loop in a blend space (use one_cycle=True)")
    return opts


def _check_one_skeleton(prep: PreparedMotions) -> None:
    """Refuse motions of different skeletons (not the same joints in the same order)."""
    names = [m.skeleton.names for m in prep.motions]
    for lab, n in zip(prep.labels[1:], names[1:], strict=True):
        if n != names[0]:
            diff = sorted(set(n) ^ set(names[0]))[:6]
            raise OptionError(
                "motions",
                f"expected motions of one skeleton (the same joints); {lab} differs from {prep.labels[0]}"
                + (f" in {diff}" if diff else " in the joint order"),
            )


def _parameters(params: str | Sequence[float], prep: PreparedMotions, k: int) -> tuple[np.ndarray, str]:
    """The motions' parameters ``(N,)`` (given, or their root speeds) and their name."""
    if isinstance(params, str):
        if params != "speed":
            raise OptionError("params", f"expected 'speed' or one number per motion; got {params!r}")
        return np.array([motion_speed(m) for m in prep.motions]), "speed_m_s"
    x = np.asarray(params, dtype=np.float64).reshape(-1)
    if x.shape != (k,) or not np.isfinite(x).all():
        raise OptionError("params", f"expected {k} finite numbers (one per motion); got {list(params)}")
    return x, "param"


def _one_cycle_each(prep: PreparedMotions) -> tuple[PreparedMotions, tuple[Note, ...]]:
    out, notes = [], []
    first = gait_cycles(prep.motions[0])
    for lab, m in zip(prep.labels, prep.motions, strict=True):
        c = gait_cycles(m, foot=first.foot or None)
        if not c.n_cycles:
            c = gait_cycles(m)
        if not c.n_cycles:
            notes.append(
                Note(NOTE_ONE_CYCLE, f"{lab}: no full gait cycle (a foot must strike twice); kept whole")
            )
            out.append(m)
            continue
        d = np.diff(c.strikes)
        i = int(np.argsort(d)[len(d) // 2])
        a, b = c.cycle(i)
        out.append(trim(m, a, b))
        notes.append(
            Note(
                NOTE_ONE_CYCLE,
                f"{lab}: one gait cycle kept, {c.foot} heel strikes {a:.2f}-{b:.2f} s "
                f"(cycle {i + 1} of {c.n_cycles})",
            )
        )
    return dataclasses.replace(prep, motions=tuple(out)), tuple(notes)
