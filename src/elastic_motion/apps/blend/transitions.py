"""Time-varying weights: a transition from A into B (``weight_curve``, two motions; paper 000
sec. 5.3).

``s(u)`` is piecewise linear in the result's normalised time ``u`` (knots from
:func:`elastic_motion.apps.blend_options.parse_weight_curve`). The poses are the frame-wise
geodesics between ``cA(u)`` and ``cB(phi(u))`` at ``s(u)`` (a constant-weight SRV blend
integrates blended velocities from a blended start, which would not end on B's pose), the
root integrates the blended root velocities ``(1 - s) cA' + s (cB o phi)'`` from the
blended start, and the clock runs at ``dT/du = (1 - s(u)) d_A + s(u) d_B phi'(u)``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from elastic_motion.curves import DiscreteCurve
from elastic_motion.notes import Note

__all__ = ["NOTE_WEIGHT_CURVE", "transition_clock", "transition_curve", "weight_curve_note"]

#: The weight curve a transition was blended with.
NOTE_WEIGHT_CURVE = "blend.weight_curve"


def transition_clock(
    warps: Sequence[np.ndarray], knots: np.ndarray, durations: np.ndarray, fps: float
) -> np.ndarray:
    """Curve parameters ``(F,)`` of the output frames with a weight curve: the clock runs at
    ``dT/du = (1 - s(u)) d_A + s(u) d_B phi'(u)``, sampled at ``fps``."""
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


def transition_curve(
    curves: Sequence[DiscreteCurve], phi: np.ndarray, knots: np.ndarray, u: np.ndarray
) -> DiscreteCurve:
    """A transition at weights ``s(u)``: poses by frame-wise geodesics between ``cA(u)`` and
    ``cB(phi(u))``, the root (the first three coordinates) by integrating the blended root
    velocities ``(1 - s) cA' + s (cB o phi)'`` from the blended start; one point per ``u``."""
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


def weight_curve_note(knots: np.ndarray) -> Note:
    """The note of a transition: its knots and how it was blended."""
    return Note(
        NOTE_WEIGHT_CURVE,
        "weight curve: s(u) = " + ", ".join(f"{a:g}:{b:g}" for a, b in knots) + " (u: normalised time); "
        "poses interpolated frame by frame at s(u), root velocities blended at s(u)",
        {"knots": knots.tolist()},
    )
