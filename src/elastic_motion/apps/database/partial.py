"""Partial matching: where a short query happens inside long takes (:func:`find_within`).

Each motion is prepared as for a database (:func:`~elastic_motion.apps.database.prepare_motion`:
metres, Y-up, no fingers), then

1. its root is made heading-relative
   (:func:`~elastic_motion.apps.database.preparation.heading_relative_root`):
   a turn or a cartwheel happening at any heading inside a long take looks the same;
2. the query is resampled to ``n_samples`` cells over its duration ``T_q``; each long take of
   duration ``T`` to ``n1 = round(n_samples T / T_q)`` cells, so both have (almost) the same
   cell length and a warp slope of 1 means "same speed";
3. both become Lie curves in one metric (:func:`elastic_motion.motion.group_weights` of the
   two) or Euler curves, and SRV arrays; the long one's SRV is taken with respect to time in
   units of the query's duration (``q1 = q~1 / sqrt(L)`` with ``L = n1 / n_samples``);
4. the open-ended DP (:func:`elastic_motion.warp.partial.partial_warp`) finds the segment
   ``[start, stop)`` and the warp with the smallest elastic distance.

Distances are in the units of the SRV norm of the representation, as in a database, and
comparable between the takes (one metric per query and take; the query's share of the
weights dominates, as the takes are of the query's skeleton).
"""

from __future__ import annotations

import os
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from elastic_motion.apps.database.files import find_motion_files
from elastic_motion.apps.database.preparation import PreparedMotion, heading_relative_root, prepare_motion
from elastic_motion.apps.progress import Progress
from elastic_motion.apps.report import jsonable
from elastic_motion.curves import srv_transform
from elastic_motion.errors import OptionError, ParseError
from elastic_motion.motion import Motion, group_weights, read_motion
from elastic_motion.motion.representations import Representation, representation
from elastic_motion.warp.partial import PartialWarp, partial_warp

__all__ = ["PartialMatch", "WithinResult", "find_within"]


@dataclass(frozen=True)
class PartialMatch:
    """The best segment of one long take for a query.

    Attributes
    ----------
    name, path : str
        The take.
    start, stop : float
        Seconds from the take's first frame (after preparation: a T-pose frame 0 dropped).
    start_frame, stop_frame : int
        The same as frames of the take at its own frame rate (``stop_frame`` inclusive).
    distance : float
        Elastic distance of the query to the segment (SRV norm units).
    duration : float
        Seconds of the take.
    """

    name: str
    path: str
    start: float
    stop: float
    start_frame: int
    stop_frame: int
    distance: float
    duration: float


@dataclass(frozen=True, eq=False)
class WithinResult:
    """Result of :func:`find_within`.

    Attributes
    ----------
    query : str
    method : {"lie", "euler-elastic"}
    matches : list of PartialMatch
        One per usable take, best (smallest distance) first.
    profiles : dict of str -> ndarray
        Per take name: the best distance of a segment ending at each cell (``+inf`` where
        none), shape ``(n1 + 1,)``; other local minima are other occurrences.
    skipped : list of dict
        ``{"path", "reason"}``: unreadable takes, other skeletons (naming the joints that
        differ), takes too short for the query.
    n_samples : int
    neighbourhood : int
    seconds : float
        Wall time of the DPs.
    """

    query: str
    method: str
    matches: list[PartialMatch]
    profiles: dict[str, np.ndarray]
    skipped: list[dict[str, str]]
    n_samples: int
    neighbourhood: int
    seconds: float

    def summary(self) -> dict[str, Any]:
        """JSON-ready fields (without the profiles)."""
        return jsonable(
            {
                "query": self.query,
                "method": self.method,
                "matches": self.matches,
                "skipped": self.skipped,
                "n_samples": self.n_samples,
                "neighbourhood": self.neighbourhood,
                "seconds": self.seconds,
            }
        )


def _srv(motion: Motion, rep: Representation, weights: tuple[np.ndarray, float] | None) -> np.ndarray:
    """The SRV array of ``motion`` in ``rep`` (Lie: with the inner-product ``weights``)."""
    curve = rep.to_curve(motion, *(weights or (None, None)))
    return np.ascontiguousarray(srv_transform(curve).q)


def find_within(
    query: str | os.PathLike[str],
    takes: str | os.PathLike[str] | Sequence[str | os.PathLike[str]],
    method: str = "lie",
    *,
    n_samples: int = 48,
    neighbourhood: int = 4,
    drop_fingers: bool = True,
    recursive: bool = False,
    progress: Progress | None = None,
) -> WithinResult:
    """Find where ``query`` happens inside each long take: segment and elastic distance.

    Parameters
    ----------
    query : path
        A short motion file.
    takes : path or sequence of paths
        Motion files and/or folders (the long takes).
    method : {"lie", "euler-elastic"}, default "lie"
        Curve representation (``"euler"`` accepted for ``"euler-elastic"``).
    n_samples : int, default 48
        Cells of the query (the takes get as many per query duration).
    neighbourhood : int, default 4
        Largest DP step: a segment lasts between ``1/m`` and ``m`` times the query.
    drop_fingers : bool, default True
    recursive : bool, default False
        Search folders recursively.
    progress : callable, optional
        ``progress("within", done, total)`` per take.

    Returns
    -------
    WithinResult

    Raises
    ------
    OptionError
        Bad ``n_samples`` / ``neighbourhood`` / method; no usable take.
    ParseError
        An unreadable query.
    """
    rep = representation(method)
    if isinstance(n_samples, bool) or not isinstance(n_samples, int) or n_samples < 2:
        raise OptionError("n_samples", f"expected an integer >= 2; got {n_samples!r}")
    if isinstance(neighbourhood, bool) or not isinstance(neighbourhood, int) or neighbourhood < 1:
        raise OptionError("neighbourhood", f"expected an integer >= 1; got {neighbourhood!r}")
    pq = prepare_motion(query, n_samples, drop_fingers=drop_fingers, align_heading=False)
    mq = heading_relative_root(pq.motion)
    files, _ = find_motion_files(
        [takes] if isinstance(takes, str | os.PathLike) else takes, recursive=recursive
    )
    qpath = os.path.realpath(query)
    files = [f for f in files if os.path.realpath(f) != qpath]
    matches: list[PartialMatch] = []
    profiles: dict[str, np.ndarray] = {}
    skipped: list[dict[str, str]] = []
    t_dp = 0.0
    for n, f in enumerate(files):
        try:
            take = _match_take(f, pq, mq, rep, neighbourhood, drop_fingers)
        except (ParseError, ValueError, KeyError, OSError) as exc:
            skipped.append({"path": os.fspath(f), "reason": f"{type(exc).__name__}: {exc}"})
            continue
        finally:
            if progress is not None:
                progress("within", n + 1, len(files))
        t_dp += take.seconds
        matches.append(take.match(f))
        profiles[matches[-1].name] = np.sqrt(np.maximum(take.result.end_energies, 0.0))
    if not matches:
        raise OptionError(
            "takes",
            "expected at least one take of the query's skeleton, long enough; got none ("
            + "; ".join(f"{s['path']}: {s['reason']}" for s in skipped[:5])
            + ")",
        )
    matches.sort(key=lambda m: (m.distance, m.path))
    return WithinResult(
        query=os.fspath(query),
        method=rep.name,
        matches=matches,
        profiles=profiles,
        skipped=skipped,
        n_samples=n_samples,
        neighbourhood=neighbourhood,
        seconds=t_dp,
    )


@dataclass(frozen=True, eq=False)
class _TakeWarp:
    """A long take prepared on the query's cell length (``prepared``: ``n1 + 1`` frames) and
    the open-ended DP's ``result`` on it, which took ``seconds``."""

    prepared: PreparedMotion
    result: PartialWarp
    seconds: float

    def match(self, path: str | os.PathLike[str]) -> PartialMatch:
        """The best segment as seconds and frames of the take at ``path``."""
        pt, res = self.prepared, self.result
        cell = pt.duration / (pt.motion.n_frames - 1)
        fps = (pt.original_frames - 1) / pt.duration if pt.duration > 0 else 1.0
        start, stop = res.start * cell, res.stop * cell
        return PartialMatch(
            name=Path(path).stem,
            path=os.fspath(path),
            start=start,
            stop=stop,
            start_frame=round(start * fps),
            stop_frame=round(stop * fps),
            distance=res.distance,
            duration=pt.duration,
        )


def _match_take(
    path: str | os.PathLike[str],
    pq: PreparedMotion,
    mq: Motion,
    rep: Representation,
    neighbourhood: int,
    drop_fingers: bool,
) -> _TakeWarp:
    """Steps 2-4 of the module docstring for one take against the prepared query ``pq``
    (``n_samples`` cells), ``mq`` its motion with a heading-relative root; the errors of a take
    it cannot use propagate (the caller skips the take)."""
    n_samples = pq.motion.n_frames - 1
    raw = read_motion(path)
    probe = prepare_motion(path, 2, drop_fingers=drop_fingers, align_heading=False, motion=raw)
    if probe.joint_names != pq.joint_names:
        a, b = set(pq.joint_names), set(probe.joint_names)
        raise OptionError(
            "takes",
            f"expected the query's skeleton ({len(a)} joints); got {len(b)} joints: lacks "
            f"{sorted(a - b) or 'nothing'}, extra {sorted(b - a) or 'nothing'}",
        )
    n1 = max(1, round(n_samples * probe.duration / pq.duration))
    pt = prepare_motion(path, n1, drop_fingers=drop_fingers, align_heading=False, motion=raw)
    mt = heading_relative_root(pt.motion)
    weights = group_weights([mq, mt]) if rep.is_lie else None
    q0 = _srv(mq, rep, weights)
    q1 = _srv(mt, rep, weights) / np.sqrt(n1 / n_samples)
    t0 = time.perf_counter()
    res = partial_warp(q0, q1, neighbourhood=neighbourhood)
    return _TakeWarp(pt, res, time.perf_counter() - t0)
