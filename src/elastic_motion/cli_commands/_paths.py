"""The safety net of every command line: nothing a command writes may overwrite what it reads.

:func:`check_paths` runs on every parsed command line before the command starts (the parser
of :mod:`._argparse` puts it in front of each command): every path the command writes is
checked against every path it reads and against its other outputs (:func:`check_output`).
:func:`check_option_limits` checks the options bounded by :mod:`elastic_motion.limits` at the
same moment, and :func:`check_report_target` (called by :func:`elastic_motion.cli.main`) that
a ``--json`` path is no motion file. Refusals are :class:`~._errors.CommandError` (exit code 2).

This module is imported when the command line is read, before
:func:`elastic_motion.cli.main` reports errors: the package's numerical modules (numpy,
numba) are imported inside the few functions that need them.
"""

from __future__ import annotations

import argparse
import os
from collections.abc import Sequence
from pathlib import Path

from elastic_motion import limits
from elastic_motion._io import same_file
from elastic_motion.cli_commands._errors import CommandError, option_message
from elastic_motion.errors import OptionError
from elastic_motion.vocabulary import MOTION_EXTENSIONS

__all__ = [
    "check_option_limits",
    "check_output",
    "check_paths",
    "check_report_target",
    "protected_inputs",
    "same_path",
]


def protected_inputs(inputs: Sequence[str | os.PathLike[str]]) -> list[str]:
    """Every file a command reads for ``inputs``: the inputs and the ``.asf`` found beside an ``.amc``."""
    out: list[str] = []
    for p in inputs:
        out.append(os.fspath(p))
        if Path(p).suffix.lower() == ".amc":
            try:
                from elastic_motion.motion import find_asf  # local: numba (module docstring)

                out.append(os.fspath(find_asf(p)))
            except (ValueError, OSError):  # no skeleton found: reading the AMC will say so
                pass
    return out


def _inside(path: Path, folder: str | os.PathLike[str]) -> bool:
    """Whether ``path`` is ``folder`` or lies below it (symbolic links resolved)."""
    try:
        f = Path(folder).resolve()
        p = path.resolve()
    except (OSError, RuntimeError):
        return False
    return p == f or f in p.parents


def check_output(
    path: str,
    inputs: Sequence[str],
    *,
    suffixes: Sequence[str] | None = None,
    what: str = "-o",
    outputs: Sequence[str] = (),
) -> Path:
    """The safety net for one output path: refuse anything that would overwrite what is read.

    Refused: an output that is one of the ``inputs`` or a file read for them (the ``.asf``
    beside an ``.amc``) -- by name, through ``../``, a symbolic or a hard link --, an output
    inside an input folder (a ``matrix`` folder's own files), one of the other ``outputs``
    of the command, an existing folder, a missing parent folder, a wrong extension.

    Parameters
    ----------
    path : str
        The output path.
    inputs : sequence of str
        Files and folders the command reads (``.amc`` files are expanded with their ``.asf``).
    suffixes : sequence of str, optional
        Accepted extensions (lower case, with the dot).
    what : str, default "-o"
        The option named in the error.
    outputs : sequence of str, optional
        The command's other outputs.

    Returns
    -------
    pathlib.Path

    Raises
    ------
    CommandError
    """
    out = Path(path)
    for p in protected_inputs(inputs):
        if same_file(out, p):
            raise CommandError(f"{what}: {path!r} is the input file {p!r}; refusing to overwrite an input")
        if os.path.isdir(p) and _inside(out, p):
            raise CommandError(
                f"{what}: expected a path outside the input folder {p!r}; got {path!r}, which would "
                "write into it"
            )
    for o in outputs:
        if same_file(out, o):
            raise CommandError(f"{what}: {path!r} is also another output of this command ({o!r})")
    if out.is_dir():
        raise CommandError(f"{what}: expected a file path; got the folder {path!r}")
    if suffixes is not None and out.suffix.lower() not in suffixes:
        raise CommandError(f"{what}: expected a {' or '.join(suffixes)} file; got {path!r}")
    if out.parent and not out.parent.exists():
        raise CommandError(f"{what}: the folder {str(out.parent)!r} does not exist")
    return out


#: Namespace attributes that are files or folders a command reads, and those it writes.
_INPUT_ATTRS = (
    "inputs",
    "input",
    "file",
    "files",
    "a",
    "b",
    "query",
    "database",
    "matrix_dir",
    "asf",
    "labels",
    "landmarks",
)
_OUTPUT_ATTRS = {"output": "-o", "json": "--json", "preview": "--preview", "plot": "--plot"}
#: Commands whose ``-o`` is a folder that must neither hold nor lie inside an input (a rerun
#: reads the folder again), and other commands whose ``-o`` is a folder they manage themselves.
_FOLDER_OUTPUTS = {"matrix", "index"}
_OWN_FOLDER_OUTPUTS = {"demo", "pca"}


def check_paths(args: argparse.Namespace) -> None:
    """The shared safety net, run on every parsed command line before the command starts.

    Every path the command writes (``-o``, ``--json PATH``, ``--preview``, ``--plot``) is
    checked against every path it reads (with the ``.asf`` beside an ``.amc``) and against
    the other outputs (:func:`check_output`); a folder output (``matrix -o``, ``index -o``)
    must neither hold nor lie inside an input. Refusals are :class:`CommandError` (exit code 2).
    """
    command = getattr(args, "command", None)
    inputs: list[str] = []
    for attr in _INPUT_ATTRS:
        v = getattr(args, attr, None)
        for item in v if isinstance(v, list | tuple) else [v]:
            if isinstance(item, str) and item not in ("", "-") and os.path.lexists(item):
                inputs.append(item)
    outputs: list[tuple[str, str]] = []
    for attr, flag in _OUTPUT_ATTRS.items():
        v = getattr(args, attr, None)
        if isinstance(v, str) and v not in ("", "-"):
            outputs.append((flag, v))
    if command in _OWN_FOLDER_OUTPUTS:  # the command checks its folder; its files are checked here
        outputs = [(f, o) for f, o in outputs if f != "-o"]
    for k, (flag, path) in enumerate(outputs):
        others = [o for i, (_, o) in enumerate(outputs) if i != k]
        if command in _FOLDER_OUTPUTS and flag == "-o":
            folder = Path(path)
            for p in protected_inputs(inputs):
                if same_path(folder, p) or _inside(folder, p) or _inside(Path(p), folder):
                    raise CommandError(
                        f"{flag}: expected an output folder that neither holds nor lies inside an input; "
                        f"got {path!r} and the input {p!r}"
                    )
            if folder.exists() and not folder.is_dir():
                raise CommandError(f"{flag}: expected a folder; got the file {path!r}")
            continue
        folder_outputs = [o for f, o in outputs if f == "-o" and command in _FOLDER_OUTPUTS]
        for fo in folder_outputs:
            if _inside(Path(path), fo):
                raise CommandError(
                    f"{flag}: expected a path outside the output folder {fo!r} (it holds the run's own "
                    f"files); got {path!r}"
                )
        check_output(path, inputs, what=flag, outputs=[o for o in others if o not in folder_outputs])


def check_option_limits(args: argparse.Namespace) -> None:
    """Options bounded by :mod:`elastic_motion.limits`, checked before a command reads anything.

    ``--repeat`` (loop previews, seam renders) against ``max_repeat``; other commands check
    their own sizes where they know them (render sizes, frame counts in the readers).
    """
    repeat = getattr(args, "repeat", None)
    if isinstance(repeat, int) and not isinstance(repeat, bool):
        try:
            limits.check_option("repeat", "a repeat count of", repeat, "max_repeat")
        except OptionError as exc:
            raise CommandError(option_message(exc)) from None


def same_path(a: str | os.PathLike[str], b: str | os.PathLike[str]) -> bool:
    """Whether ``a`` and ``b`` name the same file or folder."""
    return same_file(a, b)


def check_report_target(args: argparse.Namespace) -> None:
    """Refuse a ``--json PATH`` that names a motion file or an existing file that is not an
    earlier report, before any work (``--json`` before the inputs takes the first of them as
    its PATH; the report written at the end replaced that motion). Raises :class:`CommandError`."""
    value = getattr(args, "json", None)
    if not isinstance(value, str) or value == "-":
        return
    from elastic_motion.apps.report import is_report  # local: it loads numpy (module docstring)

    hint = "(--json takes the next word as its PATH: put it after the inputs)"
    suffix = Path(value).suffix.lower()
    # a motion file's name is never a report path (.json is a report's too: checked below)
    if suffix != ".json" and suffix in (*MOTION_EXTENSIONS, ".asf"):
        raise CommandError(
            f"--json: expected a report path (e.g. report.json), or nothing to print the report; got "
            f"{value!r}, a motion file's name {hint}"
        )
    if Path(value).is_file() and not is_report(Path(value)):
        raise CommandError(
            f"--json: expected a new file or an earlier elastic-motion report; got {value!r}, another "
            f"existing file (refusing to overwrite it) {hint}"
        )
