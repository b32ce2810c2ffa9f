"""Helpers shared by the motion sub-commands (blend, landmarks, loop, align, distance, render).

The options of the preparation step and of the time warp (one name per concept across all
commands, mapped onto :class:`elastic_motion.apps.prepare.PrepareOptions` and
:class:`elastic_motion.warp.WarpOptions`; their choices read from the API's types), parsing
landmark arguments, the ``--json`` option and error reporting. No numerical work. The user
error :class:`CommandError` (:mod:`._errors`) and the outputs' safety net :func:`check_output`
(:mod:`._paths`) are re-exported here, for the command modules.

This module imports the API's types (numpy, numba): it is imported with the command modules,
when :func:`elastic_motion.cli.main` builds the parser (``import elastic_motion.cli`` itself
stays light).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from collections.abc import Sequence
from typing import Any

from elastic_motion._options import choices
from elastic_motion.apps.align import AUTO_LANDMARK_WEIGHT
from elastic_motion.apps.landmark_files import TIME_UNITS, LandmarkFile, parse_landmarks
from elastic_motion.apps.landmarks import DEFAULT_PAIR_KINDS, EVENT_KINDS
from elastic_motion.apps.prepare import PrepareOptions, output_motion, prepare_motions
from elastic_motion.apps.progress import ProgressBar
from elastic_motion.apps.report import report_json, write_report
from elastic_motion.cli_commands._argparse import EXIT_BAD_INPUT, add_alias
from elastic_motion.cli_commands._errors import CommandError, option_message
from elastic_motion.cli_commands._paths import check_output, protected_inputs
from elastic_motion.errors import OptionError, ParseError
from elastic_motion.motion import write_bvh
from elastic_motion.motion.contacts import ContactOptions
from elastic_motion.warp import WarpOptions
from elastic_motion.warp.options import WarpMethod

__all__ = [  # CommandError and check_output are re-exported: every command module uses them
    "CommandError",
    "add_contact_height_option",
    "add_input_options",
    "add_joint_options",
    "add_json_option",
    "add_landmark_options",
    "add_landmark_weight_option",
    "add_quiet_option",
    "add_warp_options",
    "check_output",
    "contact_options",
    "emit_report",
    "fail",
    "fmt_float",
    "joints_arg",
    "landmark_kinds",
    "non_negative_float",
    "positive_float",
    "prepare_inputs",
    "prepare_options",
    "progress_for",
    "read_landmarks",
    "run_guarded",
    "warp_options",
    "write_motion",
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
        choices=("y", "z"),
        help="up axis of the inputs (default: as detected when reading; Blender exports are z-up)",
    )
    if not writes_bvh:
        return
    p.add_argument(
        "--units-out",
        default=None,
        metavar="UNIT",
        help="length unit of the written BVH: m, cm, mm, inch or cmu (default: the unit of the first input)",
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


def add_warp_options(
    p: argparse.ArgumentParser,
    *,
    defaults: Any = None,
    sampling: bool = True,
    coarse_to_fine: bool = False,
) -> None:
    """The time warp's options (:class:`elastic_motion.warp.WarpOptions`).

    ``defaults``: the options whose values the flags default to (the API's
    ``WarpOptions()`` unless a command's API has other defaults, as the database's);
    ``sampling`` adds ``--sample-fps`` (motions resampled by frame rate), ``coarse_to_fine``
    the banded DP flag (the database commands).
    """

    defaults = WarpOptions() if defaults is None else defaults  # the API's: both doors agree
    p.add_argument(
        "--warp",
        choices=choices(WarpMethod),
        default=defaults.method,
        help="time warp: dynamic programming, DP then gradient refinement off the grid, or none "
        f"(distance of the parametrised curves) (default: {defaults.method})",
    )
    p.add_argument(
        "--neighbourhood",
        type=int,
        default=defaults.neighbourhood,
        metavar="N",
        help="DP slopes: all coprime steps (a, b) with a, b <= N; larger is more exact and slower "
        f"(default: {defaults.neighbourhood})",
    )
    if sampling:
        p.add_argument(
            "--sample-fps",
            type=float,
            default=defaults.sample_fps,
            metavar="FPS",
            help="frame rate (frames per second, at most) of the curves the warp is computed on "
            f"(default: {defaults.sample_fps:g})",
        )
        add_alias(p, "--warp-fps", "--sample-fps")
        p.add_argument(
            "--sample-smoothing",
            type=float,
            default=defaults.sample_smoothing,
            metavar="SECONDS",
            help="standard deviation (seconds) of the Gaussian low-pass applied before sampling "
            f"the curves at --sample-fps; 0: none (default: {defaults.sample_smoothing:g})",
        )
    if coarse_to_fine:
        p.add_argument(
            "--coarse-to-fine",
            action="store_true",
            help="banded coarse-to-fine DP (faster on long grids, approximate; default: off)",
        )


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


def write_motion(motion: Any, prepared: Any, path: str | os.PathLike[str], inputs: Sequence[str]) -> None:
    """Write a result in the output unit (:func:`elastic_motion.apps.prepare.output_motion`)."""

    write_bvh(output_motion(motion, prepared.units_out), path, protected=list(inputs))


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


# ------------------------------------------------------------------------------------------
# Inputs and outputs
# ------------------------------------------------------------------------------------------


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


def progress_for(command: str, args: argparse.Namespace) -> ProgressBar:
    """The progress bar of ``command`` on stderr (none with ``--quiet``)."""
    return ProgressBar(command, enabled=False if getattr(args, "quiet", False) else None)


# ------------------------------------------------------------------------------------------
# Landmarks
# ------------------------------------------------------------------------------------------


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


def add_landmark_options(p: argparse.ArgumentParser) -> None:
    """``--landmarks``, ``--landmark-units``, ``--landmark-kinds``, ``--max-pairs`` and
    ``--landmark-weight`` (the landmarks of a warp between two motions)."""
    from elastic_motion.apps.landmarks import EVENT_KINDS

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
    from elastic_motion.warp import WarpOptions

    p.add_argument(
        "--landmark-weight",
        type=float,
        default=None,
        metavar="W",
        help="relative weight of the landmark term (100: missing a landmark by 5%% of the clip "
        "costs a quarter of the curves' squared SRV norms) "
        f"(default: {WarpOptions().landmark_weight:g}; --landmarks auto: at least {AUTO_LANDMARK_WEIGHT:g}; "
        "a file of `elastic-motion landmarks`: the weight it records)",
    )
    add_alias(p, "--lambda", "--landmark-weight")


def add_contact_height_option(p: argparse.ArgumentParser) -> None:
    """``--contact-height``: the height within which a joint counts as planted."""

    default = ContactOptions()
    p.add_argument(
        "--contact-height",
        type=float,
        default=None,
        metavar="METRES",
        help="a foot, toe or hand is planted when slower than "
        f"{default.speed_enter:g} m/s within this height of its lowest, and leaves above twice it "
        f"(default: {default.height_enter:g}); raise it for a floor that is not level or a capture "
        "that drifts (the notes name the stances it misses)",
    )


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


def fmt_float(x: Any, digits: int = 3) -> str:
    try:
        return f"{float(x):.{digits}g}"
    except (TypeError, ValueError):
        return str(x)
