"""Options and helpers shared by the database sub-commands (``matrix``, ``search``,
``classify``, ``mean``, ``cluster``, ``index``, ``pca``): the preparation and warp options,
``--method``, the settings they make, the error line and the report.
"""

from __future__ import annotations

import argparse

from elastic_motion.cli_commands._argparse import EXIT_BAD_INPUT, add_alias, handle_error, print_error
from elastic_motion.cli_commands._common import CommandError, add_warp_options, emit_report, joints_arg
from elastic_motion.errors import OptionError, ParseError

#: Curve representations (``--method``) of the database commands (``euler`` is accepted for
#: ``euler-elastic``, the name of the other commands).
METHODS = ("lie", "euler-elastic")
METHOD_KEYS = {"lie": "lie", "euler-elastic": "euler", "euler": "euler"}
#: Linkages of ``cluster --linkage``.
LINKAGES = ("average", "complete", "single", "weighted")
#: Removed in this release (shown in the deprecation notes of the old spellings).
ALIAS_UNTIL = "0.3"

#: Python argument names (``OptionError.option``) -> the flag that sets them; ``None``: the
#: message already starts with the file it concerns.
FLAGS: dict[str, str | None] = {
    "representation": "--method",
    "representations": "--method",
    "n_samples": "--samples",
    "joints": "--joints",
    "warp": "--warp",
    "neighbourhood": "--neighbourhood",
    "tile_size": "--tile-size",
    "out_dir": "--output",
    "k": "-k",
    "n_clusters": "--clusters",
    "method": "--method",
    "linkage": "--linkage",
    "labels": "--labels",
    "scheduler": "--scheduler",
    "engine": "--engine",
    "inputs": "inputs",
    "pose_weight": "--pose-weight",
    "cyclic": "--cyclic",
}


def alias(p: argparse.ArgumentParser, old: str, new: str) -> None:
    add_alias(p, old, new, until=ALIAS_UNTIL)


def add_preparation(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--samples",
        type=int,
        default=64,
        help="cells of the common time grid: each motion is resampled to SAMPLES + 1 frames uniformly "
        "over its duration (default: 64)",
    )
    p.add_argument(
        "--joints",
        default="all",
        help="'all' (every joint: matrix groups motions by skeleton, mean needs one skeleton), 'common' "
        "(the joints all motions share), 'map' (every skeleton on a 13-joint common body through joint-name "
        "maps: CMU BVH/ASF, Bandai, DeepMimic) or a comma-separated list of joint names (default: all)",
    )
    p.add_argument("--keep-fingers", action="store_true", help="keep finger/thumb joints (default: dropped)")
    p.add_argument(
        "--no-align",
        action="store_true",
        help="do not remove the heading and floor position of the root at frame 0 (default: removed)",
    )
    alias(p, "--no-align-heading", "--no-align")


def joints_option(value: str) -> str | tuple[str, ...]:
    return joints_arg(value, ("all", "common", "map"))


def add_warp(p: argparse.ArgumentParser) -> None:
    from elastic_motion.apps.database.settings import DEFAULT_WARP

    # the database's defaults: DP only (refinement costs about 17x a DP pair at 64 samples)
    add_warp_options(p, defaults=DEFAULT_WARP, sampling=False, coarse_to_fine=True)


def add_distance_terms(p: argparse.ArgumentParser) -> None:
    """``--pose-weight`` and ``--cyclic`` (``DatabaseSettings.pose_weight`` / ``cyclic``)."""
    p.add_argument(
        "--pose-weight",
        default=None,
        metavar="{balanced,W}",
        help="weight of a pose term beside the SRV (the joints' rotations, which the SRV does not see): "
        "'balanced' (as much mean squared pair distance as the SRV term over the database; no labels) or a "
        "number >= 0; 0: the SRV alone (default: 0)",
    )
    p.add_argument(
        "--cyclic",
        action="store_true",
        default=None,  # None: not given (a stored database's own setting is then no surprise)
        help="phase-free matching: the least distance over the cyclic shifts of either motion's cells "
        "(windows of periodic motions started at different phases; 2 x SAMPLES times the cost; needs --warp "
        "dp) (default: off)",
    )


def pose_weight_option(value: str | None) -> float | str:
    """``--pose-weight``: ``"balanced"`` or a number (validated by ``DatabaseSettings``); not
    given (None): 0."""
    if value is None:
        return 0.0
    if value == "balanced":
        return value
    try:
        return float(value)
    except ValueError:
        raise CommandError(f"--pose-weight: expected 'balanced' or a number >= 0; got {value!r}") from None


def add_method(p: argparse.ArgumentParser, *, several: bool) -> None:
    """``--method`` (the curve representation), with the old spelling ``--repr``."""
    if several:
        p.add_argument(
            "--method",
            default="lie,euler",
            metavar="{lie,euler-elastic}[,...]",
            help="curve representations, comma-separated: lie (R^3 x SO(3)^J) and/or euler-elastic (Euler "
            "angles, radians; 'euler' also accepted) (default: lie,euler)",
        )
    else:
        p.add_argument(
            "--method",
            default="lie",
            metavar="{lie,euler-elastic}",
            help="curve representation: lie (R^3 x SO(3)^J) or euler-elastic (Euler angles, radians; 'euler' "
            "also accepted) (default: lie)",
        )
    alias(p, "--repr", "--method")


def methods(value: str, *, several: bool) -> tuple[str, ...]:
    """The stored keys (``lie``, ``euler``) of ``--method``'s value."""
    got = tuple(v.strip() for v in value.split(",") if v.strip()) if several else (value,)
    keys = tuple(METHOD_KEYS.get(m, m) for m in got)
    if not got or any(m not in METHOD_KEYS for m in got) or len(set(keys)) != len(keys):
        if not several and value in LINKAGES:
            raise CommandError(
                f"--method: expected a curve representation, one of {', '.join(METHODS)}; got {value!r}, a "
                f"linkage (use --linkage {value})"
            )
        what = "distinct entries of" if several else "one of"
        raise CommandError(f"--method: expected {what} {', '.join(METHODS)}; got {value!r}")
    return keys


def database_settings(args: argparse.Namespace, reps: tuple[str, ...]):
    from elastic_motion.apps.database import DatabaseSettings
    from elastic_motion.warp import WarpOptions

    return DatabaseSettings(
        n_samples=args.samples,
        representations=reps,
        warp=WarpOptions(
            method=args.warp, neighbourhood=args.neighbourhood, coarse_to_fine=args.coarse_to_fine
        ),
        joints=joints_option(args.joints),
        drop_fingers=not args.keep_fingers,
        align_heading=not args.no_align,
        tile_size=getattr(args, "tile_size", 32),
        pose_weight=pose_weight_option(getattr(args, "pose_weight", None)),
        cyclic=bool(getattr(args, "cyclic", False)),
    )


def stored_terms_notes(args: argparse.Namespace, stored) -> list[str]:
    """Notes for ``--pose-weight`` / ``--cyclic`` given against a database that was built with
    other values (a matrix folder or an index: its stored settings ``stored`` are used)."""
    notes = []
    given = getattr(args, "pose_weight", None)
    if given is not None:
        want = pose_weight_option(given)
        have = stored.pose_weight
        same = want == have if "balanced" in (want, have) else float(want) == float(have)
        if not same:
            notes.append(
                f"--pose-weight {given} ignored: the database was built with pose weight {have!r} and is "
                "measured as it was built (build it again with the option to use it)"
            )
    if getattr(args, "cyclic", None) and not stored.cyclic:
        notes.append(
            "--cyclic ignored: the database was built without it and is measured as it was built "
            "(build it again with --cyclic to use it)"
        )
    return notes


def fail(command: str, exc: BaseException) -> int:
    """Print ``elastic-motion CMD: error: FILE-OR-OPTION: expected ...; got ...``; return the exit code.

    An :class:`~elastic_motion.errors.OptionError` is shown with the flag that sets the option.
    """
    if isinstance(exc, OptionError) and exc.option in FLAGS:
        flag = FLAGS[exc.option]
        print_error(command, exc.message if flag is None else f"{flag}: {exc.message}")
        return EXIT_BAD_INPUT
    if isinstance(exc, OSError) and exc.errno is None and exc.args:  # our own FILE: expected ...; got ...
        print_error(command, str(exc))
        return EXIT_BAD_INPUT
    return handle_error(command, exc)


#: Exceptions a database command reports as an error line (others are bugs and propagate).
USER_ERRORS = (CommandError, ValueError, KeyError, OSError, ParseError)


def emit(args: argparse.Namespace, command: str, body: dict, inputs, outputs, lines: list[str]) -> None:
    """The shared report: header (command, version, time, inputs, outputs) + ``body``."""
    from elastic_motion.apps.report import report_header

    report = {**report_header(command, inputs=inputs, outputs=outputs), **body}
    emit_report(args, report, [str(p) for p in inputs], "\n".join(lines))
