"""``elastic-motion distance A B [C ...]``: elastic distances, serially.

A thin layer over :mod:`elastic_motion.apps.distance`.
"""

from __future__ import annotations

import argparse

from elastic_motion.cli_commands._common import (
    add_input_options,
    add_joint_options,
    add_json_option,
    add_quiet_option,
    emit_report,
    joints_arg,
    load_inputs,
    progress_for,
    run_guarded,
)


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
    p.add_argument("--method", choices=("lie", "euler-elastic"), default="lie", help="curve representation")
    p.add_argument("--warp", choices=("dp", "dp+refine", "none"), default="dp", help="none: no time warp")
    p.add_argument("--warp-fps", type=float, default=30.0, help="frame rate of the curves")
    add_joint_options(p)
    add_input_options(p)
    add_json_option(p)
    add_quiet_option(p)
    p.set_defaults(func=lambda a: run_guarded("distance", run, a))


def run(args: argparse.Namespace) -> int:
    from elastic_motion.apps.distance import distance_table, format_table
    from elastic_motion.apps.report import report_header

    inputs = list(args.inputs)
    if len(inputs) < 2:
        raise ValueError(f"expected at least two motion files; got {len(inputs)}")
    motions, notes = load_inputs(
        inputs, trims=args.trim, keep_first_frame=args.keep_first_frame, units=args.units
    )
    bar = progress_for("distance", args)
    try:
        table = distance_table(
            motions,
            method=args.method,
            warp=args.warp,
            joints=joints_arg(args.joints),
            align=not args.no_align,
            warp_fps=args.warp_fps,
            progress=bar,
        )
    finally:
        bar.close()
    all_notes = notes + list(table.notes)
    report = report_header("distance", inputs, [], all_notes)
    report.update(table.summary())
    report["notes"] = all_notes
    text = f"{table.method} elastic distances (warp {table.warp}):\n{format_table(table)}"
    text += "".join(f"\nnote: {n}" for n in all_notes)
    emit_report(args, report, inputs, text)
    return 0
