"""One motion against a database: :func:`query_distances` -> :class:`QueryResult` (every
distance), :func:`knn_search` -> :class:`SearchResult` (exact k nearest, pruned by the
bounds of :mod:`.bounds`)."""

from __future__ import annotations

import contextlib
import dataclasses
import os
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from elastic_motion.apps.database import storage
from elastic_motion.apps.database.bounds import lower_bounds, part_norms
from elastic_motion.apps.database.cache import SRVCache, build_srv_cache, srv_arrays
from elastic_motion.apps.database.files import find_motion_files
from elastic_motion.apps.database.index import cache_norms, is_index, load_index
from elastic_motion.apps.database.preparation import prepare_motion, with_pose_term
from elastic_motion.apps.database.settings import QUERY_FIELDS, DatabaseSettings, ignored_settings_note
from elastic_motion.apps.database.tiles import pair_distances, single_threaded_blas
from elastic_motion.apps.prepare import rest_pose_like
from elastic_motion.apps.progress import Progress
from elastic_motion.apps.report import jsonable
from elastic_motion.apps.statistics import nearest
from elastic_motion.errors import OptionError
from elastic_motion.motion import group_weights
from elastic_motion.motion.representations import representation

__all__ = ["QueryResult", "SearchResult", "is_stored_database", "knn_search", "query_distances", "query_srv"]

#: Pairs of a query solved in one call of the batched DP (progress is reported between calls).
QUERY_BATCH = 64
#: Largest batch of pair distances the exact k-nearest search computes in one call.
KNN_BATCH = 32


@dataclass(frozen=True, eq=False)
class QueryResult:
    """Distances from one motion to every motion of a database (:func:`query_distances`).

    Attributes
    ----------
    query : str
        The query file.
    representation : {"lie", "euler"}
        The stored key of the curve representation (:attr:`method` is its public name).
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
        Settings a stored database did not use (``settings`` given that differ from its own,
        :func:`~elastic_motion.apps.database.settings.ignored_settings_note`), then what the
        preparation did to the query.
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

    @property
    def method(self) -> str:
        """The curve representation's public name: ``"lie"`` or ``"euler-elastic"``."""
        return representation(self.representation).name

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
        query = os.path.realpath(self.query)
        exclude = [i for i, p in enumerate(self.paths) if exclude_query and os.path.realpath(p) == query]
        return nearest(self.distances, k, exclude=exclude)

    def summary(self) -> dict[str, Any]:
        """JSON-ready fields (``+inf`` becomes ``null``), by :func:`elastic_motion.apps.report.jsonable`."""
        return jsonable(self)


def is_stored_database(database: str | os.PathLike[str] | Sequence[str | os.PathLike[str]]) -> bool:
    """Whether ``database`` is one stored database: an index (:mod:`.index`) or a matrix output
    folder (its ``srv_cache.npz``), measured with the settings it was built with."""
    db = [database] if isinstance(database, str | os.PathLike) else list(database)
    return len(db) == 1 and (is_index(db[0]) or (Path(db[0]) / storage.CACHE).exists())


@contextlib.contextmanager
def _open_database(
    database: str | os.PathLike[str] | Sequence[str | os.PathLike[str]],
    key: str,
    settings: DatabaseSettings | None,
    progress: Progress | None,
) -> Iterator[tuple[SRVCache, tuple[str, ...]]]:
    """The SRV cache of a matrix folder, an index (:mod:`.index`: its files closed on exit) or
    files read now, and the notes: the ``settings`` a stored database does not use (none when it
    uses them), what reading an index said."""
    db = [database] if isinstance(database, str | os.PathLike) else list(database)
    stored = [os.fspath(d) for d in db if is_stored_database(d)]
    if len(db) > 1 and stored:
        raise OptionError(
            "database",
            f"expected one stored database (an index or a matrix folder) or motion files and folders; got "
            f"{len(db)} entries, of which stored: {stored} (search them one at a time)",
        )
    notes: tuple[str, ...] = ()
    with contextlib.ExitStack() as stack:
        if is_stored_database(db):
            if is_index(db[0]):
                idx = stack.enter_context(load_index(db[0]))
                cache, notes = idx.cache, idx.notes
            else:
                cache = SRVCache.load(Path(db[0]) / storage.CACHE)
            note = None if settings is None else ignored_settings_note(settings, cache.settings, QUERY_FIELDS)
            notes = (*notes, *([] if note is None else [note]))
        else:
            if settings is None:
                settings = DatabaseSettings(representations=(key,))
            files, ignored = find_motion_files(db)
            cache = build_srv_cache(files, settings, ignored=ignored, progress=progress)
        if key not in cache.settings.representations:
            raise OptionError(
                "method",
                "expected one of the representations of the database "
                f"{[representation(r).name for r in cache.settings.representations]}; "
                f"got {representation(key).name!r}",
            )
        yield cache, notes


def _own_file(query: str | os.PathLike[str], cache: SRVCache) -> np.ndarray:
    """Whether each entry of ``cache`` is the file ``query`` itself, shape ``(M,)`` bool: the
    query's path resolved once against the entries' paths resolved when the cache was built
    (``cache.real_paths``; resolved now for a cache that does not hold them)."""
    real = cache.real_paths
    if len(real) != len(cache):
        real = [os.path.realpath(p) for p in cache.paths]
    qpath = os.path.realpath(query)
    return np.fromiter((p == qpath for p in real), dtype=bool, count=len(real))


def _query_srv(
    query: str | os.PathLike[str], cache: SRVCache, key: str
) -> tuple[np.ndarray, int, tuple, tuple]:
    """The query's SRV array in its group's metric, its group (-1: none), notes and joint names."""
    settings = cache.settings
    select: str | Sequence[str] = "all"
    if settings.joints == "common" and cache.group_joints:
        select = cache.group_joints[0]
    elif settings.joints == "map" or not isinstance(settings.joints, str):
        select = settings.joints
    p = prepare_motion(
        query,
        settings.n_samples,
        smoothing=settings.warp.sample_smoothing,
        joints=select,
        drop_fingers=settings.drop_fingers,
        align_heading=settings.align_heading,
        options=settings.read_options(),
    )
    try:
        g = [tuple(j) for j in cache.group_joints].index(p.joint_names)
    except ValueError:
        g = -1
    ref = cache.group_rest_skeleton(g, p.motion.skeleton) if g >= 0 else None
    if ref is not None:  # in its group's rest frames, as the database's motions are
        moved, rest_notes = rest_pose_like(ref[0], p.motion, ref[1], Path(os.fspath(query)).stem)
        if rest_notes:
            p = dataclasses.replace(p, motion=moved, notes=(*p.notes, *rest_notes))
    if g >= 0:  # the query is measured in its group's shared metric
        jw, tw = cache.group_weights[g]
        weights = (np.asarray(jw), float(tw))
    else:
        weights = group_weights([p.motion])
    arrays = srv_arrays(p, [key], weights, pose=bool(settings.pose_weight))
    qq = arrays[key]
    if settings.pose_weight and g >= 0:  # the database's pose weight (balanced over its motions)
        qq = with_pose_term(qq, arrays["pose"], cache.pose_weights[key][g])
    return qq, g, p.notes, p.joint_names


def query_srv(query: str | os.PathLike[str], cache: SRVCache, method: str = "lie") -> np.ndarray:
    """The SRV array of the motion file ``query`` as a search against ``cache`` compares it:
    prepared with the database's settings, in the rest pose and the metric of its skeleton
    group (e.g. to run a baseline on the features :func:`knn_search` compares).

    Parameters
    ----------
    query : path
    cache : SRVCache
        A database's (``load_index(path).cache``, :func:`build_srv_cache`, ``SRVCache.load``).
    method : {"lie", "euler-elastic"}, default "lie"

    Returns
    -------
    ndarray, shape (n_samples, D)

    Raises
    ------
    OptionError
        The database holds no motion of the query's skeleton (the message says which joints
        differ).
    """
    qq, g, _, joints = _query_srv(query, cache, representation(method).key)
    if g < 0:
        raise OptionError("query", f"{os.fspath(query)}: {_skeleton_difference(joints, cache)}")
    return qq


def _method_key(method: str, legacy: str | None) -> str:
    """The stored key of ``method``, or of ``legacy`` (the argument ``representation`` of
    earlier releases) when given."""
    if legacy is not None:
        return representation(legacy, "representation").key
    return representation(method).key


def query_distances(
    query: str | os.PathLike[str],
    database: str | os.PathLike[str] | Sequence[str | os.PathLike[str]],
    method: str = "lie",
    settings: DatabaseSettings | None = None,
    *,
    progress: Progress | None = None,
    representation: str | None = None,
) -> QueryResult:
    """Distances from one motion to every motion of a database.

    Parameters
    ----------
    query : path
        A motion file.
    database : path or sequence of paths
        A matrix output folder (its ``srv_cache.npz`` and settings are used; nothing is
        written), an index (:func:`~elastic_motion.apps.database.build_index`),
        or motion files / folders (read now, nothing cached).
    method : {"lie", "euler-elastic"}, default "lie"
        The curve representation; ``"euler"`` is accepted for ``"euler-elastic"``.
    settings : DatabaseSettings, optional
        For a database of files (default ``DatabaseSettings(representations=(method,))``). A
        stored database (:func:`is_stored_database`) is measured with its own settings: the
        fields of :data:`~elastic_motion.apps.database.settings.QUERY_FIELDS` in which these
        differ from them are named in ``notes``.
    progress : callable, optional
        ``progress(stage, done, total)``: ``"read"`` (database files), ``"query"`` (pairs).
    representation : str, optional
        The name of ``method`` in earlier releases (same values); overrides ``method``.

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
    key = _method_key(method, representation)
    with _open_database(database, key, settings, progress) as (cache, ignored):
        qq, g, notes, _ = _query_srv(query, cache, key)
        members = np.flatnonzero(cache.groups == g)
        out = np.full(len(cache), np.inf)
        with single_threaded_blas():  # in batches: one compiled call per QUERY_BATCH pairs
            for n0 in range(0, len(members), QUERY_BATCH):
                chunk = members[n0 : n0 + QUERY_BATCH]
                pairs = np.column_stack([np.zeros(len(chunk), dtype=np.int64), chunk])
                out[chunk] = pair_distances(
                    [qq], cache.q[key], pairs, cache.settings.warp, cyclic=cache.settings.cyclic
                )
                if progress is not None:
                    progress("query", n0 + len(chunk), len(members))
    return QueryResult(
        query=os.fspath(query),
        representation=key,
        names=list(cache.names),
        paths=list(cache.paths),
        distances=out,
        group=g,
        settings=cache.settings,
        skipped=list(cache.skipped),
        notes=(*ignored, *notes),
    )


@dataclass(frozen=True, eq=False)
class SearchResult:
    """The exact k nearest motions of a query (:func:`knn_search`).

    Attributes
    ----------
    query : str
    method : {"lie", "euler-elastic"}
    indices : ndarray of int, shape (<= k,)
        Database indices of the nearest motions, nearest first (ties by index): the same as
        ranking every exact distance (``query_distances(...).nearest(k)``).
    distances : ndarray, shape (<= k,)
        Their elastic distances (bit-identical to :func:`query_distances`'s).
    names, paths : list of str
        Of the whole database (length ``M``).
    lower_bounds : ndarray, shape (M,)
        The bound of :func:`~elastic_motion.apps.database.bounds.lower_bounds` for each entry
        (``+inf`` outside the query's skeleton group).
    computed : ndarray of bool, shape (M,)
        Entries whose full DP distance was computed.
    candidates : int
        Entries of the query's group (less the query itself when excluded).
    group : int
        Skeleton group of the query; -1 if the database holds no motion of its skeleton.
    settings : DatabaseSettings
    skipped : list of dict
    notes : tuple of str
        Settings a stored database did not use (as :attr:`QueryResult.notes`), the query's
        preparation; with ``group == -1`` last which joints differ from the nearest group of
        the database.
    seconds : float
        Wall time of the search (bounds and DPs, not reading).
    """

    query: str
    method: str
    indices: np.ndarray
    distances: np.ndarray
    names: list[str]
    paths: list[str]
    lower_bounds: np.ndarray
    computed: np.ndarray
    candidates: int
    group: int
    settings: DatabaseSettings
    skipped: list[dict[str, str]]
    notes: tuple[str, ...] = ()
    seconds: float = 0.0

    @property
    def n_computed(self) -> int:
        """Full DP solves made."""
        return int(self.computed.sum())

    @property
    def fraction_pruned(self) -> float:
        """Share of the candidates whose DP the bounds made unnecessary (0 with no candidate)."""
        return 1.0 - self.n_computed / self.candidates if self.candidates else 0.0

    def summary(self) -> dict[str, Any]:
        """JSON-ready fields: the results, the pruning and the settings."""
        return jsonable(
            {
                "query": self.query,
                "method": self.method,
                "results": [
                    {"rank": r + 1, "name": self.names[i], "path": self.paths[i], "distance": float(d)}
                    for r, (i, d) in enumerate(zip(self.indices, self.distances, strict=True))
                ],
                "candidates": self.candidates,
                "computed": self.n_computed,
                "fraction_pruned": self.fraction_pruned,
                "seconds": self.seconds,
                "group": self.group,
                "settings": self.settings,
                "skipped": self.skipped,
                "notes": self.notes,
            }
        )


def _skeleton_difference(joints: Sequence[str], cache: SRVCache, stored: bool = False) -> str:
    """Which joints differ between a query's skeleton and the nearest group of a database."""
    if not cache.group_joints:
        return "the database holds no motion"
    mine = set(joints)
    best = min(range(len(cache.group_joints)), key=lambda g: len(mine ^ set(cache.group_joints[g])))
    theirs = set(cache.group_joints[best])
    missing = sorted(theirs - mine)
    extra = sorted(mine - theirs)
    return (
        f"the database holds no motion of the query's skeleton ({len(joints)} joints); nearest group "
        f"{best} ({len(theirs)} joints): the query lacks {missing or 'nothing'}, "
        f"has extra {extra or 'nothing'}"
        + ("" if missing or extra else " (same names, another order)")
        + (
            "; build the database again on shared joints (joints='common', or 'map' across skeletons; "
            "--joints common / map)"
            if stored
            else "; compare on shared joints with joints='common' (--joints common)"
        )
    )


def knn_search(
    query: str | os.PathLike[str],
    database: str | os.PathLike[str] | Sequence[str | os.PathLike[str]],
    k: int = 5,
    method: str = "lie",
    settings: DatabaseSettings | None = None,
    *,
    exclude_query: bool = True,
    progress: Progress | None = None,
) -> SearchResult:
    """Exact k nearest motions of a query, computing the full DP only where the bounds cannot
    exclude an entry.

    Entries are visited by increasing lower bound (:mod:`.bounds`: the norms of the positive
    and negative parts of each SRV coordinate, which a warp keeps); the search stops when the
    next lower bound exceeds the current k-th distance. The result equals ranking every
    exact distance (same pair function, same tie rule).

    Parameters
    ----------
    query : path
    database : path or sequence of paths
        As in :func:`query_distances` (an index built by ``elastic-motion index`` avoids
        reading the database files).
    k : int, default 5
    method : {"lie", "euler-elastic"}, default "lie"
    settings : DatabaseSettings, optional
        For a database of files; against a stored database, as in :func:`query_distances`.
    exclude_query : bool, default True
        Leave out entries that are the query file itself.
    progress : callable, optional
        ``progress("read", done, total)`` while files are read.

    Returns
    -------
    SearchResult

    Raises
    ------
    OptionError
        ``k < 1``; a representation the database does not hold.
    """
    if isinstance(k, bool) or not isinstance(k, int | np.integer) or k < 1:
        raise OptionError("k", f"expected an integer >= 1; got {k!r}")
    key = representation(method).key
    with _open_database(database, key, settings, progress) as (cache, ignored):
        qq, g, notes, joints = _query_srv(query, cache, key)
        notes = (*ignored, *notes)
        t0 = time.perf_counter()
        m = len(cache)
        lb = np.full(m, np.inf)
        computed = np.zeros(m, dtype=bool)
        in_group = cache.groups == g
        members = np.flatnonzero(in_group & ~_own_file(query, cache) if exclude_query else in_group)
        found: list[tuple[float, int]] = []
        if g < 0:
            notes = (*notes, _skeleton_difference(joints, cache, is_stored_database(database)))
        elif len(members):
            norms = cache_norms(cache, key)
            lb[members] = lower_bounds(
                part_norms(qq), norms[members][:, :, : qq.shape[1]]
            )  # one group: one D
            found = _exact_nearest(qq, cache.q[key], cache.settings, members, lb, k, computed)
    top = found[:k]
    return SearchResult(
        query=os.fspath(query),
        method=representation(key).name,
        indices=np.array([i for _, i in top], dtype=np.int64),
        distances=np.array([d for d, _ in top]),
        names=list(cache.names),
        paths=list(cache.paths),
        lower_bounds=lb,
        computed=computed,
        candidates=len(members),
        group=g,
        settings=cache.settings,
        skipped=list(cache.skipped),
        notes=tuple(notes),
        seconds=time.perf_counter() - t0,
    )


def _exact_nearest(
    qq: np.ndarray,
    q: Sequence[np.ndarray],
    settings: DatabaseSettings,
    members: np.ndarray,
    lb: np.ndarray,
    k: int,
    computed: np.ndarray,
) -> list[tuple[float, int]]:
    """The exact distances ``(d, index)`` of the query's SRV array ``qq`` to the entries
    ``members`` of ``q`` that the lower bounds ``lb`` cannot exclude from the ``k`` nearest,
    sorted; ``computed`` marks them.

    Entries are visited by increasing bound (ties by index), in batches of growing size (``k``,
    then doubling up to :data:`KNN_BATCH`): one compiled call per batch instead of one per
    pair; a batch holds only entries whose bound is below the current k-th distance, so at most
    a batch more is computed than one by one.
    """
    order = members[np.lexsort((members, lb[members]))]
    found: list[tuple[float, int]] = []
    pos, step = 0, k
    with single_threaded_blas():
        while pos < len(order):
            batch = order[pos : pos + step]
            if len(found) >= k:
                batch = batch[lb[batch] <= found[k - 1][0]]  # a prefix: the bounds are sorted
            if not len(batch):
                break
            pairs = np.column_stack([np.zeros(len(batch), dtype=np.int64), batch])
            ds = pair_distances([qq], q, pairs, settings.warp, cyclic=settings.cyclic)
            computed[batch] = True
            found.extend((float(d), int(i)) for d, i in zip(ds, batch, strict=True))
            found.sort()
            pos += step
            step = min(2 * step, KNN_BATCH)
    return found
