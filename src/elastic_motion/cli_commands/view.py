"""``elastic-motion view A [B ...] -o view.html``: an interactive 3D player in one HTML page
(:mod:`elastic_motion.apps.viewer`).

``--layout`` and ``--contacts`` list the viewer's vocabularies
(:data:`elastic_motion.vocabulary.Layout`, :data:`~elastic_motion.vocabulary.ContactMarks`;
``--contacts none`` is read as ``off``) and default to
:class:`~elastic_motion.apps.viewer.ViewerOptions`' defaults (:mod:`elastic_motion.defaults`).
``run`` imports the viewer app when the command runs (CLI start-up: building the parser loads
no numpy).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Literal

from elastic_motion._io import atomic_write_text
from elastic_motion._options import choices
from elastic_motion.cli_commands._common import (
    CommandError,
    add_json_option,
    add_up_units_options,
    check_output,
    run_guarded,
)
from elastic_motion.defaults import (
    VIEWER_CONTACTS,
    VIEWER_LAYOUT,
    VIEWER_MAX_FPS,
    VIEWER_MAX_FRAMES,
    VIEWER_TITLE,
)
from elastic_motion.vocabulary import CONTACT_MARK_ALIASES, CONTACT_MARKS, LAYOUTS

#: Where the command writes plotly.js: into the page, or as ``plotly.min.js`` beside it
#: (a command-line choice only: in Python, :func:`~elastic_motion.apps.viewer.plotly_js`
#: gives the text and ``plotly_src`` the URL the page loads it from).
PlotlyPlacement = Literal["inline", "beside"]


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``view`` sub-command."""
    p = subparsers.add_parser(
        "view",
        help="an interactive 3D player of motions in one HTML page (orbit, scrub, contacts, seams, warps)",
        description=(
            "Write an HTML page that plays the motions in 3D: orbit and zoom, play / pause / scrub, clips "
            "side by side or overlaid on one floor, joint paths on demand. Motions written by 'loop' or "
            "'blend' with --json show their contacts, loop seam and time warp: the report is found beside "
            "the file (a .json file whose outputs name it) or given with --reports. The page works offline "
            'from file:// (plotly.js is written into it; pip install "elastic-motion[viewer]"). Long '
            "clips are decimated for display and the page says so."
        ),
    )
    p.add_argument(
        "inputs", nargs="+", metavar="FILE", help="motion files (.bvh, .amc, DeepMimic .txt, .gltf/.glb)"
    )
    p.add_argument("-o", "--output", required=True, help="output .html file (never one of the inputs)")
    p.add_argument(
        "--labels", nargs="+", default=None, help="names on the page, one per file (default: file names)"
    )
    p.add_argument(
        "--reports",
        nargs="+",
        default=None,
        metavar="REPORT",
        help="JSON report of each file, in order: a path, 'auto' (look beside the file) or 'none' "
        "(default: auto for every file)",
    )
    p.add_argument(
        "--layout",
        choices=LAYOUTS,
        default=VIEWER_LAYOUT,
        help="clips side by side or overlaid on one floor, at first (the page has a switch)",
    )
    p.add_argument(
        "--contacts",
        type=_contacts,
        choices=CONTACT_MARKS,
        default=VIEWER_CONTACTS,
        help="contacts to mark: report: from the reports; detect: from the reports, else detected on "
        "the motion; off: none (also 'none')",
    )
    p.add_argument(
        "--max-frames",
        type=int,
        default=VIEWER_MAX_FRAMES,
        help="at most this many frames of a clip are shown (every n-th frame; said on the page)",
    )
    p.add_argument(
        "--max-fps",
        type=float,
        default=VIEWER_MAX_FPS,
        help="at most this many frames per second are shown (frames/s)",
    )
    p.add_argument(
        "--plotlyjs",
        choices=choices(PlotlyPlacement),
        default="inline",
        help="write plotly.js into the page (one file, about 4.8 MB) or as plotly.min.js beside it",
    )
    p.add_argument("--title", default=VIEWER_TITLE, help="title of the page")
    add_up_units_options(p)
    add_json_option(p)
    p.set_defaults(func=lambda a: run_guarded("view", run, a))


def _contacts(value: str) -> str:
    """``--contacts``: the viewer's word for ``value`` (``none`` is ``off``); an unknown word is
    left for ``choices`` to refuse."""
    return CONTACT_MARK_ALIASES.get(value, value)


def run(args: argparse.Namespace) -> int:
    """Build the page and write it; exit code 0, or 2 for bad input (no page written then)."""
    # the app is imported here, not at the top: the command line starts without loading it
    from elastic_motion.apps.report import report_header
    from elastic_motion.apps.viewer import build_viewer, plotly_js, write_viewer
    from elastic_motion.cli_commands._running import emit_report

    inputs = list(args.inputs)
    out = check_output(args.output, inputs, suffixes=(".html", ".htm"))
    if args.labels is not None and len(args.labels) != len(inputs):
        raise CommandError(f"--labels: expected {len(inputs)} labels (one per file); got {len(args.labels)}")
    reports = None
    if args.reports is not None:
        if len(args.reports) != len(inputs):
            raise CommandError(
                f"--reports: expected {len(inputs)} reports (one per file: a path, 'auto' or 'none'); "
                f"got {len(args.reports)}"
            )
        reports = [None if r == "auto" else False if r == "none" else r for r in args.reports]
        for r in reports:
            if isinstance(r, str) and not Path(r).is_file():
                raise CommandError(f"--reports: {r!r}: expected a JSON report file; got no such file")
    beside = out.with_name("plotly.min.js") if args.plotlyjs == "beside" else None
    page = build_viewer(
        inputs,
        labels=args.labels,
        reports=reports,
        layout=args.layout,
        max_frames=args.max_frames,
        max_fps=args.max_fps,
        contacts=args.contacts,
        plotly_src=beside.name if beside is not None else None,
        title=args.title,
        up=args.up,
        units=args.units,
    )
    outputs = [str(out)]
    if beside is not None:
        check_output(str(beside), inputs, what="--plotlyjs beside")
        atomic_write_text(beside, plotly_js(), protected=inputs)
        outputs.append(str(beside))
    write_viewer(page, out, protected=inputs)
    report = report_header("view", inputs, outputs, page.notes)
    report.update(page.summary())
    lines = [f"wrote {out}: {len(page.clips)} clip(s); open it in a browser (works offline)"]
    for c in page.clips:
        extra = [w for w, on in (("contacts", c.contacts), ("seam", bool(c.seams)), ("warp", c.warp)) if on]
        lines.append(
            f"  {c.label}: {c.frames} frames at {c.fps:g} fps"
            + (f", 1 frame in {c.step} shown" if c.step > 1 else "")
            + (f"; from {c.report}: {', '.join(extra)}" if c.report and extra else "")
        )
    lines += [f"note: {n}" for n in page.notes if "does not match" in n or "ignored" in n]
    emit_report(args, report, inputs, "\n".join(lines))
    return 0
