"""``elastic-motion loop IN -o OUT.bvh``: make a clip loop seamlessly (:mod:`elastic_motion.apps.loop`)."""

from __future__ import annotations

import argparse
from pathlib import Path

from elastic_motion.cli_commands._common import (
    CommandError,
    add_input_options,
    add_json_option,
    add_quiet_option,
    check_output,
    emit_report,
    fmt_float,
    load_inputs,
    run_guarded,
)

_SCALARS = (
    "seam_angle_max_deg",
    "seam_angle_mean_deg",
    "seam_angular_velocity_max_deg_s",
    "seam_position_max_m",
    "seam_position_mean_m",
    "seam_velocity_max_m_s",
    "foot_sliding_m_s",
    "foot_sliding_seam_m_s",
    "deviation_max_m",
    "deviation_mean_m",
)


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``loop`` sub-command."""
    p = subparsers.add_parser(
        "loop",
        help="make a motion loop seamlessly (closing its curve, paper 000 sec. 4)",
        description=(
            "Close the motion's curve in R^3 x SO(3)^J so that its last frame meets its first (as moved "
            "by the cycle transform): with --root travel (default) the character keeps the displacement "
            "and turn of one cycle and the clip plays on from where it ended; with --root inplace it "
            "comes back to its start. The first frame never changes."
        ),
    )
    p.add_argument("input", metavar="IN", help="motion file (.bvh, .amc, DeepMimic .txt)")
    p.add_argument("-o", "--output", required=True, help="output .bvh file: one closed cycle")
    p.add_argument(
        "--root", choices=("travel", "inplace"), default="travel", help="loop convention (default travel)"
    )
    p.add_argument("--c1", action="store_true", help="also match the velocities at the seam")
    p.add_argument(
        "--representation",
        choices=("lie", "euler"),
        default="lie",
        help="close the Lie group curve (default) or the Euler-angle curve (the baseline)",
    )
    p.add_argument(
        "--method", choices=("gauss-newton", "gradient"), default="gauss-newton", help="closing solver"
    )
    p.add_argument("--tol", type=float, default=1e-6, help="stop when the seam gap is below this")
    p.add_argument("--max-iter", type=int, default=100, help="iterations at most")
    p.add_argument(
        "--free-joints",
        default="fingers",
        help="joints left free: 'fingers' (default: finger/thumb joints), 'none', or comma-separated names",
    )
    p.add_argument(
        "--repeat",
        type=int,
        default=None,
        metavar="N",
        help="also write a preview: the looped clip played N times (OUT with .repeatN.bvh)",
    )
    p.add_argument("--preview", default=None, help="path of the preview (default OUT.repeatN.bvh)")
    add_input_options(p, several=False)
    add_json_option(p)
    add_quiet_option(p)
    p.set_defaults(func=lambda a: run_guarded("loop", run, a))


def _free(value: str):
    if value == "fingers":
        return "fingers"
    if value == "none":
        return None
    return [v.strip() for v in value.split(",") if v.strip()]


def run(args: argparse.Namespace) -> int:
    from elastic_motion.apps.loop import loop_motion, repeat_motion, seam_metrics
    from elastic_motion.apps.report import report_header
    from elastic_motion.motion import write_bvh

    inputs = [args.input]
    out = check_output(args.output, inputs, suffixes=(".bvh",))
    preview = None
    if args.repeat is not None:
        if args.repeat < 1:
            raise CommandError(f"--repeat: expected a positive number of cycles; got {args.repeat}")
        preview = Path(args.preview) if args.preview else out.with_name(f"{out.stem}.repeat{args.repeat}.bvh")
        check_output(str(preview), inputs, suffixes=(".bvh",), what="--preview")
    (motion,), notes = load_inputs(
        inputs, trims=args.trim, keep_first_frame=args.keep_first_frame, units=args.units
    )
    res = loop_motion(
        motion,
        root=args.root,
        c1=args.c1,
        representation=args.representation,
        method=args.method,
        tol=args.tol,
        max_iter=args.max_iter,
        exclude_joints=_free(args.free_joints),
    )
    write_bvh(res.motion, out)
    outputs = [str(out)]
    if preview is not None:
        write_bvh(repeat_motion(res.motion, args.repeat, args.root), preview)
        outputs.append(str(preview))
    closed = list(res.closed_joints)
    before = seam_metrics(motion, root=args.root, joints=closed)
    after = seam_metrics(res.motion, original=motion, root=args.root, joints=closed)
    c = res.closing
    report = report_header("loop", inputs, outputs, notes)
    report.update(
        {
            "root": res.root,
            "representation": res.representation,
            "c1": res.c1,
            "frames": res.motion.n_frames,
            "fps": res.motion.fps,
            "closed_joints": closed,
            "free_joints": list(res.free_joints),
            "heading_change_deg": float(res.heading_change * 180.0 / 3.141592653589793),
            "displacement": res.displacement,
            "closing": {
                "gap_initial": c.gap_initial,
                "gap": c.gap,
                "velocity_gap_initial": c.velocity_gap_initial,
                "velocity_gap": c.velocity_gap,
                "iterations": c.iterations,
                "converged": c.converged,
                "message": c.message,
                "time_s": c.time,
            },
            "seam_before": {k: before[k] for k in _SCALARS if k in before},
            "seam_after": {k: after[k] for k in _SCALARS if k in after},
        }
    )
    lines = [
        f"wrote {out}: {res.motion.n_frames} frames at {res.motion.fps:g} fps, loop ({res.root}, "
        f"{res.representation}{', C1' if res.c1 else ''})",
        f"seam: largest joint angle {fmt_float(before['seam_angle_max_deg'])} -> "
        f"{fmt_float(after['seam_angle_max_deg'])} deg, largest position jump "
        f"{fmt_float(before['seam_position_max_m'])} -> {fmt_float(after['seam_position_max_m'])} m",
        f"changed the clip by at most {fmt_float(after.get('deviation_max_m', 0.0))} m "
        f"(mean {fmt_float(after.get('deviation_mean_m', 0.0))} m); foot sliding "
        f"{fmt_float(before['foot_sliding_m_s'])} -> {fmt_float(after['foot_sliding_m_s'])} m/s",
        f"closing: {c.iterations} iterations, gap {fmt_float(c.gap_initial)} -> {fmt_float(c.gap)}"
        + ("" if c.converged else f" (not converged: {c.message})"),
    ]
    if preview is not None:
        lines.append(f"wrote {preview}: the loop played {args.repeat} times")
    lines += [f"note: {n}" for n in notes]
    emit_report(args, report, inputs, "\n".join(lines))
    return 0
