"""The command line's user error and the words of an option error, shared by the parser's
plumbing (:mod:`._argparse`), the outputs' safety net (:mod:`._paths`) and the commands'
helpers (:mod:`._common`), which all import them from here.
"""

from __future__ import annotations

from elastic_motion.errors import OptionError

__all__ = ["CommandError", "option_message"]


class CommandError(Exception):
    """A user error: printed as ``elastic-motion CMD: error: MESSAGE``, exit code 2."""


#: API argument names that are input files on the command line, not options.
_POSITIONAL = {"motions", "motion", "labels", "prepare"}


def option_message(exc: OptionError) -> str:
    """An :class:`OptionError` in command-line words: the API argument ``trim`` is ``--trim``."""
    if exc.option in _POSITIONAL:
        return exc.message
    return f"--{exc.option.replace('_', '-')}: {exc.message}"
