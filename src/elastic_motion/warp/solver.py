"""The optimal-warp solver: dynamic programming, gradient refinement, closed curves.

:func:`optimal_warp` runs its stages in order: the options (:class:`WarpSolverOptions`), the
seed of closed curves (:mod:`elastic_motion.warp.seeds`), the DP on its grid
(:mod:`elastic_motion.warp.dp`), the refinement off the grid
(:mod:`elastic_motion.warp.refine`), and for closed curves the seeds of the swapped pair.
:func:`dp_energies` runs the DP of many pairs in one compiled call. See
:mod:`elastic_motion.warp` for the conventions and ``docs/warp.md`` for the method, its
complexity and measured numbers.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numba
import numpy as np

from elastic_motion import limits
from elastic_motion.warp import dp_kernels
from elastic_motion.warp.dp import (
    DPPlan,
    DPProblem,
    LandmarkTables,
    as_steps,
    coprime_steps,
    reachable_grid,
    solve_dp,
    tap_pattern,
)
from elastic_motion.warp.energy import (
    check_pair,
    check_vertices,
    kernel_array,
    shift_seed,
    srv_norm2,
    swap_closed_match,
)
from elastic_motion.warp.landmarks import Landmarks, as_landmarks, make_penalty
from elastic_motion.warp.options import (
    DEFAULT_MAX_STEP,
    WarpOptions,
    WarpSolverOptions,
    solver_options,
)
from elastic_motion.warp.refine import refine_warp
from elastic_motion.warp.seeds import roll_cells, seed_search, shifted_landmarks

__all__ = [
    "WarpDiagnostics",
    "WarpResult",
    "coprime_steps",
    "dp_energies",
    "identity_energy",
    "optimal_warp",
]


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


# ----------------------------------------------------------------------------- optimal_warp


def optimal_warp(
    q0: Any,
    q1: Any,
    options: WarpSolverOptions | WarpOptions | None = None,
    *,
    t0: Any = None,
    t1: Any = None,
    landmarks: Landmarks | Any | None = None,
    **overrides: Any,
) -> WarpResult:
    """Optimal warp ``phi`` minimising ``||q0 - q1 * phi||^2 + lam * FM`` (paper 001, eq. 21).

    Parameters
    ----------
    q0 : array_like, shape (n0, D)
        SRV array of curve 0 (cell-valued on ``t0``), in an orthonormal basis: any D, so
        one solver serves ``R^d`` and Lie-group curves.
    q1 : array_like, shape (n1, D)
        SRV array of curve 1 (the curve that is warped), on ``t1``; n1 may differ from n0.
    options : WarpSolverOptions or WarpOptions, optional
        How the warp is found and how the landmarks are penalised (:class:`WarpSolverOptions`).
        The app-level :class:`WarpOptions` fills ``method``, ``neighbourhood`` and
        ``coarse_to_fine`` (not ``lam``: pass ``options.absolute_landmark_weight(...)``); a
        keyword that *disagrees* with it is an error, one that agrees is accepted
        (:func:`~elastic_motion.warp.options.solver_options`).
    t0, t1 : array_like, shapes (n0+1,), (n1+1,), optional
        Strictly increasing break points from 0 to 1; uniform when omitted.
    landmarks : Landmarks or array_like of shape (M, 2), optional
        Feature pairs ``(theta0_m, theta1_m)`` (see :class:`Landmarks`).
    **overrides
        Fields of :class:`WarpSolverOptions` (``optimal_warp(q0, q1, method="dp", lam=2.0)``);
        an unknown one is an error naming it.

    Returns
    -------
    WarpResult

    Raises
    ------
    ValueError
        Bad shapes, NaN, mismatched dimensions, landmarks outside ``[0, 1]`` or crossing,
        hard windows that no warp on the grid can meet, bad options (``OptionError``).

    Notes
    -----
    DP cost: ``O(nu nv sum_(a,b) (a + b))`` edge work in the worst case (the cross term of
    an edge walks the cells it crosses, with the Gram matrix ``G = q0 q1^T`` computed once:
    ``O(n0 n1 D)``), much less in practice thanks to an exact pruning bound.  Memory
    ``O(nu nv)``.  For many pairs on uniform grids, :func:`dp_energies` runs the same DP
    without the Python work of a call per pair (about 0.3 ms of each call at 64 cells).
    """
    t_start = time.perf_counter()
    opts = solver_options(options, overrides)
    q0a, t0a, q1a, t1a = check_pair(q0, q1, t0, t1)
    steps = as_steps(opts.neighbourhood)
    lm = as_landmarks(landmarks)
    spec = make_penalty(opts.penalty, opts.lam, opts.windows, len(lm)) if lm is not None else None
    original = _Pair(q0a, t0a, q1a, t1a, LandmarkTables(lm, spec, opts.symmetric))
    pair, seed_shift, n_seeds = _closed_seed(original, steps) if opts.closed else (original, 0.0, 0)
    dp = _dp_stage(pair, opts, steps)
    el, lc = pair.score(dp.vertices)
    energy_dp = el + lc if opts.method in ("dp", "dp+refine") else float("nan")
    ref = _refine_stage(pair, dp, (el, lc), opts)
    vertices, el, lc = ref.vertices, ref.elastic, ref.landmark
    seed_from = "q1" if opts.closed else ""
    if opts.closed and opts.seeds == "both":
        swapped = _swapped_seed_candidate(original, opts)
        if swapped is not None:
            n_seeds += swapped[4]
            if swapped[2] + swapped[3] < el + lc:
                seed_shift, vertices, el, lc = swapped[0], swapped[1], swapped[2], swapped[3]
                seed_from = "q0"
    diag = WarpDiagnostics(
        method=opts.method,
        grid_shape=dp.grid_shape,
        n_steps=int(steps.shape[0]),
        max_step=int(steps.max()),
        nodes_evaluated=dp.nodes,
        levels=dp.levels,
        band=opts.band_width(int(steps.max())) if dp.levels > 1 else 0,
        energy_dp=energy_dp,
        iterations=ref.iterations,
        refine_stop=ref.stop,
        seeds_tried=n_seeds,
        time_dp=dp.seconds,
        time_refine=ref.seconds,
        time_total=time.perf_counter() - t_start,
        seed_from=seed_from,
    )
    return WarpResult(
        vertices=check_vertices(vertices),
        t=t0a,
        phi=np.interp(t0a, vertices[:, 0], vertices[:, 1]),
        energy=el + lc,
        distance=math.sqrt(max(el, 0.0)),
        landmark_cost=lc,
        diagnostics=diag,
        seed_shift=seed_shift,
    )


@dataclass(frozen=True)
class _Pair:
    """The two checked SRV arrays of a solve (q1 with its seed) and the landmark term."""

    q0: np.ndarray
    t0: np.ndarray
    q1: np.ndarray
    t1: np.ndarray
    lmd: LandmarkTables

    def score(self, v: np.ndarray) -> tuple[float, float]:
        """The exact elastic energy and landmark cost of the warp with vertices ``v``."""
        el = float(
            dp_kernels.energy_direct(
                self.q0, self.t0, self.q1, self.t1, kernel_array(v[:, 0]), kernel_array(v[:, 1])
            )
        )
        lm, spec = self.lmd.lm, self.lmd.spec
        lc = spec.cost(v, lm, self.lmd.symmetric) if lm is not None and spec is not None else 0.0
        return el, lc


def _closed_seed(pair: _Pair, steps: np.ndarray) -> tuple[_Pair, float, int]:
    """Closed curves: q1 started at its best seed (:func:`seed_search`), the landmarks moved with
    it; returns the pair, the seed and the number of DP solves."""
    s, n_seeds = seed_search(pair.q0, pair.t0, pair.q1, pair.t1, steps, pair.lmd)
    seed_shift = float(pair.t1[s])
    q1, t1 = roll_cells(pair.q1, pair.t1, s)
    shifted = shifted_landmarks(pair.lmd, seed_shift)
    if shifted is None:
        raise ValueError("landmarks: no seed shift of the closed curve q1 keeps the pairs in order")
    return _Pair(pair.q0, pair.t0, q1, t1, shifted), seed_shift, n_seeds


@dataclass(frozen=True)
class _DPStage:
    vertices: np.ndarray
    grid_shape: tuple[int, int]
    nodes: int
    levels: int
    seconds: float
    problem: DPProblem | None = None


def _dp_stage(pair: _Pair, opts: WarpSolverOptions, steps: np.ndarray) -> _DPStage:
    """The DP's warp (the identity for ``method="refine"``) on its grid: the given one, or the
    break points, refined when no path of the slopes joins the corners (:func:`reachable_grid`);
    the table's size is bounded before it is allocated."""
    max_step = int(steps.max())
    grid = opts.grid
    if grid is None and not opts.closed and not opts.coarse_to_fine:
        grid = reachable_grid(pair.t0, pair.t1, max_step)
    nu = len(pair.t0) - 1 if grid is None else len(grid[0]) - 1
    nv = len(pair.t1) - 1 if grid is None else len(grid[1]) - 1
    if opts.method == "refine":
        return _DPStage(np.array([[0.0, 0.0], [1.0, 1.0]]), (nu + 1, nv + 1), 0, 0, 0.0)
    if not opts.coarse_to_fine:
        # bounded before allocation (the DP table holds (nu + 1) (nv + 1) nodes)
        limits.check_option(
            "sample_fps",
            f"a time-warp table of {nu + 1} x {nv + 1} nodes (lower the frame rate of the curves, or "
            "use the coarse-to-fine DP) of",
            (nu + 1) * (nv + 1),
            "max_dp_nodes",
        )
    t = time.perf_counter()
    plan = DPPlan(steps, opts.coarse_to_fine, opts.band_width(max_step))
    out = solve_dp(pair.q0, pair.t0, pair.q1, pair.t1, pair.lmd, plan, grid)
    seconds = time.perf_counter() - t
    if not np.isfinite(out.value):
        if pair.lmd.lm is None:
            raise ValueError(
                f"neighbourhood: no increasing warp on the DP grid of {nu} x {nv} cells reaches (1, 1) "
                f"with slopes between 1/{max_step} and {max_step}; give a finer grid or a richer "
                "neighbourhood"
            )
        raise ValueError(
            "landmarks: no warp on the DP grid meets the hard windows; widen `windows`, "
            "use a finer grid or a richer neighbourhood"
        )
    return _DPStage(out.vertices, (nu + 1, nv + 1), out.nodes, out.levels, seconds, out.problem)


@dataclass(frozen=True)
class _RefineStage:
    vertices: np.ndarray
    elastic: float
    landmark: float
    iterations: int = 0
    stop: str = ""
    seconds: float = 0.0


def _refine_stage(
    pair: _Pair, dp: _DPStage, scored: tuple[float, float], opts: WarpSolverOptions
) -> _RefineStage:
    """The refinement off the grid (``"dp+refine"``, ``"refine"``) from the DP's warp, kept only
    when its exact energy is not higher than the start's (``scored``: elastic energy, landmark
    cost). The Gram matrix of the pair is the DP's when it has one (same curves)."""
    el, lc = scored
    vertices = dp.vertices
    if opts.method not in ("dp+refine", "refine"):
        return _RefineStage(vertices, el, lc)
    t = time.perf_counter()
    pb = dp.problem
    if pb is None:
        pb = DPProblem(pair.q0, pair.t0, pair.q1, pair.t1, pair.t0, pair.t1)
    ref = refine_warp(pb, vertices, pair.lmd, tol=opts.tol, max_iter=opts.max_iter)
    el_r, lc_r = pair.score(ref.vertices)
    # by construction: keep the refined warp only if its exact energy is not higher
    if el_r + lc_r <= el + lc:
        vertices, el, lc = ref.vertices, el_r, lc_r
    return _RefineStage(vertices, el, lc, ref.iterations, ref.stop, time.perf_counter() - t)


def _swapped_seed_candidate(pair: _Pair, opts: WarpSolverOptions) -> tuple | None:
    """Closed curves: solve q0 against q1 (seeds on q0's breaks) and express the match as a
    seed and warp of q1 (:func:`swap_closed_match`), scored by the objective of q1 onto q0.

    Returns ``(tau, vertices, elastic energy, landmark cost, seed solves)`` or None.
    """
    lm, spec = pair.lmd.lm, pair.lmd.spec
    lm_sw = None if lm is None else lm.swapped()
    try:
        res = optimal_warp(
            pair.q1, pair.q0, opts.replace(seeds="q1"), t0=pair.t1, t1=pair.t0, landmarks=lm_sw
        )
        tau, verts = swap_closed_match(res.vertices, res.seed_shift)
    except ValueError:
        return None  # a flat piece (no inverse) or landmarks no seed of q0 meets
    lms = lm
    if lm is not None and len(lm) and tau != 0.0:
        try:
            lms = Landmarks(lm.theta0.copy(), (lm.theta1 - tau) % 1.0)
        except ValueError:
            return None
    q1s, t1s = shift_seed(pair.q1, pair.t1, tau)
    el, lc = _Pair(pair.q0, pair.t0, q1s, t1s, LandmarkTables(lms, spec, pair.lmd.symmetric)).score(verts)
    return tau, verts, el, lc, res.diagnostics.seeds_tried


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
    steps = as_steps(DEFAULT_MAX_STEP if neighbourhood is None else neighbourhood)
    n0, n1 = a0.shape[1], a1.shape[1]
    t0, t1 = np.linspace(0.0, 1.0, n0 + 1), np.linspace(0.0, 1.0, n1 + 1)
    if reachable_grid(t0, t1, int(steps.max())) is not None:
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
    taps = tap_pattern(tuple(map(tuple, steps.tolist())), n0, n1)
    kernel = (
        dp_kernels.dp_energies_uniform
        if numba.get_num_threads() > 1
        else dp_kernels.dp_energies_uniform_serial
    )
    energy, _ = kernel(a0, a1, i0s, i1s, steps, taps, BATCH_BLOCK_ROWS)
    return energy


def identity_energy(q0: Any, q1: Any, t0: Any = None, t1: Any = None) -> float:
    """``||q0 - q1||^2`` (the energy of the identity warp); equal grids not required."""
    q0a, t0a, q1a, t1a = check_pair(q0, q1, t0, t1)
    if np.array_equal(t0a, t1a):
        return srv_norm2(q0a - q1a, t0a)
    return float(dp_kernels.energy_direct(q0a, t0a, q1a, t1a, np.array([0.0, 1.0]), np.array([0.0, 1.0])))
