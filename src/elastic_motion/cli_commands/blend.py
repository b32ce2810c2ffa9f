"""``elastic-motion blend A B [C ...] -o OUT.bvh``: blend motions (:mod:`elastic_motion.apps.blend`).

The choices are the API's vocabularies (:mod:`elastic_motion.vocabulary`); ``run`` imports the
app when the command runs (CLI start-up: building the parser loads no numpy).
"""

from __future__ import annotations

import argparse

from elastic_motion._options import choices
from elastic_motion.cli_commands._common import (
    NO_FEET,
    CommandError,
    add_contact_height_option,
    add_input_options,
    add_joint_limits_option,
    add_joint_options,
    add_json_option,
    add_landmark_options,
    add_quiet_option,
    add_warp_options,
    check_output,
    fmt_float,
    landmark_kinds,
    progress_for,
    run_guarded,
)
from elastic_motion.vocabulary import (
    CONTACT_POLICY_ALIASES,
    OUTPUT_MOTION_EXTENSIONS,
    ContactPolicy,
    ContactWarpMode,
    CurveMethod,
    SkeletonMode,
)

_INPUTS_HELP = "motion files (.bvh, .amc, DeepMimic .txt, .gltf/.glb); A first"
_OUTPUT_HELP = "output .bvh, .gltf or .glb file (never one of the inputs)"
_METHOD_HELP = (
    "euler-linear: frame-by-frame linear interpolation of Euler angles (paper 001 Fig. 5a); "
    "euler-elastic: SRV geodesic of the Euler-angle curves (Fig. 5b-d); "
    "lie: SRV geodesic in R^3 x SO(3)^J (paper 000, the default)"
)


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``blend`` sub-command."""
    p = subparsers.add_parser(
        "blend",
        help="blend two or more motions (Euler or Lie group SRV, with an optimal time warp)",
        description=(
            "Blend motions: (1-s) A + s B for two, a weighted mean after aligning all to a common "
            "template for more. B is placed like A first (heading and floor position fitted to A's "
            "root path). The root translation is a coordinate of the curve: its velocities are "
            "blended (time-aligned with a warp) and integrated from the blended start. The result "
            "plays on the blended clock (1-s) tA + s tB of the matched times, at A's frame rate."
        ),
    )
    p.add_argument("inputs", nargs="+", metavar="FILE", help=_INPUTS_HELP)
    p.add_argument("-o", "--output", required=True, help=_OUTPUT_HELP)
    p.add_argument(
        "--weight",
        type=float,
        default=None,
        help="s for two motions: the result is (1-s) A + s B (default: 0.5)",
    )
    p.add_argument(
        "--weights",
        type=float,
        nargs="+",
        default=None,
        help="one weight per input, summing to 1 (default: equal weights)",
    )
    p.add_argument("--method", choices=choices(CurveMethod), default="lie", help=_METHOD_HELP)
    add_warp_options(p)
    add_landmark_options(p)
    add_joint_options(p)
    p.add_argument(
        "--extrapolate", action="store_true", help="allow a weight outside [0, 1] (two motions only)"
    )
    p.add_argument(
        "--skeleton",
        choices=choices(SkeletonMode),
        default="blend",
        help="bone offsets of the result: weighted mean of the inputs' (default) or A's",
    )
    p.add_argument(
        "--weight-curve",
        default=None,
        metavar="KNOTS|CSV",
        help="time-varying weights, blended in SRV space: piecewise linear in the result's normalised "
        "time u in [0, 1], knots from u=0 to u=1: u:w1/w2/.../wK (one weight per motion, each knot's "
        "summing to 1, e.g. 0:1/0/0,0.5:0/1/0,1:0/0/1), or for two motions u:s (B's weight, e.g. 0:0,1:1, "
        "a transition from A into B), or a CSV file with a header u,w1,...,wK and one knot per line "
        "(default: none, the constant --weight/--weights)",
    )
    _add_contact_options(p)
    add_contact_height_option(p)
    add_joint_limits_option(p, "keep", _LIMITS_KEPT)
    p.add_argument(
        "--cycles",
        action="store_true",
        help="two motions: segment gait cycles from the foot contacts, match consecutive cycles of A "
        "and B and warp within each (steps matched one by one); falls back to the global warp, "
        "with a note, when the cycles cannot be matched (default: off)",
    )
    p.add_argument(
        "--loop",
        action="store_true",
        help="two motions: blend one matched cycle of each and close it into a seamless loop "
        "(implies --cycles; the loop command's closing, root 'travel') (default: off)",
    )
    p.add_argument(
        "--no-anchor",
        action="store_true",
        help="keep the papers' plain SRV blend: do not remove its slow drift from the aligned "
        "inputs' mean pose and root height (lie, euler-elastic; default: anchored, see the report's notes)",
    )
    p.add_argument(
        "--no-trim-ends",
        action="store_true",
        help="keep the whole clips: do not trim the output's ends where the warp holds one input still "
        "while another moves on (clips that start or stop out of phase; default: trimmed, the report "
        "says how much)",
    )
    p.add_argument(
        "--no-metrics",
        action="store_true",
        help="skip the quality metrics in the report (saves two or more DP solves)",
    )
    add_input_options(p)
    add_json_option(p)
    add_quiet_option(p)
    p.set_defaults(func=lambda a: run_guarded("blend", run, a))


def _add_contact_options(p: argparse.ArgumentParser) -> None:
    """``--contacts`` (the clean-up) and ``--contact-warp`` (the contact-guided warp)."""
    add_contacts_option(
        p,
        "the inputs' foot contacts, carried through the warp: keep (default) enforces them by leg "
        "IK (the foot-skate clean-up, bone lengths kept) when contacts are found; report only measures "
        "the blend's skating against them; off skips both (auto, the old name of keep, is still "
        "accepted)",
    )
    p.add_argument(
        "--contact-warp",
        choices=choices(ContactWarpMode),
        default="auto",
        help="two motions: warp B onto A with their heel strikes and toe-offs as landmarks (paired by "
        "phase around the plain warp): on always; auto only when the plain warp's blend has more "
        "skids than its inputs (counted on both alike) and the guided one has fewer, with d(A, B) "
        "under its warp at most 1.02 times the plain warp's (the report's notes say which was kept "
        "and why); off never. With --landmarks or --cycles (which set the landmarks) auto does nothing and "
        "on is an error (default: auto)",
    )


#: What ``--joint-limits keep`` does in a blend (its help).
_LIMITS_KEPT = (
    "the blend's last stage moves every DOF angle the inputs respect at the matched times into its "
    "range, eased over 0.15 s (the report says which joints and frames changed, by how much)"
)


def add_contacts_option(p: argparse.ArgumentParser, help_text: str) -> None:
    """``--contacts``: the contact policy of a command that blends (``blend``, ``blendspace``),
    old names accepted (:func:`contacts_flag`), default ``keep``; ``help_text`` says what it does
    there."""
    p.add_argument(
        "--contacts", type=contacts_flag, choices=choices(ContactPolicy), default="keep", help=help_text
    )


def contacts_flag(value: str) -> str:
    """``--contacts``: a contact policy, its old names (``auto`` for ``keep``) accepted; other
    words are left for argparse to refuse with the choices."""
    return CONTACT_POLICY_ALIASES.get(value, value)


def run(args: argparse.Namespace) -> int:
    """Blend ``args.inputs`` into ``args.output``; exit code 0, or 2 for bad input."""
    # the app is imported here, not at the top: the command line starts without loading it
    from elastic_motion.apps.blend import BlendOptions, blend_motions
    from elastic_motion.apps.report import report_header
    from elastic_motion.cli_commands._running import (
        contact_options,
        emit_report,
        prepare_inputs,
        read_landmarks,
        warp_options,
        write_motion,
    )

    inputs = list(args.inputs)
    if len(inputs) < 2:
        raise CommandError(f"FILE: expected at least two input motions; got {len(inputs)}")
    out = check_output(args.output, inputs, suffixes=OUTPUT_MOTION_EXTENSIONS)
    if args.weight is not None and args.weights is not None:
        raise CommandError("--weight: expected --weight (two motions) or --weights, not both")
    if args.weight_curve is not None and (args.weight is not None or args.weights is not None):
        raise CommandError("--weight-curve: expected --weight-curve or --weight/--weights, not both")
    weights = args.weight if args.weight is not None else args.weights
    if args.weight is not None and len(inputs) != 2:
        raise CommandError(
            f"--weight: expected two motions for s; got {len(inputs)}: use --weights w1 ... w{len(inputs)}"
        )
    prep = prepare_inputs(args, inputs)
    fps = [r.fps for r in prep.inputs]
    landmarks, file_weight = read_landmarks(args.landmarks, args.landmark_units, fps[0], fps[1], inputs)
    options = BlendOptions(
        method=args.method,
        warp=warp_options(args, file_weight),
        landmarks=landmarks,
        landmark_kinds=landmark_kinds(args.landmark_kinds),
        max_pairs=args.max_pairs,
        extrapolate=args.extrapolate,
        skeleton=args.skeleton,
        weight_curve=args.weight_curve,
        anchor=not args.no_anchor,
        trim_ends=not args.no_trim_ends,
        contacts=args.contacts,
        contact_options=contact_options(args),
        cycles=args.cycles,
        loop=args.loop,
        metrics=not args.no_metrics,
        joint_limits=args.joint_limits,
        contact_warp=args.contact_warp,
    )
    bar = progress_for("blend", args)
    try:
        res = blend_motions(prep, weights, options, progress=bar)
    finally:
        bar.close()
    notes = [*res.notes, *write_motion(res.motion, res.prepared, out, inputs)]
    report = report_header("blend", inputs, [str(out)], [str(n) for n in notes])
    report.update({**res.summary(), "notes": [str(n) for n in notes]})
    emit_report(args, report, [*inputs, str(out)], _summary(res, out, notes))
    return 0


def _summary(res, out, notes) -> str:
    m = res.motion
    lines = [
        f"wrote {out}: {m.n_frames} frames at {m.fps:g} fps ({m.duration:.2f} s), {m.n_joints} joints",
        f"method {res.method}, warp {res.warp}, "
        + (
            "weights "
            + ", ".join(f"{lab} {w:.3g}" for lab, w in zip(res.prepared.labels, res.weights, strict=True))
            if res.weight_curve is None
            else _weight_curve_line(res.weight_curve, res.weights, res.prepared.labels)
        ),
    ]
    if res.landmarks:
        lines.append("landmarks (s): " + ", ".join(f"{a:.2f}:{b:.2f}" for a, b in res.landmarks))
    if res.cleanup is not None and res.cleanup.applied:
        c = res.cleanup
        lines.append(
            f"clean-up: skating while in contact {fmt_float(c.skating_before.mean_speed)} -> "
            f"{fmt_float(c.skating_after.mean_speed)} m/s, below the floor "
            f"{fmt_float(c.skating_before.below_floor)} -> {fmt_float(c.skating_after.below_floor)} m; "
            f"largest change {fmt_float(c.max_position_change)} m, "
            f"{fmt_float(c.max_rotation_change_deg)} deg"
        )
    met = res.metrics.summary() if res.metrics is not None else None
    if met:
        fs = met["foot_sliding"]
        if not fs["result"]["joints"]:
            lines.append(f"foot sliding and feet: {NO_FEET}")
        else:
            lines.append(
                "foot sliding (m/s): result "
                + fmt_float(fs["result"]["mean_speed_m_s"])
                + ", inputs "
                + ", ".join(fmt_float(x["mean_speed_m_s"]) for x in fs["inputs"])
            )
        if met.get("feet") and fs["result"]["joints"]:
            ft = met["feet"]
            lines.append(
                "feet, measured like the inputs (own contacts): skating "
                + fmt_float(ft["result"]["skating_m_s"])
                + " m/s (inputs "
                + ", ".join(fmt_float(x["skating_m_s"]) for x in ft["inputs"])
                + f"), skids {ft['result']['skid_count']} (inputs "
                + ", ".join(str(x["skid_count"]) for x in ft["inputs"])
                + "), below the floor "
                + fmt_float(ft["result"]["below_floor_m"])
                + " m"
            )
        d = met["distances"]
        lines.append(
            "elastic distance (Lie): result to inputs "
            + ", ".join(fmt_float(x) for x in d["result_to_inputs"])
            + (f"; between A and B {fmt_float(d['between_inputs'][0][1])}" if len(d["labels"]) == 2 else "")
        )
        lines.append(
            "bone-length error: max "
            + fmt_float(met["bone_length_error"]["result"]["max_relative"])
            + " (relative, result against its own skeleton)"
        )
    lines += [f"note: {n}" for n in notes]
    return "\n".join(lines)


def _weight_curve_line(knots, weights, labels) -> str:
    """The report's line of a weight curve: B's weight ``(u, s)`` or every motion's."""
    if knots.shape[1] == 2:
        return (
            f"weight of {labels[1]} by normalised time: "
            + ", ".join(f"{u:g}:{w:g}" for u, w in knots)
            + f" (mean {weights[1]:.3g})"
        )
    return (
        "weights of "
        + "/".join(labels)
        + " by normalised time: "
        + ", ".join(f"{r[0]:g}:" + "/".join(f"{x:g}" for x in r[1:]) for r in knots)
        + " (mean "
        + "/".join(f"{x:.3g}" for x in weights)
        + ")"
    )
