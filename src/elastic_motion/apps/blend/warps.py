"""Stage 2 of a blend: the warps ``phi_k`` (the result's curve parameter -> input ``k``'s).

Three ways (package docstring, step 2): warps given (a blend space's template, computed
once); two motions: the warp of B onto A on the curves of the method at most
``warp.sample_fps`` frames per second, meeting the landmarks planned by
:func:`elastic_motion.apps.align.plan_landmarks` (``"auto"``: events paired by phase); three
or more: the weighted Karcher mean template (:func:`elastic_motion.apps.statistics.karcher_mean`).
Without a warp every ``phi_k`` is the identity.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from elastic_motion.apps.align import landmark_parameters, motion_curves, plan_landmarks, solve_warp
from elastic_motion.apps.blend.inputs import BlendInputs
from elastic_motion.apps.blend_options import BlendOptions
from elastic_motion.curves import DiscreteCurve, SRVFunction, srv_transform
from elastic_motion.errors import OptionError
from elastic_motion.notes import Note
from elastic_motion.vocabulary import GAIT_KINDS
from elastic_motion.warp import WarpOptions

__all__ = [
    "IDENTITY_WARP",
    "NOTE_LANDMARKS",
    "NOTE_WARP",
    "Warps",
    "contact_guided_warp",
    "find_warps",
    "pairing_notes",
]

#: The identity warp's vertices ``(2, 2)``; the curve blend skips the warping of an input whose
#: warp is this very array (``is``).
IDENTITY_WARP = np.array([[0.0, 0.0], [1.0, 1.0]])
#: How the warps were found: solved (with its distance), given, or the Karcher template.
NOTE_WARP = "blend.warp"
#: The landmarks the warp meets: from a file, or ``"auto"``'s pairing (pinned, dropped).
NOTE_LANDMARKS = "blend.landmarks"


@dataclass(frozen=True, eq=False)
class Warps:
    """The warps of a blend's inputs.

    Attributes
    ----------
    vertices : tuple of ndarray, shape (V, 2)
        ``phi_k`` per input (:data:`IDENTITY_WARP` where there is none).
    pairs : tuple of (float, float)
        Landmark pairs met, seconds in A and B.
    options : WarpOptions
        The options the warp was solved with (``"auto"`` landmarks raise the landmark weight).
    pairing : PhasePairing or None
        ``landmarks="auto"``: how the events were paired.
    notes : tuple of Note
    srvs : tuple of SRVFunction
        Two motions with a solved warp: the SRVs of A's and B's curves it was solved on (the
        method's, at most ``options.sample_fps``); empty otherwise.
    distance : float or None
        Two motions with a solved warp: ``||qA - qB * phi||`` (with landmarks, not the
        elastic distance); None otherwise.
    """

    vertices: tuple[np.ndarray, ...]
    pairs: tuple[tuple[float, float], ...]
    options: WarpOptions
    pairing: Any = None
    notes: tuple[Note, ...] = ()
    srvs: tuple[SRVFunction, ...] = ()
    distance: float | None = None


def find_warps(
    inputs: BlendInputs, options: BlendOptions, template_warps: Sequence[np.ndarray] | None = None
) -> Warps:
    """Stage 2 (module docstring).

    Raises
    ------
    OptionError
        ``template_warps`` not one per input.
    """
    k = len(inputs.prepared.motions)
    if template_warps is not None:
        if len(template_warps) != k:
            raise OptionError(
                "template_warps", f"expected {k} warps (one per motion); got {len(template_warps)}"
            )
        given = tuple(np.asarray(v, dtype=np.float64) for v in template_warps)
        return Warps(
            given, (), inputs.warp, None, (Note(NOTE_WARP, "warps: given (a common template computed once)"),)
        )
    if inputs.warp.method == "none":
        return Warps((IDENTITY_WARP,) * k, (), inputs.warp)
    opts = inputs.warp
    coarse = motion_curves(
        inputs.prepared, options.method, fps=opts.sample_fps, smoothing=opts.sample_smoothing
    )
    if k == 2:
        return pairwise_warp(coarse, inputs, options)
    return template_warp(coarse, inputs)


def pairwise_warp(coarse: Sequence[DiscreteCurve], inputs: BlendInputs, options: BlendOptions) -> Warps:
    """The warp of B onto A on their coarse curves, meeting the planned landmarks."""
    return _solve_pair(
        (srv_transform(coarse[0]), srv_transform(coarse[1])),
        inputs,
        inputs.landmarks,
        options.landmark_kinds,
        options.max_pairs,
    )


def contact_guided_warp(inputs: BlendInputs, plain: Warps) -> Warps:
    """The contact-guided warp of B onto A: the heel strikes and toe-offs of both feet
    (:data:`~elastic_motion.vocabulary.GAIT_KINDS`, from the one contact detector) paired by
    phase and met as ``landmarks="auto"`` meets them, with the ``plain`` warp (solved without
    landmarks on the same curves, :func:`pairwise_warp`) as the pairing's prior: no curve is
    sampled and no warp solved twice."""
    return _solve_pair(plain.srvs, inputs, "auto", GAIT_KINDS, None, prior=plain.vertices[1])


def _solve_pair(
    srvs: Sequence[SRVFunction],
    inputs: BlendInputs,
    landmarks: Any,
    kinds: Sequence[str] | None,
    max_pairs: int | None,
    prior: np.ndarray | None = None,
) -> Warps:
    prep = inputs.prepared
    ms, durations = prep.motions, inputs.durations
    sa, sb = srvs
    plan = plan_landmarks(
        landmarks,
        ms[0],
        ms[1],
        (sa, sb) if prior is None else prior,
        inputs.warp,
        kinds=kinds,
        max_pairs=max_pairs,
    )
    pairs, opts = plan.pairs, plan.options
    notes = list(plan.notes)
    if plan.pairing is not None:
        notes += pairing_notes(plan.pairing)
    theta = landmark_parameters(pairs, durations[0], durations[1], prep.labels[:2]) if pairs else None
    res = solve_warp(sa, sb, opts, landmarks=theta)
    notes.append(
        Note(
            NOTE_WARP,
            f"warp ({opts.method}) of {prep.labels[1]} onto {prep.labels[0]}: distance {res.distance:.4g}"
            + (f", {len(pairs)} landmark pairs" if pairs else ""),
            {"distance": float(res.distance), "landmark_pairs": len(pairs)},
        )
    )
    return Warps(
        (IDENTITY_WARP, np.asarray(res.vertices)),
        tuple(pairs),
        opts,
        plan.pairing,
        tuple(notes),
        srvs=(sa, sb),
        distance=float(res.distance),
    )


def template_warp(coarse: Sequence[DiscreteCurve], inputs: BlendInputs) -> Warps:
    """The warps of three or more inputs onto their weighted Karcher mean (aligned by DP: the
    template moves between iterations)."""
    # local: only a blend of three or more motions needs the statistics app (CLI start-up)
    from elastic_motion.apps.statistics import karcher_mean

    n = max(c.n_points for c in coarse) - 1
    km = karcher_mean(coarse, weights=inputs.weights, n_samples=n, warp=inputs.warp.replace(method="dp"))
    note = Note(
        NOTE_WARP,
        f"weighted Karcher mean template: {km.iterations} iterations, "
        f"{'converged' if km.converged else 'not converged'}",
        {"iterations": int(km.iterations), "converged": bool(km.converged)},
    )
    return Warps(tuple(np.asarray(v) for v in km.warps), (), inputs.warp, None, (note,))


def pairing_notes(pairing: Any) -> list[Note]:
    """One note for the pinned pairs and one for the dropped ones, seconds ``A:B``."""
    out = []
    if pairing.details:
        out.append(
            Note(
                NOTE_LANDMARKS,
                "landmarks auto: pinned (offset from the warp without landmarks beyond the events' "
                "timing uncertainty; met at the window's edge): "
                + ", ".join(
                    f"{d['kind']} {d['time_a_s']:.3f}:{d['time_b_s']:.3f} "
                    f"({d['offset_s']:+.3f} +- {d['window_s']:.4f} s -> {d['target_b_s']:.3f})"
                    for d in pairing.details
                ),
            )
        )
    if pairing.dropped:
        out.append(
            Note(
                NOTE_LANDMARKS,
                "landmarks auto: dropped (the warp without landmarks meets them within the events' "
                "timing uncertainty, or out of order once pinned): "
                + ", ".join(
                    f"{d['kind']} {d['time_s']:.3f}:{d['time_b_s']:.3f} "
                    f"({d['offset_s']:+.3f} +- {d['window_s']:.4f} s)"
                    for d in pairing.dropped
                ),
            )
        )
    return out
