"""Quality metrics of a blend (:func:`blend_metrics`): foot sliding, bone lengths and elastic
distances of the result and its inputs."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from elastic_motion.apps.distance import KnownDistances, distance_table
from elastic_motion.apps.metrics.bones import BoneLengthError, bone_length_error
from elastic_motion.apps.metrics.feet import FootSliding, foot_sliding
from elastic_motion.apps.metrics.floor import FootQuality, foot_quality
from elastic_motion.apps.prepare import PreparedMotions
from elastic_motion.errors import OptionError
from elastic_motion.motion import Motion
from elastic_motion.motion.contacts import ContactOptions

__all__ = ["BlendMetrics", "blend_metrics"]


@dataclass(frozen=True, eq=False)
class BlendMetrics:
    """Quality metrics of a blend (:func:`blend_metrics`), on the prepared inputs (metres).

    Attributes
    ----------
    labels : tuple of str
        The inputs' names.
    foot_sliding : FootSliding
        Of the result (:func:`elastic_motion.apps.metrics.foot_sliding`).
    foot_sliding_inputs : tuple of FootSliding
        Of each prepared input.
    bone_length_error : BoneLengthError
        Of the result against its own skeleton.
    bone_length_error_vs_inputs : tuple of BoneLengthError
        Of the result against each input's skeleton.
    distances_between_inputs : ndarray, shape (K, K)
        Lie elastic distances (``R^3 x SO(3)^J`` SRV on the inputs' curve joints with their
        shared weights, the optimal warp of ``WarpOptions()``: what a Lie blend's warp stage
        solves, so for a blend of two with that warp and no landmarks, its distance).
    distances_to_inputs : ndarray, shape (K,)
        From the result to each input, same metric (the result's curve on the inputs' joints
        and weights, where the blend put it: prepared like them already).
    geodesic_expected : ndarray, shape (2,) or (0,)
        Two inputs: ``(s d(A, B), (1 - s) d(A, B))``, what the SRV geodesic gives exactly.
    feet, feet_inputs : FootQuality, tuple of FootQuality
        The result and each input measured the same way, each on itself
        (:func:`elastic_motion.apps.metrics.floor.foot_quality`: its own contacts and their
        skating, skids, depth below the floor, swing clearance), with the same contact options.
    """

    labels: tuple[str, ...]
    foot_sliding: FootSliding
    foot_sliding_inputs: tuple[FootSliding, ...]
    bone_length_error: BoneLengthError
    bone_length_error_vs_inputs: tuple[BoneLengthError, ...]
    distances_between_inputs: np.ndarray
    distances_to_inputs: np.ndarray
    geodesic_expected: np.ndarray
    feet: FootQuality | None = None
    feet_inputs: tuple[FootQuality, ...] = ()

    def summary(self) -> dict[str, Any]:
        """JSON-ready scalars (speeds in m/s, distances in the Lie SRV metric)."""
        return {
            "foot_sliding": {
                "result": self.foot_sliding.summary(),
                "inputs": [f.summary() for f in self.foot_sliding_inputs],
            },
            "bone_length_error": {
                "result": self.bone_length_error.summary(),
                "vs_inputs": [b.summary() for b in self.bone_length_error_vs_inputs],
            },
            "feet": None
            if self.feet is None
            else {
                "measure": "each motion on itself: its own contacts (detect_contacts), their skating, "
                "skids (a foot point within 0.02 leg lengths of the floor, faster than 0.3 leg "
                "lengths/s, for 0.1 s)",
                "result": _feet_summary(self.feet),
                "inputs": [_feet_summary(q) for q in self.feet_inputs],
            },
            "distances": {
                "metric": "Lie elastic distance (R^3 x SO(3)^J SRV, optimal warp by DP), the inputs' "
                "curve joints and shared weights, the result as the blend placed it",
                "labels": list(self.labels),
                "between_inputs": self.distances_between_inputs.tolist(),
                "result_to_inputs": self.distances_to_inputs.tolist(),
                "geodesic_expected": self.geodesic_expected.tolist(),
            },
        }


def _feet_summary(q: FootQuality) -> dict[str, Any]:
    """A FootQuality's report without its contact intervals (the contacts are reported apart)."""
    return {k: v for k, v in q.summary().items() if k != "contacts"}


def blend_metrics(
    result: Motion,
    prepared: PreparedMotions,
    weights: np.ndarray,
    contact_options: ContactOptions | None = None,
    *,
    feet_inputs: Sequence[FootQuality] | None = None,
    feet: FootQuality | None = None,
    inputs_known: KnownDistances | None = None,
) -> BlendMetrics:
    """Quality metrics of a blend (module docstring): foot sliding, bone lengths, distances.

    Parameters
    ----------
    result : Motion
        The blend (:attr:`BlendResult.motion`).
    prepared : PreparedMotions
        Its prepared inputs (:attr:`BlendResult.prepared`).
    weights : ndarray, shape (K,)
    contact_options : ContactOptions, optional
        Of the feet measure (the blend's, default ``ContactOptions()``).
    feet_inputs : sequence of FootQuality, optional
        ``prepared.motions`` measured already, each ``foot_quality(m, contact_options)`` (the
        blend's contacts stage measures them): taken as they are, not measured again.
    feet : FootQuality, optional
        ``foot_quality(result, contact_options)``, when measured already (the clean-up's).
    inputs_known : KnownDistances, optional
        Of the inputs (K entries): the SRVs of their Lie curves and their distances as
        :func:`elastic_motion.apps.distance.distance_table` builds and solves them with
        ``WarpOptions()`` (a Lie blend's warp stage, when it met no landmarks): taken as they
        are. (The result is a new curve: its warps onto the inputs are solved.)

    Returns
    -------
    BlendMetrics
    """
    ms = prepared.motions
    k = len(ms)
    known = None
    if inputs_known is not None:
        n_srvs, shape = len(inputs_known.srvs), np.shape(inputs_known.distances)
        if n_srvs != k or (inputs_known.distances is not None and shape != (k, k)):
            raise OptionError(
                "inputs_known",
                f"expected the {k} inputs' SRVs and a ({k}, {k}) distance matrix; got {n_srvs} and {shape}",
            )
        solved = None
        if inputs_known.distances is not None:
            solved = np.full((k + 1, k + 1), np.nan)
            solved[:k, :k] = inputs_known.distances
        known = KnownDistances((*inputs_known.srvs, None), solved)
    table = distance_table(
        # the result beside its inputs, in their preparation (their joints, units, up axis,
        # placement and curve weights): the blend made it there, nothing to prepare again
        replace(prepared, motions=(*ms, result), labels=(*prepared.labels, "result")),
        known=known,
    )
    d = table.matrix
    expected = np.array([weights[1] * d[0, 1], weights[0] * d[0, 1]]) if k == 2 else np.zeros(0)
    if not feet_inputs:
        feet_inputs = [foot_quality(m, contact_options) for m in ms]
    return BlendMetrics(
        labels=tuple(prepared.labels),
        foot_sliding=foot_sliding(result),
        foot_sliding_inputs=tuple(foot_sliding(m) for m in ms),
        bone_length_error=bone_length_error(result),
        bone_length_error_vs_inputs=tuple(bone_length_error(result, m) for m in ms),
        distances_between_inputs=d[:k, :k].copy(),
        distances_to_inputs=d[k, :k].copy(),
        geodesic_expected=expected,
        feet=foot_quality(result, contact_options) if feet is None else feet,
        feet_inputs=tuple(feet_inputs),
    )
