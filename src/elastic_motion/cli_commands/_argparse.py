"""Argument-parsing and error-reporting plumbing shared by every ``elastic-motion`` command.

* Exit codes: :data:`EXIT_OK`, :data:`EXIT_INCOMPLETE`, :data:`EXIT_BAD_INPUT`,
  :data:`EXIT_ENVIRONMENT` (documented in ``docs/cli.md`` and in ``elastic-motion --help``).
* One error format, ``elastic-motion CMD: error: FILE-OR-OPTION: what was expected; got what
  came``: :func:`print_error` prints it, :func:`exit_code_for` and :func:`describe_error` turn
  any exception into an exit code and such a message (``cli.main`` calls :func:`handle_error`
  on whatever a command raises, so commands just raise).
* :class:`CliParser`: the parser class of the top-level parser and of every sub-command
  (argparse's own errors, e.g. a bad ``--method`` value, are rewritten to the same format),
  with :class:`DefaultsHelpFormatter`, which appends ``(default: X)`` to every option's help.
* :func:`add_alias`: keep an old option spelling working for a release, hidden from
  ``--help``, with a one-line deprecation note on stderr.

The sub-commands' user error (:class:`~._errors.CommandError`) and the outputs' safety net
(:func:`~._paths.check_paths`) are imported from the modules below this one; the Dask
cluster's error class is imported when an error is classified (the database app loads
numba, which this module, imported when the command line is read, must not).
"""

from __future__ import annotations

import argparse
import copy
import errno
import os
import re
import sys
from collections.abc import Callable, Sequence
from typing import Any, NoReturn, TextIO

from elastic_motion.cli_commands._errors import CommandError, option_message
from elastic_motion.cli_commands._paths import check_option_limits, check_paths
from elastic_motion.errors import OptionError

__all__ = [
    "EXIT_BAD_INPUT",
    "EXIT_CODES_HELP",
    "EXIT_ENVIRONMENT",
    "EXIT_INCOMPLETE",
    "EXIT_OK",
    "CliParser",
    "DefaultsHelpFormatter",
    "add_alias",
    "describe_error",
    "exit_code_for",
    "format_default",
    "handle_error",
    "mentions_default",
    "print_error",
    "print_note",
]

#: The command did what was asked.
EXIT_OK = 0
#: The run did not complete: interrupted (Ctrl-C), a ``matrix`` left incomplete (run it again
#: to resume), or an internal error (a bug).
EXIT_INCOMPLETE = 1
#: Bad input: an unreadable or malformed file, a wrong option value.
EXIT_BAD_INPUT = 2
#: The environment failed: cluster unreachable, read-only or full disk, permission denied,
#: out of memory, a missing optional package.
EXIT_ENVIRONMENT = 3

#: The exit codes as printed at the end of ``elastic-motion --help`` (and in ``docs/cli.md``).
EXIT_CODES_HELP = """\
exit codes:
  0  success
  1  the run did not complete: interrupted (Ctrl-C), a matrix left incomplete
     (run the same command again to resume), or an internal error (a bug;
     ELASTIC_MOTION_DEBUG=1 shows its traceback)
  2  bad input: an unreadable or malformed file, a wrong option value, a
     value beyond a resource limit (ELASTIC_MOTION_LIMITS raises them)
  3  environment: cluster unreachable, read-only or full disk, permission
     denied, out of memory, a missing optional package

Errors are one line on stderr: "elastic-motion COMMAND: error: FILE-OR-OPTION:
what was expected; got what came". ELASTIC_MOTION_PROGRESS=0 turns progress
bars off, =1 shows them also when stderr is not a terminal."""

#: ``errno`` values reported as an environment failure (exit code 3).
_ENVIRONMENT_ERRNOS = {
    errno.EROFS: "a writable file system; got a read-only file system",
    errno.EACCES: "read/write permission; got permission denied",
    errno.EPERM: "permission for this operation; got operation not permitted",
    errno.ENOSPC: "free disk space; got no space left on device",
    errno.EDQUOT: "free disk quota; got disk quota exceeded",
    errno.EIO: "a working disk; got an input/output error",
    errno.ENOMEM: "enough memory; got out of memory",
}
#: ``errno`` values reported as bad input (exit code 2): the path given was wrong.
_INPUT_ERRNOS = {
    errno.ENOENT: "an existing file; got no such file or folder",
    errno.EISDIR: "a file; got a folder",
    errno.ENOTDIR: "a folder in the path; got a file",
    errno.EEXIST: "a path that does not exist yet; got an existing one",
    errno.ENAMETOOLONG: "a shorter path; got a name too long for the file system",
    errno.ELOOP: "a path without a symbolic-link loop; got too many levels of symbolic links",
    errno.EINVAL: "a valid path or value; got an invalid argument",
}


# ------------------------------------------------------------------------------------------
# Messages
# ------------------------------------------------------------------------------------------


def _prog(command: str | None) -> str:
    return f"elastic-motion {command}" if command else "elastic-motion"


def _write_line(line: str, stream: TextIO | None) -> None:
    stream = sys.stderr if stream is None else stream
    try:
        stream.write(line + "\n")
        stream.flush()
    except (OSError, ValueError):  # stderr closed too: nothing more can be said
        pass


def print_error(command: str | None, message: str, *, stream: TextIO | None = None) -> None:
    """Print ``elastic-motion COMMAND: error: MESSAGE`` on stderr.

    Parameters
    ----------
    command : str or None
        The sub-command (``"blend"``), or ``None`` for the top-level program.
    message : str
        ``FILE-OR-OPTION: what was expected; got what came``.
    stream : file-like, optional
        Default ``sys.stderr`` (looked up at call time, so that tests can capture it).
    """
    _write_line(f"{_prog(command)}: error: {message}", stream)


def print_note(command: str | None, message: str, *, stream: TextIO | None = None) -> None:
    """Print ``elastic-motion COMMAND: note: MESSAGE`` on stderr (deprecations, hints)."""
    _write_line(f"{_prog(command)}: note: {message}", stream)


def _cluster_unavailable() -> type[BaseException] | None:
    try:  # local: the database app loads numba (module docstring)
        from elastic_motion.apps.database import ClusterUnavailableError
    except Exception:  # pragma: no cover - an optional import failing must not mask the error
        return None
    return ClusterUnavailableError


def _interrupt_behind(exc: BaseException) -> BaseException:
    """The ``KeyboardInterrupt`` behind ``exc`` when there is one (Ctrl-C inside compiled
    numba code surfaces as a ``SystemError`` whose context is the interrupt), else ``exc``."""
    seen = exc
    for _ in range(8):
        if isinstance(seen, KeyboardInterrupt):
            return seen
        nxt = seen.__cause__ or seen.__context__
        if nxt is None:
            break
        seen = nxt
    return exc


def exit_code_for(exc: BaseException) -> int:
    """The exit code for an exception that ended a command.

    An exception with an integer ``exit_code`` attribute sets it; otherwise:
    :data:`EXIT_INCOMPLETE` for ``KeyboardInterrupt`` and unexpected exceptions (bugs);
    :data:`EXIT_ENVIRONMENT` for ``MemoryError``, a missing package, the Dask cluster
    being unreachable and OS errors other than a wrong path (read-only or full disk,
    permission denied); :data:`EXIT_BAD_INPUT` for wrong paths and user errors (the CLI's
    ``CommandError``, :class:`~elastic_motion.errors.ParseError`, ``ValueError``,
    ``KeyError``, ``OverflowError`` and ``RecursionError``: a value or nesting too large).

    Parameters
    ----------
    exc : BaseException

    Returns
    -------
    int
    """
    exc = _interrupt_behind(exc)
    code = getattr(exc, "exit_code", None)
    if isinstance(code, int) and not isinstance(code, bool):
        return code
    if isinstance(exc, KeyboardInterrupt):
        return EXIT_INCOMPLETE
    if isinstance(exc, MemoryError | ModuleNotFoundError):
        return EXIT_ENVIRONMENT
    if isinstance(exc, RecursionError):
        return EXIT_BAD_INPUT
    if isinstance(exc, OSError):
        if isinstance(exc, FileNotFoundError | IsADirectoryError | NotADirectoryError | FileExistsError):
            return EXIT_BAD_INPUT
        return EXIT_BAD_INPUT if exc.errno in _INPUT_ERRNOS else EXIT_ENVIRONMENT
    cluster = _cluster_unavailable()
    if cluster is not None and isinstance(exc, cluster):
        return EXIT_ENVIRONMENT
    if _is_user_error(exc):
        return EXIT_BAD_INPUT
    return EXIT_INCOMPLETE


def _is_user_error(exc: BaseException) -> bool:
    if isinstance(exc, ValueError | KeyError | OverflowError):  # overflow: a number too large was given
        return True
    return isinstance(exc, CommandError)  # the sub-commands' user error


def describe_error(exc: BaseException) -> str:
    """The message part of an error line for ``exc`` (without ``elastic-motion CMD: error:``).

    OS errors become ``FILE: expected ...; got ...`` (``/ro/out.bvh: expected a writable
    file system; got a read-only file system``); user errors keep their own message (the
    package's messages already name the file or option); a ``KeyError`` is its key;
    anything else is reported as an internal error with where it happened.

    Parameters
    ----------
    exc : BaseException

    Returns
    -------
    str
    """
    exc = _interrupt_behind(exc)
    if isinstance(exc, KeyboardInterrupt):
        return "interrupted (Ctrl-C): the run did not finish"
    if isinstance(exc, MemoryError):
        return "memory: expected enough memory for this run; got out of memory (try fewer or shorter motions)"
    if isinstance(exc, ModuleNotFoundError):
        name = exc.name or str(exc)
        return f"{name}: expected the optional package {name!r}; got it not installed (pip install it)"
    if isinstance(exc, OSError):
        where = exc.filename if exc.filename is not None else None
        if exc.filename2 is not None:
            where = f"{exc.filename} -> {exc.filename2}"
        what = _ENVIRONMENT_ERRNOS.get(exc.errno) or _INPUT_ERRNOS.get(exc.errno)
        if what is None:
            text = exc.strerror or str(exc) or type(exc).__name__
            what = f"the operation to succeed; got {text}"
        return f"{where}: expected {what}" if where is not None else f"expected {what}"
    if isinstance(exc, KeyError) and exc.args:
        return str(exc.args[0])
    if isinstance(exc, OverflowError):
        return (
            f"value: expected numbers within the floating-point range and the resource limits; "
            f"got one too large ({exc}){_where(exc)}"
        )
    if isinstance(exc, RecursionError):
        return "input: expected a nesting depth Python can follow; got one too deep"
    if isinstance(exc, OptionError):  # an API argument name: say the command-line flag instead
        return option_message(exc)
    if _is_user_error(exc) or getattr(exc, "exit_code", None) is not None:
        return str(exc) or type(exc).__name__
    cluster = _cluster_unavailable()
    if cluster is not None and isinstance(exc, cluster):
        return str(exc)
    return f"internal error: {type(exc).__name__}: {exc}{_where(exc)}; this is a bug, please report it"


def _where(exc: BaseException) -> str:
    tb = exc.__traceback__
    if tb is None:
        return ""
    while tb.tb_next is not None:
        tb = tb.tb_next
    code = tb.tb_frame.f_code
    return f" (in {code.co_name}, {os.path.basename(code.co_filename)}:{tb.tb_lineno})"


def handle_error(command: str | None, exc: BaseException, *, stream: TextIO | None = None) -> int:
    """Print the error line for ``exc`` raised by ``command``; return its exit code.

    Internal errors (bugs) also say that ``ELASTIC_MOTION_DEBUG=1`` shows the traceback.

    Parameters
    ----------
    command : str or None
    exc : BaseException
    stream : file-like, optional
        Default ``sys.stderr``.

    Returns
    -------
    int
        :func:`exit_code_for` ``(exc)``.
    """
    code = exit_code_for(exc)
    message = describe_error(exc)
    if message.startswith("internal error:"):
        message += " (ELASTIC_MOTION_DEBUG=1 shows the traceback)"
    print_error(command, message, stream=stream)
    return code


# ------------------------------------------------------------------------------------------
# Help formatting
# ------------------------------------------------------------------------------------------


def format_default(value: Any) -> str:
    """How a default value is shown in ``--help``: floats with ``g``, lists space-separated."""
    if isinstance(value, list | tuple):
        return " ".join(format_default(v) for v in value)
    if isinstance(value, float):
        return f"{value:g}"
    return str(value)


_NUMBER = re.compile(r"(?<![\w.])[-+]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d+)?(?![\w.])")


def mentions_default(text: str, default: Any) -> bool:
    """Whether help ``text`` says "default" and gives the value ``default``.

    The value counts as given when its text (:func:`format_default`) appears as a word
    (case-sensitive) or, for a number, when some number in ``text`` equals it
    (``"(default 1e-4)"`` gives 0.0001).

    Parameters
    ----------
    text : str
        An option's help, as printed.
    default : object
        The option's default.

    Returns
    -------
    bool
    """
    if "default" not in text.lower():
        return False
    shown = format_default(default)
    if re.search(rf"(?<![\w]){re.escape(shown)}(?![\w])", text):
        return True
    if isinstance(default, int | float) and not isinstance(default, bool):
        return any(float(tok) == float(default) for tok in _NUMBER.findall(text))
    return False


def _shows_default(action: argparse.Action) -> bool:
    """Whether ``action`` has a default worth showing (not None, False, SUPPRESS or a flag's)."""
    if action.help is argparse.SUPPRESS or action.default is argparse.SUPPRESS:
        return False
    if action.default is None or action.default is False:
        return False
    if action.nargs == 0:  # store_true/store_false/store_const/count/help/version: the flag says it
        return False
    return bool(action.option_strings) or action.nargs in (argparse.OPTIONAL, argparse.ZERO_OR_MORE)


class DefaultsHelpFormatter(argparse.HelpFormatter):
    """Help formatter that shows every option's default.

    ``(default: X)`` is appended to the help of an option whose default is not ``None``,
    ``False`` or ``SUPPRESS`` (and which is not a flag), unless its help already says
    "default" and gives the value (:func:`mentions_default`). Descriptions and epilogs are
    wrapped paragraph by paragraph (paragraphs are separated by a blank line); a paragraph
    with an indented line is kept as written, so that tables such as the exit codes survive.
    """

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        if text is argparse.SUPPRESS or not _shows_default(action):
            return text
        if mentions_default(text.replace("%%", "%"), action.default):
            return text
        shown = format_default(action.default).replace("%", "%%")
        return f"{text} (default: {shown})" if text else f"(default: {shown})"

    def _format_action(self, action: argparse.Action) -> str:
        if not action.help and _shows_default(action):  # no help text: still show the default
            action = copy.copy(action)
            action.help = f"(default: {format_default(action.default).replace('%', '%%')})"
        return super()._format_action(action)

    def _fill_text(self, text: str, width: int, indent: str) -> str:
        out = []
        for para in re.split(r"\n\s*\n", text.strip("\n")):
            lines = para.splitlines()
            if any(line[:1].isspace() for line in lines[1:]):
                out.append("\n".join(indent + line for line in lines))
            else:
                out.append(super()._fill_text(para, width, indent))
        return "\n\n".join(out)


# ------------------------------------------------------------------------------------------
# Parser
# ------------------------------------------------------------------------------------------

_TYPE_NAMES = {"int": "an integer", "float": "a number", "str": "text"}


def _rewrite_argparse_message(message: str) -> str:
    """argparse's messages in the ``OPTION: expected ...; got ...`` form (others unchanged)."""
    m = re.fullmatch(r"argument (\S+): invalid choice: (.*) \(choose from (.*)\)", message, re.S)
    if m:
        return f"{m[1]}: expected one of {m[3]}; got {m[2]}"
    m = re.fullmatch(r"argument (\S+): invalid (\S+) value: (.*)", message, re.S)
    if m:
        return f"{m[1]}: expected {_TYPE_NAMES.get(m[2], 'a ' + m[2] + ' value')}; got {m[3]}"
    m = re.fullmatch(r"argument (\S+): expected (one|at least one) argument", message)
    if m:
        return f"{m[1]}: expected {'a value' if m[2] == 'one' else 'one or more values'}; got none"
    m = re.fullmatch(r"argument (\S+): expected (\d+) arguments", message)
    if m:
        return f"{m[1]}: expected {m[2]} values; got fewer"
    m = re.fullmatch(r"the following arguments are required: (.*)", message)
    if m:
        return f"{m[1]}: expected a value (required); got none"
    m = re.fullmatch(r"unrecognized arguments: (.*)", message)
    if m:
        return f"{m[1]}: expected options and arguments listed by --help; got unrecognized arguments"
    m = re.fullmatch(r"ambiguous option: (\S+) could match (.*)", message)
    if m:
        return f"{m[1]}: expected one of {m[2]}; got an ambiguous abbreviation"
    m = re.fullmatch(r"argument (\S+): (expected .*)", message, re.S)  # our own types' messages
    if m:
        return f"{m[1]}: {m[2]}"
    return message


def _guarded(func: Callable[[argparse.Namespace], int]) -> Callable[[argparse.Namespace], int]:
    """``func`` preceded by the outputs-vs-inputs safety net (:func:`~._paths.check_paths`)."""
    if getattr(func, "_paths_checked", False):
        return func

    def run(args: argparse.Namespace) -> int:
        try:
            check_paths(args)  # before anything is read or written
            check_option_limits(args)
        except CommandError as exc:
            print_error(getattr(args, "command", None), str(exc))
            return EXIT_BAD_INPUT
        return func(args)

    run._paths_checked = True  # type: ignore[attr-defined]
    run.__wrapped__ = func  # type: ignore[attr-defined]
    return run


class CliParser(argparse.ArgumentParser):
    """``ArgumentParser`` with :class:`DefaultsHelpFormatter` and the package's error format.

    ``cli.build_parser`` makes the top-level parser a ``CliParser``; argparse then creates
    every sub-command's parser with the same class, so ``subparsers.add_parser(...)`` in a
    command module gets both without doing anything.
    """

    def __init__(self, *args: Any, formatter_class: type = DefaultsHelpFormatter, **kwargs: Any) -> None:
        super().__init__(*args, formatter_class=formatter_class, **kwargs)

    def parse_known_args(
        self, args: Sequence[str] | None = None, namespace: argparse.Namespace | None = None
    ) -> tuple[argparse.Namespace, list[str]]:
        """As argparse's; a required option given by its deprecated alias counts as given."""
        argv = sys.argv[1:] if args is None else list(args)
        given = [
            target
            for old, target in getattr(self, "_deprecated_aliases", ())
            if target.required and any(a == old or a.startswith(old + "=") for a in argv)
        ]
        for target in given:  # argparse only counts the option's own action as "seen"
            target.required = False
        try:
            parsed, extras = super().parse_known_args(argv, namespace)
        finally:
            for target in given:
                target.required = True
        func = getattr(parsed, "func", None)
        if namespace is None and func is not None and getattr(parsed, "command", None):
            parsed.func = _guarded(func)  # the top-level parse of a command line: the outputs' safety net
        return parsed, extras

    def error(self, message: str) -> NoReturn:
        """Print the usage and ``PROG: error: OPTION: expected ...; got ...``; exit with code 2."""
        self.print_usage(sys.stderr)
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {_rewrite_argparse_message(message)}\n")


# ------------------------------------------------------------------------------------------
# Deprecated aliases
# ------------------------------------------------------------------------------------------


class _DeprecatedAlias(argparse.Action):
    """An old option spelling: parses like its new option, notes the deprecation, delegates."""

    def __init__(
        self,
        option_strings: Sequence[str],
        dest: str,
        *,
        target: argparse.Action,
        new: str,
        convert: Callable[[Any], Any] | None = None,
        until: str | None = None,
        **kwargs: Any,
    ) -> None:
        super().__init__(option_strings, dest, **kwargs)
        self.target = target
        self.new = new
        self.convert = convert
        self.until = until

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: Any,
        option_string: str | None = None,
    ) -> None:
        when = f" and will be removed in {self.until}" if self.until else ""
        _write_line(f"{parser.prog}: note: {option_string} is deprecated{when}; use {self.new}", None)
        if self.convert is not None:
            values = self.convert(values)
            choices = self.target.choices
            if choices is not None and any(v not in choices for v in _as_list(values, self.target.nargs)):
                got = values if self.target.nargs in (None, argparse.OPTIONAL) else " ".join(map(str, values))
                allowed = ", ".join(map(repr, choices))
                parser.error(f"argument {option_string}: invalid choice: {got!r} (choose from {allowed})")
        self.target(parser, namespace, values, self.new)


def _as_list(values: Any, nargs: Any) -> list[Any]:
    return [values] if nargs in (None, argparse.OPTIONAL) else list(values)


_SAME = object()  # add_alias: "as the new option"


def add_alias(
    parser: argparse.ArgumentParser,
    old: str,
    new: str,
    *,
    convert: Callable[[Any], Any] | None = None,
    nargs: Any = _SAME,
    until: str | None = None,
) -> argparse.Action:
    """Keep the old spelling ``old`` of option ``new`` working, hidden from ``--help``.

    Call it after ``parser.add_argument(new, ...)``. The alias takes the same values as
    ``new`` (same ``nargs``, ``type``, ``choices``; a flag stays a flag), stores them where
    ``new`` does, and prints one line on stderr each time it is used::

        elastic-motion matrix: note: --repr is deprecated; use --method

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The sub-command's parser, which already has the option ``new``.
    old : str
        The old option string, e.g. ``"--repr"``.
    new : str
        One option string of the new option, e.g. ``"--method"``.
    convert : callable, optional
        Maps the old option's value (the string, or the list of strings for ``nargs``) to the
        new option's, when their meanings differ; the result must be in ``new``'s choices.
    nargs : int or str, optional
        How many values the old spelling takes, when not as many as ``new`` (e.g. ``None``
        for an old comma-separated list converted to a ``nargs="+"`` option's list).
    until : str, optional
        The release that removes the alias (``"0.3"``), shown in the note.

    Returns
    -------
    argparse.Action
        The hidden alias action.

    Raises
    ------
    ValueError
        When ``parser`` has no option ``new`` (or already has ``old``, as argparse says), or
        when ``new`` is required and ``parser`` is not a :class:`CliParser` (which counts a
        required option given by its alias as given).

    Examples
    --------
    >>> p = CliParser(prog="elastic-motion loop")
    >>> _ = p.add_argument("--method", choices=("lie", "euler"), default="lie")
    >>> _ = add_alias(p, "--representation", "--method")
    >>> p.parse_args(["--representation", "euler"]).method  # doctest: +SKIP
    'euler'
    """
    target = parser._option_string_actions.get(new)
    if target is None:
        raise ValueError(f"add_alias: expected {new!r} to be an option of {parser.prog!r}; got none")
    if target.required and not isinstance(parser, CliParser):
        raise ValueError(f"add_alias: expected a CliParser for the required option {new!r}; got {parser!r}")
    kwargs: dict[str, Any] = {"nargs": target.nargs if nargs is _SAME else nargs, "metavar": target.metavar}
    if target.nargs != 0 and convert is None:  # with convert, the old values are checked after it
        kwargs.update(type=target.type, choices=target.choices)
    parser.__dict__.setdefault("_deprecated_aliases", []).append((old, target))
    return parser.add_argument(
        old,
        action=_DeprecatedAlias,
        dest=target.dest,
        default=argparse.SUPPRESS,
        help=argparse.SUPPRESS,
        target=target,
        new=new,
        convert=convert,
        until=until,
        **kwargs,
    )
