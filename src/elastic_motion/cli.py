"""Command-line interface: a thin layer over the Python API.

Each sub-command parses its arguments, calls one public function of the package and
reports what it did.  Numerical work never happens here.

:func:`main` is the one place where a command's failure becomes a message and an exit code
(see :mod:`elastic_motion.cli_commands._argparse`): commands raise, ``main`` prints
``elastic-motion CMD: error: ...`` on stderr (never a traceback, unless
``ELASTIC_MOTION_DEBUG=1``) and returns 0 success, 1 incomplete or interrupted run, 2 bad
input, 3 environment. A closed standard output (``elastic-motion ... | head -1``) ends the
command quietly with exit code 0.
"""

from __future__ import annotations

import argparse
import importlib
import os
import select
import sys
from collections.abc import Sequence

from elastic_motion import __version__
from elastic_motion.cli_commands._argparse import (
    EXIT_CODES_HELP,
    EXIT_OK,
    CliParser,
    handle_error,
)
from elastic_motion.cli_commands._paths import check_report_target

#: The command modules (``elastic_motion.cli_commands.<module>``), in the order of ``--help``, with
#: the sub-commands each registers: the README's first command first; then the motion commands;
#: then the database ones, the database index and statistical model (issue 15), blend spaces
#: (issue 16), the viewer and the Blender add-on.
COMMAND_MODULES: dict[str, tuple[str, ...]] = {
    "demo": ("demo",),
    "info": ("info",),
    "blend": ("blend",),
    "landmarks": ("landmarks",),
    "loop": ("loop",),
    "align": ("align",),
    "distance": ("distance",),
    "render": ("render",),
    "database": ("matrix", "search", "classify", "mean", "cluster"),
    "index": ("index",),
    "pca": ("pca",),
    "blendspace": ("blendspace",),
    "view": ("view",),
    "blender_addon": ("blender-addon",),
}


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """Return the top-level argument parser with the sub-commands registered.

    Every parser is a :class:`~elastic_motion.cli_commands._argparse.CliParser`: its help
    shows each option's default, its errors use the package's error format.

    Parameters
    ----------
    command : str, optional
        A sub-command's name: only its module (:data:`COMMAND_MODULES`) is imported and
        registered (:func:`main` passes the first word of a command line that starts with a
        command, so that a command imports no other). Default, or a name that is no
        command: all of them.
    """
    parser = CliParser(
        prog="elastic-motion",
        description=(
            "Elastic shape analysis of motions as curves in Lie groups "
            "(R^3 x SO(3)^J): blend, loop and compare motion-capture clips."
        ),
        epilog=EXIT_CODES_HELP,
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=CliParser)

    chosen = [name for name, commands in COMMAND_MODULES.items() if command in commands]
    for name in chosen or COMMAND_MODULES:
        importlib.import_module(f"elastic_motion.cli_commands.{name}").register(subparsers)
    return parser


def subcommand_parsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    """The sub-command parsers of ``parser`` (from :func:`build_parser`), by command name."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return dict(action.choices)
    return {}


def _debug() -> bool:
    return os.environ.get("ELASTIC_MOTION_DEBUG", "") not in ("", "0")


def _stdout_is_closed() -> bool:
    """Whether standard output is a pipe (or socket) whose reader has gone away."""
    try:
        fd = sys.stdout.fileno()
    except (AttributeError, OSError, ValueError):  # replaced by a non-file (tests): not a pipe
        return False
    try:
        poller = select.poll()
    except AttributeError:  # pragma: no cover - no poll (Windows): trust the error
        return True
    poller.register(fd, select.POLLOUT)
    return any(ev & (select.POLLERR | select.POLLHUP) for _, ev in poller.poll(0))


def _silence_stdout() -> None:
    """Point the stdout file descriptor at /dev/null, so the interpreter's final flush succeeds."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (AttributeError, OSError, ValueError):
        pass


def _flush_stdout() -> None:
    """Flush stdout; if that fails (closed pipe, full disk), silence it instead of failing at exit."""
    try:
        sys.stdout.flush()
    except OSError:
        _silence_stdout()
    except ValueError:  # closed by the command
        pass


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``elastic-motion`` console script; returns the exit code.

    Parameters
    ----------
    argv : sequence of str, optional
        The arguments (default ``sys.argv[1:]``).

    Returns
    -------
    int
        0 success, 1 the run did not complete, 2 bad input, 3 environment failure (argparse
        exits with 2 itself for a malformed command line, 0 for ``--help``).
    """
    command: str | None = None
    argv = sys.argv[1:] if argv is None else list(argv)
    try:
        # a command line that starts with a command needs that command's parser alone
        parser = build_parser(argv[0] if argv else None)
        args, extras = parser.parse_known_args(argv)
        command = getattr(args, "command", None)
        if extras:
            sub = subcommand_parsers(parser).get(command, parser) if command else parser
            sub.error(f"unrecognized arguments: {' '.join(extras)}")
        if command is None:
            parser.print_help()
            code = EXIT_OK
        else:
            check_report_target(args)  # before any work: a report never replaces a motion file
            code = int(args.func(args))
        try:
            sys.stdout.flush()
        except OSError as exc:
            if exc.filename is None:  # e.g. `elastic-motion ... > /dev/full`: name what failed
                exc.filename = "<stdout>"
            raise
        return code
    except BrokenPipeError as exc:
        if _stdout_is_closed():  # `| head`: the reader has what it wanted
            _silence_stdout()
            return EXIT_OK
        if _debug():
            raise
        return handle_error(command, exc)
    except SystemExit:  # --help, --version, argparse errors
        _flush_stdout()
        raise
    except (Exception, KeyboardInterrupt) as exc:
        if _debug():
            raise
        code = handle_error(command, exc)
        _flush_stdout()
        return code


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
