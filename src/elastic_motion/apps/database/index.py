"""An on-disk index of a motion database: :func:`build_index`, :func:`load_index`.

An index is a folder holding (index format 2)

``index.json``
    ``{"index_format": 2, "library": "<elastic-motion version>", "build": "<random id>",
    "settings": {...}, "n_motions": M, "groups": [...], "skipped": [...], "inputs": [...],
    "dims": {"<repr>": [D of each skeleton group]}, "entries": {...}}``: ``entries`` is the
    SRV cache without its arrays (:meth:`~elastic_motion.apps.database.SRVCache.meta`: names,
    paths and the paths resolved at build time, skeleton groups, group joints and weights, ...);
``srv_<repr>.npy`` and its record ``srv_<repr>.json``
    the SRV arrays of every motion one after another, as one flat float64 array: entry ``k``
    is the ``n_samples x D_g`` values (C order) that follow those of the entries before it
    (``D_g`` of its group, ``dims``). The record
    (:func:`~elastic_motion.apps.database.verified.write_rows`) holds the length and the
    SHA-256 of every entry's values;
``norms_<repr>.npy`` and its record ``norms_<repr>.json``
    shape ``(M, 2, D)``: the part norms of :func:`~elastic_motion.apps.database.bounds.part_norms`
    (the lower bounds of :func:`~elastic_motion.apps.database.knn_search`; ``D`` is the largest
    dimension of the groups, smaller groups padded with zeros, which the bound of an entry of
    the query's group never reads differently); record: size, SHA-256 (:mod:`.verified`).

**Reading** (:func:`load_index`) reads ``index.json``, the records and the norms (``M x 2 x D``
values: 3 MB for 2,500 motions of 25 joints), and opens each ``srv_<repr>.npy`` without reading
its values: an entry's SRV array is read (one positioned read at its offset) only when a distance
needs it -- :func:`~elastic_motion.apps.database.knn_search` reads only the entries its bounds
cannot exclude -- and checked against its SHA-256 then. Positioned reads rather than a memory
map: a file truncated under a map kills the process (``SIGBUS``); a short read is an error that
names the file.

**Nothing on disk is trusted**, as in a matrix run (:mod:`.verified`). Every file is opened only
if it is a regular file (never a link, FIFO or folder) of its record's size; the norms are read
whole and checked against their SHA-256; a SRV file's ``.npy`` header must be the record's (a
flat C-order ``<f8`` array of the entries' total length) and each entry read must have its
record's SHA-256 -- every value a search uses is verified, without reading the values it does
not use (a SHA-256 of the whole file at every search would read everything: what the index is
there to avoid). Each record names the build (``build``, a random id in ``index.json``): files
of two builds are never mixed (norms of one with arrays of another would prune wrongly). Whatever
does not prove to be what the build wrote is an :class:`~elastic_motion.errors.OptionError`
naming the file and giving the command that rebuilds the index.

An index written by another library version is refused with that command (its SRV arrays
follow that version's preparation). One of index format 1 (this version's earlier layout: all
arrays in ``srv_cache.npz``, read whole at every search) is still read, with a note that
rebuilding it makes searches faster.
"""

from __future__ import annotations

import functools
import json
import operator
import os
import secrets
import shlex
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from elastic_motion import __version__
from elastic_motion._io import atomic_write_bytes, open_regular, read_text, remove_stale_temporaries
from elastic_motion.apps.database import storage, verified
from elastic_motion.apps.database.bounds import part_norms
from elastic_motion.apps.database.cache import SRVCache, build_srv_cache
from elastic_motion.apps.database.files import check_output_folder, find_motion_files
from elastic_motion.apps.database.settings import FORMAT_VERSION, DatabaseSettings
from elastic_motion.apps.progress import Progress
from elastic_motion.apps.report import jsonable
from elastic_motion.errors import OptionError, ParseError

__all__ = [
    "INDEX_FORMAT",
    "READABLE_INDEX_FORMATS",
    "IndexRows",
    "MotionIndex",
    "build_index",
    "cache_norms",
    "is_index",
    "load_index",
]

#: Version of the index files this release writes.
INDEX_FORMAT = 2
#: Index formats this release reads (format 1 with a note: :func:`load_index`).
READABLE_INDEX_FORMATS = (1, 2)
INDEX_JSON = "index.json"
#: The SRV arrays of an index of format 1 (the SRV cache of a matrix run).
CACHE = "srv_cache.npz"


def _library_version() -> str:
    return str(__version__)


def srv_file(representation: str) -> str:
    """``srv_<repr>.npy``: the SRV arrays of an index (its record ``srv_<repr>.json``)."""
    return f"srv_{representation}.npy"


def norms_file(representation: str) -> str:
    """``norms_<repr>.npy``: the part norms of an index (its record ``norms_<repr>.json``)."""
    return f"norms_{representation}.npy"


def _own_files() -> set[str]:
    """Every file an index of this or an earlier format holds."""
    out = {INDEX_JSON, CACHE}
    for r in storage.REPRESENTATIONS:
        for name in (srv_file(r.key), norms_file(r.key)):
            out |= {name, verified.record_path(Path(name)).name}
    return out


def cache_norms(cache: SRVCache, key: str) -> np.ndarray:
    """Part norms of every entry of a cache, shape ``(M, 2, D_max)`` (zero-padded), cached on it."""
    memo = getattr(cache, "_norms", None)
    if memo is None:
        memo = {}
        cache._norms = memo  # type: ignore[attr-defined]
    if key not in memo:
        qs = cache.q[key]
        dmax = max((q.shape[1] for q in qs), default=0)
        out = np.zeros((len(qs), 2, dmax))
        for i, q in enumerate(qs):
            out[i, :, : q.shape[1]] = part_norms(q)
        memo[key] = out
    return memo[key]


class IndexRows(Sequence[np.ndarray]):
    """The SRV arrays of one representation of an index (``MotionIndex.cache.q[repr]``): entry
    ``k`` is read from ``srv_<repr>.npy`` the first time it is asked for, checked against its
    SHA-256 (:class:`~elastic_motion.apps.database.verified.VerifiedRows`), then kept.

    Indexing returns a read-only ndarray of shape ``(n_samples, D_g)``; a value that is not the
    build's is an :class:`~elastic_motion.errors.OptionError` that says how to rebuild the index.
    """

    def __init__(
        self, rows: verified.VerifiedRows, shapes: Sequence[tuple[int, int]], rebuild: Callable[[], str]
    ) -> None:
        self._rows = rows
        self._shapes = list(shapes)
        self._rebuild = rebuild
        self._read: dict[int, np.ndarray] = {}

    def __len__(self) -> int:
        return len(self._shapes)

    def __getitem__(self, k: Any) -> Any:
        if isinstance(k, slice):
            return [self[i] for i in range(*k.indices(len(self)))]
        i = operator.index(k)
        if not -len(self) <= i < len(self):
            raise IndexError(f"entry {k} of an index of {len(self)} motions")
        i %= len(self)
        if i not in self._read:
            if self._rows.closed:
                raise ValueError(f"{self._rows.path.parent}: the index was closed (load_index it again)")
            try:
                self._read[i] = self._rows.read(i).reshape(self._shapes[i])
            except verified.NotVerified as exc:
                raise OptionError(
                    "index", f"{self._rows.path.parent}: not what the index wrote: {exc}. " + self._rebuild()
                ) from None
        return self._read[i]

    def __iter__(self) -> Iterator[np.ndarray]:
        return (self[i] for i in range(len(self)))

    @property
    def n_read(self) -> int:
        """Entries read so far."""
        return len(self._read)

    def close(self) -> None:
        """Close the file (entries read stay available)."""
        self._rows.close()


@dataclass(frozen=True, eq=False)
class MotionIndex:
    """An index read back (:func:`load_index`) or just built (:func:`build_index`).

    Attributes
    ----------
    path : Path
    cache : SRVCache
        Its names, groups and settings; its SRV arrays ``cache.q[repr]`` are :class:`IndexRows`
        (read when used) for an index read back, part norms attached.
    meta : dict
        The content of ``index.json`` but ``entries`` (what ``cache`` holds).
    notes : tuple of str
        What the reading says (an index of an earlier format: rebuild it to search faster).
    """

    path: Path
    cache: SRVCache
    meta: dict[str, Any]
    notes: tuple[str, ...] = field(default=())

    def summary(self) -> dict[str, Any]:
        """JSON-ready: the ``index.json`` content (but the entries) and the path."""
        return {"path": os.fspath(self.path), **self.meta}

    def close(self) -> None:
        """Close its SRV files (also done when the index is garbage collected)."""
        for rows in self.cache.q.values():
            if isinstance(rows, IndexRows):
                rows.close()

    def __enter__(self) -> MotionIndex:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def is_index(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` is an index folder (holds ``index.json``)."""
    return (Path(path) / INDEX_JSON).is_file()


def _check_destination(
    dest: Path, inputs: Sequence[str | os.PathLike[str]], files: list, overwrite: bool
) -> None:
    """``OptionError`` unless ``dest`` may receive the index (new, empty, or an index with ``overwrite``)."""
    own = _own_files()
    check_output_folder(dest, inputs, files, own, "out")
    if not dest.exists():
        return
    remove_stale_temporaries(dest / INDEX_JSON)  # those a killed build left (a live one's stay: refused)
    # a folder named as a file of the index is not the index's (never removed: the user's)
    other = [p.name for p in dest.iterdir() if p.name not in own or (p.is_dir() and not p.is_symlink())]
    if other:
        raise OptionError(
            "out",
            f"expected an empty or index folder; got {os.fspath(dest)!r} holding {other[:3]} (move "
            "them elsewhere or choose another folder)",
        )
    if is_index(dest) and not overwrite:
        raise OptionError(
            "out",
            f"expected a new folder; got the index {os.fspath(dest)!r} (pass overwrite=True / --overwrite "
            "to rebuild it)",
        )


def build_index(
    inputs: Sequence[str | os.PathLike[str]],
    out: str | os.PathLike[str],
    settings: DatabaseSettings | None = None,
    *,
    recursive: bool = False,
    overwrite: bool = False,
    progress: Progress | None = None,
) -> MotionIndex:
    """Read every motion once and write its SRV arrays and bounds into the index folder ``out``.

    Parameters
    ----------
    inputs : sequence of paths
        Motion files and/or folders.
    out : path
        Index folder (created).
    settings : DatabaseSettings, optional
        Default ``DatabaseSettings()`` (both representations, 64 cells).
    recursive : bool, default False
    overwrite : bool, default False
        Replace an index already in ``out`` (otherwise an error).
    progress : callable, optional
        ``progress("read", done, total)``.

    Returns
    -------
    MotionIndex
        Its cache holds the arrays in memory.

    Raises
    ------
    OptionError
        ``out`` holding an index (without ``overwrite``) or any other file, holding or lying
        inside an input folder, or being an input or a file; no readable motion.
    """
    settings = settings or DatabaseSettings()
    dest = Path(out)
    files, ignored = find_motion_files(inputs, recursive=recursive)
    _check_destination(dest, inputs, files, overwrite)
    cache = build_srv_cache(files, settings, ignored=ignored, progress=progress)
    if len(cache) == 0:
        raise OptionError(
            "inputs",
            "expected at least one readable motion; got none (skipped: "
            + "; ".join(f"{s['path']}: {s['reason']}" for s in cache.skipped[:5])
            + ")",
        )
    dest.mkdir(parents=True, exist_ok=True)
    (dest / INDEX_JSON).unlink(missing_ok=True)  # an interrupted rebuild is never read as an index
    build = secrets.token_hex(16)
    dims = {r: _group_dims(cache, r) for r in settings.representations}
    for r in settings.representations:
        verified.write_rows(dest / srv_file(r), cache.q[r], representation=r, build=build)
        verified.save_array(dest / norms_file(r), cache_norms(cache, r), representation=r, build=build)
    written = {INDEX_JSON} | {
        n
        for r in settings.representations
        for f in (srv_file(r), norms_file(r))
        for n in (f, verified.record_path(Path(f)).name)
    }
    for name in _own_files() - written:  # an earlier format's files, representations not built again
        (dest / name).unlink(missing_ok=True)
    meta = {
        "index_format": INDEX_FORMAT,
        "library": _library_version(),
        "build": build,
        "settings": settings.to_json(),
        "n_motions": len(cache),
        "groups": [
            {"group": g, "n_joints": len(j), "joints": j, "motions": int((cache.groups == g).sum())}
            for g, j in enumerate(cache.group_joints)
        ],
        "skipped": cache.skipped,
        "inputs": [os.fspath(i) for i in inputs],
        "dims": dims,
    }
    text = json.dumps(
        jsonable({**meta, "entries": cache.meta()}), allow_nan=False
    )  # compact: read at every search
    atomic_write_bytes(dest / INDEX_JSON, (text + "\n").encode())
    return MotionIndex(dest, cache, meta)


def _group_dims(cache: SRVCache, key: str) -> list[int]:
    """The dimension ``D`` of the SRV arrays of each skeleton group of ``cache``."""
    out = []
    for g in range(len(cache.group_joints)):
        members = np.flatnonzero(cache.groups == g)
        out.append(int(cache.q[key][members[0]].shape[1]) if len(members) else 0)
    return out


def _rebuild_command(dest: Path, meta: dict[str, Any]) -> str:
    """``Rebuild it: elastic-motion index INPUTS -o DEST --overwrite`` (the inputs of ``index.json``)."""
    inputs = meta.get("inputs")
    if not isinstance(inputs, list) or not inputs or not all(isinstance(i, str) for i in inputs):
        inputs = ["DIR"]
    args = " ".join(shlex.quote(i) for i in inputs)
    return f"Rebuild it: elastic-motion index {args} -o {shlex.quote(os.fspath(dest))} --overwrite"


def load_index(path: str | os.PathLike[str]) -> MotionIndex:
    """Read an index folder written by :func:`build_index` of this library version.

    Nothing of the SRV arrays is read here (module docstring): ``cache.q[repr]`` reads an entry
    when it is used. Close the index (:meth:`MotionIndex.close`, or ``with load_index(...)``)
    to close its files at once.

    Raises
    ------
    OptionError
        Not an index; an index of another library version or of an unknown format; a file of the
        index that is not what its build wrote (module docstring). The message names the file
        and gives the command that rebuilds the index.
    """
    dest = Path(path)
    if not is_index(dest):
        raise OptionError("index", f"expected an index folder (with {INDEX_JSON}); got {os.fspath(dest)!r}")
    try:
        meta = json.loads(read_text(dest / INDEX_JSON))
    except (ParseError, ValueError) as exc:
        reason = exc.message if isinstance(exc, ParseError) else f"not JSON ({exc})"
        raise OptionError(
            "index", f"{os.fspath(dest / INDEX_JSON)}: {reason}. " + _rebuild_command(dest, {})
        ) from None
    if not isinstance(meta, dict):
        raise OptionError(
            "index", f"{os.fspath(dest / INDEX_JSON)}: expected a JSON object. " + _rebuild_command(dest, {})
        )
    fmt, lib = meta.get("index_format"), meta.get("library")
    if fmt not in READABLE_INDEX_FORMATS or lib != _library_version():
        raise OptionError(
            "index",
            f"{os.fspath(dest)}: expected an index of format {list(READABLE_INDEX_FORMATS)} written by "
            f"elastic-motion {_library_version()}; got format {fmt!r} written by elastic-motion {lib!r}. "
            + _rebuild_command(dest, meta),
        )
    return _load_format_1(dest, meta) if fmt == 1 else _load_rows(dest, meta)


def _load_format_1(dest: Path, meta: dict[str, Any]) -> MotionIndex:
    """An index of format 1: ``srv_cache.npz`` read whole (checked by :meth:`SRVCache.load`), the
    norms ``.npy`` without records; a note to rebuild it."""
    cache = SRVCache.load(dest / CACHE)
    memo = {}
    for r in cache.settings.representations:
        f = dest / norms_file(r)
        if f.exists():
            with open_regular(f) as fh:  # never a FIFO (it would block)
                memo[r] = np.load(fh, allow_pickle=False)
    cache._norms = memo  # type: ignore[attr-defined]
    note = (
        f"{os.fspath(dest)}: an index of format 1 (its SRV arrays in one {CACHE}, read whole at every "
        f"search); still read, but rebuilding it makes searches faster. {_rebuild_command(dest, meta)}"
    )
    return MotionIndex(dest, cache, meta, (note,))


def _entry_layout(meta: dict[str, Any]) -> tuple[DatabaseSettings, dict[str, Any], dict[str, list[int]]]:
    """The settings, entries and group dimensions of ``index.json`` of format 2, checked against
    one another (``KeyError``, ``TypeError``, ``ValueError`` otherwise)."""
    entries = meta["entries"]
    settings = DatabaseSettings.from_json(entries["settings"], entries.get("format", FORMAT_VERSION))
    n = meta["n_motions"]
    groups = entries["groups"]
    n_groups = len(entries["group_joints"])
    lists = [entries["names"], entries["paths"], groups, entries["info"], entries.get("real_paths", groups)]
    if not isinstance(n, int) or not all(isinstance(x, list) and len(x) == n for x in lists):
        raise ValueError(
            f"expected names, paths, resolved paths, groups and info of n_motions = {n!r} entries"
        )
    if not all(isinstance(g, int) and 0 <= g < n_groups for g in groups):
        raise ValueError(f"expected group ids in [0, {n_groups})")
    dims = {r: meta["dims"][r] for r in settings.representations}
    for r, d in dims.items():
        if not (isinstance(d, list) and len(d) == n_groups and all(isinstance(x, int) and x > 0 for x in d)):
            raise ValueError(f"dims[{r!r}]: expected {n_groups} positive dimensions; got {d!r}")
    if not isinstance(meta["build"], str):
        raise ValueError("build: expected the id of the build")
    return settings, entries, dims


def _load_rows(dest: Path, meta: dict[str, Any]) -> MotionIndex:
    """An index of format 2 (module docstring): records and norms checked, SRV files opened."""
    rebuild = functools.partial(_rebuild_command, dest, meta)  # for a message only (it quotes every input)
    try:
        settings, entries, dims = _entry_layout(meta)
    except (KeyError, TypeError, ValueError, AttributeError, OptionError) as exc:
        raise OptionError(
            "index", f"{os.fspath(dest / INDEX_JSON)}: damaged ({type(exc).__name__}: {exc}). {rebuild()}"
        ) from None
    n, groups = meta["n_motions"], entries["groups"]
    q: dict[str, Sequence[np.ndarray]] = {}
    norms = {}
    try:
        for r in settings.representations:
            shapes = [(settings.n_samples, dims[r][g]) for g in groups]
            rows = verified.open_rows(
                dest / srv_file(r), [a * b for a, b in shapes], representation=r, build=meta["build"]
            )
            q[r] = IndexRows(rows, shapes, rebuild)
            norms[r] = verified.load_array(
                dest / norms_file(r), (n, 2, max(dims[r], default=0)), representation=r, build=meta["build"]
            )
    except verified.NotVerified as exc:
        for rows in q.values():
            rows.close()  # type: ignore[attr-defined]
        problem = f"{os.fspath(dest)}: not what the index wrote: {exc}. {rebuild()}"
        raise OptionError("index", problem) from None
    try:
        cache = SRVCache.from_meta(os.fspath(dest / INDEX_JSON), entries, q)
    except (KeyError, TypeError, ValueError, OptionError) as exc:
        raise OptionError(
            "index", f"{os.fspath(dest / INDEX_JSON)}: damaged ({type(exc).__name__}: {exc}). {rebuild()}"
        ) from None
    cache._norms = norms  # type: ignore[attr-defined]
    return MotionIndex(dest, cache, {k: v for k, v in meta.items() if k != "entries"})
