"""Exceptions shared by the package.

:class:`ParseError` is the one exception a file reader raises for a malformed file: it
names the file, the line (1-based, when there is one) and what the reader expected, so
the message alone tells the user where to look::

    walk.bvh:190: expected 96 values (one per channel), found 95

:class:`OptionError` is a bad value of a named option (an argument of the Python API,
which the command line maps to its flag): ``trim: 107_02.bvh: expected START < STOP ...``.
"""

from __future__ import annotations

import os

__all__ = ["OptionError", "ParseError"]


class ParseError(ValueError):
    """A file could not be read: ``path:line: what was expected, what was found``.

    Subclasses ``ValueError`` so callers that already catch bad values keep working.

    Parameters
    ----------
    path : str or os.PathLike
        The file being read.
    line : int or None
        1-based line number of the offending text, ``None`` when the problem is not tied
        to one line (e.g. a file that ends too early is reported at its last line).
    message : str
        What was expected and what came instead.

    Attributes
    ----------
    path : str
    line : int or None
    message : str
    """

    def __init__(self, path: str | os.PathLike[str], line: int | None, message: str) -> None:
        self.path = os.fspath(path)
        self.line = line
        self.message = message
        where = f"{self.path}:{line}" if line is not None else self.path
        super().__init__(f"{where}: {message}")

    def __reduce__(self):  # keep pickling (multiprocessing) working with the custom __init__
        return (type(self), (self.path, self.line, self.message))


class OptionError(ValueError):
    """A bad value for a named option: ``option: what was expected; got what came``.

    The Python API raises it with the argument's name (``"trim"``, ``"joints"``); the
    command line shows the flag instead (``--trim``), so both doors name the same thing.

    Parameters
    ----------
    option : str
        The argument's name in the Python API.
    message : str
        What was expected and what came (may start with the file it concerns).
    """

    def __init__(self, option: str, message: str) -> None:
        self.option = option
        self.message = message
        super().__init__(f"{option}: {message}")

    def __reduce__(self):
        return (type(self), (self.option, self.message))
