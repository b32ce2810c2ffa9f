"""``elastic-motion distance A B [C ...]``: elastic distances, serially.

A thin layer over :mod:`elastic_motion.apps.distance` (:func:`~elastic_motion.apps.distance.distance_table`).
"""

from __future__ import annotations

import argparse

from elastic_motion._options import choices
from elastic_motion.cli_commands._common import (
    CommandError,
    add_input_options,
    add_joint_options,
    add_json_option,
    add_quiet_option,
    add_warp_options,
    progress_for,
    run_guarded,
)
from elastic_motion.vocabulary import INTERPOLATIONS, Method


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``distance`` sub-command."""
    p = subparsers.add_parser(
        "distance",
        help="elastic distances between a few motions (serial; `matrix` scales up)",
        description=(
            "Pairwise elastic distances min_phi ||q_i - q_j * phi|| of the motions' SRV functions "
            "(R^3 x SO(3)^J by default), after placing all like the first. For many files use "
            "`elastic-motion matrix`."
        ),
    )
    p.add_argument("inputs", nargs="+", metavar="FILE", help="two or more motion files")
    p.add_argument("--method", choices=choices(Method), default="lie", help="curve representation")
    add_warp_options(p)
    p.add_argument(
        "--interpolation",
        choices=INTERPOLATIONS,
        default="geodesic",
        help="how the curves are sampled at --sample-fps: geodesic (default; at most the clips' own "
        "rate) or cubic (cubic splines at exactly --sample-fps, above the clips' rate too: e.g. "
        "--sample-fps 120 resolves sub-frame timing on 30 fps clips, at about 16x the DP's cost)",
    )
    add_joint_options(p)
    add_input_options(p, writes_bvh=False)
    add_json_option(p)
    add_quiet_option(p)
    p.set_defaults(func=lambda a: run_guarded("distance", run, a))


def run(args: argparse.Namespace) -> int:
    # the app is imported here: the command line starts without loading what it does not run
    from elastic_motion.apps.distance import distance_table, format_table
    from elastic_motion.apps.report import report_header
    from elastic_motion.cli_commands._running import emit_report, prepare_inputs, warp_options

    inputs = list(args.inputs)
    if len(inputs) < 2:
        raise CommandError(f"FILE: expected at least two motion files; got {len(inputs)}")
    prep = prepare_inputs(args, inputs)
    bar = progress_for("distance", args)
    try:
        table = distance_table(
            prep,
            method=args.method,
            warp=warp_options(args),
            progress=bar,
            interpolation=args.interpolation,
        )
    finally:
        bar.close()
    report = report_header("distance", inputs, [], table.notes)
    report.update(table.summary())
    text = f"{table.method} elastic distances (warp {table.warp}):\n{format_table(table)}"
    text += "".join(f"\nnote: {n}" for n in table.notes)
    emit_report(args, report, inputs, text)
    return 0
