"""Helpers shared by the motion sub-commands (blend, landmarks, loop, align, distance, render).

The options of the preparation step and of the time warp (one name per concept across all
commands, mapped onto :class:`elastic_motion.apps.prepare.PrepareOptions` and
:class:`elastic_motion.warp.WarpOptions`), refusing outputs that are inputs, parsing landmark
arguments, the ``--json`` option and error reporting. No numerical work.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from elastic_motion.errors import OptionError, ParseError

#: Exit code for bad input (unreadable file, bad argument value).
EXIT_BAD_INPUT = 2


class CommandError(Exception):
    """A user error: printed as ``elastic-motion CMD: error: MESSAGE``, exit code 2."""


def fail(command: str, message: str) -> int:
    """Print an error for ``command`` on stderr and return the bad-input exit code."""
    print(f"elastic-motion {command}: error: {message}", file=sys.stderr)
    return EXIT_BAD_INPUT


#: API argument names that are input files on the command line, not options.
_POSITIONAL = {"motions", "motion", "labels", "prepare"}


def option_message(exc: OptionError) -> str:
    """An :class:`OptionError` in command-line words: the API argument ``trim`` is ``--trim``."""
    if exc.option in _POSITIONAL:
        return exc.message
    return f"--{exc.option.replace('_', '-')}: {exc.message}"


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


def check_report_target(args: argparse.Namespace) -> None:
    """Refuse a ``--json PATH`` that names a motion file or an existing file that is not an
    earlier report, before any work (``--json`` before the inputs takes the first of them as
    its PATH; the report written at the end replaced that motion). Raises :class:`CommandError`."""
    from elastic_motion.apps.database.files import MOTION_EXTENSIONS
    from elastic_motion.apps.report import is_report

    value = getattr(args, "json", None)
    if not isinstance(value, str) or value == "-":
        return
    hint = "(--json takes the next word as its PATH: put it after the inputs)"
    suffix = Path(value).suffix.lower()
    # a motion file's name is never a report path (.json is a report's too: checked below)
    if suffix != ".json" and suffix in (*MOTION_EXTENSIONS, ".asf"):
        raise CommandError(
            f"--json: expected a report path (e.g. report.json), or nothing to print the report; got "
            f"{value!r}, a motion file's name {hint}"
        )
    if Path(value).is_file() and not is_report(Path(value)):
        raise CommandError(
            f"--json: expected a new file or an earlier elastic-motion report; got {value!r}, another "
            f"existing file (refusing to overwrite it) {hint}"
        )


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
    from elastic_motion.cli_commands._argparse import add_alias

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
    from elastic_motion.cli_commands._argparse import add_alias
    from elastic_motion.warp import WARP_METHODS, WarpOptions

    defaults = WarpOptions() if defaults is None else defaults  # the API's: both doors agree
    p.add_argument(
        "--warp",
        choices=WARP_METHODS,
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
    from elastic_motion.apps.prepare import PrepareOptions

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
    from elastic_motion.warp import WarpOptions

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
    from elastic_motion.apps.prepare import prepare_motions

    return prepare_motions(list(paths), prepare_options(args, len(paths)))


def write_motion(motion: Any, prepared: Any, path: str | os.PathLike[str], inputs: Sequence[str]) -> None:
    """Write a result in the output unit (:func:`elastic_motion.apps.prepare.output_motion`)."""
    from elastic_motion.apps.prepare import output_motion
    from elastic_motion.motion import write_bvh

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


def protected_inputs(inputs: Sequence[str | os.PathLike[str]]) -> list[str]:
    """Every file a command reads for ``inputs``: the inputs and the ``.asf`` found beside an ``.amc``."""
    out: list[str] = []
    for p in inputs:
        out.append(os.fspath(p))
        if Path(p).suffix.lower() == ".amc":
            try:
                from elastic_motion.motion import find_asf

                out.append(os.fspath(find_asf(p)))
            except (ValueError, OSError):  # no skeleton found: reading the AMC will say so
                pass
    return out


def _inside(path: Path, folder: str | os.PathLike[str]) -> bool:
    """Whether ``path`` is ``folder`` or lies below it (symbolic links resolved)."""
    try:
        f = Path(folder).resolve()
        p = path.resolve()
    except (OSError, RuntimeError):
        return False
    return p == f or f in p.parents


def check_output(
    path: str,
    inputs: Sequence[str],
    *,
    suffixes: Sequence[str] | None = None,
    what: str = "-o",
    outputs: Sequence[str] = (),
) -> Path:
    """The safety net for one output path: refuse anything that would overwrite what is read.

    Refused: an output that is one of the ``inputs`` or a file read for them (the ``.asf``
    beside an ``.amc``) -- by name, through ``../``, a symbolic or a hard link --, an output
    inside an input folder (a ``matrix`` folder's own files), one of the other ``outputs``
    of the command, an existing folder, a missing parent folder, a wrong extension.

    Parameters
    ----------
    path : str
        The output path.
    inputs : sequence of str
        Files and folders the command reads (``.amc`` files are expanded with their ``.asf``).
    suffixes : sequence of str, optional
        Accepted extensions (lower case, with the dot).
    what : str, default "-o"
        The option named in the error.
    outputs : sequence of str, optional
        The command's other outputs.

    Returns
    -------
    pathlib.Path

    Raises
    ------
    CommandError
    """
    from elastic_motion._io import same_file

    out = Path(path)
    for p in protected_inputs(inputs):
        if same_file(out, p):
            raise CommandError(f"{what}: {path!r} is the input file {p!r}; refusing to overwrite an input")
        if os.path.isdir(p) and _inside(out, p):
            raise CommandError(
                f"{what}: expected a path outside the input folder {p!r}; got {path!r}, which would "
                "write into it"
            )
    for o in outputs:
        if same_file(out, o):
            raise CommandError(f"{what}: {path!r} is also another output of this command ({o!r})")
    if out.is_dir():
        raise CommandError(f"{what}: expected a file path; got the folder {path!r}")
    if suffixes is not None and out.suffix.lower() not in suffixes:
        raise CommandError(f"{what}: expected a {' or '.join(suffixes)} file; got {path!r}")
    if out.parent and not out.parent.exists():
        raise CommandError(f"{what}: the folder {str(out.parent)!r} does not exist")
    return out


#: Namespace attributes that are files or folders a command reads, and those it writes.
_INPUT_ATTRS = (
    "inputs",
    "input",
    "file",
    "files",
    "a",
    "b",
    "query",
    "database",
    "matrix_dir",
    "asf",
    "labels",
    "landmarks",
)
_OUTPUT_ATTRS = {"output": "-o", "json": "--json", "preview": "--preview", "plot": "--plot"}
#: Commands whose ``-o`` is a folder that must neither hold nor lie inside an input (a rerun
#: reads the folder again), and other commands whose ``-o`` is a folder they manage themselves.
_FOLDER_OUTPUTS = {"matrix"}
_OWN_FOLDER_OUTPUTS = {"demo", "index", "pca"}


def check_paths(args: argparse.Namespace) -> None:
    """The shared safety net, run on every parsed command line before the command starts.

    Every path the command writes (``-o``, ``--json PATH``, ``--preview``, ``--plot``) is
    checked against every path it reads (with the ``.asf`` beside an ``.amc``) and against
    the other outputs (:func:`check_output`); a folder output (``matrix -o``) must neither
    hold nor lie inside an input. Refusals are :class:`CommandError` (exit code 2).
    """
    command = getattr(args, "command", None)
    inputs: list[str] = []
    for attr in _INPUT_ATTRS:
        v = getattr(args, attr, None)
        for item in v if isinstance(v, list | tuple) else [v]:
            if isinstance(item, str) and item not in ("", "-") and os.path.lexists(item):
                inputs.append(item)
    outputs: list[tuple[str, str]] = []
    for attr, flag in _OUTPUT_ATTRS.items():
        v = getattr(args, attr, None)
        if isinstance(v, str) and v not in ("", "-"):
            outputs.append((flag, v))
    if command in _OWN_FOLDER_OUTPUTS:  # the command checks its folder; its files are checked here
        outputs = [(f, o) for f, o in outputs if f != "-o"]
    for k, (flag, path) in enumerate(outputs):
        others = [o for i, (_, o) in enumerate(outputs) if i != k]
        if command in _FOLDER_OUTPUTS and flag == "-o":
            folder = Path(path)
            for p in protected_inputs(inputs):
                if same_path(folder, p) or _inside(folder, p) or _inside(Path(p), folder):
                    raise CommandError(
                        f"{flag}: expected an output folder that neither holds nor lies inside an input; "
                        f"got {path!r} and the input {p!r}"
                    )
            if folder.exists() and not folder.is_dir():
                raise CommandError(f"{flag}: expected a folder; got the file {path!r}")
            continue
        folder_outputs = [o for f, o in outputs if f == "-o" and command in _FOLDER_OUTPUTS]
        for fo in folder_outputs:
            if _inside(Path(path), fo):
                raise CommandError(
                    f"{flag}: expected a path outside the output folder {fo!r} (it holds the run's own "
                    f"files); got {path!r}"
                )
        check_output(path, inputs, what=flag, outputs=[o for o in others if o not in folder_outputs])


def check_option_limits(args: argparse.Namespace) -> None:
    """Options bounded by :mod:`elastic_motion.limits`, checked before a command reads anything.

    ``--repeat`` (loop previews, seam renders) against ``max_repeat``; other commands check
    their own sizes where they know them (render sizes, frame counts in the readers).
    """
    from elastic_motion import limits

    repeat = getattr(args, "repeat", None)
    if isinstance(repeat, int) and not isinstance(repeat, bool):
        try:
            limits.check_option("repeat", "a repeat count of", repeat, "max_repeat")
        except OptionError as exc:
            raise CommandError(option_message(exc)) from None


def same_path(a: str | os.PathLike[str], b: str | os.PathLike[str]) -> bool:
    """Whether ``a`` and ``b`` name the same file or folder."""
    from elastic_motion._io import same_file

    return same_file(a, b)


def emit_report(
    args: argparse.Namespace, report: dict[str, Any], inputs: Sequence[str], summary: str
) -> None:
    """Print the human summary (or the JSON on stdout) and write ``--json PATH``.

    ``PATH`` goes through the safety net (:func:`check_output`) against ``inputs`` -- pass
    the command's inputs *and* the outputs it wrote -- and the ``.asf`` files beside them.
    """
    from elastic_motion.apps.report import report_json, write_report

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


def progress_for(command: str, args: argparse.Namespace):
    from elastic_motion.apps.progress import ProgressBar

    return ProgressBar(command, enabled=False if getattr(args, "quiet", False) else None)


# ------------------------------------------------------------------------------------------
# Landmarks
# ------------------------------------------------------------------------------------------


def _time(value: str, unit: str, fps: float) -> float:
    """One time of an inline ``--landmarks`` pair in seconds (:func:`landmark_time`)."""
    from elastic_motion.apps.landmark_files import landmark_time

    try:
        return landmark_time(value, unit, fps)
    except ValueError as exc:
        raise CommandError(f"--landmarks: {exc}") from None


def parse_landmarks(
    value: str | None, unit: str, fps_a: float, fps_b: float, inputs: Sequence[str] | None = None
) -> Any:
    """``--landmarks`` -> ``None``, ``"auto"`` or a list of ``(tA, tB)`` in seconds
    (:func:`read_landmarks` without the weight)."""
    return read_landmarks(value, unit, fps_a, fps_b, inputs)[0]


def read_landmarks(
    value: str | None, unit: str, fps_a: float, fps_b: float, inputs: Sequence[str] | None = None
) -> tuple[Any, float | None]:
    """``--landmarks`` -> (``None``, ``"auto"`` or a list of ``(tA, tB)`` in seconds; the
    relative landmark weight the file records, or None).

    Accepted: ``auto``, ``none``, a file, or inline pairs ``"a0:b0,a1:b1"``. Times are in
    ``unit`` (``seconds`` or ``frames``) unless suffixed with ``s`` or ``f``; frames count
    from the first frame kept (after ``--trim``), at each file's own frame rate.

    Files: JSON ``{"units": "seconds"|"frames", "pairs": [[a, b], ...]}`` or the report of
    ``elastic-motion landmarks A B --json`` (its ``pairs_s``, and its ``landmark_weight``: the
    weight ``--landmarks auto`` meets the pairs with, so that the file gives the same warp;
    refused when ``inputs`` are given and its own inputs are other files or the same ones
    swapped); or text, one pair per line (``a b``, ``a,b`` or ``a:b``; ``#`` starts a comment).
    """
    if value is not None and value not in ("none", "auto") and os.path.exists(value):
        return _landmarks_file(value, unit, fps_a, fps_b, inputs)
    return _landmarks_value(value, unit, fps_a, fps_b), None


def _landmarks_file(
    path: str, unit: str, fps_a: float, fps_b: float, inputs: Sequence[str] | None
) -> tuple[list[tuple[float, float]], float | None]:
    """A landmarks file (:func:`read_landmarks`): its pairs in seconds and recorded weight
    (:func:`elastic_motion.apps.landmark_files.read_landmark_file`, as ``em.read_landmarks``)."""
    from elastic_motion.apps.landmark_files import read_landmark_file

    lf = read_landmark_file(path, units=unit, fps=(fps_a, fps_b), inputs=inputs)
    return list(lf.pairs), lf.landmark_weight


def _landmarks_value(value: str | None, unit: str, fps_a: float, fps_b: float) -> Any:
    """``--landmarks`` other than a file (:func:`read_landmarks`)."""
    if value is None or value == "none":
        return None
    if value == "auto":
        return "auto"
    if ":" not in value:
        raise CommandError(
            f"--landmarks: expected 'auto', 'none', a file, or pairs like '0.5:0.7,1.4:1.9'; got {value!r} "
            "(no such file)"
        )
    pairs = []
    for item in value.split(","):
        if not item.strip():
            continue
        if item.count(":") != 1:
            raise CommandError(f"--landmarks: expected 'tA:tB' pairs separated by commas; got {item!r}")
        a, b = item.split(":")
        pairs.append((_time(a, unit, fps_a), _time(b, unit, fps_b)))
    return pairs


def add_landmark_options(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--landmarks",
        default=None,
        help="'auto' (events of A and B paired by phase around the warp without landmarks), "
        "'none', a file, or pairs 'tA:tB,...' (times in --landmark-units, or suffixed s/f) "
        "(default: none)",
    )
    p.add_argument(
        "--landmark-units",
        choices=("seconds", "frames"),
        default="seconds",
        help="unit of landmark times without suffix (default seconds; frames count from the first "
        "frame kept, at each file's frame rate)",
    )
    p.add_argument(
        "--landmark-kinds",
        default=None,
        help="events paired by phase by --landmarks auto, comma-separated: left_knee_passes, "
        "right_knee_passes, left_heel_strike, right_heel_strike, left_toe_off, right_toe_off, "
        "left_foot_contact, right_foot_contact (default: the knee crossings, heel strikes and toe-offs)",
    )
    p.add_argument(
        "--max-pairs", type=int, default=None, help="--landmarks auto: at most this many pairs per kind"
    )
    add_landmark_weight_option(p)


def add_landmark_weight_option(p: argparse.ArgumentParser) -> None:
    """``--landmark-weight`` (alias ``--lambda``): the relative weight of the landmark term."""
    from elastic_motion.apps.align import AUTO_LANDMARK_WEIGHT
    from elastic_motion.cli_commands._argparse import add_alias
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
    from elastic_motion.motion.contacts import ContactOptions

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
    from elastic_motion.motion.contacts import ContactOptions

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
    from elastic_motion.apps.landmarks import EVENT_KINDS

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
