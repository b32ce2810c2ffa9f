"""``elastic-motion blendspace A B C ... --at P -o OUT.bvh``: a blend space of N >= 3 motions
placed by a parameter (:mod:`elastic_motion.apps.blendspace`).

``run`` imports the app when the command runs (CLI start-up: building the parser loads no numpy).
"""

from __future__ import annotations

import argparse

from elastic_motion._options import choices
from elastic_motion.cli_commands._common import (
    CommandError,
    add_input_options,
    add_json_option,
    check_output,
    fmt_float,
    run_guarded,
)
from elastic_motion.cli_commands.blend import contacts_flag
from elastic_motion.vocabulary import OUTPUT_MOTION_EXTENSIONS, ContactPolicy, Method


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``blendspace`` sub-command."""
    p = subparsers.add_parser(
        "blendspace",
        help="a blend space: motions placed by a parameter (e.g. speed), one motion at any parameter",
        description=(
            "Place N >= 3 motions of one skeleton by a parameter (their root speed, or given numbers), "
            "align them all to a common template once (their Karcher mean), and write the motion at "
            "parameter --at: the blend of the two neighbouring motions, with the template's warps."
        ),
    )
    p.add_argument("inputs", nargs="+", metavar="FILE", help="three or more motion files of one skeleton")
    p.add_argument(
        "-o", "--output", required=True, help="output .bvh, .gltf or .glb file (never one of the inputs)"
    )
    p.add_argument(
        "--params",
        default="speed",
        help="'speed' (mean horizontal root speed, m/s) or one number per input, comma-separated "
        "(default: speed)",
    )
    p.add_argument(
        "--at",
        type=float,
        required=True,
        help="the parameter of the motion to write (within the inputs' range)",
    )
    p.add_argument(
        "--one-cycle",
        action="store_true",
        help="keep one gait cycle of each input (heel strike to heel strike; a clip without a full "
        "cycle is kept whole) (default: whole clips)",
    )
    p.add_argument(
        "--method", choices=choices(Method), default="lie", help="curves of the blend (default: lie)"
    )
    p.add_argument(
        "--contacts",
        type=contacts_flag,
        choices=choices(ContactPolicy),
        default="keep",
        help="the blend's foot contacts (as `blend --contacts`: keep plants them, report measures, off "
        "skips; auto is still accepted for keep; default: keep)",
    )
    p.add_argument(
        "--no-anchor",
        action="store_true",
        help="no pose anchoring of the blend (as `blend --no-anchor`; default: anchored)",
    )
    add_input_options(p)
    add_json_option(p)
    p.set_defaults(func=lambda a: run_guarded("blendspace", run, a))


def run(args: argparse.Namespace) -> int:
    """Write the motion at ``args.at``; exit code 0, or 2 for bad input."""
    # the app is imported here, not at the top: the command line starts without loading it
    from elastic_motion.apps.blend_options import BlendOptions
    from elastic_motion.apps.blendspace import blendspace
    from elastic_motion.apps.report import report_header
    from elastic_motion.cli_commands._running import emit_report, prepare_options, write_motion

    inputs = list(args.inputs)
    if len(inputs) < 3:
        raise CommandError(f"FILE: expected at least three input motions; got {len(inputs)}")
    out = check_output(args.output, inputs, suffixes=OUTPUT_MOTION_EXTENSIONS)
    if args.params == "speed":
        params: str | list[float] = "speed"
    else:
        try:
            params = [float(x) for x in args.params.split(",")]
        except ValueError:
            raise CommandError(
                f"--params: expected 'speed' or numbers like 1,2,3; got {args.params!r}"
            ) from None
    options = BlendOptions(
        method=args.method,
        prepare=prepare_options(args, len(inputs)),
        contacts=args.contacts,
        anchor=not args.no_anchor,
    )
    space = blendspace(inputs, params, options, one_cycle=args.one_cycle)
    res = space.at(args.at)
    write_motion(res.motion, res.prepared, out, inputs)
    texts = [str(n) for n in space.notes]
    notes = [*texts, *[str(n) for n in res.notes if str(n) not in texts]]
    report = report_header("blendspace", inputs, [str(out)], notes)
    report["blendspace"] = space.summary()
    report["at"] = args.at
    report.update(res.summary())
    m = res.motion
    lines = [
        f"wrote {out}: {m.n_frames} frames at {m.fps:g} fps ({m.duration:.2f} s), {m.n_joints} joints",
        f"{space.param_name} at {args.at:g}: "
        + ", ".join(
            f"{lab} ({fmt_float(x)}) {w:.3g}"
            for lab, x, w in zip(space.prepared.labels, space.params, res.weights, strict=True)
            if w > 0
        ),
    ]
    if res.cleanup is not None and res.cleanup.applied:
        c = res.cleanup
        lines.append(
            f"clean-up: skating while in contact {fmt_float(c.skating_before.mean_speed)} -> "
            f"{fmt_float(c.skating_after.mean_speed)} m/s"
        )
    lines += [f"note: {n}" for n in notes]
    emit_report(args, report, [*inputs, str(out)], "\n".join(lines))
    return 0
