"""Stage 3 of a blend: the output clock, the curve parameter ``u`` of every output frame.

The result is a curve on ``[0, 1]``; its parameter ``u`` is played at time
``T(u) = sum_k w_k d_k phi_k(u)``, the blended clock of the inputs (``d``: durations), and
sampled at A's frame rate (:func:`blended_clock`). So ``s = 0`` gives A and ``s = 1`` gives
B, each at its own timing. If extrapolation makes ``T`` decrease somewhere, its rate is held
there at :data:`CLOCK_FLOOR` of the mean rate and the clock rescaled to the blended duration;
a note says so. A weight curve runs its own clock
(:func:`elastic_motion.apps.blend.transitions.weighted_clock`).

**Trimmed ends** (``trim_ends=True``, the default; :func:`held_ends`): where the warp holds an
input still while another moves on, at a clip's start or end, the inputs are not in the same
phase there (a pause against a step: Bandai walks start and stop out of phase, the DP's
steepest slope then plays one input at 0.18 of the other's rate for a third of a second), and
their blend is a step at half its length: a foot sliding along the floor. The output keeps the
span from the first to the last frame where every input runs at least :data:`HELD_RATE` of
the fastest one's rate (over :data:`RATE_WINDOW`), when that span holds at least
:data:`MIN_KEPT` of the frames; a note and the report say what was cut.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from elastic_motion.apps.blend.inputs import BlendInputs
from elastic_motion.apps.blend.transitions import frame_weights, weight_curve_note, weighted_clock
from elastic_motion.apps.blend.warps import Warps
from elastic_motion.apps.blend_options import BlendOptions
from elastic_motion.errors import OptionError
from elastic_motion.notes import Note

__all__ = [
    "CLOCK_FLOOR",
    "HELD_RATE",
    "MIN_KEPT",
    "NOTE_TIMING",
    "NOTE_TRIM",
    "RATE_WINDOW",
    "Clock",
    "blended_clock",
    "held_ends",
    "output_clock",
]

#: Where an extrapolated blend's clock would run backwards, its rate is held at this fraction
#: of the mean rate (:func:`blended_clock`).
CLOCK_FLOOR = 0.1
#: The blended clock held where extrapolation would run it backwards.
NOTE_TIMING = "blend.timing"
#: The output's ends trimmed where an input is held still (:func:`held_ends`).
NOTE_TRIM = "blend.trim_ends"
#: An input runs "held" when its clock rate is below this fraction of the fastest input's:
#: the DP's steepest slope is 1/10 (Bandai walk ends: 0.18 / 1.82 = 0.1); a walk matched to a
#: walk of another rhythm runs at 0.5-2x (CMU 07_01 x 08_02: 0.33-1.48 frame by frame).
HELD_RATE = 0.25
#: Seconds over which the rates are measured (a DP warp's slope changes from frame to frame).
RATE_WINDOW = 0.2
#: The trimmed output keeps at least this fraction of the frames (else nothing is trimmed: the
#: inputs then never move together for long, and a note says so).
MIN_KEPT = 0.5


@dataclass(frozen=True, eq=False)
class Clock:
    """When each output frame is, in the result's curve and in each input.

    Attributes
    ----------
    u : ndarray, shape (F,)
        Curve parameter of each output frame.
    local_u : tuple of ndarray, shape (F,)
        Each input's curve parameter ``phi_k(u)`` at the output frames (in ``[0, 1]``).
    times : tuple of ndarray, shape (F,)
        Each input's time (s) at the output frames.
    weights : ndarray, shape (K,) or (F, K)
        The weights of the inputs, per output frame with a weight curve.
    notes : tuple of Note
    trimmed : tuple of (int, int)
        Frames of the untrimmed clock cut at the start and at the end (``(0, 0)``: none).
    """

    u: np.ndarray
    local_u: tuple[np.ndarray, ...]
    times: tuple[np.ndarray, ...]
    weights: np.ndarray
    notes: tuple[Note, ...]
    trimmed: tuple[int, int] = (0, 0)


def blended_clock(
    warps: Sequence[np.ndarray], w: np.ndarray, durations: np.ndarray, fps: float
) -> tuple[np.ndarray, str]:
    """Curve parameters ``(F,)`` of the output frames (module docstring) and a note (empty if
    the clock increases everywhere).

    Raises
    ------
    OptionError
        The blended duration ``sum_k w_k d_k`` is not positive (extrapolation).
    """
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
        rate = np.maximum(np.diff(total) / dx, CLOCK_FLOOR * duration)
        held = float(dx[np.diff(total) <= 0].sum())  # where it runs backwards (the note's share)
        total = np.concatenate([[0.0], np.cumsum(rate * dx)])
        total *= duration / total[-1]
        note = (
            f"timing: the blended clock does not increase on {100 * held:.0f} % of the curve "
            f"(extrapolation); its rate is held at {CLOCK_FLOOR:g} of the mean there, the result lasts "
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


def held_ends(times: Sequence[np.ndarray], fps: float) -> tuple[int, int]:
    """Frames to cut at the start and at the end of an output clock (module docstring).

    Parameters
    ----------
    times : sequence of ndarray, shape (F,)
        Each input's time (s) at the output frames (inputs of weight 0 left out).
    fps : float
        The output's frame rate.

    Returns
    -------
    (int, int)
        Leading and trailing frames during which some input runs below :data:`HELD_RATE` of
        the fastest one; ``(0, 0)`` when the kept span would be under :data:`MIN_KEPT`.
    """
    t = np.stack(times)
    f = t.shape[1]
    half = max(1, round(0.5 * RATE_WINDOW * fps))
    if len(times) < 2 or f < 2 * half + 3:
        return 0, 0
    idx = np.arange(f)
    lo, hi = np.clip(idx - half, 0, f - 1), np.clip(idx + half, 0, f - 1)
    rate = (t[:, hi] - t[:, lo]) / ((hi - lo) / fps)  # input seconds per output second
    fastest = rate.max(axis=0)
    moving = rate.min(axis=0) >= HELD_RATE * np.where(fastest > 0, fastest, np.inf)
    if not moving.any():
        return 0, 0
    first, last = int(np.argmax(moving)), int(f - 1 - np.argmax(moving[::-1]))
    if last - first + 1 < MIN_KEPT * f:
        return 0, 0
    return first, f - 1 - last


def _trim(clock: Clock, fps: float) -> Clock:
    """The clock without its held ends (:func:`held_ends`), and a note when it cut any."""
    weights = np.asarray(clock.weights)
    moving = [t for t, w in zip(clock.times, weights, strict=True) if w > 0]
    head, tail = held_ends(moving, fps)
    if not (head or tail):
        return clock
    keep = slice(head, clock.u.shape[0] - tail)
    text = (
        f"ends trimmed: {head} frames ({head / fps:.2f} s) at the start and {tail} ({tail / fps:.2f} s) at "
        f"the end, where the warp holds an input still while another moves on (its clock under "
        f"{HELD_RATE:g} of the fastest input's; --no-trim-ends / trim_ends=False keeps them)"
    )
    note = Note(NOTE_TRIM, text, {"start_frames": head, "end_frames": tail, "fps": fps})
    return Clock(
        clock.u[keep],
        tuple(lu[keep] for lu in clock.local_u),
        tuple(t[keep] for t in clock.times),
        clock.weights,
        (*clock.notes, note),
        (head, tail),
    )


def output_clock(inputs: BlendInputs, warps: Warps, options: BlendOptions) -> Clock:
    """Stage 3 (module docstring): the blended clock, or the weight curve's; its held ends
    trimmed when asked (constant weights in ``[0, 1]``, no matched cycles: those are trimmed
    already)."""
    prep, durations, knots = inputs.prepared, inputs.durations, inputs.knots
    if knots is not None:
        u = weighted_clock(warps.vertices, knots, durations, prep.fps)
        notes: tuple[Note, ...] = (weight_curve_note(np.array(options.weight_curve)),)
    else:
        u, text = blended_clock(warps.vertices, inputs.weights, durations, prep.fps)
        notes = (Note(NOTE_TIMING, text),) if text else ()
    local_u = tuple(np.clip(np.interp(u, v[:, 0], v[:, 1]), 0.0, 1.0) for v in warps.vertices)
    weights = inputs.weights if knots is None else frame_weights(knots, u)
    times = tuple(lu * d for lu, d in zip(local_u, durations, strict=True))
    clock = Clock(u, local_u, times, weights, notes)
    w = inputs.weights
    trim = options.trim_ends and knots is None and inputs.cycles is None and bool(((w >= 0) & (w <= 1)).all())
    return _trim(clock, prep.fps) if trim else clock
