"""``elastic-motion landmarks FILE [FILE2]``: automatic events; with two files, their pairs
(:func:`elastic_motion.apps.landmark_detection.detect_landmarks`).

``--method`` lists :data:`elastic_motion.vocabulary.METHODS`. ``run`` imports the
app when the command runs (CLI start-up: the other commands never load it).
"""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from elastic_motion.cli_commands._argparse import add_alias
from elastic_motion.cli_commands._common import (
    CommandError,
    add_input_options,
    add_json_option,
    add_landmark_weight_option,
    add_warp_options,
    landmark_kinds,
    run_guarded,
)
from elastic_motion.vocabulary import METHODS

if TYPE_CHECKING:
    from elastic_motion.apps.landmark_detection import LandmarkReport


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``landmarks`` sub-command."""
    p = subparsers.add_parser(
        "landmarks",
        help="detect events (knee crossings, foot strikes and toe-offs); pair those of two motions by phase",
        description=(
            "Detect the times when the left (right) knee passes the other one moving forward, when a "
            "foot touches down, heel strikes and toe-offs (from the contacts). With two files, pair "
            "the events by phase exactly as `blend --landmarks auto` does (same --method and warp "
            "options): the warp without landmarks predicts where each event of A falls in B, and "
            "the nearest event of the same kind is taken (events without a partner are skipped, "
            "with the reason); `--json PAIRS.json` writes a file that `--landmarks PAIRS.json` "
            "reads, with the weight `--landmarks auto` meets the pairs with: the blend or "
            "alignment is then the one `--landmarks auto` makes."
        ),
    )
    p.add_argument("inputs", nargs="+", metavar="FILE", help="one motion file, or two to pair")
    p.add_argument(
        "--kinds",
        default=None,  # DEFAULT_PAIR_KINDS
        help="event kinds to detect (comma-separated; also left_foot_contact, right_foot_contact) "
        "(default: knee crossings, heel strikes and toe-offs)",
    )
    p.add_argument(
        "--landmark-kinds",
        default=None,  # DEFAULT_PAIR_KINDS
        help="kinds to pair for two files, as `blend --landmarks auto --landmark-kinds` pairs them "
        "(default: knee crossings, heel strikes and toe-offs)",
    )
    add_alias(p, "--pair-kinds", "--landmark-kinds")
    p.add_argument(
        "--max-pairs", type=int, default=None, help="at most this many pairs per kind (default: all)"
    )
    p.add_argument(
        "--method",
        choices=METHODS,
        default="lie",
        help="two files: the curves of the warp without landmarks the pairing starts from, as the "
        "blend's or alignment's --method (default: lie)",
    )
    add_warp_options(p)
    add_landmark_weight_option(p)
    add_input_options(p, writes_bvh=False)
    add_json_option(p)
    p.set_defaults(func=lambda a: run_guarded("landmarks", run, a))


def run(args: argparse.Namespace) -> int:
    from elastic_motion.apps.landmark_detection import detect_landmarks  # CLI start-up
    from elastic_motion.apps.report import report_header
    from elastic_motion.cli_commands._running import emit_report, prepare_options, warp_options

    inputs = list(args.inputs)
    if len(inputs) not in (1, 2):
        raise CommandError(f"FILE: expected one or two motion files; got {len(inputs)}")
    res = detect_landmarks(
        *inputs,
        kinds=landmark_kinds(args.kinds, "--kinds"),
        pair_kinds=landmark_kinds(args.landmark_kinds) if len(inputs) == 2 else None,
        max_pairs=args.max_pairs,
        method=args.method,
        warp=warp_options(args),
        prepare=prepare_options(args, len(inputs)),
    )
    report = report_header("landmarks", inputs, [], res.notes)
    report.update(res.summary())
    lines = []
    for f, m, ev in zip(inputs, res.motions, res.events, strict=True):
        lines.append(f"{f}: {len(ev)} events in {m.duration:.2f} s")
        lines += [f"  {e.time:7.3f} s  frame {e.frame:5d}  {e.kind}" for e in ev]
    if res.pairing is not None:
        lines += _pair_lines(res)
    lines += [f"note: {n}" for n in res.notes]
    emit_report(args, report, inputs, "\n".join(lines))
    return 0


def _pair_lines(res: LandmarkReport) -> list[str]:
    """The summary lines of the pairs of two motions."""
    pairing = res.pairing
    lines = [
        f"pairs by phase ({', '.join(res.pair_kinds)}), seconds A:B: "
        + (", ".join(f"{a:.3f}:{b:.3f}" for a, b in res.pairs) or "none")
        + ("" if res.landmark_weight is None else f" (met with relative weight {res.landmark_weight:g})")
    ]
    lines += [
        f"  {d['kind']}: {d['time_a_s']:.3f}:{d['time_b_s']:.3f} ({d['offset_s']:+.3f} s from the prior)"
        for d in pairing.details
    ]
    lines += [f"  skipped {s['motion']} {s['kind']} {s['time_s']:.3f} s: {s['why']}" for s in pairing.skipped]
    return lines
