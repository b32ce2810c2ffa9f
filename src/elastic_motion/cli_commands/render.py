"""``elastic-motion render FILE... -o OUT``: videos and pictures
(:func:`elastic_motion.apps.render_files.render_motions`).

The choices of ``--kind``, ``--frame``, ``--root`` and ``--method`` are the API's types
(:data:`elastic_motion.vocabulary.RenderKind`, ...). ``run`` imports the drawing app when the
command runs (CLI start-up: building the parser, and the other commands, never load it).
"""

from __future__ import annotations

import argparse
import math
from typing import Any

from elastic_motion import limits
from elastic_motion.cli_commands._common import (
    CommandError,
    add_input_options,
    add_json_option,
    add_quiet_option,
    check_output,
    joints_arg,
    progress_for,
)
from elastic_motion.vocabulary import METHODS, RENDER_KINDS, ROOT_MODES, ROTATION_FRAMES

#: The options that only some kinds use: option -> (``args`` attribute, kinds).
_KIND_OPTIONS = {
    "--fps": ("fps", ("animation",)),
    "--size": ("size", ("animation",)),
    "--seconds": ("seconds", ("animation",)),
    "--trail": ("trail", ("animation",)),
    "--joint": ("joint", ("sphere",)),
    "--frame": ("frame", ("sphere",)),
    "--repeat": ("repeat", ("seam",)),
    "--root": ("root", ("seam",)),
    "--joints": ("render_joints", ("seam", "warp")),
    "--method": ("method", ("warp",)),
    "--landmarks": ("landmarks", ("warp",)),
}


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``render`` sub-command."""
    p = _parser(subparsers)
    p.add_argument("inputs", nargs="+", metavar="FILE", help="motion files")
    p.add_argument(
        "-o",
        "--output",
        required=True,
        help="output file: .gif or .mp4 (a video), .png, .svg or .pdf (required; no default)",
    )
    p.add_argument(
        "--kind",
        choices=RENDER_KINDS,
        default="auto",
        help="what to draw; auto: an animation for .gif/.mp4, the foot trajectories for a still "
        "(default: auto)",
    )
    p.add_argument(
        "--labels", default=None, help="comma-separated panel titles, one per file (default: the file names)"
    )
    _add_animation_options(p)
    _add_picture_options(p)
    add_input_options(p, writes_bvh=False)
    add_json_option(p)
    add_quiet_option(p)
    p.set_defaults(func=run)


def _parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    return subparsers.add_parser(
        "render",
        help="skeleton animation side by side (.gif/.mp4), foot trajectories, warp, seam, SO(3) plots",
        description=(
            "Draw motions. .gif (Pillow) or .mp4 (needs imageio-ffmpeg: "
            "pip install 'elastic-motion[video]'): "
            "the skeletons side by side, playing in real time. .png/.svg/.pdf: foot trajectories as in the "
            "papers (default), or --kind warp (two files), seam (a loop; or the original and its loop), "
            "sphere (a joint's rotation curve on the sphere, paper 000 Fig. 2-3). Lengths are drawn in "
            "metres. Options marked '--kind K' apply to that kind only."
        ),
    )


def _add_animation_options(p: argparse.ArgumentParser) -> None:
    """``--fps``, ``--size``, ``--seconds``, ``--trail``: the animation's options
    (:class:`~elastic_motion.apps.render.AnimationOptions`)."""
    p.add_argument(
        "--fps",
        type=float,
        default=None,
        help="video frame rate in frames per second (fps); a GIF shows at most 50 fps "
        "(default: the inputs' highest frame rate, at most 30 fps)",
    )
    p.add_argument(
        "--size",
        default=None,
        metavar="WxH",
        help="size of each video panel in pixels, width x height (default: 320x320 pixels)",
    )
    p.add_argument(
        "--seconds",
        type=float,
        default=None,
        help="video length in seconds (default: the duration of the longest input)",
    )
    p.add_argument(
        "--trail",
        type=float,
        default=None,
        metavar="SECONDS",
        help="length of the feet's trails in a video, seconds (default: 1.0 seconds)",
    )


def _add_picture_options(p: argparse.ArgumentParser) -> None:
    """The options of the sphere, seam and warp pictures."""
    p.add_argument(
        "--joint", default=None, help="--kind sphere: the joint whose rotation is drawn (default: the root)"
    )
    p.add_argument(
        "--frame",
        choices=ROTATION_FRAMES,
        default=None,
        help="--kind sphere: the joint's rotation relative to its parent (local) or to the world "
        "(global) (default: local)",
    )
    p.add_argument(
        "--repeat", type=int, default=None, help="--kind seam: cycles to play, at least 2 (default: 3)"
    )
    p.add_argument(
        "--root",
        choices=ROOT_MODES,
        default=None,
        help="--kind seam: loop convention; travel: each cycle starts where the last one ended, "
        "inplace: every cycle starts at the same place (default: travel)",
    )
    p.add_argument(
        "--joints",
        dest="render_joints",
        metavar="NAMES",
        default=None,
        help="--kind seam: comma-separated joints whose paths are drawn (default: the right ankle and "
        "the left hand); --kind warp: the joints compared, 'all', 'common' or comma-separated names "
        "(default: all)",
    )
    p.add_argument(
        "--method",
        choices=METHODS,
        default=None,
        help="--kind warp: representation of the motions (default: lie)",
    )
    p.add_argument(
        "--landmarks",
        default=None,
        help="--kind warp: 'auto' or pairs 'tA:tB,...' of times in seconds (default: none)",
    )


def _size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(x) for x in text.lower().split("x"))
    except ValueError:
        raise CommandError(f"--size: expected WxH in pixels, e.g. 320x320; got {text!r}") from None
    if w < 16 or h < 16:
        raise CommandError(f"--size: expected at least 16x16 pixels; got {text!r}")
    limits.check_option("size", "a width and height (pixels) of", max(w, h), "max_render_size")
    return w, h


def _check_limits(args: argparse.Namespace) -> None:
    """The render options against :mod:`elastic_motion.limits`, before any motion is read."""
    if args.fps is not None:
        if not math.isfinite(args.fps):
            raise CommandError(f"--fps: expected a finite frame rate; got {args.fps!r}")
        limits.check_option("fps", "a video frame rate (fps) of", args.fps, "min_render_fps", at_least=True)
        limits.check_option("fps", "a video frame rate (fps) of", args.fps, "max_render_fps")
    for attr in ("seconds", "trail"):
        v = getattr(args, attr)
        if v is not None and not (math.isfinite(v) and v >= 0):
            raise CommandError(f"--{attr}: expected a non-negative finite number of seconds; got {v!r}")
    if args.seconds is not None:
        fps = args.fps if args.fps is not None else 30.0
        limits.check_option(
            "seconds", "a video of frames (--seconds x --fps)", args.seconds * fps, "max_render_frames"
        )
    if args.repeat is not None:
        limits.check_option("repeat", "a repeat count of", args.repeat, "max_repeat")
    if args.size is not None:
        _size(args.size)


def run(args: argparse.Namespace) -> int:
    from elastic_motion.apps.render import render_kind  # CLI start-up: loaded to run only
    from elastic_motion.apps.render_files import render_motions
    from elastic_motion.apps.report import report_header
    from elastic_motion.cli_commands._running import emit_report, prepare_options

    inputs = list(args.inputs)
    _check_limits(args)
    out = check_output(args.output, inputs, suffixes=(".gif", ".mp4", ".png", ".svg", ".pdf"))
    kind = render_kind(args.kind, out)
    for option, (attr, kinds) in _KIND_OPTIONS.items():
        if getattr(args, attr) is not None and kind not in kinds:
            raise CommandError(
                f"{option}: only used with --kind {' or '.join(kinds)}; this draws {kind!r} "
                f"(--kind {args.kind}, output {out.name})"
            )
    labels = [x.strip() for x in args.labels.split(",")] if args.labels else None
    if labels is not None and len(labels) != len(inputs):
        raise CommandError(f"--labels: expected {len(inputs)} labels; got {len(labels)}")
    bar = progress_for("render", args)
    try:
        res = render_motions(
            inputs,
            out,
            kind=kind,
            labels=labels,
            prepare=prepare_options(args, len(inputs)),
            protected=inputs,
            progress=bar,
            **_picture_keywords(args, kind),
        )
    finally:
        bar.close()
    report = report_header("render", inputs, [str(out)], res.notes)
    report.update(res.summary())
    emit_report(args, report, inputs, f"wrote {out}" + "".join(f"\nnote: {n}" for n in res.notes))
    return 0


#: The options of each kind: option attribute -> the picture's keyword.
_KIND_KEYWORDS = {
    "animation": {"fps": "fps", "seconds": "seconds", "trail": "trail"},
    "sphere": {"joint": "joint", "frame": "frame"},
    "seam": {"repeat": "repeat", "root": "root"},
    "warp": {"method": "method"},
}


def _picture_keywords(args: argparse.Namespace, kind: str) -> dict[str, Any]:
    """The keywords of the picture ``kind`` from the options given (``render``'s ``**kw``)."""
    kw = {key: getattr(args, attr) for attr, key in _KIND_KEYWORDS.get(kind, {}).items()}
    kw = {k: v for k, v in kw.items() if v is not None}
    if kind == "animation" and args.size is not None:
        kw["panel_size"] = _size(args.size)
    if kind == "seam" and args.render_joints is not None:
        names = [x.strip() for x in args.render_joints.split(",") if x.strip()]
        if not names:
            raise CommandError(f"--joints: expected comma-separated joint names; got {args.render_joints!r}")
        kw["joints"] = names
    if kind == "warp":
        if args.render_joints is not None:
            kw["joints"] = joints_arg(args.render_joints)
        if args.landmarks:  # text: read by the app with the clips' frame rates
            kw["landmarks"] = args.landmarks
    return kw
