"""Finding the motion files of a database: files and folders in, motion files out."""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

__all__ = ["MOTION_EXTENSIONS", "find_motion_files"]

#: File extensions collected from a folder (``.txt`` / ``.json`` only when they look like a
#: DeepMimic clip, i.e. start with ``{``).
MOTION_EXTENSIONS = (".bvh", ".amc", ".txt", ".json")


def _looks_like_motion(path: Path) -> bool:
    if path.suffix.lower() not in (".txt", ".json"):
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
            cands = sorted(
                c for c in p.glob(pattern) if c.is_file() and c.suffix.lower() in MOTION_EXTENSIONS
            )
        else:
            cands = [p]
        for c in cands:
            c = c.resolve()
            if c in seen:
                continue
            seen.add(c)
            if p.is_dir() and not _looks_like_motion(c):
                ignored.append(c)
            else:
                files.append(c)
    return files, ignored
