"""Pair distances and tiles of pairs: the numerical work, run in-process or on Dask workers.

Rule (the same in every engine and tiling, so results agree bit for bit): only ``i < j`` is
computed, always with the lower index as ``q0`` (the curve warped is ``q_j``), and mirrored;
the diagonal is 0; motions of different skeleton groups are not compared (``+inf``). For the
DP on a common uniform grid with a slope set symmetric in ``(a, b)`` (the default) swapping
the curves gives the same minimum up to rounding (the inverse of a grid path is a grid path
and ``||q0 - q1 * phi|| = ||q1 - q0 * phi^-1||``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numba
import numpy as np

from elastic_motion._threads import single_threaded_blas
from elastic_motion.apps.database.settings import DEFAULT_WARP
from elastic_motion.apps.progress import Progress
from elastic_motion.errors import OptionError
from elastic_motion.warp import WarpOptions, coprime_steps, optimal_warp
from elastic_motion.warp.solver import dp_energies

__all__ = [
    "cluster_worth_it",
    "compute_tile",
    "distance_matrix",
    "estimated_serial_seconds",
    "pair_distance",
    "pair_distances",
    "single_threaded_blas",
    "tile_blocks",
    "tile_problem",
]


def pair_distance(
    q0: np.ndarray, q1: np.ndarray, warp: WarpOptions = DEFAULT_WARP, *, cyclic: bool = False
) -> float:
    """Distance of two SRV arrays on the same uniform grid.

    Parameters
    ----------
    q0, q1 : ndarray, shape (n, D)
        Cell values on ``linspace(0, 1, n + 1)`` (orthonormal coordinates).
    warp : WarpOptions, default :data:`~elastic_motion.apps.database.settings.DEFAULT_WARP`
        ``method``, ``neighbourhood`` and ``coarse_to_fine`` are used.
    cyclic : bool, default False
        Phase-free: the least distance over the ``n`` cyclic shifts of either array's cells
        (:func:`pair_distances`; the DP alone).

    Returns
    -------
    float
        ``method="dp"`` (or ``"dp+refine"``): ``optimal_warp(q0, q1).distance`` =
        ``min_phi ||q0 - q1 * phi||`` over the solver's warps; ``method="none"``:
        ``||q0 - q1||_L2`` (``sqrt(mean_i |q0_i - q1_i|^2)``, paper 000, eq. 4). The DP
        value never exceeds the ``"none"`` one (the identity is a DP path). The DP alone
        (``method="dp"``, no coarse to fine) runs in the batched kernel of
        :func:`pair_distances` (same DP, same numbers as one call per pair).
    """
    if cyclic:
        return float(pair_distances([q0], [q1], np.zeros((1, 2), dtype=np.int64), warp, cyclic=True)[0])
    if warp.method == "none":
        d = q0 - q1
        return float(math.sqrt(np.einsum("ij,ij->", d, d) / q0.shape[0]))
    if _batched(warp):
        return float(pair_distances([q0], [q1], np.zeros((1, 2), dtype=np.int64), warp)[0])
    return float(optimal_warp(q0, q1, **warp.solver_kwargs()).distance)


def _batched(warp: WarpOptions) -> bool:
    """Whether pairs of this warp run in the batched DP kernel (the DP alone, exact)."""
    return warp.method == "dp" and not warp.coarse_to_fine


def pair_distances(
    q0: Sequence[np.ndarray],
    q1: Sequence[np.ndarray],
    pairs: np.ndarray,
    warp: WarpOptions = DEFAULT_WARP,
    *,
    cyclic: bool = False,
) -> np.ndarray:
    """Distances of many pairs ``(q0[a], q1[b])`` for ``(a, b)`` in ``pairs``, as :func:`pair_distance`.

    Parameters
    ----------
    q0, q1 : sequences of ndarray, shapes (n, D)
        SRV arrays on uniform grids (arrays of one shape are solved together).
    pairs : ndarray of int, shape (P, 2)
        ``(index into q0, index into q1)``; both arrays of a pair have the same D.
    warp : WarpOptions
    cyclic : bool, default False
        Phase-free matching (``DatabaseSettings.cyclic``): ``min_s min(d(q0, roll(q1, s)),
        d(q1, roll(q0, s)))`` over the ``n`` cyclic shifts ``s`` of the cells (``np.roll``
        along time), with the exact DP of every shift in the batched kernel (``2 n`` times the
        cost of a pair). Symmetric in the two arrays; never above the distance without shifts
        (``s = 0``). Needs ``warp.method == "dp"`` without coarse to fine.

    Returns
    -------
    ndarray, shape (P,)
        ``pair_distance(q0[a], q1[b], warp)`` for each pair. With ``method="dp"`` (no coarse
        to fine) the pairs of each shape go to
        :func:`elastic_motion.warp.solver.dp_energies` in one compiled call (numba's threads
        share them; the numbers do not depend on how pairs are grouped or on the threads);
        otherwise one :func:`pair_distance` per pair.
    """
    pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    out = np.empty(len(pairs))
    if cyclic and not _batched(warp):
        raise OptionError(
            "cyclic",
            f"phase-free matching needs the DP alone (warp 'dp', no coarse to fine); got {warp.method!r}"
            + (" with coarse to fine" if warp.coarse_to_fine else ""),
        )
    if not _batched(warp):
        for p, (a, b) in enumerate(pairs):
            out[p] = pair_distance(q0[a], q1[b], warp)
        return out
    by_shape: dict[tuple, list[int]] = {}
    for p, (a, b) in enumerate(pairs):
        by_shape.setdefault((np.shape(q0[a]), np.shape(q1[b])), []).append(p)
    for idx in by_shape.values():
        sel = pairs[idx]
        ua, ia = np.unique(sel[:, 0], return_inverse=True)
        ub, ib = np.unique(sel[:, 1], return_inverse=True)
        a_arr = np.stack([q0[a] for a in ua])
        b_arr = np.stack([q1[b] for b in ub])
        ab = np.column_stack([ia.ravel(), ib.ravel()])
        e = dp_energies(a_arr, b_arr, ab, neighbourhood=warp.neighbourhood)
        if cyclic:
            ba = ab[:, ::-1].copy()
            for s in range(1, a_arr.shape[1]):
                e = np.minimum(
                    e, dp_energies(a_arr, np.roll(b_arr, s, axis=1), ab, neighbourhood=warp.neighbourhood)
                )
                e = np.minimum(
                    e, dp_energies(b_arr, np.roll(a_arr, s, axis=1), ba, neighbourhood=warp.neighbourhood)
                )
            e = np.minimum(e, dp_energies(b_arr, a_arr, ba, neighbourhood=warp.neighbourhood))
        out[idx] = np.sqrt(np.maximum(e, 0.0))
    return out


def compute_tile(
    rows: np.ndarray,
    cols: np.ndarray,
    q: Sequence[np.ndarray],
    g_rows: np.ndarray,
    g_cols: np.ndarray,
    warp: WarpOptions,
    *,
    cyclic: bool = False,
    numba_threads: int | None = None,
) -> np.ndarray:
    """Distances of one tile: motions ``rows`` against motions ``cols``.

    Parameters
    ----------
    rows, cols : ndarray of int, shapes (a,), (b,)
        Global motion indices.
    q : sequence of ndarray, shapes (n, D_k)
        SRV arrays of the motions, indexed by the global indices (``q[rows[r]]``, ``q[cols[c]]``;
        e.g. all the motions of the representation).
    g_rows, g_cols : ndarray of int, shapes (a,), (b,)
        Skeleton group of each motion of ``rows`` and ``cols``.
    warp : WarpOptions
    cyclic : bool, default False
        Phase-free matching (:func:`pair_distances`).
    numba_threads : int, optional
        Threads of numba's parallel DP inside this call (1 on single-threaded Dask
        workers, so two workers do not oversubscribe two cores). Results do not depend on it.

    Returns
    -------
    ndarray, shape (a, b), float64
        ``d(rows[r], cols[c])`` where ``rows[r] < cols[c]`` and the groups agree; 0 on the
        diagonal; ``+inf`` across groups; NaN where ``rows[r] > cols[c]`` (the mirrored
        entry is computed by the tile holding the pair with the lower index first).
    """
    if numba_threads is not None:
        numba.set_num_threads(max(1, min(int(numba_threads), numba.config.NUMBA_NUM_THREADS)))
    # one memory layout everywhere (arrays received from a Dask scheduler are read-only and
    # unaligned): the same compiled kernel runs in every engine, and it is the fast one
    q_rows = [np.require(q[i], np.float64, ["C", "A", "W"]) for i in rows]
    q_cols = [np.require(q[j], np.float64, ["C", "A", "W"]) for j in cols]
    out = np.full((len(rows), len(cols)), np.nan)
    rows = np.asarray(rows)
    cols = np.asarray(cols)
    g_rows = np.asarray(g_rows)
    g_cols = np.asarray(g_cols)
    upper = rows[:, None] < cols[None, :]
    out[rows[:, None] == cols[None, :]] = 0.0
    out[upper & (g_rows[:, None] != g_cols[None, :])] = np.inf
    todo = np.argwhere(upper & (g_rows[:, None] == g_cols[None, :]))
    if len(todo):
        with single_threaded_blas():
            out[todo[:, 0], todo[:, 1]] = pair_distances(q_rows, q_cols, todo, warp, cyclic=cyclic)
    return out


def tile_problem(
    tile: np.ndarray, rows: np.ndarray, cols: np.ndarray, g_rows: np.ndarray, g_cols: np.ndarray
) -> str | None:
    """Why ``tile`` cannot be what :func:`compute_tile` gives for ``rows`` x ``cols``; None if it can.

    Checks the layout of :func:`compute_tile` on the entries a matrix takes from a tile
    (``rows[r] <= cols[c]``): shape ``(a, b)`` float64, 0 on the diagonal, ``+inf`` across
    groups, finite and non-negative within a group. (A finite wrong value is for the tile's
    checksum to catch, :mod:`~elastic_motion.apps.database.verified`.)

    Parameters
    ----------
    tile : ndarray, shape (a, b)
    rows, cols, g_rows, g_cols : ndarray of int, shapes (a,), (b,), (a,), (b,)
        As for :func:`compute_tile`.

    Returns
    -------
    str or None
    """
    if tile.shape != (len(rows), len(cols)) or tile.dtype != np.float64:
        return f"expected a ({len(rows)}, {len(cols)}) float64 tile; got {tile.shape} {tile.dtype}"
    rows = np.asarray(rows)[:, None]
    cols = np.asarray(cols)[None, :]
    same = np.asarray(g_rows)[:, None] == np.asarray(g_cols)[None, :]
    within = tile[(rows < cols) & same]
    checks = [
        (tile[rows == cols], lambda v: v == 0.0, "on the diagonal not 0"),
        (within, np.isfinite, "distances not finite (NaN or infinite)"),
        (within, lambda v: ~(v < 0.0), "negative distances"),
        (tile[(rows < cols) & ~same], np.isposinf, "distances across skeleton groups not +inf"),
    ]
    for values, ok, what in checks:
        bad = int(np.count_nonzero(~ok(values)))
        if bad:
            return f"{bad} {what}"
    return None


def distance_matrix(
    q: Sequence[np.ndarray],
    warp: WarpOptions = DEFAULT_WARP,
    groups: Sequence[int] | None = None,
    *,
    cyclic: bool = False,
    progress: Progress | None = None,
) -> np.ndarray:
    """All-pairs distances of in-memory SRV arrays, serially (no files, no resume).

    Same rule as the tiled runs (module docstring), so the result equals theirs bit for bit.

    Parameters
    ----------
    q : sequence of ndarray, shapes (n, D_k)
    warp : WarpOptions, default ``DEFAULT_WARP`` (DP, neighbourhood 10)
    groups : sequence of int, optional
        Skeleton group per entry (default: all one group).
    cyclic : bool, default False
        Phase-free matching (:func:`pair_distances`).
    progress : callable, optional
        ``progress("pairs", rows done, M)``.

    Returns
    -------
    ndarray, shape (M, M)
    """
    m = len(q)
    g = np.zeros(m, dtype=np.int64) if groups is None else np.asarray(groups, dtype=np.int64)
    out = np.zeros((m, m))
    for i in range(m):
        idx = np.arange(i, m)
        row = compute_tile(np.array([i]), idx, q, g[[i]], g[idx], warp, cyclic=cyclic)
        out[i, i:] = row[0]
        out[i:, i] = row[0]
        if progress is not None:
            progress("pairs", i + 1, m)
    return out


def tile_blocks(n_motions: int, tile_size: int) -> list[tuple[int, int]]:
    """Upper-triangle block pairs ``(I, J)``, ``I <= J``, of an ``n_motions`` square split in
    blocks of ``tile_size``; block ``I`` holds motions ``I*tile_size .. (I+1)*tile_size - 1``."""
    nb = -(-n_motions // tile_size)
    return [(i, j) for i in range(nb) for j in range(i, nb)]


def block(i: int, tile_size: int, n_motions: int) -> np.ndarray:
    """Motion indices of block ``i`` (shape ``(<= tile_size,)``)."""
    return np.arange(i * tile_size, min((i + 1) * tile_size, n_motions))


#: Seconds to start a 2-worker Dask ``LocalCluster`` and load the kernels on it, measured on the
#: 2-core reference machine (38 clips: 10.1 s with ``--engine local`` against 4.0 s serial),
#: with spawned workers.
LOCAL_CLUSTER_STARTUP = 6.0
#: The same with workers forked from the driver (``engines.local_start_method``, Linux): what a
#: cluster costs beyond a serial run on the 2-core reference machine, fitted to runs in new
#: processes (``benchmarks/database_scale.py``, section ``small``, and 120 / 200 windows):
#: 40 windows (780 pairs) 1.5-1.6 s against 1.3 s serially, 80 windows 2.3-2.5 s against 2.5 s,
#: 120 windows 3.6-3.8 s against 4.2-4.3 s, 200 windows 7.2-7.3 s against 8.3-8.4 s. With
#: 1.2 s, 2 workers start from about 100 windows of 64 cells (neighbourhood 10).
LOCAL_CLUSTER_STARTUP_FORKED = 1.2
#: Seconds per DP pair at 64 cells with neighbourhood 6 on one core, batched kernel
#: (``benchmarks/database_scale.py``, section ``per_pair``: 0.175 ms; 0.48 ms with neighbourhood 10).
SECONDS_PER_PAIR_64 = 0.18e-3


def estimated_serial_seconds(n_pairs: int, n_samples: int, warp: WarpOptions = DEFAULT_WARP) -> float:
    """A rough single-core cost of ``n_pairs`` pair distances (for the engine choice, not a promise).

    ``SECONDS_PER_PAIR_64 * (n / 64)^2 * K(m) / K(6)`` per DP pair (``K(m)``: the number of
    coprime steps up to ``m``; the batched DP fills the whole ``n x n`` grid, and its measured
    cost grows like ``K(m)``: 0.175 ms at ``m = 6``, 0.48 ms at ``m = 10``); the refinement
    (``dp+refine``, one compiled refinement per pair) about 5 times that (4.7 measured on the
    benchmark's CMU windows at ``n = 64``), the coarse-to-fine DP (one ``optimal_warp`` call per
    pair) about 2.3 times; the no-warp distance ``1e-6 * n / 64`` s.
    """
    if warp.method == "none":
        return n_pairs * 1e-6 * n_samples / 64
    steps = len(coprime_steps(int(warp.neighbourhood))) / len(coprime_steps(6))
    per_pair = SECONDS_PER_PAIR_64 * (n_samples / 64) ** 2 * steps
    if warp.method != "dp":
        per_pair *= 5.0
    elif warp.coarse_to_fine:
        per_pair *= 2.3  # one optimal_warp call per pair (not batched)
    return n_pairs * per_pair


def cluster_worth_it(
    n_pairs: int,
    n_samples: int,
    warp: WarpOptions = DEFAULT_WARP,
    *,
    n_workers: int = 2,
    startup: float | None = None,
) -> tuple[bool, str]:
    """Whether a local Dask cluster would finish before a serial run; and the sentence to report.

    With ``W`` workers the cluster takes about ``startup + serial / W``; it wins when
    ``serial > startup * W / (W - 1)`` (``startup``: default :data:`LOCAL_CLUSTER_STARTUP`,
    spawned workers; :data:`LOCAL_CLUSTER_STARTUP_FORKED` for forked ones). For the engine of a
    matrix run (``engine="local"``): when this is False, run serially and report the sentence,
    so ``--engine local`` never loses to serial on small inputs.

    Returns
    -------
    (bool, str)
    """
    serial = estimated_serial_seconds(n_pairs, n_samples, warp)
    w = max(2, int(n_workers))
    startup = LOCAL_CLUSTER_STARTUP if startup is None else float(startup)
    limit = startup * w / (w - 1)
    if serial > limit:
        return True, f"local cluster of {w} workers: about {serial:.0f} s of pair work serially"
    return False, (
        f"local cluster not started: {n_pairs} pairs take about {serial:.1f} s serially, less than "
        f"the {startup:g} s a cluster needs to start (ran serially)"
    )
