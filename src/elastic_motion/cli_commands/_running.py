"""What a command does when it runs, shared by the command modules: the parsed arguments made
into the apps' options (:class:`~elastic_motion.apps.prepare.PrepareOptions`,
:class:`~elastic_motion.warp.WarpOptions`, :class:`~elastic_motion.motion.contacts.ContactOptions`),
the inputs read and prepared, the landmarks read, the result and the report written.

This module imports the apps (numpy, numba): a command module imports it inside its ``run``,
with its app, so that building the parser (:func:`elastic_motion.cli.build_parser`, every
``--help``) does not load them. The options themselves are declared in :mod:`._common`.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from collections.abc import Sequence
from typing import Any

from elastic_motion.apps.landmark_files import LandmarkFile, parse_landmarks
from elastic_motion.apps.prepare import PrepareOptions, output_motion, output_notes, prepare_motions
from elastic_motion.apps.report import report_json, write_report
from elastic_motion.cli_commands._common import CommandError, check_output, joints_arg
from elastic_motion.cli_commands._errors import option_message
from elastic_motion.cli_commands._paths import protected_inputs
from elastic_motion.errors import OptionError
from elastic_motion.motion import write_motion as write_motion_file
from elastic_motion.motion.contacts import ContactOptions
from elastic_motion.warp import WarpOptions

__all__ = [
    "contact_options",
    "emit_report",
    "prepare_inputs",
    "prepare_options",
    "read_landmarks",
    "warp_options",
    "write_motion",
]


def prepare_options(args: argparse.Namespace, n_inputs: int) -> Any:
    """The :class:`~elastic_motion.apps.prepare.PrepareOptions` of the parsed options."""

    trims: tuple = ()
    raw = getattr(args, "trim", None)
    if raw is not None:
        if len(raw) not in (1, n_inputs):
            raise CommandError(
                f"--trim: expected one range per input ({n_inputs}) or one for all; got {len(raw)}"
            )
        trims = tuple(_parse_range(r) for r in raw)
    joints = getattr(args, "joints", "all")
    return PrepareOptions(
        drop_tpose=not getattr(args, "keep_first_frame", False),
        units=getattr(args, "units", None),
        up=getattr(args, "up", None),
        trim=trims,
        joints=joints_arg(joints) if isinstance(joints, str) else joints,
        align=not getattr(args, "no_align", False),
        units_out=getattr(args, "units_out", None),
    )


def warp_options(args: argparse.Namespace, landmark_weight: float | None = None) -> Any:
    """The :class:`~elastic_motion.warp.WarpOptions` of the parsed options.

    The relative landmark weight is ``--landmark-weight`` when given, else ``landmark_weight``
    (the one a landmarks file records: :func:`read_landmarks`), else ``WarpOptions``' default.
    """

    lw = getattr(args, "landmark_weight", None)
    lw = landmark_weight if lw is None else lw
    return WarpOptions(
        method=args.warp,
        neighbourhood=args.neighbourhood,
        sample_fps=args.sample_fps,
        sample_smoothing=getattr(args, "sample_smoothing", WarpOptions().sample_smoothing),
        landmark_weight=WarpOptions().landmark_weight if lw is None else lw,
    )


def prepare_inputs(args: argparse.Namespace, paths: Sequence[str]) -> Any:
    """Read and prepare the input files: the same step the Python API runs."""

    return prepare_motions(list(paths), prepare_options(args, len(paths)))


def write_motion(motion: Any, prepared: Any, path: str | os.PathLike[str], inputs: Sequence[str]) -> tuple:
    """Write a result in the output unit (:func:`elastic_motion.apps.prepare.output_motion`) as
    ``.bvh``, ``.gltf`` or ``.glb`` (:func:`elastic_motion.motion.write_motion`: glTF is always
    metres); the notes of the writing (:func:`elastic_motion.apps.prepare.output_notes`)."""

    out = output_motion(motion, prepared.units_out)
    write_motion_file(out, path, protected=list(inputs))
    return output_notes(out, path, prepared.units_out)


def _parse_range(text: str) -> tuple[float | None, float | None] | None:
    if text.strip() == ":":
        return None
    if ":" not in text:
        raise CommandError(f"--trim: expected START:STOP in seconds; got {text!r}")
    a, b = text.split(":", 1)
    try:
        start = float(a) if a.strip() else None
        stop = float(b) if b.strip() else None
    except ValueError:
        raise CommandError(f"--trim: expected numbers in START:STOP (seconds); got {text!r}") from None
    return start, stop


def read_landmarks(
    value: str | None, unit: str, fps_a: float, fps_b: float, inputs: Sequence[str] | None = None
) -> tuple[Any, float | None]:
    """``--landmarks`` -> (``None``, ``"auto"`` or a list of ``(tA, tB)`` in seconds; the
    relative landmark weight the file records, or None).

    Accepted: ``auto``, ``none``, a file, or inline pairs ``"a0:b0,a1:b1"``. Times are in
    ``unit`` (``seconds`` or ``frames``) unless suffixed with ``s`` or ``f``; frames count
    from the first frame kept (after ``--trim``), at each file's own frame rate
    (:func:`elastic_motion.apps.landmark_files.parse_landmarks`, the one reading of this text).

    Files: JSON ``{"units": "seconds"|"frames", "pairs": [[a, b], ...]}`` or the report of
    ``elastic-motion landmarks A B --json`` (its ``pairs_s``, and its ``landmark_weight``: the
    weight ``--landmarks auto`` meets the pairs with, so that the file gives the same warp;
    refused when ``inputs`` are given and its own inputs are other files or the same ones
    swapped); or text, one pair per line (``a b``, ``a,b`` or ``a:b``; ``#`` starts a comment).
    """

    try:
        got = parse_landmarks(value, units=unit, fps=(fps_a, fps_b), inputs=inputs)
    except OptionError as exc:
        raise CommandError(option_message(exc)) from None
    if isinstance(got, LandmarkFile):
        return list(got.pairs), got.landmark_weight
    return got, None


def contact_options(args: argparse.Namespace) -> Any:
    """``--contact-height`` -> ContactOptions (None when not given)."""

    h = getattr(args, "contact_height", None)
    if h is None:
        return None
    if not (math.isfinite(h) and 0 < h <= ContactOptions().max_ground_offset):
        raise CommandError(
            f"--contact-height: expected a height in metres in (0, {ContactOptions().max_ground_offset:g}]; "
            f"got {h!r}"
        )
    return ContactOptions(height_enter=h, height_exit=2.0 * h)


def emit_report(
    args: argparse.Namespace, report: dict[str, Any], inputs: Sequence[str], summary: str
) -> None:
    """Print the human summary (or the JSON on stdout) and write ``--json PATH``.

    ``PATH`` goes through the safety net (:func:`check_output`) against ``inputs`` -- pass
    the command's inputs *and* the outputs it wrote -- and the ``.asf`` files beside them.
    """

    target = getattr(args, "json", None)
    if target == "-":
        sys.stdout.write(report_json(report))
        return
    if summary:
        print(summary)
    if target:
        check_output(target, inputs, what="--json")
        write_report(target, report, protected=protected_inputs(inputs))
        print(f"report: {target}")
