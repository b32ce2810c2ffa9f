"""Cheap bounds of the elastic distance, for exact k-nearest search (:func:`knn_search`).

For SRV arrays ``q0, q1`` of shape ``(n, D)`` on the uniform grid of ``[0, 1]`` and a warp
``phi``, the action ``(q1 * phi)(t) = sqrt(phi'(t)) q1(phi(t))`` keeps, for every coordinate
``c`` and both signs, the norm of the positive and of the negative part::

    || ((q1 * phi)_c)^+ || = || (q1_c)^+ ||,    || ((q1 * phi)_c)^- || = || (q1_c)^- ||

(change of variables ``s = phi(t)``; ``sqrt(phi') > 0`` keeps the sign). For reals,
``(a - b)^2 >= (a^+ - b^+)^2 + (a^- - b^-)^2``, so with the reverse triangle inequality per
coordinate and sign::

    d(q0, q1)^2 = min_phi ||q0 - q1 * phi||^2
               >= sum_c (||q0_c^+|| - ||q1_c^+||)^2 + (||q0_c^-|| - ||q1_c^-||)^2   (lower bound)

It holds for every warp, hence for the DP's minimum over its grid paths (which is at least
the infimum over all warps). It contains the bound ``| ||q0|| - ||q1|| | <= d`` of the whole
norm (a coarser partition) and costs ``O(D)`` per pair once the ``2 D`` part norms of each
motion are known (:func:`part_norms`, ``O(n D)`` per motion, stored in an index).

Upper bound: the identity is a DP path, so ``d_DP <= ||q0 - q1||`` (no warp, ``d_P``).
"""

from __future__ import annotations

import numpy as np

__all__ = ["lower_bounds", "part_norms", "upper_bound"]


def part_norms(q: np.ndarray) -> np.ndarray:
    """L2 norms of the positive and negative parts of each coordinate of an SRV array.

    Parameters
    ----------
    q : ndarray, shape (n, D)
        Cell values on the uniform grid of ``[0, 1]`` (cell length ``1 / n``).

    Returns
    -------
    ndarray, shape (2, D)
        ``[||q_c^+||, ||q_c^-||]`` with ``||f||^2 = mean_i f_i^2`` (the integral over ``[0, 1]``).
    """
    q = np.asarray(q, dtype=np.float64)
    pos = np.maximum(q, 0.0)
    neg = np.minimum(q, 0.0)
    n = q.shape[0]
    return np.sqrt(np.stack([np.einsum("ij,ij->j", pos, pos), np.einsum("ij,ij->j", neg, neg)]) / n)


def lower_bounds(query_norms: np.ndarray, norms: np.ndarray) -> np.ndarray:
    """Lower bounds of the elastic distance from the query to each database entry.

    Parameters
    ----------
    query_norms : ndarray, shape (2, D)
        :func:`part_norms` of the query.
    norms : ndarray, shape (M, 2, D)
        :func:`part_norms` of the entries (same ``D``).

    Returns
    -------
    ndarray, shape (M,)
        ``sqrt(sum_{s, c} (query_norms[s, c] - norms[m, s, c])^2)`` (module docstring), in the
        units of the SRV norm; never above the exact or DP elastic distance.
    """
    diff = np.asarray(norms) - np.asarray(query_norms)[None]
    return np.sqrt(np.einsum("msc,msc->m", diff, diff))


def upper_bound(q0: np.ndarray, q1: np.ndarray) -> float:
    """``||q0 - q1||`` (no warp): an upper bound of the DP elastic distance (the identity is a path)."""
    d = np.asarray(q0) - np.asarray(q1)
    return float(np.sqrt(np.einsum("ij,ij->", d, d) / d.shape[0]))
