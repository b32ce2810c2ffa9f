"""File helpers shared by every writer in the package (one home for atomic writes).

* :func:`read_text` decodes a file as UTF-8, falling back to Latin-1 (which never fails),
  so that a stray byte becomes a parse error about the text rather than a
  ``UnicodeDecodeError``; an unreadable path is reported as a ``ParseError`` too.
* :func:`atomic_write_text` writes through a temporary file in the destination folder
  and ``os.replace`` (atomic on POSIX and Windows), and refuses to write onto any of the
  given input paths: a writer never destroys the file it was read from.
  :func:`atomic_write_bytes` does the same for bytes, and :func:`atomic_path` yields a
  temporary path (same suffix) for writers that need a file name (``savefig``, video
  encoders), committing it by rename only when the block succeeds.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path

from elastic_motion.errors import ParseError

__all__ = [
    "atomic_path",
    "atomic_write_bytes",
    "atomic_write_text",
    "check_not_input",
    "read_text",
    "same_file",
]


def _default_mode() -> int:
    """Permissions of a newly created file under the current umask (``0o666 & ~umask``)."""
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask


def read_text(path: str | os.PathLike[str]) -> str:
    """Return the text of ``path`` (UTF-8, else Latin-1); ``ParseError`` if unreadable."""
    try:
        data = Path(path).read_bytes()
    except IsADirectoryError as exc:
        raise ParseError(path, None, "expected a file, found a directory") from exc
    except OSError as exc:
        raise ParseError(path, None, f"cannot read the file ({exc.strerror or exc})") from exc
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError:
        return data.decode("latin-1")


def same_file(a: str | os.PathLike[str], b: str | os.PathLike[str]) -> bool:
    """True if ``a`` and ``b`` name the same file (same inode, or same resolved path)."""
    try:
        if os.path.exists(a) and os.path.exists(b):
            return os.path.samefile(a, b)
    except OSError:
        pass
    return Path(a).resolve() == Path(b).resolve()


def check_not_input(path: str | os.PathLike[str], protected: Iterable[str | os.PathLike[str]] = ()) -> Path:
    """Return ``Path(path)``; ``ValueError`` if it names one of the ``protected`` input files."""
    dest = Path(path)
    for p in protected:
        if same_file(dest, p):
            raise ValueError(
                f"path: refusing to overwrite the input file {os.fspath(p)!r}; write to a different path"
            )
    return dest


@contextlib.contextmanager
def atomic_path(
    path: str | os.PathLike[str], *, protected: Iterable[str | os.PathLike[str]] = ()
) -> Iterator[Path]:
    """Yield a temporary path beside ``path`` (same suffix); rename it onto ``path`` on success.

    On an exception inside the block the temporary file is removed and ``path`` is left as
    it was. The committed file gets the permissions a plain ``open()`` would give it.

    Raises
    ------
    ValueError
        If ``path`` names one of the ``protected`` files.
    """
    dest = check_not_input(path, protected)
    folder = dest.parent if str(dest.parent) else Path(".")
    fd, tmp = tempfile.mkstemp(prefix=f".{dest.stem}.", suffix=dest.suffix or ".tmp", dir=folder)
    os.close(fd)
    tmp_path = Path(tmp)
    try:
        yield tmp_path
        # mkstemp creates the file 0600; give it the mode a plain open() would have.
        os.chmod(tmp_path, dest.stat().st_mode & 0o7777 if dest.exists() else _default_mode())
        os.replace(tmp_path, dest)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp_path.unlink()
        raise


def atomic_write_bytes(
    path: str | os.PathLike[str], data: bytes, *, protected: Iterable[str | os.PathLike[str]] = ()
) -> Path:
    """Write ``data`` to ``path`` atomically (fsync, then rename); see :func:`atomic_path`."""
    with atomic_path(path, protected=protected) as tmp, open(tmp, "wb") as fh:
        fh.write(data)
        fh.flush()
        os.fsync(fh.fileno())
    return Path(path)


def atomic_write_text(
    path: str | os.PathLike[str],
    text: str,
    *,
    protected: Iterable[str | os.PathLike[str]] = (),
) -> Path:
    """Write ``text`` (UTF-8, ``\\n`` line ends) to ``path`` atomically; refuse if ``path`` is
    one of ``protected``.

    Parameters
    ----------
    path : str or os.PathLike
        Destination. Its folder must exist.
    text : str
    protected : iterable of paths
        Input files that must never be overwritten (e.g. the file a motion was read from).

    Returns
    -------
    pathlib.Path
        The destination path.

    Raises
    ------
    ValueError
        If ``path`` names one of the ``protected`` files.
    OSError
        If the folder does not exist or is not writable (nothing is left behind).
    """
    return atomic_write_bytes(path, text.encode("utf-8"), protected=protected)
