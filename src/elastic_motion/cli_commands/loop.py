"""``elastic-motion loop IN -o OUT.bvh``: make a clip loop seamlessly (:mod:`elastic_motion.apps.loop`).

The allowed values of every option are the types of
:class:`~elastic_motion.apps.loop.LoopOptions` (never re-typed: :mod:`elastic_motion.vocabulary`),
the defaults its defaults (:mod:`elastic_motion.defaults`), and the arguments become one
``LoopOptions``. ``run`` imports the loop app when the command runs (CLI start-up: building the
parser loads no numpy).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from elastic_motion._options import choices
from elastic_motion.cli_commands._argparse import add_alias
from elastic_motion.cli_commands._common import (
    NO_FEET,
    CommandError,
    add_contact_height_option,
    add_input_options,
    add_joint_limits_option,
    add_json_option,
    add_quiet_option,
    check_output,
    fmt_float,
    non_negative_float,
    positive_float,
    progress_for,
    run_guarded,
)
from elastic_motion.defaults import (
    LOOP_CHANGE_BOUND,
    LOOP_FREE_JOINTS,
    LOOP_JOINT_LIMITS,
    LOOP_MAX_ITER,
    LOOP_METHOD,
    LOOP_ROOT,
    LOOP_SEAM,
    LOOP_SOLVER,
    LOOP_TOL,
    LOOP_WINDOW,
)
from elastic_motion.vocabulary import (
    METHOD_ALIASES,
    OUTPUT_MOTION_EXTENSIONS,
    ContactPolicy,
    Method,
    RootMode,
    Seam,
    Solver,
    WindowMode,
)


def _representation(value: str) -> str:
    # the old --representation said "euler" for what --method calls "euler-elastic"; other
    # words are left for argparse to refuse with the choices
    return METHOD_ALIASES.get(value, value)


def _method(value: str) -> str:
    if value in ("gauss-newton", "gradient"):  # --method named the solver before 0.2
        raise argparse.ArgumentTypeError(
            f"expected 'lie' or 'euler-elastic' (the curve that is closed); got {value!r}: "
            "the closing solver is --solver now"
        )
    return value


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
    p.add_argument("input", metavar="IN", help="motion file (.bvh, .amc, DeepMimic .txt, .gltf/.glb)")
    p.add_argument("-o", "--output", required=True, help="output .bvh, .gltf or .glb file: one closed cycle")
    _add_closing_options(p)
    _add_window_and_contact_options(p)
    _add_stopping_options(p)
    p.add_argument(
        "--repeat",
        type=int,
        default=None,
        metavar="N",
        help="also write a preview: the looped clip played N times (default: no preview)",
    )
    p.add_argument(
        "--preview", default=None, help="path of the preview (default: OUT.repeatN.bvh, or .gltf/.glb as OUT)"
    )
    add_input_options(p, several=False)
    add_json_option(p)
    add_quiet_option(p)
    p.set_defaults(func=lambda a: run_guarded("loop", run, a))


def _add_closing_options(p: argparse.ArgumentParser) -> None:
    """The loop convention, the seam, the curve and the solver."""
    p.add_argument(
        "--root",
        choices=choices(RootMode),
        default=LOOP_ROOT,
        help="loop convention: keep one cycle's displacement and turn, or come back to the start",
    )
    p.add_argument(
        "--seam",
        choices=choices(Seam),
        default=LOOP_SEAM,
        help="what closes at the seam: 'c0' the poses (paper 000), 'c1' the velocities too, "
        "'auto' C0 unless its seam has a hitch (a velocity jump above 1.5x the clip's own quick "
        "changes), then C1 when that is smoother without skating or changing the clip more (a note "
        "says which)",
    )
    p.add_argument("--c1", dest="seam", action="store_const", const="c1", help="the same as --seam c1")
    p.add_argument(
        "--method",
        type=_method,
        choices=choices(Method),
        default=LOOP_METHOD,
        help="close the Lie group curve or the Euler-angle curve (the baseline of paper 001)",
    )
    add_alias(p, "--representation", "--method", convert=_representation)
    p.add_argument(
        "--solver",
        choices=choices(Solver),
        default=LOOP_SOLVER,
        help="closing solver: 'kkt' the closed curve nearest the input in SRV L2 (a KKT point of the "
        "projection); 'gauss-newton' / 'gradient' the closing flows (closed, nearest only to first order)",
    )


def _add_window_and_contact_options(p: argparse.ArgumentParser) -> None:
    """Which frames loop, and what the loop does with contacts and joint limits."""
    p.add_argument(
        "--window",
        choices=choices(WindowMode),
        default=LOOP_WINDOW,
        help="'safe': the whole clip when its loop changes it by at most --change-bound, else the best "
        "sub-clip (the first line of the output says which and why); 'whole': the whole clip; 'auto': "
        "the sub-clip (start and end frame) that closes with the least change (the whole clip is closed "
        "too, for the report)",
    )
    p.add_argument(
        "--change-bound",
        type=positive_float,
        default=LOOP_CHANGE_BOUND,
        metavar="METRES",
        help="the most the loop may move a joint relative to the root; a loop that changes the clip more, "
        "or whose feet slide along the floor more often than the input's, is refused (exit 2) unless "
        "--force",
    )
    p.add_argument(
        "--force",
        action="store_true",
        help="keep a loop that changes the clip by more than --change-bound or adds foot slides (default: "
        "refused, with the numbers and the window that closes with the least change)",
    )
    p.add_argument(
        "--min-length",
        type=float,
        default=None,
        metavar="SECONDS",
        help="shortest window for --window auto (and safe), seconds (default: 90%% of the clip's period, "
        "or half "
        "the clip when it does not repeat)",
    )
    p.add_argument(
        "--contacts",
        choices=choices(ContactPolicy),
        default=None,  # LoopOptions.contacts: keep with --method lie and --solver kkt, else report
        help="'keep' (default with --method lie and --solver kkt): plant the input's foot/toe/hand "
        "contacts, as constraints of the same projection on a 30 fps grid (with --root inplace on a "
        "treadmill: the clip's travel removed at a constant rate, the planted feet move back with it); "
        "contacts that conflict with closing are released and named; 'report' (the default otherwise): "
        "detect them and "
        "report skating and depth below the floor of input and loop during them; 'off': skip",
    )
    add_contact_height_option(p)
    add_joint_limits_option(
        p,
        LOOP_JOINT_LIMITS,
        "the loop stays within every limit the input respects (DOFs pinned at their limit in the same "
        "projection; 16-110 s on CMU clips)",
    )


def _add_stopping_options(p: argparse.ArgumentParser) -> None:
    """The closing solver's stopping rule, and the joints left free."""
    p.add_argument(
        "--tol",
        type=non_negative_float,
        default=LOOP_TOL,
        help="stop when the seam gap is below this (radians for joint rotations; the weighted norm "
        "of the closing residual)",
    )
    p.add_argument(
        "--max-iter", type=int, default=LOOP_MAX_ITER, help="iterations of the closing solver at most"
    )
    p.add_argument(
        "--free-joints",
        default=LOOP_FREE_JOINTS,
        help="joints left free: 'fingers' (finger/thumb joints), 'none', or comma-separated names",
    )


def _free(value: str):
    if value == "fingers":
        return "fingers"
    if value == "none":
        return None
    return [v.strip() for v in value.split(",") if v.strip()]


def _fields(args: argparse.Namespace) -> dict[str, Any]:
    """The arguments as the fields of one :class:`~elastic_motion.apps.loop.LoopOptions`, but
    ``contact_options`` (``--contact-height``, made in ``run``)."""
    return dict(
        root=args.root,
        seam=args.seam,
        method=args.method,
        solver=args.solver,
        tol=args.tol,
        max_iter=args.max_iter,
        free_joints=_free(args.free_joints),
        window=args.window,
        min_length=args.min_length,
        change_bound=args.change_bound,
        force=args.force,
        contacts=args.contacts,
        joint_limits=args.joint_limits,
    )


def run(args: argparse.Namespace) -> int:
    # the app is imported here, not at the top: the command line starts without loading it
    from elastic_motion.apps.loop import LoopOptions, loop_motion, repeat_loop
    from elastic_motion.apps.loop.window import WINDOW_CHOICE
    from elastic_motion.apps.report import report_header
    from elastic_motion.cli_commands._running import (
        contact_options,
        emit_report,
        prepare_inputs,
        write_motion,
    )

    inputs = [args.input]
    out = check_output(args.output, inputs, suffixes=OUTPUT_MOTION_EXTENSIONS)
    preview = None
    if args.repeat is not None:
        if args.repeat < 1:
            raise CommandError(f"--repeat: expected a positive number of cycles; got {args.repeat}")
        preview = (
            Path(args.preview)
            if args.preview
            else out.with_name(f"{out.stem}.repeat{args.repeat}{out.suffix}")
        )
        check_output(str(preview), [*inputs, str(out)], suffixes=OUTPUT_MOTION_EXTENSIONS, what="--preview")
    bar = progress_for("loop", args)
    try:
        prepared = prepare_inputs(args, inputs)
        options = LoopOptions(**_fields(args), contact_options=contact_options(args))
        res = loop_motion(prepared, options, progress=bar)
    finally:
        bar.close()
    notes = [*res.notes, *write_motion(res.motion, res.prepared, out, inputs)]
    outputs = [str(out)]
    if preview is not None:
        write_motion(repeat_loop(res, args.repeat, args.root), res.prepared, preview, inputs)
        outputs.append(str(preview))
    report = report_header("loop", inputs, outputs, notes)
    report.update({**res.summary(), "notes": [str(n) for n in notes]})
    lines = _lines(res, out, WINDOW_CHOICE)
    if preview is not None:
        lines.append(f"wrote {preview}: the loop played {args.repeat} times")
    lines += [f"note: {n}" for n in notes if n.kind != WINDOW_CHOICE]
    emit_report(args, report, [*inputs, *outputs], "\n".join(lines))
    return 0


def _lines(res, out: Path, choice_kind: str) -> list[str]:
    """What the command prints: the window chosen and why first (the note of ``choice_kind``),
    then the headline numbers."""
    before, after, c = res.seam_before, res.seam_after, res.closing
    choice = [str(n) for n in res.notes if n.kind == choice_kind]
    lines = [
        *choice,
        f"wrote {out}: {res.motion.n_frames} frames at {res.motion.fps:g} fps, loop ({res.root}, "
        f"{res.method}{', C1' if res.c1 else ''}); its last frame is its first pose moved by the cycle: "
        "a player drops it when it repeats the clip",
        f"seam: largest joint angle {fmt_float(before.seam_angle_max_deg)} -> "
        f"{fmt_float(after.seam_angle_max_deg)} deg, largest position jump "
        f"{fmt_float(before.seam_position_max_m)} -> {fmt_float(after.seam_position_max_m)} m, "
        f"velocity jump {fmt_float(after.seam_velocity_jump_ratio)}x the clip's quickest changes; "
        + _around_the_seam(after),
        f"changed the clip by at most {fmt_float(res.change_m)} m relative to the root "
        f"(positions: at most {fmt_float(after.deviation_max_m or 0.0)} m, mean "
        f"{fmt_float(after.deviation_mean_m or 0.0)} m)",
        f"closing: {c.iterations} iterations, gap {fmt_float(c.gap_initial)} -> {fmt_float(c.gap)}"
        + ("" if c.converged else f" (not converged: {c.message})"),
    ]
    if res.window is not None:
        w = res.window
        whole = w.whole.get("deviation_max_m")
        lines.append(
            f"window: frames {w.start}..{w.stop - 1} ({w.start / w.fps:.3f}-{(w.stop - 1) / w.fps:.3f} s, "
            f"{w.length:.3f} s) changes at most {fmt_float(w.deviation_max_m)} m"
            + (f" (whole clip: {fmt_float(whole)} m)" if whole is not None else "")
        )
    lines += _contact_lines(res)
    free = res.summary()["free_joints_seam_deg"]
    if free:
        worst = max(free, key=free.get)
        lines.append(
            f"free joints (not closed): {len(free)}, the largest seam jump {fmt_float(free[worst])} deg "
            f"({worst}); "
            "--free-joints none closes them"
        )
    return lines


def _around_the_seam(after) -> str:
    """The seam's whip (:class:`~elastic_motion.apps.metrics.SeamMetrics`), or that nothing moves
    around it (both ratios 0: no ratio and no worst point to name)."""
    if after.seam_acceleration_ratio == 0 and after.seam_speed_ratio == 0:
        return "around the seam (0.3 s each side): n/a, no point moves there"
    return (
        f"around the seam (0.3 s each side) acceleration {fmt_float(after.seam_acceleration_ratio)}x "
        f"and speed {fmt_float(after.seam_speed_ratio)}x the clip's own (worst at "
        f"{after.seam_acceleration_point})"
    )


def _contact_lines(res) -> list[str]:
    """The contacts' and feet's lines, and the joint limits'."""
    lines = []
    if res.skating_before is not None and res.skating_after is not None and res.contacts.any:
        belt = res.skating_on_treadmill
        belt = "" if belt is None else f"; on the treadmill (its motion out) {fmt_float(belt.mean_speed)} m/s"
        lines.append(
            f"contacts: skating {fmt_float(res.skating_before.mean_speed)} -> "
            f"{fmt_float(res.skating_after.mean_speed)} m/s, below the floor "
            f"{fmt_float(res.skating_before.below_floor)} -> {fmt_float(res.skating_after.below_floor)} m"
            + belt
        )
    if res.feet_before is not None and not res.feet_before.has_feet:
        lines.append(f"feet: {NO_FEET}")
    elif res.feet_before is not None and res.feet_after is not None:
        lines.append(
            f"feet, measured on each: skids {res.feet_before.skid_count} -> {res.feet_after.skid_count}, "
            f"skating over their own contacts {fmt_float(res.feet_before.skating.mean_speed)} -> "
            f"{fmt_float(res.feet_after.skating.mean_speed)} m/s"
        )
    if res.joint_limits is not None:
        jl = res.joint_limits
        lines.append(
            f"joint limits ({jl.mode}): input beyond {len(jl.before.violations)} dof limits, loop beyond "
            f"{len(jl.after.violations)}; {len(jl.new_violations)} newly crossed; {jl.pinned} frames pinned"
        )
    return lines
