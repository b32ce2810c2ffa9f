"""``elastic-motion blender-addon -o elastic_motion_addon.zip``: pack the Blender add-on
(:mod:`elastic_motion.blender`)."""

from __future__ import annotations

import argparse
import os
import shutil
import sys

from elastic_motion.blender import addon_files, pack_addon
from elastic_motion.cli_commands._common import check_output, run_guarded

COMMAND = "elastic-motion"


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``blender-addon`` sub-command."""
    p = subparsers.add_parser(
        "blender-addon",
        help="write the Blender add-on (a zip to install in Blender) that runs this elastic-motion",
        description=(
            "Write the elastic-motion add-on for Blender (3.4 or later) as a zip: install it with Edit > "
            "Preferences > Add-ons > Install and enable it. Its 'elastic-motion command' preference "
            "defaults to the absolute path of this command (printed here), so Blender finds it even "
            "when this environment is not on its PATH. Its panel (3D view sidebar, tab elastic-motion) "
            "blends, loops and compares the selected armatures' actions by running this command."
        ),
    )
    p.add_argument(
        "-o",
        "--output",
        default="elastic_motion_addon.zip",
        help="output .zip file (default: elastic_motion_addon.zip, in the current folder)",
    )
    p.set_defaults(func=lambda a: run_guarded("blender-addon", run, a))


def _is_command(path: str) -> bool:
    name = os.path.basename(path).lower()
    stem = name[:-4] if name.endswith((".exe", ".cmd")) else name
    return stem == COMMAND and os.path.isfile(path) and os.access(path, os.X_OK)


def running_command(argv0: str | None = None, executable: str | None = None) -> str | None:
    """The absolute path of the ``elastic-motion`` command that runs now, or None.

    In order: ``argv0`` (default ``sys.argv[0]``: the console script as the system started
    it), the console script next to the interpreter ``executable`` (default
    ``sys.executable``: a venv's ``bin/``, also under ``python -m``), the one on PATH. Paths
    are made absolute but symbolic links are kept (a venv's ``bin/python`` is a link to
    the system's interpreter: resolving it would leave the venv).
    """
    argv0 = sys.argv[0] if argv0 is None else argv0
    executable = sys.executable if executable is None else executable
    candidates = [argv0]
    if executable:
        folder = os.path.dirname(executable)
        candidates += [os.path.join(folder, COMMAND), os.path.join(folder, COMMAND + ".exe")]
    candidates.append(shutil.which(COMMAND) or "")
    for c in candidates:
        if c and _is_command(c):
            return os.path.abspath(c)
    return None


def run(args: argparse.Namespace) -> int:
    out = check_output(args.output, [], suffixes=(".zip",))
    exe = running_command()
    pack_addon(out, command=exe)
    print(f"wrote {out}: the Blender add-on ({len(addon_files())} files)")
    print(
        "install: Blender > Edit > Preferences > Add-ons > Install... > this zip, "
        "then enable 'elastic-motion'"
    )
    if exe is None:
        print(
            f"its 'elastic-motion command' preference: set it to the path of {COMMAND} in the environment "
            f"where it is installed (`which {COMMAND}` there); this run could not find it"
        )
    else:
        print(f"its 'elastic-motion command' preference is set to: {exe}")
    return 0
