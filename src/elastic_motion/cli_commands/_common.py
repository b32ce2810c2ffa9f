"""Helpers shared by the motion sub-commands (blend, landmarks, loop, align, distance, render):
their options, declared once.

The options of the preparation step and of the time warp (one name per concept across all
commands, mapped onto :class:`elastic_motion.apps.prepare.PrepareOptions` and
:class:`elastic_motion.warp.WarpOptions`), the landmark and contact options, ``--json`` and
``--quiet``, the argument types, and error reporting. The choices are read from
:mod:`elastic_motion.vocabulary` and the defaults from :mod:`elastic_motion.defaults`, the
homes the API's types and options read them from, so that this module (imported when
:func:`elastic_motion.cli.build_parser` builds the parser) loads no numpy: what turns the
parsed options into the apps' options and runs them is in :mod:`._running`, which a command
imports inside its ``run``. The user error :class:`CommandError` (:mod:`._errors`) and the
outputs' safety net :func:`check_output` (:mod:`._paths`) are re-exported here, for the
command modules.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Sequence
from typing import Any

from elastic_motion.apps.progress import ProgressBar
from elastic_motion.cli_commands._argparse import EXIT_BAD_INPUT, add_alias
from elastic_motion.cli_commands._errors import CommandError, option_message
from elastic_motion.cli_commands._paths import check_output
from elastic_motion.defaults import (
    AUTO_LANDMARK_WEIGHT,
    CONTACT_HEIGHT_ENTER,
    CONTACT_SPEED_ENTER,
    DEFAULT_LANDMARK_WEIGHT,
    DEFAULT_MAX_STEP,
    DEFAULT_METHOD,
    DEFAULT_SAMPLE_FPS,
    DEFAULT_SAMPLE_SMOOTHING,
)
from elastic_motion.errors import OptionError, ParseError
from elastic_motion.vocabulary import (
    DEFAULT_PAIR_KINDS,
    EVENT_KINDS,
    LIMIT_POLICIES,
    TIME_UNITS,
    UP_AXES,
    WARP_METHODS,
)

__all__ = [  # CommandError and check_output are re-exported: every command module uses them
    "NO_FEET",
    "CommandError",
    "add_contact_height_option",
    "add_input_options",
    "add_joint_options",
    "add_json_option",
    "add_landmark_options",
    "add_landmark_weight_option",
    "add_quiet_option",
    "add_up_units_options",
    "add_warp_options",
    "check_output",
    "fail",
    "fmt_float",
    "joints_arg",
    "landmark_kinds",
    "non_negative_float",
    "positive_float",
    "progress_for",
    "run_guarded",
]


def fail(command: str, message: str) -> int:
    """Print an error for ``command`` on stderr and return the bad-input exit code."""
    print(f"elastic-motion {command}: error: {message}", file=sys.stderr)
    return EXIT_BAD_INPUT


def run_guarded(command: str, fn, args: argparse.Namespace) -> int:
    """Call ``fn(args)``; turn user errors (bad files, bad values) into exit code 2."""
    try:
        return int(fn(args))
    except OptionError as exc:
        return fail(command, option_message(exc))
    except (CommandError, ParseError, ValueError, KeyError, FileNotFoundError, IsADirectoryError) as exc:
        msg = exc.args[0] if isinstance(exc, KeyError) and exc.args else str(exc)
        return fail(command, str(msg))


# ------------------------------------------------------------------------------------------
# Options
# ------------------------------------------------------------------------------------------


def add_json_option(p: argparse.ArgumentParser) -> None:
    """``--json [PATH]``: write the report to PATH, or print it on stdout when no PATH."""
    p.add_argument(
        "--json",
        nargs="?",
        const="-",
        default=None,
        metavar="PATH",
        help="write a JSON report of what was done, with the quality metrics, to PATH "
        "(without PATH: print it on stdout instead of the summary; default: no report)",
    )


def add_quiet_option(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "-q", "--quiet", action="store_true", help="no progress bar on stderr (default: bars on terminals)"
    )


def add_input_options(p: argparse.ArgumentParser, *, several: bool = True, writes_bvh: bool = True) -> None:
    """The preparation step's options (:class:`elastic_motion.apps.prepare.PrepareOptions`):
    ``--trim``, ``--keep-first-frame``, ``--units``, ``--up``, and ``--units-out`` for the
    commands that write a BVH (``writes_bvh``)."""
    p.add_argument(
        "--trim",
        nargs="+",
        default=None,
        metavar="START:STOP",
        help="keep only this time range of each input, seconds from its first frame (after a dropped "
        "T-pose frame)"
        + ("; one range per input, in order (':' keeps a whole file)" if several else "")
        + "; e.g. 1.0:3.4 (default: whole clips)",
    )
    p.add_argument(
        "--keep-first-frame",
        action="store_true",
        help="keep frame 0 even when it looks like a T-pose (default: such a frame is dropped)",
    )
    add_up_units_options(p)
    if not writes_bvh:
        return
    p.add_argument(
        "--units-out",
        default=None,
        metavar="UNIT",
        help="length unit of the written BVH: m, cm, mm, inch or cmu (default: the unit of the first "
        "input); glTF is always metres (its specification)",
    )


def add_up_units_options(p: argparse.ArgumentParser) -> None:
    """``--units`` and ``--up``: how every motion file a command reads is read
    (:class:`elastic_motion.apps.prepare.PrepareOptions` ``units`` and ``up``); every command
    that reads motions has them."""
    # unit names are checked by PrepareOptions (elastic_motion.motion.UNITS); not imported
    # here so that --help does not load the numerical stack
    p.add_argument(
        "--units",
        default=None,
        metavar="UNIT",
        help="length unit of BVH inputs: m, cm, mm, inch or cmu (default: guessed from the skeleton's size)",
    )
    p.add_argument(
        "--up",
        default=None,
        choices=UP_AXES,
        help="up axis of the inputs (default: as detected when reading; Blender exports are z-up)",
    )


def add_joint_options(p: argparse.ArgumentParser) -> None:
    """``--joints`` and ``--no-align`` (preparation step)."""
    p.add_argument(
        "--joints",
        default="all",
        help="'all' (the inputs must have the same joints), 'common' (keep the shared joints; refused "
        "when that leaves less than half a body) or a comma-separated list of joint names",
    )
    p.add_argument(
        "--no-align",
        action="store_true",
        help="do not place the inputs like the first one (heading and floor position)",
    )
    add_alias(p, "--no-align-heading", "--no-align")


def add_sample_smoothing(p: argparse.ArgumentParser, grid: str, default: float | None) -> None:
    """``--sample-smoothing``: the low-pass before a motion is sampled (``WarpOptions.sample_smoothing``,
    one flag for ``distance``, ``blend`` and the database commands); ``grid`` says what is sampled
    after it, ``default`` None: the settings' own (a stored database's)."""
    p.add_argument(
        "--sample-smoothing",
        type=float,
        default=default,
        metavar="SECONDS",
        help=f"standard deviation (seconds) of the Gaussian low-pass applied before sampling {grid}; "
        f"0: none (default: {DEFAULT_SAMPLE_SMOOTHING:g})",
    )


def add_warp_options(
    p: argparse.ArgumentParser,
    *,
    method: str = DEFAULT_METHOD,
    sampling: bool = True,
    coarse_to_fine: bool = False,
) -> None:
    """The time warp's options (:class:`elastic_motion.warp.WarpOptions`), defaulting to its
    defaults (:mod:`elastic_motion.defaults`: both doors agree).

    ``method``: the default ``--warp`` (``WarpOptions``' unless a command's API has another,
    as the database's DP alone); ``sampling`` adds ``--sample-fps`` (motions resampled by frame
    rate), ``coarse_to_fine`` the banded DP flag (the database commands).
    """

    p.add_argument(
        "--warp",
        choices=WARP_METHODS,
        default=method,
        help="time warp: dynamic programming, DP then gradient refinement off the grid, or none "
        f"(distance of the parametrised curves) (default: {method})",
    )
    p.add_argument(
        "--neighbourhood",
        type=int,
        default=DEFAULT_MAX_STEP,
        metavar="N",
        help="DP slopes: all coprime steps (a, b) with a, b <= N; larger is more exact and slower "
        f"(default: {DEFAULT_MAX_STEP})",
    )
    if sampling:
        p.add_argument(
            "--sample-fps",
            type=float,
            default=DEFAULT_SAMPLE_FPS,
            metavar="FPS",
            help="frame rate (frames per second, at most) of the curves the warp is computed on "
            f"(default: {DEFAULT_SAMPLE_FPS:g})",
        )
        add_alias(p, "--warp-fps", "--sample-fps")
        add_sample_smoothing(p, "the curves at --sample-fps", DEFAULT_SAMPLE_SMOOTHING)
    if coarse_to_fine:
        p.add_argument(
            "--coarse-to-fine",
            action="store_true",
            help="banded coarse-to-fine DP (faster on long grids, approximate; default: off)",
        )


def joints_arg(value: str, modes: Sequence[str] = ("all", "common")) -> str | tuple[str, ...]:
    """``--joints``: one of ``modes`` (the database commands add ``map``) or comma-separated names."""
    if value in modes:
        return value
    names = tuple(v.strip() for v in value.split(",") if v.strip())
    if not names:
        raise CommandError(
            f"--joints: expected {', '.join(repr(m) for m in modes)} or joint names; got {value!r}"
        )
    return names


# ------------------------------------------------------------------------------------------
# Inputs and outputs
# ------------------------------------------------------------------------------------------


def progress_for(command: str, args: argparse.Namespace) -> ProgressBar:
    """The progress bar of ``command`` on stderr (none with ``--quiet``)."""
    return ProgressBar(command, enabled=False if getattr(args, "quiet", False) else None)


# ------------------------------------------------------------------------------------------
# Landmarks
# ------------------------------------------------------------------------------------------


def add_landmark_options(p: argparse.ArgumentParser) -> None:
    """``--landmarks``, ``--landmark-units``, ``--landmark-kinds``, ``--max-pairs`` and
    ``--landmark-weight`` (the landmarks of a warp between two motions)."""
    kinds = [*DEFAULT_PAIR_KINDS, *(k for k in EVENT_KINDS if k not in DEFAULT_PAIR_KINDS)]
    p.add_argument(
        "--landmarks",
        default=None,
        help="'auto' (events of A and B paired by phase around the warp without landmarks), "
        "'none', a file, or pairs 'tA:tB,...' (times in --landmark-units, or suffixed s/f) "
        "(default: none)",
    )
    p.add_argument(
        "--landmark-units",
        choices=TIME_UNITS,
        default="seconds",
        help="unit of landmark times without suffix (default seconds; frames count from the first "
        "frame kept, at each file's frame rate)",
    )
    p.add_argument(
        "--landmark-kinds",
        default=None,
        help=f"events paired by phase by --landmarks auto, comma-separated: {', '.join(kinds)} "
        "(default: the knee crossings, heel strikes and toe-offs)",
    )
    p.add_argument(
        "--max-pairs", type=int, default=None, help="--landmarks auto: at most this many pairs per kind"
    )
    add_landmark_weight_option(p)


def add_landmark_weight_option(p: argparse.ArgumentParser) -> None:
    """``--landmark-weight`` (alias ``--lambda``): the relative weight of the landmark term."""
    p.add_argument(
        "--landmark-weight",
        type=float,
        default=None,
        metavar="W",
        help="relative weight of the landmark term (100: missing a landmark by 5%% of the clip "
        "costs a quarter of the curves' squared SRV norms) "
        f"(default: {DEFAULT_LANDMARK_WEIGHT:g}; --landmarks auto: at least {AUTO_LANDMARK_WEIGHT:g}; "
        "a file of `elastic-motion landmarks`: the weight it records)",
    )
    add_alias(p, "--lambda", "--landmark-weight")


def add_contact_height_option(p: argparse.ArgumentParser) -> None:
    """``--contact-height``: the height within which a joint counts as planted."""

    p.add_argument(
        "--contact-height",
        type=float,
        default=None,
        metavar="METRES",
        help="a foot, toe or hand is planted when slower than "
        f"{CONTACT_SPEED_ENTER:g} m/s within this height of its lowest, and leaves above twice it "
        f"(default: {CONTACT_HEIGHT_ENTER:g}); raise it for a floor that is not level or a capture "
        "that drifts (the notes name the stances it misses)",
    )


def joint_limits_flag(value: str) -> str:
    """``--joint-limits``: a limit policy or the path of an ASF file (read by the app's options,
    :func:`elastic_motion.apps.limit_stage.check_limits_option`)."""
    if value in LIMIT_POLICIES or value.lower().endswith(".asf"):
        return value
    raise argparse.ArgumentTypeError(
        f"expected one of {', '.join(LIMIT_POLICIES)} or an .asf file; got {value!r}"
    )


def add_joint_limits_option(p: argparse.ArgumentParser, default: str, what: str) -> None:
    """``--joint-limits`` of the loop, the blend and the mean; ``what``: what ``keep`` does."""
    p.add_argument(
        "--joint-limits",
        type=joint_limits_flag,
        default=default,
        metavar="{keep,report,off} or FILE.asf",
        help="limits of the joints' DOF angles, from the ASF file of an .amc input or the given .asf "
        f"file (none: nothing happens): 'keep': {what}; 'report': only measured; 'off': skip. Limits "
        f"the input itself violates are reported, never enforced (default: {default})",
    )


def landmark_kinds(value: str | None, flag: str = "--landmark-kinds") -> list[str] | None:
    """``--landmark-kinds`` (or the option ``flag``) -> event kinds (None: the library's default
    kinds)."""

    if value is None:
        return None
    kinds = [k.strip() for k in value.split(",") if k.strip()]
    bad = [k for k in kinds if k not in EVENT_KINDS]
    if bad or not kinds:
        raise CommandError(f"{flag}: expected some of {', '.join(EVENT_KINDS)}; got {value!r}")
    return kinds


def _number(value: str, ok, what: str) -> float:
    try:
        x = float(value)
    except ValueError:
        x = math.nan
    if not (math.isfinite(x) and ok(x)):
        raise argparse.ArgumentTypeError(f"expected {what}; got {value!r}")
    return x


def non_negative_float(value: str) -> float:
    """An argparse ``type``: a finite number >= 0 (argparse names the option when it fails)."""
    return _number(value, lambda x: x >= 0, "a number >= 0")


def positive_float(value: str) -> float:
    """An argparse ``type``: a finite number > 0 (argparse names the option when it fails)."""
    return _number(value, lambda x: x > 0, "a number > 0")


#: What a summary says of the feet of a skeleton that has none
#: (:func:`~elastic_motion.apps.metrics.foot_joints`).
NO_FEET = "n/a, no joint named foot, toe or ankle to measure"


def fmt_float(x: Any, digits: int = 3) -> str:
    """``x`` with ``digits`` significant digits; ``"n/a"`` for NaN (a figure that had nothing
    to measure), never ``"nan"``."""
    try:
        v = float(x)
    except (TypeError, ValueError):
        return str(x)
    return "n/a" if math.isnan(v) else f"{v:.{digits}g}"
