"""Closed curves: the seed (start point) of q1 that the DP matches best, coarse to fine.

A closed curve's SRV function can start anywhere: :func:`seed_search` finds the cyclic shift
of q1 by whole cells (:func:`roll_cells`) whose DP energy against q0 is lowest, on a pyramid
of merged cells; the landmark pairs move with the seed (:func:`shifted_landmarks`).
"""

from __future__ import annotations

import numpy as np

from elastic_motion.warp.dp import DPPlan, LandmarkTables, coarsen, solve_dp
from elastic_motion.warp.landmarks import Landmarks

__all__ = ["SEED_COARSE_CELLS", "roll_cells", "seed_search", "shifted_landmarks"]

#: Closed curves: the seed search starts on a pyramid level with at most this many cells.
SEED_COARSE_CELLS = 64


def roll_cells(q: np.ndarray, t: np.ndarray, s: int) -> tuple[np.ndarray, np.ndarray]:
    """Cyclic shift of a closed curve's SRV by ``s`` whole cells (start at ``t[s]``)."""
    if s == 0:
        return q, t
    tau = t[s]
    ts = np.concatenate([t[s:] - tau, t[1 : s + 1] + (1.0 - tau)])
    ts[0], ts[-1] = 0.0, 1.0
    return np.ascontiguousarray(np.roll(q, -s, axis=0)), ts


def shifted_landmarks(lmd: LandmarkTables, tau: float) -> LandmarkTables | None:
    if lmd.lm is None or len(lmd.lm) == 0 or tau == 0.0:
        return lmd
    try:
        lm = Landmarks(lmd.lm.theta0.copy(), (lmd.lm.theta1 - tau) % 1.0)
    except ValueError:
        return None  # the shift makes the pairs cross: no warp can meet them
    return LandmarkTables(lm, lmd.spec, lmd.symmetric)


def seed_search(
    q0: np.ndarray,
    t0: np.ndarray,
    q1: np.ndarray,
    t1: np.ndarray,
    steps: np.ndarray,
    lmd: LandmarkTables,
) -> tuple[int, int]:
    """Best cyclic shift of q1 (in whole cells), coarse to fine.

    Pyramid of merged cells down to at most ``SEED_COARSE_CELLS`` cells of q1; all shifts
    on the coarsest level, then the 5 shifts around twice the best one on each finer level.
    Returns ``(shift index into t1, number of DP solves)``.
    """
    pyramid = [(q0, t0, q1, t1)]
    while len(pyramid[-1][2]) > SEED_COARSE_CELLS and len(pyramid[-1][0]) > 8:
        a, b, c, d = pyramid[-1]
        pyramid.append((*coarsen(a, b), *coarsen(c, d)))
    plan = DPPlan(steps)
    solves = 0
    best_s = 0
    candidates: list[int] | None = None
    for level in range(len(pyramid) - 1, -1, -1):
        a, b, c, d = pyramid[level]
        n1 = len(c)
        cands = range(n1) if candidates is None else sorted({s % n1 for s in candidates})
        best_e = np.inf
        for s in cands:
            cs, ds = roll_cells(c, d, s)
            lms = shifted_landmarks(lmd, float(d[s]))
            if lms is None:
                continue
            e = solve_dp(a, b, cs, ds, lms, plan).value
            solves += 1
            if e < best_e:
                best_e, best_s = e, s
        candidates = [2 * best_s + k for k in range(-2, 3)]
    return best_s, solves
