"""Time-varying weights (``weight_curve``; paper 000 sec. 5.3): ``K >= 2`` motions with weights
``w_k(u)`` piecewise linear in the result's normalised time ``u`` (knots from
:func:`elastic_motion.apps.blend_options.parse_weight_curve`, made ``(u, w_1, ..., w_K)`` by
:func:`elastic_motion.apps.blend_options.knot_weights`), blended in SRV space on the warps to
the common template: ``q(u) = sum_k w_k(u) (q_k * phi_k)(u)`` integrated from the weighted
start (:func:`elastic_motion.curves.weighted_blend` with knots). The clock runs at
``dT/du = sum_k w_k(u) d_k phi_k'(u)`` (:func:`weighted_clock`): constant weights give the
blended clock of :mod:`.timing`, ``w = e_k`` input ``k``'s own timing.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from elastic_motion.notes import Note

__all__ = ["NOTE_WEIGHT_CURVE", "frame_weights", "weight_curve_note", "weighted_clock"]

#: The weight curve a blend was made with.
NOTE_WEIGHT_CURVE = "blend.weight_curve"


def frame_weights(knots: np.ndarray, u: np.ndarray) -> np.ndarray:
    """The weights ``(F, K)`` at curve parameters ``u (F,)`` of knots ``(M, K + 1)``."""
    return np.column_stack([np.interp(u, knots[:, 0], knots[:, k]) for k in range(1, knots.shape[1])])


def weighted_clock(
    warps: Sequence[np.ndarray], knots: np.ndarray, durations: np.ndarray, fps: float
) -> np.ndarray:
    """Curve parameters ``(F,)`` of the output frames with time-varying weights (knots
    ``(M, K + 1)``): the clock runs at ``dT/du = sum_k w_k(u) d_k phi_k'(u)``, sampled at
    ``fps``."""
    x = np.unique(np.concatenate([v[:, 0] for v in warps] + [knots[:, 0], np.linspace(0.0, 1.0, 1025)]))
    mid = 0.5 * (x[1:] + x[:-1])
    w = frame_weights(knots, mid)
    rate = np.zeros_like(mid)
    for k, (v, dk) in enumerate(zip(warps, durations, strict=True)):
        rate += w[:, k] * dk * np.diff(np.interp(x, v[:, 0], v[:, 1])) / np.diff(x)
    total = np.concatenate([[0.0], np.cumsum(rate * np.diff(x))])
    n = math.floor(total[-1] * fps + 1e-6) + 1
    times = np.arange(n) / fps
    u = np.interp(times, total, x)
    u[0] = 0.0
    if abs(times[-1] - total[-1]) < 1e-6:
        u[-1] = 1.0
    return u


def weight_curve_note(given: np.ndarray) -> Note:
    """The note of a weight curve: its knots as given (``(u, s)`` or ``(u, w_1, ..., w_K)``)."""
    knots = ", ".join(f"{r[0]:g}:" + "/".join(f"{x:g}" for x in r[1:]) for r in given)
    what = "s(u)" if given.shape[1] == 2 else "w(u)"
    return Note(
        NOTE_WEIGHT_CURVE,
        f"weight curve: {what} = {knots} (u: normalised time); blended in SRV space at w(u), "
        "integrated from the weighted start",
        {"knots": given.tolist()},
    )
