"""The output folder of a matrix run: file names, atomic writes, ``names.csv``, cleaning.

Layout (every write atomic: temporary file + ``os.replace``)::

    names.csv              index,name,path,group,frames,fps,duration,joints
    distances_lie.npy      (M, M) float64, NaN = not computed yet (np.load(..., mmap_mode="r"))
    distances_euler.npy
    tiles/<repr>_<I>_<J>.npy   one finished tile (rows of block I x columns of block J)
    tiles/<repr>_<I>_<J>.json  its record: file, bytes, SHA-256, shape, dtype, tile key
    srv_cache.npz          SRV arrays q_<repr>_<k> (n_samples, D), group ids, settings
    srv_cache.json         its record
    manifest.json          settings + inputs (the identity of the run), tiles done, runs
    report.json            inputs, skipped files with reasons, skeleton groups, engine,
                           timings, "complete": true/false

Tile files with their records are the ground truth of a run, and nothing on disk is trusted:
on resume a tile is kept only if it proves to be the run's own
(:mod:`~elastic_motion.apps.database.verified`, and its values by
:func:`~elastic_motion.apps.database.tiles.tile_problem`); any other is computed again, and
the run's entry in the manifest and report notes why (``tiles_rejected``).
"""

from __future__ import annotations

import contextlib
import io
import json
import re
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from elastic_motion._io import atomic_write_bytes, is_our_temporary, read_text
from elastic_motion.apps.csv_files import csv_text, read_csv_dicts
from elastic_motion.apps.report import jsonable
from elastic_motion.motion.representations import EULER, LIE

if TYPE_CHECKING:
    from elastic_motion.apps.database.cache import SRVCache

CACHE = "srv_cache.npz"
#: The record of the cache (:func:`~elastic_motion.apps.database.verified.record_path`).
CACHE_RECORD = "srv_cache.json"
MANIFEST = "manifest.json"
REPORT = "report.json"
NAMES = "names.csv"
TILES = "tiles"
#: The representations a run may write, whose keys name its files (``distances_<key>.npy``,
#: tiles ``<key>_<I>_<J>.npy``).
REPRESENTATIONS = (LIE, EULER)
TILE_RE = re.compile(rf"^({'|'.join(r.key for r in REPRESENTATIONS)})_(\d+)_(\d+)\.npy$")
#: A tile's record (``<repr>_<I>_<J>.json``).
TILE_RECORD_RE = re.compile(rf"^({'|'.join(r.key for r in REPRESENTATIONS)})_(\d+)_(\d+)\.json$")


def matrix_name(representation: str) -> str:
    """``distances_<representation>.npy``."""
    return f"distances_{representation}.npy"


def tile_key(representation: str, bi: int, bj: int) -> str:
    """Name of a tile without ``.npy``: ``<repr>_<I>_<J>``."""
    return f"{representation}_{bi}_{bj}"


def parse_tile_key(key: str) -> tuple[str, int, int]:
    """Inverse of :func:`tile_key`."""
    r, bi, bj = key.rsplit("_", 2)
    return r, int(bi), int(bj)


def our_names() -> set[str]:
    """Names of the files a run writes at the top of its folder."""
    return {MANIFEST, REPORT, NAMES, CACHE, CACHE_RECORD, *[matrix_name(r.key) for r in REPRESENTATIONS]}


def write_json(dest: Path, obj: Any) -> None:
    """Write ``obj`` (through :func:`elastic_motion.apps.report.jsonable`) atomically."""
    atomic_write_bytes(dest, (json.dumps(jsonable(obj), indent=1, allow_nan=False) + "\n").encode())


def read_json(path: Path) -> Any:
    """The JSON content of ``path`` (a regular file only: :func:`elastic_motion._io.read_text`)."""
    return json.loads(read_text(path))


def save_npy(dest: Path, arr: np.ndarray) -> None:
    """Write ``arr`` as ``.npy`` atomically."""
    buf = io.BytesIO()
    np.save(buf, arr)
    atomic_write_bytes(dest, buf.getvalue())


def write_names(out: Path, cache: SRVCache) -> None:
    """Write ``names.csv`` (one row per motion of the cache, in matrix order; names and paths
    guarded against spreadsheet formulas by :func:`~elastic_motion.apps.csv_files.csv_cell`)."""
    rows: list[list[Any]] = [["index", "name", "path", "group", "frames", "fps", "duration", "joints"]]
    for k, (n, p, g, inf) in enumerate(zip(cache.names, cache.paths, cache.groups, cache.info, strict=True)):
        rows.append([k, n, p, int(g), inf["frames"], inf["fps"], f"{inf['duration']:.6g}", inf["joints"]])
    atomic_write_bytes(out / NAMES, csv_text(rows).encode("utf-8", "surrogateescape"))


def read_names(out: Path) -> list[dict[str, str]]:
    """Rows of ``names.csv`` as dicts, the names and paths as they were before
    :func:`write_names` guarded them."""
    return read_csv_dicts(out / NAMES)


def clean_outputs(out: Path) -> None:
    """Delete the files a run wrote in ``out`` (never anything else)."""
    for name in our_names():
        with contextlib.suppress(FileNotFoundError):
            (out / name).unlink()
    tiles = out / TILES
    if tiles.is_dir():
        for f in tiles.iterdir():
            ours = TILE_RE.match(f.name) or TILE_RECORD_RE.match(f.name) or is_our_temporary(f.name)
            if ours and not f.is_dir():
                f.unlink()
        with contextlib.suppress(OSError):
            tiles.rmdir()
