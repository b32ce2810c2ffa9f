"""``elastic-motion pca FILES -o DIR``: principal modes of aligned motions, written as BVH.

Thin wrapper over :func:`elastic_motion.apps.pca.motion_pca` and
:func:`~elastic_motion.apps.pca.write_modes`: ``mean.bvh``, ``mode<i>_minus2sd.bvh``,
``mode<i>_plus2sd.bvh``, ``sample<k>.bvh`` and ``variance.png``.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from elastic_motion.cli_commands._common import add_json_option, add_quiet_option, progress_for
from elastic_motion.cli_commands._database_options import (
    USER_ERRORS,
    add_method,
    add_preparation,
    add_warp,
    fail,
    joints_option,
)


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``pca`` sub-command."""
    p = subparsers.add_parser(
        "pca",
        help="statistical model of motions: mean and principal modes (+-2 sd) as BVH",
        description=(
            "Align the motions to their Karcher mean (warps re-centred: the mean warp is the identity), "
            "run a principal component analysis in the SRV tangent space and write into OUTPUT the mean "
            "and the mean +- SPREAD standard deviations along the first modes as BVH, random samples of "
            "the model, and the variance explained as a PNG."
        ),
    )
    p.add_argument("files", nargs="+", help="motion files of one skeleton (at least two)")
    p.add_argument("-o", "--output", required=True, help="output folder (created; required)")
    add_method(p, several=False)
    p.add_argument("--modes", type=int, default=3, help="modes written as BVH (default: 3)")
    p.add_argument(
        "--spread", type=float, default=2.0, help="standard deviations along each mode (default: 2.0)"
    )
    p.add_argument(
        "--samples-out", type=int, default=0, metavar="N", help="random motions to write (default: 0)"
    )
    p.add_argument("--seed", type=int, default=0, help="seed of the random samples (default: 0)")
    p.add_argument("--max-iter", type=int, default=20, help="Karcher iterations at most (default: 20)")
    p.add_argument(
        "--fps",
        type=float,
        default=None,
        metavar="FPS",
        help="frame rate of the output (default: the first file's)",
    )
    add_quiet_option(p)
    add_json_option(p)
    add_preparation(p)
    add_warp(p, mean=True)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Fit the model and write its files."""
    # the apps are imported here: the command line starts without loading what it does not run
    from elastic_motion.apps.database import MeanOptions
    from elastic_motion.apps.pca import motion_pca, write_modes
    from elastic_motion.apps.plots_database import plot_variance_explained
    from elastic_motion.cli_commands._database_running import emit, methods
    from elastic_motion.motion import write_bvh
    from elastic_motion.warp import WarpOptions

    bar = progress_for("pca", args)
    try:
        out = Path(args.output)
        if out.exists() and not out.is_dir():
            raise ValueError(f"--output: expected a folder; got the file {args.output!r}")
        (method,) = methods(args.method, several=False)
        options = MeanOptions(
            n_samples=args.samples,
            method=method.name,
            joints=joints_option(args.joints),
            drop_fingers=not args.keep_fingers,
            align_heading=not args.no_align,
            warp=WarpOptions(
                method=args.warp, neighbourhood=args.neighbourhood, coarse_to_fine=args.coarse_to_fine
            ),
            max_iter=args.max_iter,
            up=args.up,
            units=args.units,
            fps=args.fps,
        )
        model = motion_pca(args.files, options, progress=bar)
        paths = write_modes(model, out, n_modes=args.modes, spread=args.spread, protected=args.files)
        for k, m in enumerate(model.sample(args.samples_out, seed=args.seed)):
            paths.append(Path(write_bvh(m, out / f"sample{k + 1}.bvh", protected=args.files)))
        paths.append(
            plot_variance_explained(model.explained, out / "variance.png", title="PCA of aligned motions")
        )
    except USER_ERRORS as exc:
        return fail("pca", exc)
    finally:
        bar.close()
    body: dict[str, Any] = {**model.summary(), "files_written": [str(p) for p in paths]}
    lines = [
        f"mode {i + 1}: {100 * e:5.1f}% of the variance (cumulative {100 * c:5.1f}%), sigma {s:.4g}"
        for i, (e, c, s) in enumerate(
            zip(model.explained, body["cumulative_explained"], model.sigmas, strict=True)
        )
    ]
    if args.modes > model.n_modes:
        # say it: the user asked for more files than were written
        fewer = (
            f"--modes {args.modes}: the model has {model.n_modes} mode{'s' * (model.n_modes != 1)} "
            f"({len(args.files)} motions give at most {len(args.files) - 1}, fewer when they do not "
            f"vary independently): wrote {model.n_modes} ({2 * model.n_modes} files)"
        )
        body["modes_note"] = fewer
        lines.append(f"note: {fewer}")
    lines.append(f"{len(paths)} files -> {out}")
    emit(args, "pca", body, args.files, paths, lines)
    return 0
