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

A file too large to be read whole at every use (the SRV arrays of an index) is written by
:func:`write_rows`: its arrays ("rows") one after another as one flat ``.npy``, and a record
that holds, besides the file's size and SHA-256, the length and the SHA-256 of every row.
:func:`open_rows` checks the record, the file's size and ``.npy`` header (cheap, nothing of the
data read); :meth:`VerifiedRows.read` then reads one row at its offset and checks its
SHA-256: every byte used is verified, and only the rows used are read.
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import threading
import weakref
from collections.abc import Sequence
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np

from elastic_motion._io import atomic_path, atomic_write_bytes, open_regular, read_bytes
from elastic_motion.errors import ParseError

__all__ = [
    "NotVerified",
    "VerifiedRows",
    "load_array",
    "make_room",
    "open_rows",
    "open_verified",
    "record_path",
    "save_array",
    "write_rows",
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


#: The dtype of the rows of :func:`write_rows` (float64, little-endian, whatever the machine).
ROW_DTYPE = np.dtype("<f8")


def write_rows(dest: Path, rows: Sequence[np.ndarray], **fields: Any) -> dict[str, Any]:
    """Write the arrays ``rows`` one after another (C order, :data:`ROW_DTYPE`) as one flat
    ``.npy`` atomically, streamed, then its record; the record.

    The record holds, besides ``file``, ``bytes``, ``sha256`` (of the whole file, as any
    record: :func:`open_verified` checks it when the file is read whole), ``shape`` ``[total]``
    and ``dtype``: ``data_offset`` (bytes before the first row), ``row_elements`` (the length
    of each row) and ``row_sha256`` (each row's SHA-256: :func:`open_rows`), then ``fields``.
    """
    sizes = [int(np.size(r)) for r in rows]
    head = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        head, {"descr": ROW_DTYPE.str, "fortran_order": False, "shape": (sum(sizes),)}
    )
    header = head.getvalue()
    whole = hashlib.sha256(header)
    digests = []
    with atomic_path(dest) as tmp, open(tmp, "wb") as fh:
        fh.write(header)
        for r in rows:
            data = np.ascontiguousarray(r, dtype=ROW_DTYPE).tobytes()
            digests.append(hashlib.sha256(data).hexdigest())
            whole.update(data)
            fh.write(data)
        fh.flush()
        os.fsync(fh.fileno())
    record = {
        "file": dest.name,
        "bytes": len(header) + ROW_DTYPE.itemsize * sum(sizes),
        "sha256": whole.hexdigest(),
        "shape": [sum(sizes)],
        "dtype": ROW_DTYPE.str,
        "data_offset": len(header),
        "row_elements": sizes,
        "row_sha256": digests,
        **fields,
    }
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


def _open_as_recorded(path: Path, record: dict[str, Any], expected: dict[str, Any]) -> BinaryIO:
    """``path`` opened (a regular file, no link) if ``record`` holds the ``expected`` fields and
    the file has the record's size; :class:`NotVerified` (the file closed) otherwise."""
    for k, v in expected.items():
        if record.get(k) != v:
            raise NotVerified(f"{record_path(path).name}: expected {k} {v!r}; got {record.get(k)!r}")
    try:
        fh = open_regular(path, follow_symlinks=False)
    except ParseError as exc:
        raise NotVerified(f"{path.name}: {exc.message}") from None
    try:
        size = os.fstat(fh.fileno()).st_size
    except OSError as exc:
        fh.close()
        raise NotVerified(f"{path.name}: cannot read the file ({exc.strerror or exc})") from None
    if size != record["bytes"]:
        fh.close()
        raise NotVerified(f"{path.name}: {size} bytes; its record says {record['bytes']}")
    return fh


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
    fh = _open_as_recorded(path, record, {"file": path.name, **expected})
    try:
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


class VerifiedRows:
    """The rows of a file of :func:`write_rows` (:func:`open_rows`), each read only when asked
    and only if its SHA-256 is its record's.

    The file stays open (the one checked by :func:`open_rows`: replacing it on disk changes
    nothing here) until :meth:`close` or until the object is collected.
    """

    def __init__(self, path: Path, record: dict[str, Any], fh: BinaryIO) -> None:
        self.path = path
        self.row_elements: list[int] = list(record["row_elements"])
        self._sha = list(record["row_sha256"])
        self._starts = np.concatenate([[0], np.cumsum(self.row_elements, dtype=np.int64)])
        self._offset = int(record["data_offset"])
        self._fh = fh
        self._lock = threading.Lock()
        self._finalizer = weakref.finalize(self, fh.close)

    def __len__(self) -> int:
        return len(self.row_elements)

    def read(self, k: int) -> np.ndarray:
        """Row ``k`` (0 <= k < len), shape ``(row_elements[k],)``, read-only; :class:`NotVerified`
        when the file no longer holds the bytes its record describes."""
        n = self.row_elements[k] * ROW_DTYPE.itemsize
        with self._lock:
            try:
                self._fh.seek(self._offset + int(self._starts[k]) * ROW_DTYPE.itemsize)
                data = self._fh.read(n)
            except (OSError, ValueError) as exc:  # ValueError: read after close
                raise NotVerified(f"{self.path.name}: row {k}: cannot read the file ({exc})") from None
        if len(data) != n:
            raise NotVerified(
                f"{self.path.name}: row {k}: the file ends after {len(data)} of its {n} bytes (the file "
                "changed)"
            )
        if hashlib.sha256(data).hexdigest() != self._sha[k]:
            raise NotVerified(
                f"{self.path.name}: row {k}: its SHA-256 is not the one of its record (the file changed)"
            )
        return np.frombuffer(data, dtype=ROW_DTYPE)

    def close(self) -> None:
        """Close the file (rows can no longer be read)."""
        self._finalizer()

    @property
    def closed(self) -> bool:
        """Whether :meth:`close` was called."""
        return not self._finalizer.alive


def _check_rows_record(path: Path, record: dict[str, Any], row_elements: Sequence[int]) -> None:
    """:class:`NotVerified` unless the record of ``path`` describes rows of these lengths."""
    name = record_path(path).name
    total = int(sum(row_elements))
    want = {
        "file": path.name,
        "dtype": ROW_DTYPE.str,
        "shape": [total],
        "row_elements": [int(n) for n in row_elements],
    }
    for k, v in want.items():
        got = record.get(k)
        if got == v:
            continue
        if k == "row_elements":  # thousands of numbers: say how they differ
            n = len(got) if isinstance(got, list) else None
            what = f"{n} rows" + (" of other lengths" if n == len(v) else "") if n is not None else repr(got)
            raise NotVerified(
                f"{name}: expected row_elements of {len(v)} rows of the entries' lengths; got {what}"
            )
        raise NotVerified(f"{name}: expected {k} {v!r}; got {got!r}")
    sha, offset = record.get("row_sha256"), record.get("data_offset")
    if not (
        isinstance(sha, list)
        and len(sha) == len(row_elements)
        and all(isinstance(h, str) and len(h) == 64 for h in sha)
    ):
        raise NotVerified(f"{name}: expected {len(row_elements)} row SHA-256 digests; got another list")
    if not isinstance(offset, int) or record["bytes"] != offset + ROW_DTYPE.itemsize * total:
        raise NotVerified(
            f"{name}: expected bytes = data_offset + {ROW_DTYPE.itemsize} x {total}; got bytes "
            f"{record['bytes']!r}, data_offset {offset!r}"
        )


def open_rows(path: Path, row_elements: Sequence[int], **expected: Any) -> VerifiedRows:
    """The rows of ``path`` (written by :func:`write_rows`) if its record says rows of these
    lengths (and the ``expected`` fields), and the file is a regular file of the record's size
    whose ``.npy`` header is the record's; no row is read here (:meth:`VerifiedRows.read`).

    Raises
    ------
    NotVerified
        As :func:`open_verified`, but the whole file's SHA-256 is not computed (each row's is,
        when it is read).
    """
    record = _read_record(path)
    _check_rows_record(path, record, row_elements)
    fh = _open_as_recorded(path, record, expected)
    try:
        try:
            version = np.lib.format.read_magic(fh)
            read_header = {
                (1, 0): np.lib.format.read_array_header_1_0,
                (2, 0): np.lib.format.read_array_header_2_0,
            }[version]
            header = read_header(fh)
        except (ValueError, KeyError, OSError, EOFError) as exc:
            raise NotVerified(f"{path.name}: not a .npy array ({exc})") from None
        want = ((int(sum(row_elements)),), False, ROW_DTYPE)
        if header != want or fh.tell() != record["data_offset"]:
            raise NotVerified(
                f"{path.name}: expected a .npy header of a flat C-order {ROW_DTYPE.str} array of "
                f"{want[0][0]} values ending at byte {record['data_offset']}; got {header} ending at "
                f"{fh.tell()}"
            )
    except BaseException:
        fh.close()
        raise
    return VerifiedRows(path, record, fh)


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
