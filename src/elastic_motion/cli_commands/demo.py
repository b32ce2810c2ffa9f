"""``elastic-motion demo``: the demo pipeline (:mod:`elastic_motion.apps.demo`).

``run`` imports the demo app when the command runs (CLI start-up: it loads blend, loop and
the pictures, which the other commands do not need).
"""

from __future__ import annotations

import argparse
import sys

from elastic_motion.cli_commands._common import add_quiet_option, fail, progress_for


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``demo`` sub-command."""
    p = subparsers.add_parser(
        "demo",
        help="blends, loops, distances, figures and videos from the DeepMimic clips of pybullet",
        description=(
            "Run the whole pipeline on the DeepMimic motion clips shipped with the PyPI package pybullet "
            '(pip install "elastic-motion[demo]") and write a folder with BVH files, figures, videos and an '
            "index.html showing them side by side."
        ),
    )
    p.add_argument(
        "-o",
        "--output",
        default="elastic-motion-demo",
        help="output folder, created if needed (default: elastic-motion-demo, in the current folder)",
    )
    p.add_argument(
        "--data",
        default=None,
        help="folder with the DeepMimic clips (default: the data folder of the installed pybullet)",
    )
    p.add_argument(
        "--no-video",
        action="store_true",
        help="skip the animations, the slowest part (default: off, the GIF animations are written)",
    )
    p.add_argument(
        "--no-mp4",
        action="store_true",
        help="write GIFs only, even when imageio-ffmpeg is installed (default: off, MP4s are written "
        "beside the GIFs when imageio-ffmpeg is installed)",
    )
    p.add_argument(
        "--force",
        action="store_true",
        help="write into a non-empty folder not made by the demo (default: off, such a folder is refused)",
    )
    add_quiet_option(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from elastic_motion.apps.demo import DemoDataError, run_demo

    bar = progress_for("demo", args)
    try:
        res = run_demo(
            args.output,
            data_dir=args.data,
            video=not args.no_video,
            mp4=False if args.no_mp4 else None,
            force=args.force,
            progress=bar,
        )
    except DemoDataError as exc:
        bar.close()
        return fail("demo", str(exc))
    except ValueError as exc:
        bar.close()
        return fail("demo", str(exc))
    bar.close()
    print(f"demo written in {res.seconds:.0f} s: {len(res.files)} files in {res.out_dir}")
    print(f"open {res.index.resolve()}")
    sys.stdout.flush()
    return 0
