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
import errno
import os
import re
import stat
import tempfile
import time
from collections.abc import Iterable, Iterator
from pathlib import Path

from elastic_motion import limits
from elastic_motion.errors import ParseError

__all__ = [
    "atomic_path",
    "atomic_write_bytes",
    "atomic_write_text",
    "check_not_input",
    "read_bytes",
    "read_text",
    "remove_stale_temporaries",
    "same_file",
]


def _default_mode() -> int:
    """Permissions of a newly created file under the current umask (``0o666 & ~umask``)."""
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask


def read_bytes(path: str | os.PathLike[str]) -> bytes:
    """The bytes of the regular file ``path``; ``ParseError`` for anything else.

    The file is opened non-blocking and checked with ``fstat`` before a byte is read: a FIFO,
    socket or device (``mkfifo x.bvh``) is refused instead of blocking forever, a folder, a
    dangling or looping symbolic link, a missing or unreadable file is a ``ParseError`` naming
    the path, and a file larger than the ``max_file_bytes`` limit (:mod:`elastic_motion.limits`)
    is refused before it is read.
    """
    p = os.fspath(path)
    try:
        fd = os.open(p, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_BINARY", 0))
    except IsADirectoryError as exc:
        raise ParseError(p, None, "expected a file, found a directory") from exc
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            reason = "a symbolic link that points to itself (a loop)"
        elif exc.errno == errno.ENOENT and os.path.islink(p):
            reason = "a symbolic link whose target does not exist"
        else:
            reason = exc.strerror or str(exc)
        raise ParseError(p, None, f"cannot read the file ({reason})") from exc
    try:
        st = os.fstat(fd)
        if stat.S_ISDIR(st.st_mode):
            raise ParseError(p, None, "expected a file, found a directory")
        if not stat.S_ISREG(st.st_mode):
            kind = "a FIFO (named pipe)" if stat.S_ISFIFO(st.st_mode) else "a socket or device"
            raise ParseError(p, None, f"expected a regular file, found {kind}")
        lim = limits.current().max_file_bytes
        if st.st_size > lim:
            raise ParseError(
                p, None, limits.limit_message("a file size (bytes) of", st.st_size, "max_file_bytes", lim)
            )
        if hasattr(os, "set_blocking"):
            os.set_blocking(fd, True)
        with os.fdopen(fd, "rb") as fh:
            fd = -1
            # read(n) allocates n bytes up front: ask for the size fstat gave, then chunks if it grew
            chunks = [fh.read(st.st_size + 1)]
            total = len(chunks[0])
            while total > st.st_size and total <= lim:
                more = fh.read(1 << 20)
                if not more:
                    break
                chunks.append(more)
                total += len(more)
            data = b"".join(chunks)
    except OSError as exc:
        raise ParseError(p, None, f"cannot read the file ({exc.strerror or exc})") from exc
    finally:
        if fd >= 0:
            os.close(fd)
    if len(data) > lim:  # grew while being read
        raise ParseError(
            p, None, limits.limit_message("a file size (bytes) of", len(data), "max_file_bytes", lim)
        )
    return data


def read_text(path: str | os.PathLike[str]) -> str:
    """Return the text of ``path`` (UTF-8, else Latin-1); ``ParseError`` if unreadable.

    Only regular files are read (see :func:`read_bytes`).
    """
    data = read_bytes(path)
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


def _temp_prefix(dest: Path) -> str:
    """``.<stem>.em<pid>-``: the temporaries of ``dest`` name the process that writes them."""
    return f".{dest.stem}.em{os.getpid()}-"


def _pid_alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OSError):  # another user's process: alive
        return True
    return True


#: Temporaries of the earlier naming (``tempfile.mkstemp``, 8 random characters) older than this
#: many seconds are taken as left by an interrupted run.
STALE_SECONDS = 3600.0


def remove_stale_temporaries(path: str | os.PathLike[str]) -> list[Path]:
    """Remove the temporaries an interrupted write of ``path`` left beside it; return them.

    A temporary of ``path`` is ``.<stem>.em<pid>-<random><suffix>`` in its folder
    (:func:`atomic_path`); it is stale when process ``<pid>`` no longer runs (it was killed
    mid-write). Temporaries of the earlier naming (``.<stem>.<8 random><suffix>``) are stale
    after :data:`STALE_SECONDS`. Files that cannot be removed are left (never an error).
    """
    dest = Path(path)
    folder = dest.parent if str(dest.parent) else Path(".")
    suffix = dest.suffix or ".tmp"
    ours = re.compile(rf"^\.{re.escape(dest.stem)}\.em(\d+)-[A-Za-z0-9_]+{re.escape(suffix)}$")
    old = re.compile(rf"^\.{re.escape(dest.stem)}\.[A-Za-z0-9_]{{8}}{re.escape(suffix)}$")
    removed = []
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return removed
    now = time.time()
    for e in entries:
        m = ours.match(e.name)
        try:
            if m is not None:
                stale = not _pid_alive(int(m.group(1)))
            elif old.match(e.name):
                stale = now - e.stat(follow_symlinks=False).st_mtime > STALE_SECONDS
            else:
                continue
            if stale and e.is_file(follow_symlinks=False):
                os.unlink(e.path)
                removed.append(Path(e.path))
        except OSError:
            continue
    return removed


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
    remove_stale_temporaries(dest)
    fd, tmp = tempfile.mkstemp(prefix=_temp_prefix(dest), suffix=dest.suffix or ".tmp", dir=folder)
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
