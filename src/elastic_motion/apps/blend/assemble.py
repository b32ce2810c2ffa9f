"""Stage 6 of a blend: the full skeleton assembled.

The curve joints come from the blended curve (:mod:`.anchor`); finger joints (not on the
curves, see :mod:`elastic_motion.apps.align`) get the geodesic blend of the inputs' local
rotations at the matched times; per-frame translations of non-root joints (position
channels), linear blends. The skeleton: ``skeleton="blend"`` gives each bone the weighted
mean of the inputs' offsets, so that leg length and root height blend together; ``"first"``
keeps A's.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from elastic_motion.apps.blend.inputs import BlendInputs
from elastic_motion.apps.blend.sampling import (
    blend_rotations,
    frame_weight,
    sample_linear,
    sample_rotations,
)
from elastic_motion.apps.blend.timing import Clock
from elastic_motion.apps.blend_options import BlendOptions
from elastic_motion.motion import Motion, Skeleton

__all__ = ["assemble_motion", "blend_skeleton", "blend_translations"]


def blend_skeleton(ms: Sequence[Motion], w: np.ndarray, mode: str) -> Skeleton:
    """The result's skeleton: A's (``mode="first"``), or the inputs' bone and end-site
    offsets weighted by ``w`` ``(K,)`` (end sites only when all inputs have the same)."""
    sk = ms[0].skeleton
    if mode == "first" or len(ms) == 1:
        return sk
    offsets = np.einsum("k,kjd->jd", w, np.stack([m.skeleton.offsets for m in ms]))
    es = sk.end_site_offsets
    same_es = all(
        m.skeleton.end_site_offsets.shape == es.shape
        and np.array_equal(m.skeleton.end_site_parents, sk.end_site_parents)
        for m in ms
    )
    if same_es and es.size:
        es = np.einsum("k,kjd->jd", w, np.stack([m.skeleton.end_site_offsets for m in ms]))
    return Skeleton(sk.names, sk.parents, offsets, sk.channels, sk.end_site_parents, es)


def blend_translations(ms: Sequence[Motion], clock: Clock) -> np.ndarray | None:
    """Per-frame joint translations ``(F, J, 3)`` of the result: the inputs' blended linearly
    at the matched times (A's alone when only A has them; None when A has none)."""
    if all(m.joint_translations is not None for m in ms):
        n = clock.u.shape[0]
        return sum(
            frame_weight(clock.weights, i, n, 2) * sample_linear(m.joint_translations, m.fps, t)
            for i, (m, t) in enumerate(zip(ms, clock.times, strict=True))
        )
    if ms[0].joint_translations is not None:
        return sample_linear(ms[0].joint_translations, ms[0].fps, clock.times[0])
    return None


def assemble_motion(
    body: Motion, inputs: BlendInputs, clock: Clock, options: BlendOptions, warp_method: str
) -> Motion:
    """Stage 6 (module docstring): the blend with every joint of the prepared inputs."""
    prep, w = inputs.prepared, inputs.weights
    ms = prep.motions
    out_sk = blend_skeleton(ms, w, options.skeleton)
    names = out_sk.names
    rotations = np.empty((clock.u.shape[0], len(names), 3, 3))
    rotations[:, [names.index(n) for n in prep.curve_joints]] = body.rotations
    extra = np.array([names.index(n) for n in prep.extra_joints], dtype=int)
    if extra.size:
        rots = [sample_rotations(m, extra, t) for m, t in zip(ms, clock.times, strict=True)]
        rotations[:, extra] = blend_rotations(rots, clock.weights)
    label = " + ".join(f"{wk:.3g} {lab}" for wk, lab in zip(w, prep.labels, strict=True))
    return ms[0].replace(
        skeleton=out_sk,
        fps=prep.fps,
        root_translation=body.root_translation,
        rotations=rotations,
        joint_translations=blend_translations(ms, clock),
        source=(),
        name=f"blend ({options.method}, warp {warp_method}): {label}",
    )
