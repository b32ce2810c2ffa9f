"""Stage 3 of a blend: the output clock, the curve parameter ``u`` of every output frame.

The result is a curve on ``[0, 1]``; its parameter ``u`` is played at time
``T(u) = sum_k w_k d_k phi_k(u)``, the blended clock of the inputs (``d``: durations), and
sampled at A's frame rate (:func:`blended_clock`). So ``s = 0`` gives A and ``s = 1`` gives
B, each at its own timing. If extrapolation makes ``T`` decrease somewhere, its rate is held
there at :data:`CLOCK_FLOOR` of the mean rate and the clock rescaled to the blended duration;
a note says so. A weight curve runs its own clock
(:func:`elastic_motion.apps.blend.transitions.transition_clock`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from elastic_motion.apps.blend.inputs import BlendInputs
from elastic_motion.apps.blend.transitions import transition_clock, weight_curve_note
from elastic_motion.apps.blend.warps import Warps
from elastic_motion.errors import OptionError
from elastic_motion.notes import Note

__all__ = ["CLOCK_FLOOR", "NOTE_TIMING", "Clock", "blended_clock", "output_clock"]

#: Where an extrapolated blend's clock would run backwards, its rate is held at this fraction
#: of the mean rate (:func:`blended_clock`).
CLOCK_FLOOR = 0.1
#: The blended clock held where extrapolation would run it backwards.
NOTE_TIMING = "blend.timing"


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
    s : ndarray, shape (F,), or None
        The weight curve's ``s(u)`` at the output frames; None for constant weights.
    notes : tuple of Note
    """

    u: np.ndarray
    local_u: tuple[np.ndarray, ...]
    times: tuple[np.ndarray, ...]
    weights: np.ndarray
    s: np.ndarray | None
    notes: tuple[Note, ...]


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


def output_clock(inputs: BlendInputs, warps: Warps) -> Clock:
    """Stage 3 (module docstring): the blended clock, or the weight curve's."""
    prep, durations, knots = inputs.prepared, inputs.durations, inputs.knots
    if knots is not None:
        u = transition_clock(warps.vertices, knots, durations, prep.fps)
        notes: tuple[Note, ...] = (weight_curve_note(knots),)
    else:
        u, text = blended_clock(warps.vertices, inputs.weights, durations, prep.fps)
        notes = (Note(NOTE_TIMING, text),) if text else ()
    local_u = tuple(np.clip(np.interp(u, v[:, 0], v[:, 1]), 0.0, 1.0) for v in warps.vertices)
    s = None if knots is None else np.interp(u, knots[:, 0], knots[:, 1])
    frame_weights = inputs.weights if s is None else np.column_stack([1.0 - s, s])
    times = tuple(lu * d for lu, d in zip(local_u, durations, strict=True))
    return Clock(u, local_u, times, frame_weights, s, notes)
