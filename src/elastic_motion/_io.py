"""File helpers shared by every writer in the package (one home for atomic writes).

* :func:`read_text` decodes a file as UTF-8, falling back to Latin-1 (which never fails),
  so that a stray byte becomes a parse error about the text rather than a
  ``UnicodeDecodeError``; an unreadable path is reported as a ``ParseError`` too. Only
  regular files are opened (:func:`open_regular`: never a FIFO, which would block; with
  ``follow_symlinks=False`` never a symbolic link).
* :func:`atomic_write_text` writes through a temporary file in the destination folder
  and ``os.replace`` (atomic on POSIX and Windows), and refuses to write onto any of the
  given input paths: a writer never destroys the file it was read from.
  :func:`atomic_write_bytes` does the same for bytes, and :func:`atomic_path` yields a
  temporary path (same suffix) for writers that need a file name (``savefig``, video
  encoders), committing it by rename only when the block succeeds.

Temporaries, and which files may ever be removed
------------------------------------------------
A temporary of ``walk.bvh`` is created exclusively (``O_EXCL``, mode 0600) beside it as
``.walk.em<pid>-<token>-<tag>.bvh``: ``pid`` is the writing process, ``token`` 16 random hex
digits and ``tag`` the first 32 hex digits of HMAC-SHA256, keyed with a per-user secret, of the
host name and the rest of the name. The secret is 32 random bytes in
``$XDG_CACHE_HOME/elastic_motion/temporaries.key`` (``~/.cache/...``; ``%LOCALAPPDATA%`` on
Windows), made on first use (file 0600 in a folder 0700) and used only if it is a regular
file of this user, not a link, not writable by others. A write that fails or is interrupted
removes its own temporary; only a killed process (SIGKILL, power loss) leaves one behind.

The only files this package ever removes outside its own run folders are such leftovers
(:func:`remove_stale_temporaries`, run by :func:`atomic_path` once per folder and process): a
file is removed only if its tag checks with this user's key on this host (which no name made
by hand, by another program, user or machine, or by an earlier release of this package can
pass), it is a regular file owned by this user, and the process named in it no longer runs.
Whatever fails a check is left, whatever its name or age: a proof, not a look-alike pattern.
Without a usable key (no home folder, read-only cache) temporaries get a key of the process
only and nothing is ever removed. The key is not a secret against this user (who may delete
their files anyway); it makes a match by chance or by another party impossible.
"""

from __future__ import annotations

import contextlib
import errno
import hashlib
import hmac
import os
import platform
import re
import secrets
import stat
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import BinaryIO

from elastic_motion import limits
from elastic_motion.errors import ParseError

__all__ = [
    "atomic_path",
    "atomic_write_bytes",
    "atomic_write_text",
    "check_not_input",
    "is_our_temporary",
    "open_regular",
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


def open_regular(path: str | os.PathLike[str], *, follow_symlinks: bool = True) -> BinaryIO:
    """``path`` opened for reading (binary, blocking) if it is a regular file; ``ParseError`` else.

    The file is opened non-blocking and checked with ``fstat`` before a byte is read: a FIFO,
    socket or device (``mkfifo x.bvh``) is refused instead of blocking forever; a folder, a
    dangling or looping symbolic link, a missing or unreadable file is a ``ParseError`` naming
    the path. With ``follow_symlinks=False`` (``O_NOFOLLOW``) a symbolic link is refused too
    (files a program wrote itself and reads back: a link there was put by someone else).
    """
    p = os.fspath(path)
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_BINARY", 0)
    if not follow_symlinks:
        flags |= getattr(os, "O_NOFOLLOW", 0)
    try:
        if not follow_symlinks and not hasattr(os, "O_NOFOLLOW") and os.path.islink(p):
            raise OSError(errno.ELOOP, "a symbolic link", p)
        fd = os.open(p, flags)
    except IsADirectoryError as exc:
        raise ParseError(p, None, "expected a file, found a directory") from exc
    except OSError as exc:
        if not follow_symlinks and os.path.islink(p):
            reason = "a symbolic link, not followed here"
        elif exc.errno == errno.ELOOP:
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
        if hasattr(os, "set_blocking"):
            os.set_blocking(fd, True)
        fh = os.fdopen(fd, "rb")
        fh.raw.name = p  # type: ignore[attr-defined]  # the path in messages, not the descriptor
        return fh
    except BaseException:
        os.close(fd)
        raise


def read_bytes(path: str | os.PathLike[str], *, follow_symlinks: bool = True) -> bytes:
    """The bytes of the regular file ``path``; ``ParseError`` for anything else.

    Opened by :func:`open_regular` (a FIFO, socket, device, folder, broken link or missing
    file is a ``ParseError`` naming the path, never a wait; a symbolic link too with
    ``follow_symlinks=False``); a file larger than the ``max_file_bytes`` limit
    (:mod:`elastic_motion.limits`) is refused before it is read.
    """
    p = os.fspath(path)
    fh = open_regular(p, follow_symlinks=follow_symlinks)
    lim = limits.current().max_file_bytes
    try:
        with fh:
            size = os.fstat(fh.fileno()).st_size
            if size > lim:
                raise ParseError(
                    p, None, limits.limit_message("a file size (bytes) of", size, "max_file_bytes", lim)
                )
            # read(n) allocates n bytes up front: ask for the size fstat gave, then chunks if it grew
            chunks = [fh.read(size + 1)]
            total = len(chunks[0])
            while total > size and total <= lim:
                more = fh.read(1 << 20)
                if not more:
                    break
                chunks.append(more)
                total += len(more)
            data = b"".join(chunks)
    except OSError as exc:
        raise ParseError(p, None, f"cannot read the file ({exc.strerror or exc})") from exc
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


def _pid_alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (OSError, OverflowError, ValueError):  # another user's process, or no pid: taken as alive
        return True
    return True


#: Name of a temporary: ``.<stem>.em<pid>-<token>-<tag><suffix>`` (``tag``: see the module docstring).
_TEMP_RE = re.compile(
    r"\.(?P<stem>.*)\.em(?P<pid>\d+)-(?P<token>[0-9a-f]{16})-(?P<tag>[0-9a-f]{32})(?P<suffix>\.[^.]*)",
    re.DOTALL,
)
#: File of the per-user key, under the user's cache folder.
KEY_FOLDER = "elastic_motion"
KEY_FILE = "temporaries.key"
_KEY_BYTES = 32
#: The key of this process: ``(key, persistent)``; None until first needed.
_key_state: tuple[bytes, bool] | None = None
#: Folders (device, inode) whose stale temporaries this process already removed.
_cleaned_folders: set[tuple[int, int]] = set()


def _user_cache_folder() -> Path | None:
    """``$XDG_CACHE_HOME`` (else ``~/.cache``; ``%LOCALAPPDATA%`` on Windows); None if unknown."""
    if os.name == "nt":
        base = os.environ.get("LOCALAPPDATA", "")
    else:
        base = os.environ.get("XDG_CACHE_HOME", "")
        if not os.path.isabs(base):
            home = os.path.expanduser("~")
            base = os.path.join(home, ".cache") if os.path.isabs(home) else ""
    return Path(base) if base else None


def _owned(st: os.stat_result) -> bool:
    """Owned by this user (always True where there are no uids)."""
    return not hasattr(os, "getuid") or st.st_uid == os.getuid()


def _private(st: os.stat_result) -> bool:
    """Owned by this user and neither group- nor world-writable."""
    return _owned(st) and not (hasattr(os, "getuid") and st.st_mode & 0o022)


def _read_key(path: Path) -> bytes | None:
    """The key in ``path``: a regular file of this user, not a link, 32 bytes; None otherwise."""
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0))
    except OSError:
        return None
    try:
        st = os.fstat(fd)
        if not (stat.S_ISREG(st.st_mode) and _private(st) and st.st_size == _KEY_BYTES):
            return None
        data = os.read(fd, _KEY_BYTES + 1)
    except OSError:
        return None
    finally:
        os.close(fd)
    return data if len(data) == _KEY_BYTES else None


def _load_or_create_key() -> bytes | None:
    """The per-user key (created on first use, mode 0600 in a 0700 folder); None if unusable."""
    base = _user_cache_folder()
    if base is None:
        return None
    folder = base / KEY_FOLDER
    path = folder / KEY_FILE
    key = _read_key(path)
    if key is not None or os.path.lexists(path):
        return key
    try:
        folder.mkdir(mode=0o700, parents=True, exist_ok=True)
        st = os.lstat(folder)
        if not (stat.S_ISDIR(st.st_mode) and _private(st)):
            return None
        tmp = folder / f".{KEY_FILE}.{os.getpid()}.{secrets.token_hex(8)}"
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0), 0o600)
        try:
            os.write(fd, secrets.token_bytes(_KEY_BYTES))
            os.fsync(fd)
        finally:
            os.close(fd)
        try:
            os.link(tmp, path)  # never replaces the key another process made meanwhile
        except FileExistsError:
            pass
        finally:
            os.unlink(tmp)
    except OSError:
        return None
    return _read_key(path)


def _temporary_key() -> tuple[bytes, bool]:
    """``(key, persistent)``: the per-user key, else a key of this process only (its temporaries
    can then never be proven ours by a later process, so they are never removed)."""
    global _key_state
    if _key_state is None:
        key = _load_or_create_key()
        _key_state = (key, True) if key is not None else (secrets.token_bytes(_KEY_BYTES), False)
    return _key_state


def _tag(key: bytes, head: str, suffix: str) -> str:
    """The proof of a temporary's name: HMAC-SHA256 of host, name before the tag and suffix."""
    msg = "\0".join((platform.node(), head, suffix)).encode("utf-8", "surrogateescape")
    return hmac.new(key, msg, hashlib.sha256).hexdigest()[:32]


def _new_temporary(dest: Path) -> Path:
    """Create (exclusively, mode 0600) an empty temporary of ``dest`` beside it; return its path."""
    folder = dest.parent if str(dest.parent) else Path(".")
    suffix = dest.suffix if 0 < len(os.fsencode(dest.suffix)) <= 100 else ".tmp"
    # the name stays within 255 bytes whatever the length of dest's (the tag proves the name as written)
    stem = os.fsdecode(os.fsencode(dest.stem)[: 190 - len(os.fsencode(suffix))])
    key, _ = _temporary_key()
    for _attempt in range(100):
        head = f".{stem}.em{os.getpid()}-{secrets.token_hex(8)}-"
        tmp = folder / f"{head}{_tag(key, head, suffix)}{suffix}"
        try:
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0), 0o600)
        except FileExistsError:
            continue
        os.close(fd)
        return tmp
    raise FileExistsError(errno.EEXIST, "no free temporary name", os.fspath(folder))


def is_our_temporary(name: str) -> bool:
    """Whether the file name ``name`` is one this program gave a temporary (its tag proves it
    with this user's key on this host; see the module docstring)."""
    m = _TEMP_RE.fullmatch(name)
    if m is None:
        return False
    key, persistent = _temporary_key()
    if not persistent and int(m.group("pid")) != os.getpid():
        return False
    return hmac.compare_digest(m.group("tag"), _tag(key, name[: m.start("tag")], m.group("suffix")))


def remove_stale_temporaries(path: str | os.PathLike[str]) -> list[Path]:
    """Remove the temporaries interrupted writes left in the folder of ``path``; return them.

    A file is removed only when it is provably a temporary this program made
    (:func:`is_our_temporary`: the name's tag checks with this user's key on this host), it is
    a regular file owned by this user (not a link, not a folder), and the process named in it
    no longer runs (it was killed mid-write). Everything else is left, whatever its name or
    age. Files that cannot be removed are left (never an error).
    """
    dest = Path(path)
    folder = dest.parent if str(dest.parent) else Path(".")
    removed: list[Path] = []
    try:
        entries = [e for e in os.scandir(folder) if e.name.startswith(".") and ".em" in e.name]
    except OSError:
        return removed
    for e in entries:
        m = _TEMP_RE.fullmatch(e.name)
        if m is None or not is_our_temporary(e.name) or _pid_alive(int(m.group("pid"))):
            continue
        try:
            st = e.stat(follow_symlinks=False)
            if stat.S_ISREG(st.st_mode) and _owned(st):
                os.unlink(e.path)
                removed.append(Path(e.path))
        except OSError:
            continue
    return removed


def _remove_stale_once(folder: Path) -> None:
    """:func:`remove_stale_temporaries` for ``folder``, once per process (a folder of many
    files, ``tiles/``, is not listed again at every write)."""
    try:
        st = os.stat(folder)
    except OSError:
        return
    ident = (st.st_dev, st.st_ino)
    if ident not in _cleaned_folders:
        _cleaned_folders.add(ident)
        remove_stale_temporaries(folder / "x")


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
    _remove_stale_once(dest.parent if str(dest.parent) else Path("."))
    tmp_path = _new_temporary(dest)
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
