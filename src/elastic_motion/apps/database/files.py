"""Finding the motion files of a database: files and folders in, motion files out; and the
check that an output folder (a matrix run's, an index's) stays clear of them."""

from __future__ import annotations

import os
import stat
from collections.abc import Collection, Sequence
from pathlib import Path

from elastic_motion.errors import OptionError
from elastic_motion.vocabulary import MOTION_EXTENSIONS

__all__ = ["MOTION_EXTENSIONS", "check_output_folder", "find_motion_files"]

# MOTION_EXTENSIONS (elastic_motion.vocabulary): the file extensions collected from a folder
# (``.txt`` / ``.json`` only when they look like a DeepMimic clip, i.e. start with ``{``).


def _is_regular(path: Path) -> bool:
    """A regular file (symbolic links followed); False for FIFOs, folders, dangling links, loops."""
    try:
        return stat.S_ISREG(os.stat(path).st_mode)
    except (OSError, ValueError):
        return False


def _absolute(path: Path) -> Path:
    """``path`` resolved; a dangling link or a link loop made absolute only (named as given)."""
    if os.path.islink(path) and not os.path.exists(path):  # dangling or a loop: name the link itself
        return Path(os.path.abspath(path))
    try:
        return path.resolve()
    except (OSError, RuntimeError):
        return Path(os.path.abspath(path))


def _looks_like_motion(path: Path) -> bool:
    if path.suffix.lower() not in (".txt", ".json"):
        return True
    if not _is_regular(path):  # never open a FIFO (it would block): the reader refuses it, listed
        return True
    try:
        with open(path, "rb") as fh:
            head = fh.read(256).lstrip()
    except OSError:
        return True  # let the reader report it
    return head.startswith(b"{")


def find_motion_files(
    inputs: Sequence[str | os.PathLike[str]], *, recursive: bool = False
) -> tuple[list[Path], list[Path]]:
    """Expand files and folders into motion files.

    Parameters
    ----------
    inputs : sequence of paths
        Files are taken as given (whatever their extension; an unreadable one is reported
        later); folders contribute their ``.bvh``, ``.amc``, and DeepMimic ``.txt`` /
        ``.json`` files (text files not starting with ``{`` are ignored), sorted by name.
        Entries with those extensions that are not regular files (FIFOs, folders named
        ``*.bvh``, dangling symbolic links, link loops) are returned too, never opened here:
        reading refuses them and the run lists them as skipped.
    recursive : bool, default False
        Descend into sub-folders.

    Returns
    -------
    files : list of Path
        Absolute paths, duplicates removed, in input order.
    ignored : list of Path
        Files of a folder that are not motions (e.g. ``content_label.txt``).

    Notes
    -----
    A given file that does not exist is kept: reading it fails later and it is listed as
    skipped, like any unreadable file (one bad path never aborts a run).
    """
    files: list[Path] = []
    ignored: list[Path] = []
    seen: set[Path] = set()
    for item in inputs:
        p = Path(item)
        if p.is_dir():
            pattern = "**/*" if recursive else "*"
            # every entry with a motion extension: regular files, and also FIFOs, folders named
            # *.bvh, dangling links and link loops, which reading refuses and the run lists as skipped
            cands = sorted(c for c in p.glob(pattern) if c.suffix.lower() in MOTION_EXTENSIONS)
        else:
            cands = [p]
        for c in cands:
            c = _absolute(c)
            if c in seen:
                continue
            seen.add(c)
            if p.is_dir() and not _looks_like_motion(c):
                ignored.append(c)
            else:
                files.append(c)
    return files, ignored


def check_output_folder(
    out: Path,
    inputs: Sequence[str | os.PathLike[str]],
    files: Sequence[Path],
    own_names: Collection[str],
    argument: str,
) -> None:
    """Refuse an output folder that would overwrite an input, that holds or lies inside an input
    folder (a rerun, or a recursive search, would read its own files), or that is a file.

    Parameters
    ----------
    out : Path
        The output folder (need not exist).
    inputs : sequence of paths
        Files and folders as given.
    files : sequence of Path
        The motion files found in them (:func:`find_motion_files`, absolute).
    own_names : collection of str
        Names of the files the command writes at the top of ``out``.
    argument : str
        The argument named in the error (``"out_dir"``, ``"out"``).

    Raises
    ------
    OptionError
    """
    o = out.resolve()
    if any(o == f or (o in f.parents and f.name in own_names) for f in files):
        raise OptionError(
            argument,
            f"expected a folder that holds no input; got {os.fspath(out)!r}, which would overwrite one",
        )
    for item in inputs:
        if Path(item).is_dir():
            folder = Path(item).resolve()
            if o == folder or folder in o.parents or o in folder.parents:
                raise OptionError(
                    argument,
                    f"expected a folder that neither holds nor lies inside an input folder; got "
                    f"{os.fspath(out)!r} and the input folder {os.fspath(item)!r}",
                )
    if out.exists() and not out.is_dir():
        raise OptionError(argument, f"expected a folder; got the file {os.fspath(out)!r}")
