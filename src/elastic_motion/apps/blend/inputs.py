"""Stage 1 of a blend: the inputs prepared, the weights checked, and with ``cycles`` (or
``loop``) the gait cycles of A and B matched and both clips cut to the matched spans.

Preparation is :func:`elastic_motion.apps.prepare.prepare_motions` (the one preparation step
of every app); the cycles are :mod:`elastic_motion.apps.cycles`. The matched cycles give the
warp its landmarks (every inner cycle boundary and step), met with a relative landmark weight
of at least :data:`elastic_motion.apps.align.AUTO_LANDMARK_WEIGHT`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from elastic_motion.apps.align import AUTO_LANDMARK_WEIGHT
from elastic_motion.apps.blend_options import BlendOptions, knot_weights
from elastic_motion.apps.prepare import PreparedMotions, Source, prepare_motions
from elastic_motion.errors import OptionError
from elastic_motion.motion import trim
from elastic_motion.motion.contacts import ContactOptions
from elastic_motion.notes import Note
from elastic_motion.warp import WarpOptions

if TYPE_CHECKING:  # the cycles app is imported only by a blend that matches cycles
    from elastic_motion.apps.cycles import CycleMatch

__all__ = ["NOTE_CYCLES", "BlendInputs", "check_weights", "match_cycle_spans", "prepare_inputs"]

#: How the gait cycles were matched, or why they could not be (``cycles=True``, ``loop=True``).
NOTE_CYCLES = "blend.cycles"


@dataclass(frozen=True, eq=False)
class BlendInputs:
    """The prepared inputs of a blend and what the later stages take from the options.

    Attributes
    ----------
    prepared : PreparedMotions
        The inputs after preparation (cut to the matched cycles with ``cycles``).
    weights : ndarray, shape (K,)
        One weight per input, summing to 1 (a weight curve's mean over the normalised time).
    knots : ndarray, shape (M, K + 1), or None
        The weight curve's knots ``(u, w_1, ..., w_K)``; None for constant weights.
    landmarks : Any
        What the warp meets: the options' landmarks, or the matched cycles' pairs (s).
    warp : WarpOptions
        The options' warp; with matched cycles at least ``"dp"`` and the landmark weight
        raised to :data:`~elastic_motion.apps.align.AUTO_LANDMARK_WEIGHT`.
    cycles : CycleMatch or None
        The matched cycles (``cycles`` or ``loop``), else None.
    notes : tuple of Note
        The preparation's notes and the cycles' note.
    """

    prepared: PreparedMotions
    weights: np.ndarray
    knots: np.ndarray | None
    landmarks: Any
    warp: WarpOptions
    cycles: CycleMatch | None
    notes: tuple[Note, ...]

    @property
    def durations(self) -> np.ndarray:
        """``(K,)`` the prepared inputs' durations (s)."""
        return np.array([m.duration for m in self.prepared.motions])


def check_weights(weights: Any, k: int, extrapolate: bool) -> np.ndarray:
    """The weights ``(K,)`` of ``k`` motions from ``s`` (two motions), one weight per motion
    or None (equal weights).

    Raises
    ------
    OptionError
        Not one per motion, not finite, not summing to 1, outside ``[0, 1]`` (without
        ``extrapolate``; never for three motions or more).
    """
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


def _weights_and_knots(weights: Any, k: int, options: BlendOptions) -> tuple[np.ndarray, np.ndarray | None]:
    """The weights ``(K,)`` (a weight curve's: their means over the normalised time) and the
    weight curve's knots ``(M, K + 1)`` (or None) of ``k`` motions."""
    if options.weight_curve is None:
        return check_weights(weights, k, options.extrapolate), None
    knots = knot_weights(np.array(options.weight_curve))
    if knots.shape[1] != k + 1:
        given = (
            "(u, s): two motions" if len(options.weight_curve[0]) == 2 else f"{knots.shape[1] - 1} weights"
        )
        raise OptionError(
            "weight_curve", f"expected knots with one weight per motion ({k}); got knots {given}"
        )
    mean = np.trapezoid(knots[:, 1:], knots[:, 0], axis=0)
    return check_weights(mean / mean.sum(), k, options.extrapolate), knots


def prepare_inputs(
    motions: Sequence[Source] | PreparedMotions, weights: Any, options: BlendOptions
) -> BlendInputs:
    """Stage 1 (module docstring): prepare, check the weights, match the cycles when asked.

    Raises
    ------
    ValueError
        Fewer than 2 motions.
    OptionError
        Weights and a weight curve both; weights (:func:`check_weights`); a weight curve not
        of one weight per motion; landmarks or cycles with more than two motions.
    """
    if options.weight_curve is not None and weights is not None:
        raise OptionError("weight_curve", "expected weights or a weight curve, not both")
    if not isinstance(motions, PreparedMotions):
        motions = list(motions)
    k = len(motions.motions) if isinstance(motions, PreparedMotions) else len(motions)
    if k < 2:
        raise ValueError(f"motions: expected at least 2 motions to blend; got {k}")
    w, knots = _weights_and_knots(weights, k, options)
    if options.landmarks is not None and k != 2:
        raise OptionError("landmarks", f"expected two motions (landmarks pair A with B); got {k} motions")
    prep = prepare_motions(motions, options.prepare)
    notes = tuple(prep.notes)
    landmarks, warp, match = options.landmarks, options.warp, None
    if options.matches_cycles:
        if k != 2:
            raise OptionError("cycles", f"expected two motions (cycles of A against cycles of B); got {k}")
        prep, match = match_cycle_spans(prep, options.contact_options, 1 if options.loop else None)
        notes += (Note(NOTE_CYCLES, "cycles: " + match.why, {"matched_cycles": match.n}),)
        if match.n:
            landmarks = list(match.landmarks)
            if warp.method == "none":
                warp = warp.replace(method="dp")
            warp = warp.replace(landmark_weight=max(warp.landmark_weight, AUTO_LANDMARK_WEIGHT))
    return BlendInputs(prep, w, knots, landmarks, warp, match, notes)


def match_cycle_spans(
    prep: PreparedMotions, options: ContactOptions, max_cycles: int | None
) -> tuple[PreparedMotions, CycleMatch]:
    """Match the gait cycles of the two prepared motions and keep the matched spans; B is
    moved on the floor so that its span starts where A's does. The inputs unchanged (and
    ``n == 0``) when the cycles cannot be matched."""
    # local: only a blend with cycles (or a loop) needs the cycles app (CLI start-up)
    from elastic_motion.apps.cycles import gait_cycles, match_cycles

    ma, mb = prep.motions
    ca = gait_cycles(ma, options)
    cb = gait_cycles(mb, options, foot=ca.foot or None)
    if ca.n_cycles and not cb.n_cycles:
        other = "right" if ca.foot == "left" else "left"
        ca2, cb2 = gait_cycles(ma, options, foot=other), gait_cycles(mb, options, foot=other)
        if ca2.n_cycles and cb2.n_cycles:
            ca, cb = ca2, cb2
    match = match_cycles(ca, cb, max_cycles=max_cycles)
    if not match.n and (ca.n_cycles or cb.n_cycles):
        # say per foot what each has: the cycles must be of one foot in both
        count = {
            f: (gait_cycles(ma, options, foot=f).n_cycles, gait_cycles(mb, options, foot=f).n_cycles)
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
