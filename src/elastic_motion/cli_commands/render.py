"""``elastic-motion render FILE... -o OUT``: videos and pictures (:mod:`elastic_motion.apps.render`)."""

from __future__ import annotations

import argparse

from elastic_motion.cli_commands._common import (
    CommandError,
    add_input_options,
    add_json_option,
    add_quiet_option,
    check_output,
    emit_report,
    load_inputs,
    progress_for,
    run_guarded,
)


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``render`` sub-command."""
    p = subparsers.add_parser(
        "render",
        help="skeleton animation side by side (.gif/.mp4), foot trajectories, warp, seam, SO(3) plots",
        description=(
            "Draw motions. .gif (Pillow) or .mp4 (needs imageio-ffmpeg: "
            "pip install 'elastic-motion[video]'): "
            "the skeletons side by side. .png/.svg/.pdf: foot trajectories as in the papers (default), or "
            "--kind warp (two files), seam (a loop; or the original and its loop), sphere (a joint's "
            "rotation curve on the sphere, paper 000 Fig. 2-3)."
        ),
    )
    p.add_argument("inputs", nargs="+", metavar="FILE", help="motion files")
    p.add_argument("-o", "--output", required=True, help="output .gif, .mp4, .png, .svg or .pdf")
    p.add_argument(
        "--kind",
        choices=("auto", "animation", "feet", "warp", "seam", "sphere"),
        default="auto",
        help="what to draw",
    )
    p.add_argument("--labels", default=None, help="comma-separated panel titles (default: file names)")
    p.add_argument(
        "--fps", type=float, default=None, help="video frame rate (default: the motions', at most 30)"
    )
    p.add_argument("--size", default="320x320", help="pixels per panel of a video, WxH (default 320x320)")
    p.add_argument("--seconds", type=float, default=None, help="video length (default: the longest motion)")
    p.add_argument("--joint", default=None, help="--kind sphere: the joint (default the root)")
    p.add_argument(
        "--frame", choices=("local", "global"), default="local", help="--kind sphere: rotation frame"
    )
    p.add_argument("--repeat", type=int, default=3, help="--kind seam: cycles to play (default 3)")
    p.add_argument(
        "--root", choices=("travel", "inplace"), default="travel", help="--kind seam: loop convention"
    )
    p.add_argument(
        "--method", choices=("lie", "euler-elastic"), default="lie", help="--kind warp: representation"
    )
    p.add_argument("--landmarks", default=None, help="--kind warp: 'auto' or pairs 'tA:tB,...' (seconds)")
    add_input_options(p)
    add_json_option(p)
    add_quiet_option(p)
    p.set_defaults(func=lambda a: run_guarded("render", run, a))


def run(args: argparse.Namespace) -> int:
    from elastic_motion.apps.render import render
    from elastic_motion.apps.report import report_header
    from elastic_motion.cli_commands._common import parse_landmarks

    inputs = list(args.inputs)
    out = check_output(args.output, inputs, suffixes=(".gif", ".mp4", ".png", ".svg", ".pdf"))
    try:
        w, h = (int(x) for x in args.size.lower().split("x"))
    except ValueError:
        raise CommandError(f"--size: expected WxH in pixels, e.g. 320x320; got {args.size!r}") from None
    motions, notes = load_inputs(
        inputs, trims=args.trim, keep_first_frame=args.keep_first_frame, units=args.units
    )
    labels = [x.strip() for x in args.labels.split(",")] if args.labels else [m.name for m in motions]
    if len(labels) != len(motions):
        raise CommandError(f"--labels: expected {len(motions)} labels; got {len(labels)}")
    kw = {
        "fps": args.fps,
        "panel_size": (w, h),
        "seconds": args.seconds,
        "joint": args.joint,
        "frame": args.frame,
        "repeat": args.repeat,
        "root": args.root,
        "method": args.method,
    }
    if args.kind == "warp" and args.landmarks:
        kw["landmarks"] = parse_landmarks(args.landmarks, "seconds", motions[0].fps, motions[-1].fps)
    bar = progress_for("render", args)
    try:
        render(motions, out, kind=args.kind, labels=labels, protected=inputs, progress=bar, **kw)
    finally:
        bar.close()
    report = report_header("render", inputs, [str(out)], notes)
    report.update({"kind": args.kind, "labels": labels})
    emit_report(args, report, inputs, f"wrote {out}" + "".join(f"\nnote: {n}" for n in notes))
    return 0
