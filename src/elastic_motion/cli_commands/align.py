"""``elastic-motion align A B``: the time warp, the distance and a plot (:mod:`elastic_motion.apps.align`).

``--method`` lists :data:`elastic_motion.vocabulary.METHODS`. ``run`` imports the apps (and
numpy) when the command runs (CLI start-up: building the parser loads neither).
"""

from __future__ import annotations

import argparse

from elastic_motion.cli_commands._common import (
    add_input_options,
    add_joint_options,
    add_json_option,
    add_landmark_options,
    add_warp_options,
    check_output,
    fmt_float,
    landmark_kinds,
    run_guarded,
)
from elastic_motion.vocabulary import METHODS


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``align`` sub-command."""
    p = subparsers.add_parser(
        "align",
        help="optimal time warp of B onto A, elastic distance, plot of the warp",
        description=(
            "Find the time warp that best aligns B to A (dynamic programming on the SRV functions, "
            "optionally guided by landmarks) and report the elastic distance with and without it."
        ),
    )
    p.add_argument("a", metavar="A", help="reference motion")
    p.add_argument("b", metavar="B", help="motion warped onto A")
    p.add_argument("--method", choices=METHODS, default="lie", help="curve representation")
    add_warp_options(p)
    add_landmark_options(p)
    add_joint_options(p)
    p.add_argument(
        "--plot",
        default=None,
        metavar="PNG",
        help="write a plot of the warp with the landmarks (default: none)",
    )
    add_input_options(p, writes_bvh=False)
    add_json_option(p)
    p.set_defaults(func=lambda a: run_guarded("align", run, a))


def run(args: argparse.Namespace) -> int:
    import numpy as np

    from elastic_motion.apps.align import align_motions
    from elastic_motion.apps.render import plot_warp
    from elastic_motion.apps.report import report_header
    from elastic_motion.cli_commands._running import emit_report, prepare_inputs, read_landmarks, warp_options

    inputs = [args.a, args.b]
    plot = (
        check_output(args.plot, inputs, suffixes=(".png", ".svg", ".pdf"), what="--plot")
        if args.plot
        else None
    )
    prep = prepare_inputs(args, inputs)
    fps = [r.fps for r in prep.inputs]
    landmarks, file_weight = read_landmarks(args.landmarks, args.landmark_units, fps[0], fps[1], inputs)
    res = align_motions(
        prep,
        method=args.method,
        warp=warp_options(args, file_weight),
        landmarks=landmarks,
        landmark_kinds=landmark_kinds(args.landmark_kinds),
        max_pairs=args.max_pairs,
    )
    outputs = []
    if plot is not None:
        plot_warp(res, plot, protected=inputs)
        outputs.append(str(plot))
    all_notes = list(res.prepared.notes)
    report = report_header("align", inputs, outputs, all_notes)
    report.update(res.summary())
    report["notes"] = all_notes
    ta = np.linspace(0.0, res.duration_a, 6)
    lines = [
        f"{res.method}, warp {res.warp}: distance {fmt_float(res.distance, 4)} "
        f"(without warp {fmt_float(res.distance_unwarped, 4)})",
        "matched times A -> B (s): " + ", ".join(f"{x:.2f}->{float(res.time_in_b(x)):.2f}" for x in ta),
    ]
    if res.landmarks:
        lines.append(
            "landmarks A:B (s) -> where the warp maps them: "
            + ", ".join(f"{x:.2f}:{y:.2f}->{float(res.time_in_b(x)):.2f}" for x, y in res.landmarks)
        )
    if plot is not None:
        lines.append(f"wrote {plot}")
    lines += [f"note: {n}" for n in all_notes]
    emit_report(args, report, [*inputs, *outputs], "\n".join(lines))
    return 0
