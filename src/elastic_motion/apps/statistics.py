"""Statistics over motion databases: labels, k-NN search and classification, Karcher mean,
clustering.

The numerical layer under :mod:`elastic_motion.apps.database` (which imports this module, never
the other way): functions of distance matrices and of curves. The commands over a database's
files and matrix folders are :func:`~elastic_motion.apps.database.classify_motions`,
:func:`~elastic_motion.apps.database.mean_motion` and
:func:`~elastic_motion.apps.database.cluster_motions`.

Conventions
-----------
* A **distance matrix** is a symmetric float64 array ``(M, M)`` with zeros on the diagonal,
  as written by :mod:`elastic_motion.apps.database` (``+inf`` between motions of different
  skeleton groups; NaN = not computed, which the functions here refuse).
* **Labels** of motions come from their names (:func:`bandai_labels`, :func:`cmu_label`, the
  rules of :func:`motion_labels`) or a CSV file.
* **k-NN, leave one out**: motion ``i`` is classified by the majority label of its ``k``
  nearest other motions (finite distances only); a tie goes to the tied label whose
  nearest member is closest. With ``blocks`` (e.g. the source clip of each segment), the
  neighbours of ``i`` exclude its own block ("leave one clip out"), so segments of one
  recording cannot vote for each other.
* **Karcher mean** (:func:`karcher_mean`) of curves in one Lie group, in SRV space:
  ``mu = argmin sum_k w_k min_phi ||mu - q_k * phi||^2``, by alternating (i) the optimal warp of
  each ``q_k`` onto the current mean (:func:`elastic_motion.warp.optimal_warp`) and (ii) the
  weighted average of the aligned SRV functions (projected on the common grid). With the
  DP (:data:`MEAN_WARP`, the default) each step does not increase the energy (the
  previous warp is a path of the next DP; the average is the L2 minimiser). The mean curve
  is reconstructed with :func:`elastic_motion.curves.weighted_blend` from the aligned inputs
  (start point: the group's weighted mean of the start points). The warps are not re-centred
  unless asked (fdasrsf's ``srsf_align`` re-centres them so their mean is the identity); the
  mean therefore keeps the time-parametrisation the iteration converges to.
* **Hierarchical clustering**: :func:`scipy.cluster.hierarchy.linkage` on the condensed
  matrix; ``+inf`` entries are replaced by twice the largest finite distance (so motions of
  different skeletons join last).

Numerical code prints nothing.
"""

from __future__ import annotations

import csv
import os
import re
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from elastic_motion.apps.csv_files import csv_cell
from elastic_motion.apps.progress import Progress
from elastic_motion.curves import (
    DiscreteCurve,
    SRVFunction,
    reparametrize_srv,
    srv_transform,
    weighted_blend,
)
from elastic_motion.defaults import MEAN_WARP_METHOD
from elastic_motion.errors import OptionError
from elastic_motion.vocabulary import LINKAGES, Linkage
from elastic_motion.warp import WarpOptions, compose_warps, optimal_warp, warp_energy

__all__ = [
    "CMU_CATEGORIES",
    "LABEL_RULES",
    "LINKAGES",
    "MEAN_WARP",
    "ClusterResult",
    "KarcherMeanResult",
    "KnnEvaluation",
    "Linkage",
    "as_warp_options",
    "bandai_labels",
    "cluster",
    "cmu_label",
    "dtw_matrix",
    "karcher_mean",
    "knn_evaluate",
    "mean_warp",
    "motion_labels",
    "nearest",
    "recenter_warps",
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


#: The rules that label motions by their names (:func:`motion_labels`): the content or the
#: style of a Bandai-Namco file name (:func:`bandai_labels`), the category of a CMU trial
#: (:func:`cmu_label`).
LABEL_RULES = ("bandai-content", "bandai-style", "cmu")


def motion_labels(names: Sequence[str], rule: str | os.PathLike[str]) -> list[str | None]:
    """The label of each motion name by a rule of :data:`LABEL_RULES` or a CSV file.

    Parameters
    ----------
    names : sequence of str
        Motion names (e.g. :attr:`elastic_motion.apps.database.DistanceMatrix.names`).
    rule : {"bandai-content", "bandai-style", "cmu"} or path
        A rule, or a CSV file of rows ``name,label`` (rows of fewer fields are ignored; a
        name may also be written as ``names.csv`` writes it, e.g. ``'=x`` for ``=x``:
        :func:`elastic_motion.apps.csv_files.csv_cell`).

    Returns
    -------
    list of (str or None)
        One per name; None where the rule or the file gives none.

    Raises
    ------
    OptionError
        ``rule`` neither a rule nor a file.
    """
    if rule in ("bandai-content", "bandai-style"):
        part = 0 if rule == "bandai-content" else 1
        return [(lab[part] if (lab := bandai_labels(n)) else None) for n in names]
    if rule == "cmu":
        return [cmu_label(n) for n in names]
    if not Path(rule).is_file():
        raise OptionError(
            "labels", f"expected a CSV file (name,label) or {', '.join(LABEL_RULES)}; got {rule!r}"
        )
    with open(rule, newline="") as fh:
        table = {row[0]: row[1] for row in csv.reader(fh) if len(row) >= 2}
    # a name as written, or as names.csv writes it (a name copied from there keeps its guard)
    return [table.get(n, table.get(csv_cell(n))) for n in names]


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


#: The warp of a Karcher mean when none is given: the DP alone on the grid (neighbourhood 10,
#: :class:`~elastic_motion.warp.WarpOptions`' default), under which each iteration's energy is
#: non-increasing (the previous warp is a path of the next DP; the refinement off the grid,
#: ``"dp+refine"``, gives closer warps but loses that). A database compares its motions with
#: the same warp (:data:`elastic_motion.apps.database.DEFAULT_WARP`).
MEAN_WARP = WarpOptions(method=MEAN_WARP_METHOD)


def as_warp_options(warp: WarpOptions | str | None, default: WarpOptions | None = MEAN_WARP) -> WarpOptions:
    """The :class:`~elastic_motion.warp.WarpOptions` of ``warp``: itself, ``WarpOptions(method=warp)``
    for a method name (``"dp"``, ``"dp+refine"``, ``"none"``), ``default`` for None.

    Raises
    ------
    OptionError
        Anything else (None too when ``default`` is None); an unknown method name (from
        ``WarpOptions``).
    """
    if warp is None and default is not None:
        return default
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
        How each curve is aligned to the mean (default :data:`MEAN_WARP`: DP, neighbourhood
        10, as for a database); a method name stands for ``WarpOptions(method=name)``.
        ``"none"``: the plain SRV average (one iteration, no alignment). ``"dp+refine"`` gives
        each input a closer warp, but the energy is then no longer guaranteed to decrease (the
        refined warp of one iteration is not a path of the next DP).
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
    curves = _checked_curves(curves)
    w = _normalised_weights(weights, len(curves))
    opts = as_warp_options(warp)
    n = int(n_samples) if n_samples is not None else max(c.n_points for c in curves) - 1
    if n < 2:
        raise OptionError("n_samples", f"expected at least 2 cells; got {n}")
    g = curves[0].group
    t = np.linspace(0.0, 1.0, n + 1)
    uniform = [
        c if c.n_points == n + 1 and np.array_equal(c.t, t) else DiscreteCurve(c.evaluate(t), g, t)
        for c in curves
    ]
    state = _KarcherState.start([srv_transform(c) for c in uniform], w, t)
    if opts.method == "none":
        state.energies.append(float(np.dot(w, state.distances**2)))
        state.converged = True
    else:
        _align_and_average(state, opts, max_iter, tol, progress)
        if recenter:
            state.warps = recenter_warps(state.warps, w)
            state.average()
    mean_curve = weighted_blend(uniform, w, state.warps if opts.method != "none" else None, t_out=t)
    return KarcherMeanResult(
        mean=mean_curve,
        srv=SRVFunction(state.mu, t, mean_curve.values[0], g),
        warps=[np.asarray(v) for v in state.warps],
        energies=np.array(state.energies),
        distances=state.distances,
        iterations=state.iterations,
        converged=state.converged,
    )


def _checked_curves(curves: Sequence[DiscreteCurve]) -> list[DiscreteCurve]:
    """``curves`` as a list of at least one curve, all in the first one's group."""
    curves = list(curves)
    if not curves:
        raise ValueError("curves: expected at least one curve")
    g = curves[0].group
    for k, c in enumerate(curves):
        if not isinstance(c, DiscreteCurve):
            raise ValueError(f"curves[{k}]: expected a DiscreteCurve; got {type(c).__name__}")
        if c.group != g:
            raise ValueError(f"curves[{k}]: expected a curve in {g!r} like curves[0]; got {c.group!r}")
    return curves


def _normalised_weights(weights: Sequence[float] | None, kk: int) -> np.ndarray:
    """``(K,)`` weights summing to 1 (equal by default)."""
    w = np.full(kk, 1.0 / kk) if weights is None else np.asarray(weights, dtype=np.float64)
    if w.shape != (kk,) or (w < 0).any() or not w.sum() > 0:
        raise OptionError(
            "weights", f"expected {kk} non-negative weights with a positive sum; got {weights!r}"
        )
    return w / w.sum()


#: The identity warp's vertices.
_IDENTITY = np.array([[0.0, 0.0], [1.0, 1.0]])


@dataclass(eq=False)
class _KarcherState:
    """The iterate of :func:`karcher_mean`: the inputs' SRVs ``srvs`` (stacked: ``q``, shape
    ``(K, n, D)``) with their weights ``w`` on the grid ``t``, the current mean ``mu`` and the
    warps aligning each input to it, the energy per iteration so far."""

    srvs: list[SRVFunction]
    q: np.ndarray
    w: np.ndarray
    t: np.ndarray
    mu: np.ndarray
    warps: list[np.ndarray]
    distances: np.ndarray
    energies: list[float] = field(default_factory=list)
    iterations: int = 0
    converged: bool = False

    @classmethod
    def start(cls, srvs: list[SRVFunction], w: np.ndarray, t: np.ndarray) -> _KarcherState:
        """``mu_0``: the plain weighted average of the SRVs, every warp the identity."""
        q = np.stack([s.q for s in srvs])  # (K, n, D)
        mu = np.einsum("k,kij->ij", w, q)
        dists = np.sqrt(np.array([warp_energy(mu, q[k], _IDENTITY) for k in range(len(srvs))]))
        return cls(srvs, q, w, t, mu, [_IDENTITY] * len(srvs), dists)

    def average(self) -> None:
        """``mu``: the weighted average of the inputs aligned by the current warps, on the grid."""
        pairs = zip(self.srvs, self.warps, strict=True)
        aligned = [reparametrize_srv(s, v).on_grid(self.t).q for s, v in pairs]
        self.mu = np.einsum("k,kij->ij", self.w, np.stack(aligned))


def _align_and_average(
    state: _KarcherState, opts: WarpOptions, max_iter: int, tol: float, progress: Progress | None
) -> None:
    """The iterations of :func:`karcher_mean`: (i) the optimal warp of each input onto ``mu``,
    (ii) ``mu`` the average of the aligned inputs; until the relative energy decrease is below
    ``tol``, the energy is 0, or ``max_iter`` iterations."""
    solver = opts.solver_kwargs()
    w = state.w
    for it in range(max_iter):
        results = [optimal_warp(state.mu, state.q[k], **solver) for k in range(len(state.srvs))]
        e = float(sum(w[k] * r.energy for k, r in enumerate(results)))
        energies = state.energies
        energies.append(e)
        state.warps = [r.vertices for r in results]
        state.distances = np.array([r.distance for r in results])
        state.iterations = it + 1
        if progress is not None:
            progress("mean", state.iterations, max_iter)
        if len(energies) >= 2 and energies[-2] > 0 and (energies[-2] - e) / energies[-2] < tol:
            state.converged = True
            return
        state.average()
        if e == 0.0:
            state.converged = True
            return


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
    g = mean_warp(warps, weights)
    h = g[:, ::-1].copy()  # the inverse of an increasing piecewise linear map: swap the columns
    return [compose_warps(v, h) for v in warps]


# --------------------------------------------------------------------------------------------
# Hierarchical clustering
# --------------------------------------------------------------------------------------------


# How cluster measures the distance between two clusters: Linkage ("average": the mean of
# their pairs' distances, UPGMA; "complete": the largest; "single": the smallest; "weighted":
# the mean of the two clusters they merged, WPGMA) and LINKAGES, from elastic_motion.vocabulary.
# The linkages that assume Euclidean data (Ward, centroid, median) are not offered.


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
    # scipy.cluster takes 0.5 s to import, and every start of the command line loads this module
    # (the database's settings use its MEAN_WARP): only a clustering pays for it
    from scipy.cluster.hierarchy import fcluster, linkage
    from scipy.spatial.distance import squareform

    if method not in LINKAGES:
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
