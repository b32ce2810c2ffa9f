"""``elastic-motion index DIR... -o INDEX``: an on-disk index of SRV arrays for ``search``.

Thin wrapper over :func:`elastic_motion.apps.database.build_index`; ``search QUERY INDEX``
then reads one file instead of every motion.
"""

from __future__ import annotations

import argparse

from elastic_motion.cli_commands._common import add_json_option, add_quiet_option, progress_for
from elastic_motion.cli_commands._database_options import (
    USER_ERRORS,
    add_distance_terms,
    add_method,
    add_preparation,
    add_warp,
    fail,
)


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``index`` sub-command."""
    p = subparsers.add_parser(
        "index",
        help="build an on-disk index of a motion database for fast exact search",
        description=(
            "Read every motion of the files/folders once and write their SRV arrays and search bounds "
            "into the folder OUTPUT; `elastic-motion search QUERY OUTPUT` then needs no motion file. An "
            "index built by another version of elastic-motion is refused (rebuild it with --overwrite)."
        ),
    )
    p.add_argument("inputs", nargs="+", help="motion files and/or folders")
    p.add_argument("-o", "--output", required=True, help="index folder (created; required)")
    p.add_argument("--recursive", action="store_true", help="search folders recursively (default: off)")
    p.add_argument(
        "--overwrite", action="store_true", help="rebuild an index found in OUTPUT (default: refuse)"
    )
    add_method(p, several=True)
    add_quiet_option(p)
    add_json_option(p)
    add_preparation(p)
    add_warp(p)
    add_distance_terms(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Build the index; print a summary (or the ``--json`` report)."""
    # the app is imported here: the command line starts without loading what it does not run
    from elastic_motion.apps.database import build_index
    from elastic_motion.cli_commands._database_running import database_settings, emit, methods

    bar = progress_for("index", args)
    try:
        settings = database_settings(args, methods(args.method, several=True))
        idx = build_index(
            args.inputs,
            args.output,
            settings,
            recursive=args.recursive,
            overwrite=args.overwrite,
            progress=bar,
        )
    except USER_ERRORS as exc:
        return fail("index", exc)
    finally:
        bar.close()
    meta = idx.meta
    lines = [f"{meta['n_motions']} motions -> {idx.path} ({len(meta['groups'])} skeleton groups)"]
    if len(meta["groups"]) > 1:
        lines.append(
            "several skeletons: a query is compared with the motions of its own skeleton only "
            "(use --joints common to compare on shared joints)"
        )
    lines += [f"skipped {sk['path']}: {sk['reason']}" for sk in meta["skipped"]]
    emit(args, "index", idx.summary(), args.inputs, [idx.path], lines)
    return 0
