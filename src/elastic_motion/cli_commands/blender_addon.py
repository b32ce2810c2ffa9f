"""``elastic-motion blender-addon -o elastic_motion_addon.zip``: pack the Blender add-on
(:mod:`elastic_motion.blender`)."""

from __future__ import annotations

import argparse
import shutil

from elastic_motion.blender import addon_files, pack_addon
from elastic_motion.cli_commands._common import check_output, run_guarded


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``blender-addon`` sub-command."""
    p = subparsers.add_parser(
        "blender-addon",
        help="write the Blender add-on (a zip to install in Blender) that runs this elastic-motion",
        description=(
            "Write the elastic-motion add-on for Blender (3.4 or later) as a zip: install it with Edit > "
            "Preferences > Add-ons > Install, enable it, and set 'elastic-motion command' in its "
            "preferences to the path printed here. Its panel (3D view sidebar, tab elastic-motion) blends, "
            "loops and compares the selected armatures' actions by running this command."
        ),
    )
    p.add_argument(
        "-o",
        "--output",
        default="elastic_motion_addon.zip",
        help="output .zip file (default: elastic_motion_addon.zip, in the current folder)",
    )
    p.set_defaults(func=lambda a: run_guarded("blender-addon", run, a))


def run(args: argparse.Namespace) -> int:
    out = check_output(args.output, [], suffixes=(".zip",))
    pack_addon(out)
    exe = shutil.which("elastic-motion") or "elastic-motion"
    print(f"wrote {out}: the Blender add-on ({len(addon_files())} files)")
    print(
        "install: Blender > Edit > Preferences > Add-ons > Install... > this zip, "
        "then enable 'elastic-motion'"
    )
    print(f"set its 'elastic-motion command' preference to: {exe}")
    return 0
