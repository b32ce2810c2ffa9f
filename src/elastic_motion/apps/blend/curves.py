"""Stage 4 of a blend: the curves blended, on the curves of all non-finger joints at the full
frame rate, sampled at the output clock.

* ``"lie"`` and ``"euler-elastic"``: the SRV geodesic, ``R^{-1}((1 - s) qA + s (qB * phi))``
  started at the blended start point (paper 000, eq. 20;
  :func:`elastic_motion.curves.weighted_blend`; several motions: the weighted mean of their
  SRVs on the template's warps).
* ``"euler-linear"``: ``(1 - s) cA(u) + s cB(phi(u))``, the inputs' weighted mean at the
  matched times (paper 001 Fig. 5 (a) with a warp or without).
* A weight curve (:mod:`elastic_motion.apps.blend.transitions`): the same at the weights
  ``w_k(u)`` of each output frame, ``R^{-1}(sum_k w_k(u) (q_k * phi_k)(u))`` from the start
  weighted at ``w(0)`` (``weighted_blend`` with knots), or the inputs' mean at those weights.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from elastic_motion.apps.align import motion_curves
from elastic_motion.apps.blend.inputs import BlendInputs
from elastic_motion.apps.blend.sampling import frame_weight
from elastic_motion.apps.blend.timing import Clock
from elastic_motion.apps.blend.warps import IDENTITY_WARP, Warps
from elastic_motion.apps.blend_options import BlendOptions
from elastic_motion.curves import DiscreteCurve, weighted_blend

__all__ = ["BlendedCurve", "blend_curves", "inputs_mean"]


@dataclass(frozen=True, eq=False)
class BlendedCurve:
    """The blend as a curve, and the inputs' curves it came from.

    Attributes
    ----------
    curve : DiscreteCurve
        One point per output frame, in the method's representation.
    inputs : tuple of DiscreteCurve
        The inputs' full-rate curves (the pose anchoring of ``"euler-elastic"`` reads them).
    """

    curve: DiscreteCurve
    inputs: tuple[DiscreteCurve, ...]


def inputs_mean(curves: Sequence[DiscreteCurve], w: np.ndarray, local_u: Sequence[np.ndarray]) -> np.ndarray:
    """The inputs' weighted mean at the matched times in ``R^d``, ``(F, d)``: the
    ``"euler-linear"`` blend, and the pose the Euler elastic blend is anchored to. ``w``: the
    weights ``(K,)`` or per output frame ``(F, K)``."""
    n = local_u[0].shape[0]
    return sum(
        frame_weight(w, k, n, 1) * c.evaluate(lu)
        for k, (c, lu) in enumerate(zip(curves, local_u, strict=True))
    )


def blend_curves(inputs: BlendInputs, warps: Warps, clock: Clock, options: BlendOptions) -> BlendedCurve:
    """Stage 4 (module docstring)."""
    full = tuple(motion_curves(inputs.prepared, options.method))
    if options.method == "euler-linear":
        curve = DiscreteCurve(inputs_mean(full, clock.weights, clock.local_u), full[0].group)
    else:
        phis = [None if v is IDENTITY_WARP else v for v in warps.vertices]
        blended = weighted_blend(full, inputs.weights if inputs.knots is None else inputs.knots, phis)
        curve = DiscreteCurve(blended.evaluate(clock.u), blended.group)
    return BlendedCurve(curve, full)
