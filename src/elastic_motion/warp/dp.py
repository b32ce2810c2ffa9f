"""The dynamic-programming warp on a grid: its arrays, bands, pruning and coarse to fine.

The Python side of the DP of :func:`elastic_motion.warp.optimal_warp` (paper 001, sec. 3.2);
the loops themselves are the numba kernels of :mod:`elastic_motion.warp.dp_kernels`. See
:mod:`elastic_motion.warp` for the conventions and ``docs/warp.md`` for the method, its
complexity and measured numbers.

:func:`solve_dp` solves one pair on one grid as a :class:`DPPlan` says: the neighbourhood of
slopes (:func:`coprime_steps`, :func:`as_steps`), exact (pruned by a Cauchy-Schwarz bound
from a coarse-to-fine upper bound) or banded coarse to fine.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from elastic_motion.warp import dp_kernels
from elastic_motion.warp.energy import kernel_array
from elastic_motion.warp.landmarks import WINDOW_SLACK, Landmarks, PenaltySpec

__all__ = [
    "C2F_MIN_CELLS",
    "PRUNE_MIN_CELLS",
    "DPPlan",
    "DPProblem",
    "DPSolution",
    "LandmarkTables",
    "as_steps",
    "coarsen",
    "coprime_steps",
    "reachable_grid",
    "solve_dp",
    "tap_pattern",
]

#: Coarse-to-fine: the coarsest level of the pyramid has at most this many cells.
C2F_MIN_CELLS = 100

#: Exact pruning is tried on grids with at least twice this many cells (both curves).
PRUNE_MIN_CELLS = 100


def coprime_steps(max_step: int) -> np.ndarray:
    """All slopes ``(a, b)`` with ``1 <= a, b <= max_step`` and ``gcd(a, b) = 1``.

    Sorted by ``a + b`` (short edges first, so the pruning bound finds good candidates
    early).  ``max_step = 10`` gives fdasrsf's 63 slopes.

    Returns
    -------
    ndarray, shape (K, 2), int64
        Columns: domain step ``a`` (nodes of the domain grid), range step ``b``.
    """
    if int(max_step) < 1:
        raise ValueError(f"neighbourhood: expected a maximal step >= 1; got {max_step!r}")
    m = int(max_step)
    pairs = [(a, b) for a in range(1, m + 1) for b in range(1, m + 1) if math.gcd(a, b) == 1]
    pairs.sort(key=lambda p: (p[0] + p[1], max(p), p[0]))
    return np.array(pairs, dtype=np.int64)


def as_steps(neighbourhood: Any) -> np.ndarray:
    if np.isscalar(neighbourhood):
        if not float(neighbourhood).is_integer():
            raise ValueError(f"neighbourhood: expected an integer maximal step; got {neighbourhood!r}")
        return coprime_steps(int(neighbourhood))
    arr = np.asarray(neighbourhood)
    if arr.ndim != 2 or arr.shape[1] != 2 or arr.shape[0] < 1:
        raise ValueError(
            f"neighbourhood: expected a maximal step (int) or steps (a, b) of shape (K, 2); "
            f"got shape {arr.shape}"
        )
    if not np.issubdtype(arr.dtype, np.integer) or (arr < 1).any():
        raise ValueError("neighbourhood: steps (a, b) must be integers >= 1")
    if arr.shape[0] > 32000:
        raise ValueError(f"neighbourhood: at most 32000 steps; got {arr.shape[0]}")
    uniq = np.unique(arr.astype(np.int64), axis=0)
    order = np.lexsort((uniq[:, 0], uniq.max(axis=1), uniq.sum(axis=1)))
    return np.ascontiguousarray(uniq[order])


def reachable_grid(t0: np.ndarray, t1: np.ndarray, max_step: int) -> tuple[np.ndarray, np.ndarray] | None:
    """DP nodes on which a warp with slopes in ``[1/max_step, max_step]`` reaches ``(1, 1)``.

    The default grid is the two curves' break points; when one curve has many times more
    cells than the other (a short clip against a long take), no path of DP steps joins the
    corners. Subdividing each cell of the coarser curve into ``r`` equal parts keeps the
    edge costs exact (the SRV functions stay piecewise constant on the finer nodes) and
    brings the cell counts within ``max_step / 2`` of each other. Returns None when the
    break points already do.
    """
    n0, n1 = len(t0) - 1, len(t1) - 1
    ratio = max(n0, n1) / min(n0, n1)
    limit = max(1.0, max_step / 2.0)
    if ratio <= limit:
        return None
    r = int(np.ceil(ratio / limit))

    def refine(t: np.ndarray) -> np.ndarray:
        frac = np.arange(r) / r
        inner = (t[:-1, None] + np.diff(t)[:, None] * frac[None, :]).ravel()
        return np.concatenate([inner, t[-1:]])

    return (refine(t0), t1) if n0 < n1 else (t0, refine(t1))


@dataclass
class DPProblem:
    """Arrays of one DP solve (one level of the pyramid), in the layout of the kernels.

    ``q0`` ``(n0, D)`` on ``t0``, ``q1`` ``(n1, D)`` on ``t1``, the DP nodes ``u`` ``(nu+1,)``
    and ``v`` ``(nv+1,)``; derived: the Gram matrix ``G = q0 q1^T`` ``(n0, n1)``, the cells
    ``c0``, ``c1`` that start at each node, the prefix integrals ``P0``, ``P1`` of ``|q|^2``
    at the nodes and the squared norms ``A_tot = ||q0||^2``, ``B_tot = ||q1||^2`` (the Gram
    form the refinement uses too).
    """

    q0: np.ndarray
    t0: np.ndarray
    q1: np.ndarray
    t1: np.ndarray
    u: np.ndarray
    v: np.ndarray

    def __post_init__(self) -> None:
        for name in ("q0", "t0", "q1", "t1", "u", "v"):
            setattr(self, name, kernel_array(getattr(self, name)))
        self.G = kernel_array(self.q0 @ self.q1.T)  # one BLAS call: <q0_a, q1_b>
        self.c0 = np.clip(np.searchsorted(self.t0, self.u, side="right") - 1, 0, len(self.q0) - 1)
        self.c1 = np.clip(np.searchsorted(self.t1, self.v, side="right") - 1, 0, len(self.q1) - 1)
        # prefix integrals of |q|^2 at the grid nodes (piecewise linear: interp is exact)
        cum0 = np.concatenate([[0.0], np.cumsum(np.einsum("ij,ij->i", self.q0, self.q0) * np.diff(self.t0))])
        cum1 = np.concatenate([[0.0], np.cumsum(np.einsum("ij,ij->i", self.q1, self.q1) * np.diff(self.t1))])
        self.P0 = kernel_array(np.interp(self.u, self.t0, cum0))
        self.P1 = kernel_array(np.interp(self.v, self.t1, cum1))
        self.c0 = kernel_array(self.c0, np.int64)
        self.c1 = kernel_array(self.c1, np.int64)
        self.A_tot = float(cum0[-1])
        self.B_tot = float(cum1[-1])


def coarsen(q: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Merge pairs of cells: the L2 projection of q onto every other break point."""
    tc = t[::2]
    if tc[-1] != t[-1]:
        tc = np.append(tc, t[-1])
    cum = np.concatenate([np.zeros((1, q.shape[1])), np.cumsum(q * np.diff(t)[:, None], axis=0)])
    idx = np.searchsorted(t, tc)
    qc = np.diff(cum[idx], axis=0) / np.diff(tc)[:, None]
    return np.ascontiguousarray(qc), tc


@dataclass
class LandmarkTables:
    """The landmark pairs and their penalty, and their arrays in the layout of the kernels
    (:meth:`kernel_args`); ``lm`` None or empty: no feature term."""

    lm: Landmarks | None
    spec: PenaltySpec | None
    symmetric: bool

    def kernel_args(self, u: np.ndarray, v: np.ndarray) -> tuple:
        """``lmk`` of :func:`~elastic_motion.warp.dp_kernels.dp_solve` for the nodes ``u``, ``v``."""
        empty_f = np.zeros(0)
        empty_t = np.zeros((0, 2))
        if self.lm is None or self.spec is None or len(self.lm) == 0:
            zu = np.zeros(len(u), dtype=np.int64)
            zv = np.zeros(len(v), dtype=np.int64)
            return (
                0.0,
                0,
                empty_f,
                empty_f,
                empty_f,
                zu,
                empty_t,
                empty_f,
                empty_f,
                empty_f,
                zv,
                empty_t,
                False,
            )
        lm, spec = self.lm, self.spec
        o0 = np.argsort(lm.theta0, kind="stable")
        # the kernels test |r| > d_m + slack: a window d_m = 0 (exact hard constraint) is met by
        # an edge through the landmark node up to the rounding of phi on the linear piece
        fx, fy, fd = lm.theta0[o0], lm.theta1[o0], spec.windows[o0] + WINDOW_SLACK
        cnt0 = np.searchsorted(fx, u, side="right").astype(np.int64)
        tab0 = spec.table(fy)
        o1 = np.argsort(lm.theta1, kind="stable")
        sx, sy, sd = lm.theta0[o1], lm.theta1[o1], spec.windows[o1] + WINDOW_SLACK
        cnt1 = np.searchsorted(sy, v, side="right").astype(np.int64)
        tab1 = spec.table(sx) if self.symmetric else empty_t
        k = kernel_array
        return (
            float(spec.lam),
            int(spec.kind),
            k(fx),
            k(fy),
            k(fd),
            k(cnt0, np.int64),
            k(tab0),
            k(sx),
            k(sy),
            k(sd),
            k(cnt1, np.int64),
            k(tab1),
            bool(self.symmetric),
        )

    def endpoint_cost(self) -> float:
        """Pairs at parameter 0 are never on an edge's (k, i]: phi(0) = 0 is fixed."""
        if self.lm is None or self.spec is None or len(self.lm) == 0:
            return 0.0
        lm, spec = self.lm, self.spec
        cost = 0.0
        at0 = lm.theta0 == 0.0
        if at0.any():
            r = -lm.theta1[at0]
            if (np.abs(r) > spec.windows[at0] + WINDOW_SLACK).any():
                return np.inf
            cost += spec.lam * float(spec.values(np.zeros_like(r), lm.theta1[at0]).sum())
        if self.symmetric:
            at0 = lm.theta1 == 0.0
            if at0.any():
                r = -lm.theta0[at0]
                if (np.abs(r) > spec.windows[at0] + WINDOW_SLACK).any():
                    return np.inf
                cost += spec.lam * float(spec.values(np.zeros_like(r), lm.theta0[at0]).sum())
        return cost


@dataclass
class DPSolution:
    """The DP's warp (vertices ``(K, 2)``, empty when no path reaches ``(1, 1)``), its value
    (energy on the grid, ``+inf`` without a path), the nodes filled and the pyramid levels;
    ``problem``: the arrays of the finest level (its Gram matrix serves the refinement)."""

    vertices: np.ndarray
    value: float
    nodes: int
    levels: int
    problem: DPProblem | None = None


def _band(vertices: np.ndarray, u: np.ndarray, v: np.ndarray, w: int) -> tuple[np.ndarray, np.ndarray]:
    """Band of half-width ``w`` range nodes around a (coarse) warp, one row per domain node."""
    nv = len(v) - 1
    centre = np.interp(np.interp(u, vertices[:, 0], vertices[:, 1]), v, np.arange(nv + 1.0))
    lo = np.clip(np.floor(centre - w), 0, nv).astype(np.int64)
    hi = np.clip(np.ceil(centre + w), 0, nv).astype(np.int64)
    lo = np.minimum.accumulate(lo[::-1])[::-1]  # lo non-decreasing from the end
    hi = np.maximum.accumulate(hi)
    lo[0] = 0
    hi[-1] = nv
    return lo, hi


def _is_uniform(t: np.ndarray) -> bool:
    n = len(t) - 1
    return bool(np.allclose(np.diff(t), 1.0 / n, rtol=1e-9, atol=0.0))


def _taps(pb: DPProblem, steps: np.ndarray) -> tuple:
    """Tap patterns of the edge cross term on uniform grids (see :func:`dp_kernels.dp_solve`).

    The edge of slope (a, b) from node (0, 0) crosses the cells (dp, dr) of the segment
    to (a, b) in index space (a + b - 1 cells for coprime a, b), for lengths w (domain
    units, ``h0 = 1 / n0``).  Empty arrays when the grids are not uniform break points.
    """
    uniform = (
        (pb.u is pb.t0 or np.array_equal(pb.u, pb.t0))
        and (pb.v is pb.t1 or np.array_equal(pb.v, pb.t1))
        and _is_uniform(pb.t0)
        and _is_uniform(pb.t1)
    )
    if not uniform:
        empty_i = np.zeros(0, dtype=np.int64)
        return (empty_i, empty_i, empty_i, np.zeros(0), np.zeros(0))
    key = tuple(map(tuple, steps.tolist()))
    return tap_pattern(key, len(pb.t0) - 1, len(pb.t1) - 1)


@functools.lru_cache(maxsize=64)
def tap_pattern(steps: tuple[tuple[int, int], ...], n0: int, n1: int) -> tuple:
    """Cached taps for uniform grids of n0 and n1 cells (never modified by the kernels)."""
    h0, h1 = 1.0 / n0, 1.0 / n1
    ptr, dps, drs, ws = [0], [], [], []
    for a, b in steps:
        cuts = np.union1d(np.arange(a + 1.0), np.arange(b + 1.0) * a / b)  # domain index units
        mid = 0.5 * (cuts[1:] + cuts[:-1])
        dps.extend(np.floor(mid).astype(np.int64))
        drs.extend(np.floor(mid * b / a).astype(np.int64))
        ws.extend(np.diff(cuts) * h0)
        ptr.append(len(ws))
    st = np.array(steps, dtype=np.float64)
    sqrt_s = np.sqrt(st[:, 1] * h1 / (st[:, 0] * h0))
    return (
        np.array(ptr, dtype=np.int64),
        np.array(dps, dtype=np.int64),
        np.array(drs, dtype=np.int64),
        np.array(ws),
        sqrt_s,
    )


def _run_dp(
    pb: DPProblem, steps: np.ndarray, lmd: LandmarkTables, lo: np.ndarray, hi: np.ndarray
) -> tuple[np.ndarray, float, int]:
    args = lmd.kernel_args(pb.u, pb.v)
    # one memory layout for every call: a new layout would compile a new specialisation
    lo = np.ascontiguousarray(lo, dtype=np.int64)
    hi = np.ascontiguousarray(hi, dtype=np.int64)
    nodes = int(np.sum(np.maximum(hi - lo + 1, 0)))
    taps = _taps(pb, steps)
    nu, nv = len(pb.u) - 1, len(pb.v) - 1
    if taps[0].shape[0]:  # uniform grids: row-vectorised kernel, dense tables
        H, arg = dp_kernels.dp_solve_rows(pb.u, pb.v, pb.P0, pb.P1, pb.G, steps, taps, lo, hi, args)
        offset = np.zeros(nu + 1, dtype=np.int64)
    else:
        H, arg = dp_kernels.dp_solve(
            pb.u, pb.v, pb.t0, pb.t1, pb.c0, pb.c1, pb.G, pb.P0, pb.P1, steps, taps, lo, hi, args
        )
        offset = lo
    value = float(H[nu, nv - offset[nu]])
    if not np.isfinite(value):
        return np.zeros((0, 2)), value, nodes
    path = dp_kernels.dp_backtrack(arg, offset, steps, nu, nv)
    return np.column_stack([pb.u[path[:, 0]], pb.v[path[:, 1]]]), value + lmd.endpoint_cost(), nodes


def _norm_band(pb: DPProblem, upper: float) -> tuple[np.ndarray, np.ndarray]:
    """Nodes that an optimal path can visit, from an upper bound of the optimal energy.

    For any path through node (i, j), Cauchy-Schwarz on ``[0, u_i]`` and on ``[u_i, 1]``
    gives the lower bound ``(sqrt(P0_i) - sqrt(P1_j))^2 + (sqrt(A - P0_i) - sqrt(B - P1_j))^2``
    (the arc lengths in SRV norm must match); nodes where it exceeds ``upper`` (the energy
    of a feasible grid path) cannot be on an optimal path and are skipped: an exact
    pruning.  The bound is convex in ``P1_j``, so each row keeps an interval of j.
    """
    nu, nv = len(pb.u) - 1, len(pb.v) - 1
    ub = upper * (1.0 + 1e-9) + 1e-12 * (pb.A_tot + pb.B_tot)
    a = np.sqrt(np.maximum(pb.P0, 0.0))
    b = np.sqrt(np.maximum(pb.A_tot - pb.P0, 0.0))
    c = np.sqrt(np.maximum(pb.P1, 0.0))
    d = np.sqrt(np.maximum(pb.B_tot - pb.P1, 0.0))
    lo = np.empty(nu + 1, dtype=np.int64)
    hi = np.empty(nu + 1, dtype=np.int64)
    chunk = max(1, 2_000_000 // (nv + 1))
    for r0 in range(0, nu + 1, chunk):
        r1 = min(nu + 1, r0 + chunk)
        ok = (a[r0:r1, None] - c[None, :]) ** 2 + (b[r0:r1, None] - d[None, :]) ** 2 <= ub
        anyok = ok.any(axis=1)
        first = np.argmax(ok, axis=1)
        last = nv - np.argmax(ok[:, ::-1], axis=1)
        lo[r0:r1] = np.where(anyok, first, 1)
        hi[r0:r1] = np.where(anyok, last, 0)
    lo[0], hi[-1] = 0, nv
    hi[0] = max(hi[0], 0)
    lo[-1] = min(lo[-1], nv)
    return lo, hi


@dataclass(frozen=True)
class DPPlan:
    """How :func:`solve_dp` fills the grid.

    Attributes
    ----------
    steps : ndarray of int, shape (K, 2)
        The neighbourhood (:func:`as_steps`).
    coarse_to_fine : bool
        Banded coarse to fine (fast, not exact).
    band : int
        Half-width of the band (range nodes).
    prune : bool
        Exact pruning of large grids (from a coarse-to-fine upper bound).
    """

    steps: np.ndarray
    coarse_to_fine: bool = False
    band: int = 0
    prune: bool = True


def solve_dp(
    q0: np.ndarray,
    t0: np.ndarray,
    q1: np.ndarray,
    t1: np.ndarray,
    lmd: LandmarkTables,
    plan: DPPlan,
    grid: tuple[np.ndarray, np.ndarray] | None = None,
) -> DPSolution:
    """DP on the grid ``(u, v)`` (default: the break points): exact or coarse to fine.

    Coarse to fine solves a pyramid of merged cells (:func:`coarsen`) down to
    ``C2F_MIN_CELLS``..``2 C2F_MIN_CELLS`` cells, each level only in a band of half-width
    ``plan.band`` around the warp of the level below: fast, not exact.

    The exact solver (``plan.prune``, large grids) uses that coarse-to-fine warp as an upper
    bound ``U`` (a feasible grid path), then fills every node that an optimal path can visit
    according to :func:`_norm_band`; when those nodes all lie in the band, the banded
    solution is already exact.  Otherwise (or without pruning) the full grid is filled.
    """
    u, v = (t0, t1) if grid is None else grid
    pb = DPProblem(q0, t0, q1, t1, u, v)
    nu, nv = len(u) - 1, len(v) - 1
    steps, c2f = plan.steps, plan.coarse_to_fine
    min_cells = C2F_MIN_CELLS if c2f else PRUNE_MIN_CELLS
    if grid is None and (c2f or plan.prune) and min(nu, nv) >= 2 * min_cells:
        q0c, t0c = coarsen(q0, t0)
        q1c, t1c = coarsen(q1, t1)
        coarse = solve_dp(q0c, t0c, q1c, t1c, lmd, replace(plan, coarse_to_fine=True, prune=True))
        if coarse.vertices.shape[0]:
            refined = _within_band(pb, lmd, plan, coarse)
            if refined is not None:
                refined.problem = pb
                return refined
    lo = np.zeros(nu + 1, dtype=np.int64)
    hi = np.full(nu + 1, nv, dtype=np.int64)
    verts, value, nodes = _run_dp(pb, steps, lmd, lo, hi)
    return DPSolution(verts, value, nodes, 1, pb)


def _within_band(pb: DPProblem, lmd: LandmarkTables, plan: DPPlan, coarse: DPSolution) -> DPSolution | None:
    """The DP in the band around the coarse warp: the coarse-to-fine answer, or (pruning) the
    exact one when every node an optimal path can visit is in the band or filled after it;
    None when no path crosses the band."""
    lo, hi = _band(coarse.vertices, pb.u, pb.v, plan.band)
    verts, value, nodes = _run_dp(pb, plan.steps, lmd, lo, hi)
    if not np.isfinite(value):
        return None
    if plan.coarse_to_fine:
        return DPSolution(verts, value, nodes + coarse.nodes, coarse.levels + 1)
    lo2, hi2 = _norm_band(pb, value - lmd.endpoint_cost())
    inside = (lo2 > hi2) | ((lo2 >= lo) & (hi2 <= hi))
    if inside.all():
        return DPSolution(verts, value, nodes + coarse.nodes, 1)
    verts, value, nodes2 = _run_dp(pb, plan.steps, lmd, lo2, hi2)
    return DPSolution(verts, value, nodes + coarse.nodes + nodes2, 1)
