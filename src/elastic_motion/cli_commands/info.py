"""``elastic-motion info FILE [--json]``: joints, frames, fps, duration, units, channels.

``run`` imports the readers when the command runs (CLI start-up, as every command's app).
"""

from __future__ import annotations

import argparse
import json

from elastic_motion.cli_commands._common import add_up_units_options, positive_float


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``info`` sub-command to ``subparsers`` (sets ``func`` to :func:`run`)."""
    p = subparsers.add_parser(
        "info",
        help="describe a motion file (BVH, ASF/AMC, DeepMimic)",
        description=(
            "Print a motion file's joints, frame count, frame rate, duration, length unit, "
            "up axis and per-joint channel layout."
        ),
    )
    p.add_argument(
        "file",
        help="a .bvh, .amc (skeleton .asf found beside it), DeepMimic .txt/.json or glTF .gltf/.glb file",
    )
    p.add_argument("--json", action="store_true", help="print JSON instead of text")
    p.add_argument(
        "--asf", default=None, help="the .asf skeleton of an .amc file (default: found in its folder)"
    )
    p.add_argument(
        "--fps", type=positive_float, default=None, help="frame rate of an .amc file (default 120)"
    )
    add_up_units_options(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Read ``args.file`` and print its summary; return exit code 0.

    An unreadable file raises (:class:`~elastic_motion.errors.ParseError`, ``ValueError``,
    ``OSError``); ``cli.main`` prints ``elastic-motion info: error: FILE: ...`` and exits
    with 2 (3 for an environment failure such as permission denied).
    """
    from elastic_motion.motion import format_info, motion_info, read_motion

    kw = {}
    name = args.file.lower()
    if name.endswith(".amc"):
        if args.asf is not None:
            kw["asf"] = args.asf
        if args.fps is not None:
            kw["fps"] = args.fps
    elif name.endswith(".bvh"):
        if args.units is not None:
            kw["units"] = args.units
        if args.up is not None:
            kw["up_axis"] = args.up
    motion = read_motion(args.file, **kw)
    if args.up is not None and motion.up_axis != args.up:  # the other formats: a label
        motion = motion.replace(up_axis=args.up)
    info = motion_info(motion)
    if args.json:
        print(json.dumps(info, indent=2))
    else:
        print(format_info(info))
    return 0
