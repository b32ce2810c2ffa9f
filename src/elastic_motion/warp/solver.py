"""The optimal-warp solver: dynamic programming, gradient refinement, closed curves.

See :mod:`elastic_motion.warp` for the conventions and ``docs/warp.md`` for the method,
its complexity and measured numbers.
"""

from __future__ import annotations

import functools
import math
import time
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from elastic_motion import limits
from elastic_motion.warp import _dp
from elastic_motion.warp.energy import (
    check_pair,
    check_vertices,
    kernel_array,
    shift_seed,
    srv_norm2,
    swap_closed_match,
)
from elastic_motion.warp.landmarks import (
    _WINDOW_SLACK,
    Landmarks,
    Penalty,
    PenaltySpec,
    _landmark_cost,
    as_landmarks,
    make_penalty,
)
from elastic_motion.warp.options import DEFAULT_MAX_STEP, WarpOptions
from elastic_motion.warp.refine import refine_warp

Method = Literal["dp", "dp+refine", "refine"]

#: Default solver of :func:`optimal_warp` (and of :class:`WarpOptions`): the DP alone has
#: slopes in ``[1/m, m]`` and does not reach the elastic distance when the best warp is
#: steeper or flatter, whatever the grid; the refinement off the grid does (``docs/warp.md``,
#: "Default method").
DEFAULT_METHOD: Method = "dp+refine"

# DEFAULT_MAX_STEP (10: all coprime slopes (a, b) with 1 <= a, b <= 10, the 63 slopes of
# fdasrsf's ``DP``, its ``Nbrs`` table in ``DP.c``) has its home in warp.options.

#: Coarse-to-fine: the coarsest level of the pyramid has at most this many cells.
C2F_MIN_CELLS = 100

#: Closed curves: the seed search starts on a pyramid level with at most this many cells.
SEED_COARSE_CELLS = 64


@dataclass(frozen=True)
class WarpDiagnostics:
    """How a warp was computed.

    Attributes
    ----------
    method : str
        ``"dp"``, ``"dp+refine"`` or ``"refine"``.
    grid_shape : tuple of int
        DP grid ``(nu + 1, nv + 1)`` (domain nodes, range nodes) at the finest level.
    n_steps : int
        Size of the slope neighbourhood; ``max_step`` its largest step.
    max_step : int
    nodes_evaluated : int
        DP nodes filled over all levels (the full grid is ``(nu+1) (nv+1)``).
    levels : int
        Coarse-to-fine levels (1 = plain DP).
    band : int
        Half-width (range nodes) of the band of the banded levels (0 = none).
    energy_dp : float
        Objective of the DP warp (nan if no DP ran).
    iterations : int
        Refinement iterations; ``refine_stop`` why it stopped.
    refine_stop : str
    seeds_tried : int
        Closed curves: number of (shift, level) DP solves of the seed search.
    seed_from : str
        Closed curves: ``"q1"`` (the seed on q1's break points won) or ``"q0"`` (the search
        of q0 against q1, seeds on q0's break points, turned into a seed of q1 by
        :func:`swap_closed_match`); ``""`` for open curves.
    time_dp, time_refine, time_total : float
        Wall-clock seconds.
    """

    method: str
    grid_shape: tuple[int, int]
    n_steps: int
    max_step: int
    nodes_evaluated: int
    levels: int
    band: int
    energy_dp: float
    iterations: int
    refine_stop: str
    seeds_tried: int
    time_dp: float
    time_refine: float
    time_total: float
    seed_from: str = ""


@dataclass(frozen=True)
class WarpResult:
    """Optimal warp of q1 onto q0.

    Attributes
    ----------
    vertices : ndarray, shape (K, 2)
        Vertices ``(x_k, phi(x_k))`` of the piecewise linear warp ``phi``.
    t : ndarray, shape (n0+1,)
        The grid of q0 (break points ``t0``).
    phi : ndarray, shape (n0+1,)
        ``phi(t)``: the warp sampled on ``t0``.
    energy : float
        Objective ``||q0 - q1 * phi||^2 + landmark_cost`` (exact, :func:`warp_energy`).
    distance : float
        ``||q0 - q1 * phi||_{L^2}`` (the elastic distance when there are no landmarks).
    landmark_cost : float
        ``lam * sum_m FM(phi(theta0_m), theta1_m)`` (+ the inverse term if symmetric).
    diagnostics : WarpDiagnostics
    seed_shift : float
        Closed curves: q1's start was moved to parameter ``seed_shift`` before warping, i.e.
        ``phi`` warps ``q1_s(t) = q1((t + seed_shift) mod 1)`` (see :func:`shift_seed`).
        0.0 for open curves.
    """

    vertices: np.ndarray
    t: np.ndarray
    phi: np.ndarray
    energy: float
    distance: float
    landmark_cost: float
    diagnostics: WarpDiagnostics = field(repr=False)
    seed_shift: float = 0.0


# ----------------------------------------------------------------------------- set-up


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


def _as_steps(neighbourhood: Any) -> np.ndarray:
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


def _check_grid(grid: Any, t0: np.ndarray, t1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    if grid is None:
        return t0, t1
    try:
        gu, gv = grid
    except (TypeError, ValueError) as exc:
        raise ValueError("grid: expected a pair (domain nodes, range nodes)") from exc
    from elastic_motion._validation import check_parameters

    return check_parameters(gu, "grid[0]"), check_parameters(gv, "grid[1]")


def _reachable_grid(t0: np.ndarray, t1: np.ndarray, max_step: int) -> tuple[np.ndarray, np.ndarray] | None:
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
class _Problem:
    """Arrays of one DP solve (one level of the pyramid)."""

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


def _coarsen(q: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Merge pairs of cells: the L2 projection of q onto every other break point."""
    tc = t[::2]
    if tc[-1] != t[-1]:
        tc = np.append(tc, t[-1])
    cum = np.concatenate([np.zeros((1, q.shape[1])), np.cumsum(q * np.diff(t)[:, None], axis=0)])
    idx = np.searchsorted(t, tc)
    qc = np.diff(cum[idx], axis=0) / np.diff(tc)[:, None]
    return np.ascontiguousarray(qc), tc


@dataclass
class _LandmarkData:
    """Landmark arrays in the layout of the numba kernels."""

    lm: Landmarks | None
    spec: PenaltySpec | None
    symmetric: bool

    def kernel_args(self, u: np.ndarray, v: np.ndarray) -> tuple:
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
        fx, fy, fd = lm.theta0[o0], lm.theta1[o0], spec.windows[o0] + _WINDOW_SLACK
        cnt0 = np.searchsorted(fx, u, side="right").astype(np.int64)
        tab0 = spec.table(fy)
        o1 = np.argsort(lm.theta1, kind="stable")
        sx, sy, sd = lm.theta0[o1], lm.theta1[o1], spec.windows[o1] + _WINDOW_SLACK
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
            if (np.abs(r) > spec.windows[at0] + _WINDOW_SLACK).any():
                return np.inf
            cost += spec.lam * float(spec.values(np.zeros_like(r), lm.theta1[at0]).sum())
        if self.symmetric:
            at0 = lm.theta1 == 0.0
            if at0.any():
                r = -lm.theta0[at0]
                if (np.abs(r) > spec.windows[at0] + _WINDOW_SLACK).any():
                    return np.inf
                cost += spec.lam * float(spec.values(np.zeros_like(r), lm.theta0[at0]).sum())
        return cost


@dataclass
class _DPOut:
    vertices: np.ndarray
    value: float
    nodes: int
    levels: int


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


def _taps(pb: _Problem, steps: np.ndarray) -> tuple:
    """Tap patterns of the edge cross term on uniform grids (see :func:`_dp.dp_solve`).

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
    return _tap_pattern(key, len(pb.t0) - 1, len(pb.t1) - 1)


@functools.lru_cache(maxsize=64)
def _tap_pattern(steps: tuple[tuple[int, int], ...], n0: int, n1: int) -> tuple:
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
    pb: _Problem, steps: np.ndarray, lmd: _LandmarkData, lo: np.ndarray, hi: np.ndarray
) -> tuple[np.ndarray, float, int]:
    args = lmd.kernel_args(pb.u, pb.v)
    # one memory layout for every call: a new layout would compile a new specialisation
    lo = np.ascontiguousarray(lo, dtype=np.int64)
    hi = np.ascontiguousarray(hi, dtype=np.int64)
    nodes = int(np.sum(np.maximum(hi - lo + 1, 0)))
    taps = _taps(pb, steps)
    nu, nv = len(pb.u) - 1, len(pb.v) - 1
    if taps[0].shape[0]:  # uniform grids: row-vectorised kernel, dense tables
        H, arg = _dp.dp_solve_rows(pb.u, pb.v, pb.P0, pb.P1, pb.G, steps, taps, lo, hi, args)
        offset = np.zeros(nu + 1, dtype=np.int64)
    else:
        H, arg = _dp.dp_solve(
            pb.u, pb.v, pb.t0, pb.t1, pb.c0, pb.c1, pb.G, pb.P0, pb.P1, steps, taps, lo, hi, args
        )
        offset = lo
    value = float(H[nu, nv - offset[nu]])
    if not np.isfinite(value):
        return np.zeros((0, 2)), value, nodes
    path = _dp.dp_backtrack(arg, offset, steps, nu, nv)
    return np.column_stack([pb.u[path[:, 0]], pb.v[path[:, 1]]]), value + lmd.endpoint_cost(), nodes


def _norm_band(pb: _Problem, upper: float) -> tuple[np.ndarray, np.ndarray]:
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


#: Exact pruning is tried on grids with at least twice this many cells (both curves).
PRUNE_MIN_CELLS = 100


def _solve_dp(
    q0: np.ndarray,
    t0: np.ndarray,
    q1: np.ndarray,
    t1: np.ndarray,
    grid: tuple[np.ndarray, np.ndarray] | None,
    steps: np.ndarray,
    lmd: _LandmarkData,
    c2f: bool,
    band: int,
    prune: bool = True,
) -> _DPOut:
    """DP on the grid ``(u, v)``: exact (default) or coarse to fine (``c2f``).

    Coarse to fine solves a pyramid of merged cells (:func:`_coarsen`) down to
    ``C2F_MIN_CELLS``..``2 C2F_MIN_CELLS`` cells, each level only in a band of half-width
    ``band`` around the warp of the level below: fast, not exact.

    The exact solver (``prune``, large grids) uses that coarse-to-fine warp as an upper
    bound ``U`` (a feasible grid path), then fills every node that an optimal path can visit
    according to :func:`_norm_band`; when those nodes all lie in the band, the banded
    solution is already exact.  Otherwise (or without ``prune``) the full grid is filled.
    """
    u, v = (t0, t1) if grid is None else grid
    pb = _Problem(q0, t0, q1, t1, u, v)
    nu, nv = len(u) - 1, len(v) - 1
    min_cells = C2F_MIN_CELLS if c2f else PRUNE_MIN_CELLS
    if grid is None and (c2f or prune) and min(nu, nv) >= 2 * min_cells:
        q0c, t0c = _coarsen(q0, t0)
        q1c, t1c = _coarsen(q1, t1)
        coarse = _solve_dp(q0c, t0c, q1c, t1c, None, steps, lmd, True, band)
        if coarse.vertices.shape[0]:
            lo, hi = _band(coarse.vertices, u, v, band)
            verts, value, nodes = _run_dp(pb, steps, lmd, lo, hi)
            if np.isfinite(value):
                if c2f:
                    return _DPOut(verts, value, nodes + coarse.nodes, coarse.levels + 1)
                lo2, hi2 = _norm_band(pb, value - lmd.endpoint_cost())
                inside = (lo2 > hi2) | ((lo2 >= lo) & (hi2 <= hi))
                if inside.all():
                    return _DPOut(verts, value, nodes + coarse.nodes, 1)
                verts, value, nodes2 = _run_dp(pb, steps, lmd, lo2, hi2)
                return _DPOut(verts, value, nodes + coarse.nodes + nodes2, 1)
    lo = np.zeros(nu + 1, dtype=np.int64)
    hi = np.full(nu + 1, nv, dtype=np.int64)
    verts, value, nodes = _run_dp(pb, steps, lmd, lo, hi)
    return _DPOut(verts, value, nodes, 1)


def _roll(q: np.ndarray, t: np.ndarray, s: int) -> tuple[np.ndarray, np.ndarray]:
    """Cyclic shift of a closed curve's SRV by ``s`` whole cells (start at ``t[s]``)."""
    if s == 0:
        return q, t
    tau = t[s]
    ts = np.concatenate([t[s:] - tau, t[1 : s + 1] + (1.0 - tau)])
    ts[0], ts[-1] = 0.0, 1.0
    return np.ascontiguousarray(np.roll(q, -s, axis=0)), ts


def _shifted_landmarks(lmd: _LandmarkData, tau: float) -> _LandmarkData | None:
    if lmd.lm is None or len(lmd.lm) == 0 or tau == 0.0:
        return lmd
    try:
        lm = Landmarks(lmd.lm.theta0.copy(), (lmd.lm.theta1 - tau) % 1.0)
    except ValueError:
        return None  # the shift makes the pairs cross: no warp can meet them
    return _LandmarkData(lm, lmd.spec, lmd.symmetric)


def _seed_search(
    q0: np.ndarray,
    t0: np.ndarray,
    q1: np.ndarray,
    t1: np.ndarray,
    steps: np.ndarray,
    lmd: _LandmarkData,
) -> tuple[int, int]:
    """Best cyclic shift of q1 (in whole cells), coarse to fine.

    Pyramid of merged cells down to at most ``SEED_COARSE_CELLS`` cells of q1; all shifts
    on the coarsest level, then the 5 shifts around twice the best one on each finer level.
    Returns ``(shift index into t1, number of DP solves)``.
    """
    pyramid = [(q0, t0, q1, t1)]
    while len(pyramid[-1][2]) > SEED_COARSE_CELLS and len(pyramid[-1][0]) > 8:
        a, b, c, d = pyramid[-1]
        pyramid.append((*_coarsen(a, b), *_coarsen(c, d)))
    solves = 0
    best_s = 0
    candidates: list[int] | None = None
    for level in range(len(pyramid) - 1, -1, -1):
        a, b, c, d = pyramid[level]
        n1 = len(c)
        cands = range(n1) if candidates is None else sorted({s % n1 for s in candidates})
        best_e = np.inf
        for s in cands:
            cs, ds = _roll(c, d, s)
            lms = _shifted_landmarks(lmd, float(d[s]))
            if lms is None:
                continue
            e = _solve_dp(a, b, cs, ds, None, steps, lms, False, 0).value
            solves += 1
            if e < best_e:
                best_e, best_s = e, s
        candidates = [2 * best_s + k for k in range(-2, 3)]
    return best_s, solves


# ----------------------------------------------------------------------------- public


def optimal_warp(
    q0: Any,
    q1: Any,
    *,
    t0: Any = None,
    t1: Any = None,
    method: Method | None = None,
    neighbourhood: int | Any | None = None,
    grid: tuple[Any, Any] | None = None,
    landmarks: Landmarks | Any | None = None,
    lam: float = 1.0,
    penalty: Penalty = "squared",
    windows: float | Any | None = None,
    symmetric: bool = False,
    closed: bool = False,
    seeds: Literal["both", "q1"] = "both",
    coarse_to_fine: bool | None = None,
    band: int | None = None,
    tol: float = 1e-7,
    max_iter: int = 500,
    options: WarpOptions | None = None,
) -> WarpResult:
    """Optimal warp ``phi`` minimising ``||q0 - q1 * phi||^2 + lam * FM`` (paper 001, eq. 21).

    Parameters
    ----------
    q0 : array_like, shape (n0, D)
        SRV array of curve 0 (cell-valued on ``t0``), in an orthonormal basis: any D, so
        one solver serves ``R^d`` and Lie-group curves.
    q1 : array_like, shape (n1, D)
        SRV array of curve 1 (the curve that is warped), on ``t1``; n1 may differ from n0.
    t0, t1 : array_like, shapes (n0+1,), (n1+1,), optional
        Strictly increasing break points from 0 to 1; uniform when omitted.
    method : {"dp+refine", "dp", "refine"}, default "dp+refine"
        ``"dp"``: dynamic programming, exact on its grid, slopes in ``[1/m, m]``.
        ``"dp+refine"`` (default): then gradient refinement off the grid (never increases the
        energy); it reaches the elastic distance as the grid is refined also when the best
        warp is steeper or flatter than the DP's slopes (``docs/warp.md``, "Default method").
        ``"refine"``: gradient refinement started from the identity (a local method).
    neighbourhood : int or array_like of shape (K, 2), default 10
        Slopes of the DP edges: an int ``m`` gives all coprime ``(a, b)`` with
        ``1 <= a, b <= m`` (default 10: the 63 slopes of fdasrsf's DP); or explicit
        ``(domain step, range step)`` pairs in grid nodes.
    grid : (array_like, array_like), optional
        DP nodes ``(u, v)`` on the domain and the range (each from 0 to 1).  Default: the
        break points ``t0`` and ``t1``, on which the DP is exact.
    landmarks : Landmarks or array_like of shape (M, 2), optional
        Feature pairs ``(theta0_m, theta1_m)`` (see :class:`Landmarks`).
    lam : float
        Weight of the landmark term.
    penalty : {"squared", "abs", "window"} or callable
        Decomposable penalty ``FM(x, target)`` (see :mod:`elastic_motion.warp.landmarks`).
    windows : float or array_like of shape (M,), optional
        Hard windows ``|phi(theta0_m) - theta1_m| <= d_m`` (never violated).
    symmetric : bool
        Symmetric feature term (paper 001, sec. 2.4): also ``FM(phi^{-1}(theta1_m), theta0_m)``.
    closed : bool
        Closed curves: also optimise the seed, a cyclic shift of q1's start by whole cells,
        coarse to fine (see ``seed_shift`` of :class:`WarpResult`).  The energy stays the
        open-curve (``L^2``) one; the closed-curve energy of paper 001 (eq. 22, closed
        geodesic distance, seeds on both curves) is
        :func:`elastic_motion.closed_curves.match_closed`.
    seeds : {"both", "q1"}
        Closed curves: ``"both"`` (default) searches seeds on the break points of both
        curves (q1 against q0, and q0 against q1 turned into a seed and warp of q1 exactly
        by :func:`elastic_motion.warp.swap_closed_match`) and keeps the lower objective, so
        that swapping the curves gives the same energy up to the grid; ``"q1"``: only on q1's.
    coarse_to_fine : bool
        Banded DP for long curves: solve on merged cells (down to 100-200 cells), then only in a
        band of ``band`` range nodes around the upsampled warp.  Faster, not exact: the
        benchmark reports its energy loss.
    band : int, optional
        Half-width of the band (default ``2 * max step``).
    tol : float
        Refinement: stop when the energy decreases by less than ``tol`` (relative) per
        iteration, averaged over 5 iterations.
    max_iter : int
        Refinement: maximal number of iterations.
    options : WarpOptions, optional
        Fills ``method``, ``neighbourhood`` and ``coarse_to_fine`` from
        :meth:`WarpOptions.solver_kwargs` (its ``landmark_weight`` is relative and its
        ``sample_fps`` concerns motions: neither is used here, pass ``lam`` yourself, e.g.
        ``options.absolute_landmark_weight(...)``).  An explicit keyword that *disagrees* with
        ``options`` is an error (no silent precedence); one that agrees is accepted.
        ``options.method == "none"`` is an error (the identity needs no solver).

    Returns
    -------
    WarpResult

    Raises
    ------
    ValueError
        Bad shapes, NaN, mismatched dimensions, landmarks outside ``[0, 1]`` or crossing,
        hard windows that no warp on the grid can meet.

    Notes
    -----
    DP cost: ``O(nu nv sum_(a,b) (a + b))`` edge work in the worst case (the cross term of
    an edge walks the cells it crosses, with the Gram matrix ``G = q0 q1^T`` computed once:
    ``O(n0 n1 D)``), much less in practice thanks to an exact pruning bound.  Memory
    ``O(nu nv)``.  For many pairs on uniform grids, :func:`dp_energies` runs the same DP
    without the Python work of a call per pair (about 0.3 ms of each call at 64 cells).
    """
    t_start = time.perf_counter()
    method, neighbourhood, coarse_to_fine = _resolve_options(options, method, neighbourhood, coarse_to_fine)
    q0a, t0a, q1a, t1a = check_pair(q0, q1, t0, t1)
    if method not in ("dp", "dp+refine", "refine"):
        raise ValueError(f"method: expected 'dp', 'dp+refine' or 'refine'; got {method!r}")
    steps = _as_steps(neighbourhood)
    max_step = int(steps.max())
    grid_a = None if grid is None else _check_grid(grid, t0a, t1a)
    if closed and grid_a is not None:
        raise ValueError("grid: a custom DP grid is not supported with closed=True")
    if coarse_to_fine and grid_a is not None:
        raise ValueError("coarse_to_fine: needs the default grid (grid=None)")
    band_w = 2 * max_step if band is None else int(band)
    if band_w < 1:
        raise ValueError(f"band: expected a half-width >= 1; got {band!r}")
    if not (np.isfinite(tol) and tol >= 0):
        raise ValueError(f"tol: expected a relative tolerance >= 0; got {tol!r}")
    lm = as_landmarks(landmarks)
    spec = make_penalty(penalty, lam, windows, len(lm)) if lm is not None else None
    lmd = _LandmarkData(lm, spec, bool(symmetric))

    if seeds not in ("both", "q1"):
        raise ValueError(f"seeds: expected 'both' or 'q1'; got {seeds!r}")
    lm_orig, q1_orig, t1_orig = lm, q1a, t1a
    seed_shift = 0.0
    n_seeds = 0
    if closed:
        s, n_seeds = _seed_search(q0a, t0a, q1a, t1a, steps, lmd)
        seed_shift = float(t1a[s])
        q1a, t1a = _roll(q1a, t1a, s)
        shifted = _shifted_landmarks(lmd, seed_shift)
        if shifted is None:
            raise ValueError("landmarks: no seed shift of the closed curve q1 keeps the pairs in order")
        lmd = shifted
        lm = lmd.lm

    if grid_a is None and not closed and not coarse_to_fine:
        grid_a = _reachable_grid(t0a, t1a, max_step)
    nu = len(t0a) - 1 if grid_a is None else len(grid_a[0]) - 1
    nv = len(t1a) - 1 if grid_a is None else len(grid_a[1]) - 1
    if method in ("dp", "dp+refine") and not coarse_to_fine:
        # bounded before allocation (the DP table holds (nu + 1) (nv + 1) nodes)
        limits.check_option(
            "sample_fps",
            f"a time-warp table of {nu + 1} x {nv + 1} nodes (lower the frame rate of the curves, or "
            "use the coarse-to-fine DP) of",
            (nu + 1) * (nv + 1),
            "max_dp_nodes",
        )
    energy_dp = float("nan")
    nodes = 0
    levels = 0
    time_dp = 0.0
    if method in ("dp", "dp+refine"):
        t = time.perf_counter()
        out = _solve_dp(q0a, t0a, q1a, t1a, grid_a, steps, lmd, bool(coarse_to_fine), band_w)
        time_dp = time.perf_counter() - t
        if not np.isfinite(out.value):
            if lm is None:
                raise ValueError(
                    f"neighbourhood: no increasing warp on the DP grid of {nu} x {nv} cells reaches (1, 1) "
                    f"with slopes between 1/{max_step} and {max_step}; give a finer grid or a richer "
                    "neighbourhood"
                )
            raise ValueError(
                "landmarks: no warp on the DP grid meets the hard windows; widen `windows`, "
                "use a finer grid or a richer neighbourhood"
            )
        vertices = out.vertices
        nodes, levels = out.nodes, out.levels
    else:
        vertices = np.array([[0.0, 0.0], [1.0, 1.0]])

    def score(v: np.ndarray) -> tuple[float, float]:
        el = float(_dp.energy_direct(q0a, t0a, q1a, t1a, kernel_array(v[:, 0]), kernel_array(v[:, 1])))
        lc = _landmark_cost(v, lm, spec, lmd.symmetric) if lm is not None and spec is not None else 0.0
        return el, lc

    el, lc = score(vertices)
    if method in ("dp", "dp+refine"):
        energy_dp = el + lc
    iterations, stop, time_ref = 0, "", 0.0
    if method in ("dp+refine", "refine"):
        t = time.perf_counter()
        pb = _Problem(q0a, t0a, q1a, t1a, t0a, t1a)
        ref = refine_warp(
            t0a,
            t1a,
            pb.G,
            pb.A_tot,
            pb.B_tot,
            vertices,
            landmarks=lmd.lm,
            spec=spec,
            symmetric=lmd.symmetric,
            tol=tol,
            max_iter=max_iter,
        )
        iterations, stop = ref.iterations, ref.stop
        el_r, lc_r = score(ref.vertices)
        # by construction: keep the refined warp only if its exact energy is not higher
        if el_r + lc_r <= el + lc:
            vertices, el, lc = ref.vertices, el_r, lc_r
        time_ref = time.perf_counter() - t
    seed_from = "q1" if closed else ""
    if closed and seeds == "both":
        swapped = _swapped_seed_candidate(
            q0a,
            t0a,
            q1_orig,
            t1_orig,
            lm_orig,
            spec,
            bool(symmetric),
            dict(
                method=method,
                neighbourhood=neighbourhood,
                lam=lam,
                penalty=penalty,
                windows=windows,
                symmetric=symmetric,
                coarse_to_fine=coarse_to_fine,
                band=band,
                tol=tol,
                max_iter=max_iter,
            ),
        )
        if swapped is not None:
            n_seeds += swapped[4]
            if swapped[2] + swapped[3] < el + lc:
                seed_shift, vertices, el, lc = swapped[0], swapped[1], swapped[2], swapped[3]
                seed_from = "q0"
    phi = np.interp(t0a, vertices[:, 0], vertices[:, 1])
    diag = WarpDiagnostics(
        method=method,
        grid_shape=(nu + 1, nv + 1),
        n_steps=int(steps.shape[0]),
        max_step=max_step,
        nodes_evaluated=nodes,
        levels=levels,
        band=band_w if levels > 1 else 0,
        energy_dp=energy_dp,
        iterations=iterations,
        refine_stop=stop,
        seeds_tried=n_seeds,
        time_dp=time_dp,
        time_refine=time_ref,
        time_total=time.perf_counter() - t_start,
        seed_from=seed_from,
    )
    vertices = check_vertices(vertices)
    return WarpResult(
        vertices=vertices,
        t=t0a,
        phi=phi,
        energy=el + lc,
        distance=math.sqrt(max(el, 0.0)),
        landmark_cost=lc,
        diagnostics=diag,
        seed_shift=seed_shift,
    )


def _swapped_seed_candidate(q0, t0, q1, t1, lm, spec, symmetric, kw):
    """Closed curves: solve q0 against q1 (seeds on q0's breaks) and express the match as a
    seed and warp of q1 (:func:`swap_closed_match`), scored by the objective of q1 onto q0.

    Returns ``(tau, vertices, elastic energy, landmark cost, seed solves)`` or None.
    """
    lm_sw = None if lm is None else lm.swapped()
    try:
        res = optimal_warp(q1, q0, t0=t1, t1=t0, landmarks=lm_sw, closed=True, seeds="q1", **kw)
        tau, verts = swap_closed_match(res.vertices, res.seed_shift)
    except ValueError:
        return None  # a flat piece (no inverse) or landmarks no seed of q0 meets
    lms = lm
    if lm is not None and len(lm) and tau != 0.0:
        try:
            lms = Landmarks(lm.theta0.copy(), (lm.theta1 - tau) % 1.0)
        except ValueError:
            return None
    q1s, t1s = shift_seed(q1, t1, tau)
    el = float(_dp.energy_direct(q0, t0, q1s, t1s, kernel_array(verts[:, 0]), kernel_array(verts[:, 1])))
    lc = _landmark_cost(verts, lms, spec, symmetric) if lms is not None and spec is not None else 0.0
    return tau, verts, el, lc, res.diagnostics.seeds_tried


def _resolve_options(
    options: WarpOptions | None, method: Any, neighbourhood: Any, coarse_to_fine: Any
) -> tuple[Any, Any, bool]:
    """``(method, neighbourhood, coarse_to_fine)`` from the keywords and ``options``."""
    explicit = {"method": method, "neighbourhood": neighbourhood, "coarse_to_fine": coarse_to_fine}
    if options is not None:
        if not isinstance(options, WarpOptions):
            raise ValueError(f"options: expected a WarpOptions or None; got {type(options).__name__}")
        if options.method == "none":
            raise ValueError("options: method 'none' has no solver (the identity warp needs no optimal_warp)")
        for key, value in options.solver_kwargs().items():
            given = explicit[key]
            if given is None:
                explicit[key] = value
                continue
            same = (
                bool(np.array_equal(np.asarray(given), np.asarray(value)))
                if key == "neighbourhood"
                else given == value
            )
            if not same:
                raise ValueError(
                    f"{key}: {given!r} given both explicitly and as options.{key} = {value!r}; "
                    f"pass one of them"
                )
    m = DEFAULT_METHOD if explicit["method"] is None else explicit["method"]
    nb = DEFAULT_MAX_STEP if explicit["neighbourhood"] is None else explicit["neighbourhood"]
    c2f = False if explicit["coarse_to_fine"] is None else bool(explicit["coarse_to_fine"])
    return m, nb, c2f


#: Rows of the DP grid whose cross terms the batched kernel computes together.
BATCH_BLOCK_ROWS = 4


def _as_stack(q: Any, name: str) -> np.ndarray:
    """``(M, n, D)`` float64, C-contiguous, finite: a stack or a sequence of equal-shape arrays."""
    if isinstance(q, np.ndarray):
        arr = q
    else:
        arr = np.stack([np.asarray(x, dtype=np.float64) for x in q]) if len(q) else np.zeros((0, 1, 1))
    arr = kernel_array(arr)
    if arr.ndim != 3 or arr.shape[1] < 1 or arr.shape[2] < 1:
        raise ValueError(
            f"{name}: expected SRV arrays of one shape, stacked as (M, n, D); got shape {arr.shape}"
        )
    if not np.isfinite(arr).all():
        raise ValueError(f"{name}: expected finite values; got NaN or inf")
    return arr


def dp_energies(
    q0: Any,
    q1: Any,
    pairs: Any,
    *,
    neighbourhood: int | Any | None = None,
) -> np.ndarray:
    """DP energies of many pairs of SRV arrays on uniform grids, in one compiled call.

    ``dp_energies(q0, q1, pairs)[p]`` is ``optimal_warp(q0[a], q1[b], method="dp",
    neighbourhood=m).energy`` for ``(a, b) = pairs[p]``: the same DP (same grid, slopes, edge
    costs and tie-breaking), the exact energy of its warp, without the Python work of one
    call per pair. Pairs are shared among numba's threads (``numba.set_num_threads``); the
    result does not depend on their number.

    Parameters
    ----------
    q0 : array_like, shape (M0, n0, D), or a sequence of M0 arrays of shape (n0, D)
        SRV arrays (cell values) on ``linspace(0, 1, n0 + 1)``.
    q1 : array_like, shape (M1, n1, D), or a sequence of arrays of shape (n1, D)
        The curves that are warped, on ``linspace(0, 1, n1 + 1)``; same D.
    pairs : array_like of int, shape (P, 2)
        ``(index into q0, index into q1)``.
    neighbourhood : int or array_like of shape (K, 2), default 10
        DP slopes, as in :func:`optimal_warp`.

    Returns
    -------
    ndarray, shape (P,)
        Energies ``||q0 - q1 * phi||^2`` of the DP warps (the squared elastic distances the
        DP finds).

    Raises
    ------
    ValueError
        Bad shapes or indices, NaN, different D, a DP table beyond ``limits.max_dp_nodes``.

    Notes
    -----
    Uniform grids, open curves, no landmarks: what a database of resampled motions needs.
    Memory per thread ``O((n0 + m) (n1 + m))``; time ``O(n0 n1 sum_(a,b) (a + b - 1))`` per
    pair (no pruning: on real motions at 64 cells the exact pruning removes little, see
    ``docs/warp.md``).  When ``n0`` and ``n1`` differ by more than ``m / 2`` times,
    :func:`optimal_warp` refines the coarser grid so that a path exists; those pairs are
    solved by it, one call each.
    """
    a0 = _as_stack(q0, "q0")
    a1 = _as_stack(q1, "q1")
    if a0.shape[2] != a1.shape[2]:
        raise ValueError(f"q1: expected the dimension D = {a0.shape[2]} of q0; got {a1.shape[2]}")
    pr = np.asarray(pairs)
    if pr.size == 0:
        return np.zeros(0)
    if pr.ndim != 2 or pr.shape[1] != 2 or not np.issubdtype(pr.dtype, np.integer):
        raise ValueError(f"pairs: expected integer indices of shape (P, 2); got {pr.dtype} {pr.shape}")
    i0s = kernel_array(pr[:, 0], np.int64)
    i1s = kernel_array(pr[:, 1], np.int64)
    for name, idx, m in (("pairs[:, 0]", i0s, len(a0)), ("pairs[:, 1]", i1s, len(a1))):
        if idx.min() < 0 or idx.max() >= m:
            raise ValueError(f"{name}: expected indices in [0, {m}); got {idx.min()} .. {idx.max()}")
    steps = _as_steps(DEFAULT_MAX_STEP if neighbourhood is None else neighbourhood)
    n0, n1 = a0.shape[1], a1.shape[1]
    t0, t1 = np.linspace(0.0, 1.0, n0 + 1), np.linspace(0.0, 1.0, n1 + 1)
    if _reachable_grid(t0, t1, int(steps.max())) is not None:
        return np.array(
            [
                optimal_warp(a0[a], a1[b], method="dp", neighbourhood=steps).energy
                for a, b in zip(i0s, i1s, strict=True)
            ]
        )
    limits.check_option(
        "n_samples",
        "a time-warp table (fewer samples per curve) of",
        (n0 + 1) * (n1 + 1),
        "max_dp_nodes",
    )
    taps = _tap_pattern(tuple(map(tuple, steps.tolist())), n0, n1)
    import numba

    kernel = _dp.dp_energies_uniform if numba.get_num_threads() > 1 else _dp.dp_energies_uniform_serial
    energy, _ = kernel(a0, a1, i0s, i1s, steps, taps, BATCH_BLOCK_ROWS)
    return energy


def identity_energy(q0: Any, q1: Any, t0: Any = None, t1: Any = None) -> float:
    """``||q0 - q1||^2`` (the energy of the identity warp); equal grids not required."""
    q0a, t0a, q1a, t1a = check_pair(q0, q1, t0, t1)
    if np.array_equal(t0a, t1a):
        return srv_norm2(q0a - q1a, t0a)
    return float(_dp.energy_direct(q0a, t0a, q1a, t1a, np.array([0.0, 1.0]), np.array([0.0, 1.0])))
