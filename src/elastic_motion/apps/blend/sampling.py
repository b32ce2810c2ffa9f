"""Inputs sampled at the blend's matched times, and weighted means of rotations: the small
batched helpers the blend's stages share.

Times are seconds from a motion's first frame; rotation stacks are ``(N, k, 3, 3)`` (``N``
output frames, ``k`` joints). Frame weights are ``(K,)`` (constant weights, one per input) or
``(F, K)`` (a weight curve: one row per output frame).
"""

from __future__ import annotations

import numpy as np

from elastic_motion.groups import SO3, PowerGroup
from elastic_motion.motion import Motion

__all__ = [
    "blend_rotations",
    "frame_weight",
    "sample_linear",
    "sample_rotations",
]

_SO3 = SO3()


def sample_rotations(m: Motion, joints: np.ndarray, times: np.ndarray) -> np.ndarray:
    """Local rotations of ``joints`` at ``times`` (s) by geodesic interpolation, ``(N, k, 3, 3)``."""
    f = np.clip(times * m.fps, 0.0, m.n_frames - 1)
    i = np.clip(np.floor(f).astype(int), 0, m.n_frames - 2)
    u = f - i
    r0 = m.rotations[i][:, joints]
    r1 = m.rotations[i + 1][:, joints]
    return r0 @ _SO3.exp(u[:, None, None] * _SO3.log(np.swapaxes(r0, -1, -2) @ r1))


def sample_linear(arr: np.ndarray, fps: float, times: np.ndarray) -> np.ndarray:
    """Linear interpolation of per-frame data ``(F, ...)`` at ``times`` (s)."""
    n = arr.shape[0]
    f = np.clip(times * fps, 0.0, n - 1)
    i = np.clip(np.floor(f).astype(int), 0, max(n - 2, 0))
    u = (f - i).reshape((-1,) + (1,) * (arr.ndim - 1))
    j = np.minimum(i + 1, n - 1)
    return (1.0 - u) * arr[i] + u * arr[j]


def blend_rotations(rots: list[np.ndarray], w: np.ndarray) -> np.ndarray:
    """Weighted geodesic blend of rotation stacks ``(N, k, 3, 3)`` at weights ``w``: ``(K,)``
    (two: geodesic point, extrapolation allowed; more: weighted Karcher mean, batched) or per
    frame, ``(N, K)`` (a weight curve: two, the geodesic point at each frame's weight; more,
    each distinct row's Karcher mean)."""
    w = np.asarray(w, dtype=np.float64)
    if len(rots) == 2:
        s = w[1] if w.ndim == 1 else w[:, 1].reshape(-1, *([1] * (rots[0].ndim - 2)))
        return rots[0] @ _SO3.exp(s * _SO3.log(np.swapaxes(rots[0], -1, -2) @ rots[1]))
    if w.ndim == 2:
        rows, which = np.unique(w, axis=0, return_inverse=True)
        out = np.empty_like(rots[0])
        for i, row in enumerate(rows):
            at = np.flatnonzero(which.reshape(-1) == i)
            out[at] = blend_rotations([r[at] for r in rots], row)
        return out
    shape = rots[0].shape
    n = int(np.prod(shape[:-2]))
    g = PowerGroup(SO3(), n)
    pts = np.stack([r.reshape(n, 3, 3) for r in rots])
    return g.weighted_mean(pts, w).reshape(shape)


def frame_weight(wf: np.ndarray, k: int, n: int, ndim_extra: int) -> np.ndarray | float:
    """Input ``k``'s weight from frame weights ``wf`` (``(K,)`` or ``(n, K)``): a float, or
    ``(n, 1, ..., 1)`` with ``ndim_extra`` trailing ones (broadcasts over per-frame data)."""
    if wf.ndim == 1:
        return float(wf[k])
    return wf[:, k].reshape((n,) + (1,) * ndim_extra)
