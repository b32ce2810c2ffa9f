"""What the database sub-commands do when they run, shared by them: the parsed flags made into
the representations and the :class:`~elastic_motion.apps.database.DatabaseSettings` of the
apps, and the report written.

This module imports the apps (numpy, numba): a command imports it inside its ``run``, with its
app, so that building the parser does not load them. The flags themselves are declared in
:mod:`._database_options`.
"""

from __future__ import annotations

import argparse
import dataclasses

from elastic_motion.apps.database.settings import DEFAULT_WARP, DatabaseSettings
from elastic_motion.apps.report import report_header
from elastic_motion.cli_commands._common import CommandError
from elastic_motion.cli_commands._database_options import LINKAGES, METHODS, joints_option
from elastic_motion.cli_commands._running import emit_report
from elastic_motion.errors import OptionError
from elastic_motion.motion.representations import Representation, representation

__all__ = ["database_settings", "emit", "given_fields", "methods"]


def methods(value: str, *, several: bool) -> tuple[Representation, ...]:
    """The representations of ``--method``'s value (names, comma-separated with ``several``)."""
    got = tuple(v.strip() for v in value.split(",") if v.strip()) if several else (value,)
    try:
        reps = tuple(representation(m) for m in got)
    except OptionError:
        reps = ()
    if not got or len(reps) != len(got) or len(set(reps)) != len(reps):
        if not several and value in LINKAGES:
            raise CommandError(
                f"--method: expected a curve representation, one of {', '.join(METHODS)}; got {value!r}, a "
                f"linkage (use --linkage {value})"
            )
        what = "distinct entries of" if several else "one of"
        raise CommandError(f"--method: expected {what} {', '.join(METHODS)}; got {value!r}")
    return reps


def _given(args: argparse.Namespace) -> tuple[dict, dict]:
    """The :class:`DatabaseSettings` fields and the warp's fields that the parsed flags set
    (None: not given)."""
    fields: dict = {}
    if getattr(args, "samples", None) is not None:
        fields["n_samples"] = args.samples
    if getattr(args, "joints", None) is not None:
        fields["joints"] = joints_option(args.joints)
    if getattr(args, "keep_fingers", None) is not None:
        fields["drop_fingers"] = not args.keep_fingers
    if getattr(args, "no_align", None) is not None:
        fields["align_heading"] = not args.no_align
    if getattr(args, "pose_weight", None) is not None:
        fields["pose_weight"] = args.pose_weight  # "balanced" or a number: DatabaseSettings checks it
    if getattr(args, "cyclic", None) is not None:
        fields["cyclic"] = bool(args.cyclic)
    for name in ("up", "units"):  # how the files are read (None: detected, guessed)
        if getattr(args, name, None) is not None:
            fields[name] = getattr(args, name)
    warp = {
        f: getattr(args, f)
        for f in ("warp", "neighbourhood", "coarse_to_fine", "sample_smoothing")
        if getattr(args, f, None) is not None
    }
    if "warp" in warp:
        warp["method"] = warp.pop("warp")
    return fields, warp


def given_fields(args: argparse.Namespace) -> tuple[str, ...]:
    """The flat settings fields (``n_samples``, ``warp.method``, ...; as in
    :data:`~elastic_motion.apps.database.settings.QUERY_FIELDS`) the parsed flags set."""
    fields, warp = _given(args)
    return (*fields, *(f"warp.{f}" for f in warp))


def database_settings(args: argparse.Namespace, reps: tuple[Representation, ...]) -> DatabaseSettings:
    """The :class:`~elastic_motion.apps.database.DatabaseSettings` of the parsed flags: those
    given, the defaults for the others."""
    fields, warp = _given(args)
    return DatabaseSettings(
        representations=reps,
        warp=dataclasses.replace(DEFAULT_WARP, **warp),
        tile_size=getattr(args, "tile_size", 32),
        **fields,
    )


def emit(args: argparse.Namespace, command: str, body: dict, inputs, outputs, lines: list[str]) -> None:
    """The shared report: header (command, version, time, inputs, outputs) + ``body``."""
    report = {**report_header(command, inputs=inputs, outputs=outputs), **body}
    emit_report(args, report, [str(p) for p in inputs], "\n".join(lines))
