"""``elastic-motion blendspace A B C ... --at P -o OUT.bvh``: a blend space of N >= 3 motions
placed by a parameter (:mod:`elastic_motion.apps.blendspace`), or by two
(``--params speed,turn --at S,T``: :mod:`elastic_motion.apps.blendspace2d`).

``run`` imports the app when the command runs (CLI start-up: building the parser loads no numpy).
"""

from __future__ import annotations

import argparse
from typing import Any

from elastic_motion._options import choices
from elastic_motion.cli_commands._common import (
    CommandError,
    add_input_options,
    add_json_option,
    check_output,
    fmt_float,
    run_guarded,
)
from elastic_motion.cli_commands.blend import add_contacts_option
from elastic_motion.vocabulary import OUTPUT_MOTION_EXTENSIONS, Method


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``blendspace`` sub-command."""
    p = subparsers.add_parser(
        "blendspace",
        help="a blend space: motions placed by one or two parameters (e.g. speed x turning rate), one "
        "motion at any point",
        description=(
            "Place N >= 3 motions of one skeleton by a parameter (their root speed, or given numbers), "
            "align them all to a common template once (their Karcher mean), and write the motion at "
            "parameter --at: the blend of the two neighbouring motions, with the template's warps. With "
            "two parameters (--params speed,turn, or points x:y), the motions are placed on a plane and "
            "triangulated (Delaunay); the motion at --at X,Y blends the triangle containing the point "
            "with its barycentric weights, corrected until the blend's measured parameters meet the "
            "point (within 1 %% of each parameter's range, at most 4 corrections); a point outside the "
            "motions' convex hull is refused."
        ),
    )
    p.add_argument("inputs", nargs="+", metavar="FILE", help="three or more motion files of one skeleton")
    p.add_argument(
        "-o", "--output", required=True, help="output .bvh, .gltf or .glb file (never one of the inputs)"
    )
    p.add_argument(
        "--params",
        default="speed",
        help="'speed' (mean horizontal root speed, m/s) or one number per input, comma-separated; two "
        "parameters: 'speed,turn' (turn: the root's turning rate about the up axis, deg/s, positive to "
        "the left; either order) or one point x:y per input, comma-separated (default: speed)",
    )
    p.add_argument(
        "--at",
        required=True,
        help="the parameter of the motion to write (within the inputs' range); with two parameters the "
        "point X,Y (inside the convex hull of the inputs' points)",
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
    add_contacts_option(
        p,
        "the blend's foot contacts (as `blend --contacts`: keep plants them, report measures, off "
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
    from elastic_motion.apps.blendspace2d import blendspace_2d
    from elastic_motion.apps.report import report_header
    from elastic_motion.cli_commands._running import emit_report, prepare_options, write_motion

    inputs = list(args.inputs)
    if len(inputs) < 3:
        raise CommandError(f"FILE: expected at least three input motions; got {len(inputs)}")
    out = check_output(args.output, inputs, suffixes=OUTPUT_MOTION_EXTENSIONS)
    params = parse_params(args.params)
    at = _numbers(args.at, "--at", "a number like 1.5, or X,Y like 1.5,10 with two parameters")
    two = isinstance(params, tuple) or (isinstance(params, list) and isinstance(params[0], list))
    if len(at) != (2 if two else 1):
        raise CommandError(
            f"--at: expected {'two numbers X,Y (two parameters)' if two else 'one number'} as --params "
            f"{args.params!r} places the motions; got {args.at!r}"
        )
    options = BlendOptions(
        method=args.method,
        prepare=prepare_options(args, len(inputs)),
        contacts=args.contacts,
        anchor=not args.no_anchor,
    )
    if two:
        space: Any = blendspace_2d(inputs, params, options, one_cycle=args.one_cycle)
        res = space.at(at)
        names, points = space.param_names, [f"({fmt_float(x)}, {fmt_float(y)})" for x, y in space.params]
    else:
        space = blendspace(inputs, params, options, one_cycle=args.one_cycle)
        res = space.at(at[0])
        names, points = (space.param_name,), [fmt_float(x) for x in space.params]
    write_motion(res.motion, res.prepared, out, inputs)
    texts = [str(n) for n in space.notes]
    notes = [*texts, *[str(n) for n in res.notes if str(n) not in texts]]
    report = report_header("blendspace", inputs, [str(out)], notes)
    report["blendspace"] = space.summary()
    report["at"] = at if two else at[0]
    report.update(res.summary())
    m = res.motion
    lines = [
        f"wrote {out}: {m.n_frames} frames at {m.fps:g} fps ({m.duration:.2f} s), {m.n_joints} joints",
        f"{' x '.join(names)} at {args.at}: "
        + ", ".join(
            f"{lab} {x} {w:.3g}"
            for lab, x, w in zip(space.prepared.labels, points, res.weights, strict=True)
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


def _numbers(text: str, flag: str, what: str) -> list[float]:
    try:
        return [float(x) for x in text.split(",")]
    except ValueError:
        raise CommandError(f"{flag}: expected {what}; got {text!r}") from None


def parse_params(text: str) -> str | tuple[str, str] | list[float] | list[list[float]]:
    """``--params``: ``"speed"``, two names (``"speed,turn"``), numbers ``"1,2,3"`` or points
    ``"1:0,2:10,3:-5"``."""
    items = [x.strip() for x in text.split(",")]
    if items == ["speed"]:
        return "speed"
    if len(items) == 2 and all(x.isalpha() for x in items):
        return (items[0], items[1])
    if any(":" in x for x in items):
        pts = [x.split(":") for x in items]
        if all(len(p) == 2 for p in pts):
            try:
                return [[float(a), float(b)] for a, b in pts]
            except ValueError:
                pass
        raise CommandError(f"--params: expected points x:y, one per input, like 1:0,2:10,3:-5; got {text!r}")
    return _numbers(
        text, "--params", "'speed', 'speed,turn', numbers like 1,2,3 or points like 1:0,2:10,3:-5"
    )
