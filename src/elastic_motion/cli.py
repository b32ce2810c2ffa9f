"""Command-line interface: a thin layer over the Python API.

Each sub-command parses its arguments, calls one public function of the package and
reports what it did.  Numerical work never happens here.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from elastic_motion import __version__


def build_parser() -> argparse.ArgumentParser:
    """Return the top-level argument parser with all sub-commands registered."""
    parser = argparse.ArgumentParser(
        prog="elastic-motion",
        description=(
            "Elastic shape analysis of motions as curves in Lie groups "
            "(R^3 x SO(3)^J): blend, loop and compare motion-capture clips."
        ),
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    from elastic_motion.cli_commands import (
        align,
        blend,
        database,
        demo,
        distance,
        info,
        landmarks,
        loop,
        render,
    )

    # The README's first command first; then the motion commands; then the database ones.
    for module in (demo, info, blend, landmarks, loop, align, distance, render, database):
        module.register(subparsers)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``elastic-motion`` console script; returns the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 0
    return int(args.func(args))


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
