"""The Blender add-on (``elastic_motion_addon``) and its packing into an installable zip.

The add-on's code lives in the sub-package :mod:`elastic_motion.blender.elastic_motion_addon`;
it runs inside Blender's own Python (standard library and ``bpy`` only) and is never
imported by elastic-motion itself. :func:`pack_addon` writes the zip that Blender's
Edit > Preferences > Add-ons > Install takes (``elastic-motion blender-addon -o FILE.zip``).
"""

from __future__ import annotations

import io
import json
import os
import zipfile
from pathlib import Path

from elastic_motion._io import atomic_write_bytes

__all__ = ["ADDON_NAME", "COMMAND_FILE", "addon_files", "pack_addon"]

#: The add-on's module name inside Blender (the folder in the zip).
ADDON_NAME = "elastic_motion_addon"


def addon_files() -> list[Path]:
    """The add-on's source files (``.py``), sorted."""
    folder = Path(__file__).with_name(ADDON_NAME)
    return sorted(p for p in folder.glob("*.py") if p.is_file())


#: The file in the zip that records the command the add-on runs by default (read by
#: ``ops._default_executable``).
COMMAND_FILE = "command.json"


def pack_addon(path: str | os.PathLike[str], *, protected=(), command: str | None = None) -> Path:
    """Write the add-on zip (``elastic_motion_addon/*.py``) to ``path`` atomically.

    Parameters
    ----------
    path : path
        Destination ``.zip``; its folder must exist.
    protected : iterable of paths
        Files never to overwrite.
    command : str, optional
        The ``elastic-motion`` command the add-on runs by default (its preference's default),
        recorded as ``elastic_motion_addon/command.json``; without it the add-on looks for
        ``elastic-motion`` on Blender's PATH.

    Returns
    -------
    pathlib.Path
    """
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", compression=zipfile.ZIP_DEFLATED) as zf:
        for f in addon_files():
            info = zipfile.ZipInfo(f"{ADDON_NAME}/{f.name}", date_time=(2024, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = 0o644 << 16
            zf.writestr(info, f.read_bytes())
        if command is not None:
            info = zipfile.ZipInfo(f"{ADDON_NAME}/{COMMAND_FILE}", date_time=(2024, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = 0o644 << 16
            zf.writestr(info, json.dumps({"command": command}, indent=1) + "\n")
    return atomic_write_bytes(path, buf.getvalue(), protected=protected)
