"""Files of a run that are read back only when they prove to be what the run wrote.

A matrix run resumes from the files it left (tiles, the SRV cache); nothing on disk is
trusted. :func:`write_verified` writes a file atomically and then, atomically too, its
*record* beside it (``lie_0_1.npy`` -> ``lie_0_1.json``)::

    {"file": "lie_0_1.npy", "bytes": 1152, "sha256": "...", "shape": [32, 32], "dtype": "<f8",
     "tile": "lie_0_1"}

:func:`open_verified` opens the file again only if its record is there and says what the
caller expects (name, shape, dtype, tile, ...), the file is a regular file (never a symbolic
link, FIFO, socket, device or folder: :func:`elastic_motion._io.open_regular`, opened
``O_NOFOLLOW | O_NONBLOCK`` and checked with ``fstat`` before a byte is read), and its size and
SHA-256 are the record's; :func:`load_array` also checks the ``.npy`` it holds (no pickles,
the record's shape and dtype). Anything else is :class:`NotVerified`, with the reason: the
caller computes the file again and says why. A file whose record is missing (a run stopped
between the two writes) is not verified either: at most the file in flight is lost.
"""

from __future__ import annotations

import hashlib
import io
import json
import os
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np

from elastic_motion._io import atomic_write_bytes, open_regular, read_bytes
from elastic_motion.errors import ParseError

__all__ = [
    "NotVerified",
    "load_array",
    "make_room",
    "open_verified",
    "record_path",
    "save_array",
    "write_verified",
]

_CHUNK = 1 << 20


class NotVerified(Exception):
    """A file of a run that is not (provably) what the run wrote; ``str()`` says why
    (``<file name>: <reason>``).

    ``missing`` is True when neither the file nor its record exists (nothing was written:
    not worth a note).
    """

    def __init__(self, reason: str, *, missing: bool = False) -> None:
        super().__init__(reason)
        self.missing = missing


def record_path(path: Path) -> Path:
    """The record of ``path``: the same name with ``.json`` (``lie_0_1.npy`` -> ``lie_0_1.json``)."""
    return path.with_suffix(".json")


def write_verified(dest: Path, data: bytes, **fields: Any) -> dict[str, Any]:
    """Write ``data`` to ``dest`` atomically, then its record (``fields`` added); the record."""
    atomic_write_bytes(dest, data)
    record = {"file": dest.name, "bytes": len(data), "sha256": hashlib.sha256(data).hexdigest(), **fields}
    atomic_write_bytes(record_path(dest), (json.dumps(record) + "\n").encode())
    return record


def save_array(dest: Path, arr: np.ndarray, **fields: Any) -> dict[str, Any]:
    """Write ``arr`` as ``.npy`` with its record (shape, dtype, ``fields``); the record."""
    buf = io.BytesIO()
    np.save(buf, arr, allow_pickle=False)
    return write_verified(dest, buf.getvalue(), shape=list(arr.shape), dtype=arr.dtype.str, **fields)


def _read_record(path: Path) -> dict[str, Any]:
    rec = record_path(path)
    try:
        raw = read_bytes(rec, follow_symlinks=False)
    except ParseError as exc:
        if not os.path.lexists(rec):
            if not os.path.lexists(path):
                raise NotVerified(f"{path.name}: not written", missing=True) from None
            raise NotVerified(
                f"{path.name}: no record {rec.name} of its size and checksum (written after the file: "
                "the run stopped between the two)"
            ) from None
        raise NotVerified(f"{rec.name}: {exc.message}") from None
    try:
        record = json.loads(raw)
    except ValueError:
        record = None
    if not isinstance(record, dict) or not isinstance(record.get("bytes"), int):
        raise NotVerified(f"{rec.name}: expected a record (JSON with file, bytes, sha256); got {raw[:60]!r}")
    return record


def open_verified(path: Path, **expected: Any) -> BinaryIO:
    """``path`` opened for reading, positioned at 0, if it and its record are what was written.

    Parameters
    ----------
    path : Path
    **expected
        Fields the record must hold with these values (``shape=[32, 32]``, ``tile="lie_0_1"``).

    Raises
    ------
    NotVerified
        Record missing, unreadable or saying something else; the file missing, not a regular
        file (link, FIFO, folder, ...), or of another size or SHA-256 than its record's.
    """
    record = _read_record(path)
    for k, v in {"file": path.name, **expected}.items():
        if record.get(k) != v:
            raise NotVerified(f"{record_path(path).name}: expected {k} {v!r}; got {record.get(k)!r}")
    try:
        fh = open_regular(path, follow_symlinks=False)
    except ParseError as exc:
        raise NotVerified(f"{path.name}: {exc.message}") from None
    try:
        size = os.fstat(fh.fileno()).st_size
        if size != record["bytes"]:
            raise NotVerified(f"{path.name}: {size} bytes; its record says {record['bytes']}")
        h = hashlib.sha256()
        while chunk := fh.read(_CHUNK):
            h.update(chunk)
        if h.hexdigest() != record.get("sha256"):
            raise NotVerified(f"{path.name}: its SHA-256 is not the one of its record (the file changed)")
        fh.seek(0)
    except OSError as exc:
        fh.close()
        raise NotVerified(f"{path.name}: cannot read the file ({exc.strerror or exc})") from None
    except BaseException:
        fh.close()
        raise
    return fh


def load_array(path: Path, shape: tuple[int, ...], dtype: Any = np.float64, **expected: Any) -> np.ndarray:
    """The ``.npy`` array of ``path`` if it and its record (:func:`open_verified`) hold an array
    of this ``shape`` and ``dtype`` (and ``expected`` fields); :class:`NotVerified` otherwise."""
    dt = np.dtype(dtype)
    with open_verified(path, shape=list(shape), dtype=dt.str, **expected) as fh:
        try:
            arr = np.load(fh, allow_pickle=False)
        except (ValueError, OSError, EOFError) as exc:
            raise NotVerified(f"{path.name}: not a .npy array ({exc})") from None
    if not isinstance(arr, np.ndarray) or arr.shape != tuple(shape) or arr.dtype != dt:
        got = f"{getattr(arr, 'shape', None)} {getattr(arr, 'dtype', type(arr).__name__)}"
        raise NotVerified(f"{path.name}: expected an array {tuple(shape)} {dt}; got {got}")
    return arr


def make_room(path: Path) -> list[str]:
    """Move a folder found where ``path`` or its record is to be written aside (renamed, never
    removed: it is not the run's), so the write can replace the entry; notes saying where.

    Links, FIFOs and files there are simply replaced by the atomic write (the entry, never
    what a link points to).
    """
    notes = []
    for p in (path, record_path(path)):
        if not os.path.isdir(p) or os.path.islink(p):
            continue
        for n in range(1, 1000):
            aside = p.with_name(f"{p.name}.moved-aside" + (f"-{n}" if n > 1 else ""))
            if not os.path.lexists(aside):
                os.rename(p, aside)
                notes.append(f"{p.name}: a folder, moved aside to {aside.name}")
                break
    return notes
