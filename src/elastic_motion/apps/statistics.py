"""Statistics over motion databases: k-NN search and classification, Karcher mean, clustering.

Conventions
-----------
* A **distance matrix** is a symmetric float64 array ``(M, M)`` with zeros on the diagonal,
  as written by :mod:`elastic_motion.apps.database` (``+inf`` between motions of different
  skeleton groups; NaN = not computed, which the functions here refuse).
* **k-NN, leave one out**: motion ``i`` is classified by the majority label of its ``k``
  nearest other motions (finite distances only); a tie goes to the tied label whose
  nearest member is closest. With ``blocks`` (e.g. the source clip of each segment), the
  neighbours of ``i`` exclude its own block ("leave one clip out"), so segments of one
  recording cannot vote for each other.
* **Karcher mean** (:func:`karcher_mean`) of curves in one Lie group, in SRV space:
  ``mu = argmin sum_k w_k min_phi ||mu - q_k * phi||^2``, by alternating (i) the optimal warp of
  each ``q_k`` onto the current mean (:func:`elastic_motion.warp.optimal_warp`) and (ii) the
  weighted average of the aligned SRV functions (projected on the common grid). With the
  DP (``WarpOptions(method="dp")``, the default) each step does not increase the energy (the
  previous warp is a path of the next DP; the average is the L2 minimiser). The mean curve
  is reconstructed with :func:`elastic_motion.curves.weighted_blend` from the aligned inputs
  (start point: the group's weighted mean of the start points). The warps are not re-centred
  (fdasrsf's ``srsf_align`` re-centres them so their mean is the identity); the mean
  therefore keeps the time-parametrisation the iteration converges to.
* **Hierarchical clustering**: :func:`scipy.cluster.hierarchy.linkage` on the condensed
  matrix; ``+inf`` entries are replaced by twice the largest finite distance (so motions of
  different skeletons join last).

Numerical code prints nothing.
"""

from __future__ import annotations

import os
import re
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from elastic_motion.apps.progress import Progress
from elastic_motion.apps.report import jsonable
from elastic_motion.curves import (
    DiscreteCurve,
    SRVFunction,
    reparametrize_srv,
    srv_transform,
    weighted_blend,
)
from elastic_motion.errors import OptionError
from elastic_motion.warp import WarpOptions

if TYPE_CHECKING:
    from elastic_motion.motion import Motion

__all__ = [
    "CMU_CATEGORIES",
    "ClusterResult",
    "KarcherMeanResult",
    "KnnEvaluation",
    "MeanMotionResult",
    "bandai_labels",
    "cluster",
    "cmu_label",
    "dtw_matrix",
    "karcher_mean",
    "knn_evaluate",
    "mean_motion",
    "nearest",
]

#: Categories of the CMU trials in the project's test data (CMU database descriptions).
CMU_CATEGORIES = {
    "01_01": "jump",  # playground: climb, hang, jump
    "02_01": "walk",
    "07_01": "walk",
    "08_02": "walk",
    "09_11": "run",
    "107_02": "walk",  # walking with obstacles
    "108_01": "walk",
    "131_01": "walk",  # start, walk, stop
    "131_02": "walk",
    "131_03": "hop",
    "49_08": "cartwheel",
    "55_01": "dance",
}


# --------------------------------------------------------------------------------------------
# Labels
# --------------------------------------------------------------------------------------------

_BANDAI = re.compile(r"dataset-\d+_(?P<content>[a-z-]+)_(?P<style>[a-z-]+)_\d+", re.IGNORECASE)


def bandai_labels(name: str) -> tuple[str, str] | None:
    """``(content, style)`` from a Bandai-Namco file name, e.g.
    ``dataset-1_walk-back_normal_001`` -> ``("walk-back", "normal")``; None if it does not match."""
    m = _BANDAI.search(Path(name).stem if name.endswith(".bvh") else name)
    return (m["content"], m["style"]) if m else None


def cmu_label(name: str) -> str | None:
    """Category of a CMU trial from its name (``"09_11"`` -> ``"run"``,
    ``"107_02_30hz"`` -> ``"walk"``); None when unknown."""
    stem = Path(name).stem
    m = re.match(r"(\d+_\d+)", stem)
    return CMU_CATEGORIES.get(m.group(1)) if m else None


# --------------------------------------------------------------------------------------------
# Search and k-NN
# --------------------------------------------------------------------------------------------


def _check_matrix(d: Any, name: str = "distances") -> np.ndarray:
    d = np.asarray(d, dtype=np.float64)
    if d.ndim != 2 or d.shape[0] != d.shape[1]:
        raise ValueError(f"{name}: expected a square matrix (M, M); got shape {d.shape}")
    if np.isnan(d).any():
        i, j = (int(x) for x in np.argwhere(np.isnan(d))[0])
        raise ValueError(
            f"{name}: expected a complete matrix; entry ({i}, {j}) is NaN (not computed: resume the run)"
        )
    return d


def nearest(distances: Any, k: int = 5, *, exclude: Sequence[int] = ()) -> np.ndarray:
    """Indices of the ``k`` smallest finite distances, nearest first.

    Parameters
    ----------
    distances : array_like, shape (M,)
    k : int
    exclude : sequence of int
        Indices never returned (e.g. the query itself).

    Returns
    -------
    ndarray of int, shape (min(k, number of finite candidates),)
        Ties are broken by index (stable sort).
    """
    d = np.asarray(distances, dtype=np.float64).copy()
    if d.ndim != 1:
        raise ValueError(f"distances: expected a vector (M,); got shape {d.shape}")
    if k < 1:
        raise OptionError("k", f"expected k >= 1; got {k}")
    d[list(exclude)] = np.inf
    d[np.isnan(d)] = np.inf
    order = np.argsort(d, kind="stable")
    order = order[np.isfinite(d[order])]
    return order[:k]


@dataclass(frozen=True)
class KnnEvaluation:
    """Leave-one-out k-NN classification of the rows of a distance matrix.

    Attributes
    ----------
    accuracy : float
        Fraction of evaluated motions classified correctly (NaN if none evaluated).
    n_evaluated : int
        Motions with at least one admissible neighbour (finite distance, other block).
    k : int
    predictions : list of (str or None)
        Predicted label per motion (None: not evaluated).
    labels : list of str
    per_class : dict of str -> (correct, evaluated)
    confusion : dict of str -> dict of str -> int
        ``confusion[true][predicted]``.
    """

    accuracy: float
    n_evaluated: int
    k: int
    predictions: list[str | None]
    labels: list[str]
    per_class: dict[str, tuple[int, int]] = field(repr=False)
    confusion: dict[str, dict[str, int]] = field(repr=False)


def knn_evaluate(
    distances: Any,
    labels: Sequence[str],
    k: int = 1,
    *,
    blocks: Sequence[Any] | None = None,
) -> KnnEvaluation:
    """Leave-one-out k-NN accuracy of ``labels`` under ``distances``.

    Parameters
    ----------
    distances : array_like, shape (M, M)
    labels : sequence of str, length M
        Motions with label ``None`` or ``""`` are neither evaluated nor used as neighbours.
    k : int
        Neighbours that vote.
    blocks : sequence, length M, optional
        Group id per motion (e.g. source clip); neighbours from the motion's own block are
        excluded ("leave one block out").

    Returns
    -------
    KnnEvaluation
    """
    d = _check_matrix(distances)
    m = d.shape[0]
    labels = list(labels)
    if len(labels) != m:
        raise OptionError("labels", f"expected {m} labels (one per row); got {len(labels)}")
    if blocks is not None and len(blocks) != m:
        raise OptionError("blocks", f"expected {m} entries; got {len(blocks)}")
    if k < 1:
        raise OptionError("k", f"expected k >= 1; got {k}")
    valid = np.array([bool(lab) for lab in labels])
    preds: list[str | None] = [None] * m
    per: dict[str, list[int]] = {}
    conf: dict[str, dict[str, int]] = {}
    for i in range(m):
        if not valid[i]:
            continue
        row = d[i].copy()
        row[i] = np.inf
        row[~valid] = np.inf
        if blocks is not None:
            same = np.array([b == blocks[i] for b in blocks])
            row[same] = np.inf
        nn = nearest(row, k)
        if nn.size == 0:
            continue
        votes = Counter(labels[j] for j in nn)
        top = max(votes.values())
        tied = [lab for lab, c in votes.items() if c == top]
        # tie: the tied label whose nearest member comes first
        pred = next(labels[j] for j in nn if labels[j] in tied)
        preds[i] = pred
        c = per.setdefault(labels[i], [0, 0])
        c[1] += 1
        c[0] += int(pred == labels[i])
        conf.setdefault(labels[i], {}).setdefault(pred, 0)
        conf[labels[i]][pred] += 1
    n_eval = sum(v[1] for v in per.values())
    correct = sum(v[0] for v in per.values())
    return KnnEvaluation(
        accuracy=correct / n_eval if n_eval else float("nan"),
        n_evaluated=n_eval,
        k=k,
        predictions=preds,
        labels=labels,
        per_class={key: (v[0], v[1]) for key, v in sorted(per.items())},
        confusion=conf,
    )


def dtw_matrix(
    features: Sequence[np.ndarray], *, window: int | None = None, parallel: bool = True
) -> np.ndarray:
    """Dynamic time warping distances between multivariate series (the baseline).

    Uses ``dtaidistance.dtw_ndim.distance_matrix_fast`` (C): the DTW of two series
    ``(n_a, d)``, ``(n_b, d)`` with the squared Euclidean local cost, square-rooted.

    Parameters
    ----------
    features : sequence of ndarray, shapes (n_k, d)
        One series per motion, same ``d``.
    window : int, optional
        Sakoe-Chiba band half-width (frames); default none.
    parallel : bool

    Returns
    -------
    ndarray, shape (M, M)
        Symmetric, zero diagonal.

    Raises
    ------
    ImportError
        When ``dtaidistance`` is not installed (``pip install 'elastic-motion[benchmark]'``).
    """
    try:
        from dtaidistance import dtw_ndim
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise ImportError("dtw_matrix needs dtaidistance: pip install 'elastic-motion[benchmark]'") from exc
    series = [np.ascontiguousarray(f, dtype=np.double) for f in features]
    dims = {s.shape[1] for s in series}
    if len(dims) != 1:
        raise ValueError(f"features: expected series of one dimension d; got dimensions {sorted(dims)}")
    tri = dtw_ndim.distance_matrix_fast(series, window=window, parallel=parallel, compact=False)
    d = np.array(tri, dtype=np.float64)
    iu = np.triu_indices(len(series), 1)
    d[iu[1], iu[0]] = d[iu]
    np.fill_diagonal(d, 0.0)
    return d


# --------------------------------------------------------------------------------------------
# Karcher mean
# --------------------------------------------------------------------------------------------


def _warp_options(warp: WarpOptions | str | None) -> WarpOptions:
    if warp is None:
        from elastic_motion.apps.database.settings import DEFAULT_WARP

        return DEFAULT_WARP
    if isinstance(warp, WarpOptions):
        return warp
    if isinstance(warp, str):
        return WarpOptions(method=warp)  # type: ignore[arg-type]
    raise OptionError("warp", f"expected a WarpOptions or a method name ('dp', 'none'...); got {warp!r}")


@dataclass(frozen=True, eq=False)
class KarcherMeanResult:
    """Karcher mean of curves in SRV space.

    Attributes
    ----------
    mean : DiscreteCurve
        The mean curve sampled on the common grid ``t`` (``n + 1`` samples).
    srv : SRVFunction
        The mean SRV function on ``t`` (the last average).
    warps : list of ndarray, shapes (K_k, 2)
        Vertices of the warp of each input onto the mean (``q_k * phi_k`` is aligned).
    energies : ndarray, shape (iterations,)
        ``sum_k w_k d(mu_i, c_k)^2`` at the mean of each iteration (``mu_0``: the plain SRV average);
        non-increasing.
    distances : ndarray, shape (K,)
        Elastic distances of the inputs to the last mean they were aligned to.
    iterations : int
    converged : bool
        Relative energy decrease fell below ``tol``.
    """

    mean: DiscreteCurve
    srv: SRVFunction
    warps: list[np.ndarray]
    energies: np.ndarray
    distances: np.ndarray
    iterations: int
    converged: bool


def karcher_mean(
    curves: Sequence[DiscreteCurve],
    *,
    weights: Sequence[float] | None = None,
    n_samples: int | None = None,
    warp: WarpOptions | str | None = None,
    max_iter: int = 20,
    tol: float = 1e-4,
    progress: Progress | None = None,
    recenter: bool = False,
) -> KarcherMeanResult:
    """Karcher mean of curves: align all to the current mean, average the SRVs, repeat.

    Parameters
    ----------
    curves : sequence of DiscreteCurve
        ``K >= 1`` curves in one group.
    weights : array_like, shape (K,), optional
        Non-negative weights (normalised to sum 1); default equal.
    n_samples : int, optional
        Cells ``n`` of the common uniform grid (default: the largest ``n_points - 1``).
    warp : WarpOptions or {"dp", "dp+refine", "none"}, optional
        How each curve is aligned to the mean (default
        :data:`elastic_motion.apps.database.DEFAULT_WARP`: DP, neighbourhood 10, as for a
        database); a method name stands for ``WarpOptions(method=name)``. ``"none"``: the
        plain SRV average (one iteration, no alignment). ``"dp+refine"`` gives each input a
        closer warp, but the energy is then no longer guaranteed to decrease (the refined
        warp of one iteration is not a path of the next DP).
    max_iter : int, default 20
        Alignment iterations at most.
    tol : float, default 1e-4
        Stop when ``(E_{i-1} - E_i) / E_{i-1} < tol`` (relative, dimensionless).
    progress : callable, optional
        ``progress("mean", iteration, max_iter)``.
    recenter : bool, default False
        Re-centre the warps: the mean is only defined up to a warp ``h`` (``mu * h`` with the
        warps ``phi_k o h`` has the same energy); choose ``h`` so that the weighted mean of
        the warps is the identity: ``h = gbar^{-1}`` with ``gbar = sum_k w_k phi_k`` (the
        pointwise average of the warp functions, increasing, exact for piecewise linear
        warps at the union of their vertices). Then ``sum_k w_k (phi_k o h) = gbar o h = id``;
        the mean is re-averaged from the re-aligned inputs and its timing is the inputs'
        average timing instead of the first iterate's.

    Returns
    -------
    KarcherMeanResult

    Notes
    -----
    Cost per iteration: ``K`` DP solves on ``n x n`` grids. Energies are exact for the
    piecewise constant SRV functions (:attr:`WarpResult.energy`).
    """
    from elastic_motion.warp import optimal_warp, warp_energy

    curves = list(curves)
    if not curves:
        raise ValueError("curves: expected at least one curve")
    g = curves[0].group
    for k, c in enumerate(curves):
        if not isinstance(c, DiscreteCurve):
            raise ValueError(f"curves[{k}]: expected a DiscreteCurve; got {type(c).__name__}")
        if c.group != g:
            raise ValueError(f"curves[{k}]: expected a curve in {g!r} like curves[0]; got {c.group!r}")
    kk = len(curves)
    w = np.full(kk, 1.0 / kk) if weights is None else np.asarray(weights, dtype=np.float64)
    if w.shape != (kk,) or (w < 0).any() or not w.sum() > 0:
        raise OptionError(
            "weights", f"expected {kk} non-negative weights with a positive sum; got {weights!r}"
        )
    w = w / w.sum()
    opts = _warp_options(warp)
    n = int(n_samples) if n_samples is not None else max(c.n_points for c in curves) - 1
    if n < 2:
        raise OptionError("n_samples", f"expected at least 2 cells; got {n}")
    t = np.linspace(0.0, 1.0, n + 1)
    uniform = [
        c if c.n_points == n + 1 and np.array_equal(c.t, t) else DiscreteCurve(c.evaluate(t), g, t)
        for c in curves
    ]
    srvs = [srv_transform(c) for c in uniform]
    q = np.stack([s.q for s in srvs])  # (K, n, D)
    mu = np.einsum("k,kij->ij", w, q)
    identity = np.array([[0.0, 0.0], [1.0, 1.0]])
    warps = [identity] * kk
    energies: list[float] = []
    dists = np.sqrt(np.array([warp_energy(mu, q[k], identity) for k in range(kk)]))
    converged = False
    iterations = 0
    if opts.method == "none":
        energies.append(float(np.dot(w, dists**2)))
        converged = True
    else:
        solver = opts.solver_kwargs()
        for it in range(max_iter):
            results = [optimal_warp(mu, q[k], **solver) for k in range(kk)]
            e = float(sum(w[k] * r.energy for k, r in enumerate(results)))
            energies.append(e)
            warps = [r.vertices for r in results]
            dists = np.array([r.distance for r in results])
            iterations = it + 1
            if progress is not None:
                progress("mean", iterations, max_iter)
            if len(energies) >= 2 and energies[-2] > 0 and (energies[-2] - e) / energies[-2] < tol:
                converged = True
                break
            aligned = [reparametrize_srv(srvs[k], warps[k]).on_grid(t).q for k in range(kk)]
            mu = np.einsum("k,kij->ij", w, np.stack(aligned))
            if e == 0.0:
                converged = True
                break
        if recenter:
            warps = recenter_warps(warps, w)
            aligned = [reparametrize_srv(srvs[k], warps[k]).on_grid(t).q for k in range(kk)]
            mu = np.einsum("k,kij->ij", w, np.stack(aligned))
    mean_curve = weighted_blend(uniform, w, warps if opts.method != "none" else None, t_out=t)
    return KarcherMeanResult(
        mean=mean_curve,
        srv=SRVFunction(mu, t, mean_curve.values[0], g),
        warps=[np.asarray(v) for v in warps],
        energies=np.array(energies),
        distances=dists,
        iterations=iterations,
        converged=converged,
    )


def mean_warp(warps: Sequence[np.ndarray], weights: Sequence[float] | None = None) -> np.ndarray:
    """Pointwise weighted average ``gbar = sum_k w_k phi_k`` of piecewise linear warps.

    Parameters
    ----------
    warps : sequence of ndarray, shapes (K_k, 2)
        Vertices ``(x, phi(x))`` from ``(0, 0)`` to ``(1, 1)``.
    weights : array_like, shape (K,), optional
        Summing to 1 (default equal).

    Returns
    -------
    ndarray, shape (V, 2)
        Vertices at the union of the inputs' ``x`` (exact: an average of piecewise linear
        functions is linear between their break points); increasing.
    """
    warps = [np.asarray(v, dtype=np.float64) for v in warps]
    w = np.full(len(warps), 1.0 / len(warps)) if weights is None else np.asarray(weights, dtype=np.float64)
    x = np.unique(np.concatenate([v[:, 0] for v in warps]))
    y = sum(wk * np.interp(x, v[:, 0], v[:, 1]) for wk, v in zip(w, warps, strict=True))
    y = np.asarray(y)
    y[0], y[-1] = 0.0, 1.0
    return np.column_stack([x, y])


def recenter_warps(warps: Sequence[np.ndarray], weights: Sequence[float] | None = None) -> list[np.ndarray]:
    """Warps ``phi_k o gbar^{-1}`` whose weighted average is the identity (:func:`mean_warp`).

    Returns
    -------
    list of ndarray, shapes (K'_k, 2)
        ``sum_k w_k (phi_k o h)(x) = x`` for every ``x`` (``h = gbar^{-1}``), up to rounding.
    """
    from elastic_motion.warp import compose_warps

    g = mean_warp(warps, weights)
    h = g[:, ::-1].copy()  # the inverse of an increasing piecewise linear map: swap the columns
    return [compose_warps(v, h) for v in warps]


@dataclass(frozen=True, eq=False)
class MeanMotionResult:
    """Karcher mean of motion files, as a motion (:func:`mean_motion`).

    Attributes
    ----------
    motion : Motion
        The mean, on the skeleton of the first file (after preparation: metres when the
        unit is known, Y-up, no finger joints by default), lasting ``duration`` seconds at
        the output frame rate.
    karcher : KarcherMeanResult
        The mean curve, its SRV function, the warps, energies and distances.
    inputs : tuple of str
        The files, in order (length ``K``).
    representation : {"lie", "euler"}
    n_samples : int
        Cells of the common grid the mean was computed on (``n_samples + 1`` frames).
    duration : float
        Seconds: the mean of the inputs' durations.
    notes : dict of str -> tuple of str
        What the preparation did to each input file.
    """

    motion: Motion
    karcher: KarcherMeanResult
    inputs: tuple[str, ...]
    representation: str
    n_samples: int
    duration: float
    notes: dict[str, tuple[str, ...]] = field(default_factory=dict)

    @property
    def energies(self) -> np.ndarray:
        """``(iterations,)``: Karcher energy ``sum_k w_k d(mu_i, c_k)^2`` per iteration."""
        return self.karcher.energies

    @property
    def converged(self) -> bool:
        """The relative energy decrease fell below ``tol``."""
        return self.karcher.converged

    @property
    def distances(self) -> np.ndarray:
        """``(K,)``: elastic distance of each input to the mean (SRV norm units)."""
        return self.karcher.distances

    def summary(self) -> dict[str, Any]:
        """JSON-ready fields of a report, through :func:`~elastic_motion.apps.report.jsonable`."""
        return jsonable(
            {
                "inputs": self.inputs,
                "representation": self.representation,
                "method": "euler-elastic" if self.representation == "euler" else self.representation,
                "n_samples": self.n_samples,
                "energies": self.karcher.energies,
                "iterations": self.karcher.iterations,
                "converged": self.karcher.converged,
                "distances": dict(zip(self.inputs, self.karcher.distances, strict=True)),
                "duration": self.duration,
                "fps": self.motion.fps,
                "frames": self.motion.n_frames,
                "notes": self.notes,
            }
        )


def mean_motion(
    files: Sequence[str | os.PathLike[str]],
    *,
    n_samples: int = 64,
    method: str = "lie",
    representation: str | None = None,
    joints: str | Sequence[str] = "all",
    drop_fingers: bool = True,
    align_heading: bool = True,
    warp: WarpOptions | str | None = None,
    max_iter: int = 20,
    tol: float = 1e-4,
    fps: float | None = None,
    progress: Progress | None = None,
) -> MeanMotionResult:
    """Karcher mean of motion files, as a motion.

    The files are prepared as for a database (:func:`elastic_motion.apps.database.prepare_motion`,
    ``n_samples + 1`` frames each), turned into Lie curves with shared weights (or Euler curves),
    averaged by :func:`karcher_mean` and converted back (``from_lie_curve`` /
    ``from_euler_curve``) on the skeleton of the first file, with the mean duration, and
    resampled (geodesic interpolation) to ``fps`` (default: the first file's frame rate).

    Parameters
    ----------
    files : sequence of paths
        At least one motion file, of one skeleton (or ``joints="common"``).
    n_samples : int, default 64
    method : {"lie", "euler-elastic"}, default "lie"
        The curve representation (``"euler"`` is accepted for ``"euler-elastic"``).
    representation : str, optional
        The name of ``method`` in earlier releases (``"lie"`` / ``"euler"``); overrides it.
    joints : "all", "common" or sequence of str, default "all"
    drop_fingers, align_heading : bool, default True
        As in :class:`elastic_motion.apps.database.DatabaseSettings`.
    warp : WarpOptions or method name, optional
        Default: DP, neighbourhood 10 (see :func:`karcher_mean`).
    max_iter : int, default 20
    tol : float, default 1e-4
    fps : float, optional
        Frames per second of the result (default: the first file's, after preparation).
    progress : callable, optional
        ``progress("mean", iteration, max_iter)``.

    Returns
    -------
    MeanMotionResult

    Raises
    ------
    OptionError
        No file, different skeletons (use ``joints="common"``), or an unknown representation.
    ParseError
        A malformed file.
    """
    from elastic_motion import motion as mm
    from elastic_motion.apps.database.preparation import database_curves, prepare_same_skeleton
    from elastic_motion.apps.database.settings import canonical_method

    if representation is not None:
        representation = canonical_method(representation, "representation")
    else:
        representation = canonical_method(method)
    opts = _warp_options(warp)
    files = [os.fspath(f) for f in files]
    if not files:
        raise OptionError("files", "expected at least one motion file; got none")
    prepared = prepare_same_skeleton(
        files, n_samples, joints=joints, drop_fingers=drop_fingers, align_heading=align_heading
    )
    curves = database_curves(prepared, representation)
    res = karcher_mean(curves, n_samples=n_samples, warp=opts, max_iter=max_iter, tol=tol, progress=progress)
    duration = float(np.mean([p.duration for p in prepared]))
    like = prepared[0].motion
    conv = mm.from_lie_curve if representation == "lie" else mm.from_euler_curve
    motion = conv(res.mean, like, fps=n_samples / duration if duration > 0 else like.fps)
    p0 = prepared[0]
    out_fps = float(fps) if fps is not None else (p0.original_frames - 1) / p0.duration
    if duration > 0 and out_fps > 0:
        motion = mm.resample(motion, out_fps)
    motion = motion.replace(name="karcher mean")
    return MeanMotionResult(
        motion=motion,
        karcher=res,
        inputs=tuple(files),
        representation=representation,
        n_samples=n_samples,
        duration=duration,
        notes={p.path: p.notes for p in prepared},
    )


# --------------------------------------------------------------------------------------------
# Hierarchical clustering
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class ClusterResult:
    """Agglomerative clustering of a distance matrix.

    Attributes
    ----------
    linkage : ndarray, shape (M - 1, 4)
        SciPy linkage matrix.
    labels : ndarray of int, shape (M,) or None
        Flat cluster (1-based) of each motion when a number of clusters was asked.
    method : str
    names : list of str
    """

    linkage: np.ndarray
    labels: np.ndarray | None
    method: str
    names: list[str]


def cluster(
    distances: Any,
    names: Sequence[str] | None = None,
    *,
    method: str = "average",
    n_clusters: int | None = None,
) -> ClusterResult:
    """Hierarchical clustering from a distance matrix.

    Parameters
    ----------
    distances : array_like, shape (M, M)
        Complete, symmetric (``+inf`` allowed: replaced by twice the largest finite entry).
    names : sequence of str, optional
    method : {"average", "complete", "single", "weighted"}
        Linkage (``"ward"``/``"centroid"``/``"median"`` assume Euclidean data and are refused).
    n_clusters : int, optional
        Cut the tree into this many flat clusters (``fcluster``, criterion ``maxclust``).

    Returns
    -------
    ClusterResult
    """
    from scipy.cluster.hierarchy import fcluster, linkage
    from scipy.spatial.distance import squareform

    if method not in ("average", "complete", "single", "weighted"):
        raise OptionError("method", f"expected 'average', 'complete', 'single' or 'weighted'; got {method!r}")
    d = _check_matrix(distances).copy()
    m = d.shape[0]
    if m < 2:
        raise ValueError(f"distances: expected at least 2 motions to cluster; got {m}")
    names = [str(i) for i in range(m)] if names is None else list(names)
    if len(names) != m:
        raise ValueError(f"names: expected {m} names; got {len(names)}")
    finite = d[np.isfinite(d)]
    big = 2.0 * float(finite.max()) if finite.size and finite.max() > 0 else 1.0
    d[~np.isfinite(d)] = big
    d = 0.5 * (d + d.T)
    np.fill_diagonal(d, 0.0)
    z = linkage(squareform(d, checks=False), method=method)
    labels = None
    if n_clusters is not None:
        if not 1 <= n_clusters <= m:
            raise OptionError("n_clusters", f"expected an integer in 1..{m}; got {n_clusters}")
        labels = fcluster(z, t=n_clusters, criterion="maxclust")
    return ClusterResult(linkage=z, labels=labels, method=method, names=names)
