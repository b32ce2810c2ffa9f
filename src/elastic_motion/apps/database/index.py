"""An on-disk index of a motion database: :func:`build_index`, :func:`load_index`.

An index is a folder holding

``index.json``
    ``{"index_format": 1, "library": "<elastic-motion version>", "settings": {...},
    "n_motions": M, "groups": [...], "skipped": [...]}``;
``srv_cache.npz``
    the SRV arrays of every readable motion (:class:`~elastic_motion.apps.database.SRVCache`,
    the same file a matrix run writes);
``norms_<repr>.npy``
    shape ``(M, 2, D)``: the part norms of :func:`~elastic_motion.apps.database.bounds.part_norms`
    (the lower bounds of :func:`~elastic_motion.apps.database.knn_search`; ``D`` is the largest
    dimension of the groups, smaller groups padded with zeros, which the bound of an entry
    of the query's group never reads differently).

A query against an index reads one file instead of every motion. An index written by another
library version (or index format) is refused with the command that rebuilds it: its SRV
arrays follow that version's preparation.
"""

from __future__ import annotations

import io
import json
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from elastic_motion import __version__
from elastic_motion._io import atomic_write_bytes, open_regular, read_text, remove_stale_temporaries
from elastic_motion.apps.database import storage
from elastic_motion.apps.database.bounds import part_norms
from elastic_motion.apps.database.cache import SRVCache, build_srv_cache
from elastic_motion.apps.database.files import check_output_folder, find_motion_files
from elastic_motion.apps.database.settings import DatabaseSettings
from elastic_motion.apps.progress import Progress
from elastic_motion.errors import OptionError

__all__ = ["INDEX_FORMAT", "MotionIndex", "build_index", "cache_norms", "is_index", "load_index"]

#: Version of the index files; an index of another format is refused.
INDEX_FORMAT = 1
INDEX_JSON = "index.json"
CACHE = "srv_cache.npz"


def _library_version() -> str:
    return str(__version__)


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


@dataclass(frozen=True, eq=False)
class MotionIndex:
    """An index read back (:func:`load_index`).

    Attributes
    ----------
    path : Path
    cache : SRVCache
        Its SRV arrays, names, groups and settings (part norms attached).
    meta : dict
        The content of ``index.json``.
    """

    path: Path
    cache: SRVCache
    meta: dict[str, Any]

    def summary(self) -> dict[str, Any]:
        """JSON-ready: the ``index.json`` content and the path."""
        return {"path": os.fspath(self.path), **self.meta}


def is_index(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` is an index folder (holds ``index.json``)."""
    return (Path(path) / INDEX_JSON).is_file()


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

    Raises
    ------
    OptionError
        ``out`` holding an index (without ``overwrite``) or any other file, holding or lying
        inside an input folder, or being an input or a file; no readable motion.
    """
    settings = settings or DatabaseSettings()
    dest = Path(out)
    own = {INDEX_JSON, CACHE} | {f"norms_{r.key}.npy" for r in storage.REPRESENTATIONS}
    files, ignored = find_motion_files(inputs, recursive=recursive)
    check_output_folder(dest, inputs, files, own, "out")
    if dest.exists():
        remove_stale_temporaries(dest / CACHE)  # those a killed build left (a live one's stay: refused)
        other = [p.name for p in dest.iterdir() if p.name not in own]
        if other:
            raise OptionError(
                "out", f"expected an empty or index folder; got {os.fspath(dest)!r} holding {other[:3]}"
            )
        if is_index(dest) and not overwrite:
            raise OptionError(
                "out",
                f"expected a new folder; got the index {os.fspath(dest)!r} "
                "(pass overwrite=True / --overwrite "
                "to rebuild it)",
            )
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
    cache.save(dest / CACHE)
    for r in settings.representations:
        buf = _npy_bytes(cache_norms(cache, r))
        atomic_write_bytes(dest / f"norms_{r}.npy", buf)
    meta = {
        "index_format": INDEX_FORMAT,
        "library": _library_version(),
        "settings": settings.to_json(),
        "n_motions": len(cache),
        "groups": [
            {"group": g, "n_joints": len(j), "joints": j, "motions": int((cache.groups == g).sum())}
            for g, j in enumerate(cache.group_joints)
        ],
        "skipped": cache.skipped,
        "inputs": [os.fspath(i) for i in inputs],
    }
    atomic_write_bytes(dest / INDEX_JSON, json.dumps(meta, indent=1).encode())
    return MotionIndex(dest, cache, meta)


def _npy_bytes(a: np.ndarray) -> bytes:
    buf = io.BytesIO()
    np.save(buf, a)
    return buf.getvalue()


def load_index(path: str | os.PathLike[str]) -> MotionIndex:
    """Read an index folder written by :func:`build_index` of this library version.

    Raises
    ------
    OptionError
        Not an index; an index of another format or library version (the message gives the
        command that rebuilds it).
    """
    dest = Path(path)
    if not is_index(dest):
        raise OptionError("index", f"expected an index folder (with {INDEX_JSON}); got {os.fspath(dest)!r}")
    meta = json.loads(read_text(dest / INDEX_JSON))
    fmt, lib = meta.get("index_format"), meta.get("library")
    if fmt != INDEX_FORMAT or lib != _library_version():
        inputs = " ".join(meta.get("inputs") or ["DIR"])
        raise OptionError(
            "index",
            f"{os.fspath(dest)}: expected an index of format {INDEX_FORMAT} written by elastic-motion "
            f"{_library_version()}; got format {fmt!r} written by elastic-motion {lib!r}. Rebuild it: "
            f"elastic-motion index {inputs} -o {os.fspath(dest)} --overwrite",
        )
    cache = SRVCache.load(dest / CACHE)
    memo = {}
    for r in cache.settings.representations:
        f = dest / f"norms_{r}.npy"
        if f.exists():
            with open_regular(f) as fh:  # never a FIFO (it would block)
                memo[r] = np.load(fh, allow_pickle=False)
    cache._norms = memo  # type: ignore[attr-defined]
    return MotionIndex(dest, cache, meta)
