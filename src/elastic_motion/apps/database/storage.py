"""The output folder of a matrix run: file names, atomic writes, ``names.csv``, cleaning.

Layout (every write atomic: temporary file + ``os.replace``)::

    names.csv              index,name,path,group,frames,fps,duration,joints
    distances_lie.npy      (M, M) float64, NaN = not computed yet (np.load(..., mmap_mode="r"))
    distances_euler.npy
    tiles/<repr>_<I>_<J>.npy   one finished tile (rows of block I x columns of block J)
    srv_cache.npz          SRV arrays q_<repr>_<k> (n_samples, D), group ids, settings
    manifest.json          settings + inputs (the identity of the run), tiles done, runs
    report.json            inputs, skipped files with reasons, skeleton groups, engine,
                           timings, "complete": true/false

Tile files are the ground truth of a run: on resume every tile file already on disk is
kept and the matrices are rebuilt from them.
"""

from __future__ import annotations

import contextlib
import io
import json
import re
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from elastic_motion._io import atomic_write_bytes
from elastic_motion.apps.csv_files import csv_text, read_csv_dicts
from elastic_motion.apps.report import jsonable
from elastic_motion.motion.representations import EULER, LIE

if TYPE_CHECKING:
    from elastic_motion.apps.database.cache import SRVCache

CACHE = "srv_cache.npz"
MANIFEST = "manifest.json"
REPORT = "report.json"
NAMES = "names.csv"
TILES = "tiles"
#: The representations a run may write, whose keys name its files (``distances_<key>.npy``,
#: tiles ``<key>_<I>_<J>.npy``).
REPRESENTATIONS = (LIE, EULER)
TILE_RE = re.compile(rf"^({'|'.join(r.key for r in REPRESENTATIONS)})_(\d+)_(\d+)\.npy$")


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
    return {MANIFEST, REPORT, NAMES, CACHE, *[matrix_name(r.key) for r in REPRESENTATIONS]}


def write_json(dest: Path, obj: Any) -> None:
    """Write ``obj`` (through :func:`elastic_motion.apps.report.jsonable`) atomically."""
    atomic_write_bytes(dest, (json.dumps(jsonable(obj), indent=1, allow_nan=False) + "\n").encode())


def read_json(path: Path) -> Any:
    """The JSON content of ``path``."""
    return json.loads(path.read_text())


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
            if TILE_RE.match(f.name) or f.name.endswith(".tmp"):
                f.unlink()
        with contextlib.suppress(OSError):
            tiles.rmdir()
