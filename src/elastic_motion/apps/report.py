"""JSON reports of what a command did, written atomically.

Every command that changes a motion can write a report (``--json PATH``). A report is a
plain JSON object; the fields every report shares come from :func:`report_header`::

    {
      "command": "blend",                 # the sub-command
      "version": "0.1.0",                 # elastic-motion's version
      "created": "2025-01-01T12:00:00Z",  # UTC, seconds
      "inputs": ["a.bvh", "b.bvh"],       # as given on the command line
      "outputs": ["out.bvh"],             # files written (besides the report)
      "notes": ["resampled b.bvh from 120 to 30 fps", ...],
      ...                                 # the command's own fields (docs/cli.md)
    }

Numbers are JSON numbers (numpy scalars and arrays become numbers and lists); ``NaN`` and
infinities, which JSON lacks, become ``null``. The file is written through a temporary file
and ``os.replace`` and never onto one of the inputs.
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import json
import math
import os
import re
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from elastic_motion import __version__
from elastic_motion._io import atomic_write_text
from elastic_motion.notes import Note

__all__ = ["is_report", "jsonable", "report_header", "report_json", "write_report"]


def jsonable(obj: Any) -> Any:
    """A copy of ``obj`` made of JSON types only.

    numpy scalars and arrays become Python numbers and (nested) lists, tuples become lists,
    paths strings, notes their texts, dataclasses dicts; non-finite floats become ``None``.
    """
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, (np.bool_, bool)):
        return bool(obj)
    if isinstance(obj, (np.integer, int)):
        return int(obj)
    if isinstance(obj, (np.floating, float)):
        x = float(obj)
        return x if math.isfinite(x) else None
    if isinstance(obj, os.PathLike):
        return os.fspath(obj)
    if isinstance(obj, Note):  # a report lists what people read
        return str(obj)
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return jsonable(dataclasses.asdict(obj))
    if obj is None or isinstance(obj, str):
        return obj
    return str(obj)


def report_header(
    command: str,
    inputs: Sequence[str | os.PathLike[str]] = (),
    outputs: Sequence[str | os.PathLike[str]] = (),
    notes: Iterable[str] = (),
) -> dict[str, Any]:
    """The fields every report starts with (see the module docstring)."""
    now = _dt.datetime.now(_dt.UTC).replace(microsecond=0)
    return {
        "command": command,
        "version": __version__,
        "created": now.isoformat().replace("+00:00", "Z"),
        "inputs": [os.fspath(p) for p in inputs],
        "outputs": [os.fspath(p) for p in outputs],
        "notes": [str(n) for n in notes],
    }


def report_json(report: dict[str, Any]) -> str:
    """The report as indented JSON text (strict: no NaN)."""
    return json.dumps(jsonable(report), indent=2, allow_nan=False) + "\n"


def write_report(
    path: str | os.PathLike[str],
    report: dict[str, Any],
    *,
    protected: Iterable[str | os.PathLike[str]] = (),
) -> Path:
    """Write ``report`` as JSON to ``path`` atomically.

    Parameters
    ----------
    path : str or os.PathLike
        Destination; its folder must exist.
    report : dict
        Converted with :func:`jsonable`.
    protected : iterable of paths
        Input files: writing onto one of them raises ``ValueError``.

    Returns
    -------
    pathlib.Path

    Raises
    ------
    ValueError
        ``path`` is a protected input, or an existing file that is not a report of this
        package (a JSON object with ``"command"`` and ``"version"``): a motion file named by
        mistake is never replaced.
    """
    target = Path(path)
    if target.is_file() and not is_report(target):
        raise ValueError(
            f"{os.fspath(target)}: expected a new file or an earlier elastic-motion report to replace; got "
            "another file (refusing to overwrite it)"
        )
    return atomic_write_text(path, report_json(report), protected=protected)


#: Bytes read from the start of an existing file to see whether it is a report.
_REPORT_HEAD_BYTES = 4096


def is_report(path: Path) -> bool:
    """Whether ``path`` holds a report of this package: it starts as :func:`report_json` writes
    one, a JSON object whose first two fields are ``"command"`` and ``"version"`` (read from
    its first bytes only, whatever its size)."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(_REPORT_HEAD_BYTES).decode("utf-8", errors="replace")
    except OSError:
        return False
    return re.match(r'\s*\{\s*"command":\s*"[^"]*",\s*"version":', head) is not None
