"""Elastic distances between a few motions, computed serially.

For many motions (caching, tiles, parallel engines, resume) use
:mod:`elastic_motion.apps.database`; this module is the small, direct version behind
``elastic-motion distance A B [C ...]`` and the blend report.

Conventions
-----------
* The motions are prepared together (:func:`elastic_motion.apps.prepare.prepare_motions`:
  T-pose, metres, Y-up, joints, one frame rate, each placed like the first), their curves
  are built over the non-finger joints with weights shared by all (``"lie"``) or
  unweighted (``"euler-*"``), at most ``warp.sample_fps`` frames per second after the
  low-pass of ``warp.sample_smoothing`` (:func:`elastic_motion.apps.align.motion_curves`),
  each on ``[0, 1]`` (a clip's duration is normalised away: the distance compares shapes,
  not lengths).
* ``warp`` (a :class:`elastic_motion.warp.WarpOptions` or a method name), ``"dp"``: the
  elastic distance ``min_phi ||q_i - q_j * phi||`` by dynamic programming
  (:func:`elastic_motion.warp.optimal_warp`), always with the lower index as the curve
  warped onto (``q_i``, ``i < j``); ``warp="none"``: ``||q_i - q_j||``, the
  distance of the parametrised curves (paper 000, eq. 4). The matrix is symmetric with a
  zero diagonal.
* The database module uses the same low-pass (``warp.sample_smoothing``), curves and
  weights, so on the same grid without placement and with the same warp its distances are
  these; by default it keeps the DP alone (``DEFAULT_WARP``: its search's speed), samples
  every clip at a fixed number of frames (``n_samples + 1``) instead of a frame rate and
  removes each motion's heading instead of placing it on the first's root path, so its
  numbers differ slightly (``docs/database.md``, "What is compared").
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from elastic_motion import limits
from elastic_motion.apps.align import check_method, motion_curves, warp_options
from elastic_motion.apps.prepare import PreparedMotions, PrepareOptions, Source, prepare_motions
from elastic_motion.apps.progress import Progress, null_progress
from elastic_motion.curves import SRVFunction, srv_transform
from elastic_motion.errors import OptionError
from elastic_motion.motion.edit import check_interpolation, resampled_frames
from elastic_motion.warp import WarpOptions, optimal_warp, warp_energy

__all__ = ["DistanceTable", "KnownDistances", "distance_table", "format_table", "motion_distance"]

_IDENTITY = np.array([[0.0, 0.0], [1.0, 1.0]])


@dataclass(frozen=True, eq=False)
class KnownDistances:
    """What :func:`distance_table` need not compute again: curves built and distances solved
    already, exactly as it would (same preparation, method, warp options, interpolation).

    Attributes
    ----------
    srvs : tuple of SRVFunction or None
        One per motion: the SRV of its curve, or None (built then).
    distances : ndarray, shape (K, K), optional
        Elastic distances on those curves, NaN where not solved (solved then); None: none.
    """

    srvs: tuple[SRVFunction | None, ...]
    distances: np.ndarray | None = None


@dataclass(frozen=True, eq=False)
class DistanceTable:
    """Pairwise distances of a few motions (:func:`distance_table`).

    Attributes
    ----------
    labels : tuple of str
    matrix : ndarray, shape (K, K)
        Symmetric, zero diagonal: elastic distances (``warp != "none"``) or distances of the
        parametrised curves.
    unwarped : ndarray, shape (K, K)
        ``||q_i - q_j||`` without warp (equal to ``matrix`` for ``warp="none"``).
    method, warp : str
    notes : tuple of str
        From the preparation.
    """

    labels: tuple[str, ...]
    matrix: np.ndarray
    unwarped: np.ndarray
    method: str
    warp: str
    notes: tuple[str, ...] = ()

    def summary(self) -> dict:
        """JSON-ready fields."""
        return {
            "labels": list(self.labels),
            "method": self.method,
            "warp": self.warp,
            "distances": self.matrix.tolist(),
            "distances_unwarped": self.unwarped.tolist(),
            "notes": [str(n) for n in self.notes],
        }


def distance_table(
    motions: Sequence[Source] | PreparedMotions,
    *,
    labels: Sequence[str] | None = None,
    method: str = "lie",
    warp: str | WarpOptions | None = None,
    prepare: PrepareOptions | None = None,
    progress: Progress | None = None,
    interpolation: str = "geodesic",
    known: KnownDistances | None = None,
) -> DistanceTable:
    """All pairwise distances of ``K >= 2`` motions, serially (``K (K - 1) / 2`` DP solves).

    Parameters
    ----------
    motions : sequence of path or Motion, or PreparedMotions
        (:func:`~elastic_motion.apps.prepare.prepare_motions`' result: ``prepare`` must be None)
    labels : sequence of str, optional
    method : {"lie", "euler-elastic", "euler-linear"}
        Representation (both Euler methods mean the Euler curve here).
    warp : str or WarpOptions, optional
        How the warp is found (default ``WarpOptions()``); ``"none"``: no warp.
    prepare : PrepareOptions, optional
        The preparation step (:mod:`elastic_motion.apps.prepare`).
    progress : callable, optional
        ``progress("distances", done, total)``.
    interpolation : {"geodesic", "cubic"}, default "geodesic"
        How the curves are sampled at ``warp.sample_fps``
        (:func:`elastic_motion.apps.align.motion_curves`): ``"cubic"`` samples every motion at
        exactly that rate by cubic splines, so with a rate above the clips' own (e.g. 120 on
        30 fps clips) a motion and the same motion played between its frames measure about
        2.5 times closer (``benchmarks/blend_quality.py``); the DP then costs about
        ``(sample_fps / fps)^2`` times more.
    known : KnownDistances, optional
        Curves built and distances solved already (e.g. by a blend's warp stage,
        :mod:`elastic_motion.apps.blend.warps`), exactly as this function would (same
        preparation, ``method``, ``warp`` and ``interpolation``): only the rest are built
        and solved.

    Returns
    -------
    DistanceTable
    """
    method = check_method(method)
    opts = warp_options(warp)
    check_interpolation(interpolation, OptionError)
    report = progress or null_progress
    if not isinstance(motions, PreparedMotions):
        motions = list(motions)
    n = len(motions.motions) if isinstance(motions, PreparedMotions) else len(motions)
    if n < 2:
        raise OptionError("motions", f"expected at least 2 motions; got {n}")
    prep = prepare_motions(motions, prepare, labels=labels)
    if interpolation == "cubic" and opts.method != "none" and not opts.coarse_to_fine:
        # cubic curves may be sampled above the clips' rate: bound the largest DP table before
        # the curves are built (the solver checks each table too, but only after them)
        longest = sorted(resampled_frames(m, opts.sample_fps, "sample_fps") for m in prep.motions)[-2:]
        limits.check_option(
            "sample_fps",
            f"a time-warp table of {longest[0]} x {longest[1]} nodes (lower the frame rate, or use "
            "the coarse-to-fine DP) of",
            longest[0] * longest[1],
            "max_dp_nodes",
        )
    given = _given(known, n)
    solved = None if known is None else known.distances
    missing = [k for k, s in enumerate(given) if s is None]
    if missing:
        curves = motion_curves(
            prep,
            method,
            fps=opts.sample_fps,
            smoothing=opts.sample_smoothing,
            interpolation=interpolation,
            which=missing,
        )
        for k, c in zip(missing, curves, strict=True):
            given[k] = srv_transform(c)
    k = len(given)
    d = np.zeros((k, k))
    du = np.zeros((k, k))
    pairs = [(i, j) for i in range(k) for j in range(i + 1, k)]
    report("distances", 0, len(pairs))
    for n, (i, j) in enumerate(pairs):
        a, b = given[i], given[j]
        du[i, j] = du[j, i] = math.sqrt(max(warp_energy(a.q, b.q, _IDENTITY, a.t, b.t), 0.0))
        if opts.method == "none":
            d[i, j] = d[j, i] = du[i, j]
        elif solved is not None and not math.isnan(solved[i, j]):
            d[i, j] = d[j, i] = solved[i, j]
        else:
            r = optimal_warp(a.q, b.q, t0=a.t, t1=b.t, **opts.solver_kwargs())
            d[i, j] = d[j, i] = r.distance
        report("distances", n + 1, len(pairs))
    return DistanceTable(prep.labels, d, du, method, opts.method, prep.notes)


def _given(known: KnownDistances | None, n: int) -> list[SRVFunction | None]:
    """``distance_table``'s curves built already (one per motion or None), checked with the
    distances' shape."""
    if known is None:
        return [None] * n
    given = list(known.srvs)
    if len(given) != n:
        raise OptionError("known", f"expected one curve or None per motion ({n}); got {len(given)}")
    if known.distances is not None and np.shape(known.distances) != (n, n):
        raise OptionError(
            "known", f"expected a ({n}, {n}) matrix of distances; got shape {np.shape(known.distances)}"
        )
    return given


def motion_distance(a: Source, b: Source, **kw: object) -> float:
    """Elastic distance of two motions: ``distance_table([a, b], **kw).matrix[0, 1]``."""
    return float(distance_table([a, b], **kw).matrix[0, 1])  # type: ignore[arg-type]


def format_table(table: DistanceTable, digits: int = 3) -> str:
    """The matrix as aligned text: one row per motion (``[i] label``), columns by index."""
    labels = [f"[{i}] {lab}" for i, lab in enumerate(table.labels)]
    w = max(len(x) for x in labels)
    cw = max(digits + 5, 6)
    rows = [" " * w + "  " + "  ".join(f"{f'[{j}]':>{cw}}" for j in range(len(labels)))]
    for i, lab in enumerate(labels):
        rows.append(
            f"{lab:<{w}}  " + "  ".join(f"{table.matrix[i, j]:>{cw}.{digits}f}" for j in range(len(labels)))
        )
    return "\n".join(rows)
