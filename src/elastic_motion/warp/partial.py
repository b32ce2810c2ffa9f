"""Open-ended DP: the best match of a short SRV array inside a long one (free start and end).

Problem (partial matching, subsequence elastic matching): ``q0`` of shape ``(n0, D)`` holds on
the uniform grid of ``[0, 1]`` (cell ``h = 1 / n0``); ``q1`` of shape ``(n1, D)`` holds on the
uniform grid of ``[0, L]`` with the *same* cell length, ``L = n1 / n0`` (the long curve
sampled at the query's rate, its SRV taken with respect to that time). Find an interval
``[a, b]`` of ``[0, L]`` and an increasing ``phi: [0, 1] -> [a, b]`` minimising::

    E(a, b, phi) = int_0^1 |q0(t) - sqrt(phi'(t)) q1(phi(t))|^2 dt

which is the squared elastic distance between the query and the segment ``[a, b]`` of the
long curve (a segment reparametrised onto ``[0, 1]`` by an affine map has the SRV
``sqrt(b - a) q1(a + (b - a) t)``, which is ``q1 * phi`` for that affine ``phi``).

The DP runs on the nodes ``(i, j)``, ``i`` in ``0..n0``, ``j`` in ``0..n1``, with the edges
of :func:`~elastic_motion.warp.coprime_steps` and the exact edge cost of
:mod:`elastic_motion.warp.dp_kernels` (piecewise constant q's); ``H[0, j] = 0`` for every ``j``
(free start) and the result is ``min_j H[n0, j]`` (free end). Segment lengths are
``n0 / m .. m n0`` cells for the largest step ``m``. Cost ``O(n0 n1 K)`` edges.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit, prange

from elastic_motion.warp.dp import coprime_steps
from elastic_motion.warp.dp_kernels import cross_walk

__all__ = ["PartialWarp", "partial_warp"]


@njit(cache=True, parallel=True)
def _partial_dp(u, v, c0, c1, G, P0, P1, steps):  # pragma: no cover - numba
    n0 = u.shape[0] - 1
    n1 = v.shape[0] - 1
    K = steps.shape[0]
    H = np.full((n0 + 1, n1 + 1), np.inf)
    arg = np.full((n0 + 1, n1 + 1), -1, dtype=np.int64)
    for j in range(n1 + 1):
        H[0, j] = 0.0
    for i in range(1, n0 + 1):
        for j in prange(n1 + 1):
            best = np.inf
            bestnb = -1
            for nb in range(K):
                k = i - steps[nb, 0]
                l = j - steps[nb, 1]
                if k < 0 or l < 0:
                    continue
                hkl = H[k, l]
                if hkl >= best:
                    continue
                A = P0[i] - P0[k]
                B = P1[j] - P1[l]
                d = np.sqrt(A) - np.sqrt(B)
                if hkl + d * d >= best:  # Cauchy-Schwarz: the edge costs at least d^2
                    continue
                cross = cross_walk(u, v, u, v, c0, c1, G, k, l, i, j)
                rs = np.sqrt((v[j] - v[l]) / (u[i] - u[k]))
                e = A + B - 2.0 * rs * cross
                if e < 0.0:
                    e = 0.0
                if hkl + e < best:
                    best = hkl + e
                    bestnb = nb
            H[i, j] = best
            arg[i, j] = bestnb
    return H, arg


@dataclass(frozen=True)
class PartialWarp:
    """Result of :func:`partial_warp`.

    Attributes
    ----------
    start, stop : int
        The matched segment in cells of ``q1``: ``[start, stop)`` (time ``[start h, stop h]``).
    energy : float
        ``min E`` (module docstring); ``distance = sqrt(energy)``.
    vertices : ndarray, shape (K, 2)
        The DP path: ``(t, phi(t))`` with ``t`` in ``[0, 1]`` and ``phi`` in ``[start h, stop h]``
        (time of ``q1``'s grid ``[0, L]``).
    end_energies : ndarray, shape (n1 + 1,)
        ``min E`` over segments ending at node ``j`` (``+inf`` where none): the profile of
        the match along the long curve (local minima are other occurrences).
    """

    start: int
    stop: int
    energy: float
    vertices: np.ndarray
    end_energies: np.ndarray

    @property
    def distance(self) -> float:
        """``sqrt(energy)``: the elastic distance of the query to the segment."""
        return float(np.sqrt(max(self.energy, 0.0)))


def partial_warp(q0: np.ndarray, q1: np.ndarray, *, neighbourhood: int = 4) -> PartialWarp:
    """Best segment of ``q1`` (long) matching ``q0`` (short) under a time warp (module docstring).

    Parameters
    ----------
    q0 : array_like, shape (n0, D)
        The query's SRV array on the uniform grid of ``[0, 1]``.
    q1 : array_like, shape (n1, D)
        The long SRV array on the uniform grid of ``[0, n1 / n0]`` (same cell length).
    neighbourhood : int, default 4
        Largest DP step ``m``: slopes in ``[1/m, m]`` (segment lengths ``n0/m .. m n0`` cells).

    Returns
    -------
    PartialWarp

    Raises
    ------
    ValueError
        Bad shapes or dimensions, NaN, or ``q1`` too short for any path (``n1 < n0 / m``).
    """
    q0 = np.ascontiguousarray(q0, dtype=np.float64)
    q1 = np.ascontiguousarray(q1, dtype=np.float64)
    if q0.ndim != 2 or q1.ndim != 2 or q0.shape[1] != q1.shape[1] or len(q0) < 1 or len(q1) < 1:
        raise ValueError(f"q0, q1: expected arrays (n0, D), (n1, D); got {q0.shape}, {q1.shape}")
    if not (np.isfinite(q0).all() and np.isfinite(q1).all()):
        raise ValueError("q0, q1: expected finite values; got NaN or inf")
    m = int(neighbourhood)
    if m < 1:
        raise ValueError(f"neighbourhood: expected an integer >= 1; got {neighbourhood!r}")
    n0, n1 = len(q0), len(q1)
    h = 1.0 / n0
    u = np.arange(n0 + 1) * h
    v = np.arange(n1 + 1) * h
    c = np.arange(max(n0, n1) + 1, dtype=np.int64)
    G = q0 @ q1.T
    P0 = np.concatenate([[0.0], np.cumsum(np.einsum("ij,ij->i", q0, q0) * h)])
    P1 = np.concatenate([[0.0], np.cumsum(np.einsum("ij,ij->i", q1, q1) * h)])
    steps = np.ascontiguousarray(coprime_steps(m), dtype=np.int64)
    H, arg = _partial_dp(u, v, c[: n0 + 1], c[: n1 + 1], G, P0, P1, steps)
    ends = H[n0].copy()
    j = int(np.argmin(ends))
    if not np.isfinite(ends[j]):
        raise ValueError(f"q1: expected at least {-(-n0 // m)} cells for a query of {n0} cells; got {n1}")
    path = [(n0, j)]
    i = n0
    while i > 0:
        nb = arg[i, j]
        i, j = i - int(steps[nb, 0]), j - int(steps[nb, 1])
        path.append((i, j))
    path.reverse()
    verts = np.array([(a * h, b * h) for a, b in path])
    return PartialWarp(int(path[0][1]), int(path[-1][1]), float(ends[path[-1][1]]), verts, ends)
