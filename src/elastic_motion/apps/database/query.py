"""One motion against a database: :func:`query_distances` -> :class:`QueryResult`."""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from elastic_motion.apps.database import storage
from elastic_motion.apps.database.cache import SRVCache, build_srv_cache, srv_arrays
from elastic_motion.apps.database.files import find_motion_files
from elastic_motion.apps.database.preparation import prepare_motion
from elastic_motion.apps.database.settings import DatabaseSettings
from elastic_motion.apps.database.tiles import pair_distance, single_threaded_blas
from elastic_motion.apps.progress import Progress
from elastic_motion.apps.report import jsonable
from elastic_motion.errors import OptionError
from elastic_motion.motion import group_weights

__all__ = ["QueryResult", "query_distances"]


@dataclass(frozen=True, eq=False)
class QueryResult:
    """Distances from one motion to every motion of a database (:func:`query_distances`).

    Attributes
    ----------
    query : str
        The query file.
    representation : {"lie", "euler"}
    names : list of str
        Database motion names, in database order (length ``M``).
    paths : list of str
        Their files (length ``M``).
    distances : ndarray, shape (M,), float64
        Distance of the query to each motion, in the units of the representation's SRV
        norm; ``+inf`` for motions whose skeleton (after joint selection) differs from the
        query's. A database motion that is the query file itself has distance 0.
    group : int
        Skeleton group of the database the query belongs to; -1 if none (all distances
        ``+inf``).
    settings : DatabaseSettings
        The settings the distances were computed with (the database's, for a matrix folder).
    skipped : list of dict
        Database files that could not be used: ``{"path", "reason"}``.
    notes : tuple of str
        What the preparation did to the query.
    """

    query: str
    representation: str
    names: list[str]
    paths: list[str]
    distances: np.ndarray
    group: int
    settings: DatabaseSettings
    skipped: list[dict[str, str]]
    notes: tuple[str, ...] = ()

    def nearest(self, k: int = 5, *, exclude_query: bool = True) -> np.ndarray:
        """Indices of the ``k`` nearest motions (finite distances), nearest first.

        Parameters
        ----------
        k : int, default 5
        exclude_query : bool, default True
            Leave out database entries that are the query file itself.

        Returns
        -------
        ndarray of int, shape (<= k,)
            Ties broken by index.
        """
        from elastic_motion.apps.statistics import nearest

        query = os.path.realpath(self.query)
        exclude = [i for i, p in enumerate(self.paths) if exclude_query and os.path.realpath(p) == query]
        return nearest(self.distances, k, exclude=exclude)

    def summary(self) -> dict[str, Any]:
        """JSON-ready fields (``+inf`` becomes ``null``), by :func:`elastic_motion.apps.report.jsonable`."""
        return jsonable(self)


def query_distances(
    query: str | os.PathLike[str],
    database: str | os.PathLike[str] | Sequence[str | os.PathLike[str]],
    representation: str = "lie",
    settings: DatabaseSettings | None = None,
    *,
    progress: Progress | None = None,
) -> QueryResult:
    """Distances from one motion to every motion of a database.

    Parameters
    ----------
    query : path
        A motion file.
    database : path or sequence of paths
        A matrix output folder (its ``srv_cache.npz`` and settings are used; ``settings`` is
        then ignored and nothing is written), or motion files / folders (read now, nothing
        cached).
    representation : {"lie", "euler"}, default "lie"
    settings : DatabaseSettings, optional
        For a database of files (default ``DatabaseSettings(representations=(representation,))``).
    progress : callable, optional
        ``progress(stage, done, total)``: ``"read"`` (database files), ``"query"`` (pairs).

    Returns
    -------
    QueryResult

    Raises
    ------
    ParseError
        Unreadable query.
    OptionError
        A representation the database does not hold; a query missing the joints asked for.
    """
    db = [database] if isinstance(database, str | os.PathLike) else list(database)
    if len(db) == 1 and (Path(db[0]) / storage.CACHE).exists():
        cache = SRVCache.load(Path(db[0]) / storage.CACHE)
    else:
        if settings is None:
            settings = DatabaseSettings(representations=(representation,))
        files, ignored = find_motion_files(db)
        cache = build_srv_cache(files, settings, ignored=ignored, progress=progress)
    settings = cache.settings
    if representation not in settings.representations:
        raise OptionError(
            "representation",
            f"expected one of the representations of the database {list(settings.representations)}; "
            f"got {representation!r}",
        )
    select: str | Sequence[str] = "all"
    if settings.joints == "common" and cache.group_joints:
        select = cache.group_joints[0]
    elif not isinstance(settings.joints, str):
        select = settings.joints
    p = prepare_motion(
        query,
        settings.n_samples,
        joints=select,
        drop_fingers=settings.drop_fingers,
        align_heading=settings.align_heading,
    )
    try:
        g = [tuple(j) for j in cache.group_joints].index(p.joint_names)
    except ValueError:
        g = -1
    members = [k for k in range(len(cache)) if cache.groups[k] == g]
    if g >= 0:  # the query is measured in its group's shared metric
        jw, tw = cache.group_weights[g]
        weights = (np.asarray(jw), float(tw))
    else:
        weights = group_weights([p.motion])
    qq = srv_arrays(p, [representation], weights)[representation]
    out = np.full(len(cache), np.inf)
    with single_threaded_blas():
        for n, k in enumerate(members):
            out[k] = pair_distance(qq, cache.q[representation][k], settings.warp)
            if progress is not None:
                progress("query", n + 1, len(members))
    return QueryResult(
        query=os.fspath(query),
        representation=representation,
        names=list(cache.names),
        paths=list(cache.paths),
        distances=out,
        group=g,
        settings=settings,
        skipped=list(cache.skipped),
        notes=p.notes,
    )
